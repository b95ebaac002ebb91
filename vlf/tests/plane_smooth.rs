//! The field's remainder smoothed over planes (`plane_smooth`): a wall's ray-effect
//! streaks are flattened across its triangles, its mean kept; a step by a factor (a
//! wall's foot in shadow) stays; a parallel surface a centimetre away is not mixed in.

use crate::common;

use glam::Vec3;
use holocave_scene::{Hit, Scene};
use holocave_vlf::baked::{Blended, Opened};
use holocave_vlf::plane_smooth::{RADIUS, smooth_over_planes};
use holocave_vlf::split::Split;
use holocave_vlf::{Elements, Settings, State, VlfFile};

const SIZE: f32 = 0.05;
const STRIP: f32 = 1.3;

/// A 2 m square floor (two triangles) facing +y, and a strip 1 cm above it (a skirting's
/// top: the same orientation, another plane).
fn floor_and_strip() -> Scene {
    let mut tris: Vec<([Vec3; 3], u32)> = common::floor(1.0).iter().map(|t| (*t, 0)).collect();
    let strip = common::quad(Vec3::new(-1.0, 0.01, -1.0), Vec3::Z * 2.0, Vec3::X * 0.5);
    tris.extend(strip.iter().map(|t| (*t, 0)));
    common::scene_of(
        "floor and strip",
        &tris,
        vec![common::lambert("floor", 0.5, Vec3::ZERO)],
        |_| {},
    )
}

/// Each front-side element's centre, and whether it lies on the floor.
fn centres(scene: &Scene, elements: &Elements) -> Vec<Option<(Vec3, bool)>> {
    let (_, centres) = elements.areas_and_centres(scene);
    (0..elements.count)
        .map(|e| {
            let (t, u, v) = centres[e];
            let front = (e as u32) < elements.triangles[t as usize].base(1);
            let hit = Hit {
                triangle: t,
                t: 0.0,
                u,
                v,
            };
            front.then(|| (scene.surface(&hit).position, t < 2))
        })
        .collect()
}

#[test]
fn streaks_are_flattened_steps_and_other_planes_kept() {
    let scene = floor_and_strip();
    let elements = Elements::new(&scene, SIZE);
    let tiles = holocave_vlf::tiles(
        &scene,
        &Settings {
            glossy_alpha: 0.0,
            ..Settings::default()
        },
        &elements,
    );
    let at = centres(&scene, &elements);
    let (area, _) = elements.areas_and_centres(&scene);
    // Diagonal streaks of ±5 % with a 30 cm period on the floor (21 cm across them); the
    // strip 30 % brighter (alike enough to be averaged, were it the same plane); the
    // floor's far edge (z > 0.6) in a shadow three times darker.
    let period = 0.3;
    let streak = |p: Vec3| 1.0 + 0.05 * (std::f32::consts::TAU * (p.x + p.z) / period).sin();
    let shadow = |p: Vec3| if p.z > 0.6 { 1.0 / 3.0 } else { 1.0 };
    let values: Vec<[f32; 3]> = at
        .iter()
        .map(|c| match c {
            Some((p, true)) => Vec3::splat(streak(*p) * shadow(*p)).to_array(),
            Some((_, false)) => [STRIP; 3],
            None => [0.0; 3],
        })
        .collect();
    let smoothed = smooth_over_planes(&scene, &elements, &tiles, &values);

    // In the lit part, away from its edges, the streaks' amplitude falls to under a
    // quarter (a 2-D tent of radius 20 cm passes none of a 21 cm wavelength; what is left
    // is the elements' 5 cm sampling of it) and the mean stays within 1 %.
    let radius = RADIUS * SIZE;
    let (mut before, mut after, mut sum_before, mut sum_after, mut w) =
        (0f32, 0f32, 0f32, 0f32, 0f32);
    for (e, c) in at.iter().enumerate() {
        let Some((p, true)) = c else { continue };
        let inner = p.x.abs() < 1.0 - radius && p.z > -1.0 + radius && p.z < 0.6 - radius;
        if inner {
            before = before.max((values[e][0] - 1.0).abs());
            after = after.max((smoothed[e][0] - 1.0).abs());
            sum_before += values[e][0] * area[e];
            sum_after += smoothed[e][0] * area[e];
            w += area[e];
        }
        // The shadow's step stays where it is: every element keeps its side's level
        // within its streaks' ±5 %.
        let level = shadow(*p);
        assert!(
            (smoothed[e][0] / level - 1.0).abs() < 0.051,
            "at {p}: {} against its side's level {level}",
            smoothed[e][0]
        );
    }
    assert!(after < 0.25 * before, "streaks ±{before} became ±{after}");
    let (mb, ma) = (sum_before / w, sum_after / w);
    assert!((ma / mb - 1.0).abs() < 0.01, "mean {mb} became {ma}");
    // The strip, a centimetre above the floor, is neither dimmed nor leaks into it.
    for (e, c) in at.iter().enumerate() {
        if let Some((_, false)) = c {
            assert!(
                (smoothed[e][0] - STRIP).abs() < 1e-4,
                "strip {}",
                smoothed[e][0]
            );
        }
    }
}

