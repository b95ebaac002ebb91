//! A bake's result depends only on the scene and the settings: not on the number of
//! threads, and not on whether it was killed and resumed on the way.

use crate::common;

use std::cell::Cell;
use std::path::Path;
use std::time::Instant;

use holocave_scene::{LoadOptions, Scene};
use holocave_vlf::{Settings, State, VlfFile, bake};

fn cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    Scene::load(&path, &LoadOptions::default()).unwrap()
}

/// Small, but with every part of a bake at work: the area light by next-event estimation,
/// the mirror box and glass sphere as links, several bounces.
fn settings() -> Settings {
    Settings {
        directions: 92,
        resolution: 48,
        element_size: None,
        direct_samples: 4,
        tolerance: 1e-3,
        max_bounces: 200,
        ..Settings::default()
    }
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn bakes_on_one_two_and_three_threads_are_bit_identical() {
    let scene = cornell();
    let settings = settings();
    let start = Instant::now();
    let (one, stats) = in_pool(1, || common::bake_quiet(&scene, &settings));
    eprintln!(
        "one thread: {:.2} s, {} elements, {} links, {} bounces",
        start.elapsed().as_secs_f64(),
        stats.elements,
        stats.links,
        one.bounces
    );
    assert!(one.converged && one.bounces >= 3, "{}", one.bounces);
    assert!(stats.links > 0, "the mirror and the glass make links");
    for threads in [2, 3] {
        let (other, _) = in_pool(threads, || common::bake_quiet(&scene, &settings));
        common::assert_same_bits(&one, &other, &format!("1 and {threads} threads"));
    }
}

/// The same with glossy surfaces: their tiles are summed in the same order whatever the
/// threads (sorted by tile, in subfield order within one), and a bake killed after a
/// bounce resumes from its file to the same tiles.
#[test]
fn glossy_bakes_are_bit_identical_on_any_threads_and_when_resumed() {
    let scene = common::glossy_cornell();
    let settings = settings();
    let (one, stats) = in_pool(1, || common::bake_quiet(&scene, &settings));
    eprintln!(
        "{} elements, {} tiles, {} bounces, residuals {:?}",
        stats.elements, stats.tiles, one.bounces, one.residuals
    );
    assert!(stats.tiles > 0 && one.converged && one.bounces >= 3);
    assert!(
        one.tiles.iter().flatten().any(|&x| x > 0.0),
        "the tiles are lit"
    );
    for threads in [2, 3] {
        let (other, _) = in_pool(threads, || common::bake_quiet(&scene, &settings));
        common::assert_same_bits(&one, &other, &format!("1 and {threads} threads"));
    }
    // Killed after bounce 1, saved through the file, resumed.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glossy.vlf");
    let file = |state: &State| VlfFile::of(&scene, settings, state.clone());
    let e = bake(&scene, &settings, None, &|_| {}, &mut |s: &State| {
        file(s).write(&path).unwrap();
        if s.bounces == 1 {
            Err(Killed(1))
        } else {
            Ok(())
        }
    })
    .unwrap_err();
    assert_eq!(e.0, 1);
    let left = VlfFile::read_for(&path, &scene).unwrap();
    let (resumed, _) = bake(&scene, &settings, Some(left.state), &|_| {}, &mut |_| {
        Ok::<(), Killed>(())
    })
    .unwrap();
    common::assert_same_bits(&resumed, &one, "glossy, killed after bounce 1");
}

#[derive(Debug)]
struct Killed(u32);

#[test]
fn a_killed_bake_resumes_to_the_same_state() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell();
    let settings = settings();
    let (whole, _) = common::bake_quiet(&scene, &settings);
    assert!(whole.bounces >= 4, "{}", whole.bounces);
    let file = |state: &State| VlfFile::of(&scene, settings, state.clone());

    // Killed after bounce 0 (direct light only), in the middle, and after the last bounce
    // but before the converged state was saved.
    for kill_after in [0, 2, whole.bounces] {
        let path = dir.path().join(format!("killed{kill_after}.vlf"));
        let saves = Cell::new(0u32);
        let mut save = |s: &State| -> Result<(), Killed> {
            file(s).write(&path).unwrap();
            saves.set(saves.get() + 1);
            if s.bounces == kill_after && !s.converged {
                return Err(Killed(s.bounces));
            }
            Ok(())
        };
        let e = bake(&scene, &settings, None, &|_| {}, &mut save).unwrap_err();
        assert_eq!(e.0, kill_after);
        assert_eq!(saves.get(), kill_after + 1, "one save per bounce");

        // What the file keeps: the state after that bounce, not finished.
        let left = VlfFile::read_for(&path, &scene).unwrap();
        assert_eq!(left.settings, settings);
        assert_eq!(left.state.bounces, kill_after);
        assert!(!left.state.converged);
        assert_eq!(left.state.residuals.len() as u32, kill_after + 1);

        let resumed_saves = Cell::new(Vec::new());
        let mut save = |s: &State| -> Result<(), Killed> {
            file(s).write(&path).unwrap();
            let mut v = resumed_saves.take();
            v.push(s.bounces);
            resumed_saves.set(v);
            Ok(())
        };
        let (resumed, _) = bake(&scene, &settings, Some(left.state), &|_| {}, &mut save).unwrap();
        common::assert_same_bits(
            &resumed,
            &whole,
            &format!("killed after bounce {kill_after}"),
        );
        // The resumed bake went on from the next bounce, and its file is the final state.
        let saved = resumed_saves.take();
        assert_eq!(
            saved.first().copied(),
            Some((kill_after + 1).min(whole.bounces))
        );
        let last = VlfFile::read_for(&path, &scene).unwrap();
        common::assert_same_bits(&last.state, &whole, "the resumed bake's file");
    }

    // A finished bake given back is returned as it is, with nothing propagated.
    let (again, _) = bake(&scene, &settings, Some(whole.clone()), &|_| {}, &mut |_| {
        Err(Killed(u32::MAX))
    })
    .unwrap();
    common::assert_same_bits(&again, &whole, "a converged state resumed");
}
