//! Tone mapping at display only: Ward Larson's histogram adjustment (Ward Larson, Rushmeier
//! & Piatko 1997; the holodeck paper §2.4.6), in *camera* mode (every luminance level made
//! visible, contrast never exaggerated) and *human* mode (contrast limited by the
//! threshold-versus-intensity function of human vision). Glare, colour sensitivity and
//! acuity loss of the full human model are not simulated.
//!
//! The mapping is computed from the histogram of the displayed image's log luminance and
//! then held: [`ToneMapper::update`] recomputes it only on request or when the image's
//! log-mean luminance moves by more than a stop, so the picture does not pump.

use glam::Vec3;
use holocave_tracer::film::Image;

const BINS: usize = 100;
/// Display luminance range (cd/m²).
const LD_MIN: f32 = 1.0;
const LD_MAX: f32 = 100.0;
/// Scene radiance (W/sr/m², linear RGB) to cd/m², as Radiance does.
pub const LUMINOUS_EFFICACY: f32 = 179.0;
/// Luminances below this (cd/m²) are treated as black and left out of the histogram.
const L_FLOOR: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneMode {
    Camera,
    Human,
}

/// A brightness mapping: the cumulative histogram of log world luminance.
#[derive(Clone, Debug)]
pub struct Mapping {
    log_min: f32,
    log_max: f32,
    /// Cumulative distribution at each bin's lower edge; BINS + 1 entries, 0 to 1.
    cdf: Vec<f32>,
    /// Log-mean world luminance of the image it was made from.
    log_mean: f32,
}

fn luminance(c: Vec3) -> f32 {
    LUMINOUS_EFFICACY * c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Ferwerda's threshold-versus-intensity: log10 of the just-noticeable luminance difference
/// at adaptation luminance 10^`log_la` cd/m² (rods and cones combined).
pub fn log_tvi(log_la: f32) -> f32 {
    if log_la < -3.94 {
        -2.86
    } else if log_la < -1.44 {
        (0.405 * log_la + 1.6).powf(2.18) - 2.86
    } else if log_la < -0.0184 {
        log_la - 0.395
    } else if log_la < 1.9 {
        (0.249 * log_la + 0.65).powf(2.7) - 0.72
    } else {
        log_la - 1.255
    }
}

impl Mapping {
    /// The histogram adjustment of `image` (None when it has nothing above black).
    pub fn new(image: &Image, mode: ToneMode) -> Option<Mapping> {
        let logs: Vec<f32> = image
            .pixels
            .iter()
            .map(|&c| luminance(c))
            .filter(|&l| l > L_FLOOR && l.is_finite())
            .map(f32::log10)
            .collect();
        if logs.is_empty() {
            return None;
        }
        let log_min = logs.iter().copied().fold(f32::INFINITY, f32::min);
        let log_max = logs
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max)
            .max(log_min + 1e-3);
        let log_mean = logs.iter().sum::<f32>() / logs.len() as f32;
        let db = (log_max - log_min) / BINS as f32;
        let mut hist = vec![0.0f32; BINS];
        for &l in &logs {
            let b = (((l - log_min) / db) as usize).min(BINS - 1);
            hist[b] += 1.0;
        }
        let (ldmin, ldmax) = (LD_MIN.log10(), LD_MAX.log10());
        let total0: f32 = hist.iter().sum();
        // If the scene's range fits the display, a linear (naive) mapping needs no
        // adjustment: contrast is never exaggerated.
        let cdf_of = |h: &[f32]| {
            let t: f32 = h.iter().sum::<f32>().max(1e-12);
            let mut cdf = Vec::with_capacity(BINS + 1);
            let mut acc = 0.0;
            cdf.push(0.0);
            for &v in h {
                acc += v;
                cdf.push(acc / t);
            }
            cdf
        };
        // Iteratively trim bins above the ceiling (the paper's loop; stops when less than
        // 2.5% of the samples are trimmed in a round).
        for _ in 0..100 {
            let total: f32 = hist.iter().sum();
            if total < 1e-6 * total0 {
                break;
            }
            let cdf = cdf_of(&hist);
            let mut trimmed = 0.0;
            for b in 0..BINS {
                let ceiling = match mode {
                    ToneMode::Camera => total * db / (ldmax - ldmin),
                    ToneMode::Human => {
                        let lw = log_min + (b as f32 + 0.5) * db;
                        let p = 0.5 * (cdf[b] + cdf[b + 1]);
                        let ld = ldmin + (ldmax - ldmin) * p;
                        let ratio = 10f32.powf(log_tvi(lw) - log_tvi(ld));
                        ratio * total * db * 10f32.powf(ld) / ((ldmax - ldmin) * 10f32.powf(lw))
                    }
                };
                if hist[b] > ceiling {
                    trimmed += hist[b] - ceiling;
                    hist[b] = ceiling;
                }
            }
            if trimmed < 0.025 * total {
                break;
            }
        }
        Some(Mapping {
            log_min,
            log_max,
            cdf: cdf_of(&hist),
            log_mean,
        })
    }

    /// Display luminance (cd/m², `LD_MIN..=LD_MAX`) for world luminance `lw` (cd/m²).
    pub fn display_luminance(&self, lw: f32) -> f32 {
        if lw <= L_FLOOR {
            return 0.0;
        }
        let x = ((lw.log10() - self.log_min) / (self.log_max - self.log_min)).clamp(0.0, 1.0)
            * BINS as f32;
        let b = (x as usize).min(BINS - 1);
        let f = x - b as f32;
        let p = self.cdf[b] + (self.cdf[b + 1] - self.cdf[b]) * f;
        10f32.powf(LD_MIN.log10() + (LD_MAX.log10() - LD_MIN.log10()) * p)
    }
}

