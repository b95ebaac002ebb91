//! Energy: directional albedo `E(wo) = ∫ f(wo, wi) |cos θi| dωi` (delta lobes included)
//! never exceeds 1 for white materials, at every roughness and angle; smooth glass
//! splits energy exactly between reflection and refraction; sample weights are unbiased
//! estimates of the BSDF's integral; the BSDF is reciprocal.
//!
//! `E` is estimated by the mean of `Bsdf::sample` weights (each `f |cos| / pdf`, or the
//! delta lobe's weight), with the standard error from the sample variance. Bounds are
//! one-sided `z`-score tests with `z` for a family-wise false-failure probability of
//! 1e-3 over all the configurations of a test (Bonferroni); seeds are fixed.
//!
//! What is physically right for glass: the tracer carries radiance, and radiance
//! changes by (η_t/η_i)² across an interface (`L/η²` is invariant), so a transmitted
//! sample's weight holds a factor `1/η'²` with `η' = η_wi-side / η_wo-side`. A camera
//! path entering glass from air gets `T/η²`, one leaving it `T·η²`: the radiance
//! "albedo" from inside exceeds 1 — correctly. Energy is what must be conserved, so for
//! glass the bound is on `R + T`, the weight with the `1/η'²` factor undone.

use crate::common;

use std::f64::consts::PI;

use common::{integrate_cell, params, z_for_two_sided};
use glam::{Vec2, Vec3};
use holocave_scene::SurfaceParams;
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::fresnel;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use rayon::prelude::*;

fn wo_at(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// The factor that turns a radiance weight into an energy fraction: `η'²` for a
/// refracted sample, 1 for a reflected one.
fn energy_factor(wo: Vec3, wi: Vec3, ior: f32) -> f32 {
    if wo.z * wi.z >= 0.0 {
        1.0
    } else if wo.z > 0.0 {
        ior * ior
    } else {
        1.0 / (ior * ior)
    }
}

/// Mean and standard error of the green channel of the sample weights (times
/// `energy_factor` when `energy`).
fn estimate(bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64, energy: Option<f32>) -> (f64, f64) {
    let mut rng = Pcg32::seed_from_u64(seed);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let uc: f32 = rng.random();
        let u = Vec2::new(rng.random(), rng.random());
        let w = match bsdf.sample(wo, uc, u) {
            Some(s) => {
                assert!(
                    s.weight.is_finite() && s.weight.min_element() >= 0.0,
                    "{s:?} for wo {wo}"
                );
                f64::from(s.weight.y * energy.map_or(1.0, |ior| energy_factor(wo, s.wi, ior)))
            }
            None => 0.0,
        };
        s1 += w;
        s2 += w * w;
    }
    let nf = n as f64;
    let mean = s1 / nf;
    let var = ((s2 - s1 * s1 / nf) / (nf - 1.0)).max(0.0);
    (mean, (var / nf).sqrt())
}

const ROUGHNESS: [f32; 14] = [
    0.0, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0,
];
/// From normal incidence to 0.1° above the horizon; and from below (the opaque lobes
/// are two-sided; for glass, from inside).
const ANGLES: [f32; 15] = [
    0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0, 89.0, 89.9, 120.0, 150.0, 179.0,
];

