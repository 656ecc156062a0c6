//! Environment maps for relighting: a constant map projects to the probes' unit-radiance DC
//! and nothing else (read back from a Radiance `.hdr` the test writes), the sun lands in the
//! first band along its direction and turns with the map, and bad files are named.

use image::Rgb;
use image::codecs::hdr::HdrEncoder;
use splatzoo_illum::IllumError;
use splatzoo_illum::environment::{EquirectMap, Sky, direction_of, rotate_about_up};

/// The first band's vector `(x, y, z)` from SH coefficients 1..4 (real SH: `Y_1,-1 ∝ y`,
/// `Y_1,0 ∝ z`, `Y_1,1 ∝ x`, INRIA's signs: `−C1 y, C1 z, −C1 x`).
fn dipole(sh: &[[f64; 3]], c: usize) -> [f64; 3] {
    [-sh[3][c], -sh[1][c], sh[2][c]]
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

#[test]
fn a_constant_hdr_map_is_the_unit_radiance_of_the_probes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey.hdr");
    let (w, h) = (64, 32);
    let texels = vec![Rgb([0.5f32, 1.0, 2.0]); w * h];
    HdrEncoder::new(std::fs::File::create(&path).unwrap())
        .encode(&texels, w, h)
        .unwrap();
    let map = EquirectMap::read_hdr(&path).unwrap();
    assert_eq!((map.width, map.height), (w, h));
    let sh = map.project(2, 37.0);
    let dc = (4.0 * std::f64::consts::PI).sqrt();
    for (c, radiance) in [0.5, 1.0, 2.0].into_iter().enumerate() {
        // Radiance .hdr stores an 8-bit mantissa: 1 % is its precision.
        assert!(
            (sh[0][c] / (radiance * dc) - 1.0).abs() < 1e-2,
            "DC {} for radiance {radiance}",
            sh[0][c]
        );
        // Higher bands vanish up to the row-centre quadrature of 32 rows (≈ 5e-4 of the DC).
        for (k, coefficient) in sh.iter().enumerate().skip(1) {
            assert!(
                coefficient[c].abs() < 1e-3 * sh[0][c],
                "band coefficient {k}: {coefficient:?}"
            );
        }
    }

    std::fs::write(dir.path().join("junk.hdr"), b"not an image").unwrap();
    let error = EquirectMap::read_hdr(&dir.path().join("junk.hdr")).unwrap_err();
    assert!(matches!(error, IllumError::Input { .. }));
    assert!(error.to_string().contains("junk.hdr"), "{error}");
    let error = EquirectMap::read_hdr(&dir.path().join("missing.hdr")).unwrap_err();
    assert!(error.to_string().contains("missing.hdr"), "{error}");
}

#[test]
fn the_sun_points_the_first_band_at_itself_and_turns_with_the_map() {
    let sky = Sky {
        zenith: [0.0; 3],
        horizon: [0.0; 3],
        ground: [0.0; 3],
        sun_elevation: 25.0,
        sun_azimuth: -70.0,
        sun: [3.0; 3],
    };
    let sun = direction_of(25.0, -70.0);
    for rotation in [0.0, 90.0, 200.0] {
        let sh = sky.project(2, rotation);
        let lobe = unit(dipole(&sh, 0));
        let expected = rotate_about_up(sun, rotation);
        let cosine: f64 = (0..3).map(|a| lobe[a] * expected[a]).sum();
        assert!(
            cosine > 0.9999,
            "rotation {rotation}: lobe {lobe:?} vs sun {expected:?}"
        );
        // A delta of irradiance E has DC E·Y_0.
        assert!((sh[0][0] - 3.0 * 0.282_094_791_773_878_14).abs() < 1e-9);
    }
    // The default sky is brighter from above: its first band points up.
    let sky = Sky {
        sun: [0.0; 3],
        ..Sky::default()
    };
    let lobe = unit(dipole(&sky.project(1, 0.0), 2));
    assert!(lobe[1] > 0.9, "sky lobe {lobe:?}");
}
