//! An area light seen directly returns exactly its emitted radiance (a camera ray that
//! hits an emitter first takes its emission with MIS weight 1), on its front side;
//! its back side emits nothing unless the material is double-sided.

use crate::common;

use common::*;
use glam::Vec3;
use holocave_scene::{Daylight, Ray};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

/// The Cornell light: emissive factor (1, 0.85, 0.65) × strength 15, a 0.5 m square at
/// y = 1.98 facing down, base colour black (so nothing else adds to what it shows).
#[test]
fn cornell_light_seen_from_below_has_its_emission() {
    let scene = cornell();
    let le = Vec3::new(1.0, 0.85, 0.65) * 15.0;
    let tracer = tracer(scene);
    let mut rng = Pcg32::seed_from_u64(4);
    let eye = Vec3::new(0.0, 1.0, 3.4);
    let mut rays = Vec::new();
    let mut targets = Vec::new();
    for _ in 0..2000 {
        // Points inside the light, away from its edges by 1 mm.
        let t = Vec3::new(
            -0.249 + 0.498 * rng.random::<f32>(),
            1.98,
            -0.249 + 0.498 * rng.random::<f32>(),
        );
        targets.push(t);
        rays.push(Ray::new(eye, (t - eye).normalize()));
    }
    for ((s, t), r) in tracer.trace(&rays, 1).iter().zip(&targets).zip(&rays) {
        let d = (*t - r.origin).length();
        assert!((s.distance - d).abs() <= 1e-5 * d, "{s:?} vs {d}");
        assert_eq!(s.virtual_distance, s.distance);
        for c in 0..3 {
            assert!(
                (s.radiance[c] - le[c]).abs() <= 1e-6 * le[c],
                "{:?} != {le}",
                s.radiance
            );
        }
    }
    // From between the light and the ceiling, looking down at its back: black.
    let back: Vec<Ray> = (0..500)
        .map(|_| {
            let o = Vec3::new(
                -0.2 + 0.4 * rng.random::<f32>(),
                1.99,
                -0.2 + 0.4 * rng.random::<f32>(),
            );
            let d = Vec3::new(
                0.2 * rng.random::<f32>() - 0.1,
                -1.0,
                0.2 * rng.random::<f32>() - 0.1,
            );
            Ray::new(o, d.normalize())
        })
        .collect();
    for s in tracer.trace(&back, 2) {
        assert!(s.distance < 0.011, "{s:?}");
        assert_eq!(s.radiance, [0.0; 3], "back of the light: {s:?}");
    }
}

/// A lone emissive quad (no other geometry, no daylight) with a grey base colour: from
/// the front in any direction the radiance is `Le`; from the back it is zero for a
/// single-sided material and `Le` for a double-sided one. (Light sampling from the quad
/// onto itself is edge-on: exactly zero in exact arithmetic, `~1e-14 Le` after rounding,
/// hence the relative tolerance 1e-6.)
#[test]
fn emitter_front_back_and_double_sided() {
    let le = Vec3::new(2.0, 3.0, 4.0);
    // A 1 m square at z = 0 facing +Z.
    let quad = vec![
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ],
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
    ];
    for double_sided in [false, true] {
        let scene = scene_from(
            vec![(quad.clone(), lambert(Vec3::splat(0.5), le, double_sided))],
            Daylight::default(),
        );
        let tracer = tracer(scene);
        let mut rng = Pcg32::seed_from_u64(8);
        for side in [1.0f32, -1.0] {
            let rays: Vec<Ray> = (0..4000)
                .map(|_| {
                    let target = Vec3::new(
                        0.01 + 0.98 * rng.random::<f32>(),
                        0.01 + 0.98 * rng.random::<f32>(),
                        0.0,
                    );
                    // Any direction on this side, down to 0.5° above the plane.
                    let mut d = uniform_sphere(&mut rng);
                    d.z = d.z.abs().max(0.01) * side;
                    let d = d.normalize();
                    Ray::new(target + d * 2.0, -d)
                })
                .collect();
            let expect = if side > 0.0 || double_sided {
                le
            } else {
                Vec3::ZERO
            };
            for (s, r) in tracer.trace(&rays, 3).iter().zip(&rays) {
                assert!((s.distance - 2.0).abs() < 1e-4, "{s:?} {r:?}");
                for c in 0..3 {
                    assert!(
                        (s.radiance[c] - expect[c]).abs() <= 1e-6 * le[c],
                        "double-sided {double_sided}, side {side}: {:?} != {expect}",
                        s.radiance
                    );
                }
            }
        }
    }
}

/// Khronos' EmissiveStrengthTest (`KHR_materials_emissive_strength`): a ray straight at
/// the middle of each emissive face sees at least that face's emission, scaled by its
/// strength (the rest, light the face reflects from its neighbours, is non-negative; even
/// the black faces have a specular layer, so it is not zero).
#[test]
fn emissive_strength_test_faces_show_their_emission() {
    let scene = load(
        &shared_scene("khronos/EmissiveStrengthTest/EmissiveStrengthTest.gltf"),
        None,
    );
    let tracer = tracer(scene.clone());
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    for t in 0..scene.triangle_count() as u32 {
        let m = &scene.materials[scene.triangle_shading(t).material as usize];
        if !m.is_emissive() {
            continue;
        }
        let p = scene.triangle(t);
        let centre = (p[0] + p[1] + p[2]) / 3.0;
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let size = (p[1] - p[0]).length().min((p[2] - p[0]).length());
        let origin = centre + n * (0.01 * size);
        let ray = Ray::new(origin, -n);
        // Only faces whose centre is seen unobstructed along the normal.
        match scene.closest_hit(&ray, f32::INFINITY) {
            Some(h) if h.triangle == t => {}
            _ => continue,
        }
        rays.push(ray);
        let params = m.params(&scene.textures, glam::Vec2::ZERO);
        expected.push(params.emission);
    }
    assert!(rays.len() >= 6, "{} emissive faces seen", rays.len());
    let mut strengths: Vec<f32> = expected.iter().map(|e| e.max_element()).collect();
    strengths.sort_by(f32::total_cmp);
    strengths.dedup();
    assert!(
        strengths.len() >= 2,
        "several emissive strengths: {strengths:?}"
    );
    for ((s, le), r) in tracer.trace(&rays, 5).iter().zip(&expected).zip(&rays) {
        for c in 0..3 {
            assert!(
                s.radiance[c] >= le[c] * (1.0 - 1e-6),
                "{s:?} < {le} for {r:?}"
            );
        }
    }
}
