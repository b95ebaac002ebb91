//! Shadow rays made on the GPU (`shadow.wgsl` beside this file): the per-pixel direct
//! light's rays, made from each pixel's first hit where the wall's closest-hit pass left
//! it, so that the hits never cross the bus — only each pixel's [`MadeRays`] (20 bytes),
//! the aims of the rays the CPU chose (16 bytes each) and the answers (a bit a ray).
//!
//! The rays are the CPU's ([`holocave_vlf::pixel_direct`]) made again: the point from the
//! triangle's vertices and the hit's barycentrics (`surface_point`'s operations), or
//! those the CPU sends where it moved the pixel's estimate within the pixel, the
//! offset off the surface (`leave_surface`), the segment to a light point (`segment_ray`)
//! or the ray to infinity. Towards the punctual lights and the sun's disc the GPU makes
//! the whole ray: the sun's sample `k` of the pixel's R2 sequence from its fixed-point
//! form ([`holocave_vlf::sun_sequence`]: within two float steps at 1 of the CPU's f64
//! sample), mapped into the disc by `uniform_cone` in the sun's frame, both computed on
//! the CPU; nothing but which samples crosses the bus. The GPU's `sin`, `cos` and `sqrt`
//! are not correctly rounded, and it may fuse multiply-adds: a made ray's direction
//! differs from the CPU's by a few float steps, which moves its answer only where it
//! grazes an edge, as a ray the CPU makes and the GPU walks may (`tests/gpu_rays.rs`
//! counts them).
//!
//! Area lamps' and the sky's samples are drawn on the CPU: their distributions depend on
//! the point (the emitters weighed by what each can send to it) or follow the sky's
//! luminance, and the CPU needs the sample it drew to shade with it (the BSDF, the
//! emitted light, the densities). Made again on the GPU, a distribution's step crossed by
//! rounding would name another lamp or direction, not a ray a float step away. So the CPU
//! sends each such sample's [`Aim`] — its direction and distance from the point, 16 bytes
//! where a whole ray is 32 — and the GPU makes the ray from its own hit, in the same pass
//! as the rest: a pixel that sees its first hit sends none of its rays whole.

use bytemuck::{Pod, Zeroable};
use holocave_scene::{PunctualKind, Scene};
use holocave_tracer::frame::Frame;
use holocave_vlf::{Aim, MadeRays, sun_sequence};

use super::{GpuRays, KeptHits, dispatch, grid, read_back, source_with};
use crate::gpu::{Binding, ComputePass, Gpu};

/// Punctual lights whose rays the GPU makes (`MAX_LIGHTS` in the shader); a scene with
/// more has all its shadow rays made on the CPU.
pub const MAX_MADE_LIGHTS: usize = 24;

/// `MadeLight` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MadeLight {
    position_kind: [f32; 4],
    direction: [f32; 4],
}

/// `ShadowParams` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ShadowParams {
    count: u32,
    row: u32,
    lights: u32,
    sun: u32,
    sun_t: [f32; 4],
    sun_b: [f32; 4],
    sun_n: [f32; 4],
    step: [u32; 4],
    light: [MadeLight; MAX_MADE_LIGHTS],
}

/// The shadow-ray maker of one scene, over a [`GpuRays`] engine's tree.
pub struct ShadowMaker {
    pass: ComputePass<1>,
    params: wgpu::Buffer,
    /// The scene's lights as the shader reads them (`count` and `row` set per batch).
    lights: ShadowParams,
    faces: wgpu::Buffer,
    tasks: wgpu::Buffer,
    /// The aims of a batch's rays chosen on the CPU, and how many it has room for.
    aims: wgpu::Buffer,
    aim_capacity: usize,
    shifts: wgpu::Buffer,
    masks: wgpu::Buffer,
    receive: wgpu::Buffer,
    /// Pixels the per-pixel buffers hold (the shifts of all of them uploaded).
    capacity: u32,
}

