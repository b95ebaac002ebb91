//! The Virtual Light Field as a render node draws it (`papers/vlf-in-the-cave.md` §4):
//! the baked irradiance of a `.vlf` file, and its glossy tiles' radiance, go to the GPU once; every frame the node casts
//! one ray per pixel of each eye (visibility, continued through mirrors and glass:
//! `holocave_vlf::view`) and the GPU shades each pixel's lookup and blends it under the
//! render cache's exact samples (`shaders/vlf.wgsl`, through [`crate::RenderCache`]).

use std::path::Path;
use std::sync::Arc;

use holocave_scene::Scene;
use holocave_vlf::baked::{self, Opened};
use holocave_vlf::{Lookup, Visibility};

use crate::{EyeView, RenderNodeError};

/// How many samples the light field is worth in a pixel unless told. Blending `n`
/// samples of variance `σ²` with a base of squared error `b²` as `(kV + nC)/(k + n)`
/// has mean squared error `(k b² k + n σ²)/(k + n)²`, least at `k = σ²/b²`. On the
/// Cornell box's front view one path's relative squared error is 6.7 on average (caustic
/// fireflies) and 0.069 in the median pixel, the light field's 0.007 and 0.001: `k` is
/// 950 by the means, 68 by the medians. 256 lies between: the excess error while samples
/// accumulate stays below `σ²/4k` (0.0065) and the samples have half the say after 256
/// per pixel (see README, "The VLF under the render cache").
pub const DEFAULT_PRIOR_SAMPLES: f32 = 256.0;

/// A baked light field and the scene it was baked for.
pub struct VlfBase {
    visibility: Visibility,
    /// The elements' irradiance, then the tiles' radiance (what the lookups read).
    values: Vec<[f32; 3]>,
}

impl VlfBase {
    /// Opens `path`, refusing a file baked for another scene or with another layout.
    pub fn open(path: &Path, scene: Arc<Scene>) -> Result<VlfBase, RenderNodeError> {
        let Opened {
            file: f,
            elements,
            tiles,
        } = baked::open(path, &scene).map_err(|e| RenderNodeError::Vlf(e.to_string()))?;
        if !f.state.converged {
            tracing::warn!(
                "{}: bake not finished ({} bounces); drawing what it has",
                path.display(),
                f.state.bounces
            );
        }
        Ok(VlfBase {
            values: f.state.values(),
            visibility: Visibility::new(scene, elements, tiles),
        })
    }

    /// What the lookups read: the elements' irradiance, then the glossy tiles' radiance.
    pub fn values(&self) -> &[[f32; 3]] {
        &self.values
    }

    /// What each pixel of `view` sees (the node's own ray casts, on all cores).
    pub fn lookups(&self, view: &EyeView) -> Vec<Lookup> {
        self.visibility.pixels(&view.wall)
    }
}
