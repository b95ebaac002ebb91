//! The render node's display process: a render cache on the GPU (Walter,
//! Drettakis & Parker, `papers/render-cache.md`) over path-traced samples, in stereo.
//!
//! The modules, by concept:
//! - [`gpu`]: the wgpu device (any adapter, Mesa's software ones included) and helpers;
//!   [`gpu_rays`]: rays on the GPU: closest and any hit over the scene's BVH, and a
//!   wall's pixel rays, in WGSL compute (the CPU's BVH walk is their reference);
//! - [`cache`]: the render cache: the point cache and the per-eye compute passes (WGSL
//!   beside each pass in `cache/`);
//! - [`view`]: an eye's projection and its pixel rays;
//! - [`feed`]: where the exact samples come from: the node's own path tracer (full paths,
//!   or gathers over the light field) or a holodeck server;
//! - [`light_field`]: the Virtual Light Field under the cache (the per-pixel wall pass,
//!   shaded and blended on the GPU in `cache/shade_field.wgsl`), what it is worth in a
//!   pixel (`prior`) and which bake lights a time of day (`time_of_day`);
//! - [`build`]: the one builder of a wall's display (cache, sample feed, light field);
//!   [`display`]: a wall display and one frame of it for all eyes;
//! - [`node`]: a node's life: following the master (`follow`), joining and rejoining the
//!   cluster (`cluster`), one wall by itself (`standalone`), the windows' desk input;
//! - [`present`]: from a drawn frame to what a person sees: windows and swap lock, tone
//!   mapping, human vision, false colour, the headless node's files and mosaics.

pub mod build;
pub mod cache;
pub mod display;
pub mod feed;
pub mod gpu;
pub mod gpu_rays;
pub mod light_field;
pub mod node;
pub mod present;
pub mod view;

pub use build::{DisplayBuilder, Feed, LightField};
pub use cache::{NewSample, RenderCache, StepTimes};
pub use display::{FrameReport, SampleFeed, WallDisplay};
pub use feed::holodeck::{HolodeckOptions, HolodeckSource};
pub use feed::tracer::{PixelTracer, TracerThread};
pub use gpu::Gpu;
pub use light_field::prior::Prior;
pub use light_field::{VlfBase, VlfDrawing};
pub use present::tonemap::{ToneMapper, ToneMode};
pub use view::EyeView;

#[derive(Debug, thiserror::Error)]
pub enum RenderNodeError {
    #[error("no GPU adapter (hardware or software) is available: {0}")]
    NoAdapter(String),
    #[error("the GPU adapter refused a device: {0}")]
    Device(String),
    #[error("writing {path}: {message}")]
    Write { path: String, message: String },
    #[error("light field {0}")]
    Vlf(String),
    #[error("holodeck {0}")]
    Holodeck(String),
}
