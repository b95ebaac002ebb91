//! Creating a holodeck file, appending samples to beams, and committing.
//!
//! New samples never overwrite bytes the last commit references: a beam grows in place only
//! into free space right after it, and otherwise moves whole to a new extent; changed
//! directory chunks and the root block are written to new space too. [`HoloFile::commit`]
//! then syncs the data, writes the superblock into the other slot and syncs again — the
//! atomic commit point. Space that the new commit stops referencing becomes reusable only
//! after that.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};

use super::disk::Disk;
use super::format::{
    CHUNK_BEAMS, ChunkLoc, DATA_START, DirEntry, Extent, Root, SLOT_BYTES, Superblock, VERSION,
    chunk_to_bytes,
};
use super::free_list::FreeList;
use super::{FileError, HoloFile};
use crate::sample::{PackedSample, SAMPLE_BYTES};
use crate::section::Section;

/// The temporary name a new or rewritten file is built under before its atomic rename.
pub fn temp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

/// Syncs the directory holding `path`, making a rename durable.
pub(crate) fn sync_parent(path: &Path) -> std::io::Result<()> {
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    File::open(parent)?.sync_all()
}

impl HoloFile {
    /// Creates a new, empty holodeck file with these sections and settings. The file is
    /// built under a temporary name and renamed into place, so a crash never leaves a
    /// half-made file at `path`. Fails if `path` exists.
    pub fn create(
        path: &Path,
        sections: Vec<Section>,
        settings: BTreeMap<String, String>,
    ) -> Result<Self, FileError> {
        if path.exists() {
            return Err(FileError::Exists {
                path: path.to_path_buf(),
            });
        }
        let tmp = temp_path(path);
        let mut h = Self::create_at(&tmp, sections, settings, true)?;
        let io = |source| FileError::Io {
            path: path.to_path_buf(),
            source,
        };
        std::fs::rename(&tmp, path).map_err(io)?;
        sync_parent(path).map_err(io)?;
        h.path = path.to_path_buf();
        Ok(h)
    }

    /// Builds a new file at exactly `path` (overwriting it): used for temporary files.
    /// Without `initial_commit` the file has no valid commit until the first
    /// [`HoloFile::commit`] and beams are written without growth room (used by optimize,
    /// whose one commit holds everything).
    pub(crate) fn create_at(
        path: &Path,
        sections: Vec<Section>,
        settings: BTreeMap<String, String>,
        initial_commit: bool,
    ) -> Result<Self, FileError> {
        let io = |source| FileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(path)
            .map_err(io)?;
        file.set_len(DATA_START).map_err(io)?;
        let n = sections.len();
        let chunks = sections
            .iter()
            .map(|s| vec![ChunkLoc::default(); s.beam_count().div_ceil(CHUNK_BEAMS) as usize])
            .collect();
        let dirs = sections
            .iter()
            .map(|s| vec![DirEntry::default(); s.beam_count() as usize])
            .collect();
        let mut h = HoloFile {
            path: path.to_path_buf(),
            file: Disk::new(file),
            writable: true,
            settings,
            sections,
            dirs,
            chunks,
            dirty: vec![BTreeSet::new(); n],
            free: FreeList::default(),
            pending_free: Vec::new(),
            fresh: Default::default(),
            compact: !initial_commit,
            file_end: DATA_START,
            seq: 0,
            root: Extent::default(),
        };
        if initial_commit {
            h.write_commit()?;
        }
        Ok(h)
    }

    fn allocate(&mut self, len: u64) -> u64 {
        self.free.allocate(len).unwrap_or_else(|| {
            let at = self.file_end;
            self.file_end += len;
            at
        })
    }

    fn write_at(&self, bytes: &[u8], offset: u64) -> Result<(), FileError> {
        self.file
            .write_all_at(bytes, offset)
            .map_err(|e| self.io(e))
    }

    fn check_writable(&self) -> Result<(), FileError> {
        if self.writable {
            Ok(())
        } else {
            Err(FileError::ReadOnly {
                path: self.path.clone(),
            })
        }
    }

    fn set_entry(&mut self, section: usize, beam: u32, e: DirEntry) {
        self.dirs[section][beam as usize] = e;
        self.dirty[section].insert(beam / CHUNK_BEAMS);
    }

