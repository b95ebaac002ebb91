//! Glossy surfaces and their directional radiance tiles (`holocave_vlf::tiles`): a scene
//! without them has none; a glossy plane under a directional light has, towards every
//! eye, the radiance the tracer's BSDF gives (`f(ω_o, ω_i) E`) to within what bilinear
//! interpolation between bins allows. (A glossy bake is bit-identical on any number of
//! threads and when resumed: `determinism.rs`; its file: `file.rs`.)

mod common;

use std::path::Path;
use std::sync::Arc;

use glam::{Vec3, Vec4};
use holocave_scene::{LoadOptions, Material, PunctualKind, PunctualLight, Ray, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_vlf::octahedral::{decode, encode};
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, Visibility, layout, tiles};

fn cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    Scene::load(&path, &LoadOptions::default()).unwrap()
}

fn small() -> Settings {
    Settings {
        directions: 92,
        resolution: 48,
        direct_samples: 4,
        ..Settings::default()
    }
}

#[test]
fn a_scene_without_glossy_surfaces_has_no_tiles() {
    let scene = cornell();
    let settings = small();
    let elements = layout(&scene, &settings);
    let t = tiles(&scene, &settings, &elements);
    // Nothing allocated: no per-element map, no tiles, no bins.
    assert!(t.is_empty() && t.tiles.capacity() == 0);
    assert_eq!(t.of_element.capacity(), 0);
    assert_eq!(t.centres.capacity(), 0);
    let (state, stats) = common::bake_quiet(&scene, &settings);
    assert_eq!((stats.tiles, stats.tile_memory), (0, 0));
    assert!(state.tiles.is_empty() && state.tiles_last.is_empty());
    assert_eq!(state.values(), state.irradiance);
}

const E: f32 = 3.0;
const HALF: f32 = 2.0;

/// A metal plane (the square [−2, 2]² of y = 0, facing +y) lit by a directional light:
/// the plane cannot light itself, so what it sends towards an eye is `f(ω_o, ω_i) E cos θ_i`
/// exactly.
fn lit_plane(roughness: f32) -> (Arc<Scene>, Vec3) {
    let [t0, t1] = common::quad(
        Vec3::new(-HALF, 0.0, -HALF),
        Vec3::Z * 2.0 * HALF,
        Vec3::X * 2.0 * HALF,
    );
    let metal = Material {
        name: "metal".into(),
        base_color: Vec4::new(0.95, 0.64, 0.54, 1.0),
        metallic: 1.0,
        roughness,
        ..Material::default()
    };
    let to_light = Vec3::new(0.4, 1.0, 0.2).normalize();
    let light = PunctualLight {
        name: "sun".into(),
        kind: PunctualKind::Directional,
        position: Vec3::ZERO,
        direction: -to_light,
        intensity: Vec3::splat(E),
        range: None,
    };
    let scene = common::scene("plane", &[(t0, 0), (t1, 0)], vec![metal], vec![light]);
    (Arc::new(scene), to_light)
}

