//! The render node's display process: a render cache on the GPU (Walter,
//! Drettakis & Parker, `papers/render-cache.md`) over path-traced samples, in stereo.
//!
//! - [`gpu`]: the wgpu device (any adapter, Mesa's software ones included) and helpers;
//! - [`gpu_rays`]: rays on the GPU: closest and any hit over the scene's BVH, and a wall's
//!   pixel rays, in WGSL compute (the CPU's BVH walk is their reference);
//! - [`cache`]: the point cache and the per-eye compute passes (WGSL beside each pass in `cache/`);
//! - [`view`]: an eye's projection and its pixel rays;
//! - [`source`]: chosen pixels → eye rays → the path tracer (full paths, or gathers over
//!   the light field) → new samples;
//! - [`holodeck`]: chosen pixels → beam requests → a holodeck server → new samples;
//! - [`tonemap`]: Ward Larson's histogram adjustment (camera and human modes) and false
//!   colour, at display;
//! - [`vision`]: what a person would see (veiling glare, acuity, colour loss), for the
//!   human mode, on the CPU and the GPU;
//! - [`falsecolor`]: luminance on a logarithmic colour scale with a legend;
//! - [`build`]: the one builder of a wall's display (cache, sample feed, light field);
//! - [`display`]: a wall display (cache and sample feed) and one frame of it for all eyes;
//! - [`cluster`]: the node's link to the master and the frame cycle (ready, swap);
//! - [`cluster_node`]: joining, reconnecting, and the display for the named holodeck;
//! - [`standalone`]: one wall by itself, on its own clock and head poses;
//! - [`mosaic`]: the unfolded CAVE as one picture;
//! - [`output`]: a headless node's files (frame images, `presented.log`) and their reader;
//! - [`prior`]: how many samples the light field is worth in a pixel, measured from the
//!   feed's own samples;
//! - [`vlf`]: the Virtual Light Field under the cache (visibility per pixel; shading and
//!   blending on the GPU in `cache/light_field.wgsl`);
//! - [`window`]: the node's windows (winit) and their GPU device;
//! - [`present`]: drawing a wall into a window (layout, tone mapping on the GPU) and
//!   presenting it, split into prepare / show / abandon for swap lock;
//! - [`wall_windows`]: a wall's windows frame by frame (tone curve, prepare before Ready,
//!   show on Swap, the present log) and the skew between walls read from those logs.

pub mod build;
pub mod cache;
pub mod cluster;
pub mod cluster_node;
pub mod desk;
pub mod display;
pub mod falsecolor;
pub mod gpu;
pub mod gpu_rays;
pub mod holodeck;
pub mod mosaic;
pub mod output;
pub mod present;
pub mod prior;
pub mod source;
pub mod standalone;
pub mod time_of_day;
pub mod tonemap;
pub mod view;
pub mod vision;
pub mod vlf;
pub mod wall_windows;
pub mod window;

pub use build::{DisplayBuilder, Feed, LightField};
pub use cache::{NewSample, RenderCache, StepTimes};
pub use display::{FrameReport, SampleFeed, WallDisplay};
pub use gpu::Gpu;
pub use holodeck::{HolodeckOptions, HolodeckSource};
pub use prior::Prior;
pub use source::{PixelTracer, TracerThread};
pub use tonemap::{ToneMapper, ToneMode};
pub use view::EyeView;
pub use vlf::{VlfBase, VlfDrawing};

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
