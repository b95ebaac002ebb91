//! `holodeck check`: verifies every structure and every beam's checksum, reports what is
//! damaged and where, and salvages every intact beam into a new file.

use std::path::Path;

use super::format::{DATA_START, Extent};
use super::{Damage, FileError, HoloFile};

/// What `check` found.
#[derive(Debug, Default)]
pub struct CheckReport {
    /// The commit that was checked.
    pub seq: u64,
    pub beams_ok: u64,
    pub samples_ok: u64,
    pub damage: Vec<Damage>,
}

impl CheckReport {
    pub fn is_clean(&self) -> bool {
        self.damage.is_empty()
    }
}

/// Checks a file. Fails only if no commit of it can be read at all.
pub fn check(path: &Path) -> Result<CheckReport, FileError> {
    let (h, damage) = HoloFile::open_tolerant(path)?;
    let mut report = CheckReport {
        seq: h.seq(),
        damage,
        ..Default::default()
    };
    let mut buf = Vec::new();
    // Every referenced extent, to find overlaps.
    let mut used: Vec<(Extent, String)> = vec![(h.root, "the root block".into())];
    for (si, section) in h.sections().iter().enumerate() {
        for (ci, c) in h.chunks[si].iter().enumerate() {
            if c.extent.len > 0 {
                used.push((c.extent, format!("directory chunk {ci} of section {si}")));
            }
        }
        for beam in 0..section.beam_count() {
            let e = h.directory(si)[beam as usize];
            if e.count == 0 {
                continue;
            }
            used.push((e.extent(), format!("beam {beam} of section {si}")));
            match h.read_beam_bytes(si, beam, &mut buf) {
                Ok(()) => {
                    report.beams_ok += 1;
                    report.samples_ok += u64::from(e.count);
                }
                Err(err) => report.damage.push(Damage {
                    what: format!("beam {beam} of section {si}"),
                    offset: e.offset,
                    detail: err.to_string(),
                }),
            }
        }
    }
    for f in h.free_extents() {
        used.push((f, "free space".into()));
    }
    used.sort_by_key(|(e, _)| e.offset);
    for w in used.windows(2) {
        let ((a, an), (b, bn)) = (&w[0], &w[1]);
        if b.offset < a.end() {
            report.damage.push(Damage {
                what: format!("{bn} (bytes {}..{})", b.offset, b.end()),
                offset: b.offset,
                detail: format!("overlaps {an} (bytes {}..{})", a.offset, a.end()),
            });
        }
    }
    if let Some((first, name)) = used.first()
        && first.offset < DATA_START
    {
        report.damage.push(Damage {
            what: name.clone(),
            offset: first.offset,
            detail: "lies in the superblock area".into(),
        });
    }
    Ok(report)
}

/// What salvage copied.
#[derive(Debug, Default, PartialEq)]
pub struct SalvageReport {
    pub beams: u64,
    pub samples: u64,
    pub beams_lost: u64,
}

/// Copies every beam whose checksum verifies into a new file at `out` (which must not
/// exist), with the same sections and settings.
pub fn salvage(path: &Path, out: &Path) -> Result<SalvageReport, FileError> {
    let (h, _) = HoloFile::open_tolerant(path)?;
    let mut dst = HoloFile::create(out, h.sections().to_vec(), h.settings().clone())?;
    let mut report = SalvageReport::default();
    let mut samples = Vec::new();
    for (si, section) in h.sections().iter().enumerate() {
        for beam in 0..section.beam_count() {
            if h.count(si, beam) == 0 {
                continue;
            }
            samples.clear();
            match h.read_beam(si, beam, &mut samples) {
                Ok(()) => {
                    dst.write_beam(si, beam, &samples)?;
                    report.beams += 1;
                    report.samples += samples.len() as u64;
                }
                Err(_) => report.beams_lost += 1,
            }
        }
    }
    dst.commit()?;
    Ok(report)
}

/// How much of an earlier copy a file still holds.
#[derive(Debug, Default, PartialEq)]
pub struct HoldsReport {
    /// Beams with samples in the earlier copy.
    pub beams: u64,
    /// Samples in the earlier copy.
    pub samples: u64,
    /// Beams with fewer samples now than in the earlier copy.
    pub beams_short: u64,
    /// Samples of the earlier copy that differ now (same beam, same position).
    pub samples_changed: u64,
}

impl HoldsReport {
    /// Whether every sample of the earlier copy is still there, unchanged.
    pub fn holds_all(&self) -> bool {
        self.beams_short == 0 && self.samples_changed == 0
    }
}

