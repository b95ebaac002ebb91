//! The tracer's answers depend only on the rays and the seed: the parallel `trace`
//! equals `trace_serial` bit for bit, whatever the number of threads, and so does a
//! rendered image.

use crate::common;

use common::*;
use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_scene::Ray;
use holocave_tracer::render::render;
use holocave_tracer::{TracedRay, Tracer};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

fn bits(s: &[TracedRay]) -> Vec<[u32; 5]> {
    s.iter()
        .map(|s| {
            [
                s.radiance[0].to_bits(),
                s.radiance[1].to_bits(),
                s.radiance[2].to_bits(),
                s.distance.to_bits(),
                s.virtual_distance.to_bits(),
            ]
        })
        .collect()
}

fn random_rays(tracer: &Tracer, n: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = tracer.scene().bounds();
    let mut rng = Pcg32::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let u = Vec3::new(rng.random(), rng.random(), rng.random());
            Ray::new(lo + (hi - lo) * u, uniform_sphere(&mut rng))
        })
        .collect()
}

#[test]
fn parallel_trace_equals_serial_trace_bit_for_bit() {
    for (scene, daylight) in [
        ("scenes/cornell.gltf", None),
        (
            "scenes/room.gltf",
            Some(project_path("scenes/room.daylight.toml")),
        ),
    ] {
        let tracer = tracer(load(&project_path(scene), daylight));
        let rays = random_rays(&tracer, 20_000, 1);
        let serial = bits(&tracer.trace_serial(&rays, 42));
        // The global pool, and pools of other sizes: work is split differently each time.
        assert_eq!(
            bits(&tracer.trace(&rays, 42)),
            serial,
            "{scene}: global pool"
        );
        for threads in [1, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let par = pool.install(|| tracer.trace(&rays, 42));
            assert_eq!(bits(&par), serial, "{scene}: {threads} threads");
        }
        // One ray alone gives what it gave in the batch.
        for i in [0usize, 1, 63, 64, 12_345, 19_999] {
            assert_eq!(
                bits(&[tracer.trace_one(&rays[i], 42, i as u64)]),
                serial[i..=i].to_vec()
            );
        }
        // A different seed gives different (lit) samples.
        let other = bits(&tracer.trace_serial(&rays, 43));
        let differ = other.iter().zip(&serial).filter(|(a, b)| a != b).count();
        assert!(
            differ > rays.len() / 10,
            "{scene}: seed changes only {differ} samples"
        );
    }
}

#[test]
fn rendering_is_deterministic() {
    let scene = cornell();
    let view = WallView::through_camera(&scene.cameras[0], Size::new(24, 16));
    let tracer = tracer(scene);
    let a = render(&tracer, &view, 8, 7, &|| {});
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(5)
        .build()
        .unwrap();
    let b = pool.install(|| render(&tracer, &view, 8, 7, &|| {}));
    assert!(
        a.pixels
            .iter()
            .zip(&b.pixels)
            .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits))
    );
    let c = render(&tracer, &view, 8, 8, &|| {});
    assert_ne!(a, c);
}
