//! The `--backend` choice every binary offers: Burn's CPU backends (Flex, the 0.22 default, and
//! the older NdArray) and wgpu (a GPU, or Mesa's lavapipe where there is none). CUDA is not
//! built into this workspace (it needs the CUDA toolkit at build time).

use burn::tensor::Device;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// Burn's Flex CPU backend (multi-threaded; the fastest CPU choice).
    #[default]
    Flex,
    /// Burn's NdArray CPU backend (deprecated upstream in favour of Flex).
    Ndarray,
    /// wgpu: Vulkan, Metal or DX12; lavapipe on a machine without a GPU.
    Wgpu,
}

impl Backend {
    pub const ALL: [Backend; 3] = [Backend::Flex, Backend::Ndarray, Backend::Wgpu];

    pub fn device(self) -> Device {
        match self {
            Backend::Flex => Device::flex(),
            #[allow(deprecated)] // still served by burn 0.22
            Backend::Ndarray => Device::ndarray(),
            Backend::Wgpu => Device::wgpu(Default::default()),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Backend::Flex => "flex",
            Backend::Ndarray => "ndarray",
            Backend::Wgpu => "wgpu",
        }
    }
}
