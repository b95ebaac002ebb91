//! `holocave fill`: batch-fills a holodeck (paper §2.2, batch mode) with worker threads or
//! worker processes, showing progress and an ETA. Stopping (time limit, Ctrl-C or a kill)
//! and running again continues where it left off: the file holds every committed sample,
//! and the batch order is recomputed from the counts.

use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, bail};
use clap::Args;
use glam::DVec3;
use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::file::DistanceKind;
use holocave_holodeck::run::{RunOptions, run as run_server};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_scene::empty_box::{Aabb, triangles_inside};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::holodeck::file_settings;
use indicatif::{ProgressBar, ProgressStyle};

use super::worker::load_source;
use holocave_tracer::holodeck::scene_name;

#[derive(Args)]
pub struct FillArgs {
    /// The scene to trace.
    #[arg(long)]
    pub scene: PathBuf,
    /// The holodeck file (created if missing, continued if present).
    #[arg(long)]
    pub holodeck: PathBuf,
    /// A section box `x0,y0,z0,x1,y1,z1` (metres, scene coordinates; repeatable). Used when
    /// creating the file; default: the scene's bounds shrunk by 10% on each side. An
    /// interior section should be free space: what lies inside it is never traced.
    #[arg(long, allow_hyphen_values = true)]
    pub section: Vec<String>,
    /// Grid `W,D,H` for new sections (default: about 200,000 beams).
    #[arg(long)]
    pub grid: Option<String>,
    /// View class of new sections: interior (looking out) or exterior (looking in).
    #[arg(long, default_value = "interior")]
    pub class: String,
    /// Distance stored with new files' samples: `virtual` (through flat mirrors and glass
    /// to what they show, the paper's VDISTANCE=True) or `first-hit`. An existing file
    /// keeps the one it was made with. [default: virtual]
    #[arg(long)]
    pub distance: Option<String>,
    /// Number of workers.
    #[arg(long, default_value_t = 1)]
    pub workers: usize,
    /// Run the workers as separate `holocave worker` processes over TCP instead of threads.
    #[arg(long)]
    pub worker_processes: bool,
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

fn parse_floats<const N: usize>(s: &str, what: &str) -> anyhow::Result<[f64; N]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} {s:?}: not numbers"))?;
    v.try_into()
        .map_err(|v: Vec<f64>| anyhow::anyhow!("{what} {s:?}: {} values, expected {N}", v.len()))
}

fn make_sections(args: &FillArgs, scene: &Scene) -> anyhow::Result<Vec<Section>> {
    let class = match args.class.as_str() {
        "interior" => ViewClass::Interior,
        "exterior" => ViewClass::Exterior,
        c => bail!("--class {c:?}: expected interior or exterior"),
    };
    let boxes: Vec<[f64; 6]> = if args.section.is_empty() {
        let (lo, hi) = scene.bounds();
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let inset = (hi - lo) * 0.1;
        let (a, b) = (lo + inset, hi - inset);
        vec![[a.x, a.y, a.z, b.x, b.y, b.z]]
    } else {
        args.section
            .iter()
            .map(|s| parse_floats::<6>(s, "--section"))
            .collect::<Result<_, _>>()?
    };
    boxes
        .iter()
        .map(|b| {
            let (lo, hi) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]));
            if class == ViewClass::Interior {
                let n = triangles_inside(scene, &Aabb { lo, hi });
                if n > 0 {
                    tracing::warn!(
                        "section {b:?} is interior (free space to look out of) but {n} \
                         triangles of the scene reach into it; they will be missing from views \
                         inside it (give a free --section, or --class exterior)"
                    );
                }
            }
            let d = hi - lo;
            let edges = [DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z];
            let s = match &args.grid {
                Some(g) => {
                    let g = parse_floats::<3>(g, "--grid")?.map(|x| x as u32);
                    Section::new(lo, edges, g, class)
                }
                None => Section::with_default_grid(lo, edges, class),
            };
            s.with_context(|| format!("section {b:?}"))
        })
        .collect()
}

