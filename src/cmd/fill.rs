//! `holocave fill`: batch-fills a holodeck (paper §2.2, batch mode) with worker threads or
//! worker processes, showing progress and an ETA. Stopping (time limit, Ctrl-C or a kill)
//! and running again continues where it left off: the file holds every committed sample,
//! and the batch order is recomputed from the counts. Ctrl-C commits what was traced and
//! ends with status 130.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use glam::DVec3;
use holocave::launch::{Group, Watched, worker_command};
use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::file::DistanceKind;
use holocave_holodeck::run::{RunOptions, run as run_server};
use holocave_holodeck::scene_id::same_scene;
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_scene::Scene;
use holocave_scene::empty_box::{Aabb, triangles_inside};
use holocave_tracer::holodeck::{file_settings, sample_source, scene_identity};
use indicatif::{ProgressBar, ProgressStyle};

/// A section's view class.
#[derive(Clone, Copy, ValueEnum)]
pub enum Class {
    Interior,
    Exterior,
}

/// The distance a new file's samples store.
#[derive(Clone, Copy, ValueEnum)]
pub enum Distance {
    Virtual,
    FirstHit,
}

impl Distance {
    fn kind(self) -> DistanceKind {
        match self {
            Distance::Virtual => DistanceKind::Virtual,
            Distance::FirstHit => DistanceKind::FirstHit,
        }
    }
}

#[derive(Args)]
pub struct FillArgs {
    /// The scene to trace.
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// The holodeck file (created if missing, continued if present).
    #[arg(long)]
    pub holodeck: PathBuf,
    /// A section box `x0,y0,z0,x1,y1,z1` (metres, scene coordinates; repeatable). Used when
    /// creating the file; default: the scene's bounds shrunk by 10% on each side. An
    /// interior section should be free space: what lies inside it is never traced.
    #[arg(long, allow_hyphen_values = true, value_parser = super::parse::aabb)]
    pub section: Vec<[DVec3; 2]>,
    /// Grid `W,D,H` for new sections (default: about 200,000 beams).
    #[arg(long, value_parser = super::parse::grid)]
    pub grid: Option<[u32; 3]>,
    /// View class of new sections: interior (looking out) or exterior (looking in).
    #[arg(long, value_enum, default_value_t = Class::Interior)]
    pub class: Class,
    /// Distance stored with new files' samples: `virtual` (through flat mirrors and glass
    /// to what they show, the paper's VDISTANCE=True) or `first-hit`. An existing file
    /// keeps the one it was made with. [default: virtual]
    #[arg(long, value_enum)]
    pub distance: Option<Distance>,
    /// Tracer threads in this process.
    #[arg(long, default_value_t = 1, conflicts_with = "worker_processes")]
    pub threads: usize,
    /// Trace in this many `holocave worker` processes over TCP instead of threads.
    #[arg(long)]
    pub worker_processes: Option<usize>,
    /// Also accept external workers on this address.
    #[arg(long)]
    pub listen: Option<String>,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long)]
    pub time: Option<f64>,
    /// Beam cache budget in MiB.
    #[arg(long, default_value_t = 256)]
    pub cache_mb: usize,
    /// Commit at least this often, in seconds.
    #[arg(long, default_value_t = 5.0)]
    pub commit_every: f64,
}

fn make_sections(args: &FillArgs, scene: &Scene) -> anyhow::Result<Vec<Section>> {
    let class = match args.class {
        Class::Interior => ViewClass::Interior,
        Class::Exterior => ViewClass::Exterior,
    };
    let boxes = if args.section.is_empty() {
        let (lo, hi) = scene.bounds();
        let (lo, hi) = Section::default_box(lo.as_dvec3(), hi.as_dvec3());
        vec![[lo, hi]]
    } else {
        args.section.clone()
    };
    boxes
        .iter()
        .map(|&[lo, hi]| {
            if class == ViewClass::Interior {
                let n = triangles_inside(scene, &Aabb { lo, hi });
                if n > 0 {
                    tracing::warn!(
                        "section {lo} .. {hi} is interior (free space to look out of) but {n} \
                         triangles of the scene reach into it; they will be missing from views \
                         inside it (give a free --section, or --class exterior)"
                    );
                }
            }
            Section::of_box(lo, hi, args.grid, class)
                .with_context(|| format!("section {lo} .. {hi}"))
        })
        .collect()
}

fn spawn_workers(
    n: usize,
    addr: &str,
    scene: &Path,
    daylight: &super::daylight_flags::DaylightFlags,
    credentials: &Credentials,
) -> anyhow::Result<Group> {
    let exe = std::env::current_exe().context("finding the holocave executable")?;
    let workers = (0..n)
        .map(|i| {
            Watched::spawn(
                format!("worker {i}"),
                &mut worker_command(&exe, addr, scene, &daylight.args(), credentials),
            )
        })
        .collect::<std::io::Result<_>>()?;
    Ok(Group(workers))
}

