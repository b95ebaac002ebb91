//! A year's rows as a CSV, and the summary the standards use: the occupied hours with DGP
//! above EN 17037's class limits (0.35 perceptible, 0.40 disturbing, 0.45 intolerable), and
//! glare autonomy (Jakubiec & Reinhart 2012): the share of occupied hours whose DGP is
//! below a limit. An occupied hour without daylight counts as free of glare.

use std::io::Write;
use std::path::Path;

use serde_json::json;

use super::{HourOfYear, Row};
use crate::error::GlareError;

/// The CSV's first line.
pub const HEADER: &str = "month,day,hour,when,altitude_deg,dni_w_m2,dhi_w_m2,ev_lux,dgp,sources";

/// DGP's class limits (EN 17037).
pub const CLASS_LIMITS: [f64; 3] = [0.35, 0.40, 0.45];

/// Writes `rows` to `path`, one line a daylit hour.
pub fn write_csv(path: &Path, rows: &[Row]) -> Result<(), GlareError> {
    let err = |e: std::io::Error| GlareError::Write {
        path: path.into(),
        message: e.to_string(),
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(err)?);
    writeln!(out, "{HEADER}").map_err(err)?;
    for r in rows {
        let h = r.hour;
        writeln!(
            out,
            "{},{},{},{},{:.3},{:.1},{:.1},{:.1},{:.4},{}",
            h.month,
            h.day,
            h.hour,
            h.when.format("%Y-%m-%dT%H:%M"),
            r.altitude_deg,
            r.dni,
            r.dhi,
            r.figures.ev_lux,
            r.figures.dgp,
            r.figures.sources.len()
        )
        .map_err(err)?;
    }
    out.flush().map_err(err)
}

/// The occupied time of day: hours from `start` to `end`, local standard time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Occupied {
    pub start: u32,
    pub end: u32,
}

impl Default for Occupied {
    fn default() -> Self {
        Occupied { start: 8, end: 18 }
    }
}

impl Occupied {
    /// Whether the hour (ending at its stamp) lies within the occupied time.
    pub fn holds(&self, h: &HourOfYear) -> bool {
        h.hour > self.start && h.hour <= self.end
    }
}

/// The year's summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub daylit_hours: usize,
    pub occupied_hours: usize,
    /// Occupied hours with DGP above each of [`CLASS_LIMITS`].
    pub above: [usize; 3],
    /// The DGP below which an occupied hour counts as free of glare.
    pub limit: f64,
    /// The share of occupied hours with DGP below `limit`.
    pub glare_autonomy: f64,
}

impl Summary {
    /// The summary of `rows` (the daylit hours) among `all` the hours of the year.
    pub fn of(rows: &[Row], all: &[HourOfYear], occupied: Occupied, limit: f64) -> Summary {
        let occupied_hours = all.iter().filter(|h| occupied.holds(h)).count();
        let busy: Vec<f64> = (rows.iter())
            .filter(|r| occupied.holds(&r.hour))
            .map(|r| r.figures.dgp)
            .collect();
        let above = CLASS_LIMITS.map(|l| busy.iter().filter(|&&d| d > l).count());
        let glaring = busy.iter().filter(|&&d| d >= limit).count();
        Summary {
            daylit_hours: rows.len(),
            occupied_hours,
            above,
            limit,
            glare_autonomy: if occupied_hours == 0 {
                1.0
            } else {
                1.0 - glaring as f64 / occupied_hours as f64
            },
        }
    }

    pub fn to_json(&self) -> serde_json::Value {
        json!({
            "daylit_hours": self.daylit_hours,
            "occupied_hours": self.occupied_hours,
            "hours_dgp_above": {
                "0.35": self.above[0],
                "0.40": self.above[1],
                "0.45": self.above[2],
            },
            "glare_autonomy": self.glare_autonomy,
            "glare_autonomy_limit": self.limit,
        })
    }

    /// The summary as lines of text.
    pub fn report(&self, occupied: Occupied) -> String {
        let mut s = format!(
            "{} daylit hours; {} occupied ({:02}:00–{:02}:00)\n",
            self.daylit_hours, self.occupied_hours, occupied.start, occupied.end
        );
        for (l, n) in CLASS_LIMITS.iter().zip(self.above) {
            s += &format!("occupied hours with DGP > {l:.2}: {n}\n");
        }
        s += &format!(
            "glare autonomy (DGP < {:.2}): {:.1}% of occupied hours\n",
            self.limit,
            100.0 * self.glare_autonomy
        );
        s
    }
}
