//! The ray sets every ray engine is measured and checked on (`scene/benches/ray_sets.rs`,
//! the GPU engine's bench and exactness tests): from a view's primary rays, a shadow ray
//! from each primary hit facing the sun towards it (any hit, no end) and a
//! cosine-distributed ray about the face normal on the side seen (closest hit).

use glam::Vec3;

use crate::{Ray, Scene};

/// Direction towards the sets' sun: high over Sponza's atrium, so that it lights part of
/// the floor.
pub fn sun() -> Vec3 {
    Vec3::new(0.25, 1.0, 0.15).normalize()
}

/// Two uniform numbers in [0, 1) from an index (splitmix64): the diffuse rays are the
/// same in every run and every engine.
pub fn uniform2(i: u64) -> (f32, f32) {
    let mut z = i.wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    let a = (z >> 40) as f32 / (1u64 << 24) as f32;
    let b = ((z >> 8) & 0xff_ffff) as f32 / (1u64 << 24) as f32;
    (a, b)
}

/// A view's primary rays and the shadow and diffuse rays from their hits.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub shadow: Vec<Ray>,
    pub diffuse: Vec<Ray>,
}

impl RaySets {
    /// The sets made from `primary` (the `i`-th primary ray's diffuse ray takes the `i`-th
    /// random pair) in `scene`, with the sun towards `sun`.
    pub fn from_primary(scene: &Scene, primary: Vec<Ray>, sun: Vec3) -> RaySets {
        let (mut shadow, mut diffuse) = (Vec::new(), Vec::new());
        for (i, ray) in primary.iter().enumerate() {
            let Some(hit) = scene.closest_hit(ray, f32::INFINITY) else {
                continue;
            };
            let sp = scene.surface(&hit);
            // The face normal on the side the ray arrives from.
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
