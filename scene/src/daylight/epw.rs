//! EnergyPlus weather (EPW) files: the site from the LOCATION line, and an hour's direct
//! normal and diffuse horizontal irradiance.
//!
//! Rows follow the eight header lines, one per hour. In a row (1-based fields) 2, 3 and 4
//! are the month, day and hour; hour `h` (1–24) is the hour from `h − 1` to `h` local
//! standard time, and its radiation fields are totals over that hour (Wh/m², the hour's
//! mean W/m²): 15 is the direct normal irradiance, 16 the diffuse horizontal. 9999 marks
//! a missing value. The year column of a typical-year file mixes years, so an hour is
//! found by month, day and hour alone.

use std::path::{Path, PathBuf};

use chrono::{DateTime, Datelike, FixedOffset, Timelike};
use thiserror::Error;

use super::site::{Site, SiteError};

/// A weather file that could not be read, or an hour it cannot give.
#[derive(Debug, Error)]
pub enum EpwError {
    #[error("cannot read weather file {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("weather file {path}, line {line}: {message}")]
    Header {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("weather file {path}, line {line}, field {field} ({name}): {message}")]
    Field {
        path: PathBuf,
        line: usize,
        field: usize,
        name: &'static str,
        message: String,
    },
    #[error(
        "weather file {path} has no row for {month:02}-{day:02} hour {hour} (the hour ending at {hour}:00)"
    )]
    NoRow {
        path: PathBuf,
        month: u32,
        day: u32,
        hour: u32,
    },
}

/// One hour's radiation, W/m² (the hour's mean).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hour {
    pub month: u32,
    pub day: u32,
    /// 1–24: the hour ending at this stamp.
    pub hour: u32,
    /// The row's line in the file, 1-based.
    pub line: usize,
    /// Direct normal irradiance (field 15).
    pub dni: f64,
    /// Diffuse horizontal irradiance (field 16).
    pub dhi: f64,
}

/// A weather file: its site and its rows' stamps; radiation is read per hour asked.
#[derive(Clone, Debug)]
pub struct Weather {
    pub path: PathBuf,
    /// From the LOCATION line (north −Z).
    pub site: Site,
    /// Each row's (month, day, hour, line, text).
    rows: Vec<Row>,
}

#[derive(Clone, Debug)]
struct Row {
    month: u32,
    day: u32,
    hour: u32,
    line: usize,
    text: String,
}

const HEADER_LINES: usize = 8;
const FIELD_NAMES: [&str; 16] = [
    "year",
    "month",
    "day",
    "hour",
    "minute",
    "data source flags",
    "dry bulb temperature",
    "dew point temperature",
    "relative humidity",
    "station pressure",
    "extraterrestrial horizontal radiation",
    "extraterrestrial direct normal radiation",
    "horizontal infrared radiation",
    "global horizontal radiation",
    "direct normal radiation",
    "diffuse horizontal radiation",
];

impl Weather {
    pub fn load(path: &Path) -> Result<Weather, EpwError> {
        let text = std::fs::read_to_string(path).map_err(|source| EpwError::Io {
            path: path.into(),
            source,
        })?;
        Weather::parse(&text, path)
    }

    /// Parses the text of an EPW file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Weather, EpwError> {
        let lines: Vec<&str> = text.lines().collect();
        let site = parse_location(lines.first().copied().unwrap_or(""), path)?;
        match lines.get(HEADER_LINES - 1) {
            Some(l) if l.starts_with("DATA PERIODS") => {}
            _ => {
                return Err(EpwError::Header {
                    path: path.into(),
                    line: HEADER_LINES,
                    message: "expected the DATA PERIODS line (the eighth header line)".into(),
                });
            }
        }
        let mut rows = Vec::with_capacity(8760);
        for (i, l) in lines.iter().enumerate().skip(HEADER_LINES) {
            if l.trim().is_empty() {
                continue;
            }
            rows.push(parse_stamp(l, i + 1, path)?);
        }
        Ok(Weather {
            path: path.into(),
            site,
            rows,
        })
    }

    /// The number of hourly rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Each row's stamp, in the file's order: (month, day, hour 1–24, the hour ending then).
    pub fn stamps(&self) -> impl Iterator<Item = (u32, u32, u32)> + '_ {
        self.rows.iter().map(|r| (r.month, r.day, r.hour))
    }

    /// The row whose hour holds `when` (turned into the file's standard time): from
    /// `HH:00` up to the next hour is the row stamped `HH + 1`.
    pub fn hour_at(&self, when: &DateTime<FixedOffset>) -> Result<Hour, EpwError> {
        let local = when.with_timezone(&self.site.offset());
        self.hour(local.month(), local.day(), local.hour() + 1)
    }

    /// The row stamped `month`-`day` `hour` (1–24), with its radiation checked.
    pub fn hour(&self, month: u32, day: u32, hour: u32) -> Result<Hour, EpwError> {
        let row = self
            .rows
            .iter()
            .find(|r| (r.month, r.day, r.hour) == (month, day, hour))
            .ok_or_else(|| EpwError::NoRow {
                path: self.path.clone(),
                month,
                day,
                hour,
            })?;
        let fields: Vec<&str> = row.text.split(',').collect();
        let value = |field| irradiance(&fields, field, row.line, &self.path);
        Ok(Hour {
            month,
            day,
            hour,
            line: row.line,
            dni: value(15)?,
            dhi: value(16)?,
        })
    }
}

