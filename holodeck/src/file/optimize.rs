//! `holodeck optimize` (paper §2.2): rewrites the file so that beams lie on disk in beam
//! order (neighbouring cells together: consecutive beams share their entry cell and have
//! adjacent exit cells) with no free fragments, into a temporary file that then replaces
//! the original by an atomic rename. The original is untouched until the rename; a beam
//! that fails its checksum aborts the rewrite (run `check --salvage` first).

use std::path::Path;

use super::writer::{sync_parent, temp_path};
use super::{FileError, HoloFile};

/// Sizes before and after.
#[derive(Debug, PartialEq)]
pub struct OptimizeReport {
    pub bytes_before: u64,
    pub bytes_after: u64,
    pub fragments_before: usize,
    pub beams: u64,
    pub samples: u64,
}

/// Optimises `path` in place (via a new file and a rename).
pub fn optimize(path: &Path) -> Result<OptimizeReport, FileError> {
    let src = HoloFile::open(path)?;
    let io = |source| FileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let bytes_before = std::fs::metadata(path).map_err(io)?.len();
    let fragments_before = src.free_extents().len();
    let tmp = temp_path(path);
    let mut dst =
        HoloFile::create_at(&tmp, src.sections().to_vec(), src.settings().clone(), false)?;
    let (mut beams, mut samples) = (0, 0);
    let mut buf = Vec::new();
    for (si, section) in src.sections().iter().enumerate() {
        for beam in 0..section.beam_count() {
            if src.count(si, beam) == 0 {
                continue;
            }
            buf.clear();
            let copied = src
                .read_beam(si, beam, &mut buf)
                .and_then(|()| dst.write_beam(si, beam, &buf));
            if let Err(e) = copied {
                let _ = std::fs::remove_file(&tmp);
                return Err(e);
            }
            beams += 1;
            samples += buf.len() as u64;
        }
    }
    dst.commit()?;
    drop(dst);
    std::fs::rename(&tmp, path).map_err(io)?;
    sync_parent(path).map_err(io)?;
    let bytes_after = std::fs::metadata(path).map_err(io)?.len();
    Ok(OptimizeReport {
        bytes_before,
        bytes_after,
        fragments_before,
        beams,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::PackedSample;
    use crate::section::{Section, ViewClass};
    use glam::DVec3;

    #[test]
    fn optimize_orders_beams_and_removes_fragments() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let s =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let mut h = HoloFile::create(&p, vec![s], Default::default()).unwrap();
        let sample = |i: u32| PackedSample {
            dist: i as u16,
            ..Default::default()
        };
        for round in 0..5u32 {
            for b in (0..40u32).rev() {
                h.append_beam(0, b * 7, &[sample(round), sample(b)])
                    .unwrap();
            }
            h.commit().unwrap();
        }
        let before: Vec<Vec<PackedSample>> = (0..40)
            .map(|b| {
                let mut v = Vec::new();
                h.read_beam(0, b * 7, &mut v).unwrap();
                v
            })
            .collect();
        assert!(!h.free_extents().is_empty());
        drop(h);
        let r = optimize(&p).unwrap();
        assert_eq!((r.beams, r.samples), (40, 400));
        assert!(r.bytes_after < r.bytes_before);
        let h = HoloFile::open(&p).unwrap();
        assert!(h.free_extents().is_empty(), "{:?}", h.free_extents());
        let mut last = 0;
        for b in 0..40 {
            let mut v = Vec::new();
            h.read_beam(0, b * 7, &mut v).unwrap();
            assert_eq!(v, before[b as usize]);
            let off = h.entry(0, b * 7).unwrap().offset;
            assert!(off > last, "beams lie in beam order");
            last = off;
        }
        assert!(!temp_path(&p).exists());
    }
}
