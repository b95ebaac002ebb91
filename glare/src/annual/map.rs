//! The temporal map of a year's glare: day of the year across, hour of the day down, each
//! hour coloured by its DGP class (EN 17037): imperceptible (up to 0.35) pale, perceptible
//! yellow, disturbing orange, intolerable (above 0.45) red; hours without daylight dark.
//! Grey lines mark 6:00, 12:00 and 18:00, and each month's first day.

use std::path::Path;

use chrono::{Datelike, NaiveDate};
use image::{Rgb, RgbImage};

use super::Row;
use super::table::CLASS_LIMITS;
use crate::error::GlareError;

/// Pixels per day across and per hour down.
const DAY_PX: u32 = 2;
const HOUR_PX: u32 = 8;

const NIGHT: Rgb<u8> = Rgb([40, 40, 48]);
const CLASSES: [Rgb<u8>; 4] = [
    Rgb([236, 236, 220]),
    Rgb([245, 215, 66]),
    Rgb([240, 140, 40]),
    Rgb([215, 48, 31]),
];

/// The colour of a DGP.
pub fn class_colour(dgp: f64) -> Rgb<u8> {
    let class = CLASS_LIMITS.iter().filter(|&&l| dgp > l).count();
    CLASSES[class]
}

const GRID: Rgb<u8> = Rgb([128, 128, 136]);

/// Lines at 6:00, 12:00 and 18:00, and at the first of each month of `year` but January.
fn draw_grid(img: &mut RgbImage, year: i32) {
    for hour in [6, 12, 18] {
        for x in 0..img.width() {
            img.put_pixel(x, hour * HOUR_PX, GRID);
        }
    }
    for month in 2..=12 {
        let Some(first) = NaiveDate::from_ymd_opt(year, month, 1) else {
            continue;
        };
        for y in 0..img.height() {
            img.put_pixel(first.ordinal0() * DAY_PX, y, GRID);
        }
    }
}

/// Writes the temporal map of `rows` to `path` (PNG): 366 days by 24 hours.
pub fn write_temporal_map(path: &Path, rows: &[Row]) -> Result<(), GlareError> {
    let mut img = RgbImage::from_pixel(366 * DAY_PX, 24 * HOUR_PX, NIGHT);
    for r in rows {
        let day = r.hour.when.ordinal0();
        let hour = r.hour.hour - 1;
        let c = class_colour(r.figures.dgp);
        for x in day * DAY_PX..(day + 1) * DAY_PX {
            for y in hour * HOUR_PX..(hour + 1) * HOUR_PX {
                img.put_pixel(x, y, c);
            }
        }
    }
    let year = rows.first().map_or(2026, |r| r.hour.when.year());
    draw_grid(&mut img, year);
    img.save(path).map_err(|e| GlareError::Write {
        path: path.into(),
        message: e.to_string(),
    })
}