fn spawn_workers(
    n: usize,
    addr: &str,
    scene: &PathBuf,
    credentials: &Credentials,
) -> anyhow::Result<Vec<Child>> {
    let exe = std::env::current_exe().context("finding the holocave executable")?;
    (0..n)
        .map(|_| {
            Command::new(&exe)
                .args(["worker", "--server", addr, "--scene"])
                .arg(scene)
                .args(["--cluster", &credentials.cluster])
                .env(
                    super::credentials::SECRET_VAR,
                    super::credentials::secret_text(credentials),
                )
                .spawn()
                .context("starting a worker process")
        })
        .collect()
}

pub fn run(args: FillArgs) -> anyhow::Result<()> {
    let name = scene_name(&args.scene);
    let file = if args.holodeck.exists() {
        let h = HoloFile::open_rw(&args.holodeck)?;
        if !args.section.is_empty() || args.grid.is_some() {
            tracing::warn!(
                "{} exists: --section and --grid are ignored",
                args.holodeck.display()
            );
        }
        if h.settings().get("scene").is_some_and(|s| *s != name) {
            tracing::warn!(
                "{} was made with scene {:?}, filling with {name:?}",
                args.holodeck.display(),
                h.settings()["scene"]
            );
        }
        let kind = h.distance_kind()?;
        if let Some(d) = args.distance.as_ref().filter(|d| *d != kind.name()) {
            tracing::warn!(
                "{} stores {} distances: --distance {d} is ignored",
                args.holodeck.display(),
                kind.name(),
            );
        }
        h
    } else {
        let distance = match &args.distance {
            None => DistanceKind::Virtual,
            Some(d) => DistanceKind::from_name(d)
                .with_context(|| format!("--distance {d:?}: expected virtual or first-hit"))?,
        };
        let scene = Scene::load(&args.scene, &LoadOptions::default())
            .with_context(|| format!("loading scene {}", args.scene.display()))?;
        let sections = make_sections(&args, &scene)?;
        let settings = file_settings(&name, distance, "fill");
        HoloFile::create(&args.holodeck, sections, settings)?
    };
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
        args.holodeck.display(),
        file.total_samples(),
        file.distance_kind()?.name()
    );
    let config = ServerConfig {
        cache_bytes: args.cache_mb << 20,
        ..Default::default()
    };
    let server = Server::new(file, Mode::Batch, config);
    let start_samples = server.stats().samples;
    let listen = match (&args.listen, args.worker_processes) {
        (Some(a), _) => Some(a.clone()),
        (None, true) => Some("127.0.0.1:0".to_string()),
        (None, false) => None,
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
    let mut children = Vec::new();
    let (threads, source) = if args.worker_processes {
        let addr = listener
            .as_ref()
            .expect("bound above")
            .listener
            .local_addr()?
            .to_string();
        children = spawn_workers(args.workers, &addr, &args.scene, &credentials)?;
        (0, None)
    } else {
        let src: Arc<dyn holocave_holodeck::worker::SampleSource> =
            Arc::new(load_source(&args.scene)?);
        (args.workers, Some(src))
    };
    let limit = args.time.map(Duration::from_secs_f64);
    let bar = match limit {
        Some(l) => {
            let b = ProgressBar::new(l.as_millis() as u64);
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} ETA {eta} {msg}",
                )
                .expect("valid template"),
            );
            b
        }
        None => ProgressBar::new_spinner(),
    };
    let opts = RunOptions {
        threads,
        source,
        listener,
        scene: name,
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
    for mut c in children {
        // The server said goodbye; a worker that does not exit soon is stopped.
        for _ in 0..50 {
            if c.try_wait().ok().flatten().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        if c.try_wait().ok().flatten().is_none() {
            let _ = c.kill();
            let _ = c.wait();
        }
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
    Ok(())
}
