//! The closed furnace: a closed box whose every surface emits radiance `Le` and reflects
//! with Lambertian albedo `ρ`. The radiance is then the same everywhere and in every
//! direction, `L = Le + ρ L`, so `L = Le / (1 − ρ)` exactly, and whatever the VLF draws
//! from inside differs from it only by its own errors: the direct light's next-event
//! estimation, the lines' discretisation (directions and line spacing) and the stopping
//! rule.

use crate::common;

use std::collections::HashSet;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use holocave_scene::{Ray, Scene};
use holocave_vlf::view::shade_one;
use holocave_vlf::{Directions, PixelDirect, Settings, State, Visibility, layout};

const LE: f32 = 1.0;
const RHO: f32 = 0.5;
const SIDE: f32 = 1.0;

/// `n` directions spread evenly over the sphere (a Fibonacci spiral).
fn sphere_points(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

/// How far a point on the box's surface is from the nearest edge of its face.
fn distance_to_edge(p: Vec3) -> f32 {
    // The coordinate nearest a face is the face's; the other two measure the edges.
    let d = p.to_array().map(|c| c.min(SIDE - c));
    let face = (0..3).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
    (0..3)
        .filter(|&a| a != face)
        .map(|a| d[a])
        .fold(f32::MAX, f32::min)
}

/// The cosine-weighted solid angle the directions give a surface with normal `n`,
/// `Σ_{ω·n>0} Δω (ω·n)`, over its exact value `π`: the factor by which every propagated
/// bounce's irradiance is off.
fn cosine_quadrature(d: &Directions, n: Vec3) -> f64 {
    d.dirs
        .iter()
        .zip(&d.solid_angle)
        .map(|(w, s)| f64::from(*s) * f64::from(w.dot(n).max(0.0)))
        .sum::<f64>()
        / std::f64::consts::PI
}

#[test]
fn closed_furnace_draws_le_over_one_minus_rho() {
    let scene = Arc::new(common::closed_box(
        "furnace",
        SIDE,
        common::lambert("glowing", RHO, Vec3::splat(LE)),
    ));
    let settings = Settings {
        directions: 162,
        resolution: 64,
        element_size: Some(0.1),
        direct_samples: 1024,
        tolerance: 1e-3,
        max_bounces: 200,
        ..Settings::default()
    };
    let start = Instant::now();
    let (state, stats) = common::bake_quiet(&scene, &settings);
    eprintln!(
        "furnace bake: {:.2} s, {} elements, {} bounces, tail {:.2e}, residuals {:?}",
        start.elapsed().as_secs_f64(),
        stats.elements,
        state.bounces,
        state.tail(),
        state.residuals
    );

    // The stopping rule stopped because the tail fell below the tolerance, not at the cap.
    assert!(state.converged);
    assert!(state.bounces < settings.max_bounces, "{}", state.bounces);
    assert!(
        state.tail() < settings.tolerance,
        "tail {:.3e}",
        state.tail()
    );

    let c = assert_bounces_fall_by_rho_c(&state, settings.directions);

    // What the drawn radiance should be, relative to the exact Le/(1 − ρ):
    //  - bias: the direct light ρ Le is right on average; the propagated bounces each carry
    //    the factor c, so L = Le [1 + ρ + ρ² c / (1 − ρ c)]; and the stopping rule leaves
    //    out at most ρ^{k+2} of the exact radiance, where tail = ρ^k / (1 − ρ^k) < τ, so
    //    less than ρ² τ = 2.5e-4.
    //  - noise at one element, away from the edges: next-event estimation with S = 1024
    //    samples, uniform over the emitting area, has a per-sample relative spread σ₁ ≤ 1.5
    //    at least two elements from an edge (measured ≈ 1.0–1.3), weighted by ρ(1 − ρ) in
    //    L: 0.25 × 1.5 / √1024 = 1.2 %; the line counts — an element of side m = 2.46 line
    //    spacings gets ≈ m² cos θ lines of each direction, spread ≤ m/√2 (a random lattice
    //    offset over a square), so over the n/2 = 81 directions of a hemisphere the
    //    irradiance is off by ≤ 2 / (m √n) = 6.4 %, weighted by ρ² in L: 1.6 %. Together
    //    σ ≤ 2.0 % per ray (the bilinear interpolation over four elements only lowers it).
    //  Near an edge the next-event estimate has no bound: its variance is infinite where an
    //  emitter meets the receiver at a concave edge (the 1/d² of points on the neighbouring
    //  face, integrated over points a distance x from the edge, grows like ∫ dx / x²), so
    //  rays there are only checked to be finite and positive.
    let sigma = 0.020;
    let bias = f64::from(1.0 - RHO)
        * (1.0 + f64::from(RHO) + f64::from(RHO * RHO) * c / (1.0 - f64::from(RHO) * c))
        - 1.0;
    let truncation = f64::from(RHO * RHO) * settings.tolerance;

    let exact = LE / (1.0 - RHO);
    let (interior, seen, all) = drawn_errors(&scene, &settings, &state, exact);
    let n = interior.len() as f64;
    let mean = interior.iter().sum::<f64>() / n;
    let rms = (interior.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt();
    let worst = interior.iter().fold(0f64, |m, e| m.max((e - bias).abs()));
    eprintln!(
        "furnace: {all} rays, {} away from edges over {} elements: mean error {mean:.4} \
         (bias expected {bias:.4}), spread {rms:.4}, worst {worst:.4}",
        interior.len(),
        seen
    );
    assert!(interior.len() > all / 3, "{} of {all}", interior.len());
    // The mean over rays that see K different elements: bias, truncation, and four
    // standard errors σ/√K.
    let k = seen as f64;
    assert!(
        (mean - bias).abs() < truncation + 4.0 * sigma / k.sqrt(),
        "mean error {mean:.5}, expected {bias:.5} ± {:.5}",
        truncation + 4.0 * sigma / k.sqrt()
    );
    assert!(rms < sigma, "spread {rms:.4} above the σ = {sigma} derived");
    // No ray further than 4σ (+ the truncation) from the expected value: with ≈ 2 000 rays
    // of Gaussian errors the largest would be ≈ 3.5σ.
    assert!(
        worst < 4.0 * sigma + truncation,
        "worst ray {worst:.4} above 4σ = {}",
        4.0 * sigma
    );
}

/// The quadrature factor `c` of `directions` directions (the box's normals are the axes,
/// which the geodesic sphere treats alike, so one factor serves every face), checked
/// against the residuals: bounce 0 sends out exactly ρ of the light that arrived (one
/// albedo everywhere), and each later bounce ρ c of the one before. A line lost at the
/// box's edges or corners would make the ratio smaller; 1 % is several times the scatter
/// of the per-element line counts averaged over the 1 440 lit elements (≈ 6 % / √1440).
fn assert_bounces_fall_by_rho_c(state: &State, directions: usize) -> f64 {
    let directions = Directions::at_least(directions);
    let c = cosine_quadrature(&directions, Vec3::X);
    for n in [Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z] {
        assert!((cosine_quadrature(&directions, n) - c).abs() < 1e-4);
    }
    let r = &state.residuals;
    assert!((r[0] - f64::from(RHO)).abs() < 1e-6, "r0 {}", r[0]);
    for k in 2..r.len() {
        let q = r[k] / r[k - 1] / f64::from(RHO);
        assert!(
            (q - c).abs() < 0.01,
            "bounce {k}: ratio/ρ {q:.4}, quadrature {c:.4}"
        );
    }
    c
}

/// The relative errors against `exact` of the radiance drawn for 4 000 rays from four
/// points inside the box, of those landing more than two elements from an edge (every
/// ray's radiance finite and positive); how many elements those saw; how many rays.
fn drawn_errors(
    scene: &Arc<Scene>,
    settings: &Settings,
    state: &State,
    exact: f32,
) -> (Vec<f64>, usize, usize) {
    let elements = layout(scene, settings);
    let element_size = elements.element_size;
    let vis = Visibility::of(scene.clone(), settings);
    let values = state.values();
    let mut interior = Vec::new();
    let mut seen = HashSet::new();
    let mut all = 0usize;
    for origin in [
        Vec3::splat(0.5),
        Vec3::new(0.2, 0.3, 0.7),
        Vec3::new(0.8, 0.6, 0.25),
        Vec3::new(0.35, 0.85, 0.4),
    ] {
        for dir in sphere_points(1000) {
            let ray = Ray::new(origin * SIDE, dir);
            let hit = scene
                .closest_hit(&ray, f32::INFINITY)
                .expect("a closed box");
            let lookup = vis.lookup(ray);
            let l = shade_one(&lookup, &values);
            assert!(
                l.is_finite() && l.min_element() > 0.0,
                "ray {ray:?}: radiance {l}"
            );
            all += 1;
            if distance_to_edge(ray.at(hit.t)) > 2.0 * element_size {
                interior.push(f64::from((l.x - exact) / exact));
                seen.insert((
                    hit.triangle,
                    (lookup.u * 15.0) as u32,
                    (lookup.v * 15.0) as u32,
                ));
            }
        }
    }
    (interior, seen.len(), all)
}

/// The split: the light field's remainder (`State::indirect_values`) plus the direct light
/// computed per pixel (`pixel_direct`) draws the same furnace as the light field alone,
/// its direct light included: the same rays, the same interior points, their mean
/// relative difference within the noise of the two direct estimates.
#[test]
fn the_split_draws_what_the_total_draws() {
    let scene = Arc::new(common::closed_box(
        "furnace",
        SIDE,
        common::lambert("glowing", RHO, Vec3::splat(LE)),
    ));
    let settings = Settings {
        directions: 92,
        resolution: 48,
        element_size: Some(0.1),
        direct_samples: 1024,
        tolerance: 1e-3,
        max_bounces: 200,
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    assert!(state.converged);
    assert_the_direct_part_is_kept(&state);
    let samples = 1024;
    let exact = f64::from(LE / (1.0 - RHO));
    let Compared {
        diffs,
        elements,
        old_sum,
        new_sum,
    } = split_against_total(&scene, &settings, &state, samples);
    let n = diffs.len() as f64;
    let mean = diffs.iter().sum::<f64>() / n;
    let rms = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
    eprintln!(
        "split against total: {} rays over {} elements, mean difference {mean:.5}, spread {rms:.4}; means {:.4} and {:.4} (exact {exact})",
        diffs.len(),
        elements,
        old_sum / n,
        new_sum / n
    );
    // Each side's direct light is a next-event estimate of ρ Le with 1024 samples (an
    // element's, interpolated, and a point's), per-sample spread ≤ 1.5 (see above),
    // weighted by ρ(1 − ρ) in L: σ ≤ 0.25 × 1.5/√1024 = 1.2 % each, so their difference
    // has σ_d ≤ 1.7 % per ray (the rest of the light field is the same on both sides);
    // the mean over rays that see K different elements is within 4 σ_d/√K of zero.
    let sigma_d = 2f64.sqrt() * 0.25 * 1.5 / f64::from(samples).sqrt();
    let k = elements as f64;
    assert!(n > 300.0, "{n} interior rays");
    assert!(
        mean.abs() < 4.0 * sigma_d / k.sqrt(),
        "the split's sum differs from the total by {mean:.5} on average (bound {:.5})",
        4.0 * sigma_d / k.sqrt()
    );
    assert!(rms < sigma_d, "spread {rms:.4} above σ_d {sigma_d:.4}");
}

/// The direct part is kept as computed: every element's total holds it, and what is left
/// is the inter-reflected light, ρ c/(1 − ρ c) of the direct light at most.
fn assert_the_direct_part_is_kept(state: &State) {
    let values = state.values();
    let indirect = state.indirect_values();
    assert_eq!(values.len(), indirect.len());
    let (mut direct_sum, mut indirect_sum) = (0f64, 0f64);
    for ((t, i), d) in values.iter().zip(&indirect).zip(&state.direct) {
        for c in 0..3 {
            assert!(
                (t[c] - i[c] - d[c]).abs() <= 1e-5 * t[c] && i[c] >= 0.0,
                "total {t:?}, indirect {i:?}, direct {d:?}"
            );
        }
        direct_sum += f64::from(d[0]);
        indirect_sum += f64::from(i[0]);
    }
    // In the furnace the direct irradiance is π Le and the indirect π ρ Le/(1 − ρ) (no
    // quadrature factor: the bound is loose), so indirect/direct ≈ ρ/(1 − ρ) = 1.
    let ratio = indirect_sum / direct_sum;
    assert!(
        (ratio - f64::from(RHO / (1.0 - RHO))).abs() < 0.1,
        "indirect/direct {ratio:.3}"
    );
}

/// The total's and the split's radiance along rays from two points inside the furnace
/// that end far from an edge: their relative differences, how many elements they see,
/// and each side's sum.
struct Compared {
    diffs: Vec<f64>,
    elements: usize,
    old_sum: f64,
    new_sum: f64,
}

/// [`Compared`] for the bake `state` of `scene`, the split's direct light the mean of
/// `samples` samples at each ray's point.
fn split_against_total(
    scene: &Arc<Scene>,
    settings: &Settings,
    state: &State,
    samples: u32,
) -> Compared {
    let (values, indirect) = (state.values(), state.indirect_values());
    let vis = Visibility::of(scene.clone(), settings);
    let direct = PixelDirect::new(scene.clone());
    let exact = f64::from(LE / (1.0 - RHO));
    let element_size = layout(scene, settings).element_size;
    let mut c = Compared {
        diffs: Vec::new(),
        elements: 0,
        old_sum: 0.0,
        new_sum: 0.0,
    };
    let mut seen = HashSet::new();
    let origins = [Vec3::splat(0.5), Vec3::new(0.2, 0.3, 0.7)];
    for (o, origin) in origins.into_iter().enumerate() {
        for (k, dir) in sphere_points(500).into_iter().enumerate() {
            let (lookup, point) = vis.lookup_and_point(Ray::new(origin * SIDE, dir));
            let point = point.expect("a closed box");
            if distance_to_edge(point.position) <= 2.0 * element_size {
                continue;
            }
            let seed = (o * 1000 + k) as u64;
            let at_point = vis.with_placed(|s| direct.mean(s, &point, seed, 0, samples).radiance);
            let old = f64::from(shade_one(&lookup, &values).x);
            let new = f64::from((shade_one(&lookup, &indirect) + at_point).x);
            c.diffs.push((new - old) / exact);
            c.old_sum += old;
            c.new_sum += new;
            let cell = ((lookup.u * 15.0) as u32, (lookup.v * 15.0) as u32);
            seen.insert((point.triangle, cell));
        }
    }
    c.elements = seen.len();
    c
}
