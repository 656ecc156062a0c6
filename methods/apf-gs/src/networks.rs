//! APF-GS's networks as Burn modules (widths and depths are knobs; the spec's table of §3):
//!
//! - the image encoder `E`: a pedestrian crop → `f_img` (four stride-2 3×3 convolutions, ReLU,
//!   global average pool, a linear layer);
//! - the guidance module `C` (§II-C): `[f_img ‖ e_h ‖ γ(t)]` → the condition `c_t` and the
//!   reliability logit, whose bias starts at `logit(σ₀)` (σ₀ = 0.8, the paper's "high prior
//!   confidence") and whose weights start ×1e-3;
//! - the residual field `F_φ` (Eq. 5): `[γ(μ̄) ‖ c_t]` → `(δμ, δq, δs)`, its head zero so that
//!   `Δ ≡ 0` at step 0; `γ` is NeRF's frequency encoding, or (the spec's speed knob,
//!   `network.position_encoding = "hash"`) a learned multi-resolution hash encoding, the
//!   engine's, whose table the field owns and trains;
//! - the accessory network `D_ψ` (Eq. 8's "general deformable Gaussian model"):
//!   `[γ(x̄) ‖ γ(t) ‖ e_a]` → `(δx, δq)`, its head zero.
//!
//! The per-person and per-accessory embeddings `e_h`, `e_a` are parameters too
//! ([`Embeddings`]), trained with the networks.

use burn::module::{Module, Param};
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{Linear, LinearConfig, PaddingConfig2d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Distribution, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use splatzoo_models::networks::encoding::{encoded_width, frequency_encoding};
use splatzoo_models::networks::hash_grid::{HashGrid, HashGridConfig};
use splatzoo_models::networks::mlp::{SkipMlp, head};

/// `γ` of the residual field's canonical positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionEncoding {
    /// NeRF's frequency encoding, `position_levels` octaves (the paper's, via DeformGS).
    Frequency,
    /// instant-NGP's hash encoding with `position_hash`'s shape, trained with `F_φ`.
    Hash,
}

/// Every architectural knob.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkConfig {
    /// Crop size fed to `E`, `[height, width]`.
    pub crop: [usize; 2],
    /// Channels of `E`'s four convolutions.
    pub encoder_channels: [usize; 4],
    /// Width of `f_img`.
    pub image_features: usize,
    /// Width of `e_h` and `e_a`.
    pub embedding: usize,
    /// Frequencies of `γ(t)` and of `γ(μ̄)`, `γ(x̄)`.
    pub time_levels: usize,
    pub position_levels: usize,
    /// `γ(μ̄)` of `F_φ` (`D_ψ` keeps the frequency encoding).
    pub position_encoding: PositionEncoding,
    /// The hash encoding's shape where `position_encoding = "hash"`.
    pub position_hash: HashGridConfig,
    /// `C`'s hidden width (two layers) and the width of `c_t`.
    pub guidance_width: usize,
    pub condition: usize,
    /// `F_φ` and `D_ψ`: layers and width (the paper-size field is 8 × 256).
    pub residual_depth: usize,
    pub residual_width: usize,
    pub accessory_depth: usize,
    pub accessory_width: usize,
    /// σ at initialisation (the paper's ≈ 0.8).
    pub initial_sigma: f64,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        Self {
            crop: [128, 64],
            encoder_channels: [32, 64, 128, 128],
            image_features: 64,
            embedding: 16,
            time_levels: 10,
            position_levels: 10,
            position_encoding: PositionEncoding::Frequency,
            position_hash: HashGridConfig::default(),
            guidance_width: 256,
            condition: 64,
            residual_depth: 4,
            residual_width: 128,
            accessory_depth: 4,
            accessory_width: 128,
            initial_sigma: 0.8,
        }
    }
}

impl NetworkConfig {
    /// `[f_img ‖ e ‖ γ(t)]`, `C`'s input width.
    pub fn guidance_inputs(&self) -> usize {
        self.image_features + self.embedding + encoded_width(1, self.time_levels)
    }

    /// Width of `F_φ`'s `γ(μ̄)`.
    pub fn residual_position_width(&self) -> usize {
        match self.position_encoding {
            PositionEncoding::Frequency => encoded_width(3, self.position_levels),
            PositionEncoding::Hash => self.position_hash.levels * self.position_hash.features,
        }
    }

    /// `[γ(μ̄) ‖ c_t]`, `F_φ`'s input width.
    pub fn residual_inputs(&self) -> usize {
        self.residual_position_width() + self.condition
    }

