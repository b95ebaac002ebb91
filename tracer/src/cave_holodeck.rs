//! A CAVE's holodeck: the file every render node of a CAVE draws from (one interior section
//! around the walls, `holodeck::cave_section`) and its server, filled by this crate's
//! [`HolodeckTracer`]. One type for `node --holodeck` (one wall by itself), `master
//! --holodeck` and `sim` (the cluster's server) and `compare` (the holodeck methods).

use std::net::{SocketAddr, TcpListener};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use glam::DVec3;
use holocave_cave::Cave;
use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::cave_section::CaveSection;
use holocave_holodeck::file::DistanceKind;
use holocave_holodeck::run::{RayAllowance, RunOptions, Running, start, start_held};
use holocave_holodeck::scene_id::{fingerprint_of, same_scene};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_scene::empty_box::{Aabb, triangles_inside};
use holocave_scene::fingerprint::set_aside;
use holocave_scene::{LoadOptions, Scene};

use crate::holodeck::{file_settings, sample_source, scene_identity};

/// Why a CAVE's holodeck could not be opened, created or served.
#[derive(Debug, thiserror::Error)]
pub enum CaveHolodeckError {
    #[error("{path}: {message}")]
    File { path: String, message: String },
    #[error("the holodeck's section: {0}")]
    Section(String),
    #[error("holodeck: listening on {addr}: {source}")]
    Listen {
        addr: String,
        source: std::io::Error,
    },
    #[error("the holodeck's server: {0}")]
    Server(String),
}

/// A CAVE's holodeck file, opened for one scene.
pub struct CaveHolodeck {
    pub path: PathBuf,
    pub file: HoloFile,
    /// The section this run made, when it created the file.
    pub created: Option<CaveSection>,
    /// The scene's identity as the file records it and TCP workers are checked against.
    pub scene: String,
}

/// How a CAVE's holodeck is served.
pub struct Serving {
    /// Tracer threads in this process (none without `scene`).
    pub threads: usize,
    /// The scene the tracer threads trace.
    pub scene: Option<Arc<Scene>>,
    /// TCP workers and displays that prove its credentials are accepted here.
    pub port: Option<Port>,
    /// Raised to stop the server (the Ctrl-C flag).
    pub stop: Arc<AtomicBool>,
    /// The tracer threads trace only what this grants (a comparison's ray budget).
    pub allowance: Option<Arc<RayAllowance>>,
}

