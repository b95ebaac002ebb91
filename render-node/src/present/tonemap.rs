//! Tone mapping at display only: Ward Larson's histogram adjustment (Ward Larson, Rushmeier
//! & Piatko 1997; the holodeck paper §2.4.6), in *camera* mode (every luminance level made
//! visible, contrast never exaggerated) and *human* mode (contrast limited by the
//! threshold-versus-intensity function of human vision), and *false colour* (luminance on
//! a fixed logarithmic scale with a legend, [`crate::present::falsecolor`]). In human mode the
//! image is first changed as the eye changes it — veiling glare, acuity and colour loss
//! ([`crate::present::vision`], [`ToneMapper::map_view`]) — and the mapping is made from that.
//!
//! World luminance is `efficacy` × the Rec. 709 luminance of the scene's radiance (cd/m²);
//! the efficacy is the tone mapper's (default Radiance's 179 lm/W, or a scene's
//! `holocave_scene::Photometry`).
//!
//! A scene whose world-luminance range fits the display's, or one whose histogram cannot
//! be brought under the ceiling (the adjusted mapping would be steeper than linear), is
//! mapped linearly instead, as Ward Larson et al. prescribe and Radiance's `pcond` does:
//! its contrast is shown as it is, never stretched. The linear scale puts the image's
//! log-mean at the display's log-middle (camera; moved just enough that a range that fits
//! is all shown) or scales by the ratio of the threshold contrasts at the display's and
//! the world's adaptation (human), clipped to the display's range.
//!
//! The mapping is computed from the histogram of the displayed image's log luminance and
//! then held: [`ToneMapper::update`] recomputes it only on request or when the image's
//! log-mean luminance moves by more than a stop, so the picture does not pump.

use glam::{Vec2, Vec3};
use holocave_tracer::film::{Image, srgb8};

use crate::present::falsecolor::{FalseColor, Legend};
use crate::present::vision::{self, PixelDirections, VeilSources};

const BINS: usize = 100;
/// Display luminance range (cd/m²).
const LD_MIN: f32 = 1.0;
const LD_MAX: f32 = 100.0;
/// Scene radiance (W/sr/m², linear RGB) to cd/m², as Radiance does: the default.
pub const LUMINOUS_EFFICACY: f32 = holocave_scene::photometry::RADIANCE_WHITE_EFFICACY;
/// Luminances below this (cd/m²) are treated as black and left out of the histogram.
const L_FLOOR: f32 = 1e-4;
/// When ceiling trimming leaves at most this fraction of the histogram, the scene needs no
/// compression and is mapped linearly (Radiance `pcond`'s `CVRATIO`); also the fraction
/// trimmed in a round below which trimming stops.
const CVRATIO: f32 = 0.025;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneMode {
    Camera,
    Human,
    /// Luminance on a logarithmic false-colour scale with a legend.
    FalseColor,
}

/// A brightness mapping: the cumulative histogram of log world luminance, or linear.
#[derive(Clone, Debug)]
pub struct Mapping {
    log_min: f32,
    log_max: f32,
    curve: Curve,
    /// Log-mean world luminance of the image it was made from.
    log_mean: f32,
}

#[derive(Clone, Debug)]
enum Curve {
    /// Histogram adjustment: the cumulative distribution at each bin's lower edge; BINS + 1
    /// entries, 0 to 1.
    Histogram(Vec<f32>),
    /// Linear: log10 Ld = log10 Lw + `log_scale`, clipped to the display's range.
    Linear { log_scale: f32 },
}

/// World luminance (cd/m²) of scene radiance `c` at `efficacy` lm/W.
fn luminance(c: Vec3, efficacy: f32) -> f32 {
    efficacy * holocave_scene::luminance(c)
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

/// What a mapping is made from: the histogram of an image's log10 world luminance
/// (cd/m²) over the pixels above black, in [`BINS`] bins from `log_min` to `log_max`.
/// Made on the CPU from an image ([`LogHistogram::of_image`]) or on the GPU from the
/// image where it lies (`present::Histogrammer`), so a window's frame never leaves the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct LogHistogram {
    pub log_min: f32,
    /// At least `log_min + 1e-3`.
    pub log_max: f32,
    pub log_mean: f32,
    /// Pixels counted (above black and finite).
    pub count: u64,
    pub bins: Vec<f32>,
}

