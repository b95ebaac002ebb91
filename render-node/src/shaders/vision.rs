//! The passes of `vision.wgsl`: an eye image in a GPU buffer seen as a person would see it
//! ([`crate::vision::perceive`] on the GPU), into another buffer that the histogram and the
//! window's tone mapping then read. The foveal grid's geometry (each cell's direction,
//! solid angle and pixels per degree) is made on the CPU from the view and uploaded: a few
//! kilobytes per frame; the pixels never leave the GPU.

use bytemuck::{Pod, Zeroable};

use super::acuity::{LEVELS, level_size};
use super::veil::VEIL_OF_UNIFORM_FIELD;
use super::{Fovea, VeilSources};
use crate::gpu::{Binding, ComputePass, Gpu};

const SOURCE: &str = include_str!("vision.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct VisionParams {
    width: u32,
    height: u32,
    cols: u32,
    rows: u32,
    imported: u32,
    levels: u32,
    efficacy: f32,
    veil_uniform: f32,
}

/// `Cell` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Cell {
    dir: [f32; 4],
    ppd: [f32; 4],
}

/// `Source` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Source {
    dir: [f32; 4],
    flux: [f32; 4],
}

/// `Foveal` in the shader: 32 bytes per cell.
const FOVEAL_BYTES: u64 = 32;

/// The human-vision passes for images of one size (buffers grow as needed).
pub struct VisionPass {
    pass: ComputePass<4>,
    params: wgpu::Buffer,
    cells: wgpu::Buffer,
    sources: wgpu::Buffer,
    foveal: wgpu::Buffer,
    pyramid: wgpu::Buffer,
    /// The image as seen (one `vec4<f32>` per pixel).
    pub seen: wgpu::Buffer,
    sizes: (u64, u64, u64, u64, u64),
}

/// Texels of pyramid levels 1.. of a `w × h` image.
fn pyramid_texels(w: u32, h: u32) -> u64 {
    (1..LEVELS)
        .map(|k| u64::from(level_size(w, k)) * u64::from(level_size(h, k)))
        .sum()
}

impl VisionPass {
    pub fn new(gpu: &Gpu) -> VisionPass {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        VisionPass {
            pass: ComputePass::new(
                gpu,
                "vision",
                SOURCE,
                &[Uniform, ro, ro, ro, rw, rw, rw],
                ["means", "veil", "build_pyramid", "perceive"],
            ),
            params: gpu.uniform("vision params", std::mem::size_of::<VisionParams>() as u64),
            cells: gpu.storage("vision cells", 32),
            sources: gpu.storage("vision sources", 32),
            foveal: gpu.storage("vision foveal", 32),
            pyramid: gpu.storage("vision pyramid", 16),
            seen: gpu.storage("vision seen", 16),
            sizes: (32, 32, 32, 16, 16),
        }
    }

    /// Makes `self.seen` the `fovea.width × fovea.height` image in `image` as a person
    /// would see it (the view's foveal grid `fovea`, the other walls' `imported` sources,
    /// `efficacy` lm/W). Submits; does not wait.
    pub fn run(
        &mut self,
        gpu: &Gpu,
        image: &wgpu::Buffer,
        fovea: &Fovea,
        imported: &VeilSources,
        efficacy: f32,
    ) {
        let (w, h) = (fovea.width, fovea.height);
        let n = fovea.len() as u64;
        let grow = |size: &mut u64, buf: &mut wgpu::Buffer, want: u64, label: &str| {
            if want > *size {
                *buf = gpu.storage(label, want);
                *size = want;
            }
        };
        let (mut s0, mut s1, mut s2, mut s3, mut s4) = self.sizes;
        grow(&mut s0, &mut self.cells, 32 * n, "vision cells");
        grow(
            &mut s1,
            &mut self.sources,
            32 * (imported.0.len() as u64).max(1),
            "vision sources",
        );
        grow(&mut s2, &mut self.foveal, FOVEAL_BYTES * n, "vision foveal");
        grow(
            &mut s3,
            &mut self.pyramid,
            16 * pyramid_texels(w, h).max(1),
            "vision pyramid",
        );
        grow(
            &mut s4,
            &mut self.seen,
            16 * u64::from(w * h),
            "vision seen",
        );
        self.sizes = (s0, s1, s2, s3, s4);
        let cells: Vec<Cell> = (0..fovea.len())
            .map(|i| {
                let d = fovea.dirs[i];
                Cell {
                    dir: [d.x, d.y, d.z, fovea.omega[i]],
                    ppd: [fovea.pixels_per_degree[i], 0.0, 0.0, 0.0],
                }
            })
            .collect();
        let sources: Vec<Source> = imported
            .0
            .iter()
            .map(|s| Source {
                dir: [s.dir.x, s.dir.y, s.dir.z, 0.0],
                flux: [s.flux.x, s.flux.y, s.flux.z, 0.0],
            })
            .collect();
        let params = VisionParams {
            width: w,
            height: h,
            cols: fovea.cols,
            rows: fovea.rows,
            imported: sources.len() as u32,
            levels: LEVELS,
            efficacy,
            veil_uniform: VEIL_OF_UNIFORM_FIELD,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        gpu.queue
            .write_buffer(&self.cells, 0, bytemuck::cast_slice(&cells));
        if !sources.is_empty() {
            gpu.queue
                .write_buffer(&self.sources, 0, bytemuck::cast_slice(&sources));
        }
        let bind = self.pass.bind_group(
            gpu,
            &[
                &self.params,
                image,
                &self.cells,
                &self.sources,
                &self.foveal,
                &self.pyramid,
                &self.seen,
            ],
        );
        let groups = [
            (n as u32).div_ceil(64),
            (n as u32).div_ceil(64),
            (pyramid_texels(w, h) as u32).div_ceil(64),
        ];
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        for (k, pipe) in self.pass.pipelines.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &bind, &[]);
            match k {
                3 => pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1),
                _ => pass.dispatch_workgroups(groups[k].max(1), 1, 1),
            }
        }
        gpu.queue.submit([enc.finish()]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::with_common;
    use std::mem::{offset_of, size_of};

    #[test]
    fn vision_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(SOURCE);
        crate::gpu::layout::assert_same_layout(
            &src,
            "VisionParams",
            size_of::<VisionParams>(),
            &[
                ("width", offset_of!(VisionParams, width)),
                ("height", offset_of!(VisionParams, height)),
                ("cols", offset_of!(VisionParams, cols)),
                ("rows", offset_of!(VisionParams, rows)),
                ("imported", offset_of!(VisionParams, imported)),
                ("levels", offset_of!(VisionParams, levels)),
                ("efficacy", offset_of!(VisionParams, efficacy)),
                ("veil_uniform", offset_of!(VisionParams, veil_uniform)),
            ],
        );
        crate::gpu::layout::assert_same_layout(
            &src,
            "Cell",
            size_of::<Cell>(),
            &[
                ("dir", offset_of!(Cell, dir)),
                ("ppd", offset_of!(Cell, ppd)),
            ],
        );
        crate::gpu::layout::assert_same_layout(
            &src,
            "Source",
            size_of::<Source>(),
            &[
                ("dir", offset_of!(Source, dir)),
                ("flux", offset_of!(Source, flux)),
            ],
        );
        let foveal = crate::gpu::layout::wgsl_struct(&src, "Foveal");
        assert_eq!(u64::from(foveal.span), FOVEAL_BYTES);
    }
}
