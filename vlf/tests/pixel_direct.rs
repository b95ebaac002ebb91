//! The direct light per pixel (`pixel_direct`) against exact answers: the sun through a
//! slit onto a floor (the lit patch and the umbra exact from the first frame, the
//! penumbra and the edge's position after a still view's frames, against a quadrature of
//! the sun's disc), and a lamp's highlight on a glossy plane against the path tracer
//! (where the light field alone, its tiles' lobes widened, blurs it).

use crate::common;

use std::sync::Arc;

use glam::{DVec3, Vec2, Vec3, Vec4};
use holocave_cave::{Size, WallView};
use holocave_scene::{Daylight, Material, Ray, Scene, Sun};
use holocave_tracer::film::Image;
use holocave_vlf::settling::Settling;
use holocave_vlf::{Accumulator, DirectPoint, Estimate, PixelDirect, Settings, Visibility};

fn scene_with(
    name: &str,
    triangles: &[([Vec3; 3], u32)],
    materials: Vec<Material>,
    daylight: Daylight,
) -> Scene {
    common::scene_of(name, triangles, materials, |p| p.daylight = daylight)
}

// The slit: an opaque plane at height H with a gap of width W along z, over a Lambertian
// floor; the sun 30° from the zenith, tilted towards +x, with the real sun's angular
// radius.
/// These scenes have no moving objects: nothing is gathered beside the shadow rays.
fn no_gathers(_: &DirectPoint, _: u64, _: u64) -> Vec3 {
    Vec3::ZERO
}

const H: f32 = 1.0;
const W: f32 = 1.0;
const RHO: f32 = 0.5;
const SUN_L: f32 = 1000.0;
const SUN_R: f32 = 0.004_65;
const TILT: f32 = std::f32::consts::FRAC_PI_6;

fn sun_direction() -> Vec3 {
    Vec3::new(TILT.sin(), TILT.cos(), 0.0)
}

/// The lit floor's irradiance: `L (s·n) π sin² r` exactly (the sun's disc's
/// cosine-weighted solid angle).
fn lit_irradiance() -> f64 {
    let s = sun_direction();
    f64::from(SUN_L) * f64::from(s.y) * std::f64::consts::PI * f64::from(SUN_R).sin().powi(2)
}

fn slit() -> Scene {
    let big = 3.0;
    // The floor faces +y (a × b = z × x); the plates face −y.
    let floor = common::quad(
        Vec3::new(-big, 0.0, -big),
        Vec3::Z * 2.0 * big,
        Vec3::X * 2.0 * big,
    );
    let left = common::quad(
        Vec3::new(-big, H, -big),
        Vec3::X * (big - W / 2.0),
        Vec3::Z * 2.0 * big,
    );
    let right = common::quad(
        Vec3::new(W / 2.0, H, -big),
        Vec3::X * (big - W / 2.0),
        Vec3::Z * 2.0 * big,
    );
    let mut tris = Vec::new();
    for t in floor {
        tris.push((t, 0));
    }
    for t in left.into_iter().chain(right) {
        tris.push((t, 1));
    }
    let daylight = Daylight {
        sun: Some(Sun {
            direction: sun_direction(),
            angular_radius: SUN_R,
            radiance: Vec3::splat(SUN_L),
        }),
        sky: None,
        ..Default::default()
    };
    scene_with(
        "slit",
        &tris,
        vec![
            common::lambert("floor", RHO, Vec3::ZERO),
            common::lambert("plate", 0.0, Vec3::ZERO),
        ],
        daylight,
    )
}

/// The floor's exact irradiance at `(x, 0, 0)`: `L ∫ V(ω) cos θ dω` over the sun's disc,
/// by a midpoint rule in polar coordinates about the disc's centre (`n × n` cells), in
/// f64. A direction `d` passes the slit when `|x + H d_x / d_y| < W/2`.
fn quadrature(x: f64, n: usize) -> f64 {
    let s = sun_direction().as_dvec3();
    let e1 = DVec3::Y.cross(s).normalize().cross(s).normalize();
    let e2 = s.cross(e1);
    let r = f64::from(SUN_R);
    let mut sum = 0.0;
    for i in 0..n {
        let rho = (i as f64 + 0.5) / n as f64 * r;
        let area = rho.sin() * (r / n as f64) * (std::f64::consts::TAU / n as f64);
        for j in 0..n {
            let phi = (j as f64 + 0.5) / n as f64 * std::f64::consts::TAU;
            let d = s * rho.cos() + (e1 * phi.cos() + e2 * phi.sin()) * rho.sin();
            let hit = x + f64::from(H) * d.x / d.y;
            if hit.abs() < f64::from(W) / 2.0 {
                sum += d.y * area;
            }
        }
    }
    sum * f64::from(SUN_L)
}