#[test]
fn a_glossy_plane_under_a_directional_light_reflects_its_bsdf() {
    // α = 0.3: wider than the tiles' floor (0.219 for 8 bins and 162 directions), so the
    // lobe is the material's own.
    let roughness = 0.3f32.sqrt();
    let (scene, to_light) = lit_plane(roughness);
    let settings = Settings {
        directions: 162,
        resolution: 16,
        element_size: Some(0.5),
        direct_samples: 4,
        ..Settings::default()
    };
    let (state, stats) = common::bake_quiet(&scene, &settings);
    assert!(stats.tiles > 0);
    assert!(holocave_vlf::tiles::alpha_floor(8, 162) < 0.3);
    let vis = Visibility::of(scene.clone(), &settings);
    let t = vis.tiles();
    let k = t.bins;
    let values = state.values();
    let p = scene.materials[0].params(&scene.textures, glam::Vec2::ZERO);
    let bsdf = Bsdf::new(&p);
    let e = E * to_light.y;

    let mut worst = 0f32;
    for (i, eye) in [
        Vec3::new(-1.0, 1.5, -0.5),
        Vec3::new(-0.6, 0.8, -0.3),
        Vec3::new(0.3, 3.0, 0.2),
        Vec3::new(1.5, 0.6, 1.0),
        Vec3::new(-1.8, 0.5, 0.4),
    ]
    .into_iter()
    .enumerate()
    {
        let at = Vec3::new(0.35 - 0.2 * i as f32, 0.0, 0.15 + 0.1 * i as f32);
        let ray = Ray::new(eye, (at - eye).normalize());
        let lookup = vis.lookup(ray);
        assert!(lookup.tile != u32::MAX, "the plane is glossy");
        let drawn = shade_one(&lookup, &values);

        // The tile's frame (the plane's normal) and the exact radiance at map (x, y).
        let g = (lookup.tile - t.elements) / (k * k);
        let frame = t.tiles[g as usize].frame;
        assert!((frame.n - Vec3::Y).length() < 1e-6);
        let wi = frame.to_local(to_light);
        let exact_at = |x: f64, y: f64| bsdf.eval(decode(x, y, k).as_vec3(), wi).0 * e;
        let wo = frame.to_local(-ray.dir);
        let exact = bsdf.eval(wo, wi).0 * e;

        // 1. The lookup is the bilinear interpolation of the exact radiance at the four
        //    nearest bin centres (the tile holds f(ω_b, ω_i) E, summed over 4 samples).
        let (x, y) = encode(wo, k);
        assert!((x - lookup.x).abs() < 1e-5 && (y - lookup.y).abs() < 1e-5);
        let (fx, fy) = ((x - 0.5).max(0.0), (y - 0.5).max(0.0));
        let (i0, j0) = ((fx as u32).min(k - 1), (fy as u32).min(k - 1));
        let (i1, j1) = ((i0 + 1).min(k - 1), (j0 + 1).min(k - 1));
        let (ax, ay) = (fx - i0 as f32, fy - j0 as f32);
        let c = |i: u32, j: u32| exact_at(f64::from(i) + 0.5, f64::from(j) + 0.5);
        let bilinear = (c(i0, j0) * (1.0 - ax) + c(i1, j0) * ax) * (1.0 - ay)
            + (c(i0, j1) * (1.0 - ax) + c(i1, j1) * ax) * ay;
        assert!(
            (drawn - bilinear).abs().max_element() <= 1e-5 * bilinear.max_element() + 1e-6,
            "eye {eye}: drawn {drawn}, bilinear of the exact bins {bilinear}"
        );

        // 2. Bilinear interpolation over a cell of unit spacing errs by at most
        //    (max|∂²g/∂x²| + max|∂²g/∂y²|)/8 (the error of linear interpolation along each
        //    axis); the second derivatives are taken by central differences (step 1/20)
        //    over the cell, with 10 % added for what the sampled maximum can miss.
        let h = 0.05f64;
        let (cx, cy) = (f64::from(i0) + 0.5, f64::from(j0) + 0.5);
        let mut second = Vec3::ZERO;
        for a in 0..=20 {
            for b in 0..=20 {
                let (px, py) = (cx + f64::from(a) * h, cy + f64::from(b) * h);
                let mid = exact_at(px, py) * 2.0;
                let dxx = (exact_at(px + h, py) + exact_at(px - h, py) - mid).abs();
                let dyy = (exact_at(px, py + h) + exact_at(px, py - h) - mid).abs();
                second = second.max((dxx + dyy) / (h * h) as f32);
            }
        }
        let bound = second * (1.1 / 8.0) + Vec3::splat(1e-5);
        let err = (drawn - exact).abs();
        eprintln!("eye {eye}: drawn {drawn}, exact {exact}, error {err} within {bound}");
        assert!(
            err.cmple(bound).all(),
            "eye {eye}: drawn {drawn}, exact {exact}: error {err} above {bound}"
        );
        worst = worst.max((err / exact.max(Vec3::splat(1e-6))).max_element());
    }
    eprintln!("worst relative error {worst:.4}");
}
