//! Movable objects: furniture and the like that users move about a globally lit scene.
//!
//! The light field and the holodeck are made once for a scene, so they must never see
//! anything that moves: an object's triangles are kept apart from the static ones, and
//! every static query of [`Scene`] (and its fingerprint, the caches' identity) sees the
//! static scene alone. What draws a frame places each object where it stands
//! ([`Placement`]) and asks a [`PlacedScene`]; moving an object never rebuilds its BVH.
//! [`ObjectPaths`] are keyframed motions read from CSV, for recorded sessions and tests.
//!
//! An object's emission lights nothing (only static emitters are light sources), and
//! lights and cameras under a movable node stay where they were loaded.

mod path;
mod placed;
mod placement;

#[cfg(test)]
mod tests;

use std::path::Path;

use glam::Vec3;

pub use path::{ObjectPaths, PathError};
pub use placed::PlacedScene;
pub use placement::Placement;

use crate::bvh::Bvh;
use crate::error::SceneError;
use crate::material::Material;
use crate::parts::{SceneParts, TriangleShading};
use crate::scene::{Face, Scene, bounds_of, drop_degenerate, faces_of};

/// A movable object before its BVH is built: triangles in its own frame.
#[derive(Clone, Debug, Default)]
pub struct ObjectParts {
    pub name: String,
    /// Where the object stood when it was loaded.
    pub rest: Placement,
    /// Triangles in the object's frame (a world vertex is `rest.to_world_point(v)`).
    pub positions: Vec<[Vec3; 3]>,
    /// Per triangle, with normals in the object's frame.
    pub shading: Vec<TriangleShading>,
}

impl ObjectParts {
    /// The object of a scene scaled by `scale` about the origin, then moved by `offset`.
    pub(crate) fn transformed(self, scale: f32, offset: Vec3) -> ObjectParts {
        ObjectParts {
            rest: Placement::new(self.rest.translation * scale + offset, self.rest.rotation),
            positions: self
                .positions
                .iter()
                .map(|t| t.map(|p| p * scale))
                .collect(),
            ..self
        }
    }
}

/// A movable object: its triangles in its own frame, with their own BVH.
#[derive(Clone)]
pub struct MovableObject {
    pub name: String,
    /// Where the object stood when it was loaded: the rigid part of its first node's
    /// world transform (the scale is in the triangles).
    pub rest: Placement,
    positions: Vec<[Vec3; 3]>,
    shading: Vec<TriangleShading>,
    faces: Vec<Face>,
    bvh: Bvh,
    bounds: (Vec3, Vec3),
    /// The scene-wide id of its first triangle (after the static triangles and the
    /// objects before it).
    first: u32,
}

impl MovableObject {
    /// Builds the objects of a scene with `static_count` static triangles: drops
    /// degenerate triangles (counted into `dropped`), warns of emissive materials, and
    /// refuses duplicate names and objects without triangles.
    pub(crate) fn build_all(
        parts: Vec<ObjectParts>,
        static_count: usize,
        materials: &[Material],
        dropped: &mut usize,
        warnings: &mut Vec<String>,
        source: &Path,
    ) -> Result<Vec<MovableObject>, SceneError> {
        let err = |message: String| SceneError::Objects {
            path: source.into(),
            message,
        };
        let mut objects: Vec<MovableObject> = Vec::with_capacity(parts.len());
        let mut first = static_count;
        for o in parts {
            assert_eq!(o.positions.len(), o.shading.len());
            if objects.iter().any(|p| p.name == o.name) {
                return Err(err(format!("two objects are named {:?}", o.name)));
            }
            let (positions, shading) = drop_degenerate(&o.positions, &o.shading, dropped);
            if positions.is_empty() {
                return Err(err(format!("object {:?} has no triangles", o.name)));
            }
            let emissive = shading
                .iter()
                .map(|s| &materials[s.material as usize])
                .find(|m| m.emissive != Vec3::ZERO);
            if let Some(m) = emissive {
                let w = format!(
                    "object {:?}: material {:?} is emissive; it is drawn so, but a movable \
                     object's emission lights nothing (it is not a light source)",
                    o.name, m.name
                );
                tracing::warn!("{}: {w}", source.display());
                warnings.push(w);
            }
            let count = positions.len();
            objects.push(MovableObject {
                name: o.name,
                rest: o.rest,
                bvh: Bvh::build(&positions),
                bounds: bounds_of(&positions),
                faces: faces_of(&positions, &shading),
                positions,
                shading,
                first: u32::try_from(first).map_err(|_| err("too many triangles".into()))?,
            });
            first += count;
        }
        u32::try_from(first).map_err(|_| err("too many triangles".into()))?;
        Ok(objects)
    }