/// The floor's irradiance at `(x, 0, 0)` as the direct pass estimates it, seen from above
/// (the radiance is `ρ/π E` on the Lambertian floor): the mean of estimates
/// `first .. first + count`.
fn estimated(vis: &Visibility, direct: &PixelDirect, x: f32, first: u64, count: u32) -> f64 {
    let p = Vec3::new(x, 0.0, 0.0);
    let eye = Vec3::new(x + 0.01, 0.5, 0.02);
    let (_, point) = vis.lookup_and_point(Ray::new(eye, (p - eye).normalize()));
    let point = point.expect("the floor");
    assert!((point.position - p).length() < 1e-4, "{}", point.position);
    let seed = (x * 1e4) as u64;
    f64::from(
        vis.with_placed(|s| direct.mean(s, &point, seed, first, count).radiance)
            .x,
    ) * std::f64::consts::PI
        / f64::from(RHO)
}

#[test]
fn sun_through_a_slit_gives_the_exact_patch_and_edges() {
    let scene = Arc::new(slit());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    assert_eq!(direct.shadow_rays(), 1);

    // Lit: E = L (s·n) π sin² r exactly (the disc's cosine-weighted solid angle); one
    // direction in the disc gives L Ω cos θ_d, which differs from it by at most the
    // relative change of cos θ over the disc, tan θ_s sin r + (1 − cos r) = 0.27 %.
    let lit = lit_irradiance();
    let q = quadrature(-0.577, 400);
    assert!(
        (q - lit).abs() < 1e-4 * lit,
        "quadrature {q} against the closed form {lit}"
    );
    let one = f64::from(TILT.tan() * SUN_R.sin() + (1.0 - SUN_R.cos()));
    // The geometric edges (the disc's centre grazing the plates) and the penumbra's half
    // width about them: x_e = −H tan θ_s ± W/2, h = H (tan(θ_s + r) − tan θ_s).
    let centre = -H * TILT.tan();
    let edges = [centre - W / 2.0, centre + W / 2.0];
    let half = H * ((TILT + SUN_R).tan() - TILT.tan());
    eprintln!("lit E {lit:.4}, edges {edges:?}, penumbra half width {half:.4} m");
    assert_first_frame_exact(&vis, &direct, (lit, one), edges, half);

    // The penumbrae after N frames: each estimate is the disc's radiance times a
    // visibility of 0 or 1 (times the cosine), of variance at most E_lit²/4 (1 + 0.27 %)²;
    // the mean of N has σ ≤ E_lit (1.003) / (2 √N) (the low-discrepancy sequence does
    // better; this bound holds for independent samples too). Every point across the two
    // penumbrae is within 4σ plus the quadrature's error (the 400 × 400 midpoint rule
    // cuts ≈ 2 × 400 cells at the slit's edge, each off by at most half its weight:
    // ≤ 1/400 of E_lit) of the exact value.
    let frames = 1024u32;
    let sigma = lit * (1.0 + one) / (2.0 * f64::from(frames).sqrt());
    let tolerance = 4.0 * sigma + lit / 400.0;
    let mut worst = 0f64;
    let mut crossings = Vec::new();
    for edge in edges {
        let (xs, profile) = penumbra_profile(&vis, &direct, (edge, half), frames);
        assert_first_estimates_within_a_quarter(&vis, &direct, (&xs, &profile), lit);
        for (x, (e, q)) in xs.iter().zip(&profile) {
            worst = worst.max((e - q).abs() / lit);
            assert!(
                (e - q).abs() <= tolerance,
                "x = {x}: {frames} frames give {e:.4}, exact {q:.4} ± {tolerance:.4}"
            );
        }
        let got = half_crossing(&xs, lit, &|k| profile[k].0);
        let want = half_crossing(&xs, lit, &|k| profile[k].1);
        crossings.push((got, want));
    }
    // The edge's position: near the middle of a penumbra the irradiance rises with slope
    // E_lit (2/π)/h (a straight cut across a uniform disc), so an error of 4σ in E moves
    // the crossing by at most 4σ π h / (2 E_lit) (plus the scan's linear interpolation
    // of a curve that is straight to second order there: negligible).
    let position = 4.0 * sigma * std::f64::consts::PI * f64::from(half) / (2.0 * lit)
        + f64::from(half) / 400.0;
    for (got, want) in &crossings {
        assert!(
            (got - want).abs() <= position,
            "edge at {got:.5} m, exact {want:.5} m ± {position:.5}"
        );
    }
    eprintln!(
        "penumbrae after {frames} frames: worst error {:.4} of E_lit (bound {:.4}); edges {crossings:?} (bound {position:.5} m)",
        worst,
        tolerance / lit
    );
}

