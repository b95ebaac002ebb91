//! Propagation (§3.2 of the paper): a Neumann expansion of the rendering equation along
//! the subfields' lines, one bounce per iteration.
//!
//! Iteration `k` takes the radiance `B_{k−1}` that diffuse elements send out after the
//! previous bounce (and, through [`Link`]s, what delta surfaces send on), passes it from
//! each crossing of every line to the next one in both directions, and adds at each
//! diffuse receiver the irradiance it brings:
//!
//! `ΔE_k(e) = Σ_ω Δω · Σ_{lines of ω arriving at e} L · h² / A_e`
//!
//! where `h²` is a line's cross-section and `A_e` the element's area: each line stands
//! for the light through its `h²` of cross-section, spread over the `A_e` it lands on
//! (the `cos θ` of irradiance and the `1/cos θ` of the footprint cancel). Then
//! `B_k = ρ/π · ΔE_k`, each line's light counted and sent as the element's directional
//! albedo weighs that direction (`exitance`). The first bounce's sources are the sky at
//! the lines' ends and the light seen through delta surfaces; the light of small
//! emitters and the sun comes by next-event estimation (`direct`), added before.
//!
//! A glossy receiver (`tiles`) takes each line's `L · Δω h² / A_e` as `dE` arriving from
//! the line's direction, shares it bilinearly between the bins nearest that direction,
//! and once all of a bounce's light has arrived adds `f(ω_b, ω_j) dE_j` from every bin `j`
//! to every bin `b` of its tile, with the tracer's BSDF; a glossy sender sends along a line the radiance its tile holds in the
//! line's direction (bilinear between bins), where a diffuse one sends `B`.
//!
//! The sums are made in the same order whatever the number of threads: subfields are
//! processed in parallel in fixed chunks, and their contributions (to elements and to the
//! tiles' binned arrivals) added in subfield order, so a bake is bit-identical on any
//! machine; the tiles' BSDFs are then applied tile by tile, in parallel.

use glam::Vec3;
use rayon::prelude::*;

use crate::exitance::Exitance;
use crate::pools::Pools;
use crate::reflection::Reflection;
use crate::subfield::{Crossing, DELTA, Link, Subfield};
use crate::tiles::Tiles;

/// Subfields whose contributions are gathered in parallel before being added in order.
const CHUNK: usize = 16;

/// The light one line brings to one element, per unit of `Δω h² / A_e`.
type Contribution = (u32, Vec3);

/// The light one line brings to a glossy tile: the tile, whether it travels along `−d`
/// (so it arrives from `+d`), and the radiance.
type Arrival = (u32, bool, Vec3);

/// Light arriving at a glossy tile: the tile, the direction it comes from, its irradiance.
type TileArrival = (u32, Vec3, Vec3);

/// The lines of a bake and their weights: everything a bounce needs besides the radiance.
pub struct Lines<'a> {
    pub subfields: &'a [Subfield],
    /// Each subfield's orientation `d` (its lines run along `+d` and `−d`).
    pub dirs: &'a [Vec3],
    /// Each subfield's `Δω h²`.
    pub weight: &'a [f32],
    /// Each subfield's sky light entering along `+d` and along `−d` (first bounce only).
    pub ends: &'a [(Vec3, Vec3)],
    /// The area each element's light is spread over.
    pub area: &'a [f32],
    pub tiles: &'a Tiles,
    /// How each diffuse element's light leaves it over directions.
    pub exitance: &'a Exitance,
    /// The tiles' BSDFs between bins.
    pub reflection: &'a Reflection,
    /// Small elements pooled with their neighbours (`None`: each alone).
    pub pools: Option<&'a Pools>,
}

/// What the previous bounce sends out: diffuse elements' radiance `B` and the glossy
/// tiles' bins.
#[derive(Clone, Copy)]
pub struct Sending<'a> {
    pub radiance: &'a [[f32; 3]],
    pub tiles: &'a [[f32; 3]],
    pub first_bounce: bool,
}