/// A glossy floor's tiles are smoothed bin by bin over the plane (its tiles share one
/// frame): each bin's streaks flatten, each bin keeps its own level.
#[test]
fn a_glossy_planes_tiles_are_smoothed_bin_by_bin() {
    let tris: Vec<([Vec3; 3], u32)> = common::floor(1.0).iter().map(|t| (*t, 0)).collect();
    let satin = holocave_scene::Material {
        name: "satin".into(),
        metallic: 1.0,
        roughness: 0.5,
        ..holocave_scene::Material::default()
    };
    let scene = common::scene_of("glossy floor", &tris, vec![satin], |_| {});
    let elements = Elements::new(&scene, SIZE);
    let tiles = holocave_vlf::tiles(&scene, &Settings::default(), &elements);
    assert!(tiles.elements as usize == elements.count && !tiles.is_empty());
    let at = centres(&scene, &elements);
    let k = tiles.per_tile();
    let period = 0.3;
    let streak = |p: Vec3| 1.0 + 0.05 * (std::f32::consts::TAU * (p.x + p.z) / period).sin();
    let level = |b: usize| 1.0 + b as f32 / k as f32;
    let mut values = vec![[0.0f32; 3]; elements.count + tiles.tiles.len() * k];
    for (e, c) in at.iter().enumerate() {
        if let (Some((p, _)), Some(g)) = (c, tiles.of(e as u32)) {
            for b in 0..k {
                values[elements.count + g as usize * k + b] = [streak(*p) * level(b); 3];
            }
        }
    }
    let smoothed = smooth_over_planes(&scene, &elements, &tiles, &values);
    let radius = RADIUS * SIZE;
    let mut tiled = 0;
    for (e, c) in at.iter().enumerate() {
        let (Some((p, _)), Some(g)) = (c, tiles.of(e as u32)) else {
            continue;
        };
        if p.x.abs() > 1.0 - radius || p.z.abs() > 1.0 - radius {
            continue;
        }
        tiled += 1;
        for b in 0..k {
            let v = smoothed[elements.count + g as usize * k + b][0] / level(b);
            assert!(
                (v - 1.0).abs() < 0.25 * 0.05,
                "bin {b} at {p}: {v} of its level"
            );
        }
    }
    assert!(tiled > 100, "{tiled} inner tiles");
}

/// A bake set's blend of two bakes (`Split::of_parts`) draws each bake's remainder
/// smoothed alone, then blended: the same field whatever time of day between them, so a
/// node smooths each bake once (kept) and a new time smooths nothing. It is not the blend
/// smoothed, which the smoothing's range weights make another field (checked too, so the
/// test sees a difference where it must).
#[test]
fn a_blend_of_two_bakes_is_the_blend_of_each_smoothed() {
    let glowing = common::lambert("glowing", 0.5, Vec3::ONE);
    let scene = std::sync::Arc::new(common::closed_box("blend", 2.0, glowing));
    let settings = common::small_settings();
    let (a, _) = common::bake_quiet(&scene, &settings);
    // A second bake whose light differs from place to place (a mere scaling of the first
    // would be smoothed alike).
    let mut b = a.clone();
    for (i, v) in b.irradiance.iter_mut().enumerate() {
        let k = 1.0 + (i % 7) as f32 * 0.3;
        v.iter_mut().for_each(|c| *c *= k);
    }
    let t = 0.25;
    let blend = holocave_vlf::hours::blend(&a, &b, t).unwrap();
    let vis = holocave_vlf::Visibility::of(scene.clone(), &settings);
    let layout = (vis.elements(), vis.tiles());
    let opened = |state: &State| {
        std::sync::Arc::new(Opened {
            file: VlfFile::of(&scene, settings, state.clone()),
            elements: layout.0.clone(),
            tiles: layout.1.clone(),
            blended: None,
        })
    };
    let parts = Blended {
        before: opened(&a),
        after: opened(&b),
        t,
    };
    let split = |s: &State, parts: Option<&Blended>| {
        Split::of_parts(scene.clone(), &settings, (s, parts), layout, false)
            .unwrap()
            .remainder
    };
    let drawn = split(&blend, Some(&parts));
    let (ra, rb) = (split(&a, None), split(&b, None));
    let want: Vec<[f32; 3]> = (ra.iter().zip(&rb))
        .map(|(p, q)| std::array::from_fn(|i| (1.0 - t) * p[i] + t * q[i]))
        .collect();
    assert_eq!(drawn, want, "each bake smoothed alone, then blended");
    assert_ne!(
        split(&blend, None),
        want,
        "the blend smoothed is another field"
    );
}
