//! How a wall draws its light field per pixel: `node`'s flags, which `sim` takes too and
//! hands to each of its nodes.

use std::ffi::OsString;

use clap::Args;
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::{Prior, VlfDrawing};

#[derive(Args, Clone, Debug)]
pub struct DrawingFlags {
    /// Where the light field's rays (each pixel's first hit, the direct light's shadow rays,
    /// gather samples) are traced: `auto` (the GPU on a hardware adapter, the CPU on a
    /// software one such as lavapipe, where the CPU's walk is faster), `gpu` or `cpu`.
    #[arg(long, default_value = "auto", value_parser = str::parse::<Rays>)]
    pub rays: Rays,
    /// Leave out the direct light computed per pixel: draw the light field alone, its
    /// baked direct light included.
    #[arg(long)]
    pub no_direct: bool,
    /// Take the sky's light per pixel too (two more shadow rays per pixel and frame), under
    /// the light field's sky as a prior worth 32 of a pixel's estimates: the first frame as
    /// without, a still view's window light exact within seconds (without, the sky is the
    /// field's, its reflection in glossy floors sharpened per pixel). Needs a light field
    /// baked with the sky's part.
    #[arg(long, conflicts_with = "no_direct")]
    pub sky_per_pixel: bool,
    /// How many samples the light field is worth in a pixel: `auto` (measured at the first
    /// frame from the feed's own samples: their variance against the field's disagreement
    /// with their mean) or a number (0: the samples alone).
    #[arg(long, default_value = "auto", value_parser = str::parse::<Prior>)]
    pub vlf_prior: Prior,
}

impl DrawingFlags {
    /// What the wall computes per pixel and where its rays go.
    pub fn drawing(&self) -> VlfDrawing {
        VlfDrawing {
            direct: !self.no_direct,
            sky_per_pixel: self.sky_per_pixel,
            rays: self.rays,
        }
    }

    /// The same flags on a node's command line.
    pub fn node_args(&self) -> Vec<OsString> {
        let mut args: Vec<OsString> = vec!["--rays".into(), self.rays.to_string().into()];
        args.extend(self.no_direct.then(|| "--no-direct".into()));
        args.extend(self.sky_per_pixel.then(|| "--sky-per-pixel".into()));
        args.extend(["--vlf-prior".into(), self.vlf_prior.to_string().into()]);
        args
    }
}