fn parse_location(line: &str, path: &Path) -> Result<Site, EpwError> {
    let err = |message: String| EpwError::Header {
        path: path.into(),
        line: 1,
        message,
    };
    let f: Vec<&str> = line.split(',').map(str::trim).collect();
    if f.first() != Some(&"LOCATION") || f.len() < 10 {
        return Err(err(
            "expected LOCATION,city,state,country,source,WMO,latitude,longitude,time zone,elevation".into(),
        ));
    }
    let num = |i: usize, name: &str| {
        f[i].parse::<f64>()
            .map_err(|_| err(format!("LOCATION's {name} {:?} is not a number", f[i])))
    };
    Site::new(
        num(6, "latitude")?,
        num(7, "longitude")?,
        num(9, "elevation")?,
        num(8, "time zone")?,
    )
    .map_err(|e: SiteError| err(format!("LOCATION: {e}")))
}

fn field_error(path: &Path, line: usize, field: usize, message: String) -> EpwError {
    EpwError::Field {
        path: path.into(),
        line,
        field,
        name: FIELD_NAMES[field - 1],
        message,
    }
}

fn parse_stamp(text: &str, line: usize, path: &Path) -> Result<Row, EpwError> {
    let fields: Vec<&str> = text.split(',').collect();
    let int = |field: usize, lo: u32, hi: u32| -> Result<u32, EpwError> {
        let raw = fields.get(field - 1).map(|s| s.trim()).unwrap_or("");
        match raw.parse::<u32>() {
            Ok(v) if (lo..=hi).contains(&v) => Ok(v),
            _ => Err(field_error(
                path,
                line,
                field,
                format!("{raw:?} is not a whole number in {lo}..={hi}"),
            )),
        }
    };
    Ok(Row {
        month: int(2, 1, 12)?,
        day: int(3, 1, 31)?,
        hour: int(4, 1, 24)?,
        line,
        text: text.to_owned(),
    })
}

fn irradiance(fields: &[&str], field: usize, line: usize, path: &Path) -> Result<f64, EpwError> {
    let Some(raw) = fields.get(field - 1).map(|s| s.trim()) else {
        return Err(field_error(
            path,
            line,
            field,
            format!("the row has only {} fields", fields.len()),
        ));
    };
    match raw.parse::<f64>() {
        Ok(v) if v >= 9999.0 => Err(field_error(path, line, field, format!("missing ({raw})"))),
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(field_error(
            path,
            line,
            field,
            format!("{raw:?} is not an irradiance (W/m², ≥ 0)"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file_with(row: &str) -> String {
        let mut s = String::from("LOCATION,Here,,,,0,41.98,-87.92,-6.0,201.0\n");
        for h in [
            "DESIGN",
            "TYPICAL",
            "GROUND",
            "HOLIDAYS",
            "COMMENTS 1",
            "COMMENTS 2",
        ] {
            s += &format!("{h},x\n");
        }
        s += "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n";
        s += "1999,6,21,12,0,flags,20,10,50,99000,1300,1360,350,800,700,150\n";
        s += row;
        s
    }

    #[test]
    fn broken_rows_name_file_line_and_field() {
        let p = Path::new("w.epw");
        let ok = Weather::parse(&file_with(""), p).unwrap();
        assert_eq!(ok.hour(6, 21, 12).unwrap().dni, 700.0);
        let cases = [
            (
                "1999,6,21,13,0,f,20,10,50,99000,1,1,1,1,9999,100\n",
                "field 15",
                "missing",
            ),
            (
                "1999,6,21,13,0,f,20,10,50,99000,1,1,1,1,500,abc\n",
                "field 16",
                "\"abc\"",
            ),
            (
                "1999,6,21,13,0,f,20,10,50,99000,1,1,1,1,-3,100\n",
                "field 15",
                "\"-3\"",
            ),
            ("1999,6,21,13,0,f,20,10\n", "field 15", "only 8 fields"),
        ];
        for (row, field, what) in cases {
            let w = Weather::parse(&file_with(row), p).unwrap();
            let e = w.hour(6, 21, 13).unwrap_err().to_string();
            assert!(
                e.contains("w.epw")
                    && e.contains("line 10")
                    && e.contains(field)
                    && e.contains(what),
                "{e}"
            );
        }
        let e = Weather::parse(&file_with("1999,13,21,13,0\n"), p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 10") && e.contains("field 2 (month)"),
            "{e}"
        );
        let e = Weather::parse("LOCATION,Here,,,,0,north,-87.92,-6.0,201.0\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1") && e.contains("latitude"), "{e}");
        let e = Weather::parse("LOCATION,Here,,,,0,41,-87.92,-6.0,201.0\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 8") && e.contains("DATA PERIODS"), "{e}");
    }
}
