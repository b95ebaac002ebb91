//! The breakfast room (`../shared/scenes/breakfast_room`, skipped when absent unless
//! `HOLOCAVE_REQUIRE_SHARED=1`): what made its walls 25 % too bright in `vlf view`
//! against `render`. The walls (WhiteMatt: a rough dielectric, base 0.9, GGX α = 0.94,
//! F0 = 0.04) are lit almost only by inter-reflected light, so every bounce multiplies by
//! their albedo, and the light field's albedo was the normal-incidence
//! `base (1 − F0)² + F0` = 0.869 where the path tracer's BSDF reflects 0.772 of evenly
//! arriving light (its Lambertian base dimmed by `(1 − F(θo))(1 − F(θi))`, which grows
//! towards grazing angles): 12.6 % too much per bounce, about 25 % after the room's
//! bounces (the light sent out falls by ≈ 0.67 per bounce in its bake). This test holds
//! every material the light field draws as diffuse to the tracer's own BSDF; the field's
//! transport, with every material made Lambertian, to the path tracer's within 1 %; and
//! the walls and floor as the walls of a CAVE draw them (the light field and the direct
//! light per pixel) within 2 % of the path tracer's, which needs the small glossy
//! elements (the chairs, cups, teapot: 263 k triangles far smaller than a line's
//! cross-section) drawn diffuse and pooled rather than each given a tile that keeps only
//! a fraction of its light, and drawn with the albedo their narrow lobes really have.

use std::path::Path;

use glam::{Vec2, Vec3};
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_vlf::Settings;
use holocave_vlf::surface::diffuse_albedo;

/// The project's one skip-or-fail rule for `../shared` (`tests/common/require.rs`).
#[path = "../../tests/common/require.rs"]
mod require;

/// `(1/π) ∫∫ f cos θo cos θi` by a midpoint rule of `n × n` cells (uniform in `cos θ` and
/// `φ`) over each hemisphere, with the tracer's `eval`.
fn bsdf_albedo(bsdf: &Bsdf, n: usize) -> Vec3 {
    let dir = |k: usize| {
        let c = ((k / n) as f32 + 0.5) / n as f32;
        let phi = ((k % n) as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
        let s = (1.0 - c * c).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), c)
    };
    let cell = std::f32::consts::TAU / (n * n) as f32;
    let mut sum = Vec3::ZERO;
    for o in 0..n * n {
        let wo = dir(o);
        let mut a = Vec3::ZERO;
        for i in 0..n * n {
            let wi = dir(i);
            a += bsdf.eval(wo, wi).0 * wi.z;
        }
        sum += a * wo.z;
    }
    sum * cell * cell / std::f32::consts::PI
}