impl ShadowMaker {
    /// The maker of `scene`'s shadow rays over `engine`'s upload of its tree; `None` for a
    /// scene with more than [`MAX_MADE_LIGHTS`] punctual lights.
    pub fn new(gpu: &Gpu, engine: &GpuRays, scene: &Scene) -> Option<ShadowMaker> {
        let sun = scene.daylight.sun.as_ref();
        if scene.lights.len() > MAX_MADE_LIGHTS {
            return None;
        }
        let v4 = |v: glam::Vec3, w: f32| [v.x, v.y, v.z, w];
        let mut lights = ShadowParams::zeroed();
        lights.lights = scene.lights.len() as u32;
        for (slot, l) in lights.light.iter_mut().zip(&scene.lights) {
            let directional = matches!(l.kind, PunctualKind::Directional);
            slot.position_kind = v4(l.position, if directional { 1.0 } else { 0.0 });
            slot.direction = v4(l.direction, 0.0);
        }
        if let Some(s) = sun {
            let f = Frame::new(s.direction);
            lights.sun = 1;
            (lights.sun_t, lights.sun_b) = (v4(f.t, 0.0), v4(f.b, 0.0));
            lights.sun_n = v4(f.n, s.one_minus_cos_radius());
        }
        let step = sun_sequence(0).step;
        let words = |s: u64| [(s >> 32) as u32, s as u32];
        let ([h0, l0], [h1, l1]) = (words(step[0]), words(step[1]));
        lights.step = [h0, l0, h1, l1];
        let faces: Vec<[f32; 12]> = (0..scene.triangle_count() as u32)
            .map(|t| {
                let [p0, p1, p2] = *scene.triangle(t);
                let n = scene.face_normal(t);
                let mut f = [0.0; 12];
                f[..4].copy_from_slice(&v4(p0, n.x));
                f[4..8].copy_from_slice(&v4(p1, n.y));
                f[8..].copy_from_slice(&v4(p2, n.z));
                f
            })
            .collect();
        let faces = gpu.storage_init(
            "gpu rays: faces",
            bytemuck::cast_slice(if faces.is_empty() {
                &[[0.0; 12]]
            } else {
                &faces
            }),
        );
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let pass = ComputePass::new(
            gpu,
            "gpu rays: made shadow rays",
            &source_with(
                engine.stack_size(),
                &format!(
                    "const MAX_LIGHTS: u32 = {MAX_MADE_LIGHTS}u;\n{}",
                    include_str!("shadow.wgsl")
                ),
            ),
            &[Uniform, ro, ro, ro, rw, ro, ro, ro, ro],
            ["made_shadow_rays"],
        );
        let params = gpu.uniform(
            "gpu rays: shadow params",
            std::mem::size_of::<ShadowParams>() as u64,
        );
        // Room for no pixel yet: the first batch makes it ([`Self::reserve`]).
        let (tasks, shifts, masks, receive) = per_pixel_buffers(gpu, 1);
        Some(ShadowMaker {
            pass,
            params,
            lights,
            faces,
            tasks,
            aims: aims_buffer(gpu, 1),
            aim_capacity: 1,
            shifts,
            masks,
            receive,
            capacity: 0,
        })
    }

    /// Room for `n` pixels, the sun's shifts of each uploaded.
    fn reserve(&mut self, gpu: &Gpu, n: u32) {
        if n <= self.capacity {
            return;
        }
        (self.tasks, self.shifts, self.masks, self.receive) = per_pixel_buffers(gpu, n);
        let shifts: Vec<[u32; 2]> = (0..u64::from(n)).map(|i| sun_sequence(i).shift).collect();
        gpu.queue
            .write_buffer(&self.shifts, 0, bytemuck::cast_slice(&shifts));
        self.capacity = n;
    }