/// The first frame (estimate 0 of each pixel's sequence) is exact (within `one` of `lit`)
/// in the lit patch and zero in the umbra, wherever the point is more than the penumbra's
/// half width `half` (with a margin of 1 mm for the slant of the plates' edges seen from
/// the point) from an edge.
fn assert_first_frame_exact(
    vis: &Visibility,
    direct: &PixelDirect,
    (lit, one): (f64, f64),
    edges: [f32; 2],
    half: f32,
) {
    let mut lit_n = 0;
    let mut umbra_n = 0;
    for k in 0..400 {
        let x = -2.5 + 4.0 * (k as f32 + 0.5) / 400.0;
        let from_edge = edges.iter().map(|e| (x - e).abs()).fold(f32::MAX, f32::min);
        if from_edge < half + 1e-3 {
            continue;
        }
        let e = estimated(vis, direct, x, 0, 1);
        if x > edges[0] && x < edges[1] {
            lit_n += 1;
            assert!(
                (e - lit).abs() <= one * lit,
                "x = {x}: first frame {e}, lit {lit} ± {:.2} %",
                100.0 * one
            );
        } else {
            umbra_n += 1;
            assert_eq!(e, 0.0, "x = {x}: first frame in the umbra");
        }
    }
    assert!(lit_n > 50 && umbra_n > 50, "{lit_n} lit, {umbra_n} umbra");
}

/// A scan across the penumbra about `edge` (of half width `half`), 49 points: where, and
/// at each the mean of `frames` estimates and the exact irradiance.
fn penumbra_profile(
    vis: &Visibility,
    direct: &PixelDirect,
    (edge, half): (f32, f32),
    frames: u32,
) -> (Vec<f32>, Vec<(f64, f64)>) {
    let steps = 48;
    let xs: Vec<f32> = (0..=steps)
        .map(|k| edge - 1.2 * half + 2.4 * half * k as f32 / steps as f32)
        .collect();
    let profile = xs
        .iter()
        .map(|&x| {
            (
                estimated(vis, direct, x, 0, frames),
                quadrature(f64::from(x), 400),
            )
        })
        .collect();
    (xs, profile)
}

/// A new point's first estimate takes FIRST_SUN_SAMPLES of the disc: where a fraction p
/// of the disc is seen, one sample's squared error averages E_lit² p(1 − p), and the mean
/// of four independent ones a quarter of that. Over the scan (`xs`, its exact values in
/// `profile`) the average is held to 1.5 times a quarter (the low-discrepancy samples are
/// at 0.8 of it; one sample a point, 1.9).
fn assert_first_estimates_within_a_quarter(
    vis: &Visibility,
    direct: &PixelDirect,
    (xs, profile): (&[f32], &[(f64, f64)]),
    lit: f64,
) {
    let first_mse = xs
        .iter()
        .zip(profile)
        .map(|(&x, (_, q))| (estimated(vis, direct, x, 0, 1) - q).powi(2))
        .sum::<f64>()
        / xs.len() as f64;
    let one_sample = profile
        .iter()
        .map(|(_, q)| {
            let p = (q / lit).clamp(0.0, 1.0);
            p * (1.0 - p) * lit * lit
        })
        .sum::<f64>()
        / xs.len() as f64;
    eprintln!(
        "first estimate: mean squared error {:.4} E², one sample's {:.4} E²",
        first_mse / (lit * lit),
        one_sample / (lit * lit)
    );
    assert!(
        first_mse <= 1.5 * one_sample / 4.0,
        "the first frame's penumbra: mean squared error {:.4} E², one sample's {:.4} E²",
        first_mse / (lit * lit),
        one_sample / (lit * lit)
    );
}

