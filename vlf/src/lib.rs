//! The Virtual Light Field of holocave (`papers/vlf-in-the-cave.md`, §3–4): a baked
//! global-illumination solution that every wall draws at a cost independent of the
//! lighting.
//!
//! - [`accuracy`]: an image's figures against a converged reference;
//! - [`directions`]: directions spread evenly over the sphere (a geodesic sphere), paired
//!   into line orientations;
//! - [`subfield`]: one orientation's parallel subfield — an `N × N` grid of lines over
//!   the scene's bounding sphere — and every surface each line crosses (the scene's
//!   all-hits query);
//! - [`elements`]: the irradiance atlas, each triangle side cut into elements;
//! - [`surface`]: how a material is treated (diffuse element, glossy element with a
//!   tile, or a delta surface followed exactly);
//! - [`octahedral`]: the hemisphere of directions above a surface as `k × k` bins;
//! - [`tiles`]: directional radiance tiles for glossy surfaces (which surfaces, how an
//!   element maps to its tile, the BSDF integrated into the bins);
//! - [`direct`]: small emitters, punctual lights and the sun by next-event estimation;
//! - [`pixel_direct`]: the direct light per pixel (the walls' exact part; the bake keeps
//!   the same part apart so that a view drawing it here takes only the rest);
//! - [`tile_albedo`]: what a tile's bins make of an even light (their binning, the albedo
//!   a widened lobe loses towards grazing), put right per pixel at the pixel's angle;
//! - [`plane_smooth`]: the field's remainder averaged over planes across triangles
//!   (the lines' ray effects on plain walls);
//! - [`gather`]: samples that help the light field: exact direct light at the point
//!   seen and after one bounce, the field's remainder beyond;
//! - [`static_rays`]: batches of rays against the static scene, on the CPU or a GPU;
//! - [`propagate`]: the Neumann expansion along the lines, one bounce per iteration;
//! - [`bake`]: the whole bake, its stopping rule and its checkpoints;
//! - [`file`]: the `.vlf` file, and [`baked`]: its life on disk (settings checked, bakes
//!   saved per bounce and resumed, old versions baked again, the one `open` that checks a
//!   file against its scene); [`hours`]: a bake set's bakes at their times, and the field
//!   of a time between two of them, blended;
//! - [`remote`]: bake workers in other processes (subfields handed out as work);
//! - [`objects`]: moving objects as the walls draw them (placed, lit from probes, shadowing);
//! - [`probe`]: irradiance probes (order-2 harmonics) lighting what the field does not hold;
//! - [`view`]: per-pixel visibility and the lookup (the render node does the lookup on
//!   the GPU);
//! - [`carry`]: a moving eye's pixels carried to its next view, as the render cache
//!   carries its points, and which are drawn anew;
//! - [`glow_edges`]: the edges of emitters and the sky drawn with their share of the
//!   pixel (a wall takes one lookup through each pixel's centre), and
//!   [`surface_edges`]: the edges between a bright and a dark surface, likewise;
//! - [`caustics`]: the emitters' light through mirrors and glass per pixel, from a photon
//!   map, where the field's elements would blur it.
//!
//! What differs from the paper: mirrors and smooth glass are followed exactly (by eye rays
//! and by the lines that cross them) instead of being stored as directional radiance
//! tiles `L_s(ω, s, t, u, v, p)`. Glossy surfaces — a GGX lobe with `α` below the bake's
//! [`Settings::glossy_alpha`] (0.5 unless told), not a delta and not transmitting — get
//! the paper's directional radiance, but per element rather than per subfield tile: each
//! glossy element side stores its outgoing radiance over the hemisphere of its shading
//! normal in `k × k` bins ([`Settings::tile_bins`], 8 unless told), which glossy
//! receivers fill with the tracer's BSDF from every line and next-event sample that
//! reaches them, glossy senders read in each line's direction, and the lookup reads in the
//! direction towards the eye. Lobes narrower than the bins or the line directions are
//! widened to [`tiles::alpha_floor`] (blurred highlights, not aliased ones). Rougher
//! surfaces are diffuse elements: the field passes on their albedo's mean over the views
//! ([`surface::diffuse_albedo`]), each line taking the share its direction gets of it
//! ([`exitance`]: a rough dielectric sends less towards grazing directions), and a pixel shows its element's light times the albedo
//! towards its eye ([`surface::albedo_towards`]); a scene without glossy surfaces has no
//! tiles at all. The lines are not grouped into the paper's tiles: each line keeps its own
//! crossings.

pub mod accuracy;
pub mod bake;
pub mod baked;
pub mod carry;
pub mod caustics;
pub mod direct;
pub mod directions;
pub mod elements;
pub mod exitance;
pub mod file;
pub mod file_summary;
pub mod footprint;
pub mod gather;
pub mod glow_edges;
pub mod hours;
pub mod kept_gathers;
pub mod object_gather;
pub mod objects;
pub mod octahedral;
pub mod pixel_direct;
pub mod plane_smooth;
pub mod pools;
pub mod probe;
pub mod propagate;
pub mod reflection;
pub mod remote;
mod sequence;
pub mod settling;
pub mod split;
pub mod static_rays;
pub mod subfield;
pub mod surface;
pub mod surface_edges;
pub mod tile_albedo;
pub mod tiles;
pub mod view;
pub mod wall_pass;

pub use bake::{
    Caster, Casting, Settings, Stage, State, Stats, Threads, bake, bake_with, layout, tiles,
};
pub use directions::Directions;
pub use elements::Elements;
pub use file::{VlfError, VlfFile};
pub use pixel_direct::{
    Accumulator, Aim, DirectPoint, Estimate, Gather, Made, MadeFrom, MadeRays, PixelDirect,
    Sampled, ShadowQuery, SunSequence, made_rays, sun_sequence,
};
pub use static_rays::{CpuRays, StaticRays};
pub use tiles::Tiles;
pub use view::{Lookup, Visibility};
pub use wall_pass::{FrameContext, FrameSurfaces, WallPass};
