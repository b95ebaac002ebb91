//! Ray sets for the GPU ray engine's tests and its bench (which includes this file by
//! path): the recipe of `scene/benches/ray_sets.rs` at any resolution and for any scene
//! with a camera, and the scenes they are made on.
#![allow(dead_code)]

use std::path::Path;

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::{LoadOptions, Ray, Scene};

#[path = "../../../tests/common/require.rs"]
mod require;

/// A scene of the project's `scenes/` folder.
pub fn project_scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name);
    Scene::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Sponza of the shared scenes beside the checkout, or `None` (the caller is skipped)
/// when it is absent; with `HOLOCAVE_REQUIRE_SHARED=1` (as CI sets it) its absence is a
/// failure (the project's one skip-or-fail rule, `tests/common/require.rs`).
pub fn sponza() -> Option<Scene> {
    let path = require::shared("scenes/sponza/Sponza.gltf")?;
    Some(Scene::load(&path, &LoadOptions::default()).expect("load Sponza"))
}

/// The sun of the ray-set bench: high over Sponza's atrium.
pub fn sun() -> Vec3 {
    Vec3::new(0.25, 1.0, 0.15).normalize()
}

/// Two uniform numbers in [0, 1) from an index (splitmix64, as the ray-set bench).
pub fn uniform2(i: u64) -> (f32, f32) {
    let mut z = i.wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    let a = (z >> 40) as f32 / (1u64 << 24) as f32;
    let b = ((z >> 8) & 0xff_ffff) as f32 / (1u64 << 24) as f32;
    (a, b)
}

/// The three sets of `scene/benches/ray_sets.rs` through `view`: primary rays through the
/// pixel centres row by row (closest hit), from each primary hit facing `sun` a ray
/// towards it (any hit, no end), and from each primary hit a cosine-distributed ray about
/// the face normal on the side seen (closest hit).
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub shadow: Vec<Ray>,
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    pub fn new(scene: &Scene, view: &WallView, sun: Vec3) -> RaySets {
        let mut primary = Vec::with_capacity((view.width * view.height) as usize);
        for y in 0..view.height {
            for x in 0..view.width {
                primary.push(view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5)));
            }
        }
        let (mut shadow, mut diffuse) = (Vec::new(), Vec::new());
        for (i, ray) in primary.iter().enumerate() {
            let Some(hit) = scene.closest_hit(ray, f32::INFINITY) else {
                continue;
            };
            let sp = scene.surface(&hit);
            let n = if sp.geometric_normal.dot(ray.dir) > 0.0 {
                -sp.geometric_normal
            } else {
                sp.geometric_normal
            };
            if n.dot(sun) > 0.0 {
                shadow.push(Ray::leaving(sp.position, n, sun));
            }
            let (u1, u2) = uniform2(i as u64);
            let (r, phi) = (u1.sqrt(), std::f32::consts::TAU * u2);
            let (b1, b2) = n.any_orthonormal_pair();
            let wi = (b1 * (r * phi.cos()) + b2 * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt())
                .normalize();
            diffuse.push(Ray::leaving(sp.position, n, wi));
        }
        RaySets {
            primary,
            shadow,
            diffuse,
        }
    }
}

/// The view through `scene`'s first camera at `width` × `height`.
pub fn camera_view(scene: &Scene, width: u32, height: u32) -> WallView {
    let cam = scene.cameras.first().expect("the scene has a camera");
    WallView::through_camera(cam, width, height)
}
