//! The training schedule: every configured identity is trained.

use splatzoo_nlf_gs::trainer::identity_at;
use std::collections::BTreeSet;

#[test]
fn every_configured_identity_is_trained_once_per_round() {
    // 14 shares a factor with the old stride of 7 (which trained only identities 0 and 7).
    for n in [1, 2, 7, 12, 14, 21] {
        for round in 0..3 {
            let seen: BTreeSet<usize> = (round * n + 1..=(round + 1) * n)
                .map(|step| identity_at(step, n))
                .collect();
            assert_eq!(seen, (0..n).collect(), "{n} identities, round {round}");
        }
    }
}