#[test]
fn directional_albedo_of_white_materials_is_at_most_one() {
    let n = 20_000;
    let kinds: [(&str, f32, f32, f32); 4] = [
        ("metal", 1.0, 0.0, 1.5),
        ("dielectric", 0.0, 0.0, 1.5),
        ("glass η=1.5", 0.0, 1.0, 1.5),
        ("glass η=2.4", 0.0, 1.0, 2.4),
    ];
    let mut configs = Vec::new();
    for (kind, metallic, transmission, ior) in kinds {
        for r in ROUGHNESS {
            for a in ANGLES {
                configs.push((kind, metallic, transmission, ior, r, a));
            }
        }
    }
    let z = z_for_two_sided(2.0 * 1e-3 / configs.len() as f64);
    let failures: Vec<String> = configs
        .par_iter()
        .enumerate()
        .filter_map(|(k, &(kind, metallic, transmission, ior, r, a))| {
            let mut p = params(Vec3::ONE, metallic, r, transmission);
            p.ior = ior;
            let bsdf = Bsdf::new(&p);
            let energy = (transmission > 0.0).then_some(ior);
            let (mean, se) = estimate(&bsdf, wo_at(a), n, k as u64, energy);
            (mean > 1.0 + z * se + 1e-5)
                .then(|| format!("{kind} r={r} θo={a}°: E = {mean:.5} ± {se:.5} > 1"))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A white Lambertian surface reflects everything: every sample's weight is exactly 1.
/// A white perfect mirror likewise (Schlick with F0 = 1 is 1).
#[test]
fn white_lambert_and_white_mirror_weights_are_exactly_one() {
    let mut lambert = params(Vec3::ONE, 0.0, 1.0, 0.0);
    lambert.specular = 0.0;
    let mirror = params(Vec3::ONE, 1.0, 0.0, 0.0);
    let mut rng = Pcg32::seed_from_u64(9);
    for p in [lambert, mirror] {
        let bsdf = Bsdf::new(&p);
        for a in ANGLES {
            for _ in 0..2000 {
                let wo = wo_at(a);
                let s = bsdf
                    .sample(wo, rng.random(), Vec2::new(rng.random(), rng.random()))
                    .expect("always samples");
                assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-5, "{s:?}");
                assert!(s.wi.z * wo.z > 0.0, "stays on the viewer's side");
                if p.metallic == 1.0 {
                    assert!(s.delta);
                    assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                }
            }
        }
    }
}

/// Smooth white glass: reflection with probability R (exact Fresnel), weight 1;
/// refraction along Snell's law with probability T = 1 − R, weight 1/η'². So
/// `E[weight · η'²] = R + T = 1` exactly (energy), and the radiance albedo is
/// `R + T/η²` from outside, `R + T·η²` from inside (or 1 under total internal
/// reflection).
#[test]
fn smooth_glass_splits_energy_exactly() {
    for ior in [1.33f32, 1.5, 2.4] {
        let bsdf = Bsdf::new(&SurfaceParams {
            ior,
            ..params(Vec3::ONE, 0.0, 0.0, 1.0)
        });
        for a in ANGLES {
            let wo = wo_at(a);
            let r = fresnel::dielectric(wo.z, ior);
            let n = 4000;
            let (mut reflected, mut radiance, mut energy) = (0usize, 0.0f64, 0.0f64);
            for i in 0..n {
                let uc = (i as f32 + 0.5) / n as f32; // stratified: R is hit to 1/n
                let s = bsdf.sample(wo, uc, Vec2::new(0.3, 0.7)).unwrap();
                assert!(s.delta);
                let etap2 = energy_factor(wo, s.wi, ior);
                if s.wi.z * wo.z > 0.0 {
                    reflected += 1;
                    assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                    assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-6);
                } else {
                    // Snell: η_o sin θo = η_i sin θi, in the plane of incidence.
                    let (eta_o, eta_i) = if wo.z > 0.0 { (1.0, ior) } else { (ior, 1.0) };
                    let sin_o = (1.0 - wo.z * wo.z).sqrt();
                    let sin_i = (1.0 - s.wi.z * s.wi.z).sqrt();
                    assert!(
                        (eta_o * sin_o - eta_i * sin_i).abs() < 1e-5,
                        "{wo} → {}",
                        s.wi
                    );
                    assert!(s.wi.y.abs() < 1e-6 && s.wi.x * wo.x <= 0.0);
                    assert!((s.weight.y * etap2 - 1.0).abs() < 1e-5, "{s:?}");
                }
                radiance += f64::from(s.weight.y);
                energy += f64::from(s.weight.y * etap2);
            }
            let (radiance, energy) = (radiance / n as f64, energy / n as f64);
            let r_seen = reflected as f64 / n as f64;
            assert!(
                (r_seen - f64::from(r)).abs() <= 1.0 / n as f64,
                "R {r_seen} vs {r}"
            );
            assert!(
                (energy - 1.0).abs() < 1e-5,
                "η={ior} θo={a}: R+T = {energy}"
            );
            let t = 1.0 - f64::from(r);
            let expected = f64::from(r)
                + if wo.z > 0.0 {
                    t / f64::from(ior * ior)
                } else {
                    t * f64::from(ior * ior)
                };
            assert!(
                (radiance - expected).abs() < 1e-3 + 1.0 / n as f64 * f64::from(ior * ior),
                "η={ior} θo={a}: radiance albedo {radiance} vs {expected}"
            );
        }
    }
}

/// The mean sample weight estimates `∫ f |cos θi| dωi` computed from `eval` by
/// quadrature: sampling, its pdf and its weights agree in expectation, for coloured
/// materials of every kind.
#[test]
fn sample_weights_average_to_the_integral_of_eval() {
    let base = Vec3::new(0.9, 0.6, 0.3);
    let mut configs = Vec::new();
    for (kind, metallic, transmission) in [
        ("metal", 1.0, 0.0),
        ("dielectric", 0.0, 0.0),
        ("glass", 0.0, 1.0),
        ("mix", 0.4, 0.5),
    ] {
        for r in [0.3f32, 0.6, 1.0] {
            for a in [0.0f32, 45.0, 80.0, 130.0] {
                configs.push((kind, params(base, metallic, r, transmission), a));
            }
        }
    }
    let n = 200_000;
    let z = z_for_two_sided(1e-3 / configs.len() as f64);
    let failures: Vec<String> = configs
        .par_iter()
        .enumerate()
        .filter_map(|(k, (kind, p, a))| {
            let bsdf = Bsdf::new(p);
            let wo = wo_at(*a);
            let (mean, se) = estimate(&bsdf, wo, n, 100 + k as u64, None);
            let f = |t: f64, ph: f64| {
                let wi = Vec3::new(
                    (t.sin() * ph.cos()) as f32,
                    (t.sin() * ph.sin()) as f32,
                    t.cos() as f32,
                );
                f64::from(bsdf.eval(wo, wi).0.y * wi.z.abs()) * t.sin()
            };
            let (nt, np) = (10, 20);
            let mut quad = 0.0;
            for i in 0..nt {
                for j in 0..np {
                    let (t0, p0) = (i as f64 * PI / nt as f64, j as f64 * 2.0 * PI / np as f64);
                    quad +=
                        integrate_cell(&f, t0, t0 + PI / nt as f64, p0, p0 + 2.0 * PI / np as f64);
                }
            }
            let ok = (mean - quad).abs() <= z * se + 1e-4 * quad;
            eprintln!(
                "{kind} r={} θo={a}°: MC {mean:.5} ± {se:.5}, quadrature {quad:.5}",
                p.roughness
            );
            (!ok).then(|| {
                format!(
                    "{kind} r={} θo={a}°: MC {mean} ± {se} vs {quad}",
                    p.roughness
                )
            })
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Helmholtz reciprocity, generalised to refraction: `f(wo, wi) / η_o² = f(wi, wo) / η_i²`
/// where `η_o`, `η_i` are the indices on the sides of `wo` and `wi` (for reflection
/// they are equal and `f` is symmetric). Both sides are f32 evaluations of ~50
/// operations, the refraction half-vector `η wi + wo` losing a few digits to
/// cancellation: relative 5e-4 (~4000 ulps) bounds that; a wrong factor (a missing η²,
/// an asymmetric Fresnel or masking term) is off by 10% or more.
#[test]
fn bsdf_is_reciprocal() {
    let mut rng = Pcg32::seed_from_u64(77);
    let mut checked = 0;
    for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.4, 0.5)] {
        for r in [0.1f32, 0.3, 0.6, 1.0] {
            let p = params(Vec3::new(0.9, 0.6, 0.3), metallic, r, transmission);
            let bsdf = Bsdf::new(&p);
            for _ in 0..2000 {
                let a = common::uniform_sphere(&mut rng);
                let b = common::uniform_sphere(&mut rng);
                // Refraction pairs next to the critical angle are left out: there
                // T = 1 − F(θ) falls to 0 with an infinite slope in cos θ, so f32
                // rounding of the cosines (1e-7) changes T by ~3e-4 absolute and the
                // two evaluations cannot agree to a relative tolerance.
                if a.z * b.z < 0.0 {
                    let (inside, outside) = if a.z < 0.0 { (a, b) } else { (b, a) };
                    let wm = (inside * p.ior + outside).normalize();
                    let cos_in = inside.dot(wm).abs();
                    let cos_crit = (1.0 - 1.0 / (p.ior * p.ior)).sqrt();
                    if (cos_in - cos_crit).abs() < 1e-3 {
                        continue;
                    }
                }
                let (fab, _) = bsdf.eval(a, b);
                let (fba, _) = bsdf.eval(b, a);
                let eta = |w: Vec3| if w.z > 0.0 { 1.0 } else { p.ior };
                let lhs = fab / (eta(a) * eta(a));
                let rhs = fba / (eta(b) * eta(b));
                let scale = lhs.abs().max(rhs.abs()).max_element();
                assert!(
                    (lhs - rhs).abs().max_element() <= 5e-4 * scale + 1e-7,
                    "m={metallic} t={transmission} r={r}: f({a}, {b}) = {fab}, f({b}, {a}) = {fba}"
                );
                checked += usize::from(scale > 0.0);
            }
        }
    }
    assert!(checked > 10_000, "{checked}");
}
