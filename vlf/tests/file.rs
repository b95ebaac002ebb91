//! The `.vlf` file: a written bake reads back equal; a truncated, damaged or wrong-scene
//! file is an error of the matching kind that names the file (and the chunk and offset
//! where there is one), never a panic and never invented data.

use crate::common;

use std::path::Path;

use glam::Vec3;
use holocave_scene::Scene;
use holocave_vlf::{Settings, VlfError, VlfFile, layout};

fn settings() -> Settings {
    common::small_settings()
}

fn furnace(name: &str, rho: f32) -> Scene {
    common::closed_box(name, 1.0, common::lambert("glowing", rho, Vec3::ONE))
}

fn baked(scene: &Scene) -> VlfFile {
    let settings = settings();
    let (state, _) = common::bake_quiet(scene, &settings);
    VlfFile::of(scene, settings, state)
}

/// The chunks of a file as written: (tag, offset of its header, payload length).
fn chunks(bytes: &[u8]) -> Vec<(String, usize, usize)> {
    let mut at = 16;
    let mut out = Vec::new();
    while at < bytes.len() {
        let tag = String::from_utf8_lossy(&bytes[at..at + 4]).into_owned();
        let len = u64::from_le_bytes(bytes[at + 4..at + 12].try_into().unwrap()) as usize;
        out.push((tag, at, len));
        at += 16 + len;
    }
    assert_eq!(at, bytes.len());
    out
}

fn read_bytes(
    dir: &Path,
    name: &str,
    bytes: &[u8],
) -> (std::path::PathBuf, Result<VlfFile, VlfError>) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let r = VlfFile::read(&path);
    (path, r)
}

/// The error's message names the file.
fn names_file(e: &VlfError, path: &Path) {
    let m = e.to_string();
    assert!(
        m.contains(&path.display().to_string()),
        "{m:?} does not name {}",
        path.display()
    );
}

#[test]
fn a_bake_reads_back_equal() {
    let dir = tempfile::tempdir().unwrap();
    let scene = furnace("box", 0.5);
    let f = baked(&scene);
    assert!(f.state.converged && f.state.bounces > 2);
    let path = dir.path().join("box.vlf");
    f.write(&path).unwrap();
    // Written through a temporary file that is renamed away.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("box.vlf")]);
    let back = VlfFile::read(&path).unwrap();
    assert_eq!(back, f);
    common::assert_same_bits(&back.state, &f.state, "read back");
    assert_eq!(VlfFile::read_for(&path, &scene).unwrap(), f);

    // Written again over an existing file, a different state replaces it whole.
    let mut g = f.clone();
    g.state.bounces = 1;
    g.state.residuals.truncate(2);
    g.state.converged = false;
    g.write(&path).unwrap();
    assert_eq!(VlfFile::read(&path).unwrap(), g);

    // A file that is not there, and a directory that is not there.
    let missing = dir.path().join("missing.vlf");
    let e = VlfFile::read(&missing).unwrap_err();
    assert!(matches!(e, VlfError::Io { .. }), "{e:?}");
    names_file(&e, &missing);
    let nowhere = dir.path().join("no/such/dir/box.vlf");
    let e = f.write(&nowhere).unwrap_err();
    assert!(matches!(e, VlfError::Io { .. }), "{e:?}");
    names_file(&e, &nowhere);
}

