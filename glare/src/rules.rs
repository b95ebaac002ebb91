//! The rules of a glare evaluation, with `evalglare`'s defaults (version 2.10, the one in
//! Radiance's source tree): what counts as a glare source, how its pixels are merged,
//! peak extraction and the low-light correction.

use crate::error::GlareError;

/// Which pixels are glare source pixels: those whose luminance is above the threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold {
    /// A fixed luminance, cd/m² (`evalglare -b L` with `L > 100`; 2000 cd/m² is its
    /// default since version 2.05).
    Absolute(f64),
    /// A factor times the image's mean luminance (`evalglare -b f` with `f ≤ 100`; 5 was
    /// its default before 2.05, and is still with a task area).
    TimesAverage(f64),
}

impl Threshold {
    /// `evalglare -b`'s reading of one number: above 100 a luminance, else a factor.
    pub fn from_evalglare(b: f64) -> Result<Self, GlareError> {
        if !(b.is_finite() && b > 0.0) {
            return Err(GlareError::BadRules(format!(
                "the source threshold must be a positive number, got {b}"
            )));
        }
        Ok(if b > 100.0 {
            Threshold::Absolute(b)
        } else {
            Threshold::TimesAverage(b)
        })
    }

    /// The threshold luminance, cd/m², for an image of mean luminance `average`.
    pub fn luminance(&self, average: f64) -> f64 {
        match *self {
            Threshold::Absolute(l) => l,
            Threshold::TimesAverage(f) => f * average,
        }
    }
}

/// The largest search radius accepted, radians.
pub const MAX_SEARCH_RADIUS: f64 = 0.5;

/// The rules of one evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rules {
    pub threshold: Threshold,
    /// `evalglare -r`, radians (0.2): two source pixels belong to one source when
    /// `2 · angle ≤ search_radius` between their directions (evalglare's test, which
    /// doubles the angle: pixels up to 0.1 rad apart merge by default), or when a chain
    /// of such pixels joins them.
    pub search_radius: f64,
    /// Peak extraction (`evalglare`'s default, `-y`): the pixels of a source at or above
    /// this luminance (50 000 cd/m²) are split off into sources of their own, merged
    /// among themselves by the same rule. `None` (`-x`): no extraction.
    pub peak_limit: Option<f64>,
    /// Wienold's low-light correction of DGP below 1000 lx (on in `evalglare`).
    pub low_light: bool,
}

impl Default for Rules {
    fn default() -> Self {
        Rules {
            threshold: Threshold::Absolute(2000.0),
            search_radius: 0.2,
            peak_limit: Some(50_000.0),
            low_light: true,
        }
    }
}

impl Rules {
    /// Checks every number is in its range.
    pub fn validate(&self) -> Result<(), GlareError> {
        let bad = |m: String| Err(GlareError::BadRules(m));
        match self.threshold {
            Threshold::Absolute(l) | Threshold::TimesAverage(l) if !(l.is_finite() && l > 0.0) => {
                return bad(format!("the source threshold must be positive, got {l}"));
            }
            _ => {}
        }
        // Merging compares each source pixel with every pixel within reach, a window
        // whose area grows as the radius squared: past 0.5 rad a bright 512 × 512 view
        // would take minutes (evalglare's default is 0.2).
        if !(self.search_radius.is_finite()
            && self.search_radius > 0.0
            && self.search_radius <= MAX_SEARCH_RADIUS)
        {
            return bad(format!(
                "the search radius must be in (0, {MAX_SEARCH_RADIUS}] radians, got {}",
                self.search_radius
            ));
        }
        if let Some(p) = self.peak_limit
            && !(p.is_finite() && p > 0.0)
        {
            return bad(format!("the peak limit must be positive, got {p}"));
        }
        Ok(())
    }
}
