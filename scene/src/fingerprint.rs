//! A scene's identity: a fingerprint of everything its light depends on, so a light field
//! or a holodeck made for one scene is never used with another (a file name says nothing
//! of the daylight it was loaded with); and the files a command keeps for itself, set
//! aside by it when the scene changes.

use std::path::{Path, PathBuf};

use crate::Scene;

impl Scene {
    /// A fingerprint of everything the scene's light depends on: geometry, materials,
    /// lights, daylight (FNV-1a, 64 bits).
    pub fn fingerprint(&self) -> u64 {
        let scene = self;
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for b in bytes {
                h ^= u64::from(*b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for t in 0..scene.triangle_count() as u32 {
            for p in scene.triangle(t) {
                for c in p.to_array() {
                    eat(&c.to_le_bytes());
                }
            }
            eat(&scene.triangle_shading(t).material.to_le_bytes());
        }
        // The daylight's sun and sky alone, in the words of a `Daylight { sun, sky }`: its
        // photometry changes units, not radiance, so no bake depends on it.
        let d = &scene.daylight;
        eat(format!(
            "{:?}{:?}Daylight {{ sun: {:?}, sky: {:?} }}",
            scene.materials, scene.lights, d.sun, d.sky
        )
        .as_bytes());
        for t in &scene.textures {
            eat(t.name.as_bytes());
        }
        h
    }
}

/// Where a file kept for the scene with fingerprint `fingerprint` is set aside beside
/// `path`: `NAME.<fingerprint>.EXT`.
pub fn set_aside_path(path: &Path, fingerprint: u64) -> PathBuf {
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned());
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let name = match ext {
        Some(ext) => format!("{stem}.{fingerprint:016x}.{ext}"),
        None => format!("{stem}.{fingerprint:016x}"),
    };
    path.with_file_name(name)
}

/// A file a command keeps for itself (a default bake, `sim`'s holodeck), made for the
/// scene with fingerprint `was`, when the scene is now `now` (its daylight, materials or
/// geometry changed): `path` is set aside ([`set_aside_path`]), not removed — the hours of
/// work in it come back when the scene does — and one set aside earlier for `now` is put
/// in its place.
pub fn set_aside(path: &Path, was: u64, now: u64) -> std::io::Result<SetAside> {
    let to = set_aside_path(path, was);
    std::fs::rename(path, &to)?;
    let kept = set_aside_path(path, now);
    let back = kept.exists();
    if back {
        std::fs::rename(&kept, path)?;
    }
    Ok(SetAside { to, back })
}

/// What [`set_aside`] did, as a command tells it.
pub struct SetAside {
    /// Where the file went.
    pub to: PathBuf,
    /// Whether one set aside for the scene as it is now was put back in its place.
    pub back: bool,
}

impl std::fmt::Display for SetAside {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "set aside as {}", self.to.display())?;
        if self.back {
            write!(
                f,
                "; the one set aside for this version is back in its place"
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Setting a file aside for one scene and back again loses nothing.
    #[test]
    fn files_set_aside_come_back_with_their_scene() {
        let dir = std::env::temp_dir().join(format!("holocave-set-aside-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("room.vlf");
        std::fs::write(&path, "made for a").unwrap();
        assert_eq!(
            set_aside_path(&path, 0xa),
            dir.join("room.000000000000000a.vlf")
        );
        // The scene changed from a to b: a's file aside, nothing for b yet.
        assert!(!set_aside(&path, 0xa, 0xb).unwrap().back);
        assert!(!path.exists());
        std::fs::write(&path, "made for b").unwrap();
        // Back to a: b's file aside, a's back in place.
        assert!(set_aside(&path, 0xb, 0xa).unwrap().back);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "made for a");
        let b = std::fs::read_to_string(set_aside_path(&path, 0xb)).unwrap();
        assert_eq!(b, "made for b");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