#[test]
fn a_truncated_file_names_the_chunk_and_offset() {
    let dir = tempfile::tempdir().unwrap();
    let f = baked(&furnace("box", 0.5));
    let path = dir.path().join("whole.vlf");
    f.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let chunks = chunks(&bytes);
    assert_eq!(
        chunks.iter().map(|c| c.0.as_str()).collect::<Vec<_>>(),
        [
            "META", "IRRA", "LAST", "TILE", "TLST", "DIRE", "TDIR", "SKYE", "TSKY", "CAUS"
        ]
    );
    // Cuts in the header (in the magic number, in the version and count after it), and in
    // each chunk's header, at its payload's start, in its payload and at its last byte.
    let mut cuts = vec![(0, "header"), (5, "header"), (8, "header"), (12, "header")];
    for (tag, at, len) in &chunks {
        // (An empty chunk, the tiles of a scene without glossy surfaces, only in its header.)
        let inside = if *len > 0 {
            vec![at + 16, at + 16 + len / 2, at + 16 + len - 1]
        } else {
            vec![at + 15]
        };
        for cut in [*at, at + 7].into_iter().chain(inside) {
            cuts.push((cut, tag.as_str()));
        }
    }
    for (cut, chunk) in cuts {
        let (p, r) = read_bytes(dir.path(), &format!("cut{cut}.vlf"), &bytes[..cut]);
        let e = r.expect_err(&format!("cut at {cut}"));
        names_file(&e, &p);
        let VlfError::Truncated {
            chunk: got, offset, ..
        } = &e
        else {
            panic!("cut at {cut}: {e:?}");
        };
        assert_eq!(got, chunk, "cut at {cut}: {e}");
        // Where the chunk's header is missing the offset is the chunk's start; where its
        // payload is, the end of what is there.
        let start = chunks.iter().find(|c| c.0 == chunk).map_or(0, |c| c.1);
        let expect = if chunk == "header" || cut >= start + 16 {
            cut
        } else {
            start
        };
        assert_eq!(*offset, expect as u64, "cut at {cut}: {e}");
        assert!(e.to_string().contains(chunk) && e.to_string().contains(&expect.to_string()));
    }
}

#[test]
fn a_damaged_byte_names_the_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let f = baked(&furnace("box", 0.5));
    let path = dir.path().join("whole.vlf");
    f.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let flip = |at: usize| {
        let mut b = bytes.clone();
        b[at] ^= 0x10;
        read_bytes(dir.path(), &format!("flip{at}.vlf"), &b)
    };

    header_damage_is_named(dir.path(), &bytes, &flip);

    // The chunk count.
    let (p, r) = flip(12);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Malformed { chunk, offset: 12, .. } if chunk == "header"),
        "{e:?}"
    );
    // Bytes after the last chunk (a file appended to, or two writes run together).
    let mut longer = bytes.clone();
    longer.extend_from_slice(b"more");
    let (p, r) = read_bytes(dir.path(), "longer.vlf", &longer);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Malformed { chunk, offset, .. } if chunk == "CAUS" && *offset == bytes.len() as u64),
        "{e:?}"
    );

    for (tag, at, len) in chunks(&bytes) {
        chunk_damage_is_named(&tag, at, len, &flip);
    }
}

/// A file with byte `at` flipped, written and read back.
type Flip<'a> = dyn Fn(usize) -> (std::path::PathBuf, Result<VlfFile, VlfError>) + 'a;

/// The magic number and the version of `bytes` damaged (`flip`), and every earlier
/// version (written in `dir`): each refused, naming the file.
fn header_damage_is_named(dir: &Path, bytes: &[u8], flip: &Flip) {
    // The magic number and the version.
    for at in [0, 7] {
        let (p, r) = flip(at);
        let e = r.unwrap_err();
        assert!(matches!(e, VlfError::NotVlf { .. }), "byte {at}: {e:?}");
        names_file(&e, &p);
    }
    let (p, r) = flip(8);
    let e = r.unwrap_err();
    let damaged = u32::from(bytes[8] ^ 0x10);
    assert!(
        matches!(e, VlfError::Version { found, .. } if found == damaged),
        "{e:?}"
    );
    names_file(&e, &p);
    // A file of every earlier version (before the glossy tiles, before the direct part
    // was kept apart, another tile layout, ... : `vlf/src/file.rs` says what each would
    // draw wrong) is refused, saying to bake it again.
    let current = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    assert!(current > 1, "version {current}");
    for version in 1..current {
        let mut old = bytes.to_vec();
        old[8..12].copy_from_slice(&version.to_le_bytes());
        let (p, r) = read_bytes(dir, "old.vlf", &old);
        let e = r.unwrap_err();
        assert!(
            matches!(e, VlfError::Version { found, .. } if found == version),
            "{e:?}"
        );
        assert!(e.to_string().contains("bake it again"), "{e}");
        names_file(&e, &p);
    }
}