    /// Writes a beam whose full content is `samples`, of which the first `count` (the
    /// stored count) are already on disk and unchanged. The new samples are appended in
    /// place when the space after the beam is free, otherwise the whole beam moves. Not
    /// durable until [`HoloFile::commit`].
    pub fn write_beam(
        &mut self,
        section: usize,
        beam: u32,
        samples: &[PackedSample],
    ) -> Result<(), FileError> {
        self.check_writable()?;
        let old = self.entry(section, beam)?;
        let have = old.count as usize;
        if samples.len() < have {
            return Err(FileError::BadWrite {
                path: self.path.clone(),
                section,
                beam,
                detail: format!("{} samples given but {have} are stored", samples.len()),
            });
        }
        self.put(section, beam, old, &samples[have..], Some(samples))
    }

    /// Appends samples to a beam: in place when the space after it is free, otherwise the
    /// stored records are read (and their checksum verified) and the whole beam moves.
    pub fn append_beam(
        &mut self,
        section: usize,
        beam: u32,
        new: &[PackedSample],
    ) -> Result<(), FileError> {
        self.check_writable()?;
        let old = self.entry(section, beam)?;
        self.put(section, beam, old, new, None)
    }

    /// Appends `new` to the beam whose directory entry is `old`; `all` is its whole content
    /// if the caller has it (else it is read if the beam has to move).
    fn put(
        &mut self,
        section: usize,
        beam: u32,
        old: DirEntry,
        new: &[PackedSample],
        all: Option<&[PackedSample]>,
    ) -> Result<(), FileError> {
        if new.is_empty() {
            return Ok(());
        }
        let have = old.count as usize;
        let Some(count) = u32::try_from(have + new.len()).ok() else {
            return Err(FileError::BadWrite {
                path: self.path.clone(),
                section,
                beam,
                detail: format!("{} samples exceed a beam's limit", have + new.len()),
            });
        };
        let mut new_bytes = Vec::new();
        PackedSample::write_all(new, &mut new_bytes);
        let add = new_bytes.len() as u64;
        let old_ext = old.extent();
        let in_place = have > 0
            && (self.free.take_at(old_ext.end(), add) || {
                let at_end = old_ext.end() == self.file_end;
                if at_end {
                    self.file_end += add;
                }
                at_end
            });
        if in_place {
            self.write_at(&new_bytes, old_ext.end())?;
            let mut h = crc32fast::Hasher::new_with_initial_len(old.crc, old_ext.len);
            let mut tail = crc32fast::Hasher::new();
            tail.update(&new_bytes);
            h.combine(&tail);
            self.set_entry(
                section,
                beam,
                DirEntry {
                    offset: old.offset,
                    count,
                    crc: h.finalize(),
                },
            );
        } else {
            let mut bytes = Vec::with_capacity(count as usize * SAMPLE_BYTES);
            match all {
                Some(all) => PackedSample::write_all(all, &mut bytes),
                None => {
                    self.read_beam_bytes(section, beam, &mut bytes)?;
                    bytes.extend_from_slice(&new_bytes);
                }
            }
            if have > 0 {
                if self.fresh.remove(&old.offset) {
                    // Written since the last commit: no commit references it.
                    self.free.insert(old_ext);
                } else {
                    self.pending_free.push(old_ext);
                }
            }
            // Half again as much room, left free right after the beam, so that the next
            // appends usually go in place (not when writing a compact copy).
            let len = bytes.len() as u64;
            let slack = if self.compact { 0 } else { len / 2 };
            let at = self.allocate(len + slack);
            self.free.insert(Extent {
                offset: at + len,
                len: slack,
            });
            self.fresh.insert(at);
            self.write_at(&bytes, at)?;
            self.set_entry(
                section,
                beam,
                DirEntry {
                    offset: at,
                    count,
                    crc: crc32fast::hash(&bytes),
                },
            );
        }
        Ok(())
    }

    /// Whether anything was written since the last commit.
    pub fn has_uncommitted(&self) -> bool {
        self.dirty.iter().any(|d| !d.is_empty())
    }

    /// Makes everything written so far durable, atomically. Returns the commit's sequence
    /// number. A crash before it returns leaves the previous commit.
    pub fn commit(&mut self) -> Result<u64, FileError> {
        self.check_writable()?;
        if !self.has_uncommitted() && self.seq > 0 {
            return Ok(self.seq);
        }
        self.write_commit()?;
        Ok(self.seq)
    }

