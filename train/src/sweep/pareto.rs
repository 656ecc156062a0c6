//! Pareto fronts: the points no other point beats on both axes at once.

/// Which way an axis improves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Better {
    Higher,
    Lower,
}

impl Better {
    /// `a` is at least as good as `b`.
    fn at_least(self, a: f64, b: f64) -> bool {
        match self {
            Self::Higher => a >= b,
            Self::Lower => a <= b,
        }
    }
}

/// Whether each point of `points` (`[x, y]`) is on the Pareto front for the directions
/// `better`: no other point is at least as good on both axes and different on one. A point
/// with a non-finite coordinate is never on the front and never dominates. Ties (identical
/// points) are all on the front.
pub fn front(points: &[[f64; 2]], better: [Better; 2]) -> Vec<bool> {
    let finite = |p: &[f64; 2]| p.iter().all(|v| v.is_finite());
    points
        .iter()
        .map(|p| {
            finite(p)
                && !points.iter().any(|q| {
                    finite(q)
                        && q != p
                        && better[0].at_least(q[0], p[0])
                        && better[1].at_least(q[1], p[1])
                })
        })
        .collect()
}
