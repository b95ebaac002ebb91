//! A scene's identity: a fingerprint of everything its light depends on, so a light field
//! or a holodeck made for one scene is never used with another (a file name says nothing
//! of the daylight it was loaded with).

use crate::Scene;

impl Scene {
    /// A fingerprint of everything the scene's light depends on: geometry, materials,
    /// lights, daylight (FNV-1a, 64 bits).
    pub fn fingerprint(&self) -> u64 {
        let scene = self;
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for b in bytes {
                h ^= u64::from(*b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for t in 0..scene.triangle_count() as u32 {
            for p in scene.triangle(t) {
                for c in p.to_array() {
                    eat(&c.to_le_bytes());
                }
            }
            eat(&scene.triangle_shading(t).material.to_le_bytes());
        }
        // The daylight's sun and sky alone, in the words of a `Daylight { sun, sky }`: its
        // photometry changes units, not radiance, so no bake depends on it.
        let d = &scene.daylight;
        eat(format!(
            "{:?}{:?}Daylight {{ sun: {:?}, sky: {:?} }}",
            scene.materials, scene.lights, d.sun, d.sky
        )
        .as_bytes());
        for t in &scene.textures {
            eat(t.name.as_bytes());
        }
        h
    }
}
