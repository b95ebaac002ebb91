//! A site on the Earth and the sun seen from it, by NREL's Solar Position Algorithm.
//!
//! The sun's position comes from the `solar-positioning` crate's SPA (Reda & Andreas
//! 2004/2008): topocentric, with atmospheric refraction for the site's pressure and
//! temperature. Azimuths are degrees from north through east (0 north, 90 east).
//!
//! glTF has no north: the site's `north` is the direction in scene coordinates that points
//! north, horizontal (perpendicular to +Y, the scene's up). Its default is −Z, so east is
//! +X (east = north × up in a right-handed frame).

use chrono::{DateTime, Datelike, FixedOffset};
use glam::{DVec3, Vec3};
use solar_positioning::{Location, RefractionCorrection, SolarPositions, delta_t};
use thiserror::Error;

/// Why a site or a sun position could not be had.
#[derive(Debug, Error, PartialEq)]
pub enum SiteError {
    #[error("{field} must be {range}, got {value}")]
    OutOfRange {
        field: &'static str,
        range: &'static str,
        value: f64,
    },
    #[error("north {0:?} must be a horizontal direction (perpendicular to +Y, not zero)")]
    North([f32; 3]),
    #[error("the sun's position at {when}: {message}")]
    Spa { when: String, message: String },
}

/// Where the scene stands on the Earth, and how it is turned.
#[derive(Clone, Debug, PartialEq)]
pub struct Site {
    /// Degrees, north positive.
    pub latitude_deg: f64,
    /// Degrees, east positive.
    pub longitude_deg: f64,
    /// Metres above sea level.
    pub elevation_m: f64,
    /// The local standard time's offset from UTC, hours (east positive: Chicago is −6).
    pub time_zone_h: f64,
    /// Unit, horizontal: the scene direction that points north.
    pub north: Vec3,
    /// Air pressure for refraction, millibars (default: the standard atmosphere at the
    /// site's elevation).
    pub pressure_mbar: f64,
    /// Air temperature for refraction, °C (default 15).
    pub temperature_c: f64,
}

/// The sun seen from a site at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunPosition {
    /// Topocentric zenith angle with refraction, degrees.
    pub zenith_deg: f64,
    /// Degrees from north through east, in [0, 360).
    pub azimuth_deg: f64,
}

impl SunPosition {
    pub fn altitude_deg(&self) -> f64 {
        90.0 - self.zenith_deg
    }
}

/// The standard atmosphere's pressure at `elevation_m` (millibars).
pub fn standard_pressure_mbar(elevation_m: f64) -> f64 {
    1013.25 * (1.0 - 2.25577e-5 * elevation_m).powf(5.25588)
}

fn check(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<f64, SiteError> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(value)
    } else {
        Err(SiteError::OutOfRange {
            field,
            range,
            value,
        })
    }
}

impl Site {
    /// A checked site with the default north (−Z), pressure and temperature.
    pub fn new(
        latitude_deg: f64,
        longitude_deg: f64,
        elevation_m: f64,
        time_zone_h: f64,
    ) -> Result<Site, SiteError> {
        let elevation_m = check(
            "elevation",
            elevation_m,
            -500.0,
            9000.0,
            "in [-500, 9000] m",
        )?;
        Ok(Site {
            latitude_deg: check("latitude", latitude_deg, -90.0, 90.0, "in [-90, 90]°")?,
            longitude_deg: check("longitude", longitude_deg, -180.0, 180.0, "in [-180, 180]°")?,
            elevation_m,
            time_zone_h: check("time zone", time_zone_h, -12.0, 14.0, "in [-12, 14] h")?,
            north: Vec3::new(0.0, 0.0, -1.0),
            pressure_mbar: standard_pressure_mbar(elevation_m),
            temperature_c: 15.0,
        })
    }

    /// The site turned so that `north` (scene coordinates) points north; `north` is made
    /// unit, and must be horizontal.
    pub fn with_north(mut self, north: [f32; 3]) -> Result<Site, SiteError> {
        let n = Vec3::from_array(north);
        if !n.is_finite() || n.length() < 1e-6 || n.y.abs() > 1e-3 * n.length() {
            return Err(SiteError::North(north));
        }
        self.north = Vec3::new(n.x, 0.0, n.z).normalize();
        Ok(self)
    }

    /// The same site with other air for refraction.
    pub fn with_air(mut self, pressure_mbar: f64, temperature_c: f64) -> Result<Site, SiteError> {
        self.pressure_mbar = check("pressure", pressure_mbar, 1.0, 2000.0, "in [1, 2000] mbar")?;
        self.temperature_c = check("temperature", temperature_c, -90.0, 60.0, "in [-90, 60] °C")?;
        Ok(self)
    }

