//! Scenes and helpers shared by the VLF's integration tests.

#![allow(dead_code)]

use std::convert::Infallible;
use std::path::Path;

use glam::{Vec2, Vec3, Vec4};
use holocave_cave::Size;
use holocave_scene::{Material, PunctualKind, PunctualLight, Scene, SceneParts, TriangleShading};
use holocave_vlf::{Settings, State, Stats, bake};

/// A pure Lambert material (no specular layer, not metallic) with albedo `rho`, emitting
/// radiance `emission` from its front side.
pub fn lambert(name: &str, rho: f32, emission: Vec3) -> Material {
    Material {
        name: name.into(),
        base_color: Vec4::new(rho, rho, rho, 1.0),
        metallic: 0.0,
        roughness: 1.0,
        specular: 0.0,
        emissive: emission,
        ..Material::default()
    }
}

/// The quad `o, o + a, o + a + b, o + b` as two triangles whose right angle is at their
/// first vertex, so each triangle's elements are squares of side `|a| / r` (for `|a| =
/// |b|`). The front faces along `a × b`.
pub fn quad(o: Vec3, a: Vec3, b: Vec3) -> [[Vec3; 3]; 2] {
    [[o, o + a, o + b], [o + a + b, o + b, o + a]]
}

/// The square `[−half, half]²` of the plane y = 0, facing +y, as two triangles.
pub fn floor(half: f32) -> [[Vec3; 3]; 2] {
    quad(
        Vec3::new(-half, 0.0, -half),
        Vec3::Z * 2.0 * half,
        Vec3::X * 2.0 * half,
    )
}

/// A scene of `(triangle, material)` pairs, with `more` filling in the rest of its parts
/// (lights, daylight).
pub fn scene_of(
    name: &str,
    triangles: &[([Vec3; 3], u32)],
    materials: Vec<Material>,
    more: impl FnOnce(&mut SceneParts),
) -> Scene {
    let mut parts = SceneParts {
        name: name.into(),
        positions: triangles.iter().map(|(t, _)| *t).collect(),
        shading: triangles
            .iter()
            .map(|&(_, material)| TriangleShading {
                normals: None,
                uvs: [Vec2::ZERO; 3],
                material,
            })
            .collect(),
        materials,
        ..SceneParts::default()
    };
    more(&mut parts);
    Scene::from_parts(parts, Path::new(name)).expect("a valid test scene")
}

/// A scene of `(triangle, material)` pairs lit by `lights`.
pub fn scene(
    name: &str,
    triangles: &[([Vec3; 3], u32)],
    materials: Vec<Material>,
    lights: Vec<PunctualLight>,
) -> Scene {
    scene_of(name, triangles, materials, |p| p.lights = lights)
}

/// The cube `[0, side]³`, every face facing inwards, all of one material.
pub fn closed_box(name: &str, side: f32, material: Material) -> Scene {
    let mut tris = Vec::new();
    for axis in 0..3 {
        let mut a = Vec3::ZERO;
        let mut b = Vec3::ZERO;
        a[(axis + 1) % 3] = side;
        b[(axis + 2) % 3] = side;
        // a × b points along +axis: the face at 0 faces inwards as it is, the face at
        // `side` with a and b swapped.
        let mut far = Vec3::ZERO;
        far[axis] = side;
        for q in [quad(Vec3::ZERO, a, b), quad(far, b, a)] {
            for t in q {
                tris.push((t, 0));
            }
        }
    }
    scene(name, &tris, vec![material], vec![])
}

/// A point light (`KHR_lights_punctual`) of radiant intensity `intensity` at `position`.
pub fn point_light(position: Vec3, intensity: f32) -> PunctualLight {
    PunctualLight {
        name: "point".into(),
        kind: PunctualKind::Point,
        position,
        direction: Vec3::NEG_Y,
        intensity: Vec3::splat(intensity),
        range: None,
    }
}

/// A small, quick bake's settings: 12 directions of 16² lines, 25 cm elements.
pub fn small_settings() -> Settings {
    Settings {
        directions: 12,
        resolution: 16,
        element_size: Some(0.25),
        direct_samples: 4,
        tolerance: 1e-2,
        max_bounces: 50,
        ..Settings::default()
    }
}

/// A bake with no progress and no saving.
pub fn bake_quiet(scene: &Scene, settings: &Settings) -> (State, Stats) {
    match bake::<Infallible>(scene, settings, None, &|_| {}, &mut |_| Ok(())) {
        Ok(r) => r,
        Err(e) => match e {},
    }
}

