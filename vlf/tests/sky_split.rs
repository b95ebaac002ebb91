//! The other split: the sky's light per pixel too (`PixelDirect::with_sky`) and the light
//! field less the sky's first arrival (`State::indirect_values_without_sky`). On a floor
//! under a uniform sky and nothing else, every part is known: the field's sky part is the
//! sky's radiance times the directions' cosine quadrature (`π L Q`), nothing is
//! inter-reflected, the pixel's own sky samples average `ρ L`, and the two splits draw the
//! same floor but for the quadrature's `1 − Q`.

mod common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::{Daylight, Ray, Sky, SkyModel};
use holocave_vlf::split::{NARROW_SKY_PRIOR_SAMPLES, SkyPerPixel, Split};
use holocave_vlf::view::shade_one;
use holocave_vlf::{Directions, PixelDirect, Settings, Visibility};

const RHO: f32 = 0.5;
const SKY_L: f32 = 2.0;
/// Half the floor's side: the centre sees the sky down to 4° above the horizon's edge.
const HALF: f32 = 30.0;

fn floor_under_the_sky() -> holocave_scene::Scene {
    let floor = common::floor(HALF);
    let daylight = Daylight {
        sky: Some(Sky {
            model: SkyModel::Uniform(Vec3::splat(SKY_L)),
            ground: Vec3::ZERO,
        }),
        ..Default::default()
    };
    common::scene_of(
        "floor under the sky",
        &floor.map(|t| (t, 0)),
        vec![common::lambert("floor", RHO, Vec3::ZERO)],
        |p| p.daylight = daylight,
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
    let q = {
        let d = Directions::at_least(settings.directions);
        (d.dirs.iter().zip(&d.solid_angle))
            .map(|(w, s)| f64::from(*s) * f64::from(w.y.max(0.0)))
            .sum::<f64>()
            / std::f64::consts::PI
    };
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

/// Where the field blurs (the walls' default, `Split` with `SkyPerPixel::WhereBlurred`):
/// a varnished half of the floor (GGX α 0.0625, narrower than the tiles' floor α) and a
/// diffuse half under a uniform sky. The varnished half takes the sky per pixel and its
/// elements and tiles are read less the sky; the diffuse half keeps the sky in the field
/// and takes none per pixel. Each part sums to the field, and the varnished half's own
/// sky samples average `L` times the BSDF's directional albedo (the sky is uniform).
#[test]
fn the_sky_is_taken_per_pixel_where_the_tiles_blur_it_and_only_there() {
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
    let varnish = holocave_scene::Material {
        roughness: 0.25,
        specular: 1.0,
        ..common::lambert("varnish", RHO, Vec3::ZERO)
    };
    let triangles: Vec<([Vec3; 3], u32)> = (halves.iter().enumerate())
        .flat_map(|(m, q)| q.iter().map(move |t| (*t, m as u32)))
        .collect();
    let daylight = Daylight {
        sky: Some(Sky {
            model: SkyModel::Uniform(Vec3::splat(SKY_L)),
            ground: Vec3::ZERO,
        }),
        ..Default::default()
    };
    let scene = Arc::new(common::scene_of(
        "varnished and diffuse floor",
        &triangles,
        vec![varnish, common::lambert("floor", RHO, Vec3::ZERO)],
        |p| p.daylight = daylight,
    ));
    let settings = Settings {
        directions: 92,
        resolution: 48,
        // Elements larger than a line's spread (`bake::least_area`), so the varnish
        // gets tiles.
        element_size: Some(4.0),
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    let vis = Visibility::of(scene.clone(), &settings);
    assert!(!vis.tiles().tiles.is_empty(), "the varnish has tiles");
    let split = Split::new(
        scene.clone(),
        &settings,
        &state,
        vis.elements(),
        vis.tiles(),
        SkyPerPixel::WhereBlurred,
    )
    .unwrap();
    let (prior, k) = split.sky.as_ref().expect("the sky is taken somewhere");
    assert_eq!(*k, NARROW_SKY_PRIOR_SAMPLES);
    let indirect = state.indirect_values();
    for (i, ((r, p), t)) in split.remainder.iter().zip(prior).zip(&indirect).enumerate() {
        for c in 0..3 {
            assert!(
                (r[c] + p[c] - t[c]).abs() <= 1e-5 * t[c].max(1e-3),
                "value {i}: remainder {r:?} and the sky taken {p:?} sum to {t:?}"
            );
        }
    }

    let samples = 4096;
    for (x, varnished) in [(-HALF / 2.0, true), (HALF / 2.0, false)] {
        let (l, point) = vis.lookup_and_point(Ray::new(Vec3::new(x, 1.5, 0.3), Vec3::NEG_Y));
        let point = point.expect("the floor");
        let taken = shade_one(&l, prior).x;
        // Nothing is inter-reflected here: what the lookup reads is the field's sky or
        // nothing.
        let read = shade_one(&l, &split.remainder).x;
        let e = vis.with_placed(|s| split.direct.mean(s, &point, 3, 0, samples));
        if varnished {
            assert!(
                taken > 0.1 * RHO * SKY_L,
                "the field's sky left out: {taken}"
            );
            assert!(read < 1e-3 * RHO * SKY_L, "and not read: {read}");
            // The BSDF's directional albedo towards the eye, by its own sampling.
            let wo = Vec3::Z;
            let albedo = (0..samples)
                .filter_map(|n| {
                    let u = |k: u32| ((n * 3 + k) as f32 * 0.618_034).fract();
                    point.bsdf.sample(wo, u(0), glam::Vec2::new(u(1), u(2)))
                })
                .map(|b| b.weight.x)
                .sum::<f32>()
                / samples as f32;
            let exact = SKY_L * albedo;
            // The horizon beyond the floor's edge: under 0.5 % of the cosine-weighted
            // hemisphere (as above); the estimates' spread: the MIS pair's, under ρ L,
            // at 4 standard errors.
            let bound = 4.0 * RHO * SKY_L / (samples as f32).sqrt() + 0.005 * exact;
            assert!(
                (e.sky.x - exact).abs() <= bound,
                "the varnish's own sky {} against L × albedo {exact}",
                e.sky.x
            );
        } else {
            assert_eq!(taken, 0.0, "the diffuse half keeps the sky in the field");
            assert!(read > 0.1 * RHO * SKY_L, "and reads it: {read}");
            assert_eq!(e.sky, Vec3::ZERO, "and takes none per pixel");
        }
    }
}
