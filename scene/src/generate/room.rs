//! A small interior: a 5 m × 4 m room, 3 m high, with a window in its left wall that
//! lets in a low sun (see `DAYLIGHT`), a glossy floor, a table, a block and a ceiling lamp.

use glam::{Quat, Vec3};
use serde_json::json;

use super::GltfWriter;
use super::shapes::{Shape, append, cube, quad};

/// The daylight written beside the room: a low afternoon sun through the window and a
/// CIE clear sky.
pub const DAYLIGHT: &str = "\
# Daylight for room.gltf: a low sun through the window (in the wall at x = -2.5).
[sun]
elevation_deg = 25.0
azimuth_deg = 250.0
angular_diameter_deg = 0.53
irradiance = [600.0, 560.0, 500.0]

[sky]
model = \"cie_clear\"
zenith_radiance = [12.0, 16.0, 26.0]
ground_albedo = 0.2
";

fn material(w: &mut GltfWriter, name: &str, rgb: [f32; 3], roughness: f32, specular: f32) -> usize {
    w.material(json!({
        "name": name,
        "pbrMetallicRoughness": { "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness },
        "extensions": { "KHR_materials_specular": { "specularFactor": specular } }
    }))
}

/// The room's shell: the left wall (x = −2.5) has a window z in [−1, 1], y in [0.9, 2.2].
fn shell() -> (Shape, Shape) {
    let (x0, x1, y1, z0, z1) = (-2.5f32, 2.5f32, 3.0f32, -2.0f32, 2.0f32);
    let mut walls = (vec![], vec![], vec![]);
    append(
        &mut walls,
        quad(Vec3::new(x0, y1, z0), Vec3::X * 5.0, Vec3::Z * 4.0),
    ); // ceiling
    append(
        &mut walls,
        quad(Vec3::new(x0, 0.0, z0), Vec3::Y * y1, Vec3::X * 5.0),
    ); // back
    append(
        &mut walls,
        quad(Vec3::new(x0, 0.0, z1), Vec3::X * 5.0, Vec3::Y * y1),
    ); // front
    append(
        &mut walls,
        quad(Vec3::new(x1, 0.0, z0), Vec3::Z * 4.0, Vec3::Y * y1),
    ); // right
    // Left wall around the window, facing +X: four pieces.
    let left = |za: f32, zb: f32, ya: f32, yb: f32| {
        quad(
            Vec3::new(x0, ya, zb),
            Vec3::Z * (za - zb),
            Vec3::Y * (yb - ya),
        )
    };
    append(&mut walls, left(z0, -1.0, 0.0, y1));
    append(&mut walls, left(1.0, z1, 0.0, y1));
    append(&mut walls, left(-1.0, 1.0, 0.0, 0.9));
    append(&mut walls, left(-1.0, 1.0, 2.2, y1));
    let floor = quad(Vec3::new(x0, 0.0, z1), Vec3::X * 5.0, Vec3::Z * -4.0);
    (walls, floor)
}

pub fn room() -> String {
    let mut w = GltfWriter::default();
    let wall_m = material(&mut w, "plaster", [0.8, 0.78, 0.74], 1.0, 0.0);
    let floor_m = material(&mut w, "varnished wood", [0.45, 0.28, 0.16], 0.25, 1.0);
    let table_m = material(&mut w, "white laminate", [0.85, 0.85, 0.82], 0.4, 1.0);
    let block_m = material(&mut w, "blue fabric", [0.12, 0.2, 0.45], 1.0, 0.0);
    let lamp_m = w.material(json!({
        "name": "lamp",
        "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0 },
        "emissiveFactor": [1.0, 0.8, 0.55],
        "extensions": {
            "KHR_materials_emissive_strength": { "emissiveStrength": 8.0 },
            "KHR_materials_specular": { "specularFactor": 0.0 }
        }
    }));
    let (walls, floor) = shell();
    let m = w.mesh("walls", &walls.0, &walls.1, &walls.2, wall_m);
    w.node("walls", m, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let m = w.mesh("floor", &floor.0, &floor.1, &floor.2, floor_m);
    w.node("floor", m, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let (p, n, i) = cube();
    let table = w.mesh("table part", &p, &n, &i, table_m);
    w.node(
        "table top",
        table,
        Vec3::new(0.3, 0.74, -0.2),
        Quat::IDENTITY,
        Vec3::new(1.4, 0.04, 0.8),
    );
    for (dx, dz) in [(-0.62, -0.32), (0.62, -0.32), (-0.62, 0.32), (0.62, 0.32)] {
        w.node(
            "table leg",
            table,
            Vec3::new(0.3 + dx, 0.36, -0.2 + dz),
            Quat::IDENTITY,
            Vec3::new(0.05, 0.72, 0.05),
        );
    }
    let block = w.mesh("block", &p, &n, &i, block_m);
    w.node(
        "block",
        block,
        Vec3::new(1.6, 0.4, -1.35),
        Quat::from_rotation_y(0.3),
        Vec3::new(1.2, 0.8, 0.9),
    );
    let (p, n, i) = quad(Vec3::new(-0.3, 2.99, -0.3), Vec3::X * 0.6, Vec3::Z * 0.6);
    let lamp = w.mesh("lamp", &p, &n, &i, lamp_m);
    w.node(
        "lamp",
        lamp,
        Vec3::new(0.3, 0.0, -0.2),
        Quat::IDENTITY,
        Vec3::ONE,
    );
    w.camera(
        "entrance",
        Vec3::new(1.8, 1.6, 1.8),
        Quat::from_rotation_y(0.6),
        1.0,
    );
    w.finish()
}
