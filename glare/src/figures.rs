//! The glare figures of a fisheye, as `evalglare` defines them:
//!
//! - **Ev**, the vertical illuminance at the eye, lux: `Σ L cos θ ω` over the pixels in
//!   the view (`θ` from the line of sight to the pixel's centre, `ω` its solid angle).
//! - **DGP**, the daylight glare probability (Wienold & Christoffersen 2006, *Energy and
//!   Buildings* 38(7)):
//!   `DGP = 5.87·10⁻⁵ Ev + 9.18·10⁻² log10(1 + Σ Ls² ωs / (Ev^1.87 Ps²)) + 0.16`, capped
//!   at 1 (`0.16 + 5.87·10⁻⁵ Ev` without sources); with the low-light correction
//!   (Wienold 2009) below 1000 lx: `DGP · e^(0.024 Ev − 4) / (1 + e^(0.024 Ev − 4))`.
//!   The paper's constants; `evalglare` rounds them to 0.092 and 0.159 (its DGP is
//!   lower by 0.001 plus 2·10⁻⁴ of the log term). Valid for DGP from 0.2 to 0.8 and
//!   daylight-dominated views: below 0.2 it is outside the range it was fitted on.
//! - **UGR**, the unified glare rating (CIE 117-1995):
//!   `UGR = 8 log10(0.25 / Lb · Σ Ls² ωs / Ps²)`, with `Lb = (Ev − Ev,dir)/π` the
//!   background luminance as `evalglare` (since 2.05, its default, the CIE's way) takes
//!   it: `Ev,dir` the illuminance from the source pixels alone. 0 without sources (as
//!   `evalglare`); undefined (`None`) when `Lb` is not positive.

use glam::DVec3;

use crate::error::GlareError;
use crate::luminance::LuminanceMap;
use crate::rules::Rules;
use crate::sources::{self, Source};

/// DGP's coefficients (Wienold & Christoffersen 2006).
pub const DGP_EV: f64 = 5.87e-5;
pub const DGP_LOG: f64 = 9.18e-2;
pub const DGP_CONSTANT: f64 = 0.16;
pub const DGP_EV_EXPONENT: f64 = 1.87;

/// Below this illuminance, lux, the low-light correction applies.
pub const LOW_LIGHT_LUX: f64 = 1000.0;

/// DGP below this is outside the range the formula was fitted on.
pub const DGP_VALID_FROM: f64 = 0.2;

/// The figures of one fisheye.
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// Vertical illuminance at the eye, lux.
    pub ev_lux: f64,
    /// Daylight glare probability (low-light correction included when the rules ask).
    pub dgp: f64,
    /// Unified glare rating; `None` when the background luminance is not positive.
    pub ugr: Option<f64>,
    /// The background luminance UGR uses, cd/m².
    pub background_cd_m2: f64,
    /// The mean luminance of the view (weighted by solid angle), cd/m².
    pub average_cd_m2: f64,
    /// The luminance above which a pixel is a source pixel, cd/m².
    pub threshold_cd_m2: f64,
    /// The sources, the strongest (`L² ω / P²`) first.
    pub sources: Vec<Source>,
}

/// The low-light correction factor of DGP at `ev` lux (1 from 1000 lx up).
pub fn low_light_factor(ev: f64) -> f64 {
    if ev >= LOW_LIGHT_LUX {
        return 1.0;
    }
    let e = (0.024 * ev - 4.0).exp();
    e / (1.0 + e)
}

/// DGP at `ev` lux from the sources' `(L, ω, P)`, capped at 1, the low-light correction
/// applied when `low_light`.
pub fn dgp(ev: f64, sources: impl IntoIterator<Item = (f64, f64, f64)>, low_light: bool) -> f64 {
    let sum: f64 = sources
        .into_iter()
        .map(|(l, w, p)| l * l * w / (p * p))
        .sum();
    let glare = if sum > 0.0 && ev > 0.0 {
        DGP_LOG * (1.0 + sum / ev.powf(DGP_EV_EXPONENT)).log10()
    } else {
        0.0
    };
    let d = (DGP_EV * ev + glare + DGP_CONSTANT).min(1.0);
    if low_light {
        d * low_light_factor(ev)
    } else {
        d
    }
}

/// UGR from the background luminance `lb` and the sources' `(L, ω, P)`: 0 without
/// sources, `None` when `lb` is not positive.
pub fn ugr(lb: f64, sources: impl IntoIterator<Item = (f64, f64, f64)>) -> Option<f64> {
    let sum: f64 = sources
        .into_iter()
        .map(|(l, w, p)| l * l * w / (p * p))
        .sum();
    if lb <= 0.0 {
        return None;
    }
    if sum == 0.0 {
        return Some(0.0);
    }
    Some(8.0 * (0.25 / lb * sum).log10())
}

