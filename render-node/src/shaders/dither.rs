//! Choosing the pixels to sample (`dither.wgsl`), per eye: Floyd–Steinberg error
//! diffusion of the priority image, one invocation per 8×8 tile of a grid shifted every
//! frame.

use crate::gpu::{Binding, Gpu};

use super::Recorder;

/// `@workgroup_size` of the shader's entry point.
const WORKGROUP: u32 = 64;
/// `TILE` in the shader.
const TILE: u32 = 8;

/// The buffers the dither binds, in binding order.
pub(super) struct DitherBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub priority: &'a wgpu::Buffer,
    pub counters: &'a wgpu::Buffer,
    pub chosen: &'a wgpu::Buffer,
    pub chosen_img: &'a wgpu::Buffer,
}

/// The dither pipeline and its bind group layout.
pub(super) struct Dither {
    layout: wgpu::BindGroupLayout,
    dither: wgpu::ComputePipeline,
}

impl Dither {
    pub(super) fn new(gpu: &Gpu) -> Dither {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let layout = gpu.layout("dither", &[Uniform, ro, rw, rw, rw]);
        let [dither] = gpu
            .pipelines("dither", include_str!("dither.wgsl"), &layout, &["dither"])
            .try_into()
            .unwrap_or_else(|_| unreachable!("one entry point, one pipeline"));
        Dither { layout, dither }
    }

    pub(super) fn bind_group(&self, gpu: &Gpu, b: &DitherBuffers) -> wgpu::BindGroup {
        gpu.bind_group(
            "dither",
            &self.layout,
            &[b.params, b.priority, b.counters, b.chosen, b.chosen_img],
        )
    }

    /// Chooses the pixels of a `width`×`height` eye.
    pub(super) fn dither(&self, r: &mut Recorder, bg: &wgpu::BindGroup, width: u32, height: u32) {
        // One more tile each way: the tile grid is shifted every frame.
        let tiles = (width.div_ceil(TILE) + 1) * (height.div_ceil(TILE) + 1);
        r.pass(&self.dither, bg, tiles, WORKGROUP);
    }
}
