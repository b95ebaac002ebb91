//! The other split: the sky's light per pixel too (`PixelDirect::with_sky`) and the light
//! field less the sky's first arrival (`State::indirect_values_without_sky`). On a floor
//! under a uniform sky and nothing else, every part is known: the field's sky part is the
//! sky's radiance times the directions' cosine quadrature (`π L Q`), nothing is
//! inter-reflected, the pixel's own sky samples average `ρ L`, and the two splits draw the
//! same floor but for the quadrature's `1 − Q`.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::{Daylight, Ray, Sky, SkyModel};
use holocave_vlf::plane_smooth::smooth_over_planes;
use holocave_vlf::split::Split;
use holocave_vlf::tiles::alpha_floor;
use holocave_vlf::view::shade_one;
use holocave_vlf::{DirectPoint, Directions, PixelDirect, Settings, Visibility};
use rand::{Rng, SeedableRng, rngs::SmallRng};

const RHO: f32 = 0.5;
const SKY_L: f32 = 2.0;
/// Half the floor's side: the centre sees the sky down to 4° above the horizon's edge.
const HALF: f32 = 30.0;

fn floor_under_the_sky() -> holocave_scene::Scene {
    let floor = common::floor(HALF);
    common::scene_of(
        "floor under the sky",
        &floor.map(|t| (t, 0)),
        vec![common::lambert("floor", RHO, Vec3::ZERO)],
        |p| p.daylight = uniform_sky(),
    )
}

