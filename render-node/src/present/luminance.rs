//! The pipelines of `luminance.wgsl`: an eye image's log-luminance histogram made where the
//! image lies, so a window's tone mapping reads back a few hundred bytes, not the frame.

use bytemuck::{Pod, Zeroable};

use crate::gpu::{Binding, ComputePass, Gpu};
use crate::present::tonemap::{LogHistogram, TONE_BINS};

/// `MAX_BINS` in the shader.
const _: () = assert!(TONE_BINS <= 128);

/// The shader (compiled after `common.wgsl`: `gpu::with_common`).
const SOURCE: &str = include_str!("luminance.wgsl");

/// `@workgroup_size` of both entry points.
const WORKGROUP: u32 = 64;
/// Pixels per invocation (`CHUNK` in the shader).
const CHUNK: u32 = 256;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct LumParams {
    n: u32,
    bins: u32,
    efficacy: f32,
    pad: u32,
}

/// Makes [`LogHistogram`]s of images in GPU buffers (`vec4<f32>` per pixel).
pub struct Histogrammer {
    pass: ComputePass<2>,
    params: wgpu::Buffer,
    stats: wgpu::Buffer,
    partial: wgpu::Buffer,
    hist: wgpu::Buffer,
    /// Pixels the partial sums have room for.
    capacity: u32,
}

impl Histogrammer {
    pub fn new(gpu: &Gpu) -> Histogrammer {
        use Binding::{Storage, Uniform};
        let rw = Storage { read_only: false };
        let pass = ComputePass::new(
            gpu,
            "luminance",
            SOURCE,
            &[Uniform, Storage { read_only: true }, rw, rw, rw],
            ["reduce", "histogram"],
        );
        Histogrammer {
            pass,
            params: gpu.uniform("luminance params", 16),
            stats: gpu.storage("luminance stats", 16),
            partial: gpu.storage("luminance partial sums", 4),
            hist: gpu.storage("luminance histogram", 4 * TONE_BINS as u64),
            capacity: 0,
        }
    }

