//! The server's in-memory beam cache (paper §2.2): beams kept in memory under a byte
//! budget; when it is exceeded, the least recently used beams are written back to the file
//! (not yet committed) and dropped. [`BeamCache::flush`] writes every changed beam, in
//! beam order, and commits.
//!
//! A beam that is only added to (batch filling) is held as just its new samples: adding
//! never reads the file, and writing back appends in place. Only [`BeamCache::get`] loads
//! a whole beam. So a fill far larger than the cache costs no more per sample than a small
//! one.

use std::collections::{HashMap, VecDeque};
use std::hash::{BuildHasherDefault, Hasher};

use crate::beam_index::BeamKey;
use crate::file::{FileError, HoloFile};
use crate::sample::{PackedSample, SAMPLE_BYTES};

/// A fast hasher for beam keys and other small integers (the multiply-rotate of rustc's
/// FxHasher): the server looks beams up several times per ray bundle, and SipHash cost more
/// than the rest of the bookkeeping. Not for keys an adversary chooses.
#[derive(Default, Clone, Copy)]
pub struct BeamHasher(u64);

impl Hasher for BeamHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u16(&mut self, v: u16) {
        self.write_u64(u64::from(v));
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(u64::from(v));
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

/// A map keyed by beam (or other small integers) with [`BeamHasher`].
pub type BeamMap<K, V> = HashMap<K, V, BuildHasherDefault<BeamHasher>>;

/// Bookkeeping bytes charged per cached beam on top of its samples.
const ENTRY_OVERHEAD: usize = 64;

struct Entry {
    /// All the beam's samples if `whole`, otherwise only those after the `stored` ones.
    samples: Vec<PackedSample>,
    /// How many samples the file holds (the first ones of the beam).
    stored: u32,
    whole: bool,
    last_use: u64,
}

impl Entry {
    fn bytes(&self) -> usize {
        self.samples.capacity() * SAMPLE_BYTES + ENTRY_OVERHEAD
    }
    fn count(&self) -> u32 {
        if self.whole {
            self.samples.len() as u32
        } else {
            self.stored + self.samples.len() as u32
        }
    }
    fn unwritten(&self) -> usize {
        if self.whole {
            self.samples.len() - self.stored as usize
        } else {
            self.samples.len()
        }
    }
}

/// Beams in memory over a holodeck file.
pub struct BeamCache {
    file: HoloFile,
    budget: usize,
    used: usize,
    clock: u64,
    beams: BeamMap<BeamKey, Entry>,
    /// Uses in order (oldest first), with stale ones (the beam was used again since, or
    /// dropped) skipped on eviction and compacted away when they pile up.
    lru: VecDeque<(u64, BeamKey)>,
}

impl BeamCache {
    /// A cache of at most about `budget` bytes over `file`.
    pub fn new(file: HoloFile, budget: usize) -> Self {
        Self {
            file,
            budget,
            used: 0,
            clock: 0,
            beams: BeamMap::default(),
            lru: VecDeque::new(),
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
            Some(e) => e.count(),
            None => self.file.count(usize::from(key.section), key.beam),
        }
    }

    fn touch(&mut self, key: BeamKey) {
        self.clock += 1;
        let e = self.beams.get_mut(&key).expect("touched beams are cached");
        e.last_use = self.clock;
        self.lru.push_back((self.clock, key));
        if self.lru.len() > 4 * self.beams.len() + 1024 {
            let beams = &self.beams;
            self.lru
                .retain(|(t, k)| beams.get(k).is_some_and(|e| e.last_use == *t));
        }
    }

    /// Makes the beam's entry whole, reading the stored samples.
    fn load(&mut self, key: BeamKey) -> Result<(), FileError> {
        if self.beams.get(&key).is_some_and(|e| e.whole) {
            return Ok(());
        }
        let mut samples = Vec::new();
        self.file
            .read_beam(usize::from(key.section), key.beam, &mut samples)?;
        match self.beams.get_mut(&key) {
            Some(e) => {
                let before = e.bytes();
                samples.append(&mut e.samples);
                e.samples = samples;
                e.whole = true;
                self.used = self.used + e.bytes() - before;
            }
            None => {
                let e = Entry {
                    stored: samples.len() as u32,
                    samples,
                    whole: true,
                    last_use: 0,
                };
                self.used += e.bytes();
                self.beams.insert(key, e);
            }
        }
        Ok(())
    }

    /// A beam's samples (loaded from the file if needed).
    pub fn get(&mut self, key: BeamKey) -> Result<&[PackedSample], FileError> {
        self.load(key)?;
        self.touch(key);
        self.evict(Some(key))?;
        Ok(&self.beams[&key].samples)
    }

    /// Adds new samples to a beam (without reading it).
    pub fn add(&mut self, key: BeamKey, new: &[PackedSample]) -> Result<(), FileError> {
        if !self.beams.contains_key(&key) {
            let stored = self.file.count(usize::from(key.section), key.beam);
            let e = Entry {
                samples: Vec::new(),
                stored,
                whole: false,
                last_use: 0,
            };
            self.used += e.bytes();
            self.beams.insert(key, e);
        }
        let e = self.beams.get_mut(&key).expect("inserted above");
        let before = e.bytes();
        e.samples.extend_from_slice(new);
        self.used = self.used + e.bytes() - before;
        self.touch(key);
        self.evict(Some(key))
    }

