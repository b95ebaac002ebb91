//! Ray rates on Sponza for three ray sets, one ray at a time on one core and on two, and
//! in packets for the primary rays:
//!
//! - **primary**: a pinhole camera at Sponza's first glTF camera (`CameraMain`, in the
//!   atrium), 1024 × 576 rays through the pixel centres, row by row; closest hit.
//! - **shadow**: from every primary hit whose side faces the sun, a ray from the hit
//!   (offset off the surface as the tracer does) towards a fixed sun direction, with no
//!   end; occlusion query.
//! - **diffuse**: from every primary hit, a cosine-distributed direction about the face
//!   normal on the side the camera sees (a fixed hash of the pixel picks it); closest hit.
//!
//! The sets are deterministic. "2 cores" deals a set out to two threads (the calling
//! thread and one scoped thread) in alternate chunks of 4096 rays. Criterion reports
//! rays/s as elements/s.
//!
//! Group `sponza_rays` times wall-clock; group `sponza_rays_cpu` the same work by the
//! process's CPU time (both threads summed), i.e. rays per CPU-second: a per-core rate that
//! other processes' load on a shared machine does not lower by taking turns on the cores.
//!
//! `cargo bench -p holocave-scene --bench ray_sets`. With `HOLOCAVE_RAY_DUMP=DIR` the
//! bench first writes the world-space triangles, the three ray sets and our answers to
//! them into DIR (see [`dump`]), so that another kernel (`benches/peer_rays.sh`) traces
//! exactly the same rays and is checked against the same answers.
//!
//! Skipped with a message when Sponza (`../shared/scenes/sponza/Sponza.gltf` beside the
//! checkout) is absent.

use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use holocave_scene::ray_sets::sun;
use holocave_scene::{LoadOptions, Ray, Scene};

const WIDTH: u32 = 1024;
const HEIGHT: u32 = 576;

/// The sets through the first camera, and the primary rays reordered into 4-wide tiles of
/// a packet each.
struct RaySets {
    sets: holocave_scene::ray_sets::RaySets,
    primary_tiled: Vec<Ray>,
}

fn ray_sets(scene: &Scene) -> Option<RaySets> {
    let cam = scene.cameras.first()?;
    let [pa, pb, pc] = cam.screen(WIDTH as f32 / HEIGHT as f32);
    let mut primary = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let s = (x as f32 + 0.5) / WIDTH as f32;
            let t = 1.0 - (y as f32 + 0.5) / HEIGHT as f32;
            let p = pa + (pb - pa) * s + (pc - pa) * t;
            primary.push(Ray::new(cam.position, (p - cam.position).normalize()));
        }
    }
    let tall = holocave_scene::bvh::PACKET as u32 / 4;
    let mut primary_tiled = Vec::with_capacity(primary.len());
    for ty in (0..HEIGHT).step_by(tall as usize) {
        for tx in (0..WIDTH).step_by(4) {
            for y in ty..(ty + tall).min(HEIGHT) {
                for x in tx..tx + 4 {
                    primary_tiled.push(primary[(y * WIDTH + x) as usize]);
                }
            }
        }
    }
    Some(RaySets {
        sets: holocave_scene::ray_sets::RaySets::from_primary(scene, primary, sun()),
        primary_tiled,
    })
}

fn write_f32s(path: &Path, count: usize, values: impl Iterator<Item = f32>) {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).expect("create dump file"));
    out.write_all(&(count as u32).to_le_bytes()).unwrap();
    for v in values {
        out.write_all(&v.to_le_bytes()).unwrap();
    }
    out.flush().unwrap();
}

/// Writes into `dir`, all little-endian, each file a `u32` count followed by records:
/// `triangles.bin` (9 × f32 per triangle: three world-space vertices), `<set>.rays`
/// (6 × f32 per ray: origin, unit direction) for `primary`, `shadow` and `diffuse`, and
/// our answers: `<set>.t` (f32 per ray: the closest hit's distance, +inf for a miss) for
/// primary and diffuse, `shadow.t` (f32 per ray: 1 if occluded, else 0).
fn dump(scene: &Scene, sets: &RaySets, dir: &Path) {
    std::fs::create_dir_all(dir).expect("create dump directory");
    let n = scene.triangle_count();
    write_f32s(
        &dir.join("triangles.bin"),
        n,
        (0..n as u32).flat_map(|i| scene.triangle(i).iter().flat_map(|v| v.to_array())),
    );
    let closest = |r: &Ray| {
        scene
            .closest_hit(r, f32::INFINITY)
            .map_or(f32::INFINITY, |h| h.t)
    };
    let occluded = |r: &Ray| f32::from(u8::from(scene.occluded(r, f32::INFINITY)));
    type Answer<'a> = &'a dyn Fn(&Ray) -> f32;
    let all: [(&str, &Vec<Ray>, Answer); 3] = [
        ("primary", &sets.sets.primary, &closest),
        ("shadow", &sets.sets.shadow, &occluded),
        ("diffuse", &sets.sets.diffuse, &closest),
    ];
    for (name, rays, answer) in all {
        write_f32s(
            &dir.join(format!("{name}.rays")),
            rays.len(),
            rays.iter()
                .flat_map(|r| r.origin.to_array().into_iter().chain(r.dir.to_array())),
        );
        write_f32s(
            &dir.join(format!("{name}.t")),
            rays.len(),
            rays.iter().map(answer),
        );
    }
    eprintln!(
        "ray_sets bench: wrote {n} triangles and the ray sets to {}",
        dir.display()
    );
}

