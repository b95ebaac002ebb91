//! The EPW reader on the shared Chicago O'Hare TMY3 file (`../shared/weather` beside the
//! checkout; skipped where absent, unless `HOLOCAVE_REQUIRE_SHARED=1`): its site, and an
//! hour found from local, UTC and leap-day times.

use crate::common;

use chrono::DateTime;
use holocave_scene::daylight::Weather;

fn chicago() -> Option<Weather> {
    common::shared_file("weather/USA_IL_Chicago-OHare.725300_TMY3.epw")
        .map(|p| Weather::load(&p).unwrap())
}

#[test]
fn reads_the_shared_chicago_file() {
    let Some(w) = chicago() else {
        return;
    };
    assert_eq!(w.len(), 8760);
    assert_eq!((w.site.latitude_deg, w.site.longitude_deg), (41.98, -87.92));
    assert_eq!((w.site.time_zone_h, w.site.elevation_m), (-6.0, 201.0));
    // Line 4000 is `1979,6,16,8,…`: GHI 466, DNI 536, DHI 171 over 07:00–08:00.
    let when = DateTime::parse_from_rfc3339("2026-06-16T07:30:00-06:00").unwrap();
    let h = w.hour_at(&when).unwrap();
    assert_eq!((h.line, h.hour, h.dni, h.dhi), (4000, 8, 536.0, 171.0));
    // The same hour asked in UTC, at its first instant.
    let utc = DateTime::parse_from_rfc3339("2026-06-16T13:00:00Z").unwrap();
    assert_eq!(w.hour_at(&utc).unwrap().line, 4000);
    // A typical year has no 29 February.
    let leap = DateTime::parse_from_rfc3339("2028-02-29T12:00:00-06:00").unwrap();
    assert!(w.hour_at(&leap).unwrap_err().to_string().contains("02-29"));
}