    fn write_commit(&mut self) -> Result<(), FileError> {
        // 1. Changed directory chunks, copy-on-write.
        for s in 0..self.sections.len() {
            let dirty = std::mem::take(&mut self.dirty[s]);
            for ci in dirty {
                let first = (ci * CHUNK_BEAMS) as usize;
                let last = (first + CHUNK_BEAMS as usize).min(self.dirs[s].len());
                let bytes = chunk_to_bytes(&self.dirs[s][first..last]);
                let at = self.allocate(bytes.len() as u64);
                self.write_at(&bytes, at)?;
                let old = std::mem::replace(
                    &mut self.chunks[s][ci as usize],
                    ChunkLoc {
                        extent: Extent {
                            offset: at,
                            len: bytes.len() as u64,
                        },
                        crc: crc32fast::hash(&bytes),
                    },
                );
                self.pending_free.push(old.extent);
            }
        }
        // 2. The root, at the end; its free list is what the new commit leaves unreferenced.
        let mut saved = self.free.clone();
        for e in self.pending_free.iter().chain(std::iter::once(&self.root)) {
            saved.insert(*e);
        }
        let root = Root {
            settings: self.settings.clone(),
            sections: self.sections.clone(),
            chunks: self.chunks.clone(),
            free: saved.extents(),
        };
        let bytes = root.to_bytes();
        let root_ext = Extent {
            offset: self.file_end,
            len: bytes.len() as u64,
        };
        self.file_end += root_ext.len;
        self.write_at(&bytes, root_ext.offset)?;
        // 3. Data durable before the commit record.
        self.file.sync_data().map_err(|e| self.io(e))?;
        // 4. The commit record, in the slot not holding the previous commit.
        let seq = self.seq + 1;
        let sb = Superblock {
            version: VERSION,
            seq,
            root: root_ext,
            root_crc: crc32fast::hash(&bytes),
            file_end: self.file_end,
        };
        self.write_at(&sb.to_bytes(), (seq % 2) * SLOT_BYTES)?;
        self.file.sync_data().map_err(|e| self.io(e))?;
        // 5. Durable: released space is reusable.
        self.seq = seq;
        self.root = root_ext;
        self.pending_free.clear();
        self.fresh.clear();
        saved.truncate(self.file_end);
        self.free = saved;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::ViewClass;
    use glam::DVec3;

    fn section() -> Section {
        Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap()
    }

    fn samples(n: usize, tag: u8) -> Vec<PackedSample> {
        (0..n)
            .map(|i| PackedSample {
                rgbe: [tag, i as u8, 0, 128],
                entry: [1, 2],
                exit: [3, 4],
                dist: i as u16,
            })
            .collect()
    }

    #[test]
    fn create_write_commit_reopen() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let mut h = HoloFile::create(
            &p,
            vec![section(), section()],
            [("k".into(), "v".into())].into(),
        )
        .unwrap();
        assert!(matches!(
            HoloFile::create(&p, vec![], BTreeMap::new()),
            Err(FileError::Exists { .. })
        ));
        h.append_beam(0, 5, &samples(3, 1)).unwrap();
        h.append_beam(0, 5, &samples(2, 2)).unwrap(); // in place at the end
        h.append_beam(1, 7, &samples(4, 3)).unwrap();
        h.append_beam(0, 5, &samples(1, 4)).unwrap(); // must move
        h.commit().unwrap();
        // Uncommitted writes are invisible after reopening.
        h.append_beam(1, 9, &samples(4, 5)).unwrap();
        drop(h);
        let h = HoloFile::open(&p).unwrap();
        assert_eq!(h.settings()["k"], "v");
        let mut got = Vec::new();
        h.read_beam(0, 5, &mut got).unwrap();
        let mut want = samples(3, 1);
        want.extend(samples(2, 2));
        want.extend(samples(1, 4));
        assert_eq!(got, want);
        assert_eq!(h.count(1, 7), 4);
        assert_eq!(h.count(1, 9), 0);
        assert!(matches!(
            h.read_beam(2, 0, &mut got),
            Err(FileError::NoSection { .. })
        ));
        assert!(matches!(
            h.read_beam(0, 1 << 20, &mut got),
            Err(FileError::NoBeam { .. })
        ));
    }

    #[test]
    fn free_space_is_saved_and_reused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let mut h = HoloFile::create(&p, vec![section()], BTreeMap::new()).unwrap();
        h.append_beam(0, 1, &samples(50, 1)).unwrap();
        h.append_beam(0, 2, &samples(50, 1)).unwrap();
        h.append_beam(0, 1, &samples(1, 1)).unwrap(); // beam 1 moves, leaving a hole
        h.commit().unwrap();
        h.commit().unwrap();
        let free = h.free_extents();
        assert!(free.iter().any(|e| e.len >= 150), "{free:?}");
        drop(h);
        let mut h = HoloFile::open_rw(&p).unwrap();
        assert_eq!(h.free_extents(), free, "the free list survives reopening");
        let end = h.file_end();
        h.append_beam(0, 3, &samples(10, 2)).unwrap();
        assert_eq!(h.file_end(), end, "the hole was reused");
    }
}
