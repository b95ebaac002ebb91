//! The scene as the tracer sees it: world-space triangles with their shading data,
//! materials, lights, viewpoints and daylight, plus the BVH that answers ray queries.

use std::path::Path;
use std::time::Duration;

use glam::{Vec2, Vec3};

use crate::bvh::Bvh;
use crate::camera::NamedCamera;
use crate::daylight::Daylight;
use crate::error::SceneError;
use crate::light::PunctualLight;
use crate::material::Material;
use crate::objects::MovableObject;
use crate::parts::{SceneParts, TriangleShading};
use crate::ray::{Hit, Ray};
use crate::texture::Texture;

/// A point on a surface, as a hit sees it.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit face normal (winding order: counter-clockwise is the front).
    pub geometric_normal: Vec3,
    /// Unit interpolated normal, on the same side as `geometric_normal`.
    pub shading_normal: Vec3,
    pub uv: Vec2,
    pub material: u32,
    /// True when all three vertex normals equal the face normal: the surface is flat
    /// here, so a mirror or glass pane images what is behind it without distortion.
    pub flat: bool,
}

/// A triangle's unit face normal, and whether its vertex normals all equal it (see
/// [`SurfacePoint::flat`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Face {
    pub(crate) normal: Vec3,
    pub(crate) flat: bool,
}

impl Face {
    pub(crate) fn new(p: &[Vec3; 3], s: &TriangleShading) -> Self {
        let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        let flat = s
            .normals
            .is_none_or(|n| n.iter().all(|n| n.dot(normal) > 0.99999));
        Self { normal, flat }
    }
}

/// A loaded scene.
#[derive(Clone)]
pub struct Scene {
    pub name: String,
    pub(crate) positions: Vec<[Vec3; 3]>,
    pub(crate) shading: Vec<TriangleShading>,
    /// Per triangle, what every hit on it needs and its vertices fix: computed once.
    pub(crate) faces: Vec<Face>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<PunctualLight>,
    pub cameras: Vec<NamedCamera>,
    pub daylight: Daylight,
    /// What the loader ignored or repaired, one line each (also logged).
    pub warnings: Vec<String>,
    pub(crate) bvh: Bvh,
    bounds: (Vec3, Vec3),
    /// The movable objects, apart from the static triangles above (see [`crate::objects`]).
    pub(crate) objects: Vec<MovableObject>,
}

impl Scene {
    /// The same scene under `daylight` (another time of day): the geometry is shared
    /// work already done, copied.
    pub fn with_daylight(&self, daylight: Daylight) -> Scene {
        Scene {
            daylight,
            ..self.clone()
        }
    }

    /// The same scene scaled by `scale` about the origin and then moved by `offset` (for
    /// stress tests of numerical range). Radiance is unchanged: emission, the sky and the
    /// sun stay as they are; a point or spot light's intensity grows by `scale²`, so the
    /// irradiance it gives the scaled surfaces is the same, and its range by `scale`.
    pub fn transformed(self, scale: f32, offset: Vec3) -> Result<Scene, SceneError> {
        let at = |p: Vec3| p * scale + offset;
        let parts = SceneParts {
            name: self.name.clone(),
            positions: self.positions.iter().map(|t| t.map(at)).collect(),
            shading: self.shading,
            materials: self.materials,
            textures: self.textures,
            lights: self
                .lights
                .into_iter()
                .map(|l| PunctualLight {
                    position: at(l.position),
                    intensity: l.intensity * scale * scale,
                    range: l.range.map(|r| r * scale),
                    ..l
                })
                .collect(),
            cameras: self
                .cameras
                .into_iter()
                .map(|c| NamedCamera {
                    position: at(c.position),
                    ..c
                })
                .collect(),
            daylight: self.daylight,
            warnings: self.warnings,
            objects: self
                .objects
                .into_iter()
                .map(|o| o.into_parts().transformed(scale, offset))
                .collect(),
        };
        Scene::from_parts(parts, Path::new(&self.name))
    }

    /// Builds a scene from its parts: drops degenerate triangles (one warning with the
    /// count), builds the BVH, and builds each movable object (see
    /// [`crate::objects`]). `source` names the input in errors.
    pub fn from_parts(mut parts: SceneParts, source: &Path) -> Result<Scene, SceneError> {
        assert_eq!(parts.positions.len(), parts.shading.len());
        let mut dropped = 0;
        let (keep_pos, keep_shading) =
            drop_degenerate(&parts.positions, &parts.shading, &mut dropped);
        if keep_pos.is_empty() {
            return Err(SceneError::Empty {
                path: source.into(),
            });
        }
        if parts.materials.is_empty() {
            parts.materials.push(Material::default());
        }
        let objects = MovableObject::build_all(
            std::mem::take(&mut parts.objects),
            keep_pos.len(),
            &parts.materials,
            &mut dropped,
            &mut parts.warnings,
            source,
        )?;
        if dropped > 0 {
            let w = format!("dropped {dropped} degenerate (zero-area) triangles");
            tracing::warn!("{}: {w}", source.display());
            parts.warnings.push(w);
        }
        let bounds = bounds_of(&keep_pos);
        let bvh = Bvh::build(&keep_pos);
        let faces = faces_of(&keep_pos, &keep_shading);
        Ok(Scene {
            name: parts.name,
            positions: keep_pos,
            shading: keep_shading,
            faces,
            materials: parts.materials,
            textures: parts.textures,
            lights: parts.lights,
            cameras: parts.cameras,
            daylight: parts.daylight,
            warnings: parts.warnings,
            bvh,
            bounds,
            objects,
        })
    }

