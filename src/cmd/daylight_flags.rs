//! The daylight flags of every command that loads a scene: the daylight file, a time and a
//! weather file. A command that starts other `holocave` processes hands them on
//! ([`DaylightFlags::args`]), so that every process of a cluster sees the same sun and sky.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Result;
use clap::Args;
use holocave_render_node::light_field::time_of_day::TimeOfDay;
use holocave_scene::daylight::{Moment, Weather, When};
use holocave_scene::load::load_daylight;

#[derive(Args, Clone, Debug, Default)]
pub struct DaylightFlags {
    /// The scene's daylight file (default: <scene>.daylight.toml beside it, if present).
    #[arg(long)]
    pub daylight: Option<PathBuf>,
    /// The sun at this time, from the daylight file's [site] (or the weather file's
    /// location): YYYY-MM-DDTHH:MM in the site's local standard time, or with an offset
    /// (+01:00, Z).
    #[arg(long, value_name = "TIME")]
    pub when: Option<When>,
    /// An EPW weather file: the site, and the hour's direct and diffuse irradiance for the
    /// sun and a Perez sky (instead of the daylight file's sun light and sky).
    #[arg(long, value_name = "FILE.epw")]
    pub weather: Option<PathBuf>,
}

impl DaylightFlags {
    /// The time and weather asked for, the weather file read; `None` without `--when`.
    pub fn moment(&self) -> Result<Option<Moment>> {
        let Some(when) = self.when else {
            if let Some(w) = &self.weather {
                anyhow::bail!(
                    "--weather {}: give --when TIME, the hour to take from it",
                    w.display()
                );
            }
            return Ok(None);
        };
        let weather = (self.weather.as_deref())
            .map(|p| Weather::load(p).map(Arc::new))
            .transpose()?;
        Ok(Some(Moment { when, weather }))
    }

    /// How a node lights `scene` for the session's other times of day (`None` without
    /// `--when`): its daylight file and the weather file (read once, here) at each time.
    pub fn time_of_day(&self, scene: &Path) -> Result<Option<TimeOfDay>> {
        let Some(moment) = self.moment()? else {
            return Ok(None);
        };
        let (scene, file, weather) = (scene.to_owned(), self.daylight.clone(), moment.weather);
        let daylight_at = move |when| {
            let moment = Moment {
                when,
                weather: weather.clone(),
            };
            load_daylight(&scene, file.as_deref(), Some(&moment)).map_err(|e| e.to_string())
        };
        Ok(Some(TimeOfDay {
            start: moment.when,
            daylight_at: Arc::new(daylight_at),
        }))
    }

    /// The flags as another `holocave` process takes them.
    pub fn args(&self) -> Vec<OsString> {
        let mut a = Vec::new();
        if let Some(d) = &self.daylight {
            a.extend([OsString::from("--daylight"), d.into()]);
        }
        if let Some(w) = &self.when {
            a.extend([OsString::from("--when"), w.to_string().into()]);
        }
        if let Some(w) = &self.weather {
            a.extend([OsString::from("--weather"), w.into()]);
        }
        a
    }
}
