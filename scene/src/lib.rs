//! Scenes for holocave: glTF loading, materials, lights, daylight, and BVH ray queries.
//!
//! One concept per module: [`load`] reads glTF into [`SceneParts`] (in [`parts`]) and
//! builds a [`Scene`] from them; [`Scene`] holds the
//! world-space triangles and answers ray queries through [`bvh`]; [`material`],
//! [`texture`], [`light`], [`daylight`] and [`camera`] describe what the tracer shades;
//! [`color`] holds the one Rec. 709 luminance; [`objects`] holds the movable objects,
//! kept apart from the static triangles that light fields and holodecks are made of.

pub mod bvh;
pub mod camera;
pub mod color;
pub mod daylight;
pub mod empty_box;
pub mod error;
pub mod fingerprint;
pub mod generate;
pub mod light;
pub mod load;
pub mod material;
pub mod objects;
pub mod parts;
pub mod photometry;
pub mod ray;
pub mod ray_sets;
pub mod scene;
pub mod texture;

pub use camera::NamedCamera;
pub use color::luminance;
pub use daylight::{Daylight, Sky, SkyModel, Sun};
pub use error::SceneError;
pub use light::{PunctualKind, PunctualLight};
pub use load::{LoadOptions, ObjectSpec};
pub use material::{Material, MaterialKind, SurfaceParams, TextureRef};
pub use objects::{MovableObject, ObjectParts, ObjectPaths, PathError, PlacedScene, Placement};
pub use parts::{SceneParts, TriangleShading};
pub use photometry::Photometry;
pub use ray::{Hit, Ray, leave_surface, surface_epsilon};
pub use scene::{Scene, SurfacePoint};
pub use texture::{Encoding, Texture};
