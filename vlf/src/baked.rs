//! A baked light field's life on disk: settings checked before a bake starts, a bake that
//! saves every bounce and resumes an unfinished file, a file of an older version baked
//! again where the caller allows it, and the one `open` that checks a file against the
//! scene it is drawn with (elements and tiles laid out alike).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use holocave_scene::Scene;
use holocave_scene::fingerprint::set_aside;

use crate::bake::{Casting, Settings, Stage, State, Stats, bake_with, layout, tiles};
use crate::elements::Elements;
use crate::file::{VlfError, VlfFile};
use crate::tiles::Tiles;

/// Why a light field could not be baked or opened.
#[derive(Debug, thiserror::Error)]
pub enum BakedError {
    #[error(transparent)]
    File(#[from] VlfError),
    #[error("bake settings: {0}")]
    Settings(String),
    #[error("{path}: {what}")]
    Mismatch { path: PathBuf, what: String },
    #[error("interrupted; {path} keeps bounce {bounces} (run again to resume)")]
    Interrupted { path: PathBuf, bounces: u32 },
}

/// Checks settings a user gave before any work is done.
pub fn validate(s: &Settings) -> Result<(), BakedError> {
    let bad = |m: String| Err(BakedError::Settings(m));
    if !(0.0..=1.0).contains(&s.glossy_alpha) {
        return bad(format!("glossy alpha {}: give 0 to 1", s.glossy_alpha));
    }
    if s.tile_bins == 0 || s.tile_bins > 64 {
        return bad(format!("tile bins {}: give 1 to 64", s.tile_bins));
    }
    if s.resolution == 0 || s.resolution > 4096 {
        return bad(format!("resolution {}: give 1 to 4096 lines", s.resolution));
    }
    if s.element_size.is_some_and(|e| !(e > 0.0 && e.is_finite())) {
        return bad("the element size must be a positive length".into());
    }
    Ok(())
}

/// A light field opened for the scene it is drawn with.
#[derive(Clone)]
pub struct Opened {
    pub file: VlfFile,
    pub elements: Elements,
    pub tiles: Tiles,
    /// For a bake set's blend (`file.state`), the two bakes it was blended from: the walls
    /// smooth each bake's remainder alone and blend the smoothed fields
    /// ([`crate::split::Split`]), so a new time of day smooths nothing again.
    pub blended: Option<Arc<Blended>>,
}

/// The two bakes around a time of day, and how far the time lies from the first to the
/// second (0 to 1).
pub struct Blended {
    pub before: Arc<Opened>,
    pub after: Arc<Opened>,
    pub t: f32,
}

/// Opens `path` for `scene`: refuses a file baked for another scene (by its fingerprint)
/// or whose elements or tiles do not match the scene's layout at the file's settings.
pub fn open(path: &Path, scene: &Scene) -> Result<Opened, BakedError> {
    let file = VlfFile::read_for(path, scene)?;
    let mismatch = |what: String| BakedError::Mismatch {
        path: path.to_owned(),
        what,
    };
    let elements = layout(scene, &file.settings);
    if elements.count != file.state.irradiance.len() {
        return Err(mismatch(format!(
            "{} elements, but the scene's layout at its settings has {}",
            file.state.irradiance.len(),
            elements.count
        )));
    }
    let tiles = tiles(scene, &file.settings, &elements);
    if tiles.len() != file.state.tiles.len() {
        return Err(mismatch(format!(
            "{} tile values, but the scene's glossy surfaces at its settings have {}",
            file.state.tiles.len(),
            tiles.len()
        )));
    }
    Ok(Opened {
        file,
        elements,
        tiles,
        blended: None,
    })
}

/// Where a bake of an existing file starts.
pub enum Start {
    /// No file: a new bake.
    Fresh,
    /// An unfinished bake, resumed after its last saved bounce.
    Resumed { bounces: u32, residual: f64 },
    /// The file is converged: nothing to do.
    Converged,
}

/// A bake to `out`, saved after every bounce.
pub struct BakeJob<'a> {
    pub scene: &'a Scene,
    pub settings: Settings,
    pub out: &'a Path,
    /// Raised to stop after the bounce being propagated (it is saved first).
    pub interrupted: &'a AtomicBool,
    /// The file is one a command keeps for itself (`sim`'s and `compare`'s default
    /// bakes): one from an older version of the format is removed and baked again, one
    /// baked for another version of the scene (its daylight, materials or geometry
    /// changed) is set aside, named by its fingerprint, and one set aside for the scene
    /// as it is now put back ([`holocave_scene::fingerprint::set_aside`]). Otherwise each
    /// is an error.
    pub kept_by_command: bool,
}

impl BakeJob<'_> {
    /// Where the bake will start (also removes an old version's file when allowed).
    pub fn start(&self) -> Result<Start, BakedError> {
        if self.kept_by_command {
            let io = |source| VlfError::Io {
                path: self.out.to_owned(),
                source,
            };
            let now = self.scene.fingerprint();
            match VlfFile::read(self.out) {
                Err(VlfError::Version { .. }) => std::fs::remove_file(self.out).map_err(io)?,
                Ok(f) if f.fingerprint != now => {
                    let done = set_aside(self.out, f.fingerprint, now).map_err(io)?;
                    tracing::warn!(
                        "{} was baked for another version of scene {} (its daylight, materials \
                         or geometry changed): {done}",
                        self.out.display(),
                        f.scene,
                    );
                }
                _ => {}
            }
        }
        if !self.out.exists() {
            return Ok(Start::Fresh);
        }
        let f = self.resumable()?;
        Ok(if f.state.converged {
            Start::Converged
        } else {
            Start::Resumed {
                bounces: f.state.bounces,
                residual: f.state.residual(),
            }
        })
    }

    /// The existing file, refused when it was baked with other settings.
    fn resumable(&self) -> Result<VlfFile, BakedError> {
        let f = VlfFile::read_for(self.out, self.scene)?;
        if f.settings != self.settings {
            return Err(BakedError::Mismatch {
                path: self.out.to_owned(),
                what: format!(
                    "baked with other settings ({:?}); remove it or give the same settings",
                    f.settings
                ),
            });
        }
        Ok(f)
    }

    /// Bakes (or finishes baking) the file; the stats are `None` when it was converged.
    pub fn run(
        &self,
        casting: &dyn Casting,
        progress: &(dyn Fn(Stage) + Sync),
    ) -> Result<(VlfFile, Option<Stats>), BakedError> {
        if let Some(dir) = self.out.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| VlfError::Io {
                path: dir.to_owned(),
                source,
            })?;
        }
        let resume = if self.out.exists() {
            let f = self.resumable()?;
            if f.state.converged {
                return Ok((f, None));
            }
            Some(f.state)
        } else {
            None
        };
        let file = |state: State| VlfFile {
            scene: self.scene.name.clone(),
            fingerprint: self.scene.fingerprint(),
            settings: self.settings,
            element_size: crate::bake::element_size(self.scene, &self.settings),
            state,
        };
        let mut save = |state: &State| -> Result<(), BakedError> {
            file(state.clone()).write(self.out)?;
            if self.interrupted.load(Ordering::Relaxed) {
                return Err(BakedError::Interrupted {
                    path: self.out.to_owned(),
                    bounces: state.bounces,
                });
            }
            Ok(())
        };
        let (state, stats) = bake_with(
            self.scene,
            &self.settings,
            resume,
            casting,
            progress,
            &mut save,
        )?;
        Ok((file(state), Some(stats)))
    }
}
