//! The holodeck file (paper §2.1, Figure 5), made portable and crash-safe: see
//! [`format`] for the layout and the commit protocol, [`reader`] for opening and reading,
//! [`writer`] for creating, appending and committing, [`check`] for verification and
//! salvage, [`optimize`] for the rewrite that puts neighbouring beams together, and
//! [`info`] for statistics.

pub mod check;
pub mod disk;
pub mod format;
pub mod free_list;
pub mod info;
pub mod optimize;
#[cfg(test)]
mod power_cut;
pub mod reader;
pub mod writer;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use disk::Disk;
use format::{ChunkLoc, DirEntry, Extent};
use free_list::FreeList;

use crate::section::Section;
use holocave_protocol::holodeck::WireDistanceKind;

/// Which distance a sample generator answers for a ray (the holodeck paper's `VDISTANCE`,
/// §2.3): measured from the ray's origin either way. The file records it
/// ([`DISTANCE_SETTING`]); workers are told it in their welcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DistanceKind {
    /// To the first surface the ray hits (`VDISTANCE=False`).
    FirstHit,
    /// To the first non-specular surface, continuing through flat mirrors and flat glass
    /// (`VDISTANCE=True`): samples seen in a mirror reproject to where the reflected object
    /// appears, so reflections keep their parallax and stereo depth.
    #[default]
    Virtual,
}

impl DistanceKind {
    /// The name used in holodeck settings and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DistanceKind::FirstHit => "first-hit",
            DistanceKind::Virtual => "virtual",
        }
    }

    /// Parses [`DistanceKind::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "first-hit" => Some(DistanceKind::FirstHit),
            "virtual" => Some(DistanceKind::Virtual),
            _ => None,
        }
    }
}

impl From<DistanceKind> for WireDistanceKind {
    fn from(d: DistanceKind) -> Self {
        match d {
            DistanceKind::FirstHit => WireDistanceKind::FirstHit,
            DistanceKind::Virtual => WireDistanceKind::Virtual,
        }
    }
}

impl From<WireDistanceKind> for DistanceKind {
    fn from(d: WireDistanceKind) -> Self {
        match d {
            WireDistanceKind::FirstHit => DistanceKind::FirstHit,
            WireDistanceKind::Virtual => DistanceKind::Virtual,
        }
    }
}

/// The settings key recording which distance the samples hold (`first-hit` or `virtual`,
/// [`DistanceKind::name`]). Files without it hold first-hit distances.
pub const DISTANCE_SETTING: &str = "distance";

/// Errors of the holodeck file. Each names the file and, for damage, the structure and the
/// byte offset where it was found.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a holodeck file (neither superblock slot has the magic number)")]
    NotHolodeck { path: PathBuf },
    #[error(
        "{path}: no valid commit record (slot 0 at byte 0: {slot0}; slot 1 at byte 4096: {slot1})"
    )]
    NoValidSuperblock {
        path: PathBuf,
        slot0: String,
        slot1: String,
    },
    #[error(
        "{path}: truncated: {what} needs bytes {start}..{end} but the file has only {len} bytes"
    )]
    Truncated {
        path: PathBuf,
        what: String,
        start: u64,
        end: u64,
        len: u64,
    },
    #[error("{path}: {what} at byte {offset} is damaged: {detail}")]
    Corrupt {
        path: PathBuf,
        what: String,
        offset: u64,
        detail: String,
    },
    #[error("{path}: there is no section {section} (the file has {count})")]
    NoSection {
        path: PathBuf,
        section: usize,
        count: usize,
    },
    #[error("{path}: section {section} has no beam {beam} (it has {count} beams)")]
    NoBeam {
        path: PathBuf,
        section: usize,
        beam: u32,
        count: u32,
    },
    #[error("{path}: beam {beam} of section {section}: {detail}")]
    BadWrite {
        path: PathBuf,
        section: usize,
        beam: u32,
        detail: String,
    },
    #[error("{path} already exists; not overwriting it")]
    Exists { path: PathBuf },
    #[error("{path}: setting {key:?} is {value:?}; expected {expected}")]
    BadSetting {
        path: PathBuf,
        key: String,
        value: String,
        expected: String,
    },
    #[error("{path}: the file is open read-only")]
    ReadOnly { path: PathBuf },
}