/// Tone mapping held between recomputations.
#[derive(Clone, Debug)]
pub struct ToneMapper {
    pub mode: ToneMode,
    mapping: Option<Mapping>,
}

impl ToneMapper {
    pub fn new(mode: ToneMode) -> Self {
        ToneMapper {
            mode,
            mapping: None,
        }
    }

    /// Recomputes the mapping from `image` if there is none, if `force`, or if the image's
    /// log-mean luminance differs from the mapping's by more than a stop. True when
    /// recomputed.
    pub fn update(&mut self, image: &Image, force: bool) -> bool {
        let stale = match &self.mapping {
            None => true,
            Some(m) => {
                let (sum, n) = image
                    .pixels
                    .iter()
                    .map(|&c| luminance(c))
                    .filter(|&l| l > L_FLOOR && l.is_finite())
                    .fold((0.0f32, 0usize), |(s, n), l| (s + l.log10(), n + 1));
                n > 0 && (sum / n as f32 - m.log_mean).abs() > 2f32.log10()
            }
        };
        if (force || stale)
            && let Some(m) = Mapping::new(image, self.mode)
        {
            self.mapping = Some(m);
            return true;
        }
        false
    }

    /// The 8-bit sRGB picture of `image` under the current mapping (black without one).
    pub fn apply(&self, image: &Image) -> image::RgbImage {
        image::RgbImage::from_fn(image.width, image.height, |x, y| {
            let c = image.at(x, y);
            let Some(m) = &self.mapping else {
                return image::Rgb([0, 0, 0]);
            };
            let lw = luminance(c);
            let ld = m.display_luminance(lw);
            let scale = if lw > 0.0 { ld / lw / LD_MAX } else { 0.0 };
            let d = c * LUMINOUS_EFFICACY * scale;
            let enc = |v: f32| {
                let v = v.clamp(0.0, 1.0);
                let s = if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (s * 255.0 + 0.5) as u8
            };
            image::Rgb([enc(d.x), enc(d.y), enc(d.z)])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(lo: f32, hi: f32) -> Image {
        let mut img = Image::new(64, 4);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let t = (i % 64) as f32 / 63.0;
            *p = Vec3::splat(lo * (hi / lo).powf(t) / LUMINOUS_EFFICACY);
        }
        img
    }

    #[test]
    fn mapping_is_monotonic_and_within_the_display_range() {
        for mode in [ToneMode::Camera, ToneMode::Human] {
            let img = ramp(1e-2, 1e5);
            let m = Mapping::new(&img, mode).unwrap();
            let mut last = 0.0;
            for k in 0..=70 {
                let lw = 10f32.powf(-2.0 + k as f32 / 10.0);
                let ld = m.display_luminance(lw);
                assert!(ld >= last - 1e-4, "{mode:?}: not monotonic at {lw}");
                assert!((LD_MIN - 1e-3..=LD_MAX + 1e-3).contains(&ld));
                last = ld;
            }
        }
    }

    #[test]
    fn human_mode_shows_a_dim_scene_darker_than_camera_mode() {
        // A dim (mesopic) scene with a modest range: the camera brightens it to fill the
        // display; human vision sees it dim.
        let img = ramp(1e-2, 1.0);
        let cam = Mapping::new(&img, ToneMode::Camera).unwrap();
        let hum = Mapping::new(&img, ToneMode::Human).unwrap();
        let mid = 0.1;
        assert!(hum.display_luminance(mid) < cam.display_luminance(mid));
    }

    #[test]
    fn the_mapping_is_held_until_the_image_changes_a_lot() {
        let mut t = ToneMapper::new(ToneMode::Camera);
        let img = ramp(1.0, 1e3);
        assert!(t.update(&img, false));
        let mut brighter = img.clone();
        brighter.pixels.iter_mut().for_each(|p| *p *= 1.5);
        assert!(!t.update(&brighter, false), "half a stop: held");
        brighter.pixels.iter_mut().for_each(|p| *p *= 4.0);
        assert!(t.update(&brighter, false), "more than a stop: recomputed");
    }
}
