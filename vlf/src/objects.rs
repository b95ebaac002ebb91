//! Moving objects as the walls draw them. The light field and the holodeck hold the static
//! scene only (so they stay valid wherever an object goes); each frame the walls see every
//! object where the frame state places it:
//!
//! - **drawn exactly**: the pixel rays meet it (the scene's two-level queries);
//! - **direct light and shadows exact**: the per-pixel shadow rays see it
//!   ([`crate::pixel_direct`]), on the room and on itself;
//! - **its indirect light** gathered per pixel from its surface points where the walls take
//!   the direct light per pixel ([`crate::object_gather`]); else, and where a gather meets
//!   an object, from an irradiance probe at its centre ([`crate::probe`]), gathered from the
//!   light field (the radiance the static surfaces send towards it, and the sky), again
//!   when it has moved by a quarter of its radius;
//! - **its darkening of the room's indirect light**: the light field's part at a static
//!   point is scaled by the share of the point's cosine-weighted hemisphere the object
//!   leaves open, the object taken as a sphere with its mean shadow (below); where that
//!   share is large, the per-pixel pass gathers what the objects change there instead
//!   ([`crate::view::GATHERED_OCCLUSION`]);
//! - wherever any of these differ from what the static caches hold (the object, its
//!   shadows, its surroundings), the render cache's samples do not count
//!   ([`crate::Lookup::samples`]).
//!
//! **The occluding sphere.** A sphere of radius `r` at distance `d` above a surface, at
//! angle `θ` from its normal, covers `cos θ (r/d)²` of the cosine-weighted hemisphere
//! (exact while the sphere is above the horizon). An object is not a sphere: it is taken as
//! the sphere whose shadow has the same area on average over directions — its mean
//! projected area `Ā`, found by casting a grid of parallel rays at it from many directions,
//! gives `r = √(Ā/π)`. Far from the object this is the exact first-order occlusion (a small
//! body shadows by its projected area over `d²`); near it the shape matters and the error
//! is measured (`docs/usage/objects.md`).

use glam::Vec3;
use holocave_scene::{Placement, Ray, Scene};

use crate::probe::{IrradianceProbe, sphere_direction};

/// Directions an object's probe gathers (a Fibonacci sphere; about 0.012 sr each).
pub const PROBE_DIRECTIONS: u32 = 1024;

/// A probe is gathered again when its object's centre has moved by this share of the
/// object's bounding radius.
const REGATHER: f32 = 0.25;

/// Static samples near an object are not trusted where it takes more than this share of
/// a point's cosine-weighted hemisphere.
const TRUSTED_OCCLUSION: f32 = 0.01;

/// A share of the hemisphere too small to darken anything visibly (under an 8-bit step of
/// a mid grey): not looked at further.
const MATTERS: f32 = 1e-3;

/// One moving object as it is lit and shadows this frame.
#[derive(Clone, Debug)]
struct LitObject {
    /// Its bounding sphere where it stands.
    centre: Vec3,
    bound: f32,
    /// The sphere with its mean shadow (see the module's notes), about its centre.
    occluder: f32,
    /// `None` until the light field's values are known.
    probe: Option<IrradianceProbe>,
}

/// The moving objects' placements this frame, and the light at each.
#[derive(Clone, Debug, Default)]
pub struct ObjectLight {
    pub placements: Vec<Placement>,
    objects: Vec<LitObject>,
}

/// Object `k`'s mean projected area (over directions), from grids of parallel rays
/// across its bounding sphere, `DIRS` directions of `GRID²` rays each.
fn mean_projected_area(scene: &Scene, k: usize) -> f32 {
    const DIRS: u32 = 64;
    const GRID: u32 = 48;
    let rest = scene.rest_placements();
    let placed = scene.placed(&rest);
    let (c, r) = scene.objects()[k].bounding_sphere(&rest[k]);
    let cell = 2.0 * r / GRID as f32;
    let mut area = 0.0;
    for i in 0..DIRS {
        let d = sphere_direction(i, DIRS);
        let u = d.any_orthonormal_vector();
        let v = d.cross(u);
        let mut hits = 0u32;
        for y in 0..GRID {
            for x in 0..GRID {
                let s = ((x as f32 + 0.5) * cell - r, (y as f32 + 0.5) * cell - r);
                let origin = c + u * s.0 + v * s.1 - d * (2.0 * r);
                let ray = Ray::new(origin, d);
                let hit = placed.objects_closest_hit(&ray, 4.0 * r, None);
                hits += u32::from(hit.is_some_and(|h| placed.object_of(h.triangle) == Some(k)));
            }
        }
        area += hits as f32 * cell * cell;
    }
    area / DIRS as f32
}

