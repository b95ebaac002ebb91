//! Daylight: a sun and a sky, for the many glTF scenes that carry no lights at all.
//!
//! Given in a small TOML file, by default `<scene stem>.daylight.toml` beside the scene:
//!
//! ```toml
//! [sun]
//! elevation_deg = 12.0          # or: direction = [x, y, z]  (towards the sun)
//! azimuth_deg = 230.0           # from +Z towards +X, scene coordinates
//! angular_diameter_deg = 0.53
//! irradiance = [900.0, 850.0, 780.0]  # normal to the sun; or: radiance = [...]
//!
//! [sky]
//! model = "cie_clear"           # "uniform", "cie_overcast", "cie_clear" or "map"
//! zenith_radiance = [20.0, 24.0, 32.0]  # "radiance" for uniform; "path" (EXR) + "scale" for map
//! ground_albedo = 0.2           # directions below the horizon see a diffuse ground
//! ```
//!
//! Radiance is linear RGB in the scene's emission units; an optional `[photometry]` table
//! gives their luminous efficacy ([`crate::photometry`]).
//!
//! A place and a time may give the sun instead ([`site`], [`moment`]): an optional
//! `[site]` table, and a time asked for (`--when`), put the sun where NREL's SPA sees it
//! from the site; a weather file ([`epw`]) gives the hour's direct and diffuse irradiance
//! and with them a Perez all-weather sky ([`perez`]) in place of the file's `[sun]` light
//! and `[sky]`:
//!
//! ```toml
//! [site]
//! latitude = 41.98              # degrees, north positive
//! longitude = -87.92            # degrees, east positive
//! elevation = 201.0             # metres
//! time_zone = -6.0              # hours from UTC of local standard time
//! north = [0.0, 0.0, -1.0]      # the scene direction pointing north (default −Z)
//! ```
//!
//! Without a time the `[sun]` and `[sky]` are as written, whatever `[site]` says.

pub mod epw;
pub mod moment;
pub mod perez;
pub mod site;
pub mod when;

pub use epw::{EpwError, Weather};
pub use moment::{Instant, Moment, MomentError};
pub use perez::PerezSky;
pub use site::{Site, SunPosition};
pub use when::When;

use std::f32::consts::PI;
use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

use crate::error::SceneError;
use crate::photometry::Photometry;

/// The sun: a disk of uniform radiance.
#[derive(Clone, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector from the scene towards the sun.
    pub direction: Vec3,
    /// Half the angular diameter, radians.
    pub angular_radius: f32,
    pub radiance: Vec3,
}

impl Sun {
    /// Cosine of the angular radius: directions with `dot(d, direction) >= cos_radius`
    /// see the sun.
    pub fn cos_radius(&self) -> f32 {
        self.angular_radius.cos()
    }

    /// `1 − cos` of the angular radius, as `2 sin²(r/2)`: in f32, `1 − cos r` itself keeps
    /// only about half a percent of it for the sun's 0.27°, where `cos r` rounds near 1.
    pub fn one_minus_cos_radius(&self) -> f32 {
        2.0 * (0.5 * self.angular_radius).sin().powi(2)
    }

    /// The solid angle of the disk.
    pub fn solid_angle(&self) -> f32 {
        2.0 * PI * self.one_minus_cos_radius()
    }
}

/// An equirectangular radiance map: `u` is the azimuth (from −Z towards +X), `v` runs
/// from the zenith (top row) to the nadir.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyMap {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<Vec3>,
}

impl SkyMap {
    /// The texel a direction falls in.
    pub fn texel_of(&self, dir: Vec3) -> (usize, usize) {
        let u = (dir.x.atan2(-dir.z) / (2.0 * PI) + 0.5).clamp(0.0, 1.0);
        let v = (dir.y.clamp(-1.0, 1.0).acos() / PI).clamp(0.0, 1.0);
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }

    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (x, y) = self.texel_of(dir);
        self.texels[y * self.width + x]
    }
}

