//! Test helper for `tests/crash.rs`: fills an existing holodeck file through the beam cache
//! (small budget, so LRU write-backs happen between commits) with samples whose content is
//! a known function of (beam, index), commits every few additions and, after each commit,
//! prints `C <seq> <beam>:<count> …` for the beams changed since the last report. The test
//! SIGKILLs it at random moments and checks the file against these reports.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

use holocave_holodeck::HoloFile;
use holocave_holodeck::beam_index::BeamKey;
use holocave_holodeck::cache::BeamCache;
use holocave_holodeck::sample::PackedSample;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

#[path = "../file/crash_pattern.rs"]
mod crash_pattern;
use crash_pattern::expected;

fn main() {
    let mut args = std::env::args().skip(1);
    let (Some(path), Some(seed)) = (args.next(), args.next()) else {
        eprintln!("usage: holodeck-crash-writer FILE SEED");
        std::process::exit(2);
    };
    let seed: u64 = seed.parse().unwrap_or(0);
    let file = HoloFile::open_rw(&PathBuf::from(&path)).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1);
    });
    let beams = file.sections()[0].beam_count();
    let mut cache = BeamCache::new(file, 4096);
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut changed = BTreeMap::new();
    let out = std::io::stdout();
    loop {
        for _ in 0..rng.random_range(1..12) {
            let beam = rng.random_range(0..beams);
            let have = cache.count(BeamKey::new(0, beam));
            let new: Vec<PackedSample> = (0..rng.random_range(1..6))
                .map(|i| expected(beam, have + i))
                .collect();
            cache.add(BeamKey::new(0, beam), &new).expect("add");
            changed.insert(beam, have + new.len() as u32);
        }
        let seq = cache.flush().expect("commit");
        let mut line = format!("C {seq}");
        for (b, c) in std::mem::take(&mut changed) {
            line.push_str(&format!(" {b}:{c}"));
        }
        line.push('\n');
        let mut o = out.lock();
        o.write_all(line.as_bytes()).expect("stdout");
        o.flush().expect("stdout");
    }
}
