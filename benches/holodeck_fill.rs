//! Fill rate of the holodeck with the real path tracer (issue 3, "done when" 4), on one
//! core: samples per second that one worker adds to a holodeck of the Cornell box through
//! the server (packet building, ray generation, tracing, encoding, caching), against the
//! tracer alone on the same kind of rays. The holodeck crate's own `fill` bench measures
//! the server's ceiling with an analytic generator.
//!
//! The section is the free space in front of the box's open side, where its `front` camera
//! stands (`holocave fill --section=-1,0,1,1,2,3.5`): rays are traced outward from its
//! walls, about a third of them into the box, the rest into the empty surroundings.

use std::collections::VecDeque;
use std::path::Path;
use std::sync::Arc;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use holocave_holodeck::file::DISTANCE_SETTING;
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{DistanceKind, SampleSource, SourceRay, trace_packet};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_protocol::holodeck::SamplePacket;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::holodeck::HolodeckTracer;
use holocave_tracer::{TraceSettings, Tracer};

/// Rays per measured iteration: about half a sweep of the batch order over every beam of
/// the default grid (166,912 beams, about 8 rays each), so that both benches see the
/// fill's mix of rays into the box and rays into the void.
const RAYS: u64 = 700_000;
/// The simulated worker rate: keeps packets at 4,096 rays, so a fill overshoots RAYS by
/// less than 1%.
const RATE: f64 = 4096.0 / 1.5;

fn server(path: &Path) -> Server {
    let s = Section::with_default_grid(
        DVec3::new(-1.0, 0.0, 1.0),
        [DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.5],
        ViewClass::Interior,
    )
    .unwrap();
    let settings = [(DISTANCE_SETTING.to_string(), "virtual".to_string())].into();
    let h = HoloFile::create(path, vec![s], settings).unwrap();
    let config = ServerConfig {
        initial_rate: RATE,
        ..Default::default()
    };
    Server::new(h, Mode::Batch, config)
}

fn fill(c: &mut Criterion) {
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.gltf");
    let scene = Scene::load(&scene_path, &LoadOptions::default()).unwrap();
    let source = HolodeckTracer(Tracer::new(Arc::new(scene), TraceSettings::default()));
    let dir = tempfile::tempdir().unwrap();

    // The rays a batch fill sends to workers: every other ray of its first sweep over all
    // beams (about 8 rays per beam of average volume, in beam order).
    let mut srv = server(&dir.path().join("rays.hdk"));
    let w = srv.add_worker();
    let mut rays = Vec::new();
    let mut t = 0.0;
    while (rays.len() as u64) < 2 * RAYS {
        for p in srv.next_packets(w, t) {
            let mut r = SamplePacket {
                id: p.id,
                results: Vec::new(),
            };
            for (o, d) in p.rays().unwrap() {
                rays.push(SourceRay {
                    origin: o.into(),
                    dir: d.into(),
                });
                r.push([0.0; 3], f32::INFINITY);
            }
            t += p.len() as f64 / RATE;
            srv.complete(w, &r, t).unwrap();
        }
    }
    let rays: Vec<_> = rays.into_iter().step_by(2).take(RAYS as usize).collect();
    drop(srv);

    let mut g = c.benchmark_group("holodeck_fill_cornell");
    g.sample_size(10);
    g.throughput(Throughput::Elements(RAYS));
    let mut seed = 0;
    g.bench_function("tracer_alone_one_core", |b| {
        b.iter(|| {
            seed += 1;
            source.trace(&rays, seed, DistanceKind::Virtual).len()
        })
    });
    // The same rays without those that escape at once (most of them: the section's walls
    // face the void on five sides), for the cost of the ones that enter the box.
    let hitting: Vec<_> = source
        .trace(&rays, 0, DistanceKind::FirstHit)
        .iter()
        .zip(&rays)
        .filter(|(r, _)| r.distance.is_finite())
        .map(|(_, ray)| *ray)
        .collect();
    g.throughput(Throughput::Elements(hitting.len() as u64));
    g.bench_function(
        format!("tracer_alone_one_core_hitting_{}_of_{RAYS}", hitting.len()),
        |b| {
            b.iter(|| {
                seed += 1;
                source.trace(&hitting, seed, DistanceKind::Virtual).len()
            })
        },
    );
    g.throughput(Throughput::Elements(RAYS));
    // One server through all iterations, as in a long fill; commits are left out (a fill
    // commits every 5 s; `holocave fill` end to end includes them).
    let path = dir.path().join("fill.hdk");
    let mut srv = server(&path);
    let w = srv.add_worker();
    let mut queue = VecDeque::new();
    let mut t = 0.0;
    g.bench_function("fill_one_worker_one_core", |b| {
        b.iter(|| {
            let start = srv.stats().added;
            while srv.stats().added - start < RAYS {
                queue.extend(srv.next_packets(w, t));
                let p = queue.pop_front().unwrap();
                t += p.len() as f64 / RATE;
                let r = trace_packet(&source, &p, DistanceKind::Virtual).unwrap();
                srv.complete(w, &r, t).unwrap();
            }
        })
    });
    g.finish();
}

criterion_group!(benches, fill);
criterion_main!(benches);
