//! The wgpu device and the few helpers the render cache needs: storage buffers, bind
//! group layouts listed by hand (so every pipeline of one shader file shares them), and
//! blocking read-back.

use std::sync::mpsc;

use wgpu::util::DeviceExt;

use crate::RenderNodeError;

#[cfg(test)]
pub(crate) mod layout;

/// The WGSL a pipeline of the node is made from: `gpu/common.wgsl` (the cache's
/// structs and helpers, the one `luminance()`), then the shader's own `source`. The
/// layout tests parse this same text (`gpu/layout.rs`).
pub(crate) fn with_common(source: &str) -> String {
    format!("{}\n{}", include_str!("common.wgsl"), source)
}

/// A device and its queue, on whichever adapter exists (a real GPU, or Mesa's lavapipe
/// or llvmpipe on machines without one). Cloning shares the same device.
#[derive(Clone)]
pub struct Gpu {
    pub(crate) instance: wgpu::Instance,
    pub(crate) raw_adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Adapter name, backend and driver, for logs and benchmark tables.
    pub adapter: String,
    /// This device's number in the process, shared by its clones ([`Gpu::same_device`]).
    serial: u64,
}

/// One binding of a bind group layout.
#[derive(Clone, Copy)]
pub enum Binding {
    Uniform,
    Storage { read_only: bool },
}

impl Gpu {
    /// Opens the first adapter wgpu finds (high performance preferred; software adapters
    /// allowed). `WGPU_BACKEND` (e.g. `vulkan`, `gl`) chooses the backends.
    pub fn new() -> Result<Gpu, RenderNodeError> {
        // Vulkan first, OpenGL only if there is no Vulkan adapter (probing EGL prints
        // warnings on headless machines); WGPU_BACKEND overrides both.
        let tries: &[Option<wgpu::Backends>] = if std::env::var_os("WGPU_BACKEND").is_some() {
            &[None]
        } else {
            &[Some(wgpu::Backends::VULKAN), Some(wgpu::Backends::GL)]
        };
        let mut found = None;
        let mut last_error = String::from("no backend tried");
        for backends in tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if let Some(b) = backends {
                desc.backends = *b;
            }
            let instance = wgpu::Instance::new(desc);
            match pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            })) {
                Ok(adapter) => {
                    found = Some((instance, adapter));
                    break;
                }
                Err(e) => last_error = e.to_string(),
            }
        }
        let (instance, adapter) = found.ok_or(RenderNodeError::NoAdapter(last_error))?;
        Gpu::from_adapter(instance, adapter)
    }

    /// A device on `adapter` of `instance` (which made the surfaces it will present to).
    pub(crate) fn from_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
    ) -> Result<Gpu, RenderNodeError> {
        let info = adapter.get_info();
        let name = format!(
            "{} ({:?}, {} {})",
            info.name, info.backend, info.driver, info.driver_info
        );
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("holocave render node"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits {
                max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
                max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
                max_buffer_size: limits.max_buffer_size,
                // Windows as large as the adapter can present (a projector's 4K mode, two
                // eyes side by side); the downlevel default is 2048.
                max_texture_dimension_2d: limits.max_texture_dimension_2d,
                ..wgpu::Limits::downlevel_defaults()
            },
            ..Default::default()
        }))
        .map_err(|e| RenderNodeError::Device(e.to_string()))?;
        tracing::info!("render node GPU: {name}");
        static OPENED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Ok(Gpu {
            instance,
            raw_adapter: adapter,
            device,
            queue,
            adapter: name,
            serial: OPENED.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        })
    }

    /// Whether `other` is this device (a clone of it), whose buffers it may bind. Two
    /// devices opened apart may compare equal as `wgpu::Device`s (each instance numbers
    /// its own devices from the start), yet neither knows the other's buffers.
    pub fn same_device(&self, other: &Gpu) -> bool {
        self.serial == other.serial
    }

    pub fn storage(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    pub fn storage_init(&self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
            })
    }

    pub fn uniform(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    pub fn layout(&self, label: &str, bindings: &[Binding]) -> wgpu::BindGroupLayout {
        let entries: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match *b {
                        Binding::Uniform => wgpu::BufferBindingType::Uniform,
                        Binding::Storage { read_only } => {
                            wgpu::BufferBindingType::Storage { read_only }
                        }
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        self.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries: &entries,
            })
    }

    pub fn bind_group(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }

    /// Compute pipelines for `entries` of one WGSL source (prefixed with `common.wgsl`),
    /// all with one bind group layout.
    pub fn pipelines(
        &self,
        label: &str,
        source: &str,
        layout: &wgpu::BindGroupLayout,
        entries: &[&str],
    ) -> Vec<wgpu::ComputePipeline> {
        let code = with_common(source);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(code.into()),
            });
        let pl = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
        entries
            .iter()
            .map(|e| {
                self.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(e),
                        layout: Some(&pl),
                        module: &module,
                        entry_point: Some(e),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            })
            .collect()
    }

    /// Waits for all submitted work.
    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    /// A buffer of `size` bytes that GPU results are copied into and mapped to be read.
    pub fn read_back_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Copies `size` bytes of `buffer` back to the CPU (blocking).
    pub fn read(&self, buffer: &wgpu::Buffer, size: u64) -> Vec<u8> {
        let staging = self.read_back_buffer("read-back", size);
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit([enc.finish()]);
        self.map_read(&staging)
    }

    /// Maps a MAP_READ buffer, waits, and copies its contents out.
    pub fn map_read(&self, staging: &wgpu::Buffer) -> Vec<u8> {
        let slice = staging.slice(..);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait();
        let ok = rx.recv().map(|r| r.is_ok()).unwrap_or(false);
        let data = if ok {
            slice
                .get_mapped_range()
                .map(|v| v.to_vec())
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        staging.unmap();
        data
    }
}

/// One WGSL compute shader as its passes use it: the bind group layout of its bindings
/// and a pipeline for each of its `N` entry points.
pub struct ComputePass<const N: usize> {
    label: &'static str,
    layout: wgpu::BindGroupLayout,
    /// In the order of the entry points given.
    pub pipelines: [wgpu::ComputePipeline; N],
}

impl<const N: usize> ComputePass<N> {
    /// The shader `source` (prefixed with `common.wgsl`) with `bindings` in binding order
    /// and pipelines for `entries`.
    pub fn new(
        gpu: &Gpu,
        label: &'static str,
        source: &str,
        bindings: &[Binding],
        entries: [&str; N],
    ) -> Self {
        let layout = gpu.layout(label, bindings);
        let pipelines = gpu
            .pipelines(label, source, &layout, &entries)
            .try_into()
            .unwrap_or_else(|_| unreachable!("one pipeline per entry point"));
        ComputePass {
            label,
            layout,
            pipelines,
        }
    }

    /// A bind group of `buffers`, in binding order.
    pub fn bind_group(&self, gpu: &Gpu, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        gpu.bind_group(self.label, &self.layout, buffers)
    }
}
