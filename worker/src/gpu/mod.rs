//! The worker's GPU: which adapter to use (`--gpu auto|on|off|software`), the device
//! opened once per process and shared by every shard, and the compiled kernels of
//! `shaders/`. Kernels run through wgpu on Vulkan; Mesa's lavapipe (a Vulkan driver
//! on the CPU) is used only when asked for (`software`), which is how CI proves the
//! kernels' parity without a GPU.
//!
//! Each kernel's host side lives beside it (`round1.rs` for `shaders/round1.wgsl`) and
//! its CPU twin is the CPU backend's module (`patch_matching.rs`).

pub mod fill;
pub mod round1;

use std::sync::Arc;

use crate::device::{BackendInfo, GpuError, GpuMode};

/// An open device with its compiled kernels.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: BackendInfo,
    pub(crate) round1: wgpu::ComputePipeline,
    pub(crate) fill: wgpu::ComputePipeline,
    limits: wgpu::Limits,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext").field("info", &self.info).finish()
    }
}

/// Hit-list length per query; more hits send the query to the CPU.
pub(crate) const CAP: usize = 64;

/// The hit lists of `groups` queries: `None` where a list overflowed.
pub(crate) fn hit_lists(words: &[u32], groups: usize) -> Vec<Option<&[u32]>> {
    (0..groups)
        .map(|g| {
            let at = g * (CAP + 1);
            let count = words[at] as usize;
            (count <= CAP).then(|| &words[at + 1..at + 1 + count])
        })
        .collect()
}

/// Workgroups per dispatch: the kernels index queries by `workgroup_id.x` alone.
pub(crate) const MAX_GROUPS: usize = 65_535;

fn is_real_gpu(t: wgpu::DeviceType) -> bool {
    matches!(t, wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu | wgpu::DeviceType::VirtualGpu)
}

/// The size of a Vulkan adapter's device-local memory heaps, in bytes. wgpu has no
/// portable query for it, so this asks the Vulkan driver under wgpu directly.
fn device_memory(adapter: &wgpu::Adapter) -> Option<u64> {
    // SAFETY: the HAL adapter is only read, while `adapter` (which owns it) is alive;
    // the physical device handle it returns belongs to the instance queried.
    let hal = unsafe { adapter.as_hal::<wgpu::hal::api::Vulkan>() }?;
    let props = unsafe { hal.shared_instance().raw_instance().get_physical_device_memory_properties(hal.raw_physical_device()) };
    const DEVICE_LOCAL: u32 = 0x1; // VK_MEMORY_HEAP_DEVICE_LOCAL_BIT
    Some(props.memory_heaps_as_slice().iter().filter(|h| h.flags.as_raw() & DEVICE_LOCAL != 0).map(|h| h.size).sum())
}

impl GpuContext {
    /// Opens the adapter `mode` asks for: `Ok(None)` means score on the CPU (mode off,
    /// or auto without a GPU).
    pub fn open(mode: GpuMode) -> Result<Option<Arc<GpuContext>>, GpuError> {
        if mode == GpuMode::Off {
            return Ok(None);
        }
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            t if is_real_gpu(t) => 1,
            _ => 2,
        };
        let chosen = adapters
            .iter()
            .filter(|a| mode == GpuMode::Software || is_real_gpu(a.get_info().device_type))
            .min_by_key(|a| rank(a));
        let Some(adapter) = chosen else {
            let seen: Vec<String> =
                adapters.iter().map(|a| format!("{} ({:?})", a.get_info().name, a.get_info().device_type)).collect();
            return match mode {
                GpuMode::On => Err(GpuError::NoGpu(if seen.is_empty() { "none".into() } else { seen.join(", ") })),
                GpuMode::Software => Err(GpuError::NoAdapter),
                _ => {
                    tracing::info!(adapters = %seen.join(", "), "no GPU found; scoring on the CPU");
                    Ok(None)
                }
            };
        };
        let ai = adapter.get_info();
        let name = format!("{} ({:?}, {} {})", ai.name, ai.device_type, ai.driver, ai.driver_info).replace(" )", ")");
        let limits = adapter.limits();
        let dev_err = |what: String| GpuError::Device { adapter: name.clone(), what };
        if limits.max_storage_buffers_per_shader_stage < 11 {
            return Err(dev_err(format!(
                "allows {} storage buffers per kernel; the kernels need 11",
                limits.max_storage_buffers_per_shader_stage
            )));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("ridgeline worker"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| dev_err(e.to_string()))?;
        // errors are caught per call by error scopes (`checked`); anything else is
        // logged, never a panic
        device.on_uncaptured_error(Arc::new(|e| tracing::error!(error = %e, "GPU error")));
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let kernel = |name: &str, source: &str| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl([source, include_str!("../../../shaders/window.wgsl")].concat().into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let round1 = kernel("round1.wgsl", include_str!("../../../shaders/round1.wgsl"));
        let fill = kernel("fill.wgsl", include_str!("../../../shaders/fill.wgsl"));
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(dev_err(format!("the kernels do not compile: {e}")));
        }
        let info = BackendInfo {
            backend: "gpu",
            adapter: name,
            max_buffer_bytes: limits.max_buffer_size,
            memory_bytes: device_memory(adapter).unwrap_or(0),
        };
        tracing::info!(
            adapter = %info.adapter,
            memory_mb = info.memory_bytes >> 20,
            max_buffer_mb = info.max_buffer_bytes >> 20,
            "GPU backend ready"
        );
        Ok(Some(Arc::new(GpuContext { device, queue, info, round1, fill, limits })))
    }

