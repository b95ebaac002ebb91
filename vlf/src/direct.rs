//! Direct light from the lights that are far smaller than the direction spacing — area
//! emitters, punctual lights and the sun — by next-event estimation with the tracer's
//! light sampling: `samples` stratified points in each element, one sample of each kind
//! of light and one shadow ray per point. The sky is not sampled here: it is as large as
//! the sphere of directions, and the lines carry it (`propagate`). A glossy element's
//! samples also go into its tile: each adds `f(ω_b, ω_i) E_i / samples` to every bin.

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, Scene};
use holocave_tracer::integrator::light_unblocked;
use holocave_tracer::lights::{LightSample, Lights};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::elements::{Elements, cell_index};
use crate::tiles::Tiles;

/// The irradiance one light sample gives the point `p` on the side with normal `ns`.
pub fn irradiance_from(scene: &Scene, ls: &LightSample, p: Vec3, ng: Vec3, ns: Vec3) -> Vec3 {
    let cos = ns.dot(ls.wi);
    if cos <= 0.0 {
        return Vec3::ZERO;
    }
    if !light_unblocked(scene, ls, p, ng) {
        return Vec3::ZERO;
    }
    ls.contribution * cos
}

/// What direct light gives one element: its irradiance, and its tile's bins if glossy.
type Found = (u32, [f32; 3], Vec<Vec3>);

/// The direct irradiance of every element whose `needed` flag is set (others get zero),
/// with `samples` points each, and the radiance it gives every glossy tile (`tiles`).
/// Deterministic: each element has its own random stream.
pub fn direct_irradiance(
    scene: &Scene,
    lights: &Lights,
    elements: &Elements,
    needed: &[bool],
    samples: u32,
    tiles: &Tiles,
    on_triangle: &(dyn Fn() + Sync),
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut out = vec![[0f32; 3]; elements.count];
    let mut tile_out = vec![[0f32; 3]; tiles.len()];
    let per_triangle: Vec<Vec<Found>> = elements
        .triangles
        .par_iter()
        .enumerate()
        .map(|(t, cells)| {
            let mut found = Vec::new();
            let r = cells.res;
            for side in 0..2u32 {
                for j in 0..r {
                    for i in 0..r - j {
                        let e = cells.base(side) + cell_index(i, j, r);
                        if !needed[e as usize] {
                            continue;
                        }
                        let g = tiles.of(e);
                        let mut bins =
                            vec![Vec3::ZERO; if g.is_some() { tiles.per_tile() } else { 0 }];
                        let glossy = g.map(|g| (tiles, g, bins.as_mut_slice()));
                        let e_irr = element_direct(
                            scene,
                            lights,
                            (t as u32, side),
                            (i, j, r),
                            e,
                            samples,
                            glossy,
                        );
                        found.push((e, e_irr.to_array(), bins));
                    }
                }
            }
            on_triangle();
            found
        })
        .collect();
    let k = tiles.per_tile();
    for list in per_triangle {
        for (e, v, bins) in list {
            out[e as usize] = v;
            if let Some(g) = tiles.of(e) {
                let at = g as usize * k;
                for (o, b) in tile_out[at..at + k].iter_mut().zip(bins) {
                    *o = b.to_array();
                }
            }
        }
    }
    (out, tile_out)
}

fn element_direct(
    scene: &Scene,
    lights: &Lights,
    (t, side): (u32, u32),
    (i, j, r): (u32, u32, u32),
    e: u32,
    samples: u32,
    mut glossy: Option<(&Tiles, u32, &mut [Vec3])>,
) -> Vec3 {
    let mut rng = Pcg32::seed_from_u64(u64::from(e).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5EED);
    let k = (samples as f32).sqrt().ceil().max(1.0) as u32;
    let diagonal = i + j == r - 1;
    let mut sum = Vec3::ZERO;
    for s in 0..samples {
        let (mut a, mut b) = (
            ((s % k) as f32 + rng.random::<f32>()) / k as f32,
            ((s / k % k) as f32 + rng.random::<f32>()) / k as f32,
        );
        if diagonal && a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let (u, v) = ((i as f32 + a) / r as f32, (j as f32 + b) / r as f32);
        let sp = scene.surface(&Hit {
            triangle: t,
            t: 0.0,
            u,
            v,
        });
        let ng = sp.geometric_normal;
        let ns = if side == 0 { ng } else { -ng };
        let p = sp.position;
        let mut add = |ls: &LightSample| {
            let e = irradiance_from(scene, ls, p, ng, ns);
            sum += e;
            if let Some((tiles, g, bins)) = glossy.as_mut()
                && e.max_element() > 0.0
            {
                tiles.accumulate(*g, ls.wi, e / samples.max(1) as f32, bins);
            }
        };
        if lights.has_area() {
            let uc = rng.random();
            let u2 = Vec2::new(rng.random(), rng.random());
            if let Some(ls) = lights.sample_area(scene, p, uc, u2) {
                add(&ls);
            }
        }
        for l in 0..lights.punctual.len() {
            if let Some(ls) = lights.sample_punctual(l, p) {
                add(&ls);
            }
        }
        let u2 = Vec2::new(rng.random(), rng.random());
        if let Some(ls) = lights.sample_sun(u2) {
            add(&ls);
        }
    }
    sum / samples.max(1) as f32
}
