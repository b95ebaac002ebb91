//! Small elements keep the light that reaches them: a floor cut into triangles six times
//! smaller than a line's reach (`least`, a quarter of a line's cross-section), under a
//! uniform sky that only the lines bring, receives on average what a floor receives, where
//! alone each tiny element kept only `A / least` of it (`pools`).

use crate::common;

use std::path::Path;

use glam::{Vec2, Vec3};
use holocave_scene::{Daylight, Scene, SceneParts, Sky, SkyModel, TriangleShading};
use holocave_vlf::{Directions, Settings, layout};

const SKY: f32 = 2.0;
const N: usize = 40;

fn floor_of_small_triangles() -> Scene {
    let mut positions = Vec::new();
    let s = 2.0 / N as f32;
    for j in 0..N {
        for i in 0..N {
            let o = Vec3::new(-1.0 + i as f32 * s, 0.0, -1.0 + j as f32 * s);
            // a × b = z × x = +y: facing the sky.
            positions.extend(common::quad(o, Vec3::Z * s, Vec3::X * s));
        }
    }
    let shading = positions
        .iter()
        .map(|_| TriangleShading {
            normals: None,
            uvs: [Vec2::ZERO; 3],
            material: 0,
        })
        .collect();
    Scene::from_parts(
        SceneParts {
            name: "small floor".into(),
            positions,
            shading,
            materials: vec![common::lambert("floor", 0.5, Vec3::ZERO)],
            daylight: Daylight {
                sun: None,
                sky: Some(Sky {
                    model: SkyModel::Uniform(Vec3::splat(SKY)),
                    ground: Vec3::ZERO,
                }),
                ..Default::default()
            },
            ..SceneParts::default()
        },
        Path::new("small floor"),
    )
    .expect("a valid scene")
}

#[test]
fn tiny_elements_under_the_sky_keep_its_light() {
    let scene = floor_of_small_triangles();
    let settings = Settings {
        directions: 42,
        resolution: 16,
        ..Settings::default()
    };
    let (state, stats) = common::bake_quiet(&scene, &settings);
    let elements = layout(&scene, &settings);
    let (area, _) = elements.areas_and_centres(&scene);
    // The lines' cross-section: (2R/N)² over the scene's bounding sphere (R ≥ √2 here).
    let tiny = area[0];
    eprintln!(
        "{} elements of {tiny:.5} m², {} crossings",
        stats.elements, stats.crossings
    );
    // The front sides (facing the sky): the first element of each triangle's front.
    let (mut flux, mut total) = (0f64, 0f64);
    for cells in &elements.triangles {
        assert_eq!(cells.res, 1, "one element per triangle");
        let e = cells.base(0) as usize;
        flux += f64::from(state.irradiance[e][0]) * f64::from(area[e]);
        total += f64::from(area[e]);
    }
    let mean = flux / total;
    // What the directions give a surface facing +y of a uniform sky: L Σ Δω max(0, ω·n).
    let d = Directions::at_least(settings.directions);
    let want: f64 = d
        .dirs
        .iter()
        .zip(&d.solid_angle)
        .map(|(w, s)| f64::from(*s) * f64::from(w.y.max(0.0)))
        .sum::<f64>()
        * f64::from(SKY);
    eprintln!(
        "mean irradiance {mean:.4}, the directions' {want:.4} (π L = {:.4})",
        std::f64::consts::PI * f64::from(SKY)
    );
    // The lines of one direction cross the floor's projected area `A cos θ` in about
    // `A cos θ / h²` places (≈ 130 facing it); where the grid meets the floor's edges the
    // count is off by up to the lines along the perimeter, ≈ 2·4 m / h = 45, each a
    // random half in or out: ±√45/2 ≈ ±3.4 lines, 2.6 % of one direction; over the 21
    // directions facing it, 0.6 %; 5 % is eight times that. Alone, each element (six
    // times smaller than the clamp) kept a sixth.
    assert!(
        ((mean - want) / want).abs() < 0.05,
        "mean irradiance {mean:.4}, the directions bring {want:.4}"
    );
}