impl LogHistogram {
    /// The histogram of `image` at `efficacy` lm/W (None when it has nothing above black).
    pub fn of_image(image: &Image, efficacy: f32) -> Option<LogHistogram> {
        let logs: Vec<f32> = image
            .pixels
            .iter()
            .map(|&c| luminance(c, efficacy))
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
        let mut bins = vec![0.0f32; BINS];
        for &l in &logs {
            let b = (((l - log_min) / db) as usize).min(BINS - 1);
            bins[b] += 1.0;
        }
        Some(LogHistogram {
            log_min,
            log_max,
            log_mean,
            count: logs.len() as u64,
            bins,
        })
    }
}

impl Mapping {
    /// The histogram adjustment of `image` at `efficacy` lm/W (None when it has nothing
    /// above black).
    pub fn new(image: &Image, mode: ToneMode, efficacy: f32) -> Option<Mapping> {
        LogHistogram::of_image(image, efficacy).and_then(|h| Mapping::from_histogram(&h, mode))
    }

    /// The histogram adjustment for a histogram of `BINS` bins (None when it is empty
    /// or has another number of bins).
    pub fn from_histogram(h: &LogHistogram, mode: ToneMode) -> Option<Mapping> {
        if h.count == 0 || h.bins.len() != BINS {
            return None;
        }
        let (log_min, log_max, log_mean) = (h.log_min, h.log_max, h.log_mean);
        let db = (log_max - log_min) / BINS as f32;
        let mut hist = h.bins.clone();
        let (ldmin, ldmax) = (LD_MIN.log10(), LD_MAX.log10());
        let total0: f32 = hist.iter().sum();
        let linear = |fits: bool| {
            let log_scale = match mode {
                // The log-mean at the display's log-middle; a range that fits is moved
                // just enough to be shown whole.
                ToneMode::Camera | ToneMode::FalseColor => {
                    let s = 0.5 * (ldmin + ldmax) - log_mean;
                    let (lo, hi) = (ldmin - log_min, ldmax - log_max);
                    if fits && lo <= hi { s.clamp(lo, hi) } else { s }
                }
                // Visibility matching: a just-noticeable difference at the world's
                // adaptation becomes one at the display's (pcond's `-s` linear scale).
                ToneMode::Human => log_tvi(0.5 * (ldmin + ldmax)) - log_tvi(log_mean),
            };
            Some(Mapping {
                log_min,
                log_max,
                curve: Curve::Linear { log_scale },
                log_mean,
            })
        };
        // A scene whose range fits the display's needs no compression: histogram
        // adjustment would only stretch its contrast (Ward Larson et al. 1997).
        if log_max - log_min <= ldmax - ldmin {
            return linear(true);
        }
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
        // 2.5% of the samples are trimmed in a round). If trimming leaves almost nothing,
        // no histogram meets the ceiling: any adjusted mapping would be steeper than the
        // linear one somewhere, so the linear one is used.
        for _ in 0..100 {
            let total: f32 = hist.iter().sum();
            if total <= CVRATIO * total0 {
                return linear(false);
            }
            let cdf = cdf_of(&hist);
            let mut trimmed = 0.0;
            for b in 0..BINS {
                let ceiling = match mode {
                    ToneMode::Camera | ToneMode::FalseColor => total * db / (ldmax - ldmin),
                    ToneMode::Human => {
                        let lw = log_min + (b as f32 + 0.5) * db;
                        let p = 0.5 * (cdf[b] + cdf[b + 1]);
                        let ld = ldmin + (ldmax - ldmin) * p;
                        // dLd/dLw ≤ tvi(Ld)/tvi(Lw), with dLd/dLw of the histogram
                        // mapping = (Ld/Lw)·f(b)·(ldmax − ldmin)/(T·Δb).
                        let ratio = 10f32.powf(log_tvi(ld) - log_tvi(lw));
                        ratio * total * db * 10f32.powf(lw) / ((ldmax - ldmin) * 10f32.powf(ld))
                    }
                };
                if hist[b] > ceiling {
                    trimmed += hist[b] - ceiling;
                    hist[b] = ceiling;
                }
            }
            if trimmed < CVRATIO * total {
                break;
            }
        }
        if hist.iter().sum::<f32>() <= CVRATIO * total0 {
            return linear(false);
        }
        Some(Mapping {
            log_min,
            log_max,
            curve: Curve::Histogram(cdf_of(&hist)),
            log_mean,
        })
    }