/// A damaged structure found while opening tolerantly (for `check` and salvage).
#[derive(Clone, Debug, PartialEq)]
pub struct Damage {
    /// What is damaged, e.g. "directory chunk 3 of section 0 (beams 12288..16384)".
    pub what: String,
    pub offset: u64,
    pub detail: String,
}

/// An open holodeck file: its sections, settings and in-memory directory (paper §2.2:
/// "a copy of this directory is kept resident in memory").
pub struct HoloFile {
    path: PathBuf,
    file: Disk,
    writable: bool,
    settings: BTreeMap<String, String>,
    sections: Vec<Section>,
    dirs: Vec<Vec<DirEntry>>,
    chunks: Vec<Vec<ChunkLoc>>,
    /// Directory chunks changed since the last commit, per section.
    dirty: Vec<BTreeSet<u32>>,
    /// Space reusable now.
    free: FreeList,
    /// Space the last commit still references but the next one will not: reusable only
    /// once the next commit is durable.
    pending_free: Vec<Extent>,
    /// Offsets of beam extents allocated since the last commit (no commit references them,
    /// so moving such a beam frees its old extent at once).
    fresh: std::collections::HashSet<u64>,
    /// Write beams without growth room (a compact copy being built).
    compact: bool,
    /// Allocation high-water mark.
    file_end: u64,
    seq: u64,
    root: Extent,
}

impl HoloFile {
    pub fn path(&self) -> &Path {
        &self.path
    }
    pub fn sections(&self) -> &[Section] {
        &self.sections
    }
    pub fn settings(&self) -> &BTreeMap<String, String> {
        &self.settings
    }
    /// Which distance the samples hold, from the settings (first-hit when not recorded).
    pub fn distance_kind(&self) -> Result<DistanceKind, FileError> {
        match self.settings.get(DISTANCE_SETTING) {
            None => Ok(DistanceKind::FirstHit),
            Some(v) => DistanceKind::from_name(v).ok_or_else(|| FileError::BadSetting {
                path: self.path.clone(),
                key: DISTANCE_SETTING.into(),
                value: v.clone(),
                expected: "first-hit or virtual".into(),
            }),
        }
    }
    /// Sequence number of the last commit.
    pub fn seq(&self) -> u64 {
        self.seq
    }
    /// The directory entry of a beam.
    pub fn entry(&self, section: usize, beam: u32) -> Result<DirEntry, FileError> {
        self.check_beam(section, beam)?;
        Ok(self.dirs[section][beam as usize])
    }
    /// Samples stored for a beam.
    pub fn count(&self, section: usize, beam: u32) -> u32 {
        self.dirs
            .get(section)
            .and_then(|d| d.get(beam as usize))
            .map_or(0, |e| e.count)
    }
    /// Samples stored in all sections.
    pub fn total_samples(&self) -> u64 {
        self.dirs.iter().flatten().map(|e| u64::from(e.count)).sum()
    }
    /// The whole directory of a section.
    pub fn directory(&self, section: usize) -> &[DirEntry] {
        &self.dirs[section]
    }
    /// Free extents (reusable now and pending).
    pub fn free_extents(&self) -> Vec<Extent> {
        let mut f = self.free.clone();
        for e in &self.pending_free {
            f.insert(*e);
        }
        f.extents()
    }
    /// End of the allocated space.
    pub fn file_end(&self) -> u64 {
        self.file_end
    }

    fn check_beam(&self, section: usize, beam: u32) -> Result<(), FileError> {
        let s = self
            .sections
            .get(section)
            .ok_or_else(|| FileError::NoSection {
                path: self.path.clone(),
                section,
                count: self.sections.len(),
            })?;
        if beam >= s.beam_count() {
            return Err(FileError::NoBeam {
                path: self.path.clone(),
                section,
                beam,
                count: s.beam_count(),
            });
        }
        Ok(())
    }

    fn io(&self, source: std::io::Error) -> FileError {
        FileError::Io {
            path: self.path.clone(),
            source,
        }
    }
}