/// Chunk `tag` (at byte `at`, `len` bytes of payload) damaged by `flip`: in its payload or
/// checksum, its tag, and its length's high and low bytes, each named.
fn chunk_damage_is_named(tag: &str, at: usize, len: usize, flip: &Flip) {
    // Anywhere in the payload, or in the checksum itself: a checksum mismatch at the
    // chunk's start.
    let payload = if len > 0 {
        vec![at + 16, at + 16 + len / 2, at + 16 + len - 1]
    } else {
        vec![]
    };
    for b in std::iter::once(at + 12).chain(payload) {
        let (p, r) = flip(b);
        let e = r.unwrap_err();
        names_file(&e, &p);
        match &e {
            VlfError::Checksum { chunk, offset, .. } => {
                assert_eq!((chunk.as_str(), *offset), (tag, at as u64), "byte {b}");
                assert!(e.to_string().contains(&format!("chunk {tag} at byte {at}")));
            }
            _ => panic!("byte {b} of {tag}: {e:?}"),
        }
    }
    // The tag: not the chunk expected there.
    let (p, r) = flip(at);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Malformed { chunk, offset, .. } if *chunk == tag && *offset == at as u64),
        "tag of {tag}: {e:?}"
    );
    // The length's high byte: the payload would run past the end of the file.
    let (p, r) = flip(at + 11);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Truncated { chunk, .. } if *chunk == tag),
        "length of {tag}: {e:?}"
    );
    // The length's low byte, shorter: the chunk's checksum (or, for the last chunk,
    // the checksum too: the payload read is not the one summed).
    let (p, r) = flip(at + 4);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Checksum { chunk, .. } | VlfError::Truncated { chunk, .. } if *chunk == tag),
        "length of {tag}: {e:?}"
    );
}

#[test]
fn arrays_that_do_not_match_the_element_count_are_refused() {
    // A chunk whose checksum is right but whose length disagrees with the element count
    // in META: the reader must not make up or drop elements.
    let dir = tempfile::tempdir().unwrap();
    let f = baked(&furnace("box", 0.5));
    let path = dir.path().join("whole.vlf");
    f.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let chunks = chunks(&bytes);
    let (_, irra, len) = chunks[1].clone();
    let mut b = bytes[..irra].to_vec();
    let payload = &bytes[irra + 16..irra + 16 + len - 12];
    b.extend_from_slice(b"IRRA");
    b.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    b.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
    b.extend_from_slice(payload);
    b.extend_from_slice(&bytes[irra + 16 + len..]);
    let (p, r) = read_bytes(dir.path(), "short.vlf", &b);
    let e = r.unwrap_err();
    names_file(&e, &p);
    assert!(
        matches!(&e, VlfError::Malformed { chunk, offset, .. } if chunk == "IRRA" && *offset == (irra + 16) as u64),
        "{e:?}"
    );
}

#[test]
fn a_file_baked_for_another_scene_is_refused_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let scene = furnace("grey box", 0.5);
    let path = dir.path().join("grey.vlf");
    baked(&scene).write(&path).unwrap();
    // The same geometry with another albedo: another scene for the light field.
    let other = furnace("pale box", 0.6);
    assert_ne!(scene.fingerprint(), other.fingerprint());
    let e = VlfFile::read_for(&path, &other).unwrap_err();
    names_file(&e, &path);
    let VlfError::WrongScene {
        baked_for,
        scene: s,
        baked,
        wanted,
        ..
    } = &e
    else {
        panic!("{e:?}");
    };
    assert_eq!((baked_for.as_str(), s.as_str()), ("grey box", "pale box"));
    assert_eq!(
        (*baked, *wanted),
        (scene.fingerprint(), other.fingerprint())
    );
    let m = e.to_string();
    assert!(m.contains("grey box") && m.contains("pale box"), "{m}");
    // And it still reads for its own scene.
    assert!(VlfFile::read_for(&path, &scene).is_ok());
}

/// A closed box of a glowing glossy metal (GGX α = 0.25): every inner side has a tile.
fn glossy_box() -> Scene {
    let metal = holocave_scene::Material {
        name: "glossy".into(),
        base_color: glam::Vec4::new(0.8, 0.7, 0.6, 1.0),
        metallic: 1.0,
        roughness: 0.5,
        emissive: Vec3::splat(0.5),
        ..holocave_scene::Material::default()
    };
    common::closed_box("glossy box", 1.0, metal)
}

