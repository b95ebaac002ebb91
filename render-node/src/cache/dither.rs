//! Choosing the pixels to sample (`dither.wgsl`), per eye: Floyd–Steinberg error
//! diffusion of the priority image, one invocation per 8×8 tile of a grid shifted every
//! frame.

use crate::gpu::{Binding, ComputePass, Gpu};

use super::recorder::Recorder;

/// `@workgroup_size` of the shader's entry point.
const WORKGROUP: u32 = 64;
/// `TILE` in the shader.
const TILE: u32 = 8;

/// The dither pipeline.
pub(super) struct Dither(ComputePass<1>);

impl Dither {
    pub(super) fn new(gpu: &Gpu) -> Dither {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, rw, rw];
        let source = include_str!("dither.wgsl");
        Dither(ComputePass::new(
            gpu,
            "dither",
            source,
            &bindings,
            ["dither"],
        ))
    }

    /// A bind group of `[params, priority, counters, chosen]`, in binding order.
    pub(super) fn bind_group(&self, gpu: &Gpu, buffers: [&wgpu::Buffer; 4]) -> wgpu::BindGroup {
        self.0.bind_group(gpu, &buffers)
    }

    /// Chooses the pixels of a `width`×`height` eye.
    pub(super) fn dither(&self, r: &mut Recorder, bg: &wgpu::BindGroup, width: u32, height: u32) {
        // One more tile each way: the tile grid is shifted every frame.
        let tiles = (width.div_ceil(TILE) + 1) * (height.div_ceil(TILE) + 1);
        let [dither] = &self.0.pipelines;
        r.pass(dither, bg, tiles, WORKGROUP);
    }
}
