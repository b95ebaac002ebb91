//! A near-mirror metal without a tile is drawn as a mirror (`surface::near_mirror`): what
//! a pixel shows on it is what it reflects, not a diffuse drawing of its irradiance.

mod common;

use std::sync::Arc;

use glam::{Vec3, Vec4};
use holocave_scene::{Material, Ray, Scene};
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, Visibility};

const GLOW: f32 = 3.0;

/// A small metal square in the plane z = 0 facing +z, an eye in front of it, and a wall
/// glowing `GLOW` behind the eye (z = 2, facing −z), black to light.
fn metal_before_a_glow(roughness: f32) -> Arc<Scene> {
    let square = common::quad(Vec3::new(-0.05, -0.05, 0.0), Vec3::X * 0.1, Vec3::Y * 0.1);
    let wall = common::quad(Vec3::new(-5.0, -5.0, 2.0), Vec3::Y * 10.0, Vec3::X * 10.0);
    let metal = Material {
        name: "chrome".into(),
        base_color: Vec4::new(0.8, 0.7, 0.6, 1.0),
        metallic: 1.0,
        roughness,
        ..Material::default()
    };
    let mut tris: Vec<([Vec3; 3], u32)> = square.iter().map(|t| (*t, 0)).collect();
    tris.extend(wall.iter().map(|t| (*t, 1)));
    Arc::new(common::scene_of(
        "metal before a glow",
        &tris,
        vec![metal, common::lambert("glow", 0.0, Vec3::splat(GLOW))],
        |_| {},
    ))
}

/// Chrome (GGX α 0.03) with no tile shows the glow it mirrors, times its Fresnel
/// reflectance at normal incidence (its base colour), and the pixel's point for the direct
/// light is on the wall it mirrors; a rougher metal (α 0.09) is drawn diffuse as before
/// (here black: the light field is empty).
#[test]
fn a_near_mirror_without_a_tile_shows_what_it_mirrors() {
    let settings = Settings {
        glossy_alpha: 0.0,
        ..Settings::default()
    };
    let zeros = |vis: &Visibility| vec![[0.0f32; 3]; vis.tiles().elements as usize];
    let eye = Ray::new(Vec3::new(0.01, 0.02, 1.0), -Vec3::Z);
    let chrome = Visibility::of(metal_before_a_glow(0.03f32.sqrt()), &settings);
    let (l, point) = chrome.lookup_and_point(eye);
    let shown = shade_one(&l, &zeros(&chrome));
    let expected = Vec3::new(0.8, 0.7, 0.6) * GLOW;
    assert!(
        (shown - expected).abs().max_element() < 1e-4 * GLOW,
        "chrome shows {shown}, the glow it mirrors {expected}"
    );
    let wall = point.expect("the mirrored wall's point").triangle;
    assert!(
        wall >= 2,
        "the point is on the wall, not the metal (triangle {wall})"
    );
    let rough = Visibility::of(metal_before_a_glow(0.3), &settings);
    let (l, point) = rough.lookup_and_point(eye);
    assert_eq!(shade_one(&l, &zeros(&rough)), Vec3::ZERO, "drawn diffuse");
    assert!(point.expect("a point on the metal").triangle < 2);
}