    /// `[γ(x̄) ‖ γ(t) ‖ e_a]`, `D_ψ`'s input width.
    pub fn accessory_inputs(&self) -> usize {
        encoded_width(3, self.position_levels) + encoded_width(1, self.time_levels) + self.embedding
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.crop[0] < 16 || self.crop[1] < 16 {
            return Err("network.crop ≥ 16 × 16".into());
        }
        if !(self.initial_sigma > 0.0 && self.initial_sigma < 1.0) {
            return Err(format!(
                "network.initial_sigma in (0, 1), got {}",
                self.initial_sigma
            ));
        }
        for (name, v) in [
            ("image_features", self.image_features),
            ("embedding", self.embedding),
            ("guidance_width", self.guidance_width),
            ("condition", self.condition),
            ("residual_depth", self.residual_depth),
            ("residual_width", self.residual_width),
            ("accessory_depth", self.accessory_depth),
            ("accessory_width", self.accessory_width),
            ("position_hash.levels", self.position_hash.levels),
            ("position_hash.features", self.position_hash.features),
            (
                "position_hash.base_resolution",
                self.position_hash.base_resolution,
            ),
        ] {
            if v == 0 {
                return Err(format!("network.{name} ≥ 1"));
            }
        }
        Ok(())
    }
}

/// `E`: crops `[B, 3, H, W]` in [0, 1] → `[B, image_features]`.
#[derive(Module, Debug)]
pub struct ImageEncoder {
    pub convs: Vec<Conv2d>,
    pub out: Linear,
}

impl ImageEncoder {
    pub fn new(config: &NetworkConfig, device: &Device) -> Self {
        let mut inputs = 3;
        let convs = config
            .encoder_channels
            .iter()
            .map(|&c| {
                let conv = Conv2dConfig::new([inputs, c], [3, 3])
                    .with_stride([2, 2])
                    .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                    .init(device);
                inputs = c;
                conv
            })
            .collect();
        Self {
            convs,
            out: LinearConfig::new(inputs, config.image_features).init(device),
        }
    }

    pub fn forward(&self, crops: Tensor<4>) -> Tensor<2> {
        let mut x = crops;
        for conv in &self.convs {
            x = relu(conv.forward(x));
        }
        let [b, c, _, _] = x.dims();
        let pooled = x.mean_dim(3).mean_dim(2).reshape([b, c]);
        self.out.forward(pooled)
    }
}

/// `C`: `[f_img ‖ e_h ‖ γ(t)]` `[B, guidance_inputs]` → (`c_t` `[B, condition]`, the
/// reliability logit `[B, 1]`; σ = sigmoid of it).
#[derive(Module, Debug)]
pub struct Guidance {
    pub trunk: SkipMlp,
    pub condition: Linear,
    pub gate: Linear,
}

impl Guidance {
    pub fn new(config: &NetworkConfig, device: &Device) -> Self {
        let width = config.guidance_width;
        let mut gate = LinearConfig::new(width, 1).init(device);
        gate.weight = gate.weight.map(|w| w * 1e-3);
        let s = config.initial_sigma;
        gate.bias = Some(Param::from_tensor(Tensor::<1>::from_floats(
            [(s / (1.0 - s)).ln() as f32],
            device,
        )));
        Self {
            trunk: SkipMlp::new(config.guidance_inputs(), 2, width, None, device),
            condition: LinearConfig::new(width, config.condition).init(device),
            gate,
        }
    }

    pub fn forward(&self, inputs: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
        let hidden = self.trunk.forward(inputs);
        (
            self.condition.forward(hidden.clone()),
            self.gate.forward(hidden),
        )
    }
}

/// `F_φ` (Eq. 5): `[γ(μ̄) ‖ c_t]` → raw `[δμ (3) ‖ δq (4) ‖ δs (3)]` (and a per-Gaussian gate
/// offset `δℓ` where σ is per Gaussian), zero at initialisation.
/// With a hash `γ` the field owns its table (`encoding`), trained and checkpointed with it;
/// [`ResidualField::forward`] is the MLP on encoded inputs either way (what ONNX exports).
#[derive(Module, Debug)]
pub struct ResidualField {
    pub encoding: Option<HashGrid>,
    pub trunk: SkipMlp,
    pub head: Linear,
}