/// The sky dome's radiance distribution.
#[derive(Clone, Debug, PartialEq)]
pub enum SkyModel {
    Uniform(Vec3),
    /// CIE standard overcast sky: `L(θ) = Lz (1 + 2 cos θ) / 3`.
    CieOvercast {
        zenith: Vec3,
    },
    /// CIE clear sky (Kittler), relative to the zenith, for a given sun direction.
    CieClear {
        zenith: Vec3,
        sun: Vec3,
    },
    Map(SkyMap),
    /// The Perez all-weather sky of an hour's weather.
    Perez(PerezSky),
}

/// A sky: its model plus the ground seen below the horizon.
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    pub model: SkyModel,
    /// Radiance of the ground (below the horizon) for analytic skies.
    pub ground: Vec3,
}

fn cie_clear_ratio(cos_theta: f32, gamma: f32, sun_zenith: f32) -> f32 {
    let f = |g: f32| 0.91 + 10.0 * (-3.0 * g).exp() + 0.45 * g.cos() * g.cos();
    let phi = |c: f32| 1.0 - (-0.32 / c.max(1e-3)).exp();
    (f(gamma) * phi(cos_theta)) / (f(sun_zenith) * phi(1.0))
}

impl Sky {
    /// Radiance arriving from direction `dir` (unit, pointing away from the scene).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        if let SkyModel::Map(m) = &self.model {
            return m.radiance(dir);
        }
        if dir.y < 0.0 {
            return self.ground;
        }
        self.dome_radiance(dir)
    }

    fn dome_radiance(&self, dir: Vec3) -> Vec3 {
        match &self.model {
            SkyModel::Uniform(l) => *l,
            SkyModel::CieOvercast { zenith } => *zenith * ((1.0 + 2.0 * dir.y) / 3.0),
            SkyModel::CieClear { zenith, sun } => {
                let gamma = dir.dot(*sun).clamp(-1.0, 1.0).acos();
                let sun_zenith = sun.y.clamp(-1.0, 1.0).acos();
                *zenith * cie_clear_ratio(dir.y, gamma, sun_zenith)
            }
            SkyModel::Map(m) => m.radiance(dir),
            SkyModel::Perez(p) => Vec3::splat(p.radiance(dir) as f32),
        }
    }

    /// Irradiance on a horizontal surface from the upper hemisphere of the dome,
    /// integrated numerically (midpoint rule over a 64 × 256 grid in θ, φ).
    fn horizontal_irradiance(&self) -> Vec3 {
        let (nt, np) = (64, 256);
        let mut e = Vec3::ZERO;
        for i in 0..nt {
            let theta = (i as f32 + 0.5) / nt as f32 * PI / 2.0;
            let (s, c) = theta.sin_cos();
            for j in 0..np {
                let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                let d = Vec3::new(s * phi.cos(), c, s * phi.sin());
                e += self.dome_radiance(d) * c * s;
            }
        }
        e * (PI / 2.0 / nt as f32) * (2.0 * PI / np as f32)
    }
}