/// Where a scan's irradiance `f(k)` at the points `xs` crosses half the lit value `lit`
/// (linear between the points).
fn half_crossing(xs: &[f32], lit: f64, f: &dyn Fn(usize) -> f64) -> f64 {
    let target = lit / 2.0;
    (0..xs.len() - 1)
        .find_map(|k| {
            let (a, b) = (f(k) - target, f(k + 1) - target);
            (a * b <= 0.0 && a != b)
                .then(|| f64::from(xs[k]) + (f64::from(xs[k + 1]) - f64::from(xs[k])) * a / (a - b))
        })
        .expect("a crossing")
}

/// A screen under the slit's plates, looking down at the floor across both edges of the
/// patch, seen from `eye`.
fn under_the_plates(eye: Vec3) -> WallView {
    WallView {
        eye,
        pa: Vec3::new(-1.8, 0.4, 0.6),
        pb: Vec3::new(0.6, 0.4, 0.6),
        pc: Vec3::new(-1.8, 0.4, -0.6),
        size: Size::new(48, 24),
    }
}

/// The floor's exact irradiance at `(x, 0, z)`: the quadrature's within the penumbrae
/// (interpolated between points 1/64 of a penumbra apart, where the curve bends by a
/// millionth of `E_lit`), the lit value or zero beyond them.
fn exact_irradiance() -> impl Fn(f32) -> f64 {
    let lit = lit_irradiance();
    let centre = -H * TILT.tan();
    let edges = [centre - W / 2.0, centre + W / 2.0];
    let half = H * ((TILT + SUN_R).tan() - TILT.tan()) + 1e-3;
    let steps = 128;
    let tables: Vec<Vec<f64>> = (edges.iter())
        .map(|e| {
            (0..=steps)
                .map(|k| {
                    quadrature(
                        f64::from(e - half + 2.0 * half * k as f32 / steps as f32),
                        400,
                    )
                })
                .collect()
        })
        .collect();
    move |x: f32| {
        for (e, table) in edges.iter().zip(&tables) {
            if (x - e).abs() < half {
                let f = (x - (e - half)) / (2.0 * half) * steps as f32;
                let k = (f.floor() as usize).min(steps - 1);
                let a = f64::from(f - k as f32);
                return table[k] * (1.0 - a) + table[k + 1] * a;
            }
        }
        if x > edges[0] && x < edges[1] {
            lit
        } else {
            0.0
        }
    }
}

/// A still view's pixel across the patch's edge shows the mean light over its patch of
/// the floor, as the path tracer's pixel does, not the light at its centre: each estimate
/// is taken at its own place in the pixel (`DirectPoint::span`). After 1024 frames every
/// pixel whose patch holds an edge is within 4σ of the mean of a 64 × 64 grid of the
/// pixel's rays over the exact irradiance (the grid's own error at most two of its
/// columns, 2/64 of `E_lit`), allowing for the span's affine map of the pixel onto the
/// floor against the rays' (their two means' difference, computed per pixel).
#[test]
fn a_still_pixel_across_a_shadows_edge_shows_its_patchs_mean() {
    let (scene, vis, direct, view, points) = still_under_the_plates();
    let mut acc = Accumulator::new();
    let frames = 1024;
    let mut means = Vec::new();
    for _ in 0..frames {
        means = vis.with_placed(|sc| acc.add(&direct, sc, &points, &no_gathers));
    }
    let (_, across) = assert_patch_means(&scene, &view, &points, &means, |_| frames);
    assert!(across >= 20, "only {across} pixels across an edge");
}