impl ResidualField {
    /// A field with `columns` outputs (10, or 11 with a per-Gaussian gate:
    /// [`crate::gate::GateConfig::residual_columns`]).
    pub fn new(config: &NetworkConfig, columns: usize, device: &Device) -> Self {
        let depth = config.residual_depth;
        let trunk = SkipMlp::new(
            config.residual_inputs(),
            depth,
            config.residual_width,
            (depth >= 4).then_some(depth / 2 - 1),
            device,
        );
        let width = trunk.output_width();
        let encoding = (config.position_encoding == PositionEncoding::Hash).then(|| {
            // The table's seed from the device's generator, so a run's seed draws it.
            let seed = Tensor::<1>::random([1], Distribution::Uniform(0.0, 16_777_216.0), device)
                .into_data()
                .convert::<f32>()
                .as_slice::<f32>()
                .map_or(0, |v| v[0] as u64);
            HashGrid::new(config.position_hash, seed, device)
        });
        Self {
            encoding,
            trunk,
            head: head(width, columns, true, device),
        }
    }

    /// `γ` of canonical positions already normalised to `[−1, 1]³` (`[G, 3]`): the hash code
    /// of the unit-cube point `(x + 1) / 2` where the field owns a table, else the frequency
    /// encoding of `levels` octaves.
    pub fn encode_positions(&self, normalised: Tensor<2>, levels: usize) -> Tensor<2> {
        match &self.encoding {
            Some(grid) => grid.encode(normalised.add_scalar(1.0).mul_scalar(0.5)),
            None => frequency_encoding(normalised, levels),
        }
    }

    pub fn forward(&self, inputs: Tensor<2>) -> Tensor<2> {
        self.head.forward(self.trunk.forward(inputs))
    }
}

/// `D_ψ`: `[γ(x̄) ‖ γ(t) ‖ e_a]` → raw `[δx (3) ‖ δq (4)]`, zero at initialisation.
#[derive(Module, Debug)]
pub struct AccessoryField {
    pub trunk: SkipMlp,
    pub head: Linear,
}

/// Columns of the accessory field's output.
pub const ACCESSORY_COLUMNS: usize = 7;

impl AccessoryField {
    pub fn new(config: &NetworkConfig, device: &Device) -> Self {
        let depth = config.accessory_depth;
        let trunk = SkipMlp::new(
            config.accessory_inputs(),
            depth,
            config.accessory_width,
            (depth >= 4).then_some(depth / 2 - 1),
            device,
        );
        let width = trunk.output_width();
        Self {
            trunk,
            head: head(width, ACCESSORY_COLUMNS, true, device),
        }
    }

    pub fn forward(&self, inputs: Tensor<2>) -> Tensor<2> {
        self.head.forward(self.trunk.forward(inputs))
    }
}

/// The learned identities: `e_h` per tracked person, `e_a` per accessory node.
#[derive(Module, Debug)]
pub struct Embeddings {
    /// `[H, embedding]`.
    pub person: Param<Tensor<2>>,
    /// `[A, embedding]` (at least one row, unused without accessories).
    pub accessory: Param<Tensor<2>>,
}

impl Embeddings {
    /// Row `index` of `table`, `[1, embedding]`.
    pub fn row(table: &Param<Tensor<2>>, index: usize) -> Tensor<2> {
        let t = table.val();
        let device = t.device();
        t.select(
            0,
            Tensor::<1, Int>::from_data(TensorData::new(vec![index as i64], [1]), &device),
        )
    }
}

/// Every network and embedding of a scene.
#[derive(Module, Debug)]
pub struct ApfNetworks {
    pub encoder: ImageEncoder,
    pub guidance: Guidance,
    pub residual: ResidualField,
    pub accessory: AccessoryField,
    pub embeddings: Embeddings,
}

impl ApfNetworks {
    /// Fresh networks for `people` tracked people and `accessories` accessory nodes; `F_φ` has
    /// `residual_columns` outputs.
    pub fn new(
        config: &NetworkConfig,
        residual_columns: usize,
        people: usize,
        accessories: usize,
        device: &Device,
    ) -> Self {
        let table = |rows: usize| {
            Param::from_tensor(Tensor::<2>::random(
                [rows.max(1), config.embedding],
                Distribution::Normal(0.0, 0.1),
                device,
            ))
        };
        Self {
            encoder: ImageEncoder::new(config, device),
            guidance: Guidance::new(config, device),
            residual: ResidualField::new(config, residual_columns, device),
            accessory: AccessoryField::new(config, device),
            embeddings: Embeddings {
                person: table(people),
                accessory: table(accessories),
            },
        }
    }
}
