//! The holodeck file's byte layout. Everything is little-endian and written field by field,
//! never as in-memory structs (the original wrote native-endian C structs).
//!
//! ```text
//! 0      superblock slot 0  ┐ two alternating commit records; the valid one with the
//! 4096   superblock slot 1  ┘ higher sequence number is the file's current state
//! 8192…  extents, allocated and freed at will:
//!          beam data      — the beam's samples, contiguous, 10 bytes each
//!          directory chunk — CHUNK_BEAMS entries (offset u64, count u32, crc32 u32)
//!          root block      — settings, section geometry, the chunk table with each
//!                            chunk's crc32, and the free-space list
//! ```
//!
//! Superblock (64 bytes at the start of its slot): magic `HOLODECK`, format version u32,
//! reserved u32, sequence u64, root offset u64, root length u64, file end u64 (every
//! referenced byte lies below it), root crc32 u32, crc32 of the preceding 52 bytes u32.
//!
//! Crash safety is copy-on-write: a commit writes new beam data, changed directory chunks
//! and a new root into space the previous commit does not reference, syncs, then writes
//! the superblock into the slot *not* holding the previous commit, and syncs again. A
//! crash at any instant leaves either the old or the new commit intact and checksummed.

use std::collections::BTreeMap;

use glam::DVec3;

use crate::section::{Section, ViewClass};

/// File magic.
pub const MAGIC: &[u8; 8] = b"HOLODECK";
/// Root block magic.
pub const ROOT_MAGIC: &[u8; 8] = b"HDKROOT1";
/// Format version written by this code.
pub const VERSION: u32 = 1;
/// Size of a superblock slot.
pub const SLOT_BYTES: u64 = 4096;
/// Bytes of a superblock that are used.
pub const SUPERBLOCK_BYTES: usize = 56;
/// First byte of allocatable space.
pub const DATA_START: u64 = 2 * SLOT_BYTES;
/// Directory entries per chunk.
pub const CHUNK_BEAMS: u32 = 4096;
/// Bytes per directory entry.
pub const DIR_ENTRY_BYTES: usize = 16;

/// A byte range of the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Extent {
    pub offset: u64,
    pub len: u64,
}

impl Extent {
    pub fn end(&self) -> u64 {
        self.offset + self.len
    }
}

/// One beam's directory entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DirEntry {
    pub offset: u64,
    pub count: u32,
    /// crc32 of the beam's `count × 10` bytes.
    pub crc: u32,
}

impl DirEntry {
    pub fn extent(&self) -> Extent {
        Extent {
            offset: self.offset,
            len: u64::from(self.count) * crate::sample::SAMPLE_BYTES as u64,
        }
    }
}

/// Where a directory chunk is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ChunkLoc {
    pub extent: Extent,
    pub crc: u32,
}

/// The commit record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Superblock {
    pub version: u32,
    pub seq: u64,
    pub root: Extent,
    pub root_crc: u32,
    pub file_end: u64,
}

/// Why a structure failed to parse (the caller names the structure and where it is).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayoutError {
    #[error("bad magic number")]
    BadMagic,
    #[error("unsupported format version {0} (this build reads version {VERSION})")]
    Version(u32),
    #[error("checksum mismatch (stored {stored:#010x}, computed {computed:#010x})")]
    Checksum { stored: u32, computed: u32 },
    #[error("ends early: needs {need} more bytes at byte {at}")]
    Short { at: usize, need: usize },
    #[error("{0}")]
    Invalid(String),
}

impl Superblock {
    pub fn to_bytes(&self) -> [u8; SUPERBLOCK_BYTES] {
        let mut w = Vec::with_capacity(SUPERBLOCK_BYTES);
        w.extend_from_slice(MAGIC);
        w.extend_from_slice(&self.version.to_le_bytes());
        w.extend_from_slice(&0u32.to_le_bytes());
        w.extend_from_slice(&self.seq.to_le_bytes());
        w.extend_from_slice(&self.root.offset.to_le_bytes());
        w.extend_from_slice(&self.root.len.to_le_bytes());
        w.extend_from_slice(&self.file_end.to_le_bytes());
        w.extend_from_slice(&self.root_crc.to_le_bytes());
        let crc = crc32fast::hash(&w);
        w.extend_from_slice(&crc.to_le_bytes());
        w.try_into().expect("superblock is 56 bytes")
    }