    /// Runs `f` with validation and out-of-memory errors of the device caught and
    /// returned instead of logged.
    pub(crate) fn checked<T>(&self, f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let invalid = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let e1 = pollster::block_on(invalid.pop());
        let e2 = pollster::block_on(oom.pop());
        match (e1.or(e2), out) {
            (Some(e), _) => Err(e.to_string()),
            (None, out) => out,
        }
    }

    /// Largest storage buffer a kernel can bind, in bytes.
    pub(crate) fn max_binding(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    /// A storage buffer holding `data` (at least 4 bytes: empty arrays cannot be bound).
    pub(crate) fn storage<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let pad = [0u8; 4];
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: if bytes.is_empty() { &pad } else { bytes },
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        })
    }

    /// Runs `pipeline` with `buffers` bound at 0, 1, … and `groups` workgroups, then
    /// reads back the `hits` buffer (`groups` lists of [`CAP`] + 1 words) and, when
    /// asked, the `costs` buffer (`n_costs` floats): the two last of `buffers`.
    pub(crate) fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        groups: usize,
        n_costs: Option<usize>,
    ) -> Result<(Vec<u32>, Option<Vec<f32>>), String> {
        let layout = pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect();
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries });
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(groups as u32, 1, 1);
        }
        let (costs, hits) = (buffers[buffers.len() - 2], buffers[buffers.len() - 1]);
        let hit_words = self.read_back::<u32>(encoder, hits, groups * (CAP + 1))?;
        let cost_list = match n_costs {
            Some(n) => {
                let encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
                Some(self.read_back::<f32>(encoder, costs, n)?)
            }
            None => None,
        };
        Ok((hit_words, cost_list))
    }

    /// The device's memory bandwidth as a large buffer-to-buffer copy achieves it
    /// (bytes read plus bytes written per second, best of 5 after a warm-up): the
    /// yardstick for the kernels' bytes-read figures in the benchmark.
    pub fn copy_bandwidth(&self) -> Result<f64, String> {
        let size = (self.limits.max_buffer_size.min(256 << 20) / 4 * 4).max(4);
        let buffer = |label| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let (a, b) = (buffer("bandwidth a"), buffer("bandwidth b"));
        let mut best = f64::INFINITY;
        for round in 0..6 {
            let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            encoder.copy_buffer_to_buffer(&a, 0, &b, 0, size);
            let t = std::time::Instant::now();
            self.queue.submit(Some(encoder.finish()));
            self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| e.to_string())?;
            if round > 0 {
                best = best.min(t.elapsed().as_secs_f64());
            }
        }
        Ok(2.0 * size as f64 / best)
    }

    /// A uniform buffer holding `value`.
    pub(crate) fn uniform<T: bytemuck::Pod>(&self, label: &str, value: &T) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(value),
            usage: wgpu::BufferUsages::UNIFORM,
        })
    }

    /// Copies `buffer` back to the host after the submitted work finishes.
    pub(crate) fn read_back<T: bytemuck::Pod>(
        &self,
        encoder: wgpu::CommandEncoder,
        buffer: &wgpu::Buffer,
        len: usize,
    ) -> Result<Vec<T>, String> {
        let size = (len * std::mem::size_of::<T>()).max(4) as u64;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = encoder;
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit(Some(encoder.finish()));
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| e.to_string())?;
        rx.recv().map_err(|e| e.to_string())?.map_err(|e| e.to_string())?;
        let view = staging.slice(..).get_mapped_range().map_err(|e| e.to_string())?;
        let out: Vec<T> = bytemuck::cast_slice(&view[..len * std::mem::size_of::<T>()]).to_vec();
        drop(view);
        staging.unmap();
        Ok(out)
    }
}
