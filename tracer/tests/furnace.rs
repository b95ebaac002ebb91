//! Furnace tests: closed scenes whose radiance is known in closed form.
//!
//! - A closed Lambertian enclosure of albedo ρ whose every surface emits `Le` has
//!   `L = Le / (1 − ρ)` everywhere, in every direction (the Neumann series
//!   `Le (1 + ρ + ρ² + …)`), whatever its shape.
//! - A convex object in a uniform sky of radiance `Le` that neither absorbs nor loses
//!   energy (a white perfect mirror, white smooth glass) gives exactly `Le`; a rough one
//!   (single-scattering microfacets lose energy) gives at most `Le`.
//!
//! Tolerances are statistical: the estimate is a mean over independent path samples, so
//! it must lie within `z` standard errors (from the sample variance) of the truth, with
//! `z` chosen for a family-wise false-failure probability of 1e-4 over all comparisons in
//! a test (Bonferroni). Seeds are fixed, so a run is reproducible.

use crate::common;

use common::*;
use glam::Vec3;
use holocave_scene::{Daylight, Ray};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

/// Rays from uniform points inside the box `[lo, hi]` (shrunk by `margin`), uniform
/// directions.
fn interior_rays(lo: Vec3, hi: Vec3, margin: f32, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let u = Vec3::new(rng.random(), rng.random(), rng.random());
            let o = lo + margin + (hi - lo - 2.0 * margin) * u;
            Ray::new(o, uniform_sphere(&mut rng))
        })
        .collect()
}

fn stats_of(samples: &[holocave_tracer::TracedRay]) -> Stats {
    let mut s = Stats::default();
    for x in samples {
        assert!(x.radiance.iter().all(|c| c.is_finite() && *c >= 0.0));
        s.add(Vec3::from(x.radiance));
    }
    s
}

/// Asserts `|mean − expected| ≤ z · SE` per channel and that the test had power
/// (`SE ≤ 1%` of the expected value).
fn assert_mean(name: &str, s: &Stats, expected: Vec3, z: f64) {
    for c in 0..3 {
        let (m, se, e) = (s.mean(c), s.std_error(c), f64::from(expected[c]));
        assert!(se <= 0.01 * e, "{name} ch{c}: SE {se} too large for {e}");
        assert!(
            (m - e).abs() <= z * se + 1e-6 * e,
            "{name} ch{c}: mean {m} vs {e}, |diff| = {} > {z:.2} SE ({se})",
            (m - e).abs()
        );
    }
}

#[test]
fn white_furnace_diffuse_enclosure_gives_le_over_one_minus_rho() {
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(1.5, 1.0, 0.5));
    let le = Vec3::new(0.5, 1.0, 2.0);
    // (albedo, inward-facing, double-sided)
    let cases = [
        (Vec3::splat(0.5), true, false),
        (Vec3::splat(0.8), true, false),
        (Vec3::new(0.8, 0.5, 0.2), true, false),
        (Vec3::splat(0.8), false, true),
    ];
    let n = 100_000;
    // 4 cases × 3 channels.
    let z = z_for_two_sided(1e-4 / 12.0);
    for (k, (rho, inward, double_sided)) in cases.into_iter().enumerate() {
        let tris = box_triangles(lo, hi, inward);
        // The winding really is what the case says: face normals point inward or out.
        let centre = (lo + hi) / 2.0;
        for t in &tris {
            let ng = (t[1] - t[0]).cross(t[2] - t[0]);
            assert_eq!(ng.dot(centre - t[0]) > 0.0, inward);
        }
        let scene = scene_from(
            vec![(tris, lambert(rho, le, double_sided))],
            Daylight::default(),
        );
        let tracer = tracer(scene);
        let rays = interior_rays(lo, hi, 1e-3, n, 100 + k as u64);
        let s = stats_of(&tracer.trace(&rays, 7 + k as u64));
        let expected = le / (Vec3::ONE - rho);
        eprintln!(
            "furnace ρ={rho} inward={inward} double={double_sided}: mean ({:.4}, {:.4}, {:.4}) \
             ± ({:.4}, {:.4}, {:.4}), expected {expected}",
            s.mean(0),
            s.mean(1),
            s.mean(2),
            s.std_error(0),
            s.std_error(1),
            s.std_error(2)
        );
        assert_mean(&format!("furnace case {k}"), &s, expected, z);
    }
}

/// Single-sided emitters facing away from every interior point: nothing is emitted
/// towards the inside, so every sample is exactly zero (back faces still reflect, but
/// there is nothing to reflect).
#[test]
fn enclosure_with_emitters_facing_out_is_dark_inside() {
    let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    let scene = scene_from(
        vec![(
            box_triangles(lo, hi, false),
            lambert(Vec3::splat(0.8), Vec3::ONE, false),
        )],
        Daylight::default(),
    );
    let tracer = tracer(scene);
    let rays = interior_rays(lo, hi, 1e-3, 20_000, 3);
    // Light sampling can pick a point in the plane of the shading point's own wall, where
    // rounding makes cos θ ≈ ±1e-8 on both ends; such an edge-on sample carries
    // `Le cos θl cos θr / d²`-sized radiance (~1e-14 to
    // 1e-9). Anything above 1e-6 · Le would be real light.
    for s in tracer.trace(&rays, 1) {
        assert!(
            s.radiance.iter().all(|&c| (0.0..=1e-6).contains(&c)),
            "{s:?}"
        );
        assert!(s.distance.is_finite() && s.distance > 0.0);
    }
}

