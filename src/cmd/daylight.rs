//! `holocave daylight`: the sun and sky of a site at a time, for users and for checks.
//!
//! Prints the sun's altitude, azimuth (degrees from north through east), zenith and
//! direction in scene coordinates, the hour's DNI and DHI, and the sky model's parameters;
//! with `--json`, the last line is all of that as one JSON object. With `--sky-at FILE`
//! (directions as `east north up`, one per line) it prints instead the sky's luminance in
//! cd/m² for each direction, one per line, in order (then the JSON line, with `--json`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use holocave_scene::Photometry;
use holocave_scene::daylight::{Daylight, Instant, Moment, Site, Weather, When};
use serde_json::json;

#[derive(Args)]
pub struct DaylightArgs {
    /// The site: latitude (° north), longitude (° east), elevation (m).
    #[arg(
        long,
        value_name = "LAT,LON,ELEV",
        allow_hyphen_values = true,
        conflicts_with = "weather",
        requires = "tz"
    )]
    pub site: Option<String>,
    /// The site's standard time zone, hours from UTC (Chicago: -6).
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub tz: Option<f64>,
    /// An EPW weather file: the site from its LOCATION line, the hour's DNI and DHI.
    #[arg(long, value_name = "FILE.epw", required_unless_present = "site")]
    pub weather: Option<PathBuf>,
    /// The scene direction that points north, `x,y,z` (horizontal; default 0,0,-1).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub north: Option<String>,
    /// YYYY-MM-DDTHH:MM in the site's local standard time, or with an offset (+01:00, Z).
    #[arg(long, value_name = "TIME")]
    pub when: When,
    /// End with one JSON object of everything printed.
    #[arg(long)]
    pub json: bool,
    /// Print the sky's luminance (cd/m²) towards each direction of FILE (`east north up`
    /// per line).
    #[arg(long, value_name = "FILE")]
    pub sky_at: Option<PathBuf>,
}

/// Comma-separated numbers, exactly `n` of them.
fn numbers(flag: &str, text: &str, n: usize) -> Result<Vec<f64>> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} {text:?}: not {n} comma-separated numbers"))?;
    if v.len() != n {
        bail!(
            "{flag} {text:?}: expected {n} comma-separated numbers, got {}",
            v.len()
        );
    }
    Ok(v)
}

impl DaylightArgs {
    /// The site given by flags (with `--north`), if any.
    fn flag_site(&self) -> Result<Option<Site>> {
        let mut site = match (&self.site, self.tz) {
            (Some(s), Some(tz)) => {
                let v = numbers("--site", s, 3)?;
                Some(Site::new(v[0], v[1], v[2], tz).context("--site")?)
            }
            _ => None,
        };
        if let Some(n) = &self.north {
            let v = numbers("--north", n, 3)?;
            let north = [v[0] as f32, v[1] as f32, v[2] as f32];
            let base = match (site.take(), &self.weather) {
                (Some(s), _) => s,
                (None, Some(w)) => Weather::load(w)?.site,
                (None, None) => bail!("--north needs --site or --weather"),
            };
            site = Some(base.with_north(north).context("--north")?);
        }
        Ok(site)
    }

    fn instant(&self) -> Result<Instant> {
        let weather = (self.weather.as_deref())
            .map(|p| Weather::load(p).map(Arc::new))
            .transpose()?;
        let moment = Moment {
            when: self.when,
            weather,
        };
        Ok(moment.resolve(self.flag_site()?.as_ref())?)
    }
}

pub fn run(args: DaylightArgs) -> Result<()> {
    let instant = args.instant()?;
    let daylight = Daylight::of_instant(&instant)?;
    match &args.sky_at {
        Some(file) => print_sky_at(&instant, &daylight, file)?,
        None => print_report(&instant),
    }
    if args.json {
        println!("{}", report_json(&instant));
    }
    Ok(())
}

fn print_report(i: &Instant) {
    let s = &i.site;
    println!(
        "site       {:.4}° N, {:.4}° E, {} m, UTC{:+}, north {:?} in the scene",
        s.latitude_deg,
        s.longitude_deg,
        s.elevation_m,
        s.time_zone_h,
        s.north.to_array()
    );
    println!("time       {} (local standard time)", i.time.to_rfc3339());
    println!(
        "sun        altitude {:.4}°, azimuth {:.4}° (from north through east), zenith {:.4}°",
        i.sun.altitude_deg(),
        i.sun.azimuth_deg,
        i.sun.zenith_deg
    );
    let d = i.direction;
    println!(
        "direction  [{:.6}, {:.6}, {:.6}] (scene, towards the sun)",
        d.x, d.y, d.z
    );
    if let Some(h) = i.hour {
        println!(
            "weather    line {} ({:02}-{:02} hour {}, the hour to {}:00): DNI {} W/m², DHI {} W/m²",
            h.line, h.month, h.day, h.hour, h.hour, h.dni, h.dhi
        );
    }
    match &i.perez {
        Some(p) => {
            let [a, b, c, d, e] = p.coefficients;
            println!(
                "sky        perez: epsilon {:.4}, delta {:.4}, a {a:.6} b {b:.6} c {c:.6} d {d:.6} e {e:.6}",
                p.epsilon, p.delta
            );
            let lum = Photometry::default().efficacy as f64;
            println!(
                "           zenith {:.1} cd/m², horizontal {:.0} lx (the DHI at 179 lm/W)",
                p.zenith_radiance() * lum,
                p.dhi * lum
            );
        }
        None if i.hour.is_some() => {
            println!("sky        none (the sun is down, or no diffuse light)")
        }
        None => println!("sky        none (no weather file)"),
    }
}

fn report_json(i: &Instant) -> serde_json::Value {
    let d = i.direction;
    let sky = match &i.perez {
        Some(p) => json!({
            "model": "perez",
            "epsilon": p.epsilon,
            "delta": p.delta,
            "coefficients": p.coefficients,
            "normalization": p.normalization,
            "zenith_radiance": p.zenith_radiance(),
        }),
        None => json!(null),
    };
    json!({
        "time": i.time.to_rfc3339(),
        "sun": {
            "altitude_deg": i.sun.altitude_deg(),
            "azimuth_deg": i.sun.azimuth_deg,
            "zenith_deg": i.sun.zenith_deg,
            "direction": [d.x, d.y, d.z],
        },
        "dni": i.hour.map(|h| h.dni),
        "dhi": i.hour.map(|h| h.dhi),
        "sky": sky,
    })
}

/// Directions `east north up`, one per line (blank lines and `#` comments skipped).
fn read_directions(path: &Path) -> Result<Vec<[f64; 3]>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut dirs = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let v: Vec<f64> = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| {
                anyhow::anyhow!(
                    "{}:{}: {line:?} is not three numbers",
                    path.display(),
                    n + 1
                )
            })?;
        let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if v.len() != 3 || !len.is_finite() || len == 0.0 {
            bail!(
                "{}:{}: {line:?} is not a direction (east north up)",
                path.display(),
                n + 1
            );
        }
        dirs.push([v[0] / len, v[1] / len, v[2] / len]);
    }
    Ok(dirs)
}

fn print_sky_at(i: &Instant, daylight: &Daylight, file: &Path) -> Result<()> {
    let Some(sky) = &daylight.sky else {
        bail!("--sky-at needs a sky: give --weather (a Perez sky of the hour)");
    };
    for enu in read_directions(file)? {
        let dir = i.site.from_enu(enu).normalize();
        println!("{:.6}", daylight.photometry.luminance_cd(sky.radiance(dir)));
    }
    Ok(())
}
