//! Projection (`project.wgsl`), per eye: clear the eye's per-pixel buffers, then
//! z-buffer every point in two passes of atomicMin (the nearest depth; then, among points
//! within 1% of it, the key: quantised ray-miss distance, then point index).

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 256;

/// The clear, depth and key pipelines.
pub(super) struct Project(ComputePass<3>);

impl Project {
    pub(super) fn new(gpu: &Gpu) -> Project {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, rw, rw, rw, rw];
        let source = include_str!("project.wgsl");
        let entries = ["clear", "project_depth", "project_key"];
        Project(ComputePass::new(gpu, "project", source, &bindings, entries))
    }

    /// A bind group of `[params, points, depth, key, visible, counters]`, in binding order.
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 6]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// Clears an eye of `pixels` pixels (its depth, key and counters).
    pub(super) fn clear(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        let [clear, ..] = &self.0.pipelines;
        r.pass(clear, bg, pixels.max(4), WORKGROUP);
    }

    /// Projects `points` points into the eye: depth, then key.
    pub(super) fn project(&self, r: &mut Recorder, bg: &wgpu::BindGroup, points: u32) {
        let [_, depth, key] = &self.0.pipelines;
        r.pass(depth, bg, points, WORKGROUP);
        r.pass(key, bg, points, WORKGROUP);
    }
}
