//! A glass pane before a dark wall, a bright wall behind the eye: the pane lets the dark
//! wall through and reflects the bright one, at both of its faces. The walls follow
//! glass's stronger branch to a surface and shade the surfaces its weaker branches end on
//! from the field (`Chain::beside`): without them a window or a glass sphere showed only
//! what it lets through, dark where the path tracer shows the room reflected.

use crate::common;

use std::sync::Arc;

use glam::{Vec2, Vec3};
use holocave_scene::Material;
use holocave_tracer::fresnel;
use holocave_vlf::{Settings, Visibility};

const DARK: f32 = 1.0;
const BRIGHT: f32 = 100.0;
const IOR: f32 = 1.5;

#[test]
fn a_glass_pane_shows_the_room_it_reflects() {
    let glass = Material {
        name: "glass".into(),
        metallic: 0.0,
        roughness: 0.0,
        transmission: 1.0,
        ior: IOR,
        ..Material::default()
    };
    let materials = vec![
        common::lambert("dark wall", 0.5, Vec3::ZERO),
        common::lambert("bright wall", 0.5, Vec3::ZERO),
        glass,
    ];
    // The dark wall at z = −2 facing +z, the bright one at z = 3 facing −z, the pane's
    // two faces at z = −0.5 (facing +z) and z = −0.55 (facing −z).
    let quads = [
        (
            common::quad(Vec3::new(-5.0, -5.0, -2.0), Vec3::X * 10.0, Vec3::Y * 10.0),
            0,
        ),
        (
            common::quad(Vec3::new(-5.0, -5.0, 3.0), Vec3::Y * 10.0, Vec3::X * 10.0),
            1,
        ),
        (
            common::quad(Vec3::new(-2.0, -2.0, -0.5), Vec3::X * 4.0, Vec3::Y * 4.0),
            2,
        ),
        (
            common::quad(Vec3::new(-2.0, -2.0, -0.55), Vec3::Y * 4.0, Vec3::X * 4.0),
            2,
        ),
    ];
    let tris: Vec<([Vec3; 3], u32)> = (quads.iter())
        .flat_map(|(q, m)| q.iter().map(move |t| (*t, *m)))
        .collect();
    let scene = Arc::new(common::scene("a glass pane", &tris, materials, Vec::new()));
    let vis = Visibility::of(scene, &Settings::default());
    let mut values = vec![[DARK; 3]; vis.tiles().elements as usize];
    for t in 2..4 {
        let c = vis.elements().triangles[t];
        let cells = holocave_vlf::elements::cells(c.res);
        for e in c.base(0)..c.base(1) + cells {
            values[e as usize] = [BRIGHT; 3];
        }
    }
    vis.light_objects(Arc::new(values.clone()));
    let view = common::edge_view();
    let image = vis.render(&view, &values, 1);
    // The pixels whose ray meets the pane within 8° of its normal: there the pane lets
    // through `(1 − R)²` and reflects `R` at its front and `(1 − R)² R` off its back, `R`
    // the dielectric's Fresnel reflectance (higher orders are `R³`, under 1e-4).
    let mut looked = 0;
    for (i, px) in image.pixels.iter().enumerate() {
        let (x, y) = ((i % 32) as f32 + 0.5, (i / 32) as f32 + 0.5);
        let ray = view.ray(Vec2::new(x, y));
        let cos = ray.dir.dot(Vec3::NEG_Z);
        if cos < 8f32.to_radians().cos() {
            continue;
        }
        let r = fresnel::dielectric(cos, IOR);
        let t = (1.0 - r) * (1.0 - r);
        let radiance = |irradiance: f32| 0.5 * std::f32::consts::FRAC_1_PI * irradiance;
        let want = t * radiance(DARK) + (r + t * r) * radiance(BRIGHT);
        let got = px[1];
        assert!(
            (got - want).abs() <= 0.01 * want,
            "pixel {i}: {got} where the pane shows {want} (through it {})",
            t * radiance(DARK)
        );
        looked += 1;
    }
    assert!(looked >= 4, "{looked} pixels near the pane's normal");
}
