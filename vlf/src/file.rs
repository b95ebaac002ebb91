//! The `.vlf` file, with the holodeck file's conventions: little-endian, a magic number
//! and a version, then checksummed chunks (tag, length, CRC-32, payload). It records the
//! fingerprint of the scene it was baked for and is written to a temporary file, synced
//! and renamed, so a file on disk is always a whole bake state. A bake saves it after
//! every bounce; a killed bake resumes from it.
//!
//! Chunks: `META` (scene, settings — the glossy threshold and tile bins among them —,
//! element count, tile entry count, bounces, residuals), `IRRA` (the irradiance of every
//! element, 3 × f32), `LAST` (the radiance of the last bounce, what a resumed bake
//! propagates next), `TILE` (the glossy tiles' radiance, `tiles × k²` bins of 3 × f32;
//! empty without glossy surfaces), `TLST` (the tiles' last bounce), `DIRE` (the part of
//! `IRRA` that came by next-event estimation: what a view computing the direct light per
//! pixel leaves out), `TDIR` (the same part of `TILE`), `SKYE` (the part of `IRRA` that
//! the sky sent along the lines at the first bounce: what a view taking the sky per pixel
//! as well leaves out), `TSKY` (the same part of `TILE`) and `CAUS` (the part of `IRRA`
//! that emitters sent through mirrors and glass at the first bounce, their caustics: what
//! a view taking caustics per pixel leaves out; empty without mirrors or glass).
//!
//! Version 2 added the glossy tiles (the threshold and bins in `META`, `TILE`, `TLST`);
//! version 3 the direct parts (`DIRE`, `TDIR`); version 4 the sky's (`SKYE`, `TSKY`), and
//! no tile on a glossy element smaller than a line's reach (a new layout); version 5 the
//! tiles' bins averaged over each bin (same layout, other values); version 6 no tile on a
//! glossy element smaller than four times a line's reach, pooled instead (a new layout);
//! version 7 the caustics' part (`CAUS`); version 8 the diffuse elements' light sent by
//! their directional albedo (`exitance`; the same chunks, other values); version 9 the
//! albedo of elements drawn diffuse sampled from their BSDF (the same chunks, other
//! values); version 10 the tiles' Lambertian base taken at each arrival's own angle;
//! version 11 a widened lobe's energy the surface's (the same chunks, other values).
//! An older file is refused with the version it has (bake it again): read as this
//! version it would draw its direct light twice (1, 2), have another tile layout (3, 5),
//! or its glossy surfaces 5 % too dark (4), or draw its caustics twice (6), or its
//! corners of rough glossy paint a quarter too bright (7), or its small glossy elements
//! (glazed cups, plastic chairs) with a fraction of their albedo (8), or its glossy
//! floors a few per cent dark where light comes in low (9, 10).

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

use holocave_scene::Scene;

use crate::bake::{Settings, State};

const MAGIC: &[u8; 8] = b"HOLOVLF\0";
const VERSION: u32 = 11;
const HEADER: usize = 16;
const CHUNK_HEADER: usize = 16;
/// Chunks in a file: META, IRRA, LAST, TILE, TLST, DIRE, TDIR, SKYE, TSKY, CAUS.
const CHUNKS: u32 = 10;

#[derive(Debug, thiserror::Error)]
pub enum VlfError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a VLF file (bad magic number)")]
    NotVlf { path: PathBuf },
    #[error("{path}: VLF file version {found}, this build reads version {VERSION} (bake it again)")]
    Version { path: PathBuf, found: u32 },
    #[error("{path}: truncated in chunk {chunk} at byte {offset}")]
    Truncated {
        path: PathBuf,
        chunk: String,
        offset: u64,
    },
    #[error("{path}: chunk {chunk} at byte {offset} is damaged (checksum mismatch)")]
    Checksum {
        path: PathBuf,
        chunk: String,
        offset: u64,
    },
    #[error("{path}: chunk {chunk} at byte {offset}: {what}")]
    Malformed {
        path: PathBuf,
        chunk: String,
        offset: u64,
        what: String,
    },
    #[error(
        "{path}: baked for scene {baked_for} (fingerprint {baked:016x}), not for this scene {scene} (fingerprint {wanted:016x}): the fingerprint covers the geometry, materials, lights and daylight; bake it again for this one"
    )]
    WrongScene {
        path: PathBuf,
        baked_for: String,
        baked: u64,
        scene: String,
        wanted: u64,
    },
}

