//! Inserting samples (`insert.wgsl`): match each sample with the point at its pixel
//! (same eye: running mean; an eye nearby, same surface and place: capped mean), age the
//! points around samples that changed a lot, then place the unmatched ones over the
//! oldest point of a round-robin group. Race-free: the same samples give the same points
//! whatever order the GPU runs the invocations in.

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// The shader (compiled after `common.wgsl`: `gpu::with_common`).
pub(super) const SOURCE: &str = include_str!("insert.wgsl");

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 64;

/// The match, age and place pipelines.
pub(super) struct Insert(ComputePass<3>);

impl Insert {
    pub(super) fn new(gpu: &Gpu) -> Insert {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, rw, ro, ro, rw, rw];
        let source = SOURCE;
        let entries = ["match_samples", "age_changed", "place_samples"];
        Insert(ComputePass::new(gpu, "insert", source, &bindings, entries))
    }

    /// A bind group of `[params, points, samples, key, matched, aging]`, in binding
    /// order (`aging`: a `u32` per pixel of the eye, zero to begin with).
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 6]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// Inserts the first `count` samples of the samples buffer into an eye of `pixels`.
    pub(super) fn insert(&self, r: &mut Recorder, bg: &wgpu::BindGroup, count: u32, pixels: u32) {
        let [matching, aging, placing] = &self.0.pipelines;
        r.pass(matching, bg, count, WORKGROUP);
        r.pass(aging, bg, pixels, WORKGROUP);
        r.pass(placing, bg, count, WORKGROUP);
    }
}