/// The daylight of a scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Daylight {
    pub sun: Option<Sun>,
    pub sky: Option<Sky>,
    /// The scene's photometric units (`[photometry]`; Radiance's 179 lm/W if absent).
    pub photometry: Photometry,
    /// The scene's movable objects (`[[object]]`: `name`, `nodes`), besides the nodes the
    /// glTF marks movable: the file is the scene's settings, read by every process that
    /// loads the scene, so all of them agree on what is static.
    pub objects: Vec<crate::load::ObjectSpec>,
    /// Where the scene stands (`[site]`), for a time asked for.
    pub site: Option<Site>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SunToml {
    direction: Option<[f32; 3]>,
    elevation_deg: Option<f32>,
    azimuth_deg: Option<f32>,
    angular_diameter_deg: Option<f32>,
    radiance: Option<[f32; 3]>,
    irradiance: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SkyToml {
    model: String,
    radiance: Option<[f32; 3]>,
    zenith_radiance: Option<[f32; 3]>,
    path: Option<PathBuf>,
    scale: Option<f32>,
    ground_albedo: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DaylightToml {
    site: Option<SiteToml>,
    sun: Option<SunToml>,
    sky: Option<SkyToml>,
    photometry: Option<PhotometryToml>,
    #[serde(default)]
    object: Vec<ObjectToml>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SiteToml {
    latitude: f64,
    longitude: f64,
    elevation: f64,
    time_zone: f64,
    north: Option<[f32; 3]>,
    pressure_mbar: Option<f64>,
    temperature_c: Option<f64>,
}

impl SiteToml {
    fn site(&self) -> Result<Site, site::SiteError> {
        let mut site = Site::new(
            self.latitude,
            self.longitude,
            self.elevation,
            self.time_zone,
        )?;
        if let Some(n) = self.north {
            site = site.with_north(n)?;
        }
        let pressure = self.pressure_mbar.unwrap_or(site.pressure_mbar);
        let temperature = self.temperature_c.unwrap_or(site.temperature_c);
        site.with_air(pressure, temperature)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectToml {
    name: String,
    nodes: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PhotometryToml {
    efficacy: f32,
}

fn rgb(field: &str, v: [f32; 3], path: &Path) -> Result<Vec3, SceneError> {
    let c = Vec3::from_array(v);
    if !c.is_finite() || c.min_element() < 0.0 {
        return Err(SceneError::Daylight {
            path: path.into(),
            message: format!("{field} must be finite and non-negative, got {v:?}"),
        });
    }
    Ok(c)
}

fn daylight_error(path: &Path) -> impl Fn(String) -> SceneError + '_ {
    |message| SceneError::Daylight {
        path: path.into(),
        message,
    }
}

/// The ground's radiance under `sky` and `sun`: their horizontal irradiance times
/// `albedo / π` (a map sky carries its own ground).
fn ground_under(sky: &Sky, sun: Option<&Sun>, albedo: f32) -> Vec3 {
    if matches!(sky.model, SkyModel::Map(_)) {
        return Vec3::ZERO;
    }
    let mut e = sky.horizontal_irradiance();
    if let Some(sun) = sun {
        e += sun.radiance * sun.solid_angle() * sun.direction.y.max(0.0);
    }
    e * albedo / PI
}

impl Daylight {
    /// `when` in the local standard time of the site (a bake set names its files so).
    /// Error: no site, or a time out of range.
    pub fn local_time(&self, when: When) -> Result<chrono::NaiveDateTime, String> {
        let site = (self.site.as_ref())
            .ok_or("a time of day needs the scene's site ([site] or a weather file)")?;
        Ok(when
            .in_zone(site.offset())
            .ok_or_else(|| format!("time {when} is out of range"))?
            .naive_local())
    }

    /// Reads a daylight TOML file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_at(path, None)
    }

    /// Reads a daylight TOML file, with the sun (and with weather, the sky) of `moment`.
    pub fn load_at(path: &Path, moment: Option<&Moment>) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.into(),
            source,
        })?;
        Self::parse_at(&text, path, moment)
    }

    /// Parses daylight TOML; `path` names the input in errors and anchors relative map
    /// paths.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        Self::parse_at(text, path, None)
    }

    /// Parses daylight TOML for `moment`: its sun follows the site and time; with a weather
    /// file the sun carries the hour's DNI and the sky is the hour's Perez sky.
    pub fn parse_at(text: &str, path: &Path, moment: Option<&Moment>) -> Result<Self, SceneError> {
        let err = daylight_error(path);
        let t: DaylightToml = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        let site = (t.site.as_ref())
            .map(|s| s.site().map_err(|e| err(format!("[site]: {e}"))))
            .transpose()?;
        let instant = moment
            .map(|m| m.resolve(site.as_ref()).map_err(|e| err(e.to_string())))
            .transpose()?;
        let (sun, sky) = match instant.as_ref().filter(|i| i.hour.is_some()) {
            Some(i) => Self::weather_light(i, t.sun.as_ref(), t.sky.as_ref(), path)?,
            None => {
                let sun = (t.sun)
                    .map(|s| Self::parse_sun(s, instant.as_ref(), path))
                    .transpose()?
                    .flatten();
                let sky = (t.sky)
                    .map(|s| Self::parse_sky(s, sun.as_ref(), instant.as_ref(), path))
                    .transpose()?;
                (sun, sky)
            }
        };
        Ok(Self {
            sun,
            sky,
            photometry: Self::parse_photometry(t.photometry, path)?,
            objects: Self::parse_objects(t.object, path)?,
            // The site the sun was placed for: the file's, else the weather file's.
            site: site.or_else(|| instant.map(|i| i.site)),
        })
    }

    /// The sun and sky of an instant as a weather file gives them (a disc of 0.533°
    /// carrying the DNI, the Perez sky, a ground of albedo 0.2), with no daylight file.
    pub fn of_instant(i: &Instant) -> Result<Self, SceneError> {
        let (sun, sky) = Self::weather_light(i, None, None, Path::new("(no daylight file)"))?;
        Ok(Self {
            sun,
            sky: sky.filter(|_| i.hour.is_some()),
            site: Some(i.site.clone()),
            ..Self::default()
        })
    }

    fn parse_photometry(p: Option<PhotometryToml>, path: &Path) -> Result<Photometry, SceneError> {
        match p {
            None => Ok(Photometry::default()),
            Some(p) if p.efficacy.is_finite() && p.efficacy > 0.0 => Ok(Photometry {
                efficacy: p.efficacy,
            }),
            Some(p) => Err(daylight_error(path)(format!(
                "photometry.efficacy must be finite and positive, got {}",
                p.efficacy
            ))),
        }
    }

    fn parse_objects(
        list: Vec<ObjectToml>,
        path: &Path,
    ) -> Result<Vec<crate::load::ObjectSpec>, SceneError> {
        let err = daylight_error(path);
        let mut objects: Vec<crate::load::ObjectSpec> = Vec::new();
        for o in list {
            if o.name.is_empty() || o.nodes.is_empty() {
                return Err(err(format!(
                    "[[object]] {:?}: an object needs a name and at least one node",
                    o.name
                )));
            }
            if objects.iter().any(|s| s.name == o.name) {
                return Err(err(format!("[[object]] {:?} is named twice", o.name)));
            }
            objects.push(crate::load::ObjectSpec {
                name: o.name,
                nodes: o.nodes,
            });
        }
        Ok(objects)
    }

    /// The sun and sky of a weather hour: a disc carrying the DNI (the file's
    /// `angular_diameter_deg`, else 0.533° as gendaylit's) and the Perez sky, over a ground
    /// of the file's `ground_albedo` (else 0.2). Both are dark while the sun is down.
    fn weather_light(
        i: &Instant,
        sun: Option<&SunToml>,
        sky: Option<&SkyToml>,
        path: &Path,
    ) -> Result<(Option<Sun>, Option<Sky>), SceneError> {
        let diameter = sun.and_then(|s| s.angular_diameter_deg).unwrap_or(0.533);
        let angular_radius = Self::angular_radius(diameter, path)?;
        let dni = i.hour.map_or(0.0, |h| h.dni);
        let sun = (i.sun_up() && dni > 0.0).then(|| {
            let mut sun = Sun {
                direction: i.direction,
                angular_radius,
                radiance: Vec3::ZERO,
            };
            sun.radiance = Vec3::splat(dni as f32 / sun.solid_angle());
            sun
        });
        let model = match &i.perez {
            Some(p) => SkyModel::Perez(p.clone()),
            None => SkyModel::Uniform(Vec3::ZERO),
        };
        let albedo = Self::albedo(sky.and_then(|s| s.ground_albedo), path)?;
        let mut sky = Sky {
            model,
            ground: Vec3::ZERO,
        };
        sky.ground = ground_under(&sky, sun.as_ref(), albedo);
        Ok((sun, Some(sky)))
    }

    fn angular_radius(diameter: f32, path: &Path) -> Result<f32, SceneError> {
        if !(diameter > 0.0 && diameter < 90.0) {
            return Err(daylight_error(path)(format!(
                "sun.angular_diameter_deg must be in (0, 90), got {diameter}"
            )));
        }
        Ok((diameter / 2.0).to_radians())
    }

    fn albedo(albedo: Option<f32>, path: &Path) -> Result<f32, SceneError> {
        let albedo = albedo.unwrap_or(0.2);
        if !(0.0..=1.0).contains(&albedo) {
            return Err(daylight_error(path)(format!(
                "sky.ground_albedo must be in [0, 1], got {albedo}"
            )));
        }
        Ok(albedo)
    }

    /// The `[sun]` as written, its direction from the file or, at an instant, from the
    /// site; `None` when the instant's sun is below the horizon.
    fn parse_sun(s: SunToml, at: Option<&Instant>, path: &Path) -> Result<Option<Sun>, SceneError> {
        let err = daylight_error(path);
        let direction = match at {
            Some(i) if !i.sun_up() => return Ok(None),
            Some(i) => i.direction,
            None => Self::sun_direction(&s, path)?,
        };
        let mut sun = Sun {
            direction,
            angular_radius: Self::angular_radius(s.angular_diameter_deg.unwrap_or(0.53), path)?,
            radiance: Vec3::ZERO,
        };
        sun.radiance = match (s.radiance, s.irradiance) {
            (Some(l), None) => rgb("sun.radiance", l, path)?,
            (None, Some(e)) => rgb("sun.irradiance", e, path)? / sun.solid_angle(),
            _ => return Err(err("sun needs exactly one of radiance or irradiance".into())),
        };
        Ok(Some(sun))
    }

    fn sun_direction(s: &SunToml, path: &Path) -> Result<Vec3, SceneError> {
        let err = daylight_error(path);
        match (s.direction, s.elevation_deg, s.azimuth_deg) {
            (Some(d), None, None) => {
                let d = Vec3::from_array(d);
                if !d.is_finite() || d.length() < 1e-6 {
                    return Err(err(format!("sun.direction {d} is not a direction")));
                }
                Ok(d.normalize())
            }
            (None, Some(el), Some(az)) => {
                if !(-90.0..=90.0).contains(&el) {
                    return Err(err(format!(
                        "sun.elevation_deg must be in [-90, 90], got {el}"
                    )));
                }
                if !az.is_finite() {
                    return Err(err(format!("sun.azimuth_deg must be finite, got {az}")));
                }
                let (el, az) = (el.to_radians(), az.to_radians());
                Ok(Vec3::new(
                    el.cos() * az.sin(),
                    el.sin(),
                    el.cos() * az.cos(),
                ))
            }
            _ => Err(err(
                "sun needs either direction or both elevation_deg and azimuth_deg \
                 (or a [site] and a time)"
                    .into(),
            )),
        }
    }

    fn parse_sky(
        s: SkyToml,
        sun: Option<&Sun>,
        at: Option<&Instant>,
        path: &Path,
    ) -> Result<Sky, SceneError> {
        let err = daylight_error(path);
        let need = |v: Option<[f32; 3]>, field: &str| {
            v.ok_or_else(|| err(format!("sky model {:?} needs {field}", s.model)))
                .and_then(|v| rgb(&format!("sky.{field}"), v, path))
        };
        let model = match s.model.as_str() {
            "uniform" => SkyModel::Uniform(need(s.radiance, "radiance")?),
            "cie_overcast" => SkyModel::CieOvercast {
                zenith: need(s.zenith_radiance, "zenith_radiance")?,
            },
            "cie_clear" => SkyModel::CieClear {
                zenith: need(s.zenith_radiance, "zenith_radiance")?,
                sun: match (sun, at) {
                    (Some(sun), _) => sun.direction,
                    (None, Some(i)) => i.direction,
                    (None, None) => {
                        return Err(err("sky model \"cie_clear\" needs a [sun]".into()));
                    }
                },
            },
            "map" => {
                let rel = s
                    .path
                    .as_ref()
                    .ok_or_else(|| err("sky model \"map\" needs path".into()))?;
                let scale = s.scale.unwrap_or(1.0);
                if !(scale.is_finite() && scale >= 0.0) {
                    return Err(err(format!(
                        "sky.scale must be finite and non-negative, got {scale}"
                    )));
                }
                let full = path.parent().unwrap_or(Path::new(".")).join(rel);
                SkyModel::Map(load_sky_map(&full, scale)?)
            }
            other => {
                return Err(err(format!(
                    "unknown sky.model {other:?} (uniform, cie_overcast, cie_clear, map; \
                     a Perez sky comes from a weather file)"
                )));
            }
        };
        let albedo = Self::albedo(s.ground_albedo, path)?;
        let mut sky = Sky {
            model,
            ground: Vec3::ZERO,
        };
        sky.ground = ground_under(&sky, sun, albedo);
        Ok(sky)
    }
}

