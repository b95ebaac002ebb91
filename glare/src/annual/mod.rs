//! A year's glare at one seat (`holocave glare --annual`): for every daylit hour of a
//! weather file, Ev, DGP and the sources' count of the seat's fisheye, and the summary the
//! standards use. The view is traced once into daylight coefficients
//! ([`coefficients`]); each hour is then a product with that hour's sky and sun plus its
//! sharp parts ([`hour`]), and its figures are `evalglare`'s ([`crate::figures`]). An
//! hour's row is the glare `holocave glare --when` measures at the row's `when` (the
//! middle of the weather file's hour), within the coefficients' discretisation
//! (`docs/usage/glare.md`). [`table`] writes the rows and the summary, [`map`] the
//! temporal map.

pub mod coefficients;
pub mod hour;
pub mod map;
pub mod patches;
pub mod table;

use std::path::Path;
use std::sync::Arc;

use chrono::{NaiveDate, NaiveDateTime};
use holocave_scene::daylight::{Daylight, Moment, Site, Weather, When};
use holocave_scene::load::load_daylight;
use holocave_scene::{Photometry, Scene, SceneError};
use rayon::prelude::*;

use crate::error::GlareError;
use crate::figures::{Figures, evaluate};
use crate::fisheye::Fisheye;
use crate::luminance::LuminanceMap;
use crate::rules::Rules;
use coefficients::ViewCoefficients;
use hour::HourLight;

/// One hour of the weather file, at the year asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HourOfYear {
    pub month: u32,
    pub day: u32,
    /// 1–24: the hour ending at this stamp (the file's own stamp).
    pub hour: u32,
    /// The middle of the hour, local standard time: the `--when` of a single run.
    pub when: NaiveDateTime,
}

/// Every row of `weather` at `year`. Error: a row whose date that year does not have
/// (29 February outside leap years).
pub fn hours_of(weather: &Weather, year: i32) -> Result<Vec<HourOfYear>, String> {
    weather
        .stamps()
        .map(|(month, day, hour)| {
            let when = NaiveDate::from_ymd_opt(year, month, day)
                .and_then(|d| d.and_hms_opt(hour - 1, 30, 0))
                .ok_or_else(|| {
                    format!(
                        "{}: the row of {month:02}-{day:02} hour {hour} has no date in {year} \
                         (give a --year that has it)",
                        weather.path.display()
                    )
                })?;
            Ok(HourOfYear {
                month,
                day,
                hour,
                when,
            })
        })
        .collect()
}

/// An hour's light: where its sun stands, the weather's irradiance, and (while the sun is
/// up) the daylight as the scene is loaded at that hour.
pub struct LitHour {
    pub hour: HourOfYear,
    pub altitude_deg: f64,
    pub dni: f64,
    pub dhi: f64,
    /// `None` while the sun's centre is below the horizon.
    pub daylight: Option<Daylight>,
}

impl LitHour {
    /// Whether the sun's centre is above the horizon.
    pub fn daylit(&self) -> bool {
        self.daylight.is_some()
    }
}

/// The light of each hour as `holocave glare --when` loads it: the scene's daylight file
/// `daylight` (else the one beside `scene_path`; `file_site` its `[site]`) with the
/// weather's hour. The sun's position comes first: a night hour loads no daylight and
/// reads no weather row.
pub fn light_of_hours(
    scene_path: &Path,
    (daylight, file_site): (Option<&Path>, Option<&Site>),
    weather: &Arc<Weather>,
    hours: &[HourOfYear],
) -> Result<Vec<LitHour>, SceneError> {
    let err = |message: String| SceneError::Daylight {
        path: weather.path.clone(),
        message,
    };
    hours
        .par_iter()
        .map(|&hour| {
            let moment = Moment {
                when: When::Local(hour.when),
                weather: Some(weather.clone()),
            };
            let site = moment.site(file_site).map_err(|e| err(e.to_string()))?;
            let time = (moment.when.in_zone(site.offset()))
                .ok_or_else(|| err(format!("{} has no instant", hour.when)))?;
            let altitude_deg = (site.sun_at(&time).map_err(|e| err(e.to_string()))?).altitude_deg();
            if altitude_deg <= 0.0 {
                return Ok(LitHour {
                    hour,
                    altitude_deg,
                    dni: 0.0,
                    dhi: 0.0,
                    daylight: None,
                });
            }
            let row =
                (weather.hour(hour.month, hour.day, hour.hour)).map_err(|e| err(e.to_string()))?;
            Ok(LitHour {
                hour,
                altitude_deg,
                dni: row.dni,
                dhi: row.dhi,
                daylight: Some(load_daylight(scene_path, daylight, Some(&moment))?),
            })
        })
        .collect()
}

/// The sky patches the sun stands in at some daylit hour, in order.
pub fn sun_patches(hours: &[LitHour]) -> Vec<usize> {
    let mut p: Vec<usize> = (hours.iter())
        .filter_map(|h| h.daylight.as_ref()?.sun.as_ref())
        .map(|s| patches::patch_of(s.direction))
        .collect();
    p.sort_unstable();
    p.dedup();
    p
}

/// One daylit hour's figures.
#[derive(Clone, Debug)]
pub struct Row {
    pub hour: HourOfYear,
    pub altitude_deg: f64,
    pub dni: f64,
    pub dhi: f64,
    pub figures: Figures,
}

/// The figures of each daylit hour of `hours` from the view's coefficients, in order.
/// `progress` is called with the hours done so far.
pub fn rows(
    scene: &Scene,
    coefficients: &ViewCoefficients,
    hours: &[LitHour],
    (rules, photometry): (&Rules, &Photometry),
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Row>, GlareError> {
    let done = std::sync::atomic::AtomicUsize::new(0);
    let daylit: Vec<&LitHour> = hours.iter().filter(|h| h.daylit()).collect();
    daylit
        .par_iter()
        .map(|h| {
            let figures = hour_figures(scene, coefficients, h, rules, photometry)?;
            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
            Ok(Row {
                hour: h.hour,
                altitude_deg: h.altitude_deg,
                dni: h.dni,
                dhi: h.dhi,
                figures,
            })
        })
        .collect()
}

/// One hour's figures from the view's coefficients.
pub fn hour_figures(
    scene: &Scene,
    coefficients: &ViewCoefficients,
    h: &LitHour,
    rules: &Rules,
    photometry: &Photometry,
) -> Result<Figures, GlareError> {
    let daylight = h.daylight.as_ref();
    let light = HourLight {
        sun: daylight.and_then(|d| d.sun.as_ref()),
        sky: daylight.and_then(|d| d.sky.as_ref()),
    };
    let image = light.draw(scene, coefficients);
    let map = LuminanceMap::from_radiance(coefficients.fisheye.clone(), &image, photometry)?;
    evaluate(&map, rules)
}

/// The fisheye an annual run measures for a seat: `coefficients` traced for `fisheye` in
/// `scene` with a sun column for each patch the sun of `hours` visits.
pub fn trace_view(
    scene: &Scene,
    fisheye: &Fisheye,
    hours: &[LitHour],
    spp: u32,
    seed: u64,
) -> ViewCoefficients {
    ViewCoefficients::trace(scene, fisheye, sun_patches(hours), spp, seed)
}