    pub(crate) fn into_parts(self) -> ObjectParts {
        ObjectParts {
            name: self.name,
            rest: self.rest,
            positions: self.positions,
            shading: self.shading,
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.positions.len()
    }

    /// The scene-wide id of the object's first triangle; its triangle `j` is
    /// `first_triangle() + j` in every [`Hit`](crate::Hit) of a [`PlacedScene`].
    pub fn first_triangle(&self) -> u32 {
        self.first
    }

    /// Axis-aligned bounds in the object's own frame.
    pub fn local_bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The sphere round its bounds, placed at `at`: world centre and radius.
    pub fn bounding_sphere(&self, at: &Placement) -> (Vec3, f32) {
        let (lo, hi) = self.bounds;
        (at.to_world_point(0.5 * (lo + hi)), 0.5 * (hi - lo).length())
    }

    /// The object's triangles in its own frame.
    pub fn local_triangles(&self) -> &[[Vec3; 3]] {
        &self.positions
    }

    /// The object's triangles and their shading at `placement`, in world space.
    fn placed_triangles(
        &self,
        at: Placement,
    ) -> impl Iterator<Item = ([Vec3; 3], TriangleShading)> + '_ {
        self.positions.iter().zip(&self.shading).map(move |(p, s)| {
            let normals = s.normals.map(|n| n.map(|n| at.to_world_dir(n)));
            (
                p.map(|v| at.to_world_point(v)),
                TriangleShading { normals, ..*s },
            )
        })
    }
}

impl Scene {
    /// The movable objects, in the order placements are given.
    pub fn objects(&self) -> &[MovableObject] {
        &self.objects
    }

    /// The index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// Every object where it stood when loaded.
    pub fn rest_placements(&self) -> Vec<Placement> {
        self.objects.iter().map(|o| o.rest).collect()
    }

    /// A scene without movable objects: the static triangles and, after them in
    /// [`Scene::objects`] order, every object's triangles at `placements` (one per
    /// object), so triangle ids are those of [`PlacedScene`]. For references (a path
    /// tracer of one frame) and tests; textures are copied, not read again.
    pub fn with_objects_at(&self, placements: &[Placement]) -> Result<Scene, SceneError> {
        if placements.len() != self.objects.len() {
            return Err(SceneError::Objects {
                path: self.name.clone().into(),
                message: format!(
                    "{} placements given for {} objects",
                    placements.len(),
                    self.objects.len()
                ),
            });
        }
        let mut positions = self.positions.clone();
        let mut shading = self.shading.clone();
        for (o, at) in self.objects.iter().zip(placements) {
            for (p, s) in o.placed_triangles(*at) {
                positions.push(p);
                shading.push(s);
            }
        }
        let parts = SceneParts {
            name: self.name.clone(),
            positions,
            shading,
            materials: self.materials.clone(),
            textures: self.textures.clone(),
            lights: self.lights.clone(),
            cameras: self.cameras.clone(),
            daylight: self.daylight.clone(),
            warnings: self.warnings.clone(),
            objects: Vec::new(),
        };
        Scene::from_parts(parts, Path::new(&self.name))
    }
}