/// A still view whose means settle (`Settling::WALLS`) spends its estimates where the
/// light varies: after 256 frames, a pixel whose patch is all lit or all in the umbra
/// (every sample of the sun's disc agrees) takes one estimate in 16 frames, its turn to
/// look again; a pixel across the patch's edge (one estimate's spread about half the lit
/// value: 2,500 estimates to a 2 % error) still takes one every frame. Every pixel shows
/// its patch's mean within what its own estimates allow (as above, `σ/√n` for the `n` it
/// holds). Seen to fail against a stale mean kept (settled after two frames that agreed,
/// never looked at again): pixels across the edge then show all or none of the sun.
#[test]
fn a_settled_still_view_estimates_only_where_the_light_varies() {
    let (scene, vis, direct, view, points) = still_under_the_plates();
    let rule = Settling::WALLS;
    let mut acc = Accumulator::settling(rule);
    let (frames, last) = (256, 16);
    let mut means = Vec::new();
    let mut held_before = Vec::new();
    let mut taken = 0;
    for f in 0..frames {
        if f == frames - last {
            held_before = (0..points.len()).map(|i| acc.frames(i)).collect();
        }
        means = vis.with_placed(|sc| acc.add(&direct, sc, &points, &no_gathers));
        if f >= frames - last {
            taken += acc.taken();
        }
    }
    let held: Vec<u32> = (0..points.len()).map(|i| acc.frames(i)).collect();
    let (checked, across) = assert_patch_means(&scene, &view, &points, &means, |i| held[i]);
    assert!(across >= 20, "only {across} pixels across an edge");
    let lit = lit_irradiance() as f32 * RHO / std::f32::consts::PI;
    let (mut even, mut varying) = (0, 0);
    for (i, p) in points.iter().enumerate() {
        if p.is_none() {
            continue;
        }
        let late = held[i] - held_before[i];
        let shown = means[i].radiance.x;
        if shown < 1e-6 * lit || (shown / lit - 1.0).abs() < 1e-3 {
            even += 1;
            assert!(
                late <= 1,
                "pixel {i}, evenly lit ({shown}), took {late} of {last}"
            );
        } else if shown > 0.2 * lit && shown < 0.8 * lit {
            varying += 1;
            assert_eq!(late, last, "pixel {i} across the edge ({shown} of {lit})");
        }
    }
    eprintln!(
        "{checked} pixels checked; {even} evenly lit, {varying} across an edge; \
         {:.1} of {} pixels took estimates a frame over the last {last}",
        taken as f64 / f64::from(last),
        points.len()
    );
    assert!(
        even > points.len() / 2 && varying >= 20,
        "{even} even, {varying} varying"
    );
}

/// The slit's scene, its visibility and direct light, the still view under the plates
/// from (−0.6, 0.8, 0) and what its pixels see.
fn still_under_the_plates() -> (
    Arc<Scene>,
    Visibility,
    PixelDirect,
    WallView,
    Vec<Option<DirectPoint>>,
) {
    let scene = Arc::new(slit());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    let view = under_the_plates(Vec3::new(-0.6, 0.8, 0.0));
    let points = vis.pixels_and_points(&view).1;
    (scene, vis, direct, view, points)
}

/// Checks every pixel of `view` (its `points`) whose patch lies on one triangle of the
/// slit's floor: its mean (of `held(i)` estimates) is within 4σ of the mean of a 64 × 64
/// grid of the pixel's rays over the exact irradiance (the grid's own error at most two of
/// its columns, 2/64 of `E_lit`), allowing for the span's affine map of the pixel onto the
/// floor against the rays' (their two means' difference, computed per pixel). Returns how
/// many pixels it checked, and how many of them lie across an edge.
fn assert_patch_means(
    scene: &Scene,
    view: &WallView,
    points: &[Option<DirectPoint>],
    means: &[Estimate],
    held: impl Fn(usize) -> u32,
) -> (usize, usize) {
    let exact = exact_irradiance();
    let lit = lit_irradiance();
    let g = 64;
    let (mut checked, mut across, mut worst) = (0, 0, 0f64);
    for (i, p) in points.iter().enumerate() {
        let Some(p) = p else { continue };
        let frames = held(i).max(1);
        let sigma = lit * (1.0 + f64::from(TILT.tan() * SUN_R.sin() + (1.0 - SUN_R.cos())))
            / (2.0 * f64::from(frames).sqrt());
        let (x, y) = ((i % 48) as f32, (i / 48) as f32);
        // The pixel's rays on a grid, and the span's points for the same places.
        let mut rays_mean = 0.0;
        let mut span_mean = 0.0;
        let mut one_triangle = true;
        for a in 0..g {
            for b in 0..g {
                let (u, v) = ((a as f32 + 0.5) / g as f32, (b as f32 + 0.5) / g as f32);
                let ray = view.ray(Vec2::new(x + u, y + v));
                let Some(hit) = scene.closest_hit(&ray, f32::INFINITY) else {
                    one_triangle = false;
                    continue;
                };
                one_triangle &= hit.triangle == p.triangle;
                rays_mean += exact(ray.at(hit.t).x);
                let at = p.position + p.span[0] * (u - 0.5) + p.span[1] * (v - 0.5);
                span_mean += exact(at.x);
            }
        }
        // A pixel across the floor's two triangles takes the other's part at its centre.
        if !one_triangle {
            continue;
        }
        let n = f64::from(g * g);
        let (rays_mean, span_mean) = (rays_mean / n, span_mean / n);
        let shown = f64::from(means[i].radiance.x) * std::f64::consts::PI / f64::from(RHO);
        let tolerance = 4.0 * sigma + 2.0 * lit / f64::from(g) + (rays_mean - span_mean).abs();
        checked += 1;
        if rays_mean > 0.2 * lit && rays_mean < 0.8 * lit {
            across += 1;
        }
        worst = worst.max((shown - rays_mean).abs() / lit);
        assert!(
            (shown - rays_mean).abs() <= tolerance,
            "pixel ({x}, {y}): {shown:.4} after {frames} estimates, its patch's mean {rays_mean:.4} ± {tolerance:.4}"
        );
    }
    eprintln!("{checked} pixels, {across} across an edge; worst error {worst:.4} of E_lit");
    (checked, across)
}

