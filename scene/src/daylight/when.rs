//! An instant as a user writes it: `2026-12-21T09:00` in the site's local standard time
//! (never daylight-saving time, as weather files keep it), or with an explicit offset
//! (`2026-12-21T09:00+01:00`, `…Z`), which is then turned into the site's standard time.

use std::fmt;
use std::str::FromStr;

use chrono::{DateTime, FixedOffset, NaiveDateTime, TimeZone};
use thiserror::Error;

#[derive(Debug, Error, PartialEq)]
#[error(
    "time {input:?}: {reason} (write YYYY-MM-DDTHH:MM[:SS], local standard time, \
     or with an offset such as +01:00 or Z)"
)]
pub struct WhenError {
    pub input: String,
    pub reason: String,
}

/// A date and time of day, local to the site or with its own offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum When {
    /// The site's local standard time.
    Local(NaiveDateTime),
    /// An instant with an explicit offset from UTC.
    Fixed(DateTime<FixedOffset>),
}

const LOCAL_FORMATS: [&str; 2] = ["%Y-%m-%dT%H:%M:%S", "%Y-%m-%dT%H:%M"];

impl FromStr for When {
    type Err = WhenError;

    fn from_str(s: &str) -> Result<When, WhenError> {
        let t = s.trim();
        for f in LOCAL_FORMATS {
            if let Ok(n) = NaiveDateTime::parse_from_str(t, f) {
                return Ok(When::Local(n));
            }
        }
        for f in ["%Y-%m-%dT%H:%M:%S%:z", "%Y-%m-%dT%H:%M%:z"] {
            if let Ok(d) = DateTime::parse_from_str(t, f) {
                return Ok(When::Fixed(d));
            }
        }
        if let Some(utc) = t.strip_suffix('Z').or_else(|| t.strip_suffix('z')) {
            for f in LOCAL_FORMATS {
                if let Ok(n) = NaiveDateTime::parse_from_str(utc, f) {
                    return Ok(When::Fixed(n.and_utc().fixed_offset()));
                }
            }
        }
        Err(WhenError {
            input: s.into(),
            reason: "not a date and time".into(),
        })
    }
}

impl When {
    /// The instant in the local standard time `zone` of a site; `None` only for a time
    /// at the very end of chrono's range, where the offset leaves it.
    pub fn in_zone(&self, zone: FixedOffset) -> Option<DateTime<FixedOffset>> {
        match self {
            When::Local(n) => zone.from_local_datetime(n).single(),
            When::Fixed(d) => {
                let utc = d.naive_utc();
                utc.checked_add_offset(zone).map(|_| d.with_timezone(&zone))
            }
        }
    }
}

impl fmt::Display for When {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            When::Local(n) => write!(f, "{}", n.format("%Y-%m-%dT%H:%M:%S")),
            When::Fixed(d) => write!(f, "{}", d.format("%Y-%m-%dT%H:%M:%S%:z")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_and_offset_times() {
        let chicago = FixedOffset::west_opt(6 * 3600).unwrap();
        let w: When = "2026-12-21T09:00".parse().unwrap();
        assert_eq!(
            w.in_zone(chicago).unwrap().to_rfc3339(),
            "2026-12-21T09:00:00-06:00"
        );
        let w: When = "2026-12-21T16:00+01:00".parse().unwrap();
        assert_eq!(
            w.in_zone(chicago).unwrap().to_rfc3339(),
            "2026-12-21T09:00:00-06:00"
        );
        let w: When = "2026-12-21T15:00:00Z".parse().unwrap();
        assert_eq!(
            w.in_zone(chicago).unwrap().to_rfc3339(),
            "2026-12-21T09:00:00-06:00"
        );
        assert_eq!(w.to_string().parse::<When>().unwrap(), w);
    }

    #[test]
    fn bad_times_name_the_input() {
        for bad in ["2026-13-01T09:00", "2026-12-21", "9:00", "2026-02-30T10:00"] {
            let e = bad.parse::<When>().unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
    }
}
