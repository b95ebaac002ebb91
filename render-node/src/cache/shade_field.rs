//! The light field's pass (`shade_field.wgsl`), per eye: shade each pixel's lookup from the baked
//! irradiance and blend it under the cache's samples (or draw it alone).

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// The shader (compiled after `common.wgsl`: `gpu::with_common`).
pub(super) const SOURCE: &str = include_str!("shade_field.wgsl");

/// `@workgroup_size` of the shader's entry points.
const WORKGROUP: u32 = 256;

/// The lookup and blend pipelines.
pub(super) struct VlfPass(ComputePass<2>);

impl VlfPass {
    pub(super) fn new(gpu: &Gpu) -> VlfPass {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, ro, ro, ro, rw, rw, rw, ro, ro, ro];
        let source = SOURCE;
        VlfPass(ComputePass::new(
            gpu,
            "vlf",
            source,
            &bindings,
            ["lookup", "blend"],
        ))
    }

    /// A bind group of `[params, lookups, irradiance, points, key, color, priority,
    /// counters, irradiance1, irradiance2, irradiance3]`, in binding order (the light
    /// field's values in four buffers: `crate::cache::VLF_BUFFERS`).
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 11]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// The light field alone into the colour image of an eye of `pixels` pixels.
    pub(super) fn lookup(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        let [lookup, _] = &self.0.pipelines;
        r.pass(lookup, bg, pixels, WORKGROUP);
    }

    /// The light field blended under the cache's image of an eye of `pixels` pixels.
    pub(super) fn blend(&self, r: &mut Recorder, bg: &wgpu::BindGroup, pixels: u32) {
        let [_, blend] = &self.0.pipelines;
        r.pass(blend, bg, pixels, WORKGROUP);
    }
}