/// A moving eye keeps the running means: after 16 frames of one view, the eye moved 2 cm
/// (the screen, a CAVE wall, stays), almost every pixel carries its mean on and adds one
/// estimate to it, and the lit patch and the umbra are still exact.
#[test]
fn a_moving_eye_carries_the_means_over_and_stays_exact() {
    let scene = Arc::new(slit());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    let a = under_the_plates(Vec3::new(-0.6, 0.8, 0.0));
    let b = under_the_plates(Vec3::new(-0.58, 0.8, 0.0));
    let points = |v: &WallView| vis.pixels_and_points(v).1;
    let (pa, pb) = (points(&a), points(&b));
    let mut acc = Accumulator::new();
    for _ in 0..16 {
        vis.with_placed(|sc| acc.add(&direct, sc, &pa, &no_gathers));
    }
    acc.reproject(&a, &b, &pb);
    let means = vis.with_placed(|sc| acc.add(&direct, sc, &pb, &no_gathers));

    let seen: Vec<usize> = (0..pb.len()).filter(|&i| pb[i].is_some()).collect();
    let carried = seen.iter().filter(|&&i| acc.frames(i) == 17).count();
    // Lost only where the point lies on the quad's diagonal (another triangle seen from
    // the old eye: a line of pixels, ~4 %) or came into sight at the border (2 cm at 0.8 m:
    // under a column, ~2 %).
    assert!(
        carried * 10 >= seen.len() * 9,
        "{carried} of {} pixels carried their means",
        seen.len()
    );
    // The eye moved 2 cm, and a pixel's point on the floor (twice as far as the screen)
    // 2 cm with it: beyond the penumbra and 5 cm, a carried mean is exact.
    let margin = H * ((TILT + SUN_R).tan() - TILT.tan()) + 0.05;
    let (lit_n, umbra_n) = assert_patch_exact(&pb, &means, margin);
    assert!(lit_n > 50 && umbra_n > 50, "{lit_n} lit, {umbra_n} umbra");
}

/// Checks every pixel whose point lies farther than `margin` from the slit patch's edges:
/// in the umbra no direct light at all, in the patch the sun's within what one sample may
/// differ by (a direction at the disc's rim: a mean begun this frame may hold one).
/// Returns how many lit and umbra pixels it checked.
fn assert_patch_exact(
    points: &[Option<DirectPoint>],
    means: &[Estimate],
    margin: f32,
) -> (u32, u32) {
    let lit = lit_irradiance();
    // One sample's most, plus f32 rounding.
    let one = f64::from(TILT.tan() * SUN_R.sin() + (1.0 - SUN_R.cos())) + 1e-5;
    let centre = -H * TILT.tan();
    let edges = [centre - W / 2.0, centre + W / 2.0];
    let (mut lit_n, mut umbra_n) = (0, 0);
    for (i, p) in points.iter().enumerate() {
        let Some(p) = p else { continue };
        let x = p.position.x;
        if edges.iter().any(|e| (x - e).abs() < margin) {
            continue;
        }
        let e = f64::from(means[i].radiance.x) * std::f64::consts::PI / f64::from(RHO);
        if x > edges[0] && x < edges[1] {
            lit_n += 1;
            assert!(
                (e - lit).abs() <= one * lit,
                "pixel {i} at x = {x}: {e}, lit {lit}"
            );
        } else {
            umbra_n += 1;
            assert_eq!(e, 0.0, "pixel {i} at x = {x}: in the umbra");
        }
    }
    (lit_n, umbra_n)
}