/// Loads an equirectangular EXR as a sky map (RGB, scaled).
pub fn load_sky_map(path: &Path, scale: f32) -> Result<SkyMap, SceneError> {
    use exr::prelude::*;
    let err = |message: String| SceneError::Daylight {
        path: path.into(),
        message,
    };
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| SkyMap {
            width: res.width(),
            height: res.height(),
            texels: vec![Vec3::ZERO; res.width() * res.height()],
        },
        move |m: &mut SkyMap, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let c = Vec3::new(r, g, b) * scale;
            // Non-finite or negative texels would poison every path that sees them.
            m.texels[pos.y() * m.width + pos.x()] = if c.is_finite() {
                c.max(Vec3::ZERO)
            } else {
                Vec3::ZERO
            };
        },
    )
    .map_err(|e| err(format!("cannot read sky map: {e}")))?;
    let map = image.layer_data.channel_data.pixels;
    if map.width == 0 || map.height == 0 {
        return Err(err("sky map is empty".into()));
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_sky_horizontal_irradiance_is_pi_l() {
        let sky = Sky {
            model: SkyModel::Uniform(Vec3::ONE),
            ground: Vec3::ZERO,
        };
        let e = sky.horizontal_irradiance();
        assert!((e.x - PI).abs() < 1e-3, "{e}");
    }

    #[test]
    fn parses_sun_and_sky_and_names_bad_fields() {
        let d = Daylight::parse(
            "[sun]\nelevation_deg = 90.0\nazimuth_deg = 0.0\nirradiance = [1.0, 1.0, 1.0]\n\
             [sky]\nmodel = \"cie_overcast\"\nzenith_radiance = [3.0, 3.0, 3.0]\n",
            Path::new("x.toml"),
        )
        .unwrap();
        let sun = d.sun.unwrap();
        assert!((sun.direction - Vec3::Y).length() < 1e-6);
        assert!((sun.radiance.x * sun.solid_angle() - 1.0).abs() < 1e-4);
        let sky = d.sky.unwrap();
        assert!((sky.radiance(Vec3::Y).x - 3.0).abs() < 1e-6);
        assert!((sky.radiance(Vec3::X).x - 1.0).abs() < 1e-6);
        // Overcast: E = 7π/9 Lz; plus the sun at the zenith, times albedo / π.
        let expected = (7.0 * PI / 9.0 * 3.0 + 1.0) * 0.2 / PI;
        assert!((sky.radiance(-Vec3::Y).x - expected).abs() < 1e-3);

        for (bad, needle) in [
            ("[sky]\nmodel = \"bogus\"", "bogus"),
            ("[sky]\nmodel = \"uniform\"", "radiance"),
            (
                "[sky]\nmodel = \"cie_clear\"\nzenith_radiance=[1.0,1.0,1.0]",
                "[sun]",
            ),
            ("[sun]\nradiance = [1.0, 1.0, 1.0]", "direction"),
            (
                "[sun]\ndirection=[0.0,1.0,0.0]\nradiance = [-1.0, 1.0, 1.0]",
                "sun.radiance",
            ),
            ("[sun", "x.toml"),
        ] {
            let e = Daylight::parse(bad, Path::new("x.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{e:?} should mention {needle:?}");
        }
    }

    #[test]
    fn cie_clear_is_brightest_near_the_sun() {
        let sun = Vec3::new(0.0, 0.5, 0.866).normalize();
        let sky = Sky {
            model: SkyModel::CieClear {
                zenith: Vec3::ONE,
                sun,
            },
            ground: Vec3::ZERO,
        };
        assert!((sky.radiance(Vec3::Y).x - 1.0).abs() < 1e-5);
        let near = sky
            .radiance((sun + Vec3::new(0.0, 0.05, 0.0)).normalize())
            .x;
        let away = sky.radiance(Vec3::new(0.0, 0.5, -0.866).normalize()).x;
        assert!(near > 3.0 * away, "near {near} away {away}");
    }
}
