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
//! `B_k = ρ/π · ΔE_k`. The first bounce's sources are the sky at the lines' ends and the
//! light seen through delta surfaces; the light of small emitters and the sun comes by
//! next-event estimation (`direct`), added before.
//!
//! The sums are made in the same order whatever the number of threads: subfields are
//! processed in parallel in fixed chunks, and their contributions added in subfield
//! order, so a bake is bit-identical on any machine.

use glam::Vec3;
use rayon::prelude::*;

use crate::subfield::{Crossing, DELTA, Link, Subfield};

/// Subfields whose contributions are gathered in parallel before being added in order.
const CHUNK: usize = 16;

/// The light one line brings to one element, per unit of `Δω h² / A_e`.
type Contribution = (u32, Vec3);

/// What a side of a crossing sends along its line.
fn outgoing(side: u32, links: &[Link], radiance: &[[f32; 3]], first_bounce: bool) -> Vec3 {
    let at = |e: u32| {
        if e == u32::MAX {
            Vec3::ZERO
        } else {
            Vec3::from(radiance[e as usize])
        }
    };
    if side & DELTA != 0 {
        let l = &links[(side & !DELTA) as usize];
        let emitted = if first_bounce { l.emitted } else { Vec3::ZERO };
        l.weight * at(l.element) + emitted
    } else {
        at(side)
    }
}

/// The lines of one subfield passing `radiance` one step, both ways. `ends` is the sky
/// light entering along `+d` and along `−d` (first bounce only).
fn gather(
    s: &Subfield,
    radiance: &[[f32; 3]],
    first_bounce: bool,
    ends: (Vec3, Vec3),
    out: &mut Vec<Contribution>,
) {
    for w in s.line_start.windows(2) {
        let line: &[Crossing] = &s.crossings[w[0] as usize..w[1] as usize];
        let mut receive = |side: u32, l: Vec3| {
            if side & DELTA == 0 && l.max_element() > 0.0 {
                out.push((side, l));
            }
        };
        if first_bounce {
            receive(line[0].minus, ends.0);
            receive(line[line.len() - 1].plus, ends.1);
        }
        for pair in line.windows(2) {
            // Along +d: from the first's plus side to the second's minus side; and back.
            receive(
                pair[1].minus,
                outgoing(pair[0].plus, &s.links, radiance, first_bounce),
            );
            receive(
                pair[0].plus,
                outgoing(pair[1].minus, &s.links, radiance, first_bounce),
            );
        }
    }
}

/// One bounce over all subfields: the irradiance each element receives from `radiance`.
/// `weight[k]` is subfield `k`'s `Δω h²`, `ends[k]` its sky light (see [`gather`]).
pub fn bounce(
    subfields: &[Subfield],
    weight: &[f32],
    ends: &[(Vec3, Vec3)],
    area: &[f32],
    radiance: &[[f32; 3]],
    first_bounce: bool,
) -> Vec<[f32; 3]> {
    let mut irradiance = vec![Vec3::ZERO; area.len()];
    for (c, chunk) in subfields.chunks(CHUNK).enumerate() {
        let parts: Vec<Vec<Contribution>> = chunk
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let mut out = Vec::new();
                gather(s, radiance, first_bounce, ends[c * CHUNK + i], &mut out);
                out
            })
            .collect();
        for (i, part) in parts.iter().enumerate() {
            let w = weight[c * CHUNK + i];
            for &(e, l) in part {
                irradiance[e as usize] += l * w;
            }
        }
    }
    irradiance
        .iter()
        .zip(area)
        .map(|(e, a)| (*e / *a).to_array())
        .collect()
}

/// The flux leaving all elements with radiance `b`: `Σ π B A` (luminance).
pub fn flux(b: &[[f32; 3]], area: &[f32]) -> f64 {
    b.iter()
        .zip(area)
        .map(|(b, a)| {
            let l = 0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2];
            f64::from(l) * f64::from(*a) * std::f64::consts::PI
        })
        .sum()
}