    /// Whether the static scene blocks each pixel's made rays (`rays`, one a pixel of the
    /// wall whose first hits `hits` holds; `aims`, those of all pixels): bit `i` for
    /// punctual light `i`, bit `P + j` for the sun's sample `first_sun + j`, bit `P + S +
    /// a` for the pixel's aim `first_aim + a` (`S` its sun samples).
    pub fn trace(
        &mut self,
        gpu: &Gpu,
        engine: &GpuRays,
        hits: &KeptHits,
        rays: &[MadeRays],
        aims: &[Aim],
    ) -> Vec<u32> {
        let n = rays.len() as u32;
        assert_eq!(n, hits.pixels, "one made ray set per pixel of the wall");
        if n == 0 {
            return Vec::new();
        }
        self.reserve(gpu, n);
        let tasks: Vec<[u32; 5]> = rays
            .iter()
            .map(|m| {
                let counts = m.suns.min(0xff)
                    | (u32::from(m.punctual) << 8)
                    | (u32::from(m.at.is_some()) << 9);
                let [u, v] = m.at.unwrap_or_default().map(f32::to_bits);
                [
                    m.first_sun,
                    counts | (m.aimed.min(0xff) << 16),
                    m.first_aim,
                    u,
                    v,
                ]
            })
            .collect();
        gpu.queue
            .write_buffer(&self.tasks, 0, bytemuck::cast_slice(&tasks));
        if aims.len() > self.aim_capacity {
            self.aims = aims_buffer(gpu, aims.len());
            self.aim_capacity = aims.len();
        }
        if !aims.is_empty() {
            let aims: Vec<[f32; 4]> = aims
                .iter()
                .map(|a| [a.dir.x, a.dir.y, a.dir.z, a.dist])
                .collect();
            gpu.queue
                .write_buffer(&self.aims, 0, bytemuck::cast_slice(&aims));
        }
        let (_, _, row) = grid(n);
        let params = ShadowParams {
            count: n,
            row,
            ..self.lights
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let bind = self.pass.bind_group(
            gpu,
            &[
                &self.params,
                &engine.nodes,
                &engine.triangles,
                &self.faces,
                &self.masks,
                &hits.buffer,
                &self.tasks,
                &self.shifts,
                &self.aims,
            ],
        );
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        dispatch(&mut enc, &self.pass.pipelines[0], &bind, n);
        let bytes = 4 * u64::from(n);
        read_back(
            gpu,
            enc,
            &self.masks,
            &self.receive,
            bytes,
            |&[m]: &[u32; 1]| m,
        )
        .unwrap_or_else(|e| {
            tracing::warn!("gpu rays: the made shadow rays' answers did not map: {e}");
            // A lost device: every made ray blocked, as a lost device draws black.
            vec![u32::MAX; n as usize]
        })
    }
}

/// The per-pixel buffers for `n` pixels: tasks, shifts, masks, and the masks' read-back.
fn per_pixel_buffers(
    gpu: &Gpu,
    n: u32,
) -> (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer, wgpu::Buffer) {
    let n = u64::from(n.max(1));
    (
        gpu.storage("gpu rays: made shadow rays' tasks", 20 * n),
        gpu.storage("gpu rays: the sun's shifts", 8 * n),
        gpu.storage("gpu rays: made shadow rays' answers", 4 * n),
        gpu.read_back_buffer("gpu rays: made shadow rays' answers back", 4 * n),
    )
}

/// Room for `n` aims (16 bytes each).
fn aims_buffer(gpu: &Gpu, n: usize) -> wgpu::Buffer {
    gpu.storage(
        "gpu rays: the aims of rays chosen on the CPU",
        16 * n.max(1) as u64,
    )
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;

    #[test]
    fn the_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(&source_with(
            8,
            &format!(
                "const MAX_LIGHTS: u32 = {MAX_MADE_LIGHTS}u;\n{}",
                include_str!("shadow.wgsl")
            ),
        ));
        every_field!(MadeLight {
            position_kind,
            direction
        });
        assert_same_layout(
            &src,
            "MadeLight",
            size_of::<MadeLight>(),
            &[
                ("position_kind", offset_of!(MadeLight, position_kind)),
                ("direction", offset_of!(MadeLight, direction)),
            ],
        );
        every_field!(ShadowParams {
            count,
            row,
            lights,
            sun,
            sun_t,
            sun_b,
            sun_n,
            step,
            light
        });
        assert_same_layout(
            &src,
            "ShadowParams",
            size_of::<ShadowParams>(),
            &[
                ("count", offset_of!(ShadowParams, count)),
                ("row", offset_of!(ShadowParams, row)),
                ("lights", offset_of!(ShadowParams, lights)),
                ("sun", offset_of!(ShadowParams, sun)),
                ("sun_t", offset_of!(ShadowParams, sun_t)),
                ("sun_b", offset_of!(ShadowParams, sun_b)),
                ("sun_n", offset_of!(ShadowParams, sun_n)),
                ("step", offset_of!(ShadowParams, step)),
                ("light", offset_of!(ShadowParams, light)),
            ],
        );
    }
}
