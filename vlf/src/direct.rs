//! Direct light from the lights that are far smaller than the direction spacing — area
//! emitters, punctual lights and the sun — by next-event estimation with the tracer's
//! light sampling: `samples` stratified points in each element, one sample of each kind
//! of light and one shadow ray per point, each counted as the element's directional
//! albedo weighs its direction (`exitance`). The sky is not sampled here: it is as large
//! as the sphere of directions, and the lines carry it (`propagate`). A glossy element's
//! samples also go into its tile: each adds `f(ω_b, ω_i) E_i / samples` to every bin.
//!
//! The points also tell how much of each element is open: a point inside a closed object
//! resting on the surface (the floor under a box, a wall's foot inside a cupboard) sees no
//! light and no eye sees it. It is left out of the element's mean, and the bake puts the
//! light the lines bring the element over its open part only (`bake::over_open_part`).

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, Ray, Scene, SurfacePoint};
use holocave_tracer::frame::Frame;
use holocave_tracer::integrator::light_unblocked;
use holocave_tracer::lights::{LightSample, Lights};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::elements::{Elements, cell_index};
use crate::exitance::Exitance;
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

/// Whether the point `p` of a surface (face normal `ng`, its side's normal `ns`) lies
/// inside a closed object resting on the surface: the ray along `ns` and four leaning 60°
/// from it all meet a surface from behind. Under a box standing on a floor they meet the
/// box's faces from inside; under a table's top they meet its underside from the front,
/// and beside a box they leave by the open side.
fn covered(scene: &Scene, p: Vec3, ng: Vec3, ns: Vec3) -> bool {
    let from_behind = |d: Vec3| {
        let ray = Ray::leaving(p, ng, d);
        (scene.closest_hit(&ray, f32::INFINITY))
            .is_some_and(|h| scene.face_normal(h.triangle).dot(d) > 0.0)
    };
    if !from_behind(ns) {
        return false;
    }
    let frame = Frame::new(ns);
    let (sin, cos) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
    (0..4).all(|k| {
        let phi = k as f32 * std::f32::consts::FRAC_PI_2;
        from_behind(frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)))
    })
}

/// What direct light gives one element: its irradiance, the open share of its points,
/// and its tile's bins if glossy.
type Found = (u32, [f32; 3], f32, Vec<Vec3>);

/// The direct irradiance of every element whose `needed` flag is set (others get zero),
/// with `samples` points each over its open part, the open share of each element's area
/// (not inside a closed object resting on it, as its points found; 1 where not needed),
/// and the radiance it gives every glossy tile (`tiles`).
/// Deterministic: each element has its own random stream.
pub fn direct_irradiance(
    scene: &Scene,
    lights: &Lights,
    elements: &Elements,
    needed: &[bool],
    samples: u32,
    (tiles, exitance): (&Tiles, &Exitance),
    on_triangle: &(dyn Fn() + Sync),
) -> (Vec<[f32; 3]>, Vec<f32>, Vec<[f32; 3]>) {
    let mut out = vec![[0f32; 3]; elements.count];
    let mut open = vec![1f32; elements.count];
    let mut tile_out = vec![[0f32; 3]; tiles.len()];
    let per_triangle: Vec<Vec<Found>> = elements
        .triangles
        .par_iter()
        .enumerate()
        .map(|(t, cells)| {
            let mut found = Vec::new();
            let r = cells.res;
            for side in 0..2u32 {
                // The covered probes of each needed cell, in cell order.
                let mut probes = Vec::new();
                for j in 0..r {
                    for i in 0..r - j {
                        if needed[(cells.base(side) + cell_index(i, j, r)) as usize] {
                            probes.push(covered_probes(scene, (t as u32, side), (i, j, r)));
                        }
                    }
                }
                let side_of = |skip_covered: bool| {
                    let mut found = Vec::new();
                    let mut probes = probes.iter();
                    for j in 0..r {
                        for i in 0..r - j {
                            let e = cells.base(side) + cell_index(i, j, r);
                            if !needed[e as usize] {
                                continue;
                            }
                            let skip_covered = skip_covered && probes.next() != Some(&0);
                            let g = tiles.of(e);
                            let mut bins =
                                vec![Vec3::ZERO; if g.is_some() { tiles.per_tile() } else { 0 }];
                            let glossy = g.map(|g| (tiles, g, bins.as_mut_slice()));
                            let (e_irr, e_open) = element_direct(
                                scene,
                                lights,
                                (t as u32, side, skip_covered),
                                (i, j, r),
                                (e, exitance),
                                samples,
                                glossy,
                            );
                            found.push((e, e_irr.to_array(), e_open, bins));
                        }
                    }
                    found
                };
                // A side covered all over is no contact: its faces' normals point the
                // other way round (a room modelled as a box with outward normals, seen
                // from inside, meets its own walls from behind everywhere), or it lies
                // wholly inside an object, where nothing sees it. Taken as open.
                let all_covered = probes.iter().all(|&p| p == 5);
                let mut side_found = side_of(!all_covered);
                if !side_found.is_empty() && side_found.iter().all(|f| f.2 == 0.0) {
                    side_found = side_of(false);
                }
                found.extend(side_found);
            }
            on_triangle();
            found
        })
        .collect();
    let k = tiles.per_tile();
    for list in per_triangle {
        for (e, v, o, bins) in list {
            out[e as usize] = v;
            open[e as usize] = o;
            if let Some(g) = tiles.of(e) {
                let at = g as usize * k;
                for (o, b) in tile_out[at..at + k].iter_mut().zip(bins) {
                    *o = b.to_array();
                }
            }
        }
    }
    (out, open, tile_out)
}

