//! What a scene is made of before its BVH is built: the loader's output and
//! [`crate::Scene::from_parts`]'s input.

use glam::{Vec2, Vec3};

use crate::camera::NamedCamera;
use crate::daylight::Daylight;
use crate::light::PunctualLight;
use crate::material::Material;
use crate::objects::ObjectParts;
use crate::texture::Texture;

/// Per-triangle data used for shading (not for intersection).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleShading {
    /// Vertex normals; `None` means the face normal is used.
    pub normals: Option<[Vec3; 3]>,
    pub uvs: [Vec2; 3],
    pub material: u32,
}

/// Everything a scene is made of, before the BVH is built.
#[derive(Default)]
pub struct SceneParts {
    pub name: String,
    pub positions: Vec<[Vec3; 3]>,
    pub shading: Vec<TriangleShading>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<PunctualLight>,
    pub cameras: Vec<NamedCamera>,
    pub daylight: Daylight,
    pub warnings: Vec<String>,
    /// The movable objects, apart from the static triangles above.
    pub objects: Vec<ObjectParts>,
}
