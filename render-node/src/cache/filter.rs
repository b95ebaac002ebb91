//! Filtering (`filter.wgsl`), per eye: the 3×3 depth cull of reprojected points, then
//! 3×3 interpolation of empty pixels with the priority image in one pass.

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 256;

/// The cull and interpolate pipelines.
pub(super) struct Filter(ComputePass<2>);

impl Filter {
    pub(super) fn new(gpu: &Gpu) -> Filter {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, ro, ro, rw, rw, rw, rw];
        let source = include_str!("filter.wgsl");
        let entries = ["cull", "interpolate"];
        Filter(ComputePass::new(gpu, "filter", source, &bindings, entries))
    }

    /// A bind group of `[params, points, depth, key, culled, color, priority, counters]`, in binding order.
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 8]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// The depth cull of an eye of `pixels` pixels.
    pub(super) fn cull(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        let [cull, _] = &self.0.pipelines;
        r.pass(cull, bg, pixels, WORKGROUP);
    }

    /// Interpolation and the priority image of an eye of `pixels` pixels.
    pub(super) fn interpolate(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        let [_, interpolate] = &self.0.pipelines;
        r.pass(interpolate, bg, pixels, WORKGROUP);
    }
}
