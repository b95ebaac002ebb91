//! Power cuts: the crash test (`tests/crash.rs`) SIGKILLs a writer, which keeps every
//! write in the page cache, so it cannot tell whether the commit syncs at all. Here the
//! file is written through a [`Disk`](super::disk::Disk) keeping a power-cut journal, and
//! after every single write and sync the image a power cut would leave there (the synced
//! bytes and a random subset of the writes since) is opened and checked against what the
//! writer had committed: it must open cleanly, hold every committed sample and invent none.

use std::collections::HashMap;

use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use super::HoloFile;
use super::check::check;
use crate::beam_index::BeamKey;
use crate::cache::BeamCache;
use crate::sample::PackedSample;
use crate::section::{Section, ViewClass};

#[path = "crash_pattern.rs"]
mod crash_pattern;
use crash_pattern::expected;

/// What is wrong with a power-cut `image`, given the last commit that returned (`seq`,
/// per-beam counts); `None` if nothing.
fn damage(
    dir: &std::path::Path,
    image: &[u8],
    seq: u64,
    committed: &HashMap<u32, u32>,
) -> Option<String> {
    let path = dir.join("cut.hdk");
    std::fs::write(&path, image).expect("write the image");
    let h = match HoloFile::open(&path) {
        Ok(h) => h,
        Err(e) => return Some(format!("unreadable: {e}")),
    };
    if h.seq() < seq {
        return Some(format!(
            "commit {seq} had returned, the image is at {}",
            h.seq()
        ));
    }
    for beam in 0..h.sections()[0].beam_count() {
        let mut got = Vec::new();
        if let Err(e) = h.read_beam(0, beam, &mut got) {
            return Some(format!("beam {beam}: {e}"));
        }
        let want = committed.get(&beam).copied().unwrap_or(0) as usize;
        if got.len() < want {
            return Some(format!(
                "beam {beam} has {} samples, {want} were committed",
                got.len()
            ));
        }
        if let Some(i) = (0..got.len()).find(|&i| got[i] != expected(beam, i as u32)) {
            return Some(format!("beam {beam}: sample {i} was never written"));
        }
    }
    match check(&path) {
        Ok(r) if r.is_clean() => None,
        Ok(_) => Some("check found damage".into()),
        Err(e) => Some(format!("check: {e}")),
    }
}

#[test]
fn a_power_cut_after_any_write_loses_nothing_committed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.hdk");
    let s = Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
    HoloFile::create(&path, vec![s], Default::default()).unwrap();
    let mut h = HoloFile::open_rw(&path).unwrap();
    let journal = h.file.journal();
    journal.lock().unwrap().cut_every(1, 7);
    let beams = h.sections()[0].beam_count();
    // A small budget, so LRU write-backs happen between commits.
    let mut cache = BeamCache::new(h, 4096);
    let mut rng = SmallRng::seed_from_u64(5);
    let (mut seq, mut committed) = (1, HashMap::new());
    let mut counts: HashMap<u32, u32> = HashMap::new();
    let (mut cuts, mut failures) = (0, Vec::new());
    let mut look = |seq: u64, committed: &HashMap<u32, u32>| {
        for image in journal.lock().unwrap().take_cuts() {
            cuts += 1;
            if let Some(d) = damage(dir.path(), &image, seq, committed) {
                failures.push(format!("cut {cuts}: {d}"));
            }
        }
    };
    for _ in 0..100 {
        for _ in 0..rng.random_range(1..12) {
            let beam = rng.random_range(0..beams);
            let have = cache.count(BeamKey::new(0, beam));
            let new: Vec<PackedSample> = (0..rng.random_range(1..6))
                .map(|i| expected(beam, have + i))
                .collect();
            cache.add(BeamKey::new(0, beam), &new).unwrap();
            counts.insert(beam, have + new.len() as u32);
            look(seq, &committed);
        }
        let done = cache.flush().unwrap();
        // The cuts during the commit may show it or the one before.
        look(seq, &committed);
        (seq, committed) = (done, counts.clone());
    }
    look(seq, &committed);
    assert!(
        failures.is_empty(),
        "{} of {cuts} power cuts lost or invented data, first: {}",
        failures.len(),
        failures[0]
    );
    assert!(cuts >= 1000, "only {cuts} power cuts");
}