/// Rays per chunk when two threads share a set: thread `k` takes chunks `k`, `k + 2`, …,
/// so both get rays from every part of the image (a multiple of the packet size).
const CHUNK: usize = 4096;

/// `f` over the rays on the calling thread alone, or over alternate chunks on it and one
/// more thread.
fn run_split(rays: &[Ray], threads: usize, f: impl Fn(&[Ray]) -> f32 + Sync) -> f32 {
    if threads == 1 {
        return f(rays);
    }
    let share = |k: usize| rays.chunks(CHUNK).skip(k).step_by(2).map(&f).sum::<f32>();
    std::thread::scope(|s| {
        let other = s.spawn(|| share(1));
        share(0) + other.join().expect("bench thread panicked")
    })
}

/// CPU time this process has used, all threads.
fn process_cpu_time() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to write.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID) failed");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

fn ray_rates(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/sponza/Sponza.gltf");
    if !path.exists() {
        eprintln!(
            "ray_sets bench: {} is absent; skipping the Sponza ray sets",
            path.display()
        );
        return;
    }
    let scene = match Scene::load(&path, &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("ray_sets bench: skipping Sponza: {e}");
            return;
        }
    };
    let Some(sets) = ray_sets(&scene) else {
        eprintln!("ray_sets bench: Sponza has no camera; skipping");
        return;
    };
    eprintln!(
        "ray_sets bench: Sponza, {} triangles, camera {:?}: {} primary, {} shadow, {} diffuse rays",
        scene.triangle_count(),
        scene.cameras[0].name,
        sets.sets.primary.len(),
        sets.sets.shadow.len(),
        sets.sets.diffuse.len()
    );
    if let Some(dir) = std::env::var_os("HOLOCAVE_RAY_DUMP") {
        dump(&scene, &sets, &PathBuf::from(dir));
    }

    let closest = |rays: &[Ray]| {
        let mut t_sum = 0.0f32;
        for r in rays {
            if let Some(h) = scene.closest_hit(r, f32::INFINITY) {
                t_sum += h.t;
            }
        }
        t_sum
    };
    let occluded = |rays: &[Ray]| {
        rays.iter()
            .filter(|r| scene.occluded(r, f32::INFINITY))
            .count() as f32
    };
    let packets = |rays: &[Ray]| {
        let hits = scene.closest_hits(rays, f32::INFINITY);
        hits.iter().flatten().map(|h| h.t).sum::<f32>()
    };

    type Query<'a> = &'a (dyn Fn(&[Ray]) -> f32 + Sync);
    let benches: [(&str, &Vec<Ray>, Query); 4] = [
        ("primary", &sets.sets.primary, &closest),
        ("shadow", &sets.sets.shadow, &occluded),
        ("diffuse", &sets.sets.diffuse, &closest),
        ("primary_packets", &sets.primary_tiled, &packets),
    ];
    for cpu_time in [false, true] {
        let mut group = c.benchmark_group(if cpu_time {
            "sponza_rays_cpu"
        } else {
            "sponza_rays"
        });
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_secs(1))
            .measurement_time(Duration::from_secs(4));
        for (name, rays, query) in benches {
            group.throughput(Throughput::Elements(rays.len() as u64));
            for threads in [1, 2] {
                let run = || black_box(run_split(black_box(rays), threads, query));
                group.bench_function(format!("{name}_{threads}t"), |b| {
                    if cpu_time {
                        b.iter_custom(|iters| {
                            let start = process_cpu_time();
                            for _ in 0..iters {
                                run();
                            }
                            process_cpu_time() - start
                        })
                    } else {
                        b.iter(run)
                    }
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, ray_rates);
criterion_main!(benches);
