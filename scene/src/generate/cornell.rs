//! The holocave Cornell box: a 2 m box open towards +Z, diffuse (pure Lambert) walls,
//! a square area light in the ceiling, a perfect-mirror box and a glass sphere.

use glam::{Quat, Vec3};
use serde_json::json;

use super::GltfWriter;
use super::shapes::{cube, quad, sphere};

fn lambert(w: &mut GltfWriter, name: &str, rgb: [f32; 3]) -> usize {
    w.material(json!({
        "name": name,
        "pbrMetallicRoughness": { "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 },
        "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } }
    }))
}

/// Corners of the box: x in [−1, 1], y in [0, 2], z in [−1, 1]; the light is 0.5 m square.
pub fn cornell_box() -> String {
    let mut w = GltfWriter::default();
    let white = lambert(&mut w, "white", [0.73, 0.73, 0.73]);
    let red = lambert(&mut w, "red", [0.63, 0.065, 0.05]);
    let green = lambert(&mut w, "green", [0.14, 0.45, 0.091]);
    let light = w.material(json!({
        "name": "light",
        "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0 },
        "emissiveFactor": [1.0, 0.85, 0.65],
        "extensions": {
            "KHR_materials_emissive_strength": { "emissiveStrength": 15.0 },
            "KHR_materials_specular": { "specularFactor": 0.0 }
        }
    }));
    let mirror = w.material(json!({
        "name": "mirror",
        "pbrMetallicRoughness": { "baseColorFactor": [0.95, 0.95, 0.95, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.0 }
    }));
    let glass = w.material(json!({
        "name": "glass",
        "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0 },
        "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_ior": { "ior": 1.5 } }
    }));

    let x = Vec3::X * 2.0;
    let y = Vec3::Y * 2.0;
    let z = Vec3::Z * 2.0;
    let walls = [
        ("floor", quad(Vec3::new(-1.0, 0.0, 1.0), x, -z), white),
        ("ceiling", quad(Vec3::new(-1.0, 2.0, -1.0), x, z), white),
        ("back", quad(Vec3::new(-1.0, 0.0, -1.0), x, y), white),
        ("left", quad(Vec3::new(-1.0, 0.0, 1.0), -z, y), red),
        ("right", quad(Vec3::new(1.0, 0.0, -1.0), z, y), green),
        (
            "light",
            quad(Vec3::new(-0.25, 1.98, -0.25), Vec3::X * 0.5, Vec3::Z * 0.5),
            light,
        ),
    ];
    for (name, (p, n, i), m) in walls {
        let mesh = w.mesh(name, &p, &n, &i, m);
        w.node(name, mesh, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    }
    let (p, n, i) = cube();
    let mesh = w.mesh("mirror box", &p, &n, &i, mirror);
    w.node(
        "mirror box",
        mesh,
        Vec3::new(-0.4, 0.6, -0.35),
        Quat::from_rotation_y(0.35),
        Vec3::new(0.6, 1.2, 0.6),
    );
    let (p, n, i) = sphere(24, 48);
    let mesh = w.mesh("glass sphere", &p, &n, &i, glass);
    w.node(
        "glass sphere",
        mesh,
        Vec3::new(0.45, 0.35, 0.3),
        Quat::IDENTITY,
        Vec3::splat(0.35),
    );
    w.camera("front", Vec3::new(0.0, 1.0, 3.4), Quat::IDENTITY, 0.6911);
    w.finish()
}