    pub fn parse(b: &[u8]) -> Result<Self, LayoutError> {
        let mut r = ByteReader::new(b);
        if r.bytes(8)? != MAGIC {
            return Err(LayoutError::BadMagic);
        }
        let version = r.u32()?;
        r.u32()?;
        let seq = r.u64()?;
        let root = Extent {
            offset: r.u64()?,
            len: r.u64()?,
        };
        let file_end = r.u64()?;
        let root_crc = r.u32()?;
        let computed = crc32fast::hash(&b[..SUPERBLOCK_BYTES - 4]);
        let stored = r.u32()?;
        if stored != computed {
            return Err(LayoutError::Checksum { stored, computed });
        }
        if version != VERSION {
            return Err(LayoutError::Version(version));
        }
        Ok(Self {
            version,
            seq,
            root,
            root_crc,
            file_end,
        })
    }
}

/// The root block's content.
#[derive(Clone, Debug, PartialEq)]
pub struct Root {
    pub settings: BTreeMap<String, String>,
    pub sections: Vec<Section>,
    pub chunks: Vec<Vec<ChunkLoc>>,
    pub free: Vec<Extent>,
}

impl Root {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Vec::new();
        w.extend_from_slice(ROOT_MAGIC);
        put_u32(&mut w, self.settings.len() as u32);
        for (k, v) in &self.settings {
            put_str(&mut w, k);
            put_str(&mut w, v);
        }
        put_u32(&mut w, self.sections.len() as u32);
        for (s, chunks) in self.sections.iter().zip(&self.chunks) {
            for v in [s.origin(), s.edges()[0], s.edges()[1], s.edges()[2]] {
                for c in v.to_array() {
                    w.extend_from_slice(&c.to_le_bytes());
                }
            }
            for g in s.grid() {
                put_u32(&mut w, g);
            }
            w.extend_from_slice(&[s.class().to_byte(), 0, 0, 0]);
            put_u32(&mut w, s.beam_count());
            put_u32(&mut w, chunks.len() as u32);
            for c in chunks {
                w.extend_from_slice(&c.extent.offset.to_le_bytes());
                put_u32(&mut w, c.extent.len as u32);
                put_u32(&mut w, c.crc);
            }
        }
        w.extend_from_slice(&(self.free.len() as u64).to_le_bytes());
        for e in &self.free {
            w.extend_from_slice(&e.offset.to_le_bytes());
            w.extend_from_slice(&e.len.to_le_bytes());
        }
        w
    }

    pub fn parse(b: &[u8]) -> Result<Self, LayoutError> {
        let mut r = ByteReader::new(b);
        if r.bytes(8)? != ROOT_MAGIC {
            return Err(LayoutError::BadMagic);
        }
        let n = r.count(8)?;
        let mut settings = BTreeMap::new();
        for _ in 0..n {
            let k = r.string()?;
            settings.insert(k, r.string()?);
        }
        let n = r.count(136)?;
        let mut sections = Vec::with_capacity(n);
        let mut chunks = Vec::with_capacity(n);
        for i in 0..n {
            let mut v = [DVec3::ZERO; 4];
            for x in &mut v {
                *x = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
            }
            let grid = [r.u32()?, r.u32()?, r.u32()?];
            let class_byte = r.bytes(4)?[0];
            let class = ViewClass::from_byte(class_byte).ok_or_else(|| {
                LayoutError::Invalid(format!("section {i}: unknown view class {class_byte}"))
            })?;
            let section = Section::new(v[0], [v[1], v[2], v[3]], grid, class)
                .map_err(|e| LayoutError::Invalid(format!("section {i}: {e}")))?;
            let beams = r.u32()?;
            if beams != section.beam_count() {
                return Err(LayoutError::Invalid(format!(
                    "section {i}: records {beams} beams but its grid {grid:?} has {}",
                    section.beam_count()
                )));
            }
            let nc = r.count(16)?;
            if nc as u64 != u64::from(beams).div_ceil(u64::from(CHUNK_BEAMS)) {
                return Err(LayoutError::Invalid(format!(
                    "section {i}: {nc} directory chunks for {beams} beams"
                )));
            }
            let mut locs = Vec::with_capacity(nc);
            for _ in 0..nc {
                let offset = r.u64()?;
                let len = u64::from(r.u32()?);
                locs.push(ChunkLoc {
                    extent: Extent { offset, len },
                    crc: r.u32()?,
                });
            }
            sections.push(section);
            chunks.push(locs);
        }
        let nf = r.u64()?;
        if nf > (b.len() / 16) as u64 {
            return Err(LayoutError::Invalid(format!(
                "free list of {nf} extents cannot fit"
            )));
        }
        let mut free = Vec::with_capacity(nf as usize);
        for _ in 0..nf {
            free.push(Extent {
                offset: r.u64()?,
                len: r.u64()?,
            });
        }
        Ok(Self {
            settings,
            sections,
            chunks,
            free,
        })
    }
}

