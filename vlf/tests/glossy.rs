//! Glossy surfaces and their directional radiance tiles (`holocave_vlf::tiles`): a scene
//! without them has none; a glossy plane under a directional light has, towards every
//! eye, the radiance the tracer's BSDF gives (`f(ω_o, ω_i) E`) to within what bilinear
//! interpolation between bins allows; a varnished floor under a uniform sky sends every
//! viewer the sky's light times its BSDF's directional albedo. (A glossy bake is bit-identical on any number of
//! threads and when resumed: `determinism.rs`; its file: `file.rs`.)

use crate::common;

use std::path::Path;
use std::sync::Arc;

use glam::{Vec3, Vec4};
use holocave_scene::{
    Daylight, LoadOptions, Material, PunctualKind, PunctualLight, Ray, Scene, Sky, SkyModel,
};
use holocave_tracer::bsdf::Bsdf;
use holocave_vlf::octahedral::{decode, encode};
use holocave_vlf::tile_albedo::TileAlbedo;
use holocave_vlf::view::shade_one;
use holocave_vlf::{Directions, Settings, Visibility, layout, tiles};

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
    let [t0, t1] = common::floor(HALF);
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
        // Elements of a fifth of a square metre: above `pools::POOLED_BELOW` times a
        // line's reach (a 16-line grid over the plane's 5.7 m sphere), so they get tiles.
        element_size: Some(1.0),
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
        // What a bin holds: the BSDF averaged over the bin.
        let bin_at =
            |i: u32, j: u32| t.bin_mean((j * k + i) as usize, |wo| bsdf.eval(wo, wi).0) * e;
        let wo = frame.to_local(-ray.dir);
        let exact = bsdf.eval(wo, wi).0 * e;

        // 1. The lookup is the bilinear interpolation of the four nearest bins (each holds
        //    f(bin, ω_i) E, the BSDF averaged over the bin, summed over 4 samples).
        let (x, y) = encode(wo, k);
        assert!((x - lookup.x).abs() < 1e-5 && (y - lookup.y).abs() < 1e-5);
        let (fx, fy) = ((x - 0.5).max(0.0), (y - 0.5).max(0.0));
        let (i0, j0) = ((fx as u32).min(k - 1), (fy as u32).min(k - 1));
        let (i1, j1) = ((i0 + 1).min(k - 1), (j0 + 1).min(k - 1));
        let (ax, ay) = (fx - i0 as f32, fy - j0 as f32);
        let c = |i: u32, j: u32| bin_at(i, j);
        let bilinear = (c(i0, j0) * (1.0 - ax) + c(i1, j0) * ax) * (1.0 - ay)
            + (c(i0, j1) * (1.0 - ax) + c(i1, j1) * ax) * ay;
        assert!(
            (drawn - bilinear).abs().max_element() <= 1e-5 * bilinear.max_element() + 1e-6,
            "eye {eye}: drawn {drawn}, bilinear of the exact bins {bilinear}"
        );

        // 2. Bilinear interpolation over a cell of unit spacing errs by at most
        //    (max|∂²g/∂x²| + max|∂²g/∂y²|)/8 (the error of linear interpolation along each
        //    axis), and a bin's average over its 2 × 2 sub-directions (at ±1/4 of a bin
        //    from its centre) differs from its centre's value by at most that sum / 32;
        //    the second derivatives are taken by central differences (step 1/20) over the
        //    cell and the quarter bin around it, with 10 % added for what the sampled
        //    maximum can miss.
        let h = 0.05f64;
        let (cx, cy) = (f64::from(i0) + 0.5, f64::from(j0) + 0.5);
        let mut second = Vec3::ZERO;
        for a in -5..=25 {
            for b in -5..=25 {
                let (px, py) = (cx + f64::from(a) * h, cy + f64::from(b) * h);
                let mid = exact_at(px, py) * 2.0;
                let dxx = (exact_at(px + h, py) + exact_at(px - h, py) - mid).abs();
                let dyy = (exact_at(px, py + h) + exact_at(px, py - h) - mid).abs();
                second = second.max((dxx + dyy) / (h * h) as f32);
            }
        }
        let bound = second * (1.1 * (1.0 / 8.0 + 1.0 / 32.0)) + Vec3::splat(1e-5);
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

/// `∫ f(ω_o, ω_i) cos θ_i dω_i` by a midpoint rule in `cos θ_i` and `φ` fine enough for
/// the tiles' lobes (steps of 0.8° or less where the lobe is).
fn directional_albedo(bsdf: &Bsdf, wo: Vec3) -> Vec3 {
    integrated(|wi| bsdf.eval(wo, wi).0)
}

/// [`directional_albedo`] of what a tile reflects: its widened lobe at the surface's
/// energy for light arriving at each angle ([`tiles::Glossy::glossy_scale`]), and the
/// base.
fn tile_albedo(tile: &tiles::Glossy, wo: Vec3) -> Vec3 {
    let b = &tile.bsdf;
    integrated(|wi| {
        let base = b.eval_diffuse(wo, wi);
        (b.eval(wo, wi).0 - base) * tile.glossy_scale(wi.z) + base
    })
}