    /// Display luminance (cd/m², `LD_MIN..=LD_MAX`) for world luminance `lw` (cd/m²).
    pub fn display_luminance(&self, lw: f32) -> f32 {
        if lw <= L_FLOOR {
            return 0.0;
        }
        let (ldmin, ldmax) = (LD_MIN.log10(), LD_MAX.log10());
        let cdf = match &self.curve {
            Curve::Linear { log_scale } => {
                return 10f32.powf((lw.log10() + log_scale).clamp(ldmin, ldmax));
            }
            Curve::Histogram(cdf) => cdf,
        };
        let x = ((lw.log10() - self.log_min) / (self.log_max - self.log_min)).clamp(0.0, 1.0)
            * BINS as f32;
        let b = (x as usize).min(BINS - 1);
        let f = x - b as f32;
        let p = cdf[b] + (cdf[b + 1] - cdf[b]) * f;
        10f32.powf(ldmin + (ldmax - ldmin) * p)
    }
}

/// A mapping as a shader applies it (`present/screen.wgsl`): the same curve as
/// [`Mapping::display_luminance`], in numbers, or the false-colour scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneCurve {
    /// Linear (`log_scale`) instead of the histogram's cumulative distribution (`cdf`).
    pub linear: bool,
    pub log_min: f32,
    pub log_max: f32,
    pub log_scale: f32,
    /// The cumulative distribution at each bin's lower edge (`BINS + 1` entries).
    pub cdf: [f32; BINS + 1],
    /// lm/W: scene radiance to cd/m².
    pub efficacy: f32,
    /// False colour on this scale instead of the curve.
    pub false_color: Option<FalseColor>,
}

/// Bins of the log-luminance histogram.
pub const TONE_BINS: usize = BINS;

impl Mapping {
    /// The curve in the numbers a shader takes.
    pub fn curve(&self, efficacy: f32) -> ToneCurve {
        let mut c = ToneCurve {
            linear: false,
            log_min: self.log_min,
            log_max: self.log_max,
            log_scale: 0.0,
            cdf: [0.0; BINS + 1],
            efficacy,
            false_color: None,
        };
        match &self.curve {
            Curve::Linear { log_scale } => {
                c.linear = true;
                c.log_scale = *log_scale;
            }
            Curve::Histogram(cdf) => c.cdf.copy_from_slice(cdf),
        }
        c
    }
}

/// Tone mapping held between recomputations.
#[derive(Clone, Debug)]
pub struct ToneMapper {
    pub mode: ToneMode,
    /// lm/W: cd/m² per unit of the scene's radiance luminance.
    pub efficacy: f32,
    /// The false-colour scale (used in [`ToneMode::FalseColor`]).
    pub false_color: FalseColor,
    mapping: Option<Mapping>,
}

impl ToneMapper {
    /// A tone mapper at Radiance's 179 lm/W.
    pub fn new(mode: ToneMode) -> Self {
        Self::with_efficacy(mode, LUMINOUS_EFFICACY)
    }

    /// A tone mapper for a scene whose radiance is `efficacy` lm/W
    /// (`holocave_scene::Photometry::efficacy`).
    pub fn with_efficacy(mode: ToneMode, efficacy: f32) -> Self {
        ToneMapper {
            mode,
            efficacy,
            false_color: FalseColor::default(),
            mapping: None,
        }
    }

    /// Recomputes the mapping from `image` if there is none, if `force`, or if the image's
    /// log-mean luminance differs from the mapping's by more than a stop. True when
    /// recomputed. (False colour has a fixed scale: never.)
    pub fn update(&mut self, image: &Image, force: bool) -> bool {
        if self.mode == ToneMode::FalseColor {
            return false;
        }
        let stale = match &self.mapping {
            None => true,
            Some(m) => {
                let (sum, n) = image
                    .pixels
                    .iter()
                    .map(|&c| luminance(c, self.efficacy))
                    .filter(|&l| l > L_FLOOR && l.is_finite())
                    .fold((0.0f32, 0usize), |(s, n), l| (s + l.log10(), n + 1));
                n > 0 && (sum / n as f32 - m.log_mean).abs() > 2f32.log10()
            }
        };
        if (force || stale)
            && let Some(m) = Mapping::new(image, self.mode, self.efficacy)
        {
            self.mapping = Some(m);
            return true;
        }
        false
    }

