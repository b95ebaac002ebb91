//! Projection (`project.wgsl`), per eye: clear the eye's per-pixel buffers, then
//! z-buffer every point in two passes of atomicMin (the nearest depth; then, among points
//! within 1% of it, the key: quantised ray-miss distance, then point index).

use crate::gpu::{Binding, Gpu};

use super::Recorder;

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 256;

/// The buffers the projection binds, in binding order.
pub(super) struct ProjectBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub points: &'a wgpu::Buffer,
    pub depth: &'a wgpu::Buffer,
    pub key: &'a wgpu::Buffer,
    pub visible: &'a wgpu::Buffer,
    pub counters: &'a wgpu::Buffer,
}

/// The clear, depth and key pipelines and their bind group layout.
pub(super) struct Project {
    layout: wgpu::BindGroupLayout,
    clear: wgpu::ComputePipeline,
    depth: wgpu::ComputePipeline,
    key: wgpu::ComputePipeline,
}

impl Project {
    pub(super) fn new(gpu: &Gpu) -> Project {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let layout = gpu.layout("project", &[Uniform, ro, rw, rw, rw, rw]);
        let [clear, depth, key] = gpu
            .pipelines(
                "project",
                include_str!("project.wgsl"),
                &layout,
                &["clear", "project_depth", "project_key"],
            )
            .try_into()
            .unwrap_or_else(|_| unreachable!("three entry points, three pipelines"));
        Project {
            layout,
            clear,
            depth,
            key,
        }
    }

    pub(super) fn bind_group(&self, gpu: &Gpu, b: &ProjectBuffers) -> wgpu::BindGroup {
        gpu.bind_group(
            "project",
            &self.layout,
            &[b.params, b.points, b.depth, b.key, b.visible, b.counters],
        )
    }

    /// Clears an eye of `pixels` pixels (its depth, key and counters).
    pub(super) fn clear(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        r.pass(&self.clear, bg, pixels.max(4), WORKGROUP);
    }

    /// Projects `points` points into the eye: depth, then key.
    pub(super) fn project(&self, r: &mut Recorder, bg: &wgpu::BindGroup, points: u32) {
        r.pass(&self.depth, bg, points, WORKGROUP);
        r.pass(&self.key, bg, points, WORKGROUP);
    }
}