/// A baked (or partly baked) light field as stored.
#[derive(Clone, Debug, PartialEq)]
pub struct VlfFile {
    pub scene: String,
    pub fingerprint: u64,
    pub settings: Settings,
    /// The element size used (the settings' or the default one).
    pub element_size: f32,
    pub state: State,
}

fn put_f32s(out: &mut Vec<u8>, v: &[[f32; 3]]) {
    out.reserve(v.len() * 12);
    for x in v.iter().flatten() {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

impl VlfFile {
    /// The file of bake state `state` of `scene` with `settings` (fingerprinting the scene
    /// and laying out its elements: a bake that saves every bounce keeps both instead).
    pub fn of(scene: &Scene, settings: Settings, state: State) -> VlfFile {
        VlfFile {
            scene: scene.name.clone(),
            fingerprint: scene.fingerprint(),
            settings,
            element_size: crate::bake::layout(scene, &settings).element_size,
            state,
        }
    }

    fn meta(&self) -> Vec<u8> {
        let mut m = Vec::new();
        m.extend_from_slice(&self.fingerprint.to_le_bytes());
        m.extend_from_slice(&(self.scene.len() as u32).to_le_bytes());
        m.extend_from_slice(self.scene.as_bytes());
        let s = &self.settings;
        m.extend_from_slice(&(s.directions as u32).to_le_bytes());
        m.extend_from_slice(&s.resolution.to_le_bytes());
        m.extend_from_slice(&s.element_size.unwrap_or(0.0).to_le_bytes());
        m.extend_from_slice(&self.element_size.to_le_bytes());
        m.extend_from_slice(&s.direct_samples.to_le_bytes());
        m.extend_from_slice(&s.tolerance.to_le_bytes());
        m.extend_from_slice(&s.max_bounces.to_le_bytes());
        m.extend_from_slice(&s.glossy_alpha.to_le_bytes());
        m.extend_from_slice(&s.tile_bins.to_le_bytes());
        let st = &self.state;
        m.extend_from_slice(&(st.irradiance.len() as u64).to_le_bytes());
        m.extend_from_slice(&(st.tiles.len() as u64).to_le_bytes());
        m.extend_from_slice(&st.bounces.to_le_bytes());
        m.push(u8::from(st.converged));
        m.extend_from_slice(&st.arrived.to_le_bytes());
        m.extend_from_slice(&(st.residuals.len() as u32).to_le_bytes());
        for r in &st.residuals {
            m.extend_from_slice(&r.to_le_bytes());
        }
        m
    }

    /// Writes the file: a temporary file beside `path`, synced, then renamed over it.
    pub fn write(&self, path: &Path) -> Result<(), VlfError> {
        let io = |source| VlfError::Io {
            path: path.into(),
            source,
        };
        let mut bytes = Vec::new();
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&VERSION.to_le_bytes());
        bytes.extend_from_slice(&CHUNKS.to_le_bytes());
        let mut irra = Vec::new();
        put_f32s(&mut irra, &self.state.irradiance);
        let mut last = Vec::new();
        put_f32s(&mut last, &self.state.last);
        let mut tile = Vec::new();
        put_f32s(&mut tile, &self.state.tiles);
        let mut tlst = Vec::new();
        put_f32s(&mut tlst, &self.state.tiles_last);
        let mut dire = Vec::new();
        put_f32s(&mut dire, &self.state.direct);
        let mut tdir = Vec::new();
        put_f32s(&mut tdir, &self.state.tiles_direct);
        let mut skye = Vec::new();
        put_f32s(&mut skye, &self.state.sky);
        let mut tsky = Vec::new();
        put_f32s(&mut tsky, &self.state.tiles_sky);
        let mut caus = Vec::new();
        put_f32s(&mut caus, &self.state.caustics);
        for (tag, payload) in [
            (b"META", self.meta()),
            (b"IRRA", irra),
            (b"LAST", last),
            (b"TILE", tile),
            (b"TLST", tlst),
            (b"DIRE", dire),
            (b"TDIR", tdir),
            (b"SKYE", skye),
            (b"TSKY", tsky),
            (b"CAUS", caus),
        ] {
            bytes.extend_from_slice(tag);
            bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
            bytes.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
            bytes.extend_from_slice(&payload);
        }
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        let mut f = File::create(&tmp).map_err(io)?;
        f.write_all(&bytes).map_err(io)?;
        f.sync_all().map_err(io)?;
        drop(f);
        fs::rename(&tmp, path).map_err(io)?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
            && let Ok(d) = File::open(dir)
        {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// Reads and checks a file (magic, version, every chunk's length and checksum, and
    /// that the arrays have the element count the metadata states).
    pub fn read(path: &Path) -> Result<VlfFile, VlfError> {
        let bytes = fs::read(path).map_err(|source| VlfError::Io {
            path: path.into(),
            source,
        })?;
        Reader {
            path,
            bytes: &bytes,
        }
        .file()
    }

    /// Reads a file and checks that it was baked for `scene`.
    pub fn read_for(path: &Path, scene: &Scene) -> Result<VlfFile, VlfError> {
        let f = VlfFile::read(path)?;
        let wanted = scene.fingerprint();
        if f.fingerprint != wanted {
            return Err(VlfError::WrongScene {
                path: path.into(),
                baked_for: f.scene,
                baked: f.fingerprint,
                scene: scene.name.clone(),
                wanted,
            });
        }
        Ok(f)
    }
}

struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
}

/// Reads fields from one chunk's payload, naming the chunk and offset on failure.
struct Fields<'a> {
    path: &'a Path,
    chunk: &'static str,
    data: &'a [u8],
    at: usize,
    base: usize,
}

impl Fields<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], VlfError> {
        if self.data.len() - self.at < n {
            return Err(VlfError::Malformed {
                path: self.path.into(),
                chunk: self.chunk.into(),
                offset: (self.base + self.at) as u64,
                what: format!("{n} more bytes expected"),
            });
        }
        self.at += n;
        Ok(&self.data[self.at - n..self.at])
    }
    fn u32(&mut self) -> Result<u32, VlfError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }
    fn u64(&mut self) -> Result<u64, VlfError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or_default(),
        ))
    }
    fn f32(&mut self) -> Result<f32, VlfError> {
        Ok(f32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }
    fn f64(&mut self) -> Result<f64, VlfError> {
        Ok(f64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or_default(),
        ))
    }
}

