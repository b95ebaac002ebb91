//! 10^7 path samples over every scene the project knows, with no NaN or Inf anywhere:
//! radiance finite and non-negative, first-hit distance ≥ 0 or +∞, virtual distance at
//! least the first-hit distance.
//!
//! The split follows the cost of a path (measured on a 2-core machine, wall time with
//! both cores): the cheap generated scenes get most of the samples.
//!
//! | scene                                   | light                 | samples   |
//! |-----------------------------------------|-----------------------|-----------|
//! | scenes/cornell.gltf                     | area light            | 4 000 000 |
//! | khronos/EmissiveStrengthTest            | emissive cubes        | 2 000 000 |
//! | scenes/room.gltf                        | sun + sky (its file)  | 1 500 000 |
//! | khronos/MetalRoughSpheresNoTextures     | uniform sky (added)   | 1 000 000 |
//! | breakfast_room/BreakfastRoom.gltf       | sun + sky (configs/)  |   800 000 |
//! | sponza/Sponza.gltf                      | sun + sky (configs/)  |   700 000 |
//! | total                                   |                       | 10 000 000|
//!
//! Rays, in equal thirds: through random points of each glTF camera's image (or, for
//! scenes without cameras, from outside like the last third); from uniform points inside
//! the scene's bounds in uniform directions (many start inside walls or objects and see
//! back faces); and from a sphere around the scene, twice its size, at uniform points
//! of its bounds.

use crate::common;

use std::sync::Arc;
use std::time::Instant;

use common::*;
use glam::Vec3;
use holocave_scene::{LoadOptions, Ray, Scene};
use holocave_tracer::{TracedRay, Tracer};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

const TOTAL: u64 = 10_000_000;
const CHUNK: usize = 250_000;

fn rays_for(scene: &Scene, n: usize, rng: &mut Pcg32) -> Vec<Ray> {
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) / 2.0;
    let radius = (hi - lo).length();
    let inside =
        |rng: &mut Pcg32| lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
    (0..n)
        .map(|i| match (i % 3, scene.cameras.is_empty()) {
            (0, false) => {
                let cam = &scene.cameras[i / 3 % scene.cameras.len()];
                let [pa, pb, pc] = cam.screen(16.0 / 9.0);
                let p = pa + (pb - pa) * rng.random::<f32>() + (pc - pa) * rng.random::<f32>();
                Ray::new(cam.position, (p - cam.position).normalize())
            }
            (1, _) => Ray::new(inside(rng), uniform_sphere(rng)),
            _ => {
                let o = centre + uniform_sphere(rng) * radius;
                Ray::new(o, (inside(rng) - o).normalize())
            }
        })
        .collect()
}

fn check(s: &TracedRay, ray: &Ray, scene: &str) {
    assert!(
        s.radiance.iter().all(|c| c.is_finite() && *c >= 0.0)
            && s.distance >= 0.0
            && s.virtual_distance >= s.distance,
        "{scene}: {s:?} for {ray:?}"
    );
}

#[test]
fn ten_million_samples_over_every_scene_are_finite() {
    let scenes: [(&str, std::path::PathBuf, Option<std::path::PathBuf>, u64); 6] = [
        (
            "cornell",
            project_path("scenes/cornell.gltf"),
            None,
            4_000_000,
        ),
        (
            "EmissiveStrengthTest",
            shared_scene("khronos/EmissiveStrengthTest/EmissiveStrengthTest.gltf"),
            None,
            2_000_000,
        ),
        (
            "room",
            project_path("scenes/room.gltf"),
            Some(project_path("scenes/room.daylight.toml")),
            1_500_000,
        ),
        (
            "MetalRoughSpheresNoTextures",
            shared_scene("khronos/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf"),
            None,
            1_000_000,
        ),
        (
            "BreakfastRoom",
            shared_scene("breakfast_room/BreakfastRoom.gltf"),
            Some(project_path("configs/breakfast_room.daylight.toml")),
            800_000,
        ),
        (
            "Sponza",
            shared_scene("sponza/Sponza.gltf"),
            Some(project_path("configs/sponza.daylight.toml")),
            700_000,
        ),
    ];
    assert_eq!(scenes.iter().map(|s| s.3).sum::<u64>(), TOTAL);
    let mut traced = 0u64;
    for (k, (name, path, daylight, count)) in scenes.into_iter().enumerate() {
        let start = Instant::now();
        let mut scene = Scene::load(
            &path,
            &LoadOptions {
                strict: false,
                daylight,
                ..Default::default()
            },
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        if scene.lights.is_empty()
            && scene.daylight == Default::default()
            && !scene.materials.iter().any(|m| m.is_emissive())
        {
            // A scene with no light at all would only ever return zero: light it.
            scene.daylight = uniform_sky(Vec3::new(1.0, 0.9, 0.8));
        }
        let tracer = Tracer::new(Arc::new(scene), Default::default());
        let load_time = start.elapsed().as_secs_f64();
        let mut rng = Pcg32::seed_from_u64(1000 + k as u64);
        let (mut left, mut batch) = (count as usize, 0u64);
        let (mut sum, mut hits) = (Vec3::ZERO.as_dvec3(), 0u64);
        while left > 0 {
            let n = left.min(CHUNK);
            let rays = rays_for(tracer.scene(), n, &mut rng);
            let samples = tracer.trace(&rays, batch);
            for (s, r) in samples.iter().zip(&rays) {
                check(s, r, name);
                sum += Vec3::from(s.radiance).as_dvec3();
                hits += u64::from(s.distance.is_finite());
            }
            traced += n as u64;
            left -= n;
            batch += 1;
        }
        eprintln!(
            "{name}: {count} samples in {:.1} s (+{load_time:.1} s loading), {:.0}% hit, mean radiance {:.4}",
            start.elapsed().as_secs_f64() - load_time,
            100.0 * hits as f64 / count as f64,
            sum / count as f64
        );
        // The scene is lit and seen: some radiance arrives.
        assert!(sum.max_element() > 0.0, "{name}: everything black");
    }
    assert_eq!(traced, TOTAL);
}
