//! drivestudio's LiDAR files (`lidar/{t:03}.bin`) read into the re-centred world, and bad ones
//! named.

use splatzoo_datasets::fixtures::drivestudio_fixture;
use splatzoo_datasets::formats::drivestudio::lidar;

/// The fixture's wall: returns at x = 11.5 m in each frame's ego frame, y ∈ {−1, 0, 1},
/// z ∈ {0.5, 1.6, 2.5}.
fn wall(x: f64) -> Vec<[f64; 3]> {
    [-1.0, 0.0, 1.0]
        .into_iter()
        .flat_map(|y| [0.5, 1.6, 2.5].map(|z| [x, y, z]))
        .collect()
}

fn assert_points(got: &[[f64; 3]], want: &[[f64; 3]]) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        assert!(
            (0..3).all(|i| (g[i] - w[i]).abs() < 1e-5),
            "{g:?} against {w:?}"
        );
    }
}

#[test]
fn lidar_returns_land_in_the_recentred_world() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    drivestudio_fixture(root, true);
    let frames = lidar(root).unwrap();
    assert_eq!(frames.len(), 2);
    // Frame 0 is the world's origin; in frame 1 the ego is 2 m further along its heading.
    assert_points(frames[0].as_ref().unwrap(), &wall(11.5));
    assert_points(frames[1].as_ref().unwrap(), &wall(13.5));
    std::fs::remove_file(root.join("lidar/001.bin")).unwrap();
    let frames = lidar(root).unwrap();
    assert!(frames[0].is_some() && frames[1].is_none());
}

#[test]
fn bad_lidar_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    drivestudio_fixture(root, true);
    std::fs::write(root.join("lidar/001.bin"), [0u8; 4 * 13]).unwrap();
    let e = lidar(root).unwrap_err().to_string();
    assert!(
        e.contains("lidar/001.bin") && e.contains("52 bytes") && e.contains("14 values"),
        "{e}"
    );
    let mut row = [0.0f32; 14];
    row[4] = f32::NAN;
    let bytes: Vec<u8> = [[0.0f32; 14], row]
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(root.join("lidar/000.bin"), bytes).unwrap();
    let e = lidar(root).unwrap_err().to_string();
    assert!(
        e.contains("lidar/000.bin") && e.contains("row 1") && e.contains("non-finite"),
        "{e}"
    );
}