/// Rays from outside a convex object towards random points of it.
fn rays_at_sphere(centre: Vec3, radius: f32, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let o = centre + uniform_sphere(&mut rng) * (3.0 * radius);
            let target = centre + uniform_sphere(&mut rng) * (0.9 * radius * rng.random::<f32>());
            Ray::new(o, (target - o).normalize())
        })
        .collect()
}

/// Which rays from outside a closed object enter it through a crack: their first hit is
/// a back face. Plain Möller–Trumbore in f32 let about one ray in 10^5 through a shared
/// edge here; the scene's intersector widens its bounds so that none does, and any leak
/// fails the test (the returned mask keeps a leak from also failing the comparisons).
fn leaks(scene: &holocave_scene::Scene, rays: &[Ray]) -> Vec<bool> {
    let leaked: Vec<bool> = rays
        .iter()
        .map(|r| match scene.closest_hit(r, f32::INFINITY) {
            Some(h) => scene.surface(&h).geometric_normal.dot(r.dir) > 0.0,
            None => false,
        })
        .collect();
    let count = leaked.iter().filter(|&&l| l).count();
    eprintln!("{count} of {} rays entered through a crack", rays.len());
    assert_eq!(count, 0, "rays leaked through shared edges");
    leaked
}

#[test]
fn white_mirror_and_smooth_glass_in_a_uniform_sky_give_the_sky() {
    let le = Vec3::new(1.0, 2.0, 0.5);
    let (centre, radius) = (Vec3::new(0.3, 1.0, -0.2), 0.5);
    let n = 100_000;
    // A white perfect mirror reflects each ray once, with weight exactly one: every
    // sample equals the sky.
    let mirror = material(Vec3::ONE, 1.0, 0.0, 0.0);
    let scene = scene_from(
        vec![(sphere_triangles(centre, radius, 16, 32), mirror)],
        uniform_sky(le),
    );
    let rays = rays_at_sphere(centre, radius, n, 1);
    let leaked = leaks(&scene, &rays);
    for (s, leak) in tracer(scene).trace(&rays, 2).iter().zip(leaked) {
        assert!(s.distance.is_finite());
        if leak {
            continue;
        }
        for c in 0..3 {
            assert!(
                (s.radiance[c] - le[c]).abs() <= 1e-5 * le[c],
                "mirror sample {:?} != {le}",
                s.radiance
            );
        }
    }
    // White smooth glass: reflection has weight 1, entering scales radiance by 1/η²
    // and leaving by η², so an escaping path has weight exactly one; only Russian
    // roulette on paths of three or more bounces adds (zero-mean) noise.
    for ior in [1.5f32, 2.4] {
        let mut glass = material(Vec3::ONE, 0.0, 0.0, 1.0);
        glass.ior = ior;
        let scene = scene_from(
            vec![(sphere_triangles(centre, radius, 16, 32), glass)],
            uniform_sky(le),
        );
        let rays = rays_at_sphere(centre, radius, n, 3);
        let leaked = leaks(&scene, &rays);
        // Flat facets let high-index glass trap paths by total internal reflection for
        // many bounces (weight 1 each, so roulette keeps 95% per bounce); the default cap
        // of 64 bounces then cuts off ~0.3% of the energy at η = 2.4. The cap is a
        // documented bias, not the thing under test, so it is raised here.
        let settings = holocave_tracer::TraceSettings {
            max_depth: 1024,
            ..Default::default()
        };
        let samples: Vec<_> = holocave_tracer::Tracer::new(scene, settings)
            .trace(&rays, 4)
            .into_iter()
            .zip(leaked)
            .filter_map(|(s, l)| (!l).then_some(s))
            .collect();
        let s = stats_of(&samples);
        let z = z_for_two_sided(1e-4 / 6.0);
        for c in 0..3 {
            let (m, se) = (s.mean(c), s.std_error(c));
            eprintln!(
                "smooth glass η={ior} ch{c}: {m:.5} ± {se:.5} (sky {})",
                le[c]
            );
            assert!(
                (m - f64::from(le[c])).abs() <= z * se + 1e-5 * f64::from(le[c]),
                "smooth glass η={ior} ch{c}: {m} ± {se} vs {}",
                le[c]
            );
        }
    }
}