    /// The histogram of the `n` pixels in `image` at `efficacy` lm/W (None when none is
    /// above black).
    pub fn histogram(
        &mut self,
        gpu: &Gpu,
        image: &wgpu::Buffer,
        n: u32,
        efficacy: f32,
    ) -> Option<LogHistogram> {
        let invocations = n.div_ceil(CHUNK).max(1);
        let groups = invocations.div_ceil(WORKGROUP);
        if n > self.capacity {
            self.partial = gpu.storage("luminance partial sums", 4 * u64::from(invocations));
            self.capacity = invocations * CHUNK;
        }
        let params = LumParams {
            n,
            bins: TONE_BINS as u32,
            efficacy,
            pad: 0,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        gpu.queue.write_buffer(
            &self.stats,
            0,
            bytemuck::cast_slice(&[u32::MAX, 0u32, 0, 0]),
        );
        let bind = self.pass.bind_group(
            gpu,
            &[&self.params, image, &self.stats, &self.partial, &self.hist],
        );
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.hist, 0, None);
        for pipe in &self.pass.pipelines {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        gpu.queue.submit([enc.finish()]);
        let stats: Vec<u32> = bytemuck::cast_slice(&gpu.read(&self.stats, 16)).to_vec();
        let count = *stats.get(2)?;
        if count == 0 {
            return None;
        }
        let partial: Vec<f32> =
            bytemuck::cast_slice(&gpu.read(&self.partial, 4 * u64::from(invocations))).to_vec();
        let hist: Vec<u32> =
            bytemuck::cast_slice(&gpu.read(&self.hist, 4 * TONE_BINS as u64)).to_vec();
        let unkey = |k: u32| {
            if k & 0x8000_0000 != 0 {
                f32::from_bits(k & 0x7fff_ffff)
            } else {
                f32::from_bits(!k)
            }
        };
        let log_min = unkey(stats[0]);
        let sum: f64 = partial.iter().map(|&s| f64::from(s)).sum();
        Some(LogHistogram {
            log_min,
            log_max: unkey(stats[1]).max(log_min + 1e-3),
            log_mean: (sum / f64::from(count)) as f32,
            count: u64::from(count),
            bins: hist.iter().map(|&c| c as f32).collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use holocave_tracer::film::Image;

    #[test]
    fn luminance_wgsl_params_are_laid_out_as_in_rust() {
        use std::mem::{offset_of, size_of};
        crate::gpu::layout::every_field!(LumParams {
            n,
            bins,
            efficacy,
            pad
        });
        crate::gpu::layout::assert_same_layout(
            &crate::gpu::with_common(SOURCE),
            "LumParams",
            size_of::<LumParams>(),
            &[
                ("n", offset_of!(LumParams, n)),
                ("bins", offset_of!(LumParams, bins)),
                ("efficacy", offset_of!(LumParams, efficacy)),
                ("_pad", offset_of!(LumParams, pad)),
            ],
        );
    }

    #[test]
    fn the_gpu_histogram_is_the_cpu_one() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        let mut h = Histogrammer::new(&gpu);
        // 1000 pixels (not a multiple of the workgroup) over six decades, some black, one
        // infinite.
        let mut img = Image::new(40, 25);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            // Irrational steps: few pixels on a bin edge.
            let t = (i as f32 * 0.618_034).fract();
            *p = Vec3::new(1.0, 0.7, 0.4) * 10f32.powf(-2.0 + 6.0 * t) / 179.0;
            if i % 17 == 0 {
                *p = Vec3::ZERO;
            }
        }
        img.pixels[5] = Vec3::splat(f32::INFINITY);
        let data: Vec<[f32; 4]> = img.pixels.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
        let buf = gpu.storage_init("image", bytemuck::cast_slice(&data));
        let cpu = LogHistogram::of_image(&img, 179.0).unwrap();
        for _ in 0..2 {
            let g = h.histogram(&gpu, &buf, 1000, 179.0).unwrap();
            assert_eq!(g.count, cpu.count);
            assert!((g.log_min - cpu.log_min).abs() < 1e-5, "{g:?}\n{cpu:?}");
            assert!((g.log_max - cpu.log_max).abs() < 1e-5);
            assert!((g.log_mean - cpu.log_mean).abs() < 1e-4);
            // A pixel on a bin edge may land in the neighbouring bin (log2 × constant on
            // the GPU, log10 on the CPU): at most a few move.
            let moved: f32 = g
                .bins
                .iter()
                .zip(&cpu.bins)
                .map(|(a, b)| (a - b).abs())
                .sum();
            assert!(moved <= 4.0, "{moved} pixels in other bins");
            assert_eq!(g.bins.iter().sum::<f32>(), cpu.count as f32);
        }
        // A black image: no histogram.
        let black = gpu.storage_init("black", bytemuck::cast_slice(&vec![[0f32; 4]; 300]));
        assert!(h.histogram(&gpu, &black, 300, 179.0).is_none());
    }
}

#[cfg(test)]
mod timing {
    use super::*;
    use glam::Vec3;
    use holocave_tracer::film::Image;

    /// Not a check: prints what the GPU histogram and the CPU one (read-back included)
    /// cost for a 1024x768 image (`cargo test --release -p holocave-render-node --lib
    /// luminance_timing -- --ignored --nocapture`).
    #[test]
    #[ignore]
    fn luminance_timing() {
        let gpu = Gpu::new().unwrap();
        let mut h = Histogrammer::new(&gpu);
        let n = 1024 * 768;
        let data: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let v = 10f32.powf(-2.0 + 6.0 * (i as f32 * 0.618_034).fract()) / 179.0;
                [v, v * 0.8, v * 0.5, 1.0]
            })
            .collect();
        let buf = gpu.storage_init("image", bytemuck::cast_slice(&data));
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let g = h.histogram(&gpu, &buf, n as u32, 179.0).unwrap();
            let gpu_ms = t.elapsed().as_secs_f64() * 1e3;
            let t = std::time::Instant::now();
            let bytes = gpu.read(&buf, 16 * n as u64);
            let px: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
            let mut img = Image::new(1024, 768);
            for (d, s) in img.pixels.iter_mut().zip(px) {
                *d = Vec3::new(s[0], s[1], s[2]);
            }
            let c = LogHistogram::of_image(&img, 179.0).unwrap();
            let cpu_ms = t.elapsed().as_secs_f64() * 1e3;
            assert_eq!(g.count, c.count);
            println!("GPU histogram {gpu_ms:.1} ms, read-back + CPU histogram {cpu_ms:.1} ms");
        }
    }
}
