//! Which device a shard scores on (`--gpu auto|on|off|software`), what a device is,
//! and why none could be had — in every build (the device itself, `backend::Device`,
//! exists only with the `gpu` feature).

/// Which scoring backend to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GpuMode {
    /// A real GPU if one is present, else the CPU.
    #[default]
    Auto,
    /// A real GPU; fail clearly without one.
    On,
    /// The CPU backend (rayon).
    Off,
    /// Any Vulkan adapter, a software one (lavapipe) included: for parity tests.
    Software,
}

impl std::str::FromStr for GpuMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(GpuMode::Auto),
            "on" => Ok(GpuMode::On),
            "off" => Ok(GpuMode::Off),
            "software" => Ok(GpuMode::Software),
            _ => Err(format!("'{s}' is not a GPU mode (auto, on, off or software)")),
        }
    }
}

/// Why no GPU backend could be set up.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("--gpu on: no GPU adapter found (Vulkan adapters seen: {0}); use --gpu auto or off to score on the CPU")]
    NoGpu(String),
    #[error("--gpu software: no Vulkan adapter at all (install mesa-vulkan-drivers and libvulkan1 for lavapipe)")]
    NoAdapter,
    #[error("GPU {adapter}: {what}")]
    Device { adapter: String, what: String },
    #[error(
        "--gpu {0:?}: this ridgeline was built without the GPU backend (build with the `gpu` feature); use --gpu auto or off"
    )]
    NotBuilt(GpuMode),
}

/// What a worker scores on, for its capabilities, logs and the job report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BackendInfo {
    /// "cpu" or "gpu".
    pub backend: &'static str,
    /// Adapter name and driver, or the CPU's thread count.
    pub adapter: String,
    /// Largest single buffer the device accepts (bytes); 0 on the CPU: this bounds how
    /// large a shard's pool can be resident in one binding.
    pub max_buffer_bytes: u64,
    /// The device's own memory (its device-local Vulkan heaps, bytes); 0 on the CPU or
    /// where the driver does not say.
    pub memory_bytes: u64,
}

impl BackendInfo {
    /// The CPU backend on `threads` threads.
    pub fn cpu(threads: usize) -> Self {
        BackendInfo { backend: "cpu", adapter: format!("rayon, {threads} threads"), max_buffer_bytes: 0, memory_bytes: 0 }
    }
}