pub fn run(args: FillArgs) -> anyhow::Result<()> {
    let scene = Arc::new(super::render::load_scene(
        &args.scene,
        args.daylight.clone(),
        false,
    )?);
    let identity = scene_identity(&args.scene, &scene);
    let file = open_or_create(&args, &scene, &identity)?;
    log_contents(&file, &args.holodeck)?;
    let file_scene = file.settings().get("scene").cloned().unwrap_or(identity);
    let config = ServerConfig {
        cache_bytes: args.cache_mb << 20,
        ..Default::default()
    };
    let server = Server::new(file, Mode::Batch, config);
    let start_samples = server.stats().samples;
    let listen = match (&args.listen, args.worker_processes) {
        (Some(a), _) => Some(a.clone()),
        (None, Some(_)) => Some("127.0.0.1:0".to_string()),
        (None, None) => None,
    };
    // Workers prove the cluster's secret: HOLOCAVE_SECRET, or a fresh one that only this
    // fill's own worker processes are given.
    let credentials = super::credentials::fresh(super::credentials::DEFAULT_CLUSTER)?;
    let listener = listen
        .map(|a| {
            let listener = TcpListener::bind(&a).with_context(|| format!("listening on {a}"))?;
            anyhow::Ok(Port {
                listener,
                credentials: credentials.clone(),
            })
        })
        .transpose()?;
    let mut children = Group::default();
    let (threads, source) = if let Some(processes) = args.worker_processes {
        let addr = listener
            .as_ref()
            .expect("bound above")
            .listener
            .local_addr()?
            .to_string();
        children = spawn_workers(processes, &addr, &args.scene, &args.daylight, &credentials)?;
        (0, None)
    } else {
        (args.threads, Some(sample_source(scene.clone())))
    };
    let limit = args.time.map(Duration::from_secs_f64);
    let bar = progress_bar(limit);
    let opts = RunOptions {
        threads,
        source,
        listener,
        scene: file_scene,
        commit_every: Duration::from_secs_f64(args.commit_every.max(0.1)),
        stop: super::interrupt::ctrl_c_flag(),
    };
    let result = run_server(server, opts, |p| {
        let secs = p.elapsed.as_secs_f64().max(1e-3);
        bar.set_position(p.elapsed.as_millis() as u64);
        bar.set_message(format!(
            "{} samples (+{}, {:.0}/s), {} workers, {} commits",
            p.stats.samples,
            p.stats.added,
            p.stats.added as f64 / secs,
            p.stats.workers,
            p.commits
        ));
        limit.is_some_and(|l| p.elapsed >= l)
    });
    bar.finish();
    // The server said goodbye; a worker that does not exit soon is stopped.
    for problem in children.wait(Duration::from_secs(5)) {
        tracing::warn!("{problem}");
    }
    let server = result?;
    let s = server.stats();
    println!(
        "{}: added {} samples in this run; {} samples in the holodeck ({} before)",
        args.holodeck.display(),
        s.added,
        s.samples,
        start_samples
    );
    if super::interrupt::interrupted() {
        super::interrupt::exit_interrupted(&format!(
            "{} keeps its {} samples (committed); run again to go on",
            args.holodeck.display(),
            s.samples
        ));
    }
    Ok(())
}

/// The holodeck at `args.holodeck`: opened where it exists (refused if it holds another
/// scene's samples), else made with the sections and distances asked.
fn open_or_create(args: &FillArgs, scene: &Scene, identity: &str) -> anyhow::Result<HoloFile> {
    Ok(if args.holodeck.exists() {
        let h = HoloFile::open_rw(&args.holodeck)?;
        if !args.section.is_empty() || args.grid.is_some() {
            tracing::warn!(
                "{} exists: --section and --grid are ignored",
                args.holodeck.display()
            );
        }
        if let Some(recorded) = h.settings().get("scene")
            && !same_scene(recorded, identity)
        {
            bail!(
                "{} holds samples of scene {recorded:?}, not of {identity:?} (another scene, \
                 or the same under another daylight): filling it would mix the two",
                args.holodeck.display()
            );
        }
        let kind = h.distance_kind()?;
        if let Some(d) = args.distance.map(Distance::kind).filter(|d| *d != kind) {
            tracing::warn!(
                "{} stores {} distances: --distance {} is ignored",
                args.holodeck.display(),
                kind.name(),
                d.name(),
            );
        }
        h
    } else {
        let distance = args.distance.map_or(DistanceKind::Virtual, Distance::kind);
        let sections = make_sections(args, scene)?;
        let settings = file_settings(identity, distance, "fill");
        HoloFile::create(&args.holodeck, sections, settings)?
    })
}

/// Logs the holodeck's sections, samples and distances.
fn log_contents(file: &HoloFile, path: &std::path::Path) -> anyhow::Result<()> {
    for (i, s) in file.sections().iter().enumerate() {
        let g = s.grid();
        tracing::info!(
            "section {i}: {:?}, grid {}x{}x{}, {} beams",
            s.class(),
            g[0],
            g[1],
            g[2],
            s.beam_count()
        );
    }
    tracing::info!(
        "{}: {} samples, {} distances",
        path.display(),
        file.total_samples(),
        file.distance_kind()?.name()
    );
    Ok(())
}

/// The fill's progress: a bar over `limit`, else a spinner.
fn progress_bar(limit: Option<Duration>) -> ProgressBar {
    let Some(l) = limit else {
        return ProgressBar::new_spinner();
    };
    let b = ProgressBar::new(l.as_millis() as u64);
    b.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} ETA {eta} {msg}")
            .expect("valid template"),
    );
    b
}