    /// World-space axis-aligned bounds of the static geometry.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    pub fn triangle_count(&self) -> usize {
        self.positions.len()
    }

    pub fn triangle(&self, i: u32) -> &[Vec3; 3] {
        &self.positions[i as usize]
    }

    /// Triangle `i`'s unit face normal (counter-clockwise winding is the front).
    pub fn face_normal(&self, i: u32) -> Vec3 {
        self.faces[i as usize].normal
    }

    pub fn triangle_shading(&self, i: u32) -> &TriangleShading {
        &self.shading[i as usize]
    }

    /// The BVH every ray query goes through (for walkers outside this crate, e.g. on a
    /// GPU, through [`Bvh::flat`]).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    pub fn bvh_build_time(&self) -> Duration {
        self.bvh.build_time()
    }

    /// The closest hit before `tmax`.
    pub fn closest_hit(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        self.bvh.closest_hit(ray, tmax)
    }

    /// The closest hit before `tmax` of each ray; rays next to each other are traced
    /// together (see [`Bvh::closest_hits`]), so give them in a coherent order.
    pub fn closest_hits(&self, rays: &[Ray], tmax: f32) -> Vec<Option<Hit>> {
        self.bvh.closest_hits(rays, tmax)
    }

    /// Every hit before `tmax`, nearest first, into `hits` (cleared first).
    pub fn all_hits(&self, ray: &Ray, tmax: f32, hits: &mut Vec<Hit>) {
        self.bvh.all_hits(ray, tmax, hits)
    }

    /// Whether anything lies on the ray before `tmax`.
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        self.bvh.occluded(ray, tmax)
    }

    /// The surface point of a hit.
    pub fn surface(&self, hit: &Hit) -> SurfacePoint {
        let i = hit.triangle as usize;
        surface_point(&self.positions[i], &self.shading[i], self.faces[i], hit)
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: u32) -> f32 {
        let p = &self.positions[i as usize];
        0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
    }
}

/// The triangles that are not degenerate (zero area, or not finite), with their shading;
/// adds the number dropped to `dropped`.
pub(crate) fn drop_degenerate(
    positions: &[[Vec3; 3]],
    shading: &[TriangleShading],
    dropped: &mut usize,
) -> (Vec<[Vec3; 3]>, Vec<TriangleShading>) {
    let mut keep_pos = Vec::with_capacity(positions.len());
    let mut keep_shading = Vec::with_capacity(positions.len());
    for (p, s) in positions.iter().zip(shading) {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let area2 = e1.cross(e2).length();
        let scale = e1.length_squared().max(e2.length_squared());
        if area2 > 1e-10 * scale && area2.is_finite() {
            keep_pos.push(*p);
            keep_shading.push(*s);
        }
    }
    *dropped += positions.len() - keep_pos.len();
    (keep_pos, keep_shading)
}

/// The axis-aligned bounds of triangles.
pub(crate) fn bounds_of(positions: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in positions.iter().flatten() {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo, hi)
}

pub(crate) fn faces_of(positions: &[[Vec3; 3]], shading: &[TriangleShading]) -> Vec<Face> {
    positions
        .iter()
        .zip(shading)
        .map(|(p, s)| Face::new(p, s))
        .collect()
}

/// The surface point of `hit` on triangle `p` with shading `s` and face `face`.
pub(crate) fn surface_point(
    p: &[Vec3; 3],
    s: &TriangleShading,
    face: Face,
    hit: &Hit,
) -> SurfacePoint {
    let Face { normal: ng, flat } = face;
    let w = Vec3::new(1.0 - hit.u - hit.v, hit.u, hit.v);
    let ns = match &s.normals {
        Some(n) => {
            let ns = (n[0] * w.x + n[1] * w.y + n[2] * w.z).normalize_or_zero();
            if ns == Vec3::ZERO {
                ng
            } else if ns.dot(ng) < 0.0 {
                -ns
            } else {
                ns
            }
        }
        None => ng,
    };
    let uv = s.uvs[0] * w.x + s.uvs[1] * w.y + s.uvs[2] * w.z;
    SurfacePoint {
        // From the vertices, not `origin + t·dir`: exact on the surface even for
        // rays that start far away.
        position: p[0] * w.x + p[1] * w.y + p[2] * w.z,
        geometric_normal: ng,
        shading_normal: ns,
        uv,
        material: s.material,
        flat,
    }
}
