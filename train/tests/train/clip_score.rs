//! The CLIP score with a user's image encoder: a small random convolutional encoder exported to
//! ONNX stands in for CLIP's; the score equals the cosine the same encoder gives in Burn on the
//! preprocessed image, is 100 against the image's own embedding and 0 against its opposite;
//! the preprocessing resizes and normalises as documented; bad files are refused by name.

use burn::tensor::{Device, Distribution, Tensor, TensorData};
use splatzoo_train::checkpoint::Checkpoint;
use splatzoo_train::clip_score::fixture::{TinyImageEncoder, write_tiny_clip};
use splatzoo_train::clip_score::{ClipConfig, ClipScorer, TEXT_EMBEDDING};
use splatzoo_train::host_f32;
use std::path::{Path, PathBuf};

const SIZE: usize = 16;
const DIM: usize = 8;

fn write_embedding(path: &Path, values: &[f32], shape: &[usize]) {
    let mut file = Checkpoint::default();
    file.tensors
        .insert(TEXT_EMBEDDING.into(), (shape.to_vec(), values.to_vec()));
    file.write(path).unwrap();
}

/// The fixture's CLIP in `dir` with the text embedding `text`.
fn setup(dir: &Path, text: &[f32]) -> (PathBuf, TinyImageEncoder) {
    write_tiny_clip(dir, SIZE, text, &Device::flex()).unwrap()
}

fn cosine(a: &[f32], b: &[f32]) -> f64 {
    let dot: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| f64::from(*x) * f64::from(*y))
        .sum();
    let norm = |v: &[f32]| v.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt();
    dot / (norm(a) * norm(b))
}

#[test]
fn the_score_is_the_encoders_cosine_to_the_prompt() {
    let device = Device::flex();
    let text: Vec<f32> = (0..DIM).map(|k| (k as f32 * 0.7).sin() + 0.3).collect();
    let dir = tempfile::tempdir().unwrap();
    let (toml, encoder) = setup(dir.path(), &text);
    let scorer = ClipScorer::load(&toml).unwrap();
    assert_eq!(scorer.dimension(), DIM);

    // An image of another size, resized by the scorer; Burn runs the encoder on the same input.
    let image = Tensor::<3>::random([24, 20, 3], Distribution::Uniform(0.0, 1.0), &device);
    let planar = scorer.preprocess(&host_f32(&image), 24, 20);
    let input =
        Tensor::<4>::from_data(TensorData::new(planar.clone(), [1, 3, SIZE, SIZE]), &device);
    let reference = host_f32(&encoder.forward(input));
    let expected = 100.0 * cosine(&reference, &text).max(0.0);
    let got = scorer.score(image).unwrap();
    assert!((got - expected).abs() < 1e-3, "{got} against {expected}");
    assert!((0.0..=100.0).contains(&got));

    // Against the image's own embedding the score is 100, against its opposite 0 (clamped).
    for (sign, want) in [(1.0f32, 100.0), (-1.0, 0.0)] {
        let own: Vec<f32> = reference.iter().map(|v| sign * v).collect();
        let dir = tempfile::tempdir().unwrap();
        write_embedding(&dir.path().join("own.safetensors"), &own, &[1, DIM]);
        let config = ClipConfig {
            text_embedding: dir.path().join("own.safetensors"),
            ..scorer.config.clone()
        };
        let graph_dir = toml.parent().unwrap();
        let own_scorer = ClipScorer::with_config(config, graph_dir).unwrap();
        let embedding = own_scorer.image_embedding(&planar).unwrap();
        let score = 100.0 * cosine(&embedding, &own).max(0.0);
        assert!((score - want).abs() < 1e-3, "sign {sign}: {score}");
    }
}

#[test]
fn preprocessing_resizes_and_normalises_as_clip_does() {
    let dir = tempfile::tempdir().unwrap();
    let scorer = ClipScorer::load(&setup(dir.path(), &[1.0; DIM]).0).unwrap();
    let (mean, std) = (scorer.config.mean, scorer.config.std);
    // A constant image: every value is (v − mean) / std of its channel, planar.
    let constant = vec![0.25f32; 5 * 7 * 3];
    let planar = scorer.preprocess(&constant, 5, 7);
    assert_eq!(planar.len(), 3 * SIZE * SIZE);
    for c in 0..3 {
        let want = (0.25 - mean[c]) / std[c];
        assert!(
            planar[c * SIZE * SIZE..(c + 1) * SIZE * SIZE]
                .iter()
                .all(|v| (v - want).abs() < 1e-6)
        );
    }
    // At the encoder's own size the resize is the identity.
    let image: Vec<f32> = (0..SIZE * SIZE * 3)
        .map(|i| (i % 97) as f32 / 97.0)
        .collect();
    let planar = scorer.preprocess(&image, SIZE, SIZE);
    for (i, pixel) in image.chunks(3).enumerate() {
        for c in 0..3 {
            let back = planar[c * SIZE * SIZE + i] * std[c] + mean[c];
            assert!((back - pixel[c]).abs() < 1e-5);
        }
    }
}

#[test]
fn bad_files_are_refused_by_name() {
    let device = Device::flex();
    let dir = tempfile::tempdir().unwrap();
    let (toml, _) = setup(dir.path(), &[1.0; DIM]);
    let prompt = dir.path().join("prompt.safetensors");
    let error = |expected: &str| {
        let e = ClipScorer::load(&toml).expect_err("refused").to_string();
        assert!(e.contains(expected), "{e} lacks {expected}");
    };
    write_embedding(&prompt, &[1.0; DIM - 3], &[DIM - 3]);
    error("the text embedding has 5 values");
    write_embedding(&prompt, &[1.0; 2 * DIM], &[2, DIM]);
    error("expected [D] or [1, D]");
    write_embedding(&prompt, &[0.0; DIM], &[1, DIM]);
    error("zero or not finite");
    let mut empty = Checkpoint::default();
    empty.put("other", &Tensor::<1>::ones([DIM], &device));
    empty.write(&prompt).unwrap();
    error("no `text_embedding` tensor");
    std::fs::remove_file(dir.path().join("visual.onnx")).unwrap();
    write_embedding(&prompt, &[1.0; DIM], &[DIM]);
    error("visual.onnx");
    let config = ClipConfig {
        size: 0,
        ..toml::from_str::<ClipConfig>("image_encoder = \"a\"\ntext_embedding = \"b\"").unwrap()
    };
    assert!(ClipScorer::with_config(config, dir.path()).is_err());
    let scorer_dir = tempfile::tempdir().unwrap();
    let scorer = ClipScorer::load(&setup(scorer_dir.path(), &[1.0; DIM]).0).unwrap();
    let four = Tensor::<3>::zeros([4, 4, 4], &device);
    assert!(
        scorer
            .score(four)
            .unwrap_err()
            .to_string()
            .contains("[4, 4, 4]")
    );
}
