//! Light sampled through flat mirrors (`holocave_tracer::mirrors`) estimates the same
//! integral as BSDF sampling that happens to cross a mirror and reach a light: at points of
//! the Cornell box lit by its mirror box's reflection of the ceiling light, the light a
//! white Lambertian surface reflects by way of one mirror, estimated both ways.

use crate::common;

use glam::{Vec2, Vec3};
use holocave_scene::Ray;
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::frame::Frame;
use holocave_tracer::lights::Lights;
use holocave_tracer::sampling::cosine_hemisphere;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

fn luminance(c: Vec3) -> f64 {
    f64::from(holocave_scene::luminance(c))
}

#[test]
fn light_through_a_mirror_matches_bsdf_sampling() {
    let scene = common::cornell();
    let lights = Lights::new(&scene);
    assert!(lights.has_mirrors());
    let points = [
        // The back wall, the ceiling and the red wall where the box's top reflects the light.
        (Vec3::new(-0.5, 1.7, -0.999), Vec3::Z),
        (Vec3::new(-0.8, 1.999, -0.7), -Vec3::Y),
        (Vec3::new(-0.999, 1.6, -0.3), Vec3::X),
    ];
    for (x, n) in points {
        let frame = Frame::new(n);
        let mut rng = Pcg32::seed_from_u64(1);
        let n_samples = 400_000;
        let (mut a, mut a2, mut b, mut b2) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n_samples {
            // Light sampling through a mirror, for a white Lambertian at x.
            let s = lights.sample_via_mirror(
                &scene,
                x,
                rng.random(),
                rng.random(),
                Vec2::new(rng.random(), rng.random()),
            );
            let va = s.map_or(0.0, |s| {
                let cos = n.dot(s.wi);
                let blocked = scene.occluded(&Ray::new(x, s.wi), s.dist * (1.0 - 1e-4));
                if cos <= 0.0 || blocked {
                    0.0
                } else {
                    luminance(s.contribution) * f64::from(cos) / std::f64::consts::PI
                }
            });
            a += va;
            a2 += va * va;
            // Cosine sampling: mirror first, then an emitter.
            let wi = frame.to_world(cosine_hemisphere(Vec2::new(rng.random(), rng.random())));
            let vb = mirror_then_light(&scene, x, wi);
            b += vb;
            b2 += vb * vb;
        }
        let nf = f64::from(n_samples);
        let (ma, mb) = (a / nf, b / nf);
        let se = ((a2 / nf - ma * ma) / nf + (b2 / nf - mb * mb) / nf).sqrt();
        eprintln!("{x}: through mirrors {ma:.5}, by cosine sampling {mb:.5}, SE {se:.5}");
        assert!(
            mb > 0.05,
            "{x} receives little light by way of the mirror: {mb}"
        );
        assert!((ma - mb).abs() <= 4.0 * se, "{x}: {ma} against {mb} ± {se}");
    }
}

/// Luminance gathered along `wi` from `x` if it meets a mirror and then an emitter.
fn mirror_then_light(scene: &holocave_scene::Scene, x: Vec3, wi: Vec3) -> f64 {
    let Some(h) = scene.closest_hit(&Ray::new(x, wi), f32::INFINITY) else {
        return 0.0;
    };
    let sp = scene.surface(&h);
    let m = &scene.materials[sp.material as usize];
    let bsdf = Bsdf::new(&m.params(&scene.textures, sp.uv));
    if !bsdf.is_pure_delta() || bsdf.transmits() {
        return 0.0;
    }
    let frame = Frame::new(sp.geometric_normal);
    let Some(bs) = bsdf.sample(frame.to_local(-wi), 0.0, Vec2::ZERO) else {
        return 0.0;
    };
    let out = frame.to_world(bs.wi);
    let ng = sp.geometric_normal;
    let start = sp.position + ng * (1e-4 * ng.dot(out).signum());
    let Some(h2) = scene.closest_hit(&Ray::new(start, out), f32::INFINITY) else {
        return 0.0;
    };
    let sp2 = scene.surface(&h2);
    let m2 = &scene.materials[sp2.material as usize];
    if sp2.geometric_normal.dot(out) >= 0.0 && !m2.double_sided {
        return 0.0;
    }
    luminance(bs.weight * m2.params(&scene.textures, sp2.uv).emission)
}
