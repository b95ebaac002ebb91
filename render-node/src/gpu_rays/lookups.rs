//! The light field's lookups read from the wall's first hits on the GPU
//! (`lookups.wgsl` beside this file): where a pixel's point is its first hit on an element
//! (the common pixel: no mirror, glass, glossy tile or moving object on the way) and its
//! material is shaded there ([`SceneSurfaces`]), the lookup's element and barycentrics come
//! from the hit kept there and its weight from the surface's albedo towards the pixel's
//! ray, and the CPU sends only the emitted light it computed (the per-pixel direct light's
//! running mean among it): 16 bytes instead of the lookup's 64. Other pixels' lookups are
//! sent whole.
//!
//! The composed lookups are the CPU's bit for bit but for the weight, which is the CPU's
//! within the float bound of the material data's operations (`surfaces.rs`): a pixel is
//! composed only where the CPU's lookup is what the kernel writes from that hit, its
//! weight the surface's own albedo over π (not scaled by an edge's share or by moving
//! objects' shade) ([`split`]).

use bytemuck::{Pod, Zeroable};
use holocave_scene::{Hit, Scene};
use holocave_vlf::{DirectPoint, Elements, Lookup};
use rayon::prelude::*;

use super::surfaces::SceneSurfaces;
use super::{KeptHits, dispatch, grid};
use crate::gpu::{Binding, ComputePass, Gpu};

/// `Shade` in the shader: what the CPU sends of a pixel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Shade {
    pub emitted: [f32; 3],
    /// The side of the triangle seen (0 front, 1 back) where the lookup is composed on
    /// the GPU; `2 + k` where it is the `k`-th of those sent whole.
    pub tag: u32,
}

/// `LookupParams` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LookupParams {
    count: u32,
    row: u32,
    pad: [u32; 2],
}

/// What each pixel sends, given its CPU lookup `l`, its point and its first hit: its
/// shade, and its whole lookup where the GPU cannot compose it from the hit.
fn shade_of(
    elements: &Elements,
    surfaces: &SceneSurfaces,
    l: &Lookup,
    point: Option<&DirectPoint>,
    hit: Option<&Hit>,
) -> Result<Shade, Lookup> {
    let (Some(p), Some(h)) = (point, hit) else {
        return Err(*l);
    };
    let Some(cells) = elements.triangles.get(h.triangle as usize) else {
        return Err(*l);
    };
    let side = (0..2).find(|&s| cells.base(s) == l.base);
    let composed = Lookup {
        base: l.base,
        res: cells.res,
        u: h.u,
        v: h.v,
        weight: l.weight,
        emitted: l.emitted,
        ..Lookup::NONE
    };
    let own_weight = l.weight == (p.albedo * std::f32::consts::FRAC_1_PI).to_array();
    match side {
        Some(side)
            if p.triangle == h.triangle
                && composed == *l
                && l.base != u32::MAX
                && own_weight
                && surfaces.shades(h) =>
        {
            Ok(Shade {
                emitted: l.emitted,
                tag: side,
            })
        }
        _ => Err(*l),
    }
}

/// Each pixel's shade, and the lookups sent whole (the shades index them), from the CPU's
/// `lookups`, the pixels' `points` and their first `hits`.
pub fn split(
    elements: &Elements,
    surfaces: &SceneSurfaces,
    lookups: &[Lookup],
    points: &[Option<DirectPoint>],
    hits: &[Option<Hit>],
) -> (Vec<Shade>, Vec<Lookup>) {
    let each: Vec<Result<Shade, Lookup>> = (lookups.par_iter().zip(points).zip(hits))
        .map(|((l, p), h)| shade_of(elements, surfaces, l, p.as_ref(), h.as_ref()))
        .collect();
    let mut sent = Vec::new();
    let shades = each
        .into_iter()
        .map(|s| {
            s.unwrap_or_else(|l| {
                sent.push(l);
                Shade {
                    emitted: [0.0; 3],
                    tag: 2 + sent.len() as u32 - 1,
                }
            })
        })
        .collect();
    (shades, sent)
}

/// The composer of one scene's lookups (its element table and surfaces on the GPU).
pub struct LookupComposer {
    pass: ComputePass<1>,
    params: wgpu::Buffer,
    cells: wgpu::Buffer,
    pub surfaces: SceneSurfaces,
    shades: wgpu::Buffer,
    sent: wgpu::Buffer,
}