/// Serialises directory entries (one chunk).
pub fn chunk_to_bytes(entries: &[DirEntry]) -> Vec<u8> {
    let mut w = Vec::with_capacity(entries.len() * DIR_ENTRY_BYTES);
    for e in entries {
        w.extend_from_slice(&e.offset.to_le_bytes());
        put_u32(&mut w, e.count);
        put_u32(&mut w, e.crc);
    }
    w
}

/// Parses a chunk of `n` entries.
pub fn parse_chunk(b: &[u8], n: usize) -> Result<Vec<DirEntry>, LayoutError> {
    if b.len() != n * DIR_ENTRY_BYTES {
        return Err(LayoutError::Invalid(format!(
            "{} bytes for {n} entries",
            b.len()
        )));
    }
    let mut r = ByteReader::new(b);
    (0..n)
        .map(|_| {
            Ok(DirEntry {
                offset: r.u64()?,
                count: r.u32()?,
                crc: r.u32()?,
            })
        })
        .collect()
}

fn put_u32(w: &mut Vec<u8>, v: u32) {
    w.extend_from_slice(&v.to_le_bytes());
}

fn put_str(w: &mut Vec<u8>, s: &str) {
    put_u32(w, s.len() as u32);
    w.extend_from_slice(s.as_bytes());
}

/// Bounds-checked little-endian reads.
struct ByteReader<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> ByteReader<'a> {
    fn new(b: &'a [u8]) -> Self {
        Self { b, at: 0 }
    }
    fn bytes(&mut self, n: usize) -> Result<&'a [u8], LayoutError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len());
        let end = end.ok_or(LayoutError::Short {
            at: self.at,
            need: n,
        })?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, LayoutError> {
        Ok(u32::from_le_bytes(
            self.bytes(4)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self) -> Result<u64, LayoutError> {
        Ok(u64::from_le_bytes(
            self.bytes(8)?.try_into().expect("8 bytes"),
        ))
    }
    fn f64(&mut self) -> Result<f64, LayoutError> {
        Ok(f64::from_le_bytes(
            self.bytes(8)?.try_into().expect("8 bytes"),
        ))
    }
    /// A count of items of at least `min_bytes` each, checked against the bytes left.
    fn count(&mut self, min_bytes: usize) -> Result<usize, LayoutError> {
        let n = self.u32()? as usize;
        if n.saturating_mul(min_bytes) > self.b.len() - self.at {
            return Err(LayoutError::Invalid(format!(
                "count {n} at byte {} exceeds the block",
                self.at - 4
            )));
        }
        Ok(n)
    }
    fn string(&mut self) -> Result<String, LayoutError> {
        let n = self.count(1)?;
        let at = self.at;
        String::from_utf8(self.bytes(n)?.to_vec())
            .map_err(|_| LayoutError::Invalid(format!("string at byte {at} is not UTF-8")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn superblock_round_trip_and_damage() {
        let sb = Superblock {
            version: VERSION,
            seq: 7,
            root: Extent {
                offset: 8192,
                len: 100,
            },
            root_crc: 0xdead_beef,
            file_end: 9000,
        };
        let b = sb.to_bytes();
        assert_eq!(&b[..8], MAGIC);
        assert_eq!(Superblock::parse(&b).unwrap(), sb);
        let mut bad = b;
        bad[20] ^= 1;
        assert!(matches!(
            Superblock::parse(&bad),
            Err(LayoutError::Checksum { .. })
        ));
        assert!(matches!(
            Superblock::parse(&b[..30]),
            Err(LayoutError::Short { .. })
        ));
        assert!(matches!(
            Superblock::parse(&[0; 56]),
            Err(LayoutError::BadMagic)
        ));
    }

    #[test]
    fn root_round_trip_and_truncation() {
        let s = Section::new(
            DVec3::ONE,
            [DVec3::X, DVec3::Y * 2.0, DVec3::Z],
            [2, 3, 1],
            ViewClass::Exterior,
        )
        .unwrap();
        let root = Root {
            settings: [("scene".to_string(), "cornell.gltf".to_string())].into(),
            sections: vec![s],
            chunks: vec![vec![ChunkLoc {
                extent: Extent { offset: 1, len: 2 },
                crc: 3,
            }]],
            free: vec![Extent {
                offset: 10,
                len: 20,
            }],
        };
        let b = root.to_bytes();
        assert_eq!(Root::parse(&b).unwrap(), root);
        for cut in 0..b.len() {
            assert!(Root::parse(&b[..cut]).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn chunk_round_trip() {
        let e = vec![
            DirEntry {
                offset: 1 << 40,
                count: 5,
                crc: 9,
            },
            DirEntry::default(),
        ];
        assert_eq!(parse_chunk(&chunk_to_bytes(&e), 2).unwrap(), e);
        assert!(parse_chunk(&chunk_to_bytes(&e), 3).is_err());
    }
}