#[test]
fn glossy_tiles_read_back_equal_and_damage_in_them_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scene = glossy_box();
    let f = baked(&scene);
    let settings = settings();
    let elements = layout(&scene, &settings);
    let tiles = holocave_vlf::tiles(&scene, &settings, &elements);
    // The box's inner sides (the fronts; the material is one-sided).
    assert_eq!(tiles.tiles.len(), elements.count / 2);
    assert_eq!(f.state.tiles.len(), tiles.len());
    assert!(f.state.tiles.iter().flatten().any(|&x| x > 0.0));
    let path = dir.path().join("glossy.vlf");
    f.write(&path).unwrap();
    let back = VlfFile::read_for(&path, &scene).unwrap();
    assert_eq!(back, f);
    common::assert_same_bits(&back.state, &f.state, "read back");
    let tb = |s: &holocave_vlf::State| -> Vec<u32> {
        s.tiles
            .iter()
            .chain(&s.tiles_last)
            .flatten()
            .map(|x| x.to_bits())
            .collect()
    };
    assert_eq!(tb(&back.state), tb(&f.state));
    assert_eq!(
        (back.settings.glossy_alpha, back.settings.tile_bins),
        (settings.glossy_alpha, settings.tile_bins)
    );

    let bytes = std::fs::read(&path).unwrap();
    let chunks = chunks(&bytes);
    // The chunks of the tiles: their radiance, last bounce and direct part.
    let tile_chunks = chunks
        .iter()
        .filter(|c| ["TILE", "TLST", "TDIR"].contains(&c.0.as_str()));
    assert_eq!(tile_chunks.clone().count(), 3);
    for (tag, at, len) in tile_chunks {
        assert_eq!(*len, tiles.len() * 12, "{tag}");
        // A damaged byte in the payload: that chunk's checksum.
        let mut b = bytes.clone();
        b[at + 16 + len / 2] ^= 0x10;
        let (p, r) = read_bytes(dir.path(), &format!("flip{tag}.vlf"), &b);
        let e = r.unwrap_err();
        names_file(&e, &p);
        assert!(
            matches!(&e, VlfError::Checksum { chunk, offset, .. } if chunk == tag && *offset == *at as u64),
            "{e:?}"
        );
        // Cut inside it: truncated there.
        let cut = at + 16 + len / 3;
        let (_, r) = read_bytes(dir.path(), &format!("cut{tag}.vlf"), &bytes[..cut]);
        let e = r.unwrap_err();
        assert!(
            matches!(&e, VlfError::Truncated { chunk, offset, .. } if chunk == tag && *offset == cut as u64),
            "{e:?}"
        );
    }
    // A TILE chunk one bin short (with a right checksum) does not fit META's count.
    let (_, tile, len) = chunks[3].clone();
    let mut b = bytes[..tile].to_vec();
    let payload = &bytes[tile + 16..tile + 16 + len - 12];
    b.extend_from_slice(b"TILE");
    b.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    b.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
    b.extend_from_slice(payload);
    b.extend_from_slice(&bytes[tile + 16 + len..]);
    let (_, r) = read_bytes(dir.path(), "short-tile.vlf", &b);
    let e = r.unwrap_err();
    assert!(
        matches!(&e, VlfError::Malformed { chunk, .. } if chunk == "TILE"),
        "{e:?}"
    );
}

#[test]
fn photometric_units_are_not_part_of_the_fingerprint_but_the_sky_is() {
    let scene = furnace("grey box", 0.5);
    let mut units = furnace("grey box", 0.5);
    units.daylight.photometry.efficacy = 683.0;
    assert_eq!(scene.fingerprint(), units.fingerprint());
    let mut sky = furnace("grey box", 0.5);
    sky.daylight.sky = Some(holocave_scene::Sky {
        model: holocave_scene::SkyModel::Uniform(Vec3::ONE),
        ground: Vec3::ZERO,
    });
    assert_ne!(scene.fingerprint(), sky.fingerprint());
}