impl CaveHolodeck {
    /// Opens the holodeck at `path`, or creates it for `cave` (its [`CaveSection`], then
    /// an interior section for each box of `more`, or where `more` is empty of the
    /// config's `[navigation] sections`) when it does not exist; creating needs
    /// `scene`, loaded from `scene_path`. Opening warns when the file was made for another scene or another
    /// CAVE. `made_by` names the command in a new file's settings.
    pub fn open_or_create(
        path: &Path,
        cave: &Cave,
        scene_path: &Path,
        scene: Option<&Scene>,
        made_by: &str,
        more: &[[DVec3; 2]],
    ) -> Result<CaveHolodeck, CaveHolodeckError> {
        let bad = |message: String| CaveHolodeckError::File {
            path: path.display().to_string(),
            message,
        };
        let more = match more.is_empty() {
            true => &cave.navigation.sections[..],
            false => more,
        };
        let identity = scene.map(|s| scene_identity(scene_path, s));
        if path.exists() {
            let file = HoloFile::open_rw(path).map_err(|e| bad(e.to_string()))?;
            let recorded = file.settings().get("scene").cloned();
            if let (Some(r), Some(id)) = (&recorded, &identity)
                && !same_scene(r, id)
            {
                tracing::warn!(
                    "{} was made with scene {r:?}, drawing with {id:?}: its samples are of \
                     another scene (or another daylight)",
                    path.display(),
                );
            }
            let inside = cave.room_to_scene.transform_point3(cave.inside);
            if !file.sections().iter().any(|s| s.contains(inside)) {
                tracing::warn!(
                    "{} was made for another CAVE: no section holds this CAVE's inside point \
                     {inside:.3} (scene coordinates), so its eyes will get no holodeck samples",
                    path.display()
                );
            }
            if !more.is_empty() && file.sections().len() != 1 + more.len() {
                tracing::warn!(
                    "{} exists with {} section(s): the {} section(s) asked for apply to a new \
                     file only",
                    path.display(),
                    file.sections().len(),
                    more.len()
                );
            }
            return Ok(CaveHolodeck {
                path: path.to_owned(),
                file,
                created: None,
                scene: recorded.or(identity).unwrap_or_default(),
            });
        }
        let scene =
            scene.ok_or_else(|| bad("does not exist (creating it needs the scene)".into()))?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| bad(format!("creating its folder: {e}")))?;
        }
        let cs =
            CaveSection::new(cave, scene).map_err(|e| CaveHolodeckError::Section(e.to_string()))?;
        let mut sections = vec![cs.section.clone()];
        for &[lo, hi] in more {
            let inside = triangles_inside(scene, &Aabb { lo, hi });
            if inside > 0 {
                tracing::warn!(
                    "section {lo:.2} .. {hi:.2}: {inside} triangles of the scene reach into it \
                     and will vanish from views inside it (`holocave holodeck sections` proposes \
                     empty ones)"
                );
            }
            sections.push(
                Section::of_box(lo, hi, None, ViewClass::Interior)
                    .map_err(|e| CaveHolodeckError::Section(format!("{lo} .. {hi}: {e}")))?,
            );
        }
        let name = scene_identity(scene_path, scene);
        let settings = file_settings(&name, DistanceKind::Virtual, made_by);
        let file = HoloFile::create(path, sections, settings).map_err(|e| bad(e.to_string()))?;
        Ok(CaveHolodeck {
            path: path.to_owned(),
            file,
            created: Some(cs),
            scene: name,
        })
    }

    /// What was opened, in a line or two: the samples held, the sections, and where a new
    /// file's section was cut.
    pub fn describe(&self) -> String {
        let mut s = String::new();
        if let Some(cs) = self.created.as_ref().filter(|c| c.was_cut()) {
            s += &format!(
                "holodeck section: {:.2} .. {:.2} (scene coordinates), cut from the CAVE's box \
                 {:.2} .. {:.2} to leave the scene's surfaces outside; eyes outside it see no \
                 holodeck samples\n",
                cs.cut.lo, cs.cut.hi, cs.walls_box.lo, cs.walls_box.hi
            );
        }
        let g = self.file.sections()[0].grid();
        s += &format!(
            "holodeck {}: {} samples, {} section(s), first grid {}x{}x{}",
            self.path.display(),
            self.file.total_samples(),
            self.file.sections().len(),
            g[0],
            g[1],
            g[2]
        );
        s
    }

    /// Starts the server for displays: `threads` tracer threads in this process tracing
    /// the scene, and TCP workers and displays on the port. It commits every 5 s;
    /// [`Running::stop`] commits the rest.
    pub fn serve(self, serving: Serving) -> Result<Running, CaveHolodeckError> {
        let source = serving.scene.map(sample_source);
        let server = Server::new(self.file, Mode::Interactive, ServerConfig::interactive());
        let opts = RunOptions {
            threads: if source.is_some() { serving.threads } else { 0 },
            source,
            listener: serving.port,
            scene: self.scene,
            commit_every: Duration::from_secs(5),
            stop: serving.stop,
        };
        match serving.allowance {
            Some(a) => start_held(server, opts, a),
            None => start(server, opts),
        }
        .map_err(|e| CaveHolodeckError::Server(e.to_string()))
    }

    /// Hosts the holodeck for a cluster (the master, or `sim`): serves it on `listen` to
    /// workers and render nodes that prove `credentials`, with `threads` tracer threads of
    /// `scene` in this process.
    pub fn host(
        self,
        listen: &str,
        credentials: Credentials,
        threads: usize,
        scene: Option<Arc<Scene>>,
        stop: Arc<AtomicBool>,
    ) -> Result<Hosted, CaveHolodeckError> {
        let listener = TcpListener::bind(listen).map_err(|source| CaveHolodeckError::Listen {
            addr: listen.to_owned(),
            source,
        })?;
        let addr = listener
            .local_addr()
            .map_err(|source| CaveHolodeckError::Listen {
                addr: listen.to_owned(),
                source,
            })?;
        let path = self.path.clone();
        let running = self.serve(Serving {
            threads,
            scene,
            port: Some(Port {
                listener,
                credentials,
            }),
            stop,
            allowance: None,
        })?;
        Ok(Hosted {
            running,
            addr,
            path,
        })
    }
}

/// Sets the holodeck at `path` aside when it holds samples of another version of `scene`
/// (see [`HostSpec::follows_scene`]).
fn set_aside_for_another_scene(path: &Path, scene: &Scene) -> Result<(), CaveHolodeckError> {
    let bad = |message: String| CaveHolodeckError::File {
        path: path.display().to_string(),
        message,
    };
    let recorded = HoloFile::open(path)
        .map_err(|e| bad(e.to_string()))?
        .settings()
        .get("scene")
        .cloned();
    let now = scene.fingerprint();
    let Some(was) = recorded.as_deref().and_then(fingerprint_of) else {
        return Ok(());
    };
    if was != now {
        let done = set_aside(path, was, now).map_err(|e| bad(format!("setting it aside: {e}")))?;
        tracing::warn!(
            "{} holds samples of another version of the scene (its daylight, materials or \
             geometry changed): {done}",
            path.display(),
        );
    }
    Ok(())
}