/// Compares `path` with an earlier copy of it (`old`, e.g. a salvage taken while it was
/// being filled): every beam of `old` must be a prefix of the same beam now, since samples
/// are only ever appended (`optimize` moves beams but keeps their order).
pub fn holds(path: &Path, old: &Path) -> Result<HoldsReport, FileError> {
    let h = HoloFile::open(path)?;
    let o = HoloFile::open(old)?;
    if o.sections() != h.sections() {
        return Err(FileError::Corrupt {
            path: old.to_path_buf(),
            what: "section geometry".into(),
            offset: 0,
            detail: format!("differs from that of {}", path.display()),
        });
    }
    let mut report = HoldsReport::default();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for (si, section) in o.sections().iter().enumerate() {
        for beam in 0..section.beam_count() {
            if o.count(si, beam) == 0 {
                continue;
            }
            a.clear();
            b.clear();
            o.read_beam(si, beam, &mut a)?;
            h.read_beam(si, beam, &mut b)?;
            report.beams += 1;
            report.samples += a.len() as u64;
            if b.len() < a.len() {
                report.beams_short += 1;
            }
            report.samples_changed += a.iter().zip(&b).filter(|(x, y)| x != y).count() as u64;
        }
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::format::SLOT_BYTES;
    use crate::sample::PackedSample;
    use crate::section::{Section, ViewClass};
    use glam::DVec3;
    use std::os::unix::fs::FileExt;

    fn make(path: &Path) -> HoloFile {
        let s =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let mut h = HoloFile::create(path, vec![s], Default::default()).unwrap();
        for b in 0..20 {
            let v: Vec<PackedSample> = (0..(b + 1))
                .map(|i| PackedSample {
                    dist: i as u16,
                    ..Default::default()
                })
                .collect();
            h.write_beam(0, b, &v).unwrap();
        }
        h.commit().unwrap();
        h
    }

    fn poke(path: &Path, at: u64) {
        let f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .unwrap();
        let mut b = [0u8];
        f.read_exact_at(&mut b, at).unwrap();
        f.write_all_at(&[b[0] ^ 0x55], at).unwrap();
    }

    #[test]
    fn clean_file_checks_clean() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        make(&p);
        let r = check(&p).unwrap();
        assert!(r.is_clean(), "{:?}", r.damage);
        assert_eq!((r.beams_ok, r.samples_ok), (20, 210));
    }

    #[test]
    fn corrupt_beam_is_named_and_salvage_keeps_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let h = make(&p);
        let off = h.entry(0, 7).unwrap().offset;
        drop(h);
        poke(&p, off + 3);
        let r = check(&p).unwrap();
        assert_eq!(r.damage.len(), 1);
        assert_eq!(r.damage[0].what, "beam 7 of section 0");
        assert!(
            r.damage[0].detail.contains("checksum"),
            "{}",
            r.damage[0].detail
        );
        let h = HoloFile::open(&p).unwrap();
        let err = h.read_beam(0, 7, &mut Vec::new()).unwrap_err().to_string();
        assert!(
            err.contains("beam 7 of section 0") && err.contains(&format!("byte {off}")),
            "{err}"
        );
        let out = dir.path().join("b.hdk");
        let s = salvage(&p, &out).unwrap();
        assert_eq!(
            s,
            SalvageReport {
                beams: 19,
                samples: 202,
                beams_lost: 1
            }
        );
        assert!(check(&out).unwrap().is_clean());
        // The salvage holds only what it copied; the original holds all of the salvage.
        let r = holds(&p, &out).unwrap();
        assert!(r.holds_all() && r.samples == 202, "{r:?}");
    }

    #[test]
    fn holds_finds_missing_and_changed_samples() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let mut h = make(&p);
        let old = dir.path().join("old.hdk");
        std::fs::copy(&p, &old).unwrap();
        let more = [PackedSample {
            dist: 999,
            ..Default::default()
        }];
        h.append_beam(0, 3, &more).unwrap();
        h.commit().unwrap();
        assert_eq!(
            holds(&p, &old).unwrap(),
            HoldsReport {
                beams: 20,
                samples: 210,
                beams_short: 0,
                samples_changed: 0
            }
        );
        // The other way round, beam 3 is short; a changed sample is counted.
        assert_eq!(holds(&old, &p).unwrap().beams_short, 1);
        let mut v: Vec<PackedSample> = Vec::new();
        h.read_beam(0, 5, &mut v).unwrap();
        drop(h);
        let c = dir.path().join("c.hdk");
        let mut h = HoloFile::create(
            &c,
            HoloFile::open(&p).unwrap().sections().to_vec(),
            Default::default(),
        )
        .unwrap();
        for b in 0..20 {
            let mut s: Vec<PackedSample> = Vec::new();
            HoloFile::open(&p).unwrap().read_beam(0, b, &mut s).unwrap();
            if b == 5 {
                s[2].dist ^= 1;
            }
            h.write_beam(0, b, &s).unwrap();
        }
        h.commit().unwrap();
        let r = holds(&c, &old).unwrap();
        assert_eq!((r.beams_short, r.samples_changed), (0, 1), "{r:?}");
        assert!(!r.holds_all());
    }

    #[test]
    fn truncation_and_damaged_structures_are_reported() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let h = make(&p);
        let len = std::fs::metadata(&p).unwrap().len();
        let chunk = h.chunks[0][0].extent.offset;
        drop(h);
        // Truncated: strict open names the problem.
        let t = dir.path().join("t.hdk");
        std::fs::copy(&p, &t).unwrap();
        std::fs::OpenOptions::new()
            .write(true)
            .open(&t)
            .unwrap()
            .set_len(len - 100)
            .unwrap();
        let err = HoloFile::open(&t).err().unwrap().to_string();
        assert!(err.contains("truncated"), "{err}");
        // Damaged directory chunk.
        let c = dir.path().join("c.hdk");
        std::fs::copy(&p, &c).unwrap();
        poke(&c, chunk + 5);
        let err = HoloFile::open(&c).err().unwrap().to_string();
        assert!(
            err.contains("directory chunk 0 of section 0") && err.contains("checksum"),
            "{err}"
        );
        let r = check(&c).unwrap();
        assert!(
            r.damage
                .iter()
                .any(|d| d.what.starts_with("directory chunk 0")),
            "{:?}",
            r.damage
        );
        // Damaged newest superblock: the previous commit is used.
        let s = dir.path().join("s.hdk");
        std::fs::copy(&p, &s).unwrap();
        let seq = HoloFile::open(&s).unwrap().seq();
        poke(&s, (seq % 2) * SLOT_BYTES + 20);
        assert_eq!(HoloFile::open(&s).unwrap().seq(), seq - 1);
        // Not a holodeck file at all.
        let n = dir.path().join("n.hdk");
        std::fs::write(&n, b"hello").unwrap();
        assert!(matches!(
            HoloFile::open(&n),
            Err(FileError::NotHolodeck { .. })
        ));
    }
}
