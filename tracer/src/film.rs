//! Images of linear radiance: written as OpenEXR (the data) and as a tone-mapped PNG
//! (for looking at), and compared by relative MSE.

use std::path::Path;

use glam::Vec3;
use holocave_scene::luminance;

/// A display value in [0, 1] (clamped) as an 8-bit sRGB code: the sRGB transfer curve,
/// rounded to the nearest code.
pub fn srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// A linear RGB image, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    #[error("writing {path}: {message}")]
    Write { path: String, message: String },
    #[error("reading {path}: {message}")]
    Read { path: String, message: String },
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Linear half-float RGB OpenEXR.
    pub fn write_exr(&self, path: &Path) -> Result<(), FilmError> {
        exr::prelude::write_rgb_file(path, self.width as usize, self.height as usize, |x, y| {
            let p = self.at(x as u32, y as u32);
            (p.x, p.y, p.z)
        })
        .map_err(|e| FilmError::Write {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    pub fn read_exr(path: &Path) -> Result<Self, FilmError> {
        let err = |e: exr::error::Error| FilmError::Read {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, _| Image::new(res.width() as u32, res.height() as u32),
            |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width as usize;
                img.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(err)?;
        Ok(image.layer_data.channel_data.pixels)
    }

    /// The one auto-exposure rule of the PNG previews (every command's and the node's):
    /// middle grey (0.18) over the log-average luminance of the pixels that are not black
    /// (luminance above 1e-6; holes and escaped rays would otherwise wash the picture
    /// out). `None` for an image with no such pixel.
    pub fn lit_exposure(&self) -> Option<f32> {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for &p in &self.pixels {
            let l = luminance(p);
            if l > 1e-6 {
                sum += f64::from(l).ln();
                n += 1;
            }
        }
        (n > 0).then(|| (0.18 / (sum / n as f64).exp()) as f32)
    }

    /// [`Image::lit_exposure`], or 1 for a black image.
    pub fn auto_exposure(&self) -> f32 {
        self.lit_exposure().unwrap_or(1.0)
    }

    /// An 8-bit sRGB preview: exposure, Reinhard's `x / (1 + x)` on luminance, sRGB curve.
    pub fn to_preview(&self, exposure: f32) -> image::RgbImage {
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let c = self.at(x, y) * exposure;
            let l = luminance(c);
            let c = if l > 0.0 {
                c * (1.0 / (1.0 + l))
            } else {
                Vec3::ZERO
            };
            image::Rgb([srgb8(c.x), srgb8(c.y), srgb8(c.z)])
        })
    }

    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<(), FilmError> {
        self.to_preview(exposure)
            .save(path)
            .map_err(|e| FilmError::Write {
                path: path.display().to_string(),
                message: e.to_string(),
            })
    }

    /// Relative mean squared error against `reference`: the mean over pixels and channels
    /// of `(a − b)² / (b² + 0.01)` (the 0.01 keeps black pixels from dominating).
    pub fn relative_mse(&self, reference: &Image) -> f64 {
        assert_eq!(
            (self.width, self.height),
            (reference.width, reference.height),
            "image sizes differ"
        );
        let mut sum = 0.0f64;
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            for c in 0..3 {
                let (a, b) = (f64::from(a[c]), f64::from(b[c]));
                sum += (a - b).powi(2) / (b * b + 0.01);
            }
        }
        sum / (3 * self.pixels.len().max(1)) as f64
    }

    /// Mean squared error against `reference`: the mean over pixels and channels of
    /// `(a − b)²` (its square root is the RMSE).
    pub fn mean_squared_error(&self, reference: &Image) -> f64 {
        assert_eq!(
            (self.width, self.height),
            (reference.width, reference.height),
            "image sizes differ"
        );
        let sum: f64 = self
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| f64::from((*a - *b).length_squared()))
            .sum();
        sum / (3 * self.pixels.len().max(1)) as f64
    }

    /// The image averaged over `k`×`k` blocks; a part block at the right or bottom edge is
    /// dropped.
    pub fn block_means(&self, k: u32) -> Image {
        let mut out = Image::new(self.width / k, self.height / k);
        for y in 0..out.height {
            for x in 0..out.width {
                let mut s = Vec3::ZERO;
                for dy in 0..k {
                    for dx in 0..k {
                        s += self.at(x * k + dx, y * k + dy);
                    }
                }
                out.pixels[(y * out.width + x) as usize] = s / (k * k) as f32;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_means_average_whole_blocks_and_drop_the_edges() {
        let mut i = Image::new(5, 3);
        for (n, p) in i.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(n as f32);
        }
        let b = i.block_means(2);
        assert_eq!((b.width, b.height), (2, 1));
        // Pixels 0, 1, 5, 6 and 2, 3, 7, 8.
        assert_eq!(b.pixels, vec![Vec3::splat(3.0), Vec3::splat(5.0)]);
    }

    #[test]
    fn auto_exposure_maps_the_lit_pixels_log_average_to_middle_grey() {
        // Half black, a quarter at 0.02 and a quarter at 0.5: the log-average of the lit
        // half is 0.1 (black pixels do not count), so the exposure is 0.18 / 0.1.
        let mut img = Image::new(4, 2);
        img.pixels[4..6].fill(Vec3::splat(0.02));
        img.pixels[6..8].fill(Vec3::splat(0.5));
        let e = img.lit_exposure().unwrap();
        assert!((e - 1.8).abs() < 1e-5, "{e}");
        assert_eq!(img.auto_exposure(), e);
        let black = Image::new(4, 2);
        assert_eq!(black.lit_exposure(), None);
        assert_eq!(black.auto_exposure(), 1.0);
    }

    #[test]
    fn errors_of_hand_made_images() {
        // Reference: black and grey 0.5; image: 0.1 over black, exactly 0.5 over grey.
        let mut reference = Image::new(2, 1);
        reference.pixels = vec![Vec3::ZERO, Vec3::splat(0.5)];
        let mut img = Image::new(2, 1);
        img.pixels = vec![Vec3::splat(0.1), Vec3::splat(0.5)];
        // 0.1² / (0 + 0.01) = 1 on each channel of the first pixel, 0 on the second.
        assert!((img.relative_mse(&reference) - 0.5).abs() < 1e-6);
        // 0.01 on three of six channels.
        assert!((img.mean_squared_error(&reference) - 0.005).abs() < 1e-9);
        assert_eq!(reference.mean_squared_error(&reference), 0.0);
    }

    #[test]
    fn exr_round_trip_is_half_precise() {
        let mut img = Image::new(7, 5);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32 * 0.37, 1.0 / (i as f32 + 1.0), 1000.0);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        img.write_exr(&path).unwrap();
        let back = Image::read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            // Half floats keep 11 significant bits.
            assert!(((*a - *b).abs() / a.abs().max(Vec3::splat(1e-3))).max_element() < 1e-3);
        }
        assert!(img.relative_mse(&img) == 0.0);
    }
}