impl LookupComposer {
    /// The composer of `scene`'s lookups over `elements`; `None`, with a warning that says
    /// why, where the adapter cannot bind what the pass reads.
    pub fn new(gpu: &Gpu, elements: &Elements, scene: &Scene) -> Option<LookupComposer> {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, ro, ro, ro, rw, ro, ro, ro, ro, ro, ro, ro];
        let storage = (bindings.iter())
            .filter(|b| matches!(b, Storage { .. }))
            .count() as u32;
        let most = gpu.device.limits().max_storage_buffers_per_shader_stage;
        if storage > most {
            tracing::warn!(
                "the light field's lookups sent whole: composing them on the GPU binds \
                 {storage} storage buffers, the adapter at most {most}"
            );
            return None;
        }
        let surfaces = SceneSurfaces::new(gpu, scene)?;
        let cells: Vec<[u32; 2]> = (elements.triangles.iter())
            .map(|c| [c.offset, c.res])
            .collect();
        let cells = gpu.storage_init(
            "gpu lookups: elements per triangle",
            bytemuck::cast_slice(if cells.is_empty() { &[[0; 2]] } else { &cells }),
        );
        Some(LookupComposer {
            pass: ComputePass::new(
                gpu,
                "gpu lookups",
                &format!(
                    "{}\n{}",
                    include_str!("surfaces.wgsl"),
                    include_str!("lookups.wgsl")
                ),
                &bindings,
                ["compose"],
            ),
            params: gpu.uniform(
                "gpu lookups: params",
                std::mem::size_of::<LookupParams>() as u64,
            ),
            cells,
            surfaces,
            shades: gpu.storage("gpu lookups: shades", 16),
            sent: gpu.storage("gpu lookups: sent whole", 64),
        })
    }

    /// Writes each pixel's lookup into `target` (the render cache's lookups of the eye,
    /// sixteen words a pixel): composed from its first hit in `hits`, or copied from
    /// `sent` ([`split`]).
    pub fn compose(
        &mut self,
        gpu: &Gpu,
        hits: &KeptHits,
        shades: &[Shade],
        sent: &[Lookup],
        target: &wgpu::Buffer,
    ) {
        let n = shades.len() as u32;
        assert_eq!(n, hits.pixels, "one shade per pixel of the wall");
        if n == 0 {
            return;
        }
        let fit = |buffer: &mut wgpu::Buffer, bytes: u64, label| {
            if buffer.size() < bytes {
                *buffer = gpu.storage(label, bytes);
            }
        };
        fit(&mut self.shades, 16 * u64::from(n), "gpu lookups: shades");
        fit(
            &mut self.sent,
            64 * sent.len() as u64,
            "gpu lookups: sent whole",
        );
        gpu.queue
            .write_buffer(&self.shades, 0, bytemuck::cast_slice(shades));
        if !sent.is_empty() {
            gpu.queue
                .write_buffer(&self.sent, 0, bytemuck::cast_slice(sent));
        }
        let (_, _, row) = grid(n);
        let params = LookupParams {
            count: n,
            row,
            pad: [0; 2],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let [s0, s1, s2, s3, s4, s5] = &self.surfaces.buffers;
        let bind = self.pass.bind_group(
            gpu,
            &[
                &self.params,
                &self.cells,
                &hits.buffer,
                &self.shades,
                &self.sent,
                target,
                s0,
                s1,
                s2,
                s3,
                s4,
                s5,
                &hits.rays,
            ],
        );
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        dispatch(&mut enc, &self.pass.pipelines[0], &bind, n);
        gpu.queue.submit([enc.finish()]);
    }
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;

    #[test]
    fn the_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(&format!(
            "{}\n{}",
            include_str!("surfaces.wgsl"),
            include_str!("lookups.wgsl")
        ));
        every_field!(Shade { emitted, tag });
        assert_same_layout(
            &src,
            "Shade",
            size_of::<Shade>(),
            &[
                ("emitted", offset_of!(Shade, emitted)),
                ("tag", offset_of!(Shade, tag)),
            ],
        );
        every_field!(LookupParams { count, row, pad });
        let pad = offset_of!(LookupParams, pad);
        assert_same_layout(
            &src,
            "LookupParams",
            size_of::<LookupParams>(),
            &[
                ("count", offset_of!(LookupParams, count)),
                ("row", offset_of!(LookupParams, row)),
                ("pad0", pad),
                ("pad1", pad + 4),
            ],
        );
    }
}
