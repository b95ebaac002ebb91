//! Opening a holodeck file and reading beams. Opening picks the valid superblock with the
//! highest sequence number, verifies the root block's and every directory chunk's crc32 and
//! that every beam extent lies inside the committed file; reading a beam verifies its crc32.
//! A strict open fails on the first damage, naming it; a tolerant open (for `check` and
//! salvage) records damage, drops what it makes unreadable, and goes on.

use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::os::unix::fs::FileExt;
use std::path::Path;

use super::disk::Disk;
use super::format::{
    self, CHUNK_BEAMS, ChunkLoc, DATA_START, DIR_ENTRY_BYTES, DirEntry, Extent, LayoutError, Root,
    SLOT_BYTES, SUPERBLOCK_BYTES, Superblock,
};
use super::free_list::FreeList;
use super::{Damage, FileError, HoloFile};
use crate::sample::{PackedSample, SAMPLE_BYTES};

impl HoloFile {
    /// Opens for reading.
    pub fn open(path: &Path) -> Result<Self, FileError> {
        Ok(Self::open_with(path, false, false)?.0)
    }

    /// Opens for reading and appending.
    pub fn open_rw(path: &Path) -> Result<Self, FileError> {
        Ok(Self::open_with(path, true, false)?.0)
    }

    /// Opens read-only, recording damage instead of failing where the rest is still usable.
    pub fn open_tolerant(path: &Path) -> Result<(Self, Vec<Damage>), FileError> {
        Self::open_with(path, false, true)
    }

    fn open_with(
        path: &Path,
        writable: bool,
        tolerant: bool,
    ) -> Result<(Self, Vec<Damage>), FileError> {
        let io = |source| FileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = OpenOptions::new()
            .read(true)
            .write(writable)
            .open(path)
            .map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let mut slots = Vec::new();
        let mut why = Vec::new();
        let mut any_magic = false;
        for slot in 0..2u64 {
            let start = slot * SLOT_BYTES;
            let mut buf = [0u8; SUPERBLOCK_BYTES];
            if len < start + SUPERBLOCK_BYTES as u64 {
                why.push(format!("file ends at byte {len}"));
                continue;
            }
            file.read_exact_at(&mut buf, start).map_err(io)?;
            any_magic |= &buf[..8] == format::MAGIC;
            match Superblock::parse(&buf) {
                Ok(sb) => slots.push(sb),
                Err(e) => why.push(e.to_string()),
            }
        }
        if slots.is_empty() {
            if !any_magic {
                return Err(FileError::NotHolodeck {
                    path: path.to_path_buf(),
                });
            }
            return Err(FileError::NoValidSuperblock {
                path: path.to_path_buf(),
                slot0: why[0].clone(),
                slot1: why.get(1).cloned().unwrap_or_default(),
            });
        }
        slots.sort_by_key(|s| std::cmp::Reverse(s.seq));
        let mut damage = Vec::new();
        let mut last_err = None;
        for sb in &slots {
            match Self::load_commit(path, &file, len, sb, writable, tolerant, &mut damage) {
                Ok(h) => return Ok((h, damage)),
                Err(e) if tolerant => {
                    damage.push(Damage {
                        what: format!("commit {} (superblock slot {})", sb.seq, sb.seq % 2),
                        offset: sb.root.offset,
                        detail: e.to_string(),
                    });
                    last_err = Some(e);
                }
                Err(e) => return Err(e),
            }
        }
        Err(last_err.expect("at least one superblock was tried"))
    }

    fn load_commit(
        path: &Path,
        file: &File,
        len: u64,
        sb: &Superblock,
        writable: bool,
        tolerant: bool,
        damage: &mut Vec<Damage>,
    ) -> Result<Self, FileError> {
        let root = read_root(path, file, len, sb, tolerant)?;
        let dirs = read_directory(
            path,
            file,
            (len, sb.file_end.min(len)),
            &root,
            tolerant,
            damage,
        )?;
        let mut free = FreeList::from_extents(&root.free);
        free.truncate(sb.file_end);
        let sections = root.sections;
        let io = |source| FileError::Io {
            path: path.to_path_buf(),
            source,
        };
        Ok(HoloFile {
            path: path.to_path_buf(),
            file: Disk::new(file.try_clone().map_err(io)?),
            writable,
            settings: root.settings,
            dirty: vec![BTreeSet::new(); sections.len()],
            sections,
            dirs,
            chunks: root.chunks,
            free,
            pending_free: Vec::new(),
            fresh: Default::default(),
            compact: false,
            file_end: sb.file_end,
            seq: sb.seq,
            root: sb.root,
        })
    }