    /// The local standard time's offset.
    pub fn offset(&self) -> FixedOffset {
        let secs = (self.time_zone_h * 3600.0).round() as i32;
        FixedOffset::east_opt(secs).expect("time zone checked to [-12, 14] h")
    }

    /// The scene direction that points east: north × up.
    pub fn east(&self) -> Vec3 {
        self.north.cross(Vec3::Y)
    }

    /// The sun at `when`, with ΔT (TT − UT) estimated for its date.
    pub fn sun_at(&self, when: &DateTime<FixedOffset>) -> Result<SunPosition, SiteError> {
        let spa_err = |e: solar_positioning::Error| SiteError::Spa {
            when: when.to_rfc3339(),
            message: e.to_string(),
        };
        let dt = delta_t::estimate_from_date(when.year(), when.month()).map_err(spa_err)?;
        self.sun_at_delta_t(when, dt)
    }

    /// The sun at `when` for a given ΔT, seconds.
    pub fn sun_at_delta_t(
        &self,
        when: &DateTime<FixedOffset>,
        delta_t_s: f64,
    ) -> Result<SunPosition, SiteError> {
        let spa_err = |e: solar_positioning::Error| SiteError::Spa {
            when: when.to_rfc3339(),
            message: e.to_string(),
        };
        let location = Location {
            latitude: self.latitude_deg,
            longitude: self.longitude_deg,
        };
        let air =
            RefractionCorrection::new(self.pressure_mbar, self.temperature_c).map_err(spa_err)?;
        let p = SolarPositions::new()
            .at(when, location, self.elevation_m, delta_t_s, Some(air))
            .map_err(spa_err)?;
        Ok(SunPosition {
            zenith_deg: p.zenith_angle(),
            azimuth_deg: p.azimuth(),
        })
    }

    /// The unit scene direction at `azimuth_deg` (from north through east) and
    /// `altitude_deg` above the horizon.
    pub fn direction(&self, azimuth_deg: f64, altitude_deg: f64) -> Vec3 {
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        let (sh, ch) = altitude_deg.to_radians().sin_cos();
        let (n, e) = (self.north.as_dvec3(), self.east().as_dvec3());
        (ch * (ca * n + sa * e) + sh * DVec3::Y)
            .normalize()
            .as_vec3()
    }

    /// A scene direction from its `east north up` components.
    pub fn from_enu(&self, enu: [f64; 3]) -> Vec3 {
        let v =
            enu[0] * self.east().as_dvec3() + enu[1] * self.north.as_dvec3() + enu[2] * DVec3::Y;
        v.as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// SPA's published example (Reda & Andreas, NREL/TP-560-34302, Table A5.1):
    /// 2003-10-17 12:30:30 at −7 h, 39.742476° N, 105.1786° W, 1830.14 m, 820 mbar,
    /// 11 °C, ΔT 67 s: topocentric zenith 50.11162°, azimuth 194.34024°.
    #[test]
    fn spa_published_case() {
        let site = Site::new(39.742476, -105.1786, 1830.14, -7.0)
            .unwrap()
            .with_air(820.0, 11.0)
            .unwrap();
        let when = DateTime::parse_from_rfc3339("2003-10-17T12:30:30-07:00").unwrap();
        let sun = site.sun_at_delta_t(&when, 67.0).unwrap();
        eprintln!(
            "SPA case: zenith {:.6}°, azimuth {:.6}°",
            sun.zenith_deg, sun.azimuth_deg
        );
        assert!((sun.zenith_deg - 50.11162).abs() < 1e-4, "{sun:?}");
        assert!((sun.azimuth_deg - 194.34024).abs() < 1e-4, "{sun:?}");
    }

    #[test]
    fn directions_follow_north_and_east() {
        let site = Site::new(45.0, 7.0, 0.0, 1.0).unwrap();
        assert!((site.direction(0.0, 0.0) - -Vec3::Z).length() < 1e-6);
        assert!((site.direction(90.0, 0.0) - Vec3::X).length() < 1e-6);
        assert!((site.direction(123.0, 90.0) - Vec3::Y).length() < 1e-6);
        let turned = site.with_north([1.0, 0.0, 0.0]).unwrap();
        assert!((turned.direction(90.0, 0.0) - Vec3::Z).length() < 1e-6);
        assert!((turned.from_enu([0.0, 1.0, 0.0]) - Vec3::X).length() < 1e-6);
    }

    #[test]
    fn bad_sites_are_named() {
        let e = Site::new(91.0, 0.0, 0.0, 0.0).unwrap_err().to_string();
        assert!(e.contains("latitude") && e.contains("91"), "{e}");
        let e = Site::new(0.0, 0.0, 0.0, 0.0)
            .unwrap()
            .with_north([0.0, 1.0, 0.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("north"), "{e}");
    }
}