/// The radiance arriving at a point from a direction (see [`crate::Visibility::incoming`]).
pub type Incoming<'a> = dyn Fn(Vec3, Vec3) -> Vec3 + Sync + 'a;

impl ObjectLight {
    /// The scene's objects at rest, unlit until [`ObjectLight::place`] is given the light.
    pub fn at_rest(scene: &Scene) -> Self {
        let mut light = ObjectLight::default();
        light.place(scene, &scene.rest_placements(), None);
        light
    }

    /// Whether the scene has moving objects.
    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    /// Puts the objects at `placements` (one per object of the scene); with the light
    /// (`incoming`), an object without a probe, or whose centre moved by more than a
    /// quarter of its radius since its probe was gathered, has it gathered (again).
    /// Returns whether any object moved.
    pub fn place(
        &mut self,
        scene: &Scene,
        placements: &[Placement],
        incoming: Option<&Incoming>,
    ) -> bool {
        assert_eq!(placements.len(), scene.objects().len());
        let moved = self.placements.as_slice() != placements;
        for (k, at) in placements.iter().enumerate() {
            let (centre, bound) = scene.objects()[k].bounding_sphere(at);
            let gather = |c: Vec3| {
                incoming.map(|f| IrradianceProbe::gather(c, PROBE_DIRECTIONS, |d| f(c, d)))
            };
            match self.objects.get_mut(k) {
                Some(o) => {
                    o.centre = centre;
                    let stale = o
                        .probe
                        .is_none_or(|p| (p.position - centre).length() > REGATHER * bound);
                    if stale && incoming.is_some() {
                        o.probe = gather(centre);
                    }
                }
                None => self.objects.push(LitObject {
                    centre,
                    bound,
                    occluder: (mean_projected_area(scene, k) / std::f32::consts::PI).sqrt(),
                    probe: gather(centre),
                }),
            }
        }
        self.placements = placements.to_vec();
        moved
    }

    /// The irradiance on object `k`'s surface with unit normal `n`, from its probe (none
    /// before the light is known).
    pub fn irradiance(&self, k: usize, n: Vec3) -> Vec3 {
        self.objects[k]
            .probe
            .map_or(Vec3::ZERO, |p| p.irradiance(n))
    }

    /// The share of the cosine-weighted hemisphere of a static point `p` (unit normal
    /// `n`) the objects leave open, and whether they take enough of it that the static
    /// caches' samples there are wrong. An object counts only where `in_sight(centre)`
    /// says the static scene does not hide its centre from `p` (a chair in the next room
    /// darkens nothing here); that costs one ray per point and object near it.
    pub fn openness(&self, p: Vec3, n: Vec3, in_sight: &dyn Fn(Vec3) -> bool) -> (f32, bool) {
        let mut open = 1.0f32;
        let mut near = false;
        for o in &self.objects {
            let to = o.centre - p;
            let d = to.length().max(o.occluder);
            let cos = (n.dot(to) / d).clamp(0.0, 1.0);
            let covered = cos * (o.occluder / d).powi(2);
            // Too little to matter, or behind a wall.
            if (covered <= MATTERS && d >= o.bound) || !in_sight(o.centre) {
                continue;
            }
            open *= 1.0 - covered;
            near |= covered > TRUSTED_OCCLUSION || d < o.bound;
        }
        (open, near)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::LoadOptions;

    /// Cauchy's formula: a convex body's projected area averaged over directions is a
    /// quarter of its surface area. The room's block is a cuboid; its grids are 48 cells
    /// across (cells about 2 cm, whose partial coverage at the outline averages out over
    /// the 64 directions), so the estimate is within 2 %.
    #[test]
    fn a_cuboids_mean_shadow_is_a_quarter_of_its_surface() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
        let opts = LoadOptions::with_objects(&["block"]);
        let scene = Scene::load(&path, &opts).unwrap();
        let (lo, hi) = scene.objects()[0].local_bounds();
        let e = hi - lo;
        let surface = 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
        let area = mean_projected_area(&scene, 0);
        assert!(
            (area - surface / 4.0).abs() < 0.02 * surface / 4.0,
            "mean projected area {area}, a quarter of the surface {}",
            surface / 4.0
        );
    }
}