    /// Reads a beam's raw records into `buf` (cleared first) and verifies its checksum.
    pub fn read_beam_bytes(
        &self,
        section: usize,
        beam: u32,
        buf: &mut Vec<u8>,
    ) -> Result<(), FileError> {
        let e = self.entry(section, beam)?;
        buf.clear();
        if e.count == 0 {
            return Ok(());
        }
        let n = e.extent().len as usize;
        buf.resize(n, 0);
        self.file
            .file()
            .read_exact_at(buf, e.offset)
            .map_err(|err| {
                if err.kind() == std::io::ErrorKind::UnexpectedEof {
                    FileError::Truncated {
                        path: self.path.clone(),
                        what: format!("beam {beam} of section {section}"),
                        start: e.offset,
                        end: e.offset + n as u64,
                        len: self.file.file().metadata().map_or(0, |m| m.len()),
                    }
                } else {
                    self.io(err)
                }
            })?;
        let computed = crc32fast::hash(buf);
        if computed != e.crc {
            buf.clear();
            return Err(FileError::Corrupt {
                path: self.path.clone(),
                what: format!("beam {beam} of section {section} ({} samples)", e.count),
                offset: e.offset,
                detail: LayoutError::Checksum {
                    stored: e.crc,
                    computed,
                }
                .to_string(),
            });
        }
        Ok(())
    }

    /// Reads a beam's samples, appending them to `out`.
    pub fn read_beam(
        &self,
        section: usize,
        beam: u32,
        out: &mut Vec<PackedSample>,
    ) -> Result<(), FileError> {
        let mut buf = Vec::new();
        self.read_beam_bytes(section, beam, &mut buf)?;
        PackedSample::read_all(&buf, out);
        debug_assert_eq!(buf.len() % SAMPLE_BYTES, 0);
        Ok(())
    }
}

/// `FileError::Corrupt` for `what` at `offset` of the file at `path`.
fn corrupt(path: &Path, what: String, offset: u64, detail: String) -> FileError {
    FileError::Corrupt {
        path: path.to_path_buf(),
        what,
        offset,
        detail,
    }
}

