//! The passes of `vision.wgsl`: an eye image in a GPU buffer seen as a person would see it
//! ([`crate::present::vision::perceive`] on the GPU), into another buffer that the histogram and the
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
        self.grow_buffers(gpu, fovea, imported);
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

    /// The buffers grown where `fovea` and `imported` need more than they hold.
    fn grow_buffers(&mut self, gpu: &Gpu, fovea: &Fovea, imported: &VeilSources) {
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
    }

    /// The bright foveal samples of the image last [`VisionPass::run`] on `fovea`, for the
    /// other walls' veils ([`VeilSources::export`] of the foveal means read back: 32 bytes
    /// per one-degree sample, not the frame).
    pub fn sources(&self, gpu: &Gpu, fovea: &Fovea) -> VeilSources {
        let bytes = gpu.read(&self.foveal, FOVEAL_BYTES * fovea.len() as u64);
        let cells: &[[f32; 8]] = bytemuck::cast_slice(&bytes);
        let means: Vec<glam::Vec3> = cells
            .iter()
            .map(|c| glam::Vec3::new(c[0], c[1], c[2]))
            .collect();
        VeilSources::export(fovea, &means)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::with_common;
    use crate::present::tonemap::{ToneMapper, ToneMode};
    use crate::present::vision::VeilSource;
    use glam::{Vec2, Vec3};
    use holocave_tracer::film::Image;
    use std::mem::{offset_of, size_of};

    #[test]
    fn vision_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(SOURCE);
        crate::gpu::layout::every_field!(VisionParams {
            width,
            height,
            cols,
            rows,
            imported,
            levels,
            efficacy,
            veil_uniform
        });
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
        crate::gpu::layout::every_field!(Cell { dir, ppd });
        crate::gpu::layout::assert_same_layout(
            &src,
            "Cell",
            size_of::<Cell>(),
            &[
                ("dir", offset_of!(Cell, dir)),
                ("ppd", offset_of!(Cell, ppd)),
            ],
        );
        crate::gpu::layout::every_field!(Source { dir, flux });
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

    /// A 61° × 40° view of a room-like image: a dim coloured floor of 0.001 to 1 cd/m²
    /// (colour loss and acuity at work), a fine grating, a bright window of 20 000 cd/m²
    /// (the veil), some black; and two sources from another wall.
    /// A window, gratings and dim strips, `scale` times as bright: from 1 down to 1e-7 the
    /// picture's luminance (veil included) goes through the mesopic range to the rods'
    /// grey below it. `width` is the screen's at a distance of 1: 1.2 (1.5 pixels a
    /// degree) is sharper than the eye at any light, 0.05 (35 a degree) is blurred in dim
    /// light.
    fn scene(scale: f32, width: f32) -> (Image, impl Fn(Vec2) -> Vec3, VeilSources) {
        let (w, h) = (90u32, 60u32);
        let dirs = move |p: Vec2| {
            Vec3::new(
                width * (p.x / w as f32 - 0.5),
                width * (1.0 / 3.0 - 2.0 / 3.0 * p.y / h as f32),
                -1.0,
            )
        };
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let t = ((x * 7 + y * 13) % 23) as f32 / 22.0;
                let c = if (60..80).contains(&x) && (5..25).contains(&y) {
                    Vec3::new(1.0, 0.95, 0.9) * 20000.0
                } else if y > 40 {
                    Vec3::new(0.9, 0.4, 0.2) * 10f32.powf(-3.0 + 3.0 * t)
                } else if x < 20 {
                    Vec3::splat(if x % 2 == 0 { 30.0 } else { 0.0 })
                } else if (x + y) % 11 == 0 {
                    Vec3::ZERO
                } else {
                    Vec3::new(0.3, 0.5, 0.8) * 10f32.powf(-1.0 + 2.0 * t)
                };
                img.pixels[(y * w + x) as usize] = c * scale / 179.0;
            }
        }
        let sources = VeilSources(vec![
            VeilSource {
                dir: Vec3::new(-1.0, -0.5, 0.2).normalize(),
                flux: Vec3::new(3.0, 2.5, 2.0) * scale,
            },
            VeilSource {
                dir: Vec3::new(0.3, -1.0, -0.4).normalize(),
                flux: Vec3::new(0.5, 0.5, 0.6) * scale,
            },
        ]);
        (img, dirs, sources)
    }

    #[test]
    fn the_gpu_sees_what_the_cpu_sees() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        for width in [1.2, 0.05] {
            for scale in [1.0, 1e-3, 1e-5, 1e-7] {
                gpu_equals_cpu(&gpu, scale, width);
            }
        }
    }

    fn gpu_equals_cpu(gpu: &Gpu, scale: f32, width: f32) {
        let (img, dirs, sources) = scene(scale, width);
        let cpu = crate::present::vision::perceive(&img, &dirs, &sources, 179.0);
        let fovea = Fovea::new(img.width, img.height, &dirs);
        let data: Vec<[f32; 4]> = img.pixels.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
        let buf = gpu.storage_init("image", bytemuck::cast_slice(&data));
        let mut pass = VisionPass::new(gpu);
        for _ in 0..2 {
            pass.run(gpu, &buf, &fovea, &sources, 179.0);
            let n = u64::from(img.width * img.height);
            let bytes = gpu.read(&pass.seen, 16 * n);
            let seen: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
            let mut got = Image::new(img.width, img.height);
            for (d, s) in got.pixels.iter_mut().zip(seen) {
                *d = Vec3::new(s[0], s[1], s[2]);
            }
            // The same sums in the same order; the GPU's asin, log2 and pow are not the
            // CPU's (lavapipe's are good to about 1e-4 relative). 1e-3 relative is a ninth
            // of the smallest step between 8-bit sRGB codes (254 to 255: 0.9% in linear).
            for (i, (g, c)) in got.pixels.iter().zip(&cpu.image.pixels).enumerate() {
                let tol = 1e-3 * c.max_element() + 1e-9;
                assert!(
                    (*g - *c).abs().max_element() <= tol,
                    "pixel {i}: GPU {g}, CPU {c}"
                );
            }
            // Tone-mapped, the pictures are the same within one 8-bit step.
            let mut tone = ToneMapper::new(ToneMode::Human);
            assert!(tone.update(&cpu.image, true));
            let (a, b) = (tone.apply(&cpu.image), tone.apply(&got));
            let d = a
                .pixels()
                .zip(b.pixels())
                .flat_map(|(p, q)| (0..3).map(move |k| p[k].abs_diff(q[k])))
                .max()
                .unwrap();
            assert!(d <= 1, "{d} 8-bit steps apart");
            // The sources shared with other walls: the same samples, the same flux.
            let shared = pass.sources(gpu, &fovea);
            assert_eq!(shared.0.len(), cpu.sources.0.len());
            assert!(!shared.0.is_empty(), "the window is a source");
            for (g, c) in shared.0.iter().zip(&cpu.sources.0) {
                assert_eq!(g.dir, c.dir);
                assert!((g.flux - c.flux).abs().max_element() <= 1e-5 * c.flux.max_element());
            }
        }
    }
}