    /// [`ToneMapper::update`] from an image's histogram (`None`: nothing above black, the
    /// mapping is kept).
    pub fn update_from(&mut self, h: Option<&LogHistogram>, force: bool) -> bool {
        if self.mode == ToneMode::FalseColor {
            return false;
        }
        let Some(h) = h.filter(|h| h.count > 0) else {
            return false;
        };
        let stale = match &self.mapping {
            None => true,
            Some(m) => (h.log_mean - m.log_mean).abs() > 2f32.log10(),
        };
        if (force || stale)
            && let Some(m) = Mapping::from_histogram(h, self.mode)
        {
            self.mapping = Some(m);
            return true;
        }
        false
    }

    /// The current mapping's curve for a shader (`None`: no mapping yet; the picture is
    /// black). False colour always has one.
    pub fn curve(&self) -> Option<ToneCurve> {
        if self.mode == ToneMode::FalseColor {
            let mut c = Mapping {
                log_min: 0.0,
                log_max: 1.0,
                curve: Curve::Linear { log_scale: 0.0 },
                log_mean: 0.0,
            }
            .curve(self.efficacy);
            c.false_color = Some(self.false_color);
            return Some(c);
        }
        self.mapping.as_ref().map(|m| m.curve(self.efficacy))
    }

    /// The 8-bit sRGB picture of `image` under the current mapping (black without one), or
    /// in false colour with its legend.
    pub fn apply(&self, image: &Image) -> image::RgbImage {
        if self.mode == ToneMode::FalseColor {
            let legend = Legend::new(&self.false_color, image.width, image.height);
            return image::RgbImage::from_fn(image.width, image.height, |x, y| {
                if let Some(c) = legend.as_ref().and_then(|l| l.at(x, y)) {
                    return image::Rgb(c);
                }
                let lw = luminance(image.at(x, y), self.efficacy);
                image::Rgb(self.false_color.colour(lw))
            });
        }
        image::RgbImage::from_fn(image.width, image.height, |x, y| {
            let c = image.at(x, y);
            let Some(m) = &self.mapping else {
                return image::Rgb([0, 0, 0]);
            };
            let lw = luminance(c, self.efficacy);
            let ld = m.display_luminance(lw);
            let scale = if lw > 0.0 { ld / lw / LD_MAX } else { 0.0 };
            let d = c * self.efficacy * scale;
            image::Rgb([srgb8(d.x), srgb8(d.y), srgb8(d.z)])
        })
    }

    /// The picture of `image`, seen through `dirs` (each pixel's direction from the eye):
    /// in human mode what a person would see ([`vision::perceive`], with the veil of the
    /// other walls' `imported` sources) mapped by a mapping made from it (updated as
    /// [`ToneMapper::update`] says, `force` to remake it); otherwise [`ToneMapper::update`]
    /// and [`ToneMapper::apply`]. Also this view's sources for the other walls' veils (none
    /// outside human mode).
    pub fn map_view(
        &mut self,
        image: &Image,
        dirs: PixelDirections,
        imported: &VeilSources,
        force: bool,
    ) -> (image::RgbImage, VeilSources) {
        if self.mode != ToneMode::Human {
            self.update(image, force);
            return (self.apply(image), VeilSources::none());
        }
        let seen = vision::perceive(image, dirs, imported, self.efficacy);
        self.update(&seen.image, force);
        (self.apply(&seen.image), seen.sources)
    }
}