#[test]
fn the_sky_split_conserves_the_light_and_draws_the_same_floor() {
    let scene = Arc::new(floor_under_the_sky());
    let settings = Settings {
        directions: 92,
        resolution: 48,
        element_size: Some(1.0),
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    assert!(state.converged);
    let sky = state.sky_values().expect("the sky's part is baked");
    let rest = state.indirect_values_without_sky().unwrap();
    let values = state.values();
    // Every element: the total is the direct part (none: no sun, no lamp), the sky's part
    // and the rest, each not negative.
    for (i, ((t, s), r)) in values.iter().zip(&sky).zip(&rest).enumerate() {
        for c in 0..3 {
            assert!(
                s[c] >= 0.0 && (t[c] - s[c] - r[c]).abs() <= 1e-5 * t[c].max(1e-3),
                "value {i}: total {t:?}, sky {s:?}, rest {r:?}"
            );
        }
    }

    // Seen from above, over the floor's middle: the field's sky part averages π L Q (ρ/π
    // of it drawn), where Q is the directions' cosine quadrature; the rest is nothing (a
    // floor reflects nothing back onto itself). Each lookup carries the lines' noise
    // (which lines of a direction hit an element), so the mean of N lookups is held to 4
    // standard errors, times 3 for the 3 × 3 smoothing that spreads one element's noise
    // over its neighbours, plus the sky beyond the floor's edge (below 4° from the
    // corners: cos² 86°, 0.5 % of the cosine-weighted hemisphere).
    let vis = Visibility::of(scene.clone(), &settings);
    let q = cosine_quadrature(settings.directions);
    let (mut drawn, mut inter) = (Vec::new(), 0f64);
    for i in 0..40 {
        for j in 0..40 {
            let at = Vec3::new(
                -25.0 + i as f32 * 1.25 + 0.3,
                1.5,
                -25.0 + j as f32 * 1.25 + 0.2,
            );
            let (l, _) = vis.lookup_and_point(Ray::new(at, Vec3::NEG_Y));
            drawn.push(f64::from(shade_one(&l, &sky).x));
            inter = inter.max(f64::from(shade_one(&l, &rest).x));
        }
    }
    let n = drawn.len() as f64;
    let mean = drawn.iter().sum::<f64>() / n;
    let se = (drawn.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt() / n.sqrt();
    let field = f64::from(RHO * SKY_L) * q;
    assert!(
        (mean - field).abs() <= 12.0 * se + 0.005 * field,
        "the field's sky over the floor {mean} (standard error {se}), ρ L Q = {field} (Q = {q:.4})"
    );
    assert!(inter < 1e-3 * field, "nothing inter-reflected: {inter}");

    // The pixel's own samples of the sky at one point: each is 2 ρ L cos θ over the upper
    // hemisphere (the sky's pdf 1/2π there), variance (ρ L)²/3; the mean of n from the R
    // sequence at most 4 σ/√n off ρ L (plus the sky below the edge, as above).
    let direct = PixelDirect::new(scene.clone()).with_sky(true);
    assert_eq!(
        direct.shadow_rays(),
        2,
        "a sample of the sky and one of the BSDF"
    );
    let eye = Vec3::new(0.3, 1.5, 0.2);
    let (_, point) = vis.lookup_and_point(Ray::new(eye, Vec3::NEG_Y));
    let point = point.expect("the floor");
    let samples = 16_384;
    let e = vis.with_placed(|s| direct.mean(s, &point, 7, 0, samples));
    assert_eq!(e.radiance, e.sky, "all of it the sky's");
    let exact = f64::from(RHO * SKY_L);
    let sigma = exact / 3f64.sqrt() / f64::from(samples).sqrt();
    assert!(
        (f64::from(e.sky.x) - exact).abs() <= 4.0 * sigma + 0.005 * exact,
        "the pixel's sky {} against ρ L = {exact}",
        e.sky.x
    );
    // So the two splits draw the same floor but for the quadrature: the field's is Q
    // times the pixel's.
    assert!(
        (mean / f64::from(e.sky.x) - q).abs() <= (12.0 * se + 4.0 * sigma) / exact + 0.01,
        "field {mean}, pixel {}, Q {q}",
        e.sky.x
    );
}

/// Q: the upward cosine summed over the field's directions (at least `directions` of
/// them), each weighted by its solid angle, over π; 1 for an exact quadrature.
fn cosine_quadrature(directions: usize) -> f64 {
    let d = Directions::at_least(directions);
    (d.dirs.iter().zip(&d.solid_angle))
        .map(|(w, s)| f64::from(*s) * f64::from(w.y.max(0.0)))
        .sum::<f64>()
        / std::f64::consts::PI
}

/// Where the tiles blur the sky (the walls' default: `Split` with
/// `sky_per_pixel` false): a floor, varnished on one half (GGX α 0.0625,
/// narrower than the 0.26 a tile resolves here) and diffuse on the other, under a
/// ceiling with a square hole above each half, and a uniform sky. The field is read
/// whole, and the per-pixel pass adds, on the varnish only, the difference between the
/// sky its own lobe reflects through the hole and the sky its tile's widened lobe
/// reflects: checked against that difference estimated independently, by each BSDF's
/// own sampling with a shadow ray per sample.
#[test]
fn the_sky_reflected_by_a_narrower_lobe_than_a_tile_holds_is_sharpened_per_pixel() {
    let scene = Arc::new(half_varnished_floor_under_a_holed_ceiling());
    let settings = Settings {
        directions: 92,
        resolution: 48,
        element_size: Some(4.0),
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    let vis = Visibility::of(scene.clone(), &settings);
    let layout = (vis.elements(), vis.tiles());
    let split = Split::new(scene.clone(), &settings, &state, layout, false).unwrap();
    assert!(split.sky.is_none(), "the field keeps its sky");
    let whole = smooth_over_planes(&scene, layout.0, layout.1, &state.indirect_values());
    assert_eq!(split.remainder, whole, "read whole");
    let floor = alpha_floor(8, Settings::rounded_directions(settings.directions));

    for (centre, varnished) in HOLE_CENTRES.into_iter().zip([true, false]) {
        let eye = centre + Vec3::Y * 1.5;
        let (_, point) = vis.lookup_and_point(Ray::new(eye, Vec3::NEG_Y));
        let point = point.expect("the floor");
        let samples = 16_384;
        let e = vis.with_placed(|s| split.direct.mean(s, &point, 5, 0, samples));
        if !varnished {
            assert_eq!(e.radiance, Vec3::ZERO, "nothing added on the diffuse half");
            continue;
        }
        let (a, b, bound) = sharpening_by_the_bsdfs_own_sampling(&vis, &point, floor);
        let sharpened = f64::from(e.radiance.x);
        assert!(
            a - b > 5.0 * bound,
            "the hole's reflection is sharper than the tile's: {a} against {b}"
        );
        assert!(
            (sharpened - (a - b)).abs() <= bound,
            "sharpened by {sharpened}, by the BSDFs' own sampling {} (own {a}, widened {b})",
            a - b
        );
        check_first_estimates_sharpen_as_much_on_average(&vis, &split, &point, a - b, bound);
        check_gathers_take_no_sharpened_reflection(&scene, &vis, &split, eye, a - b);
    }
}

/// The side of each square hole in the ceiling.
const HOLE: f32 = 0.5;
const HALF_HOLE: f32 = HOLE / 2.0;
/// The ceiling's height over the floor.
const CEILING: f32 = 2.0;
/// Below each hole: one over the varnished half, one over the diffuse half.
const HOLE_CENTRES: [Vec3; 2] = [Vec3::new(-5.0, 0.0, 0.3), Vec3::new(5.0, 0.0, 0.3)];

/// A uniform sky of radiance `SKY_L` over a black ground, and no sun.
fn uniform_sky() -> Daylight {
    Daylight {
        sky: Some(Sky {
            model: SkyModel::Uniform(Vec3::splat(SKY_L)),
            ground: Vec3::ZERO,
        }),
        ..Default::default()
    }
}

/// The floor, varnished (material 0) for x < 0 and diffuse (material 1) beyond, under
/// the holed ceiling (diffuse too), and the uniform sky.
fn half_varnished_floor_under_a_holed_ceiling() -> holocave_scene::Scene {
    let mut triangles: Vec<([Vec3; 3], u32)> = Vec::new();
    let halves = [
        common::quad(
            Vec3::new(-HALF, 0.0, -HALF),
            Vec3::Z * 2.0 * HALF,
            Vec3::X * HALF,
        ),
        common::quad(
            Vec3::new(0.0, 0.0, -HALF),
            Vec3::Z * 2.0 * HALF,
            Vec3::X * HALF,
        ),
    ];
    for (m, q) in halves.iter().enumerate() {
        triangles.extend(q.iter().map(|t| (*t, m as u32)));
    }
    triangles.extend(holed_ceiling().into_iter().map(|t| (t, 1)));
    let varnish = holocave_scene::Material {
        roughness: 0.25,
        specular: 1.0,
        ..common::lambert("varnish", RHO, Vec3::ZERO)
    };
    common::scene_of(
        "varnished and diffuse floor under a ceiling with holes",
        &triangles,
        vec![varnish, common::lambert("diffuse", RHO, Vec3::ZERO)],
        |p| p.daylight = uniform_sky(),
    )
}

/// The ceiling (facing down) around the two holes: strips between and around them.
fn holed_ceiling() -> Vec<[Vec3; 3]> {
    let (x0, x1) = (-5.0 - HALF_HOLE, -5.0 + HALF_HOLE);
    let (x2, x3) = (5.0 - HALF_HOLE, 5.0 + HALF_HOLE);
    let (z0, z1) = (0.3 - HALF_HOLE, 0.3 + HALF_HOLE);
    let rect = |xa: f32, xb: f32, za: f32, zb: f32| {
        common::quad(
            Vec3::new(xa, CEILING, za),
            Vec3::X * (xb - xa),
            Vec3::Z * (zb - za),
        )
    };
    [
        rect(-HALF, HALF, -HALF, z0),
        rect(-HALF, HALF, z1, HALF),
        rect(-HALF, x0, z0, z1),
        rect(x1, x2, z0, z1),
        rect(x3, HALF, z0, z1),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The same difference by each BSDF's own sampling: the mean of f cos / p times the sky
/// where the sample passes the hole, for the surface's BSDF less its widened one; 4
/// standard errors of that difference. Returns the own lobe's mean, the widened lobe's,
/// and the bound (those 4 standard errors plus 1 % of the own).
fn sharpening_by_the_bsdfs_own_sampling(
    vis: &Visibility,
    point: &DirectPoint,
    floor: f32,
) -> (f64, f64, f64) {
    let own = sky_reflected_by_sampling(vis, point, &point.bsdf, 1);
    let wide = sky_reflected_by_sampling(vis, point, &point.bsdf.widened(floor), 2);
    let ((a, va), (b, vb)) = (mean_and_its_variance(&own), mean_and_its_variance(&wide));
    (a, b, 4.0 * (va + vb).sqrt() + 0.01 * a)
}

/// 200,000 samples of `bsdf` at `point`, each f cos / p times the sky if its ray leaves
/// upwards unoccluded (through a hole), else nothing.
fn sky_reflected_by_sampling(
    vis: &Visibility,
    point: &DirectPoint,
    bsdf: &holocave_tracer::bsdf::Bsdf,
    seed: u64,
) -> Vec<f64> {
    let frame = holocave_tracer::frame::Frame::new(point.shading_normal);
    let wo = frame.to_local(point.wo);
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..200_000)
        .map(|_| {
            let (uc, u) = (rng.random(), glam::Vec2::new(rng.random(), rng.random()));
            let Some(b) = bsdf.sample(wo, uc, u) else {
                return 0.0;
            };
            let wi = frame.to_world(b.wi).normalize();
            let ray = Ray::leaving(point.position, point.normal, wi);
            let open = vis.with_placed(|s| !s.occluded(&ray, f32::INFINITY));
            if open && wi.y > 0.0 {
                f64::from(b.weight.x * SKY_L)
            } else {
                0.0
            }
        })
        .collect()
}

/// The mean of `v` and the variance of that mean.
fn mean_and_its_variance(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n / n)
}

/// A new point's first estimate (FIRST_SHARPENING_PAIRS pairs, each its share) has the
/// same mean as the sharpening `difference`, taken over many pixels' sequences.
fn check_first_estimates_sharpen_as_much_on_average(
    vis: &Visibility,
    split: &Split,
    point: &DirectPoint,
    difference: f64,
    bound: f64,
) {
    let firsts: Vec<f64> = (0..4096u64)
        .map(|seed| {
            let e = vis.with_placed(|s| split.direct.estimate(s, point, seed, 0));
            f64::from(e.radiance.x)
        })
        .collect();
    let (first, v_first) = mean_and_its_variance(&firsts);
    assert!(
        (first - difference).abs() <= bound + 4.0 * v_first.sqrt(),
        "a first estimate sharpens by {first} on average, the BSDFs' own sampling by {difference}"
    );
}

/// A gather sample there reflects the sky along its bounce with the surface's own
/// lobe, so it takes no sharpened reflection as well: each of 4,096 is what it is
/// with a per-pixel pass that sharpens nothing (the same rays and draws; the
/// ceiling, where the bounces end, is diffuse), within float rounding.
fn check_gathers_take_no_sharpened_reflection(
    scene: &Arc<holocave_scene::Scene>,
    vis: &Visibility,
    split: &Split,
    eye: Vec3,
    sharpening: f64,
) {
    let rays = vec![Ray::new(eye, Vec3::NEG_Y); 4096];
    let traced = holocave_vlf::CpuRays(scene);
    let plain = PixelDirect::new(scene.clone());
    let gather = |direct: &PixelDirect| {
        holocave_vlf::gather::gather_all(vis, direct, &split.remainder, &rays, 9, &traced)
    };
    let (with, without) = (gather(&split.direct), gather(&plain));
    let worst = (with.iter().zip(&without))
        .map(|(a, b)| (a.radiance - b.radiance).abs().max_element())
        .fold(0.0f32, f32::max);
    let mean = with.iter().map(|g| f64::from(g.radiance.x)).sum::<f64>() / 4096.0;
    assert!(
        worst <= 1e-4 * (mean as f32 + SKY_L),
        "a gather differs by up to {worst} with the sharpening (mean {mean}, the \
         sharpened reflection {sharpening})"
    );
}