/// How many of a cell's corners and its middle are covered ([`covered`]), of five: its
/// samples are tested one by one only where some are (an object resting on the surface
/// within the cell and touching none of them, a thin leg, goes unseen), and a side whose
/// cells are covered at all five is taken as open without testing its samples.
fn covered_probes(scene: &Scene, (t, side): (u32, u32), cell: (u32, u32, u32)) -> u32 {
    let probes = [
        (0.01, 0.01),
        (0.99, 0.01),
        (0.01, 0.99),
        (0.99, 0.99),
        (0.5, 0.5),
    ];
    (probes.into_iter())
        .filter(|&ab| {
            let sp = cell_point(scene, t, cell, ab);
            let ng = sp.geometric_normal;
            covered(scene, sp.position, ng, side_normal(side, ng))
        })
        .count() as u32
}

/// The point of triangle `t` at `(a, b)` of cell `(i, j)` of its `r × r` grid (`[0, 1)²`
/// over the cell; a diagonal cell, a triangle, folds the far half back onto itself).
fn cell_point(
    scene: &Scene,
    t: u32,
    (i, j, r): (u32, u32, u32),
    (a, b): (f32, f32),
) -> SurfacePoint {
    let (a, b) = if i + j == r - 1 && a + b > 1.0 {
        (1.0 - a, 1.0 - b)
    } else {
        (a, b)
    };
    scene.surface(&Hit {
        triangle: t,
        t: 0.0,
        u: (i as f32 + a) / r as f32,
        v: (j as f32 + b) / r as f32,
    })
}

/// The normal of `side` (0: the face's front) of a face of normal `ng`.
fn side_normal(side: u32, ng: Vec3) -> Vec3 {
    if side == 0 { ng } else { -ng }
}

fn element_direct(
    scene: &Scene,
    lights: &Lights,
    (t, side, skip_covered): (u32, u32, bool),
    (i, j, r): (u32, u32, u32),
    (e, exitance): (u32, &Exitance),
    samples: u32,
    mut glossy: Option<(&Tiles, u32, &mut [Vec3])>,
) -> (Vec3, f32) {
    let mut rng = Pcg32::seed_from_u64(u64::from(e).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5EED);
    let k = (samples as f32).sqrt().ceil().max(1.0) as u32;
    let mut sum = Vec3::ZERO;
    let mut open = 0u32;
    for s in 0..samples {
        let ab = (
            ((s % k) as f32 + rng.random::<f32>()) / k as f32,
            ((s / k % k) as f32 + rng.random::<f32>()) / k as f32,
        );
        let sp = cell_point(scene, t, (i, j, r), ab);
        let ng = sp.geometric_normal;
        let ns = side_normal(side, ng);
        let p = sp.position;
        if skip_covered && covered(scene, p, ng, ns) {
            continue;
        }
        open += 1;
        let mut add = |ls: &LightSample| {
            let irradiance = irradiance_from(scene, ls, p, ng, ns);
            sum += irradiance * exitance.towards(e, ls.wi);
            if let Some((tiles, g, bins)) = glossy.as_mut()
                && irradiance.max_element() > 0.0
            {
                tiles.accumulate(*g, ls.wi, irradiance, bins);
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
    // The mean over the open points (none open: nothing lit, and nothing seen).
    let n = open.max(1) as f32;
    if let Some((_, _, bins)) = glossy {
        bins.iter_mut().for_each(|b| *b /= n);
    }
    let share = if samples == 0 {
        1.0
    } else {
        open as f32 / samples as f32
    };
    (sum / n, share)
}