/// The directions of a wall view's pixels, for [`ToneMapper::map_view`].
pub fn wall_directions(view: &holocave_cave::WallView) -> impl Fn(Vec2) -> Vec3 + '_ {
    move |p| view.ray(p).dir
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
            let m = Mapping::new(&img, mode, LUMINOUS_EFFICACY).unwrap();
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

    /// The slope of the mapping in log–log terms, `d log Ld / d log Lw`, between
    /// neighbouring world luminances `a < b`: 1 is the linear operator's contrast.
    fn log_slope(m: &Mapping, a: f32, b: f32) -> f32 {
        (m.display_luminance(b) / m.display_luminance(a)).log10() / (b / a).log10()
    }

    #[test]
    fn a_scene_whose_range_fits_the_display_is_mapped_linearly() {
        // A 2:1 scene (50 to 100 cd/m²) on a 100:1 display: its contrast is shown as it
        // is, 2:1, not stretched over the display's whole range.
        for mode in [ToneMode::Camera, ToneMode::Human] {
            let img = ramp(50.0, 100.0);
            let m = Mapping::new(&img, mode, LUMINOUS_EFFICACY).unwrap();
            let (lo, mid, hi) = (
                m.display_luminance(50.0),
                m.display_luminance(75.0),
                m.display_luminance(100.0),
            );
            assert!(
                (hi / lo - 2.0).abs() < 2e-3 && (mid / lo - 1.5).abs() < 2e-3,
                "{mode:?}: 50, 75, 100 cd/m² shown as {lo}, {mid}, {hi} cd/m² (not 2:1)"
            );
            assert!((LD_MIN..=LD_MAX).contains(&lo) && (LD_MIN..=LD_MAX).contains(&hi));
            // The 8-bit picture: the two ends' linear display values are 2:1 within the
            // rounding of their sRGB codes (half a code each).
            let mut t = ToneMapper::new(mode);
            assert!(t.update(&img, true));
            let px = t.apply(&img);
            let decode = |c: u8| {
                let s = f32::from(c) / 255.0;
                if s <= 0.040_45 {
                    s / 12.92
                } else {
                    ((s + 0.055) / 1.055).powf(2.4)
                }
            };
            let (a, b) = (px.get_pixel(0, 0)[1], px.get_pixel(63, 0)[1]);
            let (da, db) = (decode(a), decode(b));
            // d(linear)/d(code) relative to the value, for half a code at each end.
            let rel = |c: u8| (decode(c.saturating_add(1)) - decode(c)) / decode(c) / 2.0;
            let tol = 2.0 * (rel(a) + rel(b));
            assert!(
                (db / da / 2.0 - 1.0).abs() <= tol,
                "{mode:?}: sRGB codes {a} and {b} are {:.3}:1, not 2:1 (± {tol:.3})",
                db / da
            );
        }
    }

    #[test]
    fn camera_mode_never_shows_more_contrast_than_the_linear_operator() {
        // Whatever the scene's range, below, at or above the display's: nowhere is the
        // mapping steeper than linear (Ward Larson's ceiling; the linear fallback where
        // the ceiling cannot be met).
        for (lo, hi) in [
            (50.0, 100.0),
            (1.0, 10.0),
            (1.0, 99.0),
            (1.0, 1e3),
            (1e-2, 1e5),
        ] {
            let m = Mapping::new(&ramp(lo, hi), ToneMode::Camera, LUMINOUS_EFFICACY).unwrap();
            for k in 0..40 {
                let a = lo * (hi / lo).powf(k as f32 / 40.0);
                let b = lo * (hi / lo).powf((k + 1) as f32 / 40.0);
                let s = log_slope(&m, a, b);
                assert!(
                    s <= 1.0 + 0.05,
                    "{lo}..{hi} cd/m²: slope {s:.2} between {a:.3} and {b:.3} (linear is 1)"
                );
            }
        }
    }

    #[test]
    fn human_mode_shows_a_dim_scene_darker_than_camera_mode() {
        // A dim (mesopic) scene with a modest range: the camera brightens it to fill the
        // display; human vision sees it dim.
        let img = ramp(1e-2, 1.0);
        let cam = Mapping::new(&img, ToneMode::Camera, LUMINOUS_EFFICACY).unwrap();
        let hum = Mapping::new(&img, ToneMode::Human, LUMINOUS_EFFICACY).unwrap();
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

    #[test]
    fn human_mode_shows_a_dim_coloured_view_grey_and_camera_mode_in_colour() {
        // A 40° view of a red-orange wall at 0.002 cd/m², below the scotopic limit.
        let img = {
            let mut i = ramp(1.0, 1.0);
            let c = Vec3::new(1.0, 0.4, 0.2);
            let k = 0.002 / (LUMINOUS_EFFICACY * holocave_scene::luminance(c));
            i.pixels.iter_mut().for_each(|p| *p = c * k);
            i
        };
        let dirs = |p: Vec2| Vec3::new(-0.36 + 0.72 * p.x / 64.0, 0.02 - 0.01 * p.y, -1.0);
        let none = VeilSources::none();
        let (human, _) = ToneMapper::new(ToneMode::Human).map_view(&img, &dirs, &none, true);
        let (camera, _) = ToneMapper::new(ToneMode::Camera).map_view(&img, &dirs, &none, true);
        for (h, c) in human.pixels().zip(camera.pixels()) {
            assert!(h[0].abs_diff(h[2]) <= 1, "human mode: {h:?} is not grey");
            assert!(c[0] > c[2] + 50, "camera mode: {c:?} lost its colour");
        }
    }
}