/// What a cluster's hosted holodeck is: its file, the scene, and who may fill and draw it.
pub struct HostSpec<'a> {
    pub path: &'a Path,
    pub cave: &'a Cave,
    pub scene_path: &'a Path,
    /// Tracer threads in this process (workers on other hosts add more).
    pub threads: usize,
    /// The address to listen on, and what workers and displays must prove.
    pub listen: &'a str,
    pub credentials: Credentials,
    /// The scene's daylight file (`None`: the one beside the scene, if any).
    pub daylight: Option<&'a Path>,
    /// The time and weather the daylight is taken at (`None`: the daylight file as written).
    pub moment: Option<holocave_scene::daylight::Moment>,
    /// The command that creates a new file (`master`, `sim`).
    pub made_by: &'a str,
    /// Interior sections a new file gets besides the CAVE's (boxes `lo, hi` in scene
    /// coordinates: the rooms a walk-through goes to); empty: the config's.
    pub sections: &'a [[DVec3; 2]],
    pub stop: Arc<AtomicBool>,
    /// The file is the command's own (`sim`'s default): one made for another version of
    /// the scene (its daylight, materials or geometry changed) is set aside, named by its
    /// fingerprint, and one set aside for the scene as it is now put back
    /// ([`holocave_scene::fingerprint::set_aside`]); else a new one is made. Otherwise
    /// such a file is opened with a warning (its samples are of another scene).
    pub follows_scene: bool,
}

impl HostSpec<'_> {
    /// Opens or creates the file and hosts it. The scene is loaded only when it is needed:
    /// to cut a new file's section, or for tracer threads (a master serving an existing
    /// file to remote workers does without it). Also returns [`CaveHolodeck::describe`].
    pub fn host(self) -> Result<(Hosted, String), CaveHolodeckError> {
        let scene = if self.threads > 0 || !self.path.exists() || self.follows_scene {
            let options = LoadOptions {
                daylight: self.daylight.map(Path::to_path_buf),
                moment: self.moment.clone(),
                ..LoadOptions::default()
            };
            let s =
                Scene::load(self.scene_path, &options).map_err(|e| CaveHolodeckError::File {
                    path: self.scene_path.display().to_string(),
                    message: e.to_string(),
                })?;
            Some(Arc::new(s))
        } else {
            None
        };
        if let (true, Some(scene)) = (self.follows_scene && self.path.exists(), &scene) {
            set_aside_for_another_scene(self.path, scene)?;
        }
        let holodeck = CaveHolodeck::open_or_create(
            self.path,
            self.cave,
            self.scene_path,
            scene.as_deref(),
            self.made_by,
            self.sections,
        )?;
        let described = holodeck.describe();
        let hosted = holodeck.host(
            self.listen,
            self.credentials,
            self.threads,
            scene,
            self.stop,
        )?;
        Ok((hosted, described))
    }
}

/// A CAVE's holodeck hosted for a cluster: the server, the address workers and render
/// nodes reach it at, and its file.
pub struct Hosted {
    running: Running,
    pub addr: SocketAddr,
    pub path: PathBuf,
}

/// What a hosted holodeck holds when it stops.
pub struct Stopped {
    /// Samples added by this run.
    pub added: u64,
    /// Samples in the file, all committed.
    pub samples: u64,
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} samples added by this run, {} in all (committed)",
            self.added, self.samples
        )
    }
}

impl Hosted {
    /// A status-line part: samples held, samples added per second since the last call,
    /// workers connected.
    pub fn status(&self) -> Box<dyn FnMut() -> String + Send> {
        let monitor = self.running.monitor();
        let mut last: Option<(Instant, u64)> = None;
        Box::new(move || {
            let Some(s) = monitor.stats() else {
                return "holodeck stopped".to_owned();
            };
            let now = Instant::now();
            let rate = last.map_or(0.0, |(t, added)| {
                (s.added - added) as f64 / now.duration_since(t).as_secs_f64().max(1e-3)
            });
            last = Some((now, s.added));
            format!(
                "holodeck {:.2} M samples, {:.0} k rays/s, {} workers",
                s.samples as f64 / 1e6,
                rate / 1e3,
                s.workers
            )
        })
    }

    /// Stops the server and commits everything traced.
    pub fn stop(self) -> Result<Stopped, CaveHolodeckError> {
        let server = self
            .running
            .stop()
            .map_err(|e| CaveHolodeckError::Server(e.to_string()))?;
        let s = server.stats();
        Ok(Stopped {
            added: s.added,
            samples: s.samples,
        })
    }
}