#[test]
fn the_breakfast_rooms_diffuse_albedos_are_the_path_tracers() {
    let Some(path) = require::shared("scenes/breakfast_room/BreakfastRoom.gltf") else {
        return;
    };
    let daylight =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/breakfast_room.daylight.toml");
    let scene = Scene::load(
        &path,
        &LoadOptions {
            daylight: Some(daylight),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    let glossy_alpha = Settings::default().glossy_alpha;
    let mut checked = Vec::new();
    for m in &scene.materials {
        // At the middle of its texture, if it has one.
        let p = m.params(&scene.textures, Vec2::splat(0.5));
        let bsdf = Bsdf::new(&p);
        if bsdf.is_pure_delta() || p.roughness * p.roughness < glossy_alpha {
            continue; // followed exactly, or a glossy tile with the BSDF itself
        }
        let got = diffuse_albedo(&p);
        // The rule the light field uses has cells twice as large; this one's error is
        // below 0.1 % for these rough lobes, the light field's below 0.3 % (measured
        // against this one): 0.5 % of the albedo in all.
        let want = bsdf_albedo(&bsdf, 48);
        eprintln!("{}: light field {got}, path tracer {want}", m.name);
        assert!(
            (got - want).abs().max_element() <= 0.005 * want.max_element(),
            "{}: the light field reflects {got}, the path tracer's BSDF {want}",
            m.name
        );
        checked.push(m.name.clone());
    }
    // The walls and the blinds (WhiteMatt), the floor, the pictures, the lamp shades.
    assert!(
        checked.iter().any(|n| n == "WhiteMatt") && checked.len() >= 3,
        "{checked:?}"
    );
}

/// The breakfast room's walls (the pixels whose centre sees WhiteMatt) and floor
/// (FloorTiles) from `CameraMain` at 160 × 90 as the walls draw it at the first frame
/// (the light field with the default bake and the direct light per pixel), against the
/// mean of two 256-spp path-traced renders, with every material passed through `material`
/// first: each region's bias of the mean luminance, and its references' standard error
/// (half their difference, relative).
fn walls_and_floor(material: impl Fn(&mut holocave_scene::Material)) -> [(f64, f64); 2] {
    let Some(path) = require::shared("scenes/breakfast_room/BreakfastRoom.gltf") else {
        return [(0.0, 0.0); 2];
    };
    let daylight =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/breakfast_room.daylight.toml");
    let mut scene = Scene::load(
        &path,
        &LoadOptions {
            daylight: Some(daylight),
            ..LoadOptions::default()
        },
    )
    .expect("the breakfast room loads");
    scene.materials.iter_mut().for_each(material);
    let scene = std::sync::Arc::new(scene);
    let camera = (scene.cameras.iter())
        .find(|c| c.name == "CameraMain")
        .expect("CameraMain");
    let view = WallView::through_camera(camera, Size::new(160, 90));
    let settings = Settings::default();
    let (state, _) =
        holocave_vlf::bake(&scene, &settings, None, &|_| {}, &mut |_| Ok::<(), ()>(()))
            .expect("bake");
    let vis = holocave_vlf::Visibility::of(scene.clone(), &settings);
    let pass = holocave_vlf::WallPass::new(vis, &settings, &state, false).expect("split");
    let drawn = pass.render(&view, pass.values(), 2, 1);
    let tracer = holocave_tracer::Tracer::new(scene.clone(), Default::default());
    let refs: Vec<_> = (1..=2)
        .map(|seed| holocave_tracer::render::render(&tracer, &view, 256, seed, &|| {}))
        .collect();
    // A material's pixels: those whose centre's ray first meets it.
    let pixels_of = |name: &str| {
        let m = (scene.materials.iter())
            .position(|m| m.name == name)
            .expect("the material") as u32;
        let sees = |x: u32, y: u32| {
            let ray = view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            (scene.closest_hit(&ray, f32::INFINITY))
                .is_some_and(|h| scene.triangle_shading(h.triangle).material == m)
        };
        let pixels: Vec<(u32, u32)> = (0..view.size.height)
            .flat_map(|y| (0..view.size.width).map(move |x| (x, y)))
            .filter(|&(x, y)| sees(x, y))
            .collect();
        assert!(pixels.len() > 500, "{} pixels of {name}", pixels.len());
        pixels
    };
    ["WhiteMatt", "FloorTiles"].map(|name| {
        let pixels = pixels_of(name);
        let sum = |img: &holocave_tracer::film::Image| {
            (pixels.iter())
                .map(|&(x, y)| f64::from(holocave_scene::color::luminance(img.at(x, y))))
                .sum::<f64>()
        };
        let (a, b) = (sum(&refs[0]), sum(&refs[1]));
        let reference = 0.5 * (a + b);
        let bias = sum(&drawn) / reference - 1.0;
        let se = 0.5 * (a - b).abs() / reference;
        eprintln!(
            "{name}: {:+.2} % (references {:.2} % apart)",
            100.0 * bias,
            100.0 * (a - b).abs() / reference
        );
        (bias, se)
    })
}

/// With every material made Lambertian (its base colour and textures kept), the light
/// field's transport on a real scene: the walls and the floor each within 1 % of the path
/// tracer's mean, plus three standard errors of the references' mean. What the 1 % is
/// for: the sky brought in over each direction's cone rather than its cell (0.3 %, the
/// bake's unit test) and the light the smallest elements lose to the least area a line's
/// light is spread over (about half a per cent here: with a sixteenth of a line's
/// cross-section instead of a quarter, the field gained 0.6 %). Measured: walls +0.22 %,
/// floor −1.58 % (its references 0.73 % apart). With the sky taken at each direction's
/// centre, as the bake did, the directions on the horizon carried the bright sky just
/// above it over a cone half of which is the ground: 7.7 % too much sky, the walls
/// +3.55 %, which fails.
#[test]
fn made_lambertian_the_walls_and_floor_are_the_path_tracers() {
    let lambertian = |m: &mut holocave_scene::Material| {
        m.metallic = 0.0;
        m.roughness = 1.0;
        m.specular = 0.0;
        m.transmission = 0.0;
        m.metallic_roughness_texture = None;
    };
    for (what, (bias, se)) in ["walls", "floor"]
        .into_iter()
        .zip(walls_and_floor(lambertian))
    {
        assert!(
            bias.abs() <= 0.01 + 3.0 * se,
            "the {what} {:+.2} % off the path tracer's (allowed 1 % + {:.2} %)",
            100.0 * bias,
            300.0 * se
        );
    }
}

/// The walls and floor with their own materials, each within the goal for the
/// mean bias, 2 %, plus three standard errors of the references' mean. Measured: the
/// walls −0.44 %, the floor +1.82 % (its references 1.10 % apart). With the elements
/// drawn diffuse given an albedo by a midpoint rule of `eval` (32 × 32 incident cells,
/// blind to the glazed ceramics' and the chairs' narrow lobes), the walls were −2.43 %,
/// which fails. Drawn with their albedo's mean over all views instead of their albedo
/// towards the eye (`surface::albedo_towards`), the walls were 2.8 % too dark (seen from
/// nearer their normal) and the floor 8.6 % too bright (seen at 60–85° off its normal).
#[test]
fn the_walls_and_floor_are_within_two_per_cent_of_the_path_tracer() {
    let [(walls, walls_se), (floor, floor_se)] = walls_and_floor(|_| {});
    assert!(
        walls.abs() <= 0.02 + 3.0 * walls_se,
        "the walls {:+.2} % off the path tracer's (allowed 2 % + {:.2} %)",
        100.0 * walls,
        300.0 * walls_se
    );
    assert!(
        floor.abs() <= 0.02 + 3.0 * floor_se,
        "the floor {:+.2} % off the path tracer's (allowed 2 % + {:.2} %)",
        100.0 * floor,
        300.0 * floor_se
    );
}
