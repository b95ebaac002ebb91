//! The emitters' caustics per pixel (`holocave_vlf::caustics`): the photon map carries the
//! light the field's caustic part holds.

use std::path::Path;
use std::sync::Arc;

use glam::{Vec3, Vec4};
use holocave_scene::color::luminance;
use holocave_scene::{Daylight, LoadOptions, Material, PunctualLight, Scene, Sun};
use holocave_tracer::fresnel;
use holocave_tracer::lights::Lights;
use holocave_vlf::Settings;
use holocave_vlf::caustics::{Caustics, PHOTONS};

use crate::common;

fn cornell() -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    Arc::new(Scene::load(&path, &LoadOptions::default()).expect("the Cornell box loads"))
}

/// The mirrors' base colour (a metal's: its reflectance at normal incidence).
const MIRROR_BASE: f32 = 0.9;

/// A smooth metal mirror.
fn mirror() -> Material {
    Material {
        name: "mirror".into(),
        base_color: Vec4::new(MIRROR_BASE, MIRROR_BASE, MIRROR_BASE, 1.0),
        metallic: 1.0,
        roughness: 0.0,
        ..Material::default()
    }
}

/// The mirror's reflectance at `cos` from its normal (Schlick's, as the tracer's metal).
fn reflectance(cos: f32) -> f32 {
    fresnel::schlick(Vec3::splat(MIRROR_BASE), Vec3::ONE, cos).x
}

/// The flux the photons bring to the surfaces equals the flux of the field's caustic
/// part (its elements' irradiance times their areas).
#[test]
fn the_photons_carry_the_fields_caustic_flux() {
    let scene = cornell();
    let settings = Settings::default();
    let (state, _) = common::bake_quiet(&scene, &settings);
    let elements = holocave_vlf::layout(&scene, &settings);
    let (area, _) = elements.areas_and_centres(&scene);
    let field: f64 = (state.caustics.iter().zip(&area))
        .map(|(c, a)| f64::from(luminance((*c).into()) * a))
        .sum();
    let map = Caustics::trace(&scene, &Lights::new(&scene), PHOTONS).expect("photons");
    let photons = f64::from(luminance(map.power()));
    eprintln!("field {field}, photons {photons} ({} stored)", map.len());
    assert!(
        (photons / field - 1.0).abs() < 0.05,
        "{photons} against {field}"
    );
}

/// A small lamp above a horizontal mirror lights the ceiling above it through the
/// mirror: the photons' irradiance there is the mirror image of the lamp's, times the
/// mirror's reflectance, blocked where the lamp's back stands in the way, integrated
/// here by a 64 × 64 midpoint rule over the lamp.
#[test]
fn a_lamps_image_in_a_mirror_lights_the_ceiling_as_the_image_would() {
    const L: f32 = 10.0;
    let materials = vec![
        mirror(),
        common::lambert("lamp", 0.0, Vec3::splat(L)),
        common::lambert("ceiling", 0.5, Vec3::ZERO),
    ];
    // The mirror at y = 0 facing up, the lamp at y = 1 facing down, the ceiling at y = 2
    // facing down.
    let quads = [
        (
            common::quad(Vec3::new(-2.0, 0.0, 2.0), Vec3::X * 4.0, Vec3::Z * -4.0),
            0,
        ),
        (
            common::quad(Vec3::new(-0.1, 1.0, -0.1), Vec3::X * 0.2, Vec3::Z * 0.2),
            1,
        ),
        (
            common::quad(Vec3::new(-3.0, 2.0, -3.0), Vec3::X * 6.0, Vec3::Z * 6.0),
            2,
        ),
    ];
    let tris: Vec<([Vec3; 3], u32)> = (quads.iter())
        .flat_map(|(q, m)| q.iter().map(move |t| (*t, *m)))
        .collect();
    let scene = common::scene("a lamp over a mirror", &tris, materials, Vec::new());
    let map = Caustics::trace(&scene, &Lights::new(&scene), PHOTONS).expect("photons");
    let image = |p: Vec3| {
        let n = 64;
        let side = 0.2 / n as f32;
        let mut e = 0.0;
        for i in 0..n {
            for j in 0..n {
                let q = Vec3::new(
                    -0.1 + (i as f32 + 0.5) * side,
                    -1.0,
                    -0.1 + (j as f32 + 0.5) * side,
                );
                let d = p - q;
                let cos = d.y / d.length();
                // Where the reflected ray passes the lamp's height, the lamp's back.
                let at_lamp = q + d * (2.0 / 3.0);
                if at_lamp.x.abs() < 0.1 && at_lamp.z.abs() < 0.1 {
                    continue;
                }
                let r = reflectance(cos);
                e += L * r * cos * cos / d.length_squared() * side * side;
            }
        }
        e
    };
    let (mut sum, mut worst) = (0.0f32, 0.0f32);
    // Away from the lamp's shadow (within 0.25 m of the centre), where an estimate's disc
    // would straddle its edge.
    let points: Vec<Vec3> = (0..16)
        .map(|k| {
            let (a, r) = (k as f32 * 0.39, 0.5 + 0.1 * (k % 4) as f32);
            Vec3::new(r * a.cos(), 2.0, r * a.sin())
        })
        .collect();
    for p in &points {
        let want = image(*p);
        let got = luminance(map.irradiance(*p, Vec3::NEG_Y, None));
        eprintln!("{p}: photons {got:.5}, the image {want:.5}");
        sum += got / want;
        worst = worst.max((got / want - 1.0).abs());
    }
    let mean = sum / points.len() as f32;
    // An estimate of NEAREST photons or more is off by about 1/√NEAREST (1/8); the mean
    // of sixteen by a quarter of that: both asserted at four of their deviations.
    assert!((mean - 1.0).abs() < 0.125, "mean ratio {mean}");
    assert!(worst < 0.5, "worst ratio off by {worst}");
}

