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
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use holocave_holodeck::file::DISTANCE_SETTING;
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{DistanceKind, SampleSource, SourceRay, trace_packet};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_protocol::frame::{MAX_FRAME_BYTES, decode, encode};
use holocave_protocol::holodeck::{RayPacket, SamplePacket, ServerMsg, WorkerMsg};
use holocave_protocol::session::{Opener, Sealer, SessionKeys};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::holodeck::HolodeckTracer;
use holocave_tracer::{TraceSettings, Tracer};
use serde::Serialize;
use serde::de::DeserializeOwned;

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

/// The rays a batch fill sends to workers: every other ray of its first sweep over all
/// beams (about 8 rays per beam of average volume, in beam order).
fn first_sweep_rays(path: &Path) -> Vec<SourceRay> {
    let mut srv = server(path);
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
    rays.into_iter().step_by(2).take(RAYS as usize).collect()
}

fn fill(c: &mut Criterion) {
    let scene_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.gltf");
    let scene = Scene::load(&scene_path, &LoadOptions::default()).unwrap();
    let source = HolodeckTracer(Tracer::new(Arc::new(scene), TraceSettings::default()));
    let dir = tempfile::tempdir().unwrap();

    let rays = first_sweep_rays(&dir.path().join("rays.hdk"));

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
    // commits every 5 s; `holocave fill` end to end includes them). Each packet and its
    // samples cross between server and worker in process, as plain frames (encoded and
    // decoded both ways: a TCP worker's wire work without the socket), or sealed (the
    // same, authenticated: what a TCP worker does since every holodeck port is).
    let keys = SessionKeys::derive(b"holodeck_fill bench");
    let (mut server_seal, mut server_open) = keys.acceptor();
    let (mut worker_seal, mut worker_open) = keys.connector();
    for wire in [Wire::InProcess, Wire::Framed, Wire::Sealed] {
        let path = dir.path().join(format!("fill-{wire:?}.hdk"));
        let mut srv = server(&path);
        let w = srv.add_worker();
        let mut queue = VecDeque::new();
        let mut t = 0.0;
        // The crossings' own time, against the whole fill's, in the same iterations.
        let (mut crossing, mut whole, mut packets) = (Duration::ZERO, Duration::ZERO, 0u64);
        g.bench_function(format!("fill_one_worker_one_core{}", wire.suffix()), |b| {
            b.iter(|| {
                let begin = Instant::now();
                let start = srv.stats().added;
                while srv.stats().added - start < RAYS {
                    queue.extend(srv.next_packets(w, t));
                    let p = queue.pop_front().unwrap();
                    t += p.len() as f64 / RATE;
                    let c = Instant::now();
                    let p = rays_of(cross(
                        wire,
                        ServerMsg::Rays(p),
                        &mut server_seal,
                        &mut worker_open,
                    ));
                    crossing += c.elapsed();
                    let r = trace_packet(&source, &p, DistanceKind::Virtual).unwrap();
                    let c = Instant::now();
                    let r = samples_of(cross(
                        wire,
                        WorkerMsg::Samples(r),
                        &mut worker_seal,
                        &mut server_open,
                    ));
                    crossing += c.elapsed();
                    packets += 1;
                    srv.complete(w, &r, t).unwrap();
                }
                whole += begin.elapsed();
            })
        });
        eprintln!(
            "{wire:?}: crossing server and worker took {:.2}% of the fill's time, {:.0} µs per packet",
            100.0 * crossing.as_secs_f64() / whole.as_secs_f64().max(1e-9),
            crossing.as_secs_f64() * 1e6 / packets.max(1) as f64
        );
    }
    g.finish();
}

/// How a packet of rays and its samples cross between the server and the worker.
#[derive(Clone, Copy, Debug)]
enum Wire {
    InProcess,
    Framed,
    Sealed,
}

impl Wire {
    fn suffix(self) -> &'static str {
        match self {
            Wire::InProcess => "",
            Wire::Framed => "_framed",
            Wire::Sealed => "_sealed",
        }
    }
}

const MAX: u32 = MAX_FRAME_BYTES;

/// `msg` as the other side gets it over `wire` (sealed with `seal`, opened with `open`).
fn cross<T: Serialize + DeserializeOwned>(
    wire: Wire,
    msg: T,
    seal: &mut Sealer,
    open: &mut Opener,
) -> T {
    match wire {
        Wire::InProcess => msg,
        Wire::Framed => decode(&encode(&msg, MAX).unwrap()[4..]).unwrap(),
        Wire::Sealed => open.open(&seal.seal(&msg, MAX).unwrap()[4..]).unwrap(),
    }
}

fn rays_of(m: ServerMsg) -> RayPacket {
    match m {
        ServerMsg::Rays(p) => p,
        other => panic!("expected rays, got {other:?}"),
    }
}

fn samples_of(m: WorkerMsg) -> SamplePacket {
    match m {
        WorkerMsg::Samples(r) => r,
        other => panic!("expected samples, got {other:?}"),
    }
}

criterion_group!(benches, fill);
criterion_main!(benches);