/// The root block of commit `sb` in `file` (`len` bytes long), checked: inside the data
/// area and the file, its crc32 as the superblock says, and parsed. A commit whose data
/// runs past the file's end is refused unless `tolerant`.
fn read_root(
    path: &Path,
    file: &File,
    len: u64,
    sb: &Superblock,
    tolerant: bool,
) -> Result<Root, FileError> {
    let root_what = format!("root block of commit {}", sb.seq);
    if sb.root.offset < DATA_START || sb.root.end() > sb.file_end {
        let detail = "lies outside the data area".into();
        return Err(corrupt(path, root_what, sb.root.offset, detail));
    }
    if sb.file_end > len && !tolerant {
        return Err(FileError::Truncated {
            path: path.to_path_buf(),
            what: format!("commit {} (its data ends at byte {})", sb.seq, sb.file_end),
            start: DATA_START,
            end: sb.file_end,
            len,
        });
    }
    if sb.root.end() > len {
        return Err(FileError::Truncated {
            path: path.to_path_buf(),
            what: root_what,
            start: sb.root.offset,
            end: sb.root.end(),
            len,
        });
    }
    let mut buf = vec![0u8; sb.root.len as usize];
    file.read_exact_at(&mut buf, sb.root.offset)
        .map_err(|source| FileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let computed = crc32fast::hash(&buf);
    if computed != sb.root_crc {
        let detail = LayoutError::Checksum {
            stored: sb.root_crc,
            computed,
        }
        .to_string();
        return Err(corrupt(path, root_what, sb.root.offset, detail));
    }
    Root::parse(&buf).map_err(|e| corrupt(path, root_what, sb.root.offset, e.to_string()))
}

/// Every section's beam directory from `root`'s chunks in `file` (`len` bytes long, the
/// commit's data ending at `data_end`). A chunk that does not read back, or an entry
/// pointing outside the data, fails the open, or with `tolerant` is recorded in `damage`
/// and left empty.
fn read_directory(
    path: &Path,
    file: &File,
    (len, data_end): (u64, u64),
    root: &Root,
    tolerant: bool,
    damage: &mut Vec<Damage>,
) -> Result<Vec<Vec<DirEntry>>, FileError> {
    let mut dirs = Vec::with_capacity(root.sections.len());
    for (si, (section, locs)) in root.sections.iter().zip(&root.chunks).enumerate() {
        let beams = section.beam_count();
        let mut dir = vec![DirEntry::default(); beams as usize];
        for (ci, loc) in locs.iter().enumerate() {
            let first = ci as u32 * CHUNK_BEAMS;
            let n = (beams - first).min(CHUNK_BEAMS) as usize;
            let entries = match read_chunk(file, loc, n, data_end, len) {
                Ok(Some(entries)) => entries,
                Ok(None) => continue,
                Err(detail) => {
                    let what = format!(
                        "directory chunk {ci} of section {si} (beams {first}..{})",
                        first as usize + n
                    );
                    let err = corrupt(path, what.clone(), loc.extent.offset, detail.clone());
                    let offset = loc.extent.offset;
                    record(
                        tolerant,
                        err,
                        damage,
                        Damage {
                            what,
                            offset,
                            detail,
                        },
                    )?;
                    continue;
                }
            };
            for (k, e) in entries.into_iter().enumerate() {
                let b = first as usize + k;
                let ext = e.extent();
                if e.count == 0 || (e.offset >= DATA_START && ext.end() <= data_end) {
                    dir[b] = e;
                    continue;
                }
                let err = if ext.end() > len {
                    FileError::Truncated {
                        path: path.to_path_buf(),
                        what: format!("beam {b} of section {si}"),
                        start: ext.offset,
                        end: ext.end(),
                        len,
                    }
                } else {
                    corrupt(
                        path,
                        format!("directory entry of beam {b} of section {si}"),
                        loc.extent.offset + (k * DIR_ENTRY_BYTES) as u64,
                        format!(
                            "points at bytes {}..{} outside the data area",
                            ext.offset,
                            ext.end()
                        ),
                    )
                };
                let found = Damage {
                    what: format!("beam {b} of section {si}"),
                    offset: ext.offset,
                    detail: err.to_string(),
                };
                record(tolerant, err, damage, found)?;
            }
        }
        dirs.push(dir);
    }
    Ok(dirs)
}

/// A strict open fails with `err`; a tolerant one records `found` and goes on.
fn record(
    tolerant: bool,
    err: FileError,
    damage: &mut Vec<Damage>,
    found: Damage,
) -> Result<(), FileError> {
    if !tolerant {
        return Err(err);
    }
    damage.push(found);
    Ok(())
}

/// Reads one directory chunk: `Ok(None)` for a never-written (all empty) chunk.
fn read_chunk(
    file: &File,
    loc: &ChunkLoc,
    n: usize,
    data_end: u64,
    len: u64,
) -> Result<Option<Vec<DirEntry>>, String> {
    if loc.extent.len == 0 {
        return Ok(None);
    }
    let ext: Extent = loc.extent;
    if ext.offset < DATA_START || ext.end() > data_end {
        return Err(format!(
            "lies at bytes {}..{}, outside the data area (file has {len} bytes)",
            ext.offset,
            ext.end()
        ));
    }
    let mut buf = vec![0u8; ext.len as usize];
    file.read_exact_at(&mut buf, ext.offset)
        .map_err(|e| e.to_string())?;
    let computed = crc32fast::hash(&buf);
    if computed != loc.crc {
        return Err(LayoutError::Checksum {
            stored: loc.crc,
            computed,
        }
        .to_string());
    }
    format::parse_chunk(&buf, n)
        .map(Some)
        .map_err(|e| e.to_string())
}
