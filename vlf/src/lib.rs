//! The Virtual Light Field of holocave (`papers/vlf-in-the-cave.md`, §3–4): a baked
//! global-illumination solution that every wall draws at a cost independent of the
//! lighting.
//!
//! - [`directions`]: directions spread evenly over the sphere (a geodesic sphere), paired
//!   into line orientations;
//! - [`subfield`]: one orientation's parallel subfield — an `N × N` grid of lines over
//!   the scene's bounding sphere — and every surface each line crosses (the scene's
//!   all-hits query);
//! - [`elements`]: the irradiance atlas, each triangle side cut into elements;
//! - [`surface`]: how a material is treated (diffuse element, or a delta surface followed
//!   exactly);
//! - [`direct`]: small emitters, punctual lights and the sun by next-event estimation;
//! - [`propagate`]: the Neumann expansion along the lines, one bounce per iteration;
//! - [`bake`]: the whole bake, its stopping rule and its checkpoints;
//! - [`file`]: the `.vlf` file;
//! - [`remote`]: bake workers in other processes (subfields handed out as work);
//! - [`view`]: per-pixel visibility and the lookup (the render node does the lookup on
//!   the GPU).
//!
//! What differs from the paper: mirrors and smooth glass are followed exactly (by eye rays
//! and by the lines that cross them) instead of being stored as directional radiance
//! tiles `L_s(ω, s, t, u, v, p)`, and glossy surfaces are drawn as diffuse with their
//! albedo. So a scene has no directional tiles at all, and its lines are not grouped
//! into tiles: each line keeps its own crossings.

pub mod bake;
pub mod direct;
pub mod directions;
pub mod elements;
pub mod file;
pub mod propagate;
pub mod remote;
pub mod subfield;
pub mod surface;
pub mod view;

pub use bake::{Caster, Casting, Settings, Stage, State, Stats, Threads, bake, bake_with, layout};
pub use directions::Directions;
pub use elements::Elements;
pub use file::{VlfError, VlfFile};
pub use view::{Lookup, Visibility};