/// Asserts two states are equal bit for bit (`==` on floats would let `0.0 == -0.0` and
/// fail on NaN).
pub fn assert_same_bits(a: &State, b: &State, what: &str) {
    let bits = |v: &[[f32; 3]]| -> Vec<u32> { v.iter().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(a.bounces, b.bounces, "{what}: bounces");
    assert_eq!(a.converged, b.converged, "{what}: converged");
    assert_eq!(a.arrived.to_bits(), b.arrived.to_bits(), "{what}: arrived");
    let r = |s: &State| -> Vec<u64> { s.residuals.iter().map(|x| x.to_bits()).collect() };
    assert_eq!(r(a), r(b), "{what}: residuals");
    assert!(
        bits(&a.irradiance) == bits(&b.irradiance),
        "{what}: irradiance differs"
    );
    assert!(
        bits(&a.last) == bits(&b.last),
        "{what}: last bounce's radiance differs"
    );
    assert!(
        bits(&a.tiles) == bits(&b.tiles),
        "{what}: glossy tiles differ"
    );
    assert!(
        bits(&a.tiles_last) == bits(&b.tiles_last),
        "{what}: glossy tiles' last bounce differs"
    );
    assert!(
        bits(&a.direct) == bits(&b.direct) && bits(&a.tiles_direct) == bits(&b.tiles_direct),
        "{what}: the direct parts differ"
    );
}

/// The Cornell box with its white walls made a glossy metal (GGX α = 0.09): every part
/// of a bake at work, glossy tiles among them (fed by the area light's next-event samples
/// and by the lines, read by lines and through the mirror's links).
pub fn glossy_cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    let mut scene = Scene::load(&path, &holocave_scene::LoadOptions::default()).unwrap();
    let white = scene
        .materials
        .iter()
        .position(|m| m.name == "white")
        .expect("the white walls");
    let m = &mut scene.materials[white];
    m.metallic = 1.0;
    m.roughness = 0.3;
    scene
}

/// A converged reference of `view`: the mean of two path-traced renders of `spp` paths
/// with different seeds, its own relative MSE (a quarter of the two renders' against each
/// other), and the two renders.
pub fn two_seed_reference(
    scene: &std::sync::Arc<Scene>,
    view: &holocave_cave::WallView,
    spp: u32,
) -> (
    holocave_tracer::film::Image,
    f64,
    [holocave_tracer::film::Image; 2],
) {
    let tracer =
        holocave_tracer::Tracer::new(scene.clone(), holocave_tracer::TraceSettings::default());
    let a = holocave_tracer::render::render(&tracer, view, spp, 1, &|| {});
    let b = holocave_tracer::render::render(&tracer, view, spp, 2, &|| {});
    let mut mean = holocave_tracer::film::Image::new(view.size.width, view.size.height);
    for (r, (a, b)) in mean.pixels.iter_mut().zip(a.pixels.iter().zip(&b.pixels)) {
        *r = (*a + *b) * 0.5;
    }
    let noise = a.relative_mse(&b) / 4.0;
    (mean, noise, [a, b])
}

/// A 32 × 24 view through a 2 m × 1.5 m screen at z = 0 from an eye 1 m in front of it,
/// a little off its centre: what the edge tests draw (`glow_edges`, `surface_edges`).
pub fn edge_view() -> holocave_cave::WallView {
    holocave_cave::WallView {
        eye: Vec3::new(0.03, 0.02, 1.0),
        pa: Vec3::new(-1.0, -0.75, 0.0),
        pb: Vec3::new(1.0, -0.75, 0.0),
        pc: Vec3::new(-1.0, 0.75, 0.0),
        size: Size::new(32, 24),
    }
}

/// The pixels of `view` holding the corners of the rectangle from `o` spanning `a` along
/// x and `b` along y.
pub fn corner_pixels(view: &holocave_cave::WallView, o: Vec3, (a, b): (f32, f32)) -> Vec<usize> {
    [(0.0, 0.0), (a, 0.0), (0.0, b), (a, b)]
        .iter()
        .filter_map(|&(x, y)| {
            let c = o + Vec3::new(x, y, 0.0);
            let (px, py) = view.project((c - view.eye).as_dvec3())?;
            Some(py as usize * view.size.width as usize + px as usize)
        })
        .collect()
}

/// A wall at z = −2 facing +z (material 0, triangles 0 and 1) and before it, at `o` in
/// z = −1.5, a square of `a` × `b` (material 1, triangles 2 and 3): what the edge tests
/// look at through [`edge_view`].
pub fn square_before_a_wall(
    name: &str,
    o: Vec3,
    (a, b): (f32, f32),
    [wall, square]: [Material; 2],
) -> Scene {
    let back = quad(Vec3::new(-5.0, -5.0, -2.0), Vec3::X * 10.0, Vec3::Y * 10.0);
    let front = quad(o, Vec3::X * a, Vec3::Y * b);
    let tris: Vec<([Vec3; 3], u32)> = (back.iter().map(|t| (*t, 0)))
        .chain(front.iter().map(|t| (*t, 1)))
        .collect();
    scene(name, &tris, vec![wall, square], Vec::new())
}
