//! The server's in-memory beam cache (paper §2.2): whole beams kept in memory under a byte
//! budget; when it is exceeded, the least recently used beams are written back to the file
//! (not yet committed) and dropped. [`BeamCache::flush`] writes every changed beam, in
//! beam order, and commits.

use std::collections::{BTreeMap, HashMap};

use crate::file::{FileError, HoloFile};
use crate::sample::{SAMPLE_BYTES, Sample};

/// Identifies a beam: (section, beam).
pub type BeamKey = (u16, u32);

/// Bookkeeping bytes charged per cached beam on top of its samples.
const ENTRY_OVERHEAD: usize = 64;

struct Entry {
    samples: Vec<Sample>,
    /// How many of `samples` the file holds.
    stored: u32,
    last_use: u64,
}

impl Entry {
    fn bytes(&self) -> usize {
        self.samples.capacity() * SAMPLE_BYTES + ENTRY_OVERHEAD
    }
}

/// Beams in memory over a holodeck file.
pub struct BeamCache {
    file: HoloFile,
    budget: usize,
    used: usize,
    clock: u64,
    beams: HashMap<BeamKey, Entry>,
    lru: BTreeMap<u64, BeamKey>,
}

impl BeamCache {
    /// A cache of at most about `budget` bytes over `file`.
    pub fn new(file: HoloFile, budget: usize) -> Self {
        Self {
            file,
            budget,
            used: 0,
            clock: 0,
            beams: HashMap::new(),
            lru: BTreeMap::new(),
        }
    }

    pub fn file(&self) -> &HoloFile {
        &self.file
    }

    /// Bytes in use.
    pub fn used(&self) -> usize {
        self.used
    }

    /// Beams in memory.
    pub fn len(&self) -> usize {
        self.beams.len()
    }

    pub fn is_empty(&self) -> bool {
        self.beams.is_empty()
    }

    /// Whether the beam is in memory.
    pub fn contains(&self, key: BeamKey) -> bool {
        self.beams.contains_key(&key)
    }

    /// Samples a beam has, in memory or in the file.
    pub fn count(&self, key: BeamKey) -> u32 {
        match self.beams.get(&key) {
            Some(e) => e.samples.len() as u32,
            None => self.file.count(usize::from(key.0), key.1),
        }
    }

    fn touch(&mut self, key: BeamKey) {
        self.clock += 1;
        let e = self.beams.get_mut(&key).expect("touched beams are cached");
        self.lru.remove(&e.last_use);
        e.last_use = self.clock;
        self.lru.insert(self.clock, key);
    }

    fn load(&mut self, key: BeamKey) -> Result<(), FileError> {
        if self.beams.contains_key(&key) {
            return Ok(());
        }
        let mut samples = Vec::new();
        self.file
            .read_beam(usize::from(key.0), key.1, &mut samples)?;
        let e = Entry {
            stored: samples.len() as u32,
            samples,
            last_use: 0,
        };
        self.used += e.bytes();
        self.beams.insert(key, e);
        Ok(())
    }

    /// A beam's samples (loaded from the file if needed).
    pub fn get(&mut self, key: BeamKey) -> Result<&[Sample], FileError> {
        self.load(key)?;
        self.touch(key);
        self.evict(Some(key))?;
        Ok(&self.beams[&key].samples)
    }

    /// Adds new samples to a beam.
    pub fn add(&mut self, key: BeamKey, new: &[Sample]) -> Result<(), FileError> {
        self.load(key)?;
        let e = self.beams.get_mut(&key).expect("just loaded");
        let before = e.bytes();
        e.samples.extend_from_slice(new);
        self.used = self.used + e.bytes() - before;
        self.touch(key);
        self.evict(Some(key))
    }

    /// Writes back and drops least recently used beams until within budget (never `keep`).
    fn evict(&mut self, keep: Option<BeamKey>) -> Result<(), FileError> {
        while self.used > self.budget {
            let Some((&t, &key)) = self.lru.iter().find(|&(_, k)| Some(*k) != keep) else {
                break;
            };
            self.write_back(key)?;
            let e = self.beams.remove(&key).expect("lru entries are cached");
            self.lru.remove(&t);
            self.used -= e.bytes();
        }
        Ok(())
    }

    fn write_back(&mut self, key: BeamKey) -> Result<(), FileError> {
        let e = self.beams.get_mut(&key).expect("cached");
        if e.samples.len() as u32 != e.stored {
            self.file
                .write_beam(usize::from(key.0), key.1, &e.samples)?;
            e.stored = e.samples.len() as u32;
        }
        Ok(())
    }

    /// Writes every changed beam (in beam order) and commits; returns the commit number.
    pub fn flush(&mut self) -> Result<u64, FileError> {
        let mut dirty: Vec<BeamKey> = self
            .beams
            .iter()
            .filter(|(_, e)| e.samples.len() as u32 != e.stored)
            .map(|(k, _)| *k)
            .collect();
        dirty.sort_unstable();
        for key in dirty {
            self.write_back(key)?;
        }
        self.file.commit()
    }

    /// Flushes and gives the file back.
    pub fn into_file(mut self) -> Result<HoloFile, FileError> {
        self.flush()?;
        Ok(self.file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::{Section, ViewClass};
    use glam::DVec3;

    fn s(i: u32) -> Sample {
        Sample {
            dist: i as u16,
            ..Default::default()
        }
    }

    #[test]
    fn lru_write_back_keeps_every_sample() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let sec = Section::new(
            DVec3::ZERO,
            [DVec3::X, DVec3::Y, DVec3::Z],
            [2, 2, 2],
            ViewClass::Interior,
        )
        .unwrap();
        let h = HoloFile::create(&p, vec![sec], Default::default()).unwrap();
        // Room for about three beams of 20 samples.
        let mut c = BeamCache::new(h, 3 * (20 * SAMPLE_BYTES + ENTRY_OVERHEAD) + 100);
        for round in 0..20u32 {
            for b in 0..10u32 {
                c.add((0, b), &[s(round * 100 + b)]).unwrap();
                assert!(c.used() <= c.budget || c.len() == 1);
            }
        }
        assert!(c.len() < 10, "beams were evicted");
        for b in 0..10u32 {
            assert_eq!(c.count((0, b)), 20);
        }
        c.flush().unwrap();
        drop(c);
        let h = HoloFile::open(&p).unwrap();
        for b in 0..10u32 {
            let mut v = Vec::new();
            h.read_beam(0, b, &mut v).unwrap();
            assert_eq!(v, (0..20).map(|r| s(r * 100 + b)).collect::<Vec<_>>());
        }
    }
}