/// A mirror floor lit by `daylight` and `lights`, a strip of ceiling beside where the
/// light comes down, and the photons' irradiance at sixteen points of the strip against
/// `want`; returns the mean ratio and the worst ratio's distance from one.
fn ceiling_through_a_mirror(
    daylight: Daylight,
    lights: Vec<PunctualLight>,
    want: &dyn Fn(Vec3) -> f32,
) -> (f32, f32) {
    let materials = vec![mirror(), common::lambert("ceiling", 0.5, Vec3::ZERO)];
    // The mirror at y = 0 facing up; the ceiling's strip at y = 2, x from −3 to −1,
    // facing down (the sun from +x at 60° passes beside it on its way down).
    let quads = [
        (
            common::quad(Vec3::new(-2.0, 0.0, 2.0), Vec3::X * 4.0, Vec3::Z * -4.0),
            0,
        ),
        (
            common::quad(Vec3::new(-3.0, 2.0, -2.0), Vec3::X * 2.0, Vec3::Z * 4.0),
            1,
        ),
    ];
    let tris: Vec<([Vec3; 3], u32)> = (quads.iter())
        .flat_map(|(q, m)| q.iter().map(move |t| (*t, *m)))
        .collect();
    let scene = common::scene_of("a light over a mirror", &tris, materials, |p| {
        p.daylight = daylight;
        p.lights = lights;
    });
    let map = Caustics::trace(&scene, &Lights::new(&scene), PHOTONS).expect("photons");
    let (mut sum, mut worst) = (0.0f32, 0.0f32);
    for k in 0..16 {
        let p = Vec3::new(
            -2.6 + 0.4 * (k % 4) as f32,
            2.0,
            -0.9 + 0.6 * (k / 4) as f32,
        );
        let got = luminance(map.irradiance(p, Vec3::NEG_Y, None));
        let want = want(p);
        eprintln!("{p}: photons {got:.5}, expected {want:.5}");
        sum += got / want;
        worst = worst.max((got / want - 1.0).abs());
    }
    (sum / 16.0, worst)
}

/// The sun and a point light over a mirror light the ceiling through it: the sun's patch
/// `R(θ) E cos θ` (its radiance times the disc's solid angle), the point light as its
/// mirror image would, `R(θ) I cos θ / d²`. Neither reaches the walls otherwise: their
/// shadow rays stop at the mirror, and the field's lines carry no sun.
#[test]
fn the_sun_and_a_point_light_reach_the_ceiling_through_a_mirror() {
    let sun = Sun {
        direction: Vec3::new(0.5, 3f32.sqrt() / 2.0, 0.0),
        angular_radius: 0.0047,
        radiance: Vec3::splat(1000.0),
    };
    let e = sun.radiance.x * sun.solid_angle();
    let cos = 3f32.sqrt() / 2.0;
    let daylight = Daylight {
        sun: Some(sun),
        sky: None,
        ..Default::default()
    };
    let (mean, worst) =
        ceiling_through_a_mirror(daylight, Vec::new(), &|_| reflectance(cos) * e * cos);
    // As for the lamp above: four deviations of the mean of sixteen, and of one.
    assert!((mean - 1.0).abs() < 0.125, "the sun: mean ratio {mean}");
    assert!(worst < 0.5, "the sun: worst ratio off by {worst}");

    let at = Vec3::new(1.0, 1.5, 0.0);
    let light = common::point_light(at, 20.0);
    let intensity = light.intensity.x;
    let image = Vec3::new(at.x, -at.y, at.z);
    let (mean, worst) = ceiling_through_a_mirror(Daylight::default(), vec![light], &|p| {
        let d = p - image;
        let cos = d.y / d.length();
        reflectance(cos) * intensity * cos / d.length_squared()
    });
    assert!(
        (mean - 1.0).abs() < 0.125,
        "the point light: mean ratio {mean}"
    );
    assert!(worst < 0.5, "the point light: worst ratio off by {worst}");
}
