//! OpenPose keypoint JSON: a written person reads back; a folder of frames lists in name
//! order; other body layouts and malformed files are named in the error.

use splatzoo_datasets::openpose::{
    BODY_25, PersonKeypoints, keypoint_files, read_keypoints, read_main_person, write_keypoints,
};

fn person(shift: f32) -> PersonKeypoints {
    let points = |n: usize| -> Vec<[f32; 3]> {
        (0..n)
            .map(|i| [i as f32 + shift, 2.0 * i as f32, 0.5 + shift / 100.0])
            .collect()
    };
    PersonKeypoints {
        body: points(BODY_25.len()),
        face: points(70),
        left_hand: points(21),
        right_hand: Vec::new(),
    }
}

#[test]
fn keypoints_round_trip_and_frames_list_in_order() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (k, name) in ["frame_0002", "frame_0000", "frame_0001"]
        .iter()
        .enumerate()
    {
        write_keypoints(
            &dir.path().join(format!("{name}_keypoints.json")),
            &person(k as f32),
        )
        .expect("written");
    }
    std::fs::write(dir.path().join("notes.txt"), "not a frame").expect("written");
    let files = keypoint_files(dir.path()).expect("listed");
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "frame_0000_keypoints.json",
            "frame_0001_keypoints.json",
            "frame_0002_keypoints.json"
        ]
    );
    let people = read_keypoints(&files[0]).expect("read");
    assert_eq!(people, vec![person(1.0)]);
    let main = read_main_person(&files[2])
        .expect("read")
        .expect("one person");
    assert_eq!(main.body.len(), 25);
    assert!(main.right_hand.is_empty());
}

#[test]
fn other_layouts_and_broken_files_are_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let coco = dir.path().join("coco.json");
    let values: Vec<String> = (0..54).map(|i| format!("{i}.0")).collect();
    std::fs::write(
        &coco,
        format!(
            "{{\"people\": [{{\"pose_keypoints_2d\": [{}]}}]}}",
            values.join(",")
        ),
    )
    .expect("written");
    let message = read_keypoints(&coco).expect_err("COCO-18").to_string();
    assert!(
        message.contains("coco.json") && message.contains("COCO-18") && message.contains("75"),
        "{message}"
    );
    let face = dir.path().join("face.json");
    std::fs::write(
        &face,
        format!(
            "{{\"people\": [{{\"pose_keypoints_2d\": [{}], \"face_keypoints_2d\": [1, 2, 3]}}]}}",
            vec!["0"; 75].join(",")
        ),
    )
    .expect("written");
    let message = read_keypoints(&face).expect_err("a short face").to_string();
    assert!(message.contains("people[0].face_keypoints_2d"), "{message}");
    let broken = dir.path().join("broken.json");
    std::fs::write(&broken, "{\"persons\": []}").expect("written");
    let message = read_keypoints(&broken).expect_err("no people").to_string();
    assert!(
        message.contains("broken.json") && message.contains("OpenPose"),
        "{message}"
    );
    let empty = tempfile::tempdir().expect("temp dir");
    assert!(keypoint_files(empty.path()).is_err());
}
