//! Recall rate (issue 3): samples per second served from the memory cache and from a warm
//! holodeck file (in the page cache), on one core. The paper's server recalled 35,000 to
//! 350,000 samples/s; the goal here is at least 20 million from a warm file.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use holocave_holodeck::beam_index::BeamKey;
use holocave_holodeck::cache::BeamCache;
use holocave_holodeck::sample::PackedSample;
use holocave_holodeck::{HoloFile, Section, ViewClass};

const PER_BEAM: u32 = 64;

fn build(path: &std::path::Path) -> (u32, u64) {
    let s = Section::axis_aligned(
        DVec3::ZERO,
        DVec3::new(4.0, 3.0, 5.0),
        [5, 4, 6],
        ViewClass::Interior,
    )
    .unwrap();
    let beams = s.beam_count();
    let mut h = HoloFile::create(path, vec![s], Default::default()).unwrap();
    let mut total = 0;
    for b in 0..beams {
        let v: Vec<PackedSample> = (0..PER_BEAM)
            .map(|i| PackedSample {
                rgbe: [b as u8, i as u8, 7, 130],
                entry: [i as u8, 3],
                exit: [5, b as u8],
                dist: (b ^ i) as u16,
            })
            .collect();
        h.write_beam(0, b, &v).unwrap();
        total += v.len() as u64;
    }
    h.commit().unwrap();
    (beams, total)
}

fn recall(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.hdk");
    let (beams, total) = build(&path);
    let h = HoloFile::open(&path).unwrap();
    let mut g = c.benchmark_group("recall");
    g.sample_size(10);
    g.throughput(Throughput::Elements(total));
    let mut buf = Vec::new();
    let mut samples = Vec::with_capacity(PER_BEAM as usize);
    g.bench_function("warm_file", |b| {
        b.iter(|| {
            let mut acc = 0u64;
            for beam in 0..beams {
                h.read_beam_bytes(0, beam, &mut buf).unwrap();
                samples.clear();
                PackedSample::read_all(&buf, &mut samples);
                acc += u64::from(samples[samples.len() - 1].dist);
            }
            acc
        })
    });
    let mut cache = BeamCache::new(HoloFile::open(&path).unwrap(), 1 << 30);
    for beam in 0..beams {
        cache.get(BeamKey::new(0, beam)).unwrap();
    }
    // Copied out, as the server does when it sends a beam to a display.
    g.bench_function("memory_cache", |b| {
        b.iter(|| {
            let mut acc = 0u64;
            for beam in 0..beams {
                samples.clear();
                samples.extend_from_slice(cache.get(BeamKey::new(0, beam)).unwrap());
                acc += u64::from(samples[samples.len() - 1].dist);
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, recall);
criterion_main!(benches);