/// Rough white metal and rough white glass lose energy (single-scattering microfacets)
/// but never create it: the mean radiance is at most the sky's. (How much they lose is
/// checked against the BSDF's integral in `albedo.rs`; at roughness 1, GGX sends half the
/// mirrored visible normals below the horizon even at normal incidence.)
#[test]
fn rough_white_objects_in_a_uniform_sky_never_exceed_it() {
    let le = Vec3::ONE;
    let (centre, radius) = (Vec3::ZERO, 1.0);
    let n = 30_000;
    // 2 kinds × 4 roughnesses, one-sided bound on one channel (white, so all equal).
    let z = z_for_two_sided(2.0 * 1e-4 / 8.0);
    for (kind, metallic, transmission) in [("metal", 1.0, 0.0), ("glass", 0.0, 1.0)] {
        for roughness in [0.1f32, 0.4, 0.7, 1.0] {
            let m = material(Vec3::ONE, metallic, roughness, transmission);
            let scene = scene_from(
                vec![(sphere_triangles(centre, radius, 16, 32), m)],
                uniform_sky(le),
            );
            let samples = tracer(scene).trace(&rays_at_sphere(centre, radius, n, 5), 6);
            let s = stats_of(&samples);
            let (mean, se) = (s.mean(1), s.std_error(1));
            eprintln!("rough {kind} r={roughness}: {mean:.4} ± {se:.4}");
            assert!(
                mean <= 1.0 + z * se + 1e-5,
                "{kind} r={roughness}: {mean} ± {se}"
            );
            assert!(mean > 0.1, "{kind} r={roughness}: {mean}");
        }
    }
}

/// A white-ish Lambertian plane under a CIE clear sky and a sun: its radiance is
/// `ρ E / π`, with the irradiance `E` from the sky's upper hemisphere (integrated here
/// by a fine midpoint rule in f64) plus the sun's disk (`Ls π sin²r cos θs`, exact for a
/// spherical cap). This checks light sampling of the sun and of the sky's grid, and
/// their MIS weights against BSDF sampling.
#[test]
fn lambert_plane_under_sun_and_sky_gives_rho_e_over_pi() {
    use holocave_scene::{Sky, SkyModel, Sun};
    let sun_dir = Vec3::new(0.5, 0.64, -0.3).normalize();
    let sky = Sky {
        model: SkyModel::CieClear {
            zenith: Vec3::new(12.0, 16.0, 26.0),
            sun: sun_dir,
        },
        ground: Vec3::splat(5.0),
    };
    let sun = Sun {
        direction: sun_dir,
        angular_radius: 0.5f32.to_radians(),
        radiance: Vec3::splat(2.0e5),
    };
    // Irradiance on the plane (normal +Y).
    let (nt, np) = (2000, 2000);
    let mut e_sky = glam::DVec3::ZERO;
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
            let d = glam::DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            e_sky += sky.radiance(d.as_vec3()).as_dvec3() * theta.cos() * theta.sin();
        }
    }
    e_sky *= std::f64::consts::FRAC_PI_2 / nt as f64 * 2.0 * std::f64::consts::PI / np as f64;
    let r = f64::from(sun.angular_radius);
    let e_sun =
        sun.radiance.as_dvec3() * std::f64::consts::PI * r.sin().powi(2) * f64::from(sun_dir.y);
    let rho = Vec3::new(0.8, 0.6, 0.4);
    let expected = (rho.as_dvec3() * (e_sky + e_sun) / std::f64::consts::PI).as_vec3();

    let plane = vec![
        [
            Vec3::new(-50.0, 0.0, -50.0),
            Vec3::new(-50.0, 0.0, 50.0),
            Vec3::new(50.0, 0.0, 50.0),
        ],
        [
            Vec3::new(-50.0, 0.0, -50.0),
            Vec3::new(50.0, 0.0, 50.0),
            Vec3::new(50.0, 0.0, -50.0),
        ],
    ];
    let scene = scene_from(
        vec![(plane, lambert(rho, Vec3::ZERO, false))],
        Daylight {
            sun: Some(sun),
            sky: Some(sky),
            ..Default::default()
        },
    );
    let mut rng = Pcg32::seed_from_u64(17);
    let rays: Vec<Ray> = (0..100_000)
        .map(|_| {
            let mut d = uniform_sphere(&mut rng);
            d.y = d.y.abs().max(0.05);
            let target = Vec3::new(
                rng.random::<f32>() * 2.0 - 1.0,
                0.0,
                rng.random::<f32>() * 2.0 - 1.0,
            );
            Ray::new(target + d.normalize() * 3.0, -d.normalize())
        })
        .collect();
    let s = stats_of(&tracer(scene).trace(&rays, 5));
    eprintln!(
        "plane: ({:.3}, {:.3}, {:.3}) ± ({:.3}, {:.3}, {:.3}), expected {expected} (sky E {e_sky:.2}, sun E {e_sun:.2})",
        s.mean(0),
        s.mean(1),
        s.mean(2),
        s.std_error(0),
        s.std_error(1),
        s.std_error(2)
    );
    assert_mean("sun and sky", &s, expected, z_for_two_sided(1e-4 / 3.0));
}
