//! The light field's lookups read from the wall's first hits on the GPU
//! (`lookups.wgsl` beside this file): where a pixel's point is its first hit on an element
//! (the common pixel: no mirror, glass, glossy tile or moving object on the way), the
//! lookup's element and barycentrics come from the hit kept there, and the CPU sends only
//! the emitted light it computed (the per-pixel direct light's running mean among it):
//! 16 bytes instead of the lookup's 64. The weight comes from the surface's albedo towards
//! the pixel's ray where its material is shaded there ([`SceneSurfaces`]) and the weight
//! is the surface's own (not scaled by an edge's share or by moving objects' shade);
//! elsewhere the CPU sends it too (16 bytes more). Other pixels' lookups are sent whole.
//!
//! The composed lookups are the CPU's bit for bit but for the weights made on the GPU,
//! which are the CPU's within the float bound of the material data's operations
//! (`surfaces.rs`): a pixel is composed only where the CPU's lookup is what the kernel
//! writes from that hit ([`split`]).

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
    /// How the GPU writes the pixel's lookup: composed from its hit with the weight from
    /// the material data, `side` (the side of the triangle seen: 0 front, 1 back);
    /// composed with the `k`-th weight the CPU sent, `WEIGHT_SENT | k << 1 | side`; or
    /// the `k`-th lookup sent whole, `WHOLE | k`.
    pub tag: u32,
}

/// `WEIGHT_SENT` in the shader.
const WEIGHT_SENT: u32 = 1 << 30;
/// `WHOLE` in the shader.
const WHOLE: u32 = 1 << 31;

/// `LookupParams` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct LookupParams {
    count: u32,
    row: u32,
    pad: [u32; 2],
}

/// How the GPU can write one pixel's lookup.
enum Written {
    /// Composed from its hit, the weight from the material data: the side seen.
    WeighedHere(u32),
    /// Composed from its hit with the CPU's weight: the side seen.
    WeightSent(u32),
    /// Copied from the lookup sent whole.
    Whole,
}

/// How the GPU writes the lookup `l` of a pixel whose point and first hit are `point` and
/// `hit`: composed where `l` is exactly what the kernel writes from that hit but for the
/// weight, and with its own weight where that is the surface's albedo over π (not scaled
/// by an edge's share or moving objects' shade) and the material's table is on the GPU.
fn written(
    elements: &Elements,
    surfaces: &SceneSurfaces,
    l: &Lookup,
    point: Option<&DirectPoint>,
    hit: Option<&Hit>,
) -> Written {
    let (Some(p), Some(h)) = (point, hit) else {
        return Written::Whole;
    };
    let Some(cells) = elements.triangles.get(h.triangle as usize) else {
        return Written::Whole;
    };
    let composed = Lookup {
        base: l.base,
        res: cells.res,
        u: h.u,
        v: h.v,
        weight: l.weight,
        emitted: l.emitted,
        ..Lookup::NONE
    };
    let side = (0..2).find(|&s| cells.base(s) == l.base);
    match side {
        Some(side) if p.triangle == h.triangle && composed == *l && l.base != u32::MAX => {
            let own = l.weight == (p.albedo * std::f32::consts::FRAC_1_PI).to_array();
            if own && surfaces.shades(h) {
                Written::WeighedHere(side)
            } else {
                Written::WeightSent(side)
            }
        }
        _ => Written::Whole,
    }
}

/// What the CPU sends of a wall's lookups for [`LookupComposer::compose`].
pub struct Split {
    /// One a pixel.
    pub shades: Vec<Shade>,
    /// The weights of the pixels composed with the CPU's weight (`w` unused).
    pub weights: Vec<[f32; 4]>,
    /// The lookups sent whole.
    pub whole: Vec<Lookup>,
}

impl Split {
    /// How many pixels take their weight from the material data on the GPU.
    pub fn weighed_here(&self) -> usize {
        self.shades.len() - self.weights.len() - self.whole.len()
    }
}

/// What the CPU sends of each pixel, from its `lookups`, the pixels' `points` and their
/// first `hits`.
pub fn split(
    elements: &Elements,
    surfaces: &SceneSurfaces,
    lookups: &[Lookup],
    points: &[Option<DirectPoint>],
    hits: &[Option<Hit>],
) -> Split {
    let each: Vec<Written> = (lookups.par_iter().zip(points).zip(hits))
        .map(|((l, p), h)| written(elements, surfaces, l, p.as_ref(), h.as_ref()))
        .collect();
    let (mut weights, mut whole) = (Vec::new(), Vec::new());
    let shades = (each.into_iter().zip(lookups))
        .map(|(w, l)| {
            let tag = match w {
                Written::WeighedHere(side) => side,
                Written::WeightSent(side) => {
                    weights.push([l.weight[0], l.weight[1], l.weight[2], 0.0]);
                    WEIGHT_SENT | (weights.len() as u32 - 1) << 1 | side
                }
                Written::Whole => {
                    whole.push(*l);
                    WHOLE | (whole.len() as u32 - 1)
                }
            };
            Shade {
                emitted: l.emitted,
                tag,
            }
        })
        .collect();
    Split {
        shades,
        weights,
        whole,
    }
}

/// The composer of one scene's lookups (its element table and surfaces on the GPU).
pub struct LookupComposer {
    pass: ComputePass<1>,
    params: wgpu::Buffer,
    cells: wgpu::Buffer,
    pub surfaces: SceneSurfaces,
    shades: wgpu::Buffer,
    weights: wgpu::Buffer,
    whole: wgpu::Buffer,
}

impl LookupComposer {
    /// The composer of `scene`'s lookups over `elements`; `None`, with a warning that says
    /// why, where the adapter cannot bind what the pass reads.
    pub fn new(gpu: &Gpu, elements: &Elements, scene: &Scene) -> Option<LookupComposer> {
        use Binding::{Storage, Uniform};
        let (ro, rw) = (Storage { read_only: true }, Storage { read_only: false });
        let bindings = [Uniform, ro, ro, ro, ro, rw, ro, ro, ro, ro, ro, ro, ro, ro];
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
            weights: gpu.storage("gpu lookups: weights sent", 16),
            whole: gpu.storage("gpu lookups: sent whole", 64),
        })
    }

    /// Writes each pixel's lookup into `target` (the render cache's lookups of the eye,
    /// sixteen words a pixel) as `split` says: composed from its first hit in `hits`, or
    /// copied from the lookups sent whole ([`split`]).
    pub fn compose(&mut self, gpu: &Gpu, hits: &KeptHits, split: &Split, target: &wgpu::Buffer) {
        let n = split.shades.len() as u32;
        assert_eq!(n, hits.pixels, "one shade per pixel of the wall");
        if n == 0 {
            return;
        }
        let fill = |buffer: &mut wgpu::Buffer, bytes: &[u8], label| {
            if buffer.size() < bytes.len() as u64 {
                *buffer = gpu.storage(label, bytes.len() as u64);
            }
            if !bytes.is_empty() {
                gpu.queue.write_buffer(buffer, 0, bytes);
            }
        };
        let shades = bytemuck::cast_slice(&split.shades);
        fill(&mut self.shades, shades, "gpu lookups: shades");
        let weights = bytemuck::cast_slice(&split.weights);
        fill(&mut self.weights, weights, "gpu lookups: weights sent");
        let whole = bytemuck::cast_slice(&split.whole);
        fill(&mut self.whole, whole, "gpu lookups: sent whole");
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
                &self.whole,
                target,
                s0,
                s1,
                s2,
                s3,
                s4,
                s5,
                &hits.rays,
                &self.weights,
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