/// An eye sweeping sideways in small steps (96 steps of 5 mm, each carrying the means on)
/// leaves no trail: a mean is carried only while its point stays within a pixel's
/// footprint of where the mean began, so none drifts across an edge of the patch, and
/// after the sweep the umbra is still dark and the patch exactly lit everywhere but
/// within the penumbra and two footprints of an edge (a mean's estimates lie within a
/// footprint of where it began, the point seen now within one of that).
#[test]
fn a_sweeping_eye_leaves_no_trail_across_the_shadows_edge() {
    let scene = Arc::new(slit());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    let screen = |x: f32| under_the_plates(Vec3::new(x, 0.8, 0.0));
    let mut acc = Accumulator::new();
    let mut from = screen(-0.84);
    let mut points = vis.pixels_and_points(&from).1;
    let mut means = vis.with_placed(|sc| acc.add(&direct, sc, &points, &no_gathers));
    for step in 1..=96 {
        let to = screen(-0.84 + 0.005 * step as f32);
        points = vis.pixels_and_points(&to).1;
        acc.reproject(&from, &to, &points);
        means = vis.with_placed(|sc| acc.add(&direct, sc, &points, &no_gathers));
        from = to;
    }
    // A pixel is 5 cm on a screen 0.4 m below the eye, parallel to the floor 0.8 m below
    // it: its footprint there is 10 cm.
    let footprint = 2.4 / 48.0 * 0.8 / 0.4;
    let margin = H * ((TILT + SUN_R).tan() - TILT.tan()) + 2.0 * footprint;
    let (lit_n, umbra_n) = assert_patch_exact(&points, &means, margin);
    assert!(lit_n > 50 && umbra_n > 50, "{lit_n} lit, {umbra_n} umbra");
}

// The highlight: a glossy metal plane (GGX α = 0.04) under a small square lamp, seen
// around the lamp's mirror image. Nothing else in the scene: the plane is flat and the
// lamp's back is black, so the light field's remainder is zero and the whole picture is
// the direct light.
fn highlight() -> Scene {
    let floor = common::quad(Vec3::new(-2.0, 0.0, -2.0), Vec3::Z * 4.0, Vec3::X * 4.0);
    let a = 0.1;
    // The lamp faces −y (a × b = x × z = −y).
    let lamp = common::quad(Vec3::new(-a, 1.0, -a), Vec3::X * 2.0 * a, Vec3::Z * 2.0 * a);
    let metal = Material {
        name: "metal".into(),
        base_color: Vec4::new(0.9, 0.8, 0.6, 1.0),
        metallic: 1.0,
        roughness: 0.2,
        ..Material::default()
    };
    let mut tris = Vec::new();
    for t in floor {
        tris.push((t, 0));
    }
    for t in lamp {
        tris.push((t, 1));
    }
    scene_with(
        "highlight",
        &tris,
        vec![metal, common::lambert("lamp", 0.0, Vec3::splat(20.0))],
        Daylight::default(),
    )
}

const SIZE: u32 = 32;
const AA: u32 = 4;

fn highlight_view() -> WallView {
    // The eye at (0, 1, 1.5) sees the lamp's image at z = 0.75 on the floor; the screen,
    // 0.6 m across, looks down at it.
    let eye = Vec3::new(0.0, 1.0, 1.5);
    let at = Vec3::new(0.0, 0.0, 0.75);
    let f = (at - eye).normalize();
    let right = f.cross(Vec3::Y).normalize();
    let up = right.cross(f);
    let c = eye + f;
    WallView {
        eye,
        pa: c - right * 0.3 - up * 0.3,
        pb: c + right * 0.3 - up * 0.3,
        pc: c - right * 0.3 + up * 0.3,
        size: Size::new(SIZE, SIZE),
    }
}