impl Reader<'_> {
    fn chunk(&self, at: &mut usize, tag: &'static str) -> Result<(&[u8], usize), VlfError> {
        let truncated = |offset: usize| VlfError::Truncated {
            path: self.path.into(),
            chunk: tag.into(),
            offset: offset as u64,
        };
        let start = *at;
        let head = self
            .bytes
            .get(start..start + CHUNK_HEADER)
            .ok_or(truncated(start))?;
        if &head[..4] != tag.as_bytes() {
            return Err(VlfError::Malformed {
                path: self.path.into(),
                chunk: tag.into(),
                offset: start as u64,
                what: format!(
                    "expected chunk {tag}, found {:?}",
                    String::from_utf8_lossy(&head[..4])
                ),
            });
        }
        let len = u64::from_le_bytes(head[4..12].try_into().unwrap_or_default());
        let crc = u32::from_le_bytes(head[12..16].try_into().unwrap_or_default());
        let body = start + CHUNK_HEADER;
        let end = usize::try_from(len).ok().and_then(|l| body.checked_add(l));
        let payload = end
            .and_then(|end| self.bytes.get(body..end))
            .ok_or(truncated(self.bytes.len()))?;
        if crc32fast::hash(payload) != crc {
            return Err(VlfError::Checksum {
                path: self.path.into(),
                chunk: tag.into(),
                offset: start as u64,
            });
        }
        *at = body + payload.len();
        Ok((payload, body))
    }

    fn array(
        &self,
        at: &mut usize,
        tag: &'static str,
        count: u64,
    ) -> Result<Vec<[f32; 3]>, VlfError> {
        self.array_of(at, tag, &[count])
    }

    /// An array of any of `counts` values (the first named in an error).
    fn array_of(
        &self,
        at: &mut usize,
        tag: &'static str,
        counts: &[u64],
    ) -> Result<Vec<[f32; 3]>, VlfError> {
        let (p, base) = self.chunk(at, tag)?;
        let count = counts[0];
        if !counts.iter().any(|&c| p.len() as u64 == c * 12) {
            return Err(VlfError::Malformed {
                path: self.path.into(),
                chunk: tag.into(),
                offset: base as u64,
                what: format!("{} bytes for {count} values (12 each)", p.len()),
            });
        }
        Ok(p.chunks_exact(12)
            .map(|c| {
                let f = |i: usize| {
                    f32::from_le_bytes(c[i * 4..i * 4 + 4].try_into().unwrap_or_default())
                };
                [f(0), f(1), f(2)]
            })
            .collect())
    }

    /// Checks the header: the magic number, this version, and its number of chunks.
    fn header(&self) -> Result<(), VlfError> {
        let path = self.path;
        if self.bytes.len() < HEADER || &self.bytes[..8] != MAGIC {
            // Cut inside the magic number or inside the version and chunk count after it.
            let cut_header = MAGIC.starts_with(self.bytes) || self.bytes.starts_with(MAGIC);
            if self.bytes.len() < HEADER && cut_header {
                return Err(VlfError::Truncated {
                    path: path.into(),
                    chunk: "header".into(),
                    offset: self.bytes.len() as u64,
                });
            }
            return Err(VlfError::NotVlf { path: path.into() });
        }
        let version = u32::from_le_bytes(self.bytes[8..12].try_into().unwrap_or_default());
        if version != VERSION {
            return Err(VlfError::Version {
                path: path.into(),
                found: version,
            });
        }
        let chunks = u32::from_le_bytes(self.bytes[12..16].try_into().unwrap_or_default());
        if chunks != CHUNKS {
            return Err(VlfError::Malformed {
                path: path.into(),
                chunk: "header".into(),
                offset: 12,
                what: format!("{chunks} chunks, version {VERSION} has {CHUNKS}"),
            });
        }
        Ok(())
    }

    fn file(&self) -> Result<VlfFile, VlfError> {
        let path = self.path;
        self.header()?;
        let mut at = HEADER;
        let (meta, base) = self.chunk(&mut at, "META")?;
        let mut m = Fields {
            path,
            chunk: "META",
            data: meta,
            at: 0,
            base,
        };
        let fingerprint = m.u64()?;
        let name_len = m.u32()? as usize;
        let scene = String::from_utf8_lossy(m.take(name_len)?).into_owned();
        let directions = m.u32()? as usize;
        let resolution = m.u32()?;
        let size = m.f32()?;
        let element_size = m.f32()?;
        let direct_samples = m.u32()?;
        let tolerance = m.f64()?;
        let max_bounces = m.u32()?;
        let glossy_alpha = m.f32()?;
        let tile_bins = m.u32()?;
        let count = m.u64()?;
        let tile_count = m.u64()?;
        let bounces = m.u32()?;
        let converged = m.take(1)?[0] != 0;
        let arrived = m.f64()?;
        let n = m.u32()? as usize;
        let residuals = (0..n).map(|_| m.f64()).collect::<Result<Vec<_>, _>>()?;
        let irradiance = self.array(&mut at, "IRRA", count)?;
        let last = self.array(&mut at, "LAST", count)?;
        let tiles = self.array(&mut at, "TILE", tile_count)?;
        let tiles_last = self.array(&mut at, "TLST", tile_count)?;
        let direct = self.array(&mut at, "DIRE", count)?;
        let tiles_direct = self.array(&mut at, "TDIR", tile_count)?;
        let sky = self.array(&mut at, "SKYE", count)?;
        let tiles_sky = self.array(&mut at, "TSKY", tile_count)?;
        // Empty without mirrors or glass.
        let caustics = self.array_of(&mut at, "CAUS", &[count, 0])?;
        if at != self.bytes.len() {
            return Err(VlfError::Malformed {
                path: path.into(),
                chunk: "CAUS".into(),
                offset: at as u64,
                what: format!("{} bytes after the last chunk", self.bytes.len() - at),
            });
        }
        Ok(VlfFile {
            scene,
            fingerprint,
            settings: Settings {
                directions,
                resolution,
                element_size: (size > 0.0).then_some(size),
                direct_samples,
                tolerance,
                max_bounces,
                glossy_alpha,
                tile_bins,
            },
            element_size,
            state: State {
                bounces,
                irradiance,
                last,
                tiles,
                tiles_last,
                direct,
                tiles_direct,
                sky,
                tiles_sky,
                caustics,
                arrived,
                residuals,
                converged,
            },
        })
    }
}