/// `∫ f(ω_i) cos θ_i dω_i` over the hemisphere, by the midpoint rule above.
fn integrated(f: impl Fn(Vec3) -> Vec3) -> Vec3 {
    let n = 400;
    let mut sum = Vec3::ZERO;
    for i in 0..n {
        for j in 0..n {
            let c = (i as f32 + 0.5) / n as f32;
            let phi = (j as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
            let s = (1.0 - c * c).sqrt();
            sum += f(Vec3::new(s * phi.cos(), s * phi.sin(), c)) * c;
        }
    }
    sum * (std::f32::consts::TAU / (n * n) as f32)
}

/// The room's varnished wood (GGX α = 0.0625, widened in its tiles to the bins' 0.22) as
/// a floor under a uniform sky: seen from 10°, 30° and 50° off the normal, each point
/// sends `L × albedo(ω_o)` of what the tile reflects (the widened lobe at the surface's
/// energy for each arrival, and the base; times the sky directions' cosine quadrature
/// `Q`), in luminance. The rest is the lobe's binning on the light's side and the
/// viewer's and the sky beyond the floor's edge (0.5 %): 2.85 % at most here (at 50°),
/// held to 3 %, a bound set from that measurement, not derived — it was 1.3 %, held to
/// 2 %, while the widened lobe kept its own energy: at the surface's it weighs the
/// arrivals near grazing, whose energy it raises by up to a third, and there the bins
/// shift light the most; with what the pixel adds for it (`tile_albedo`), 0.23 % at
/// most, held to 0.5 %. With
/// each bin's BSDF taken at its centre alone the lobe, as narrow as the bins, was
/// aliased, and the energy scaling took the excess from the whole arrival: 5.3 % too
/// dark at 10° (the room's floor view 2.9 % too dark overall).
#[test]
fn a_varnished_floor_under_a_uniform_sky_reflects_its_directional_albedo() {
    const SKY: f32 = 1.0;
    const HALF: f32 = 30.0;
    let floor = common::floor(HALF);
    let varnish = Material {
        name: "varnished wood".into(),
        base_color: Vec4::new(0.45, 0.28, 0.16, 1.0),
        metallic: 0.0,
        roughness: 0.25,
        specular: 1.0,
        ..Material::default()
    };
    let daylight = Daylight {
        sky: Some(Sky {
            model: SkyModel::Uniform(Vec3::splat(SKY)),
            ground: Vec3::ZERO,
        }),
        ..Default::default()
    };
    let scene = Arc::new(common::scene_of(
        "varnished floor",
        &floor.map(|t| (t, 0)),
        vec![varnish],
        |p| p.daylight = daylight,
    ));
    let settings = Settings {
        directions: 642,
        resolution: 96,
        element_size: Some(2.0),
        ..Settings::default()
    };
    let (state, stats) = common::bake_quiet(&scene, &settings);
    assert!(stats.tiles > 0, "the varnish is glossy");
    let values = state.values();
    let vis = Visibility::of(scene.clone(), &settings);
    let dirs = Directions::at_least(settings.directions);
    let q = (dirs.dirs.iter().zip(&dirs.solid_angle))
        .map(|(w, s)| f64::from(*s) * f64::from(w.y.max(0.0)))
        .sum::<f64>()
        / std::f64::consts::PI;
    let tile = vis.tiles().tiles[0];
    let tile_bsdf = tile.bsdf;
    let grazing = TileAlbedo::new(vis.tiles(), settings.directions, state.sky_values());
    for degrees in [10f32, 30.0, 50.0] {
        let (s, c) = degrees.to_radians().sin_cos();
        let towards_eye = Vec3::new(s, c, 0.0);
        // 200 points over the floor's middle, each seen along the same direction.
        let n = 200;
        let (drawn, corrected) = (0..n)
            .map(|i| {
                let at = Vec3::new(
                    -5.0 + 10.0 * (i as f32 + 0.5) / n as f32,
                    0.0,
                    -5.0 + 10.0 * ((i * 37 % n) as f32 + 0.5) / n as f32,
                );
                let l = vis.lookup(Ray::new(at + towards_eye * 2.0, -towards_eye));
                assert!(l.tile != u32::MAX, "a tile is seen");
                let c = shade_one(&l, &values);
                (c, c + grazing.added(&l, &values))
            })
            .fold((Vec3::ZERO, Vec3::ZERO), |(a, b), (c, d)| (a + c, b + d));
        let (drawn, corrected) = (drawn / n as f32, corrected / n as f32);
        // The floor's frame: +y up, so the local direction is (x, z, y).
        let wo = Vec3::new(towards_eye.x, towards_eye.z, towards_eye.y);
        let expected = tile_albedo(&tile, wo) * SKY * q as f32;
        // In luminance, as the accuracy figures are (the blue channel, with the least
        // base colour, has the lobe's binning as a larger share: 2.4 % at 30°).
        let lum = holocave_scene::luminance;
        let off = (lum(drawn) / lum(expected) - 1.0).abs();
        eprintln!(
            "{degrees}°: drawn {drawn}, expected {expected}: {:.2} %",
            off * 100.0
        );
        assert!(
            off < 0.03,
            "{degrees}° off the normal: drawn {drawn}, the sky times the albedo {expected}"
        );
        // With what the pixel adds (`holocave_vlf::tile_albedo`), the bins' error is gone
        // and the sky's quadrature with it: the sky times the lobe's albedo, to 0.5 %
        // (the floor's edge, above, and the albedo tables' steps).
        let albedo = directional_albedo(&tile_bsdf, wo) * SKY;
        let off = (lum(corrected) / lum(albedo) - 1.0).abs();
        eprintln!("  with the pixel's correction {:.2} %", off * 100.0);
        assert!(
            off < 0.005,
            "{degrees}°: drawn with the pixel's correction {corrected}, the sky times the albedo {albedo}"
        );
    }
}
