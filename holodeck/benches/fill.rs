//! Fill rate (issue 3): samples per second that one worker adds to the holodeck through the
//! server (packet building, ray generation, sample encoding, caching). The sample generator
//! here is analytic, so this is the server's ceiling per worker; with the path tracer the
//! fill rate is the tracer's own rate (the root crate's `holodeck_fill` bench; figures in
//! README.md).

use std::collections::VecDeque;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{
    DistanceKind, SampleSource, SourceRay, SourceResult, trace_packet,
};
use holocave_holodeck::{HoloFile, Section, ViewClass};

struct Analytic;

impl SampleSource for Analytic {
    fn trace(&self, rays: &[SourceRay], _seed: u64, _distance: DistanceKind) -> Vec<SourceResult> {
        rays.iter()
            .map(|r| SourceResult {
                radiance: r.dir.abs().to_array(),
                distance: 1.0 + r.origin.x.abs(),
            })
            .collect()
    }
}

const RAYS: u64 = 200_000;

fn fill(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut g = c.benchmark_group("fill");
    g.sample_size(10);
    g.throughput(Throughput::Elements(RAYS));
    let mut n = 0;
    g.bench_function("one_worker_analytic", |b| {
        b.iter_batched(
            || {
                n += 1;
                let path = dir.path().join(format!("fill{n}.hdk"));
                let s = Section::with_default_grid(
                    DVec3::ZERO,
                    [DVec3::X * 4.0, DVec3::Y * 3.0, DVec3::Z * 5.0],
                    ViewClass::Interior,
                )
                .unwrap();
                HoloFile::create(&path, vec![s], Default::default()).unwrap();
                let config = ServerConfig {
                    initial_rate: 1e6,
                    ..Default::default()
                };
                (
                    path.clone(),
                    Server::new(HoloFile::open_rw(&path).unwrap(), Mode::Batch, config),
                )
            },
            |(path, mut srv)| {
                let w = srv.add_worker();
                let mut queue = VecDeque::new();
                let mut t = 0.0;
                while srv.stats().added < RAYS {
                    queue.extend(srv.next_packets(w, t));
                    let p = queue.pop_front().unwrap();
                    t += p.len() as f64 / 1e6;
                    srv.complete(
                        w,
                        &trace_packet(&Analytic, &p, DistanceKind::Virtual).unwrap(),
                        t,
                    )
                    .unwrap();
                }
                srv.flush().unwrap();
                std::fs::remove_file(&path).unwrap();
            },
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group!(benches, fill);
criterion_main!(benches);
