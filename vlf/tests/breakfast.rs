//! The breakfast room (`../shared/scenes/breakfast_room`, skipped when absent unless
//! `HOLOCAVE_REQUIRE_SHARED=1`): what made its walls 25 % too bright in `vlf view`
//! against `render`. The walls (WhiteMatt: a rough dielectric, base 0.9, GGX α = 0.94,
//! F0 = 0.04) are lit almost only by inter-reflected light, so every bounce multiplies by
//! their albedo, and the light field's albedo was the normal-incidence
//! `base (1 − F0)² + F0` = 0.869 where the path tracer's BSDF reflects 0.772 of evenly
//! arriving light (its Lambertian base dimmed by `(1 − F(θo))(1 − F(θi))`, which grows
//! towards grazing angles): 12.6 % too much per bounce, about 25 % after the room's
//! bounces (the light sent out falls by ≈ 0.67 per bounce in its bake). This test holds
//! every material the light field draws as diffuse to the tracer's own BSDF; and the walls
//! as the walls of a CAVE draw them (the light field and the direct light per pixel)
//! within 2 % of the path tracer's, which needs the small glossy elements (the chairs,
//! cups, teapot: 263 k triangles far smaller than a line's cross-section) drawn diffuse
//! and pooled rather than each given a tile that keeps only a fraction of its light.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_vlf::Settings;
use holocave_vlf::surface::diffuse_albedo;

fn shared_scene(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/scenes")
        .join(rel);
    if p.exists() {
        return Some(p);
    }
    let why = format!(
        "{} is absent (the shared scenes live in ../shared/scenes)",
        p.display()
    );
    assert!(
        std::env::var("HOLOCAVE_REQUIRE_SHARED").as_deref() != Ok("1"),
        "HOLOCAVE_REQUIRE_SHARED=1 and {why}"
    );
    eprintln!("SKIPPED: {why}");
    None
}

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
    let Some(path) = shared_scene("breakfast_room/BreakfastRoom.gltf") else {
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

/// `CameraMain` at 160 × 90 as the walls draw it at the first frame, bake with the
/// default settings, against the mean of two 256-spp path-traced renders: the walls (the
/// pixels whose centre sees WhiteMatt) and the floor (FloorTiles) each within 2 % in mean
/// luminance (the goal for the mean bias), plus three standard errors of the
/// references' mean (half their difference). Both are rough dielectrics drawn as diffuse
/// elements; drawn with their albedo's mean over all views instead of their albedo
/// towards the eye (`surface::albedo_towards`), the walls were 2.8 % too dark (seen from
/// nearer their normal) and the floor 8.6 % too bright (seen at 60–85° off its normal).
/// With a tile on every glossy element, as before that, the walls were 3.8 % too dark
/// (the chairs black, sending them too little).
#[test]
fn the_walls_and_floor_are_within_a_few_percent_of_the_path_tracer() {
    let Some(path) = shared_scene("breakfast_room/BreakfastRoom.gltf") else {
        return;
    };
    let daylight =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/breakfast_room.daylight.toml");
    let scene = std::sync::Arc::new(
        Scene::load(
            &path,
            &LoadOptions {
                daylight: Some(daylight),
                ..LoadOptions::default()
            },
        )
        .expect("the breakfast room loads"),
    );
    let camera = (scene.cameras.iter())
        .find(|c| c.name == "CameraMain")
        .expect("CameraMain");
    let view = holocave_cave::WallView::through_camera(camera, 160, 90);
    let settings = Settings::default();
    let (state, _) =
        holocave_vlf::bake(&scene, &settings, None, &|_| {}, &mut |_| Ok::<(), ()>(()))
            .expect("bake");
    let vis = holocave_vlf::Visibility::of(scene.clone(), &settings);
    let direct = holocave_vlf::PixelDirect::new(scene.clone());
    let drawn = vis.render_with_direct(&view, &state.indirect_values(), 2, &direct, 1, None);
    let tracer = holocave_tracer::Tracer::new(scene.clone(), Default::default());
    let refs: Vec<_> = (1..=2)
        .map(|seed| holocave_tracer::render::render(&tracer, &view, 256, seed, &|| {}))
        .collect();
    // The floor's pixels: those whose centre's ray first meets FloorTiles.
    let pixels_of = |name: &str| {
        let m = (scene.materials.iter())
            .position(|m| m.name == name)
            .expect("the material") as u32;
        let sees = |x: u32, y: u32| {
            let ray = view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            (scene.closest_hit(&ray, f32::INFINITY))
                .is_some_and(|h| scene.triangle_shading(h.triangle).material == m)
        };
        let pixels: Vec<(u32, u32)> = (0..view.height)
            .flat_map(|y| (0..view.width).map(move |x| (x, y)))
            .filter(|&(x, y)| sees(x, y))
            .collect();
        pixels
    };
    let floor_pixels = pixels_of("FloorTiles");
    let wall_pixels = pixels_of("WhiteMatt");
    assert!(
        floor_pixels.len() > 500,
        "{} floor pixels",
        floor_pixels.len()
    );
    let sum = |img: &holocave_tracer::film::Image, pixels: &mut dyn Iterator<Item = (u32, u32)>| {
        pixels
            .map(|(x, y)| f64::from(holocave_scene::color::luminance(img.at(x, y))))
            .sum::<f64>()
    };
    let upper = |img: &holocave_tracer::film::Image| {
        sum(
            img,
            &mut (0..img.height / 2).flat_map(|y| (0..img.width).map(move |x| (x, y))),
        )
    };
    let floor_sum =
        |img: &holocave_tracer::film::Image| sum(img, &mut floor_pixels.iter().copied());
    let wall_sum = |img: &holocave_tracer::film::Image| sum(img, &mut wall_pixels.iter().copied());
    let upper_bias = upper(&drawn) / (0.5 * (upper(&refs[0]) + upper(&refs[1]))) - 1.0;
    eprintln!("the image's upper half: {:+.2} %", 100.0 * upper_bias);
    for (what, region) in [
        (
            "walls",
            &wall_sum as &dyn Fn(&holocave_tracer::film::Image) -> f64,
        ),
        ("floor", &floor_sum),
    ] {
        let (a, b) = (region(&refs[0]), region(&refs[1]));
        let reference = 0.5 * (a + b);
        let se = 0.5 * (a - b).abs() / reference;
        let bias = region(&drawn) / reference - 1.0;
        eprintln!(
            "{what}: {:+.2} % (references {:.2} % apart)",
            100.0 * bias,
            100.0 * (a - b).abs() / reference
        );
        assert!(
            bias.abs() <= 0.02 + 3.0 * se,
            "the {what} {:+.2} % off the path tracer's (allowed 2 % + {:.2} %)",
            100.0 * bias,
            300.0 * se
        );
    }
}
