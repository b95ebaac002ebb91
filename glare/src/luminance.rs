//! A fisheye's luminance, cd/m², checked: what the figures are computed from.

use glam::Vec3;
use holocave_scene::Photometry;
use holocave_tracer::film::Image;

use crate::error::GlareError;
use crate::fisheye::Fisheye;

/// A fisheye view and the luminance of each of its pixels, rows from the top.
#[derive(Clone, Debug)]
pub struct LuminanceMap {
    pub fisheye: Fisheye,
    /// cd/m², one per pixel (the pixels outside the circle are kept but not used).
    pub luminance: Vec<f64>,
}

impl LuminanceMap {
    /// Luminance given per pixel. Errors: a count that is not the fisheye's, or a value
    /// that is not finite or is negative (named by its pixel).
    pub fn new(fisheye: Fisheye, luminance: Vec<f64>) -> Result<Self, GlareError> {
        let n = fisheye.size;
        if luminance.len() != (n as usize) * (n as usize) {
            return Err(GlareError::WrongCount {
                count: luminance.len(),
                size: n,
            });
        }
        if let Some(i) = luminance.iter().position(|l| !l.is_finite() || *l < 0.0) {
            return Err(GlareError::BadPixel {
                x: i as u32 % n,
                y: i as u32 / n,
                value: format!("{} cd/m²", luminance[i]),
            });
        }
        Ok(LuminanceMap { fisheye, luminance })
    }

    /// The luminance of an image of radiance in the scene's units, by `photometry`.
    /// Errors: an image of another size, or a pixel whose RGB is not finite or whose
    /// luminance is negative.
    pub fn from_radiance(
        fisheye: Fisheye,
        image: &Image,
        photometry: &Photometry,
    ) -> Result<Self, GlareError> {
        let n = fisheye.size;
        if (image.width, image.height) != (n, n) {
            return Err(GlareError::SizeMismatch {
                width: image.width,
                height: image.height,
                size: n,
            });
        }
        if n == 0 {
            return Err(GlareError::EmptyImage { size: n });
        }
        let bad = |i: usize, c: Vec3| GlareError::BadPixel {
            x: i as u32 % n,
            y: i as u32 / n,
            value: format!("RGB {c}"),
        };
        let luminance = image
            .pixels
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                if !c.is_finite() {
                    return Err(bad(i, c));
                }
                Ok(f64::from(photometry.luminance_cd(c)))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(fisheye, luminance)
    }
}