/// What one bounce brings: every element's irradiance, every tile's radiance.
pub struct Received {
    pub irradiance: Vec<[f32; 3]>,
    pub tiles: Vec<[f32; 3]>,
}

/// What element `e` sends along `dir`: a glossy one what its tile holds that way, a
/// diffuse one its `B` as its directional albedo spreads it ([`Exitance`]).
fn out_of(e: u32, dir: Vec3, lines: &Lines, sending: &Sending) -> Vec3 {
    if e == u32::MAX {
        Vec3::ZERO
    } else if let Some(g) = lines.tiles.of(e) {
        lines.tiles.radiance(sending.tiles, g, dir)
    } else {
        Vec3::from(sending.radiance[e as usize]) * lines.exitance.towards(e, dir)
    }
}

/// What a side of a crossing sends along its line, in direction `dir`.
fn outgoing(side: u32, dir: Vec3, links: &[Link], lines: &Lines, sending: &Sending) -> Vec3 {
    if side & DELTA != 0 {
        let l = &links[(side & !DELTA) as usize];
        let emitted = if sending.first_bounce {
            l.emitted
        } else {
            Vec3::ZERO
        };
        l.weight * out_of(l.element, l.toward, lines, sending) + emitted
    } else {
        out_of(side, dir, lines, sending)
    }
}

/// The lines of one subfield (orientation `d`) passing the light one step, both ways.
/// `ends` is the sky light entering along `+d` and along `−d` (first bounce only).
fn gather(
    s: &Subfield,
    d: Vec3,
    lines: &Lines,
    sending: &Sending,
    ends: (Vec3, Vec3),
    out: &mut Vec<Contribution>,
    glossy: &mut Vec<Arrival>,
) {
    let tiles = lines.tiles;
    for w in s.line_start.windows(2) {
        let line: &[Crossing] = &s.crossings[w[0] as usize..w[1] as usize];
        let mut receive = |side: u32, backwards: bool, l: Vec3| {
            if side & DELTA == 0 && l.max_element() > 0.0 {
                out.push((side, l * lines.exitance.towards(side, d)));
                if let Some(g) = tiles.of(side) {
                    glossy.push((g, backwards, l));
                }
            }
        };
        if sending.first_bounce {
            receive(line[0].minus, false, ends.0);
            receive(line[line.len() - 1].plus, true, ends.1);
        }
        for pair in line.windows(2) {
            // Along +d: from the first's plus side to the second's minus side; and back.
            receive(
                pair[1].minus,
                false,
                outgoing(pair[0].plus, d, &s.links, lines, sending),
            );
            receive(
                pair[0].plus,
                true,
                outgoing(pair[1].minus, -d, &s.links, lines, sending),
            );
        }
    }
}

/// Adds each arrival `(tile, from, irradiance)` to its tile's bins in `incoming`, the
/// tiles in parallel: each tile takes its arrivals in the order given, so the sums are
/// the same, bit for bit, as one after the other (a glossy scene's arrivals, one
/// thread's work, were most of its bake).
fn splat_by_tile(lines: &Lines, arrivals: &mut [TileArrival], incoming: &mut [Vec3]) {
    let tiles = lines.tiles;
    let slots = Reflection::slots(tiles);
    arrivals.sort_by_key(|a| a.0);
    let mut runs: Vec<(&mut [Vec3], &[TileArrival])> = Vec::new();
    let (mut rest, mut done) = (incoming, 0usize);
    for run in arrivals.chunk_by(|a, b| a.0 == b.0) {
        let g = run[0].0 as usize;
        let (_, from_g) = std::mem::take(&mut rest).split_at_mut((g - done) * slots);
        let (slots_of_g, after) = from_g.split_at_mut(slots);
        runs.push((slots_of_g, run));
        (rest, done) = (after, g + 1);
    }
    runs.into_par_iter().for_each(|(out, run)| {
        for &(g, from, l) in run {
            lines.reflection.splat(tiles, g, from, l, out);
        }
    });
}