impl Figures {
    /// Whether DGP is in the range its formula was fitted on (from 0.2).
    pub fn dgp_in_range(&self) -> bool {
        self.dgp >= DGP_VALID_FROM
    }

    /// The figures as one JSON object: `ev_lux`, `dgp`, `ugr` (null when undefined),
    /// `background_cd_m2`, `threshold_cd_m2` and `sources`, each with its `direction`
    /// (unit, scene coordinates), `solid_angle_sr`, `luminance_cd_m2` and
    /// `position_index`.
    pub fn to_json(&self) -> serde_json::Value {
        let sources: Vec<serde_json::Value> = self
            .sources
            .iter()
            .map(|s| {
                serde_json::json!({
                    "direction": s.direction.to_array(),
                    "solid_angle_sr": s.solid_angle_sr,
                    "luminance_cd_m2": s.luminance_cd_m2,
                    "position_index": s.position_index,
                })
            })
            .collect();
        serde_json::json!({
            "ev_lux": self.ev_lux,
            "dgp": self.dgp,
            "ugr": self.ugr,
            "background_cd_m2": self.background_cd_m2,
            "threshold_cd_m2": self.threshold_cd_m2,
            "sources": sources,
        })
    }
}

/// Evaluates a fisheye by `rules`.
pub fn evaluate(map: &LuminanceMap, rules: &Rules) -> Result<Figures, GlareError> {
    rules.validate()?;
    let f = &map.fisheye;
    let omega = f.solid_angles();
    let dirs = f.directions();
    evaluate_with(map, rules, &omega, &dirs)
}

/// [`evaluate`] with the fisheye's solid angles and directions already computed (a
/// meter measuring every frame at one size computes them once).
pub fn evaluate_with(
    map: &LuminanceMap,
    rules: &Rules,
    omega: &[f64],
    dirs: &[Option<DVec3>],
) -> Result<Figures, GlareError> {
    rules.validate()?;
    let f = &map.fisheye;
    let l = &map.luminance;
    let cosine = |i: usize| dirs[i].map_or(0.0, |d| d.dot(f.look).max(0.0));
    let (mut ev, mut sum_omega, mut sum_lw) = (0.0, 0.0, 0.0);
    for i in 0..l.len() {
        ev += l[i] * cosine(i) * omega[i];
        sum_omega += omega[i];
        sum_lw += l[i] * omega[i];
    }
    let average = if sum_omega > 0.0 {
        sum_lw / sum_omega
    } else {
        0.0
    };
    let threshold = rules.threshold.luminance(average);
    let sources = sources::find(
        f,
        omega,
        dirs,
        l,
        threshold,
        rules.search_radius,
        rules.peak_limit,
    );
    let ev_dir: f64 = sources
        .iter()
        .flat_map(|s| &s.pixels)
        .map(|&p| l[p as usize] * cosine(p as usize) * omega[p as usize])
        .sum();
    let lb = (ev - ev_dir) / std::f64::consts::PI;
    let terms = || {
        sources
            .iter()
            .map(|s| (s.luminance_cd_m2, s.solid_angle_sr, s.position_index))
    };
    Ok(Figures {
        ev_lux: ev,
        dgp: dgp(ev, terms(), rules.low_light),
        ugr: ugr(lb, terms()),
        background_cd_m2: lb,
        average_cd_m2: average,
        threshold_cd_m2: threshold,
        sources,
    })
}

impl Figures {
    /// The figures as lines of text: Ev, DGP (with its glare class, and a note when it
    /// is below its range), UGR, the background and the sources.
    pub fn report(&self) -> String {
        let class = match self.dgp {
            d if d < 0.35 => "imperceptible",
            d if d < 0.40 => "perceptible",
            d if d < 0.45 => "disturbing",
            _ => "intolerable",
        };
        let mut s = format!("Ev   {:.1} lx\n", self.ev_lux);
        s += &format!("DGP  {:.3} ({class})", self.dgp);
        if !self.dgp_in_range() {
            s += "; below 0.2, outside the range DGP was fitted on";
        }
        s += "\n";
        s += &match self.ugr {
            Some(u) => format!("UGR  {u:.1}\n"),
            None => "UGR  undefined (no background luminance)\n".into(),
        };
        s += &format!(
            "background {:.1} cd/m², mean {:.1} cd/m², source threshold {:.1} cd/m²\n",
            self.background_cd_m2, self.average_cd_m2, self.threshold_cd_m2
        );
        s += &format!("{} glare source(s)\n", self.sources.len());
        for (i, src) in self.sources.iter().enumerate() {
            let d = src.direction;
            s += &format!(
                "  {:>2}. direction ({:.3}, {:.3}, {:.3}), {:.3e} sr, {:.0} cd/m², P {:.2}{}\n",
                i + 1,
                d.x,
                d.y,
                d.z,
                src.solid_angle_sr,
                src.luminance_cd_m2,
                src.position_index,
                if src.peak { " (peak)" } else { "" }
            );
        }
        s
    }
}