/// `view` drawn from `values` plus the direct light per pixel: `AA × AA` lookups per
/// pixel, each the mean of estimates `first .. first + frames`.
fn drawn(
    vis: &Visibility,
    direct: &PixelDirect,
    view: &WallView,
    values: &[[f32; 3]],
    first: u64,
    frames: u32,
) -> Image {
    let mut image = Image::new(view.size.width, view.size.height);
    for (i, px) in image.pixels.iter_mut().enumerate() {
        let (x, y) = (
            (i as u32 % view.size.width) as f32,
            (i as u32 / view.size.width) as f32,
        );
        let mut sum = Vec3::ZERO;
        for s in 0..AA * AA {
            let o = Vec2::new(
                ((s % AA) as f32 + 0.5) / AA as f32,
                ((s / AA) as f32 + 0.5) / AA as f32,
            );
            let (l, p) = vis.lookup_and_point(view.ray(Vec2::new(x, y) + o));
            sum += holocave_vlf::view::shade_one(&l, values);
            if let Some(p) = p {
                sum += vis.with_placed(|sc| {
                    direct
                        .mean(sc, &p, (i as u64) * 64 + u64::from(s), first, frames)
                        .radiance
                });
            }
        }
        *px = sum / (AA * AA) as f32;
    }
    image
}

#[test]
fn a_lamps_highlight_on_a_glossy_plane_matches_the_path_tracer() {
    let scene = Arc::new(highlight());
    let view = highlight_view();
    let settings = Settings {
        directions: 42,
        resolution: 32,
        ..Settings::default()
    };
    let (state, stats) = common::bake_quiet(&scene, &settings);
    assert!(stats.tiles > 0, "the metal plane has glossy tiles");
    let vis = Visibility::of(scene.clone(), &settings);
    // As a wall draws: the field's whole light for what the glossy surfaces without tiles
    // reflect, its remainder under the per-pixel pass.
    vis.light_objects(Arc::new(state.values()));
    vis.draw_with(Arc::new(state.indirect_values()), true);
    let direct = PixelDirect::new(scene.clone());
    let (reference, noise, _) = common::two_seed_reference(&scene, &view, 2048);

    // Two independent halves of a still view's frames (the sequence's first and second
    // 64): their relative MSE against each other is twice one half's noise, so the mean
    // of both has a quarter of it.
    let frames = 64;
    let a = drawn(&vis, &direct, &view, &state.indirect_values(), 0, frames);
    let b = drawn(
        &vis,
        &direct,
        &view,
        &state.indirect_values(),
        u64::from(frames),
        frames,
    );
    let own = a.relative_mse(&b) / 4.0;
    let mut image = Image::new(SIZE, SIZE);
    for (r, (a, b)) in image.pixels.iter_mut().zip(a.pixels.iter().zip(&b.pixels)) {
        *r = (*a + *b) * 0.5;
    }
    let split = image.relative_mse(&reference);
    let old = vis
        .render(&view, &state.values(), AA)
        .relative_mse(&reference);
    let mean = |im: &Image| im.pixels.iter().map(|p| f64::from(p.x)).sum::<f64>();
    let peak = |im: &Image| im.pixels.iter().map(|p| p.x).fold(0f32, f32::max);
    eprintln!(
        "highlight: per-pixel direct relative MSE {split:.5} (its noise {own:.5}, the reference's {noise:.5}); light field alone {old:.5}; peak {} / reference {}; sum {:.3} / {:.3}",
        peak(&image),
        peak(&reference),
        mean(&image),
        mean(&reference)
    );
    // Both are unbiased estimates of the same pixel means, so the expected relative MSE
    // between them is the sum of their noises: held to twice that (a bias of a tenth of
    // the noise's root would already show as +1 %).
    assert!(
        split <= 2.0 * (noise + own),
        "relative MSE {split:.5} against the path tracer, above 2 × (n̂ {noise:.5} + own {own:.5})"
    );
    // The light field alone blurs the highlight far outside that bound.
    assert!(old > 10.0 * (noise + own), "light field alone {old:.5}");
}