/// One bounce over all subfields: the irradiance each element receives from `sending`,
/// and the radiance each glossy tile makes of it.
pub fn bounce(lines: &Lines, sending: Sending) -> Received {
    let tiles = lines.tiles;
    let bins = tiles.per_tile();
    let slots = Reflection::slots(tiles);
    let mut irradiance = vec![Vec3::ZERO; lines.area.len()];
    // The light arriving at each tile, binned by the direction it comes from.
    let mut incoming = vec![Vec3::ZERO; tiles.tiles.len() * slots];
    for (c, chunk) in lines.subfields.chunks(CHUNK).enumerate() {
        let parts: Vec<(Vec<Contribution>, Vec<Arrival>)> = chunk
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let k = c * CHUNK + i;
                let (mut out, mut glossy) = (Vec::new(), Vec::new());
                gather(
                    s,
                    lines.dirs[k],
                    lines,
                    &sending,
                    lines.ends[k],
                    &mut out,
                    &mut glossy,
                );
                (out, glossy)
            })
            .collect();
        let mut arrivals = Vec::new();
        for (i, (part, glossy)) in parts.iter().enumerate() {
            let k = c * CHUNK + i;
            let w = lines.weight[k];
            for &(e, l) in part {
                irradiance[e as usize] += l * w;
            }
            for &(g, backwards, l) in glossy {
                // Light travelling along +d arrives from −d.
                let from = if backwards {
                    lines.dirs[k]
                } else {
                    -lines.dirs[k]
                };
                arrivals.push((g, from, l * w));
            }
        }
        splat_by_tile(lines, &mut arrivals, &mut incoming);
    }
    // Pooled tiles (`pools`; none at present: see there) reflect the light that arrived
    // at their whole pool.
    let pooled: Vec<Vec<Vec3>> = match lines.pools {
        Some(p) => p
            .members
            .iter()
            .map(|m| {
                let mut sum = vec![Vec3::ZERO; if tiles.of(m[0]).is_some() { slots } else { 0 }];
                for &e in m {
                    if let Some(h) = tiles.of(e) {
                        let at = h as usize * slots;
                        for (s, x) in sum.iter_mut().zip(&incoming[at..at + slots]) {
                            *s += *x;
                        }
                    }
                }
                sum
            })
            .collect(),
        None => Vec::new(),
    };
    // The BSDF applied once per tile to all the light that arrived.
    let tiles_out = incoming
        .par_chunks(slots)
        .zip(&tiles.tiles)
        .enumerate()
        .flat_map_iter(|(g, (arrived, t))| {
            let mut out = vec![Vec3::ZERO; bins];
            let e = t.element as usize;
            let (arrived, a) = match lines.pools.map(|p| (p, p.of[e])) {
                Some((p, k)) if k != u32::MAX => (
                    pooled[k as usize].as_slice(),
                    p.area[k as usize].max(p.least),
                ),
                _ => (arrived, lines.area[e]),
            };
            lines.reflection.apply(tiles, g as u32, arrived, &mut out);
            out.into_iter().map(move |l| (l / a).to_array())
        })
        .collect();
    let irradiance = match lines.pools {
        Some(p) => p.irradiance(&irradiance, lines.area),
        None => irradiance
            .iter()
            .zip(lines.area)
            .map(|(e, a)| (*e / *a).to_array())
            .collect(),
    };
    Received {
        irradiance,
        tiles: tiles_out,
    }
}

/// The flux leaving all elements with radiance `b`: `Σ π B A` (luminance).
pub fn flux(b: &[[f32; 3]], area: &[f32]) -> f64 {
    b.iter()
        .zip(area)
        .map(|(b, a)| {
            let l = holocave_scene::luminance(Vec3::from(*b));
            f64::from(l) * f64::from(*a) * std::f64::consts::PI
        })
        .sum()
}
