//! An instant's daylight: a time (and maybe a weather file) resolved at a site into the
//! sun's position and, with weather, the hour's irradiance and its Perez sky.
//!
//! The sun stands where SPA puts it at the instant asked. The radiation is the weather
//! file's for the hour that holds that instant: `09:00`–`09:59` is the row stamped 10, the
//! hour ending at 10:00. gendaylit and gendaymtx (through `epw2wea`) evaluate a row's sky
//! with the sun at the middle of its hour, so asking `HH:30` gives exactly their sky.

use std::sync::Arc;

use chrono::{DateTime, Datelike, FixedOffset};
use glam::Vec3;
use thiserror::Error;

use super::epw::{EpwError, Hour, Weather};
use super::perez::{PerezError, PerezSky};
use super::site::{Site, SiteError, SunPosition};
use super::when::When;

#[derive(Debug, Error)]
pub enum MomentError {
    #[error(
        "a time needs a site: a [site] table in the daylight file (latitude, longitude, \
         elevation, time_zone), or a weather file"
    )]
    NoSite,
    #[error("time {0} is out of range")]
    OutOfRange(When),
    #[error(transparent)]
    Site(#[from] SiteError),
    #[error(transparent)]
    Weather(#[from] EpwError),
    #[error("weather file {path}, line {line}: {source}")]
    Perez {
        path: std::path::PathBuf,
        line: usize,
        source: PerezError,
    },
}

/// A time asked for, and the weather file that gives its hour's light.
#[derive(Clone, Debug)]
pub struct Moment {
    pub when: When,
    pub weather: Option<Arc<Weather>>,
}

/// A moment resolved at a site.
#[derive(Clone, Debug)]
pub struct Instant {
    pub site: Site,
    /// In the site's local standard time.
    pub time: DateTime<FixedOffset>,
    pub sun: SunPosition,
    /// Unit scene direction towards the sun.
    pub direction: Vec3,
    /// The weather file's hour, when there is one.
    pub hour: Option<Hour>,
    /// The hour's Perez sky; `None` without weather, or with no sky to draw (the sun at or
    /// below the horizon, or no diffuse light).
    pub perez: Option<PerezSky>,
}

impl Moment {
    /// The site the moment is resolved at: the weather file's location (with the daylight
    /// file's north and air, if it has a `[site]`), else the daylight file's `[site]`.
    pub fn site(&self, file_site: Option<&Site>) -> Result<Site, MomentError> {
        match (&self.weather, file_site) {
            (Some(w), Some(f)) => Ok(w
                .site
                .clone()
                .with_north(f.north.to_array())?
                .with_air(f.pressure_mbar, f.temperature_c)?),
            (Some(w), None) => Ok(w.site.clone()),
            (None, Some(f)) => Ok(f.clone()),
            (None, None) => Err(MomentError::NoSite),
        }
    }

    /// The sun, and with weather the hour and its sky, at this moment.
    pub fn resolve(&self, file_site: Option<&Site>) -> Result<Instant, MomentError> {
        let site = self.site(file_site)?;
        let time = self
            .when
            .in_zone(site.offset())
            .ok_or(MomentError::OutOfRange(self.when))?;
        let sun = site.sun_at(&time)?;
        let direction = site.direction(sun.azimuth_deg, sun.altitude_deg());
        let (hour, perez) = match &self.weather {
            None => (None, None),
            Some(w) => {
                let hour = w.hour_at(&time)?;
                let perez = PerezSky::new(direction, hour.dni, hour.dhi, time.ordinal()).map_err(
                    |source| MomentError::Perez {
                        path: w.path.clone(),
                        line: hour.line,
                        source,
                    },
                )?;
                (Some(hour), perez)
            }
        };
        Ok(Instant {
            site,
            time,
            sun,
            direction,
            hour,
            perez,
        })
    }
}

impl Instant {
    /// Whether the sun's centre is above the horizon.
    pub fn sun_up(&self) -> bool {
        self.sun.altitude_deg() > 0.0
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::daylight::{Daylight, SkyModel};

    const FILE: &str = "[site]\nlatitude = 41.98\nlongitude = -87.92\nelevation = 201.0\n\
                        time_zone = -6.0\nnorth = [1.0, 0.0, 0.0]\n\
                        [sun]\nirradiance = [800.0, 800.0, 800.0]\n\
                        [sky]\nmodel = \"cie_clear\"\nzenith_radiance = [20.0, 20.0, 20.0]\n";

    fn weather() -> Arc<Weather> {
        let mut s = String::from("LOCATION,Here,,,,0,41.98,-87.92,-6.0,201.0\n");
        s += &"HEADER,x\n".repeat(6);
        s += "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n";
        s += "1999,6,21,13,0,f,20,10,50,99000,1300,1360,350,800,700,150\n";
        Arc::new(Weather::parse(&s, Path::new("w.epw")).unwrap())
    }

    fn at(when: &str, weather: Option<Arc<Weather>>) -> Moment {
        Moment {
            when: when.parse().unwrap(),
            weather,
        }
    }

    #[test]
    fn a_time_turns_the_files_sun_and_clear_sky() {
        let path = Path::new("d.toml");
        // Without a time, a [sun] with no direction is an error that names the way out.
        let e = Daylight::parse(FILE, path).unwrap_err().to_string();
        assert!(e.contains("[site] and a time"), "{e}");
        let m = at("2026-06-21T12:30", None);
        let d = Daylight::parse_at(FILE, path, Some(&m)).unwrap();
        let i = m.resolve(d.site.as_ref()).unwrap();
        let sun = d.sun.unwrap();
        assert_eq!(sun.direction, i.direction);
        // Near noon the sun is high and to the south: north is +X here, so south is −X.
        assert!(
            i.sun.altitude_deg() > 65.0 && sun.direction.x < -0.2,
            "{i:?}"
        );
        match d.sky.unwrap().model {
            SkyModel::CieClear { sun: s, .. } => assert_eq!(s, sun.direction),
            other => panic!("{other:?}"),
        }
        // At night there is no sun.
        let night = at("2026-06-21T23:00", None);
        assert!(
            Daylight::parse_at(FILE, path, Some(&night))
                .unwrap()
                .sun
                .is_none()
        );
    }

    #[test]
    fn weather_gives_the_dni_sun_and_a_perez_sky() {
        let m = at("2026-06-21T12:30", Some(weather()));
        let d = Daylight::parse_at(FILE, Path::new("d.toml"), Some(&m)).unwrap();
        let sun = d.sun.unwrap();
        assert!(
            (sun.radiance.x * sun.solid_angle() - 700.0).abs() < 0.5,
            "{sun:?}"
        );
        let sky = d.sky.unwrap();
        let SkyModel::Perez(p) = &sky.model else {
            panic!("{:?}", sky.model)
        };
        assert_eq!((p.dni, p.dhi), (700.0, 150.0));
        assert!(sky.ground.x > 0.0);
        // The file's north still turns the scene: the sun stands towards −X (south).
        assert!(p.sun.x < -0.2, "{:?}", p.sun);
        // No daylight file at all: the weather's site and light.
        let i = m.resolve(None).unwrap();
        let alone = Daylight::of_instant(&i).unwrap();
        assert!(matches!(alone.sky.unwrap().model, SkyModel::Perez(_)));
    }

    #[test]
    fn errors_name_what_is_missing() {
        let e = at("2026-06-21T12:30", None).resolve(None).unwrap_err();
        assert!(e.to_string().contains("[site]"), "{e}");
        let e = at("2026-06-21T15:30", Some(weather()))
            .resolve(None)
            .unwrap_err();
        assert!(e.to_string().contains("06-21 hour 16"), "{e}");
    }
}
