//! Filtering (`filter.wgsl`), per eye: the 3×3 depth cull of reprojected points, then
//! 3×3 interpolation of empty pixels with the priority image in one pass.

use crate::gpu::{Binding, Gpu};

use super::Recorder;

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 256;

/// The buffers the filter binds, in binding order.
pub(super) struct FilterBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub points: &'a wgpu::Buffer,
    pub depth: &'a wgpu::Buffer,
    pub key: &'a wgpu::Buffer,
    pub culled: &'a wgpu::Buffer,
    pub color: &'a wgpu::Buffer,
    pub priority: &'a wgpu::Buffer,
    pub counters: &'a wgpu::Buffer,
}

/// The cull and interpolate pipelines and their bind group layout.
pub(super) struct Filter {
    layout: wgpu::BindGroupLayout,
    cull: wgpu::ComputePipeline,
    interpolate: wgpu::ComputePipeline,
}

impl Filter {
    pub(super) fn new(gpu: &Gpu) -> Filter {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let layout = gpu.layout("filter", &[Uniform, ro, ro, ro, rw, rw, rw, rw]);
        let [cull, interpolate] = gpu
            .pipelines(
                "filter",
                include_str!("filter.wgsl"),
                &layout,
                &["cull", "interpolate"],
            )
            .try_into()
            .unwrap_or_else(|_| unreachable!("two entry points, two pipelines"));
        Filter {
            layout,
            cull,
            interpolate,
        }
    }

    pub(super) fn bind_group(&self, gpu: &Gpu, b: &FilterBuffers) -> wgpu::BindGroup {
        gpu.bind_group(
            "filter",
            &self.layout,
            &[
                b.params, b.points, b.depth, b.key, b.culled, b.color, b.priority, b.counters,
            ],
        )
    }

    /// The depth cull of an eye of `pixels` pixels.
    pub(super) fn cull(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        r.pass(&self.cull, bg, pixels, WORKGROUP);
    }

    /// Interpolation and the priority image of an eye of `pixels` pixels.
    pub(super) fn interpolate(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        r.pass(&self.interpolate, bg, pixels, WORKGROUP);
    }
}
