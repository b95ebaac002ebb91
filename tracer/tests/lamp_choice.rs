//! Next-event estimation that chooses its lamp by place (`holocave_tracer::few_lights`:
//! each emissive triangle weighed by its power over its distance, one-sided triangles
//! turned away from the point never chosen) estimates the same direct light as cosine
//! sampling that happens to hit a lamp, and reports the same density again for MIS.
//!
//! The scene: a white floor with two glowing cubes of different strength (outward-facing,
//! one-sided: from any point, half their faces or more turn away) and a small double-sided
//! panel above them.

use crate::common;

use common::*;
use glam::{Vec2, Vec3};
use holocave_scene::{Daylight, Ray, Scene};
use holocave_tracer::frame::Frame;
use holocave_tracer::lights::Lights;
use holocave_tracer::sampling::cosine_hemisphere;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

fn luminance(c: Vec3) -> f64 {
    f64::from(holocave_scene::luminance(c))
}

fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Vec<[Vec3; 3]> {
    vec![[a, b, c], [a, c, d]]
}

fn lamps() -> std::sync::Arc<Scene> {
    let floor = quad(
        Vec3::new(-4.0, 0.0, -4.0),
        Vec3::new(-4.0, 0.0, 4.0),
        Vec3::new(4.0, 0.0, 4.0),
        Vec3::new(4.0, 0.0, -4.0),
    );
    let weak = box_triangles(Vec3::new(-1.5, 0.2, -0.5), Vec3::new(-0.5, 1.2, 0.5), false);
    let strong = box_triangles(Vec3::new(0.5, 0.2, -0.5), Vec3::new(1.5, 1.2, 0.5), false);
    let panel = quad(
        Vec3::new(-0.3, 2.0, -0.3),
        Vec3::new(0.3, 2.0, -0.3),
        Vec3::new(0.3, 2.0, 0.3),
        Vec3::new(-0.3, 2.0, 0.3),
    );
    scene_from(
        vec![
            (floor, lambert(Vec3::splat(0.5), Vec3::ZERO, false)),
            (weak, lambert(Vec3::ZERO, Vec3::splat(1.0), false)),
            (strong, lambert(Vec3::ZERO, Vec3::new(8.0, 6.0, 4.0), false)),
            (panel, lambert(Vec3::ZERO, Vec3::splat(2.0), true)),
        ],
        Daylight::default(),
    )
}

#[test]
fn lamps_chosen_by_place_match_cosine_sampling() {
    let scene = lamps();
    let lights = Lights::new(&scene);
    // On the floor between the cubes, beside the weak one, far off; under the panel
    // facing up at it, and above everything facing down (only the panel's back side).
    let points = [
        (Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
        (Vec3::new(-2.0, 0.0, 0.3), Vec3::Y),
        (Vec3::new(3.5, 0.0, -3.0), Vec3::Y),
        (Vec3::new(0.1, 1.5, 0.0), Vec3::Y),
        (Vec3::new(0.0, 3.0, 0.2), -Vec3::Y),
    ];
    for (on, n) in points {
        // Just off the surface, as a path vertex's rays start.
        let x = on + n * 1e-4;
        let frame = Frame::new(n);
        let mut rng = Pcg32::seed_from_u64(7);
        let n_samples = 200_000;
        let (mut a, mut a2, mut b, mut b2) = (0.0, 0.0, 0.0, 0.0);
        let (mut lit, mut mismatched) = (0u32, 0u32);
        for _ in 0..n_samples {
            // Light sampling, for a white Lambertian at x.
            let s = lights.sample_area(
                &scene,
                x,
                rng.random(),
                Vec2::new(rng.random(), rng.random()),
            );
            let va = s.map_or(0.0, |s| {
                let cos = n.dot(s.wi);
                let ray = Ray::new(x, s.wi);
                if cos <= 0.0 || scene.occluded(&ray, s.dist * (1.0 - 1e-4)) {
                    return 0.0;
                }
                // The density MIS is given for the same point is the one it was drawn
                // with. Not quite always: a line that grazes an edge can be reported to
                // meet the neighbour (the other half of a cube's face, or the next face),
                // whose density differs; the BVH widens triangles by 1e-5 of their size,
                // so that is about one sample in 1e4.
                let hit = scene.closest_hit(&ray, f32::INFINITY).expect("the lamp");
                let ng = scene.face_normal(hit.triangle);
                let pdf = lights.area_pdf(&hit, x, ng, s.wi);
                if (pdf - s.pdf).abs() > 1e-3 * s.pdf {
                    mismatched += 1;
                }
                lit += 1;
                luminance(s.contribution) * f64::from(cos) / std::f64::consts::PI
            });
            a += va;
            a2 += va * va;
            // Cosine sampling: the emission of whatever lamp side is met first.
            let wi = frame.to_world(cosine_hemisphere(Vec2::new(rng.random(), rng.random())));
            let vb = emission_seen(&scene, x, wi);
            b += vb;
            b2 += vb * vb;
        }
        let nf = f64::from(n_samples);
        let (ma, mb) = (a / nf, b / nf);
        let se = ((a2 / nf - ma * ma) / nf + (b2 / nf - mb * mb) / nf).sqrt();
        eprintln!("{x}: lamps by place {ma:.5}, by cosine sampling {mb:.5}, SE {se:.5}");
        assert!(mb > 0.01, "{x} receives little direct light: {mb}");
        assert!(
            mismatched as f32 <= 1e-3 * lit as f32,
            "{x}: MIS reads another density for {mismatched} of {lit} light samples"
        );
        assert!((ma - mb).abs() <= 4.0 * se, "{x}: {ma} against {mb} ± {se}");
    }
}

/// Luminance emitted towards `x` by what lies first along `wi`.
fn emission_seen(scene: &Scene, x: Vec3, wi: Vec3) -> f64 {
    let Some(h) = scene.closest_hit(&Ray::new(x, wi), f32::INFINITY) else {
        return 0.0;
    };
    let sp = scene.surface(&h);
    let m = &scene.materials[sp.material as usize];
    if sp.geometric_normal.dot(wi) >= 0.0 && !m.double_sided {
        return 0.0;
    }
    luminance(m.params(&scene.textures, sp.uv).emission)
}