/// A default bake a command keeps for itself follows its scene: baked for another
/// version of it (here another albedo), the file is set aside under its fingerprint and a
/// new bake starts; back at the first version, the first bake comes back whole (nothing
/// is baked again). A file that is not the command's own is refused instead.
#[test]
fn a_kept_bake_is_set_aside_for_another_version_of_its_scene_and_comes_back() {
    use holocave_scene::fingerprint::set_aside_path;
    use holocave_vlf::baked::{BakeJob, Start};
    use std::sync::atomic::AtomicBool;

    let dir = std::env::temp_dir().join(format!("holocave-kept-bake-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("furnace.vlf");
    let (first, second) = (furnace("furnace", 0.5), furnace("furnace", 0.6));
    let stop = AtomicBool::new(false);
    let job = |scene, kept_by_command| BakeJob {
        scene,
        settings: settings(),
        out: &out,
        interrupted: &stop,
        kept_by_command,
    };
    let bake = |scene| {
        job(scene, true)
            .run(&holocave_vlf::bake::Threads, &|_| {})
            .unwrap()
            .0
    };
    let made = bake(&first);
    // Not the command's own: the other version is refused, the file left as it is.
    assert!(job(&second, false).start().is_err());
    assert_eq!(
        VlfFile::read(&out).unwrap().fingerprint,
        first.fingerprint()
    );
    // The command's own: set aside, and a new bake for the second version.
    assert!(matches!(job(&second, true).start().unwrap(), Start::Fresh));
    let aside = set_aside_path(&out, first.fingerprint());
    assert_eq!(
        VlfFile::read(&aside).unwrap().state.irradiance,
        made.state.irradiance
    );
    bake(&second);
    // Back to the first version: its bake is back in place, converged.
    assert!(matches!(
        job(&first, true).start().unwrap(),
        Start::Converged
    ));
    let back = VlfFile::read(&out).unwrap();
    assert_eq!(back.fingerprint, first.fingerprint());
    assert_eq!(back.state.irradiance, made.state.irradiance);
    assert!(set_aside_path(&out, second.fingerprint()).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_caustics_part_reads_back_and_a_wrong_length_is_refused() {
    // Empty (no mirror or glass) and one value an element both read back; any other
    // length is refused, naming the chunk.
    let dir = tempfile::tempdir().unwrap();
    let mut f = baked(&furnace("box", 0.5));
    assert!(f.state.caustics.is_empty(), "a furnace has no caustics");
    let n = f.state.irradiance.len();
    f.state.caustics = (0..n).map(|i| [i as f32, 0.5, 2.0]).collect();
    let path = dir.path().join("caustics.vlf");
    f.write(&path).unwrap();
    assert_eq!(VlfFile::read(&path).unwrap(), f);

    f.state.caustics.pop();
    let path = dir.path().join("short.vlf");
    f.write(&path).unwrap();
    let e = VlfFile::read(&path).unwrap_err();
    names_file(&e, &path);
    assert!(
        matches!(&e, VlfError::Malformed { chunk, .. } if chunk == "CAUS"),
        "{e:?}"
    );
}

#[test]
fn the_check_names_a_negative_value_and_info_describes_the_bake() {
    let dir = tempfile::tempdir().unwrap();
    let scene = furnace("summary", 0.5);
    let mut f = baked(&scene);
    let path = dir.path().join("summary.vlf");
    f.write(&path).unwrap();
    let ok = holocave_vlf::file_summary::check(&path, Some(&scene)).unwrap();
    assert!(
        ok.ends_with(&format!(
            "ok ({} elements, {} bounces)",
            f.state.irradiance.len(),
            f.state.bounces
        )),
        "{ok}"
    );
    let lines = holocave_vlf::file_summary::describe(&path).unwrap();
    assert!(
        lines[1].contains(&format!("{:016x}", f.fingerprint)),
        "{lines:?}"
    );
    f.state.irradiance[3][1] = -0.5;
    f.write(&path).unwrap();
    let e = holocave_vlf::file_summary::check(&path, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("summary.vlf") && e.contains("1 irradiance or tile values"),
        "{e}"
    );
}
