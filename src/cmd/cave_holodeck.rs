//! A CAVE's holodeck: the file every render node of a CAVE draws from (one interior
//! section around the walls), and its server in interactive mode, shared by `node
//! --holodeck` (one wall by itself), `master --holodeck` (the cluster's server) and `sim`.

use std::net::{SocketAddr, TcpListener};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use holocave_cave::Cave;
use holocave_holodeck::HoloFile;
use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::cave_section::CaveSection;
use holocave_holodeck::file::DistanceKind;
use holocave_holodeck::run::{RunOptions, Running, start};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::SampleSource;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::holodeck::{HolodeckTracer, file_settings, scene_name};
use holocave_tracer::{TraceSettings, Tracer};

/// Opens the holodeck at `path`, or creates it for `cave` with `scene` (loaded from
/// `scene_path`) if it does not exist. `made_by` names the command in its settings.
pub fn open_or_create(
    path: &Path,
    cave: &Cave,
    scene_path: &Path,
    scene: &Scene,
    made_by: &str,
) -> Result<HoloFile> {
    if path.exists() {
        open(path, cave, scene_path)
    } else {
        create(path, cave, scene_path, scene, made_by)
    }
}

/// Opens an existing holodeck for `cave`, warning when it was made for another scene or
/// another CAVE.
fn open(path: &Path, cave: &Cave, scene_path: &Path) -> Result<HoloFile> {
    let name = scene_name(scene_path);
    let h = HoloFile::open_rw(path)?;
    if h.settings().get("scene").is_some_and(|s| *s != name) {
        tracing::warn!(
            "{} was made with scene {:?}, drawing with {name:?}",
            path.display(),
            h.settings()["scene"]
        );
    }
    let inside = cave.room_to_scene.transform_point3(cave.inside);
    if !h.sections().iter().any(|s| s.contains(inside)) {
        tracing::warn!(
            "{} was made for another CAVE: no section holds this CAVE's inside point \
             {inside:.3} (scene coordinates), so its eyes will get no holodeck samples",
            path.display()
        );
    }
    announce(path, &h);
    Ok(h)
}

/// Creates the holodeck at `path` for `cave`: one section, its [`CaveSection`].
fn create(
    path: &Path,
    cave: &Cave,
    scene_path: &Path,
    scene: &Scene,
    made_by: &str,
) -> Result<HoloFile> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let cs = CaveSection::new(cave, scene)?;
    if cs.was_cut() {
        println!(
            "holodeck section: {:.2} .. {:.2} (scene coordinates), cut from the CAVE's box \
             {:.2} .. {:.2} to leave the scene's surfaces outside; eyes outside it see no \
             holodeck samples",
            cs.cut.lo, cs.cut.hi, cs.walls_box.lo, cs.walls_box.hi
        );
    }
    let section = cs.section;
    let settings = file_settings(&scene_name(scene_path), DistanceKind::Virtual, made_by);
    let h = HoloFile::create(path, vec![section], settings)?;
    announce(path, &h);
    Ok(h)
}

fn announce(path: &Path, file: &HoloFile) {
    let g = file.sections()[0].grid();
    println!(
        "holodeck {}: {} samples, {} section(s), first grid {}x{}x{}",
        path.display(),
        file.total_samples(),
        file.sections().len(),
        g[0],
        g[1],
        g[2]
    );
}

/// Starts the holodeck's server for displays: `threads` tracer threads in this process
/// tracing `scene` (needed only when `threads > 0`; named `name` for TCP workers), and
/// TCP workers and displays that prove its credentials accepted on `listener`. It commits every 5 s;
/// [`Running::stop`] commits the rest.
pub fn serve(
    file: HoloFile,
    threads: usize,
    scene: Option<Arc<Scene>>,
    name: String,
    listener: Option<Port>,
) -> Result<Running> {
    let source = scene.map(|s| {
        Arc::new(HolodeckTracer(Tracer::new(s, TraceSettings::default()))) as Arc<dyn SampleSource>
    });
    let server = Server::new(file, Mode::Interactive, ServerConfig::interactive());
    let running = start(
        server,
        RunOptions {
            threads: if source.is_some() { threads } else { 0 },
            source,
            listener,
            scene: name,
            commit_every: Duration::from_secs(5),
            stop: super::interrupt::ctrl_c_flag(),
        },
    )?;
    if let Some(a) = running.local_addr() {
        println!("holodeck workers and displays may connect to {a}");
    }
    Ok(running)
}

/// A CAVE's holodeck hosted by the cluster's master (or `sim`): the server, the address
/// workers and render nodes reach it at, and its file.
pub struct Hosted {
    running: Running,
    pub addr: SocketAddr,
    path: PathBuf,
}

/// Opens or creates the holodeck `path` for `cave` and serves it on `listen` with
/// `threads` tracer threads in this process (workers proving `credentials` may add more
/// from any host).
pub fn host(
    path: &Path,
    cave: &Cave,
    scene_path: &Path,
    threads: usize,
    (listen, credentials): (&str, Credentials),
    made_by: &str,
) -> Result<Hosted> {
    // The scene is needed to cut a new file's section and for tracer threads; a master
    // serving an existing file to remote workers does without it.
    let scene = if threads > 0 || !path.exists() {
        let s = Scene::load(scene_path, &LoadOptions::default())
            .with_context(|| format!("loading {}", scene_path.display()))?;
        Some(Arc::new(s))
    } else {
        None
    };
    let file = match &scene {
        Some(s) => open_or_create(path, cave, scene_path, s, made_by)?,
        None => open(path, cave, scene_path)?,
    };
    let listener =
        TcpListener::bind(listen).with_context(|| format!("holodeck: listening on {listen}"))?;
    let addr = listener.local_addr()?;
    let port = Port {
        listener,
        credentials,
    };
    let running = serve(file, threads, scene, scene_name(scene_path), Some(port))?;
    Ok(Hosted {
        running,
        addr,
        path: path.to_owned(),
    })
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

    /// Stops the server, commits everything traced and says how much it holds.
    pub fn stop(self) -> Result<()> {
        let server = self.running.stop()?;
        let s = server.stats();
        println!(
            "holodeck {}: {} samples added by this run, {} in all (committed)",
            self.path.display(),
            s.added,
            s.samples
        );
        Ok(())
    }
}