    /// Writes back and drops least recently used beams until within budget (never `keep`).
    fn evict(&mut self, keep: Option<BeamKey>) -> Result<(), FileError> {
        let mut kept = None;
        while self.used > self.budget {
            let Some((t, key)) = self.lru.pop_front() else {
                break;
            };
            if self.beams.get(&key).is_none_or(|e| e.last_use != t) {
                continue; // stale
            }
            if Some(key) == keep {
                kept = Some((t, key));
                continue;
            }
            self.write_back(key)?;
            let e = self
                .beams
                .remove(&key)
                .expect("live lru entries are cached");
            self.used -= e.bytes();
        }
        if let Some(k) = kept {
            self.lru.push_front(k);
        }
        Ok(())
    }

    fn write_back(&mut self, key: BeamKey) -> Result<(), FileError> {
        let e = self.beams.get_mut(&key).expect("cached");
        let n = e.unwritten();
        if n == 0 {
            return Ok(());
        }
        let (s, b) = (usize::from(key.section), key.beam);
        if e.whole {
            self.file.write_beam(s, b, &e.samples)?;
        } else {
            self.file.append_beam(s, b, &e.samples)?;
            e.samples.clear();
        }
        e.stored += n as u32;
        Ok(())
    }

    /// Writes every changed beam (in beam order) and commits; returns the commit number.
    pub fn flush(&mut self) -> Result<u64, FileError> {
        let mut dirty: Vec<BeamKey> = self
            .beams
            .iter()
            .filter(|(_, e)| e.unwritten() > 0)
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

    fn s(i: u32) -> PackedSample {
        PackedSample {
            dist: i as u16,
            ..Default::default()
        }
    }

    #[test]
    fn lru_write_back_keeps_every_sample() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let sec =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let h = HoloFile::create(&p, vec![sec], Default::default()).unwrap();
        // Room for about three beams of 20 samples.
        let mut c = BeamCache::new(h, 3 * (20 * SAMPLE_BYTES + ENTRY_OVERHEAD) + 100);
        for round in 0..20u32 {
            for b in 0..10u32 {
                c.add(BeamKey::new(0, b), &[s(round * 100 + b)]).unwrap();
                assert!(c.used() <= c.budget || c.len() == 1);
            }
        }
        assert!(c.len() < 10, "beams were evicted");
        for b in 0..10u32 {
            assert_eq!(c.count(BeamKey::new(0, b)), 20);
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

    #[test]
    fn the_least_recently_used_beam_goes_first() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let sec =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let h = HoloFile::create(&p, vec![sec], Default::default()).unwrap();
        // A one-sample beam holds a vector of capacity 4.
        let one = 4 * SAMPLE_BYTES + ENTRY_OVERHEAD;
        let mut c = BeamCache::new(h, 3 * one);
        for b in 0..3 {
            c.add(BeamKey::new(0, b), &[s(b)]).unwrap();
        }
        // Many uses of beams 0 and 2 (stale queue entries pile up and are compacted).
        for i in 0..5000 {
            c.get(BeamKey::new(0, 2 * (i % 2))).unwrap();
        }
        c.add(BeamKey::new(0, 3), &[s(3)]).unwrap();
        assert!(
            !c.contains(BeamKey::new(0, 1)),
            "beam 1 was the least recently used"
        );
        assert!(
            c.contains(BeamKey::new(0, 0))
                && c.contains(BeamKey::new(0, 2))
                && c.contains(BeamKey::new(0, 3))
        );
        assert!(c.lru.len() <= 4 * c.len() + 1024);
        c.get(BeamKey::new(0, 0)).unwrap();
        c.add(BeamKey::new(0, 4), &[s(4)]).unwrap();
        assert!(!c.contains(BeamKey::new(0, 2)) && c.contains(BeamKey::new(0, 0)));
        assert_eq!(
            c.count(BeamKey::new(0, 1)),
            1,
            "written back, counted from the file"
        );
    }

    #[test]
    fn adding_to_stored_beams_keeps_only_the_new_samples_in_memory() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let sec =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let mut h = HoloFile::create(&p, vec![sec], Default::default()).unwrap();
        let old: Vec<PackedSample> = (0..1000).map(s).collect();
        for b in 0..4 {
            h.write_beam(0, b, &old).unwrap();
        }
        h.commit().unwrap();
        let mut c = BeamCache::new(h, 1 << 20);
        for b in 0..4 {
            c.add(BeamKey::new(0, b), &[s(5000 + b), s(6000 + b)])
                .unwrap();
        }
        assert_eq!(c.count(BeamKey::new(0, 2)), 1002);
        assert!(
            c.used() < 4 * (100 * SAMPLE_BYTES + ENTRY_OVERHEAD),
            "{}",
            c.used()
        );
        // A reader sees the whole beam, stored samples first.
        let got = c.get(BeamKey::new(0, 1)).unwrap().to_vec();
        assert_eq!(got.len(), 1002);
        assert_eq!(&got[..1000], &old[..]);
        assert_eq!(got[1000..], [s(5001), s(6001)]);
        c.add(BeamKey::new(0, 1), &[s(7001)]).unwrap();
        c.add(BeamKey::new(0, 3), &[s(7003)]).unwrap();
        c.flush().unwrap();
        c.add(BeamKey::new(0, 3), &[s(8003)]).unwrap();
        assert_eq!(c.count(BeamKey::new(0, 3)), 1004);
        drop(c.into_file().unwrap());
        let h = HoloFile::open(&p).unwrap();
        for (b, tail) in [
            (0, vec![s(5000), s(6000)]),
            (1, vec![s(5001), s(6001), s(7001)]),
            (2, vec![s(5002), s(6002)]),
            (3, vec![s(5003), s(6003), s(7003), s(8003)]),
        ] {
            let mut v = Vec::new();
            h.read_beam(0, b, &mut v).unwrap();
            assert_eq!(&v[..1000], &old[..], "beam {b}");
            assert_eq!(v[1000..], tail[..], "beam {b}");
        }
    }
}
