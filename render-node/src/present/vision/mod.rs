//! What a person would see (Ward Larson, Rushmeier & Piatko 1997, "A visibility matching
//! tone reproduction operator", its human visual limits; Radiance `pcond -h`): the world's
//! radiance changed by the eye before the human-mode histogram adjustment maps it to the
//! display —
//!
//! 1. [`acuity`]: detail finer than the adaptation luminance lets one resolve is blurred
//!    away;
//! 2. [`veil`]: scattered light from bright sources, on this wall and on the others
//!    ([`VeilSources`]), veils what lies near them;
//! 3. [`scotopic`]: colour fades to the rods' grey between 5.62 and 0.00562 cd/m².
//!
//! All three work on the [`fovea`] grid of one-degree samples, made from a function that
//! gives each pixel's direction from the eye, so the model knows no projection. The same
//! steps run on the GPU for windows (`vision/vision.wgsl`, driven by
//! [`gpu::VisionPass`]); their results are tested equal.

pub mod acuity;
pub mod fovea;
pub mod gpu;
pub mod scotopic;
pub mod veil;

use glam::Vec3;
use holocave_tracer::film::Image;

pub use fovea::{Fovea, PixelDirections};
pub use veil::{VeilSource, VeilSources};

/// One image as a person would see it, and the sources it shares with other walls.
#[derive(Clone, Debug)]
pub struct Perceived {
    /// Scene radiance (the same units as the input), veiled, blurred and desaturated.
    pub image: Image,
    /// This view's bright foveal samples, for the other walls' veils.
    pub sources: VeilSources,
}

/// Everything the per-pixel step needs, per foveal cell: what the GPU is given too.
#[derive(Clone, Debug)]
pub struct FovealState {
    pub fovea: Fovea,
    /// Mean radiance per cell.
    pub means: Vec<Vec3>,
    /// Veil per cell (radiance), from this view's cells and the imported sources.
    pub veil: Vec<Vec3>,
    /// Pyramid level per cell ([`acuity::level`] of its pixels per degree and luminance).
    pub level: Vec<f32>,
}

impl FovealState {
    /// The foveal grid of `image` seen through `dirs`, its veil with `imported` sources,
    /// and its acuity levels; `efficacy` (lm/W) turns radiance into cd/m².
    pub fn new(
        image: &Image,
        dirs: PixelDirections,
        imported: &VeilSources,
        efficacy: f32,
    ) -> FovealState {
        let fovea = Fovea::new(image.width, image.height, dirs);
        let means = fovea.means(image);
        let veil = veil::veil(&fovea, &means, imported);
        let level = Self::levels(&fovea, &means, efficacy);
        FovealState {
            fovea,
            means,
            veil,
            level,
        }
    }

    /// The acuity level of each cell from its mean luminance (the local adaptation).
    pub fn levels(fovea: &Fovea, means: &[Vec3], efficacy: f32) -> Vec<f32> {
        means
            .iter()
            .zip(&fovea.pixels_per_degree)
            .map(|(&c, &ppd)| acuity::level(ppd, efficacy * holocave_scene::luminance(c)))
            .collect()
    }
}

/// One pixel as seen: acuity from `pyramid` at the interpolated level, the veil added and
/// the scattered fraction taken away, then the colour loss at the result's luminance.
pub fn perceive_pixel(
    state: &FovealState,
    pyramid: &acuity::Pyramid,
    efficacy: f32,
    x: u32,
    y: u32,
) -> Vec3 {
    let w = state.fovea.bilinear(x, y);
    let mut level = 0.0;
    let mut veil = Vec3::ZERO;
    for (i, t) in w {
        level += t * state.level[i];
        veil += t * state.veil[i];
    }
    let seen = pyramid.sample(level, x, y) * (1.0 - veil::VEIL_OF_UNIFORM_FIELD) + veil;
    scotopic::mesopic(seen, efficacy * holocave_scene::luminance(seen))
}

/// `image` as a person would see it through `dirs` (each pixel's direction from the eye),
/// with the veil of the other walls' `imported` sources; `efficacy` in lm/W.
pub fn perceive(
    image: &Image,
    dirs: PixelDirections,
    imported: &VeilSources,
    efficacy: f32,
) -> Perceived {
    let state = FovealState::new(image, dirs, imported, efficacy);
    let pyramid = acuity::Pyramid::new(image);
    let mut out = Image::new(image.width, image.height);
    for y in 0..image.height {
        for x in 0..image.width {
            out.pixels[(y * image.width + x) as usize] =
                perceive_pixel(&state, &pyramid, efficacy, x, y);
        }
    }
    Perceived {
        image: out,
        sources: VeilSources::export(&state.fovea, &state.means),
    }
}

#[cfg(test)]
mod tests;
