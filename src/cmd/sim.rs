//! `holocave sim`: a whole CAVE cluster on one machine — the master and the holodeck's
//! server in this process, one render-node process per wall and holodeck worker processes,
//! on loopback with real sockets — headless. Each node writes its frames; at the end the
//! walls of every written frame are laid out as the unfolded CAVE (left | front | right,
//! the floor under the front wall). The nodes and workers run under a [`Supervisor`]: one
//! that dies during the frames is started again (unless `--no-restart`), its wall presents
//! again, and the status line and the summary say who died, when, and when it was back.

use std::collections::{BTreeMap, BTreeSet};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::DVec3;
use holocave::launch::worker_command;
use holocave::supervise::{Backoff, Death, Relaunch, Supervisor};
use holocave_cave::{Cave, Eye, Place, Unfolded, Wall, load_cave, unfold};
use holocave_glare::session::{FrameView, measure_session, views_of};
use holocave_holodeck::auth::Credentials;
use holocave_master::cluster::{FrameHook, MasterOptions, run as run_master};
use holocave_master::sun_clock::SunClock;
use holocave_protocol::cluster::{MAX_CLUSTER_FRAME, MasterMsg};
use holocave_protocol::frame::{FrameError, read_frame};
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::mosaic::cave_mosaic;
use holocave_render_node::output::{PRESENTED_LOG, frame_png, read_presented};
use holocave_render_node::wall_windows::present_skew;
use holocave_tracer::cave_holodeck::{HostSpec, Hosted};

use super::credentials;
use super::master::{HeadArgs, host, print_summary, stop_hosted};

/// The recorded head trace used when none is given (a HoloLens user walking and looking
/// around), if the shared data is beside the checkout; otherwise a synthetic walk.
const DEFAULT_LOG: &str = "../shared/tracking/pred6dof/1.csv";

#[derive(Args)]
pub struct SimArgs {
    /// The CAVE config.
    #[arg(long, default_value = "configs/cave4-room.toml")]
    pub config: PathBuf,
    /// The scene (glTF).
    #[arg(long, default_value = "scenes/room.gltf")]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// Move the scene's moving objects along these paths (CSV
    /// `object,time_s,tx,ty,tz,qx,qy,qz,qw`, time from the run's start); the master sends
    /// their placements with every frame.
    #[arg(long, value_name = "FILE")]
    pub objects: Option<PathBuf>,
    #[command(flatten)]
    pub head: HeadArgs,
    /// Frames to run.
    #[arg(long, default_value_t = 240)]
    pub frames: u64,
    /// Output folder: DIR/<wall>/ for each node's frames, DIR/mosaic/ for the mosaics.
    #[arg(long, default_value = "out/sim")]
    pub out: PathBuf,
    /// Wall images at this fraction of the config's pixels (each eye).
    #[arg(long, default_value_t = 0.125)]
    pub scale: f64,
    /// Frame rate. Four nodes and their tracers share this machine's cores, so the
    /// default is below a real CAVE's (whose config says 60 Hz).
    #[arg(long, default_value_t = 30.0)]
    pub rate: f64,
    /// The dead-node timeout (ms). Four nodes, their tracers, the holodeck's workers and,
    /// with --window, four presenting windows share this machine's cores, so a wall
    /// normally takes longer than a real CAVE's node; the default waits for it rather than
    /// declaring it out (the config's `dead_node_ms` is for a real cluster).
    #[arg(long, default_value_t = 2000.0)]
    pub dead_node_ms: f64,
    /// Write every wall's images (and a mosaic) every K frames.
    #[arg(long, default_value_t = 30)]
    pub every: u64,
    /// The holodeck the walls draw from, hosted by the master and kept between runs: a
    /// second run starts from every ray the first traced (default: DIR/<scene>.hdk).
    #[arg(long)]
    pub holodeck: Option<PathBuf>,
    /// No holodeck: each node traces its own samples and keeps none.
    #[arg(long, conflicts_with = "holodeck")]
    pub no_holodeck: bool,
    /// An interior section a new holodeck file gets besides the CAVE's,
    /// `x0,y0,z0,x1,y1,z1` in scene coordinates (repeatable; `holocave holodeck sections`
    /// proposes them).
    #[arg(long, conflicts_with = "no_holodeck", value_parser = super::parse::aabb)]
    pub section: Vec<[DVec3; 2]>,
    /// Worker processes tracing for the holodeck.
    #[arg(long, default_value_t = 2)]
    pub workers: usize,
    /// The light field the walls draw under their samples, baked when missing and kept
    /// between runs (default: DIR/<scene>.vlf, baked with default settings); a folder is
    /// a bake set (`vlf bake --until`), drawn at each frame's time of day.
    #[arg(long)]
    pub vlf: Option<PathBuf>,
    /// No light field: the walls show the render cache alone.
    #[arg(long, conflicts_with = "vlf")]
    pub no_vlf: bool,
    /// Also measure the glare of every frame's view (a SIZE×SIZE fisheye drawn from the
    /// light field with the direct light per pixel): `glare.csv` and a summary, computed
    /// after the run from the frame states, so the walls are not slowed.
    #[arg(long, value_name = "SIZE", conflicts_with = "no_vlf")]
    pub glare: Option<u32>,
    /// Every node takes the sky's light per pixel too (`node --sky-per-pixel`).
    #[arg(long, conflicts_with = "no_vlf")]
    pub sky_per_pixel: bool,
    /// Where each node traces its light field's per-pixel rays (`node --rays`).
    #[arg(long, default_value = "auto", value_parser = str::parse::<Rays>)]
    pub rays: Rays,
    /// Every wall's tone mapping (windows and PNG frames): `camera`, `human` (what a person
    /// would see), `falsecolor` (cd/m² with a legend), or `reinhard` (PNG frames only).
    #[arg(long, value_enum, default_value_t = super::tone::Tone::Camera)]
    pub tone: super::tone::Tone,
    #[command(flatten)]
    pub windows: super::window::SimWindowArgs,
    /// Leave a node or worker that dies during the frames down. By default it is started
    /// again with the same command after 0.1 s (doubling to 1 s while it keeps dying soon
    /// after its start, back to 0.1 s once it has run 10 s): a node's wall presents again,
    /// a worker joins the holodeck again.
    #[arg(long)]
    pub no_restart: bool,
}

pub fn run(mut args: SimArgs) -> Result<()> {
    let cave = checked_cave(&mut args)?;
    // The scene, loaded once if this process needs it (a bake, navigation, glare).
    let scene = super::render::SharedScene::new(&args.scene, args.daylight.clone());
    // A fresh secret for this run; the nodes and workers get it through their environment.
    let credentials = credentials::fresh(&cave.cluster.id)?;
    let secret = credentials::secret_text(&credentials);
    let listener = TcpListener::bind("127.0.0.1:0").context("listening on loopback")?;
    let addr = listener.local_addr()?.to_string();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let exe = std::env::current_exe().context("finding the holocave executable")?;
    println!(
        "simulated CAVE: {} walls, {} frames at {} Hz, tracker {}, master on {addr}, output in {}",
        cave.walls.len(),
        args.frames,
        cave.cluster.rate_hz,
        args.head.tracker.as_deref().unwrap_or("?"),
        args.out.display()
    );
    let vlf = light_field(&args, &scene)?;
    let hosted = host_holodeck(&args, &cave, &credentials)?;
    // One layout of the unfolded CAVE for the windows and the mosaics.
    let unfolded = unfolded_walls(&args, &cave);
    let placed = unfolded.fit(args.windows.desktop);
    let nodes = Nodes {
        exe: &exe,
        master: &addr,
        unfolded: &unfolded,
        placed: &placed,
        vlf: vlf.as_deref(),
        secret: &secret,
    };
    let mut children = worker_children(&args, &exe, hosted.as_ref(), &credentials)?;
    for wall in &cave.walls {
        children.push(nodes.child(&args, wall)?);
    }
    let backoff = (!args.no_restart).then(Backoff::default);
    let supervisor = Supervisor::start(children, backoff, super::interrupt::ctrl_c_flag())?;
    let sent = SentTimes::default();
    let opts = master_options(&args, &scene, &cave, hosted.as_ref(), vlf.as_deref())?;
    let opts = MasterOptions {
        status_extra: Some(status_parts(hosted.as_ref(), &supervisor)),
        on_frame: Some(frame_hook(sent.clone(), supervisor.ending(), args.frames)),
        ..opts
    };
    let origin = supervisor.started;
    let head = args.head.open(&cave)?;
    let running = Mutex::new(Some(Running { supervisor, hosted }));
    let kept = kept_on_ctrl_c(&args, vlf.as_deref());
    let (summary, running) = std::thread::scope(|s| {
        s.spawn(|| end_if_the_master_hangs(&running, &kept));
        let summary = run_master(&cave, head, listener, secret.into_bytes(), opts);
        let running = running.lock().unwrap_or_else(|e| e.into_inner()).take();
        (summary, running)
    });
    let running = running.expect("only the watchdog takes it, and it ends the process");
    let interrupted = super::interrupt::interrupted();
    let (mut children, deaths) = running.stop()?;
    let summary = summary?;
    // Told to shut down, the nodes end at once; one that does not is killed.
    let limit = Duration::from_secs(if interrupted { 1 } else { 20 });
    for problem in children.wait(limit) {
        tracing::warn!("{problem}");
    }
    print_summary(&summary);
    let presented = presented_logs(&args.out, &cave)?;
    let sent = sent.lock().unwrap_or_else(|e| e.into_inner());
    report_deaths(&args, &deaths, (origin, &sent), &presented);
    if interrupted {
        report_presented(&presented);
        super::interrupt::exit_interrupted(&format!(
            "{kept} (no mosaics or glare made); run again to go on"
        ));
    }
    // The mosaics and the glare read what is written and write their own: Ctrl-C ends
    // them at once.
    super::interrupt::ending_at_once(format!("{kept}; run again to go on"), || {
        report_frames(&args, &cave, &unfolded, &presented)?;
        // A session's glare, windows or not: every frame's view from the frame states.
        if let (Some(size), Some(vlf)) = (args.glare, &vlf) {
            measure_glare(&args, &scene.get()?, vlf, size)?;
        }
        Ok(())
    })
}

/// How long the master has, after Ctrl-C, to end its frames and tell the nodes to shut
/// down: it looks at Ctrl-C only between frames, and not while it waits for the walls to
/// join or draw their first frame, so past this `sim` stops the processes itself.
const MASTER_GRACE: Duration = Duration::from_millis(500);

/// What `sim` stops once the master returned (or its watchdog, where the master does not
/// stop): the supervised nodes and workers and the hosted holodeck.
struct Running {
    supervisor: Supervisor,
    hosted: Option<Hosted>,
}

impl Running {
    /// Stops supervising (the children, to wait for, and every death seen), then the
    /// holodeck: that commits its samples and tells the workers goodbye, also when the
    /// master failed, so what the workers traced is kept.
    fn stop(self) -> Result<(holocave::launch::Group, Vec<Death>)> {
        let stopped = self.supervisor.stop();
        if let Some(h) = self.hosted {
            stop_hosted(h)?;
        }
        Ok(stopped)
    }

    /// Kills the children (they wait for a master that is gone), then stops the holodeck,
    /// which commits what it received (it waits for its connections to close).
    fn kill(self) -> Result<()> {
        drop(self.supervisor.stop());
        if let Some(h) = self.hosted {
            stop_hosted(h)?;
        }
        Ok(())
    }
}

/// The watchdog beside the master: once Ctrl-C was pressed and the master has not
/// returned within [`MASTER_GRACE`], stops the children and the holodeck and ends the
/// process, saying `kept`. Returns when the master returned first (it took `running`).
fn end_if_the_master_hangs(running: &Mutex<Option<Running>>, kept: &str) {
    let mut since = None;
    loop {
        std::thread::sleep(Duration::from_millis(20));
        let mut r = running.lock().unwrap_or_else(|e| e.into_inner());
        if r.is_none() {
            return;
        }
        if !super::interrupt::interrupted() {
            continue;
        }
        let since = *since.get_or_insert_with(Instant::now);
        if since.elapsed() < MASTER_GRACE {
            continue;
        }
        tracing::warn!("the master did not stop: stopping the nodes, workers and holodeck");
        if let Some(Err(e)) = r.take().map(Running::kill) {
            tracing::error!("{e:#}");
        }
        super::interrupt::exit_interrupted(&format!("{kept}; run again to go on"));
    }
}

/// What a run that Ctrl-C ends keeps: the holodeck's samples (committed), the light field,
/// the walls' frames and the frame states written so far.
fn kept_on_ctrl_c(args: &SimArgs, vlf: Option<&Path>) -> String {
    let mut kept = Vec::new();
    if !args.no_holodeck {
        let hdk = (args.holodeck.clone())
            .unwrap_or_else(|| super::kept_beside(&args.out, &args.scene, "hdk"));
        kept.push(format!(
            "the holodeck {} keeps its samples (committed)",
            hdk.display()
        ));
    }
    if let Some(vlf) = vlf {
        kept.push(format!("the light field {} is whole", vlf.display()));
    }
    kept.push(format!(
        "the walls' frames and the frame states so far are in {}",
        args.out.display()
    ));
    kept.join("; ")
}

/// The master's options for the run (less the status line's extra part and the frame
/// hook, which need the supervisor): the head's clock, the frames asked, the holodeck and
/// light field told to the nodes, the logs, navigation and moving objects.
fn master_options(
    args: &SimArgs,
    scene: &super::render::SharedScene,
    cave: &Cave,
    hosted: Option<&Hosted>,
    vlf: Option<&Path>,
) -> Result<MasterOptions> {
    let mut navigation = args.head.navigation(cave, Some(scene))?;
    if let Some(nav) = &mut navigation {
        super::master::log_desk(nav, &args.out)?;
    }
    Ok(MasterOptions {
        clock: args.head.clock(),
        frames: Some(args.frames),
        seconds: None,
        stop_at_end_of_log: false,
        holodeck: hosted.map(|h| h.addr.to_string()),
        vlf: vlf.map(|p| p.display().to_string()),
        states_log: Some(args.out.join("states.bin")),
        status_every: Duration::from_secs(1),
        stop: super::interrupt::ctrl_c_flag(),
        wait_for_walls: Duration::from_secs(60),
        status_extra: None,
        navigation,
        navigation_log: Some(args.out.join(holocave_master::navigation::log::FILE_NAME)),
        objects: super::master::object_motion(&scene.get()?, args.objects.as_deref())?,
        on_frame: None,
        session_state: None,
        resume: None,
        sun: args.daylight.when.map(SunClock::new),
    })
}

/// When each frame's state was made, by frame number (a run's frames are numbered from 0,
/// one after another): the summary's clock for when a wall presented again.
type SentTimes = Arc<Mutex<Vec<Instant>>>;

/// The master's hook for every frame state: notes when it was made in `sent`, and with the
/// last of `frames` sets `ending` (the supervisor then starts no child again: the nodes
/// are about to be told to shut down).
fn frame_hook(sent: SentTimes, ending: Arc<AtomicBool>, frames: u64) -> FrameHook {
    Box::new(move |state| {
        sent.lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(Instant::now());
        if state.frame + 1 >= frames {
            ending.store(true, Ordering::Relaxed);
        }
    })
}

/// The status line's part after the master's: the holodeck's (when hosted), then the
/// supervisor's (processes up and down, restarts).
fn status_parts(
    hosted: Option<&Hosted>,
    supervisor: &Supervisor,
) -> Box<dyn FnMut() -> String + Send> {
    let mut parts: Vec<Box<dyn FnMut() -> String + Send>> = (hosted.map(Hosted::status))
        .into_iter()
        .chain([supervisor.status()])
        .collect();
    Box::new(move || {
        parts
            .iter_mut()
            .map(|p| p())
            .collect::<Vec<_>>()
            .join(" | ")
    })
}

/// The summary's lines on the nodes and workers that died: how many, then each death
/// (which process, when, how, when it was started again; for a node, when its wall
/// presented again and how many frames it missed). Times are seconds from the processes'
/// start (`origin`); `sent` holds when each frame's state was made.
fn report_deaths(
    args: &SimArgs,
    deaths: &[Death],
    (origin, sent): (Instant, &[Instant]),
    presented: &BTreeMap<String, BTreeSet<u64>>,
) {
    let restarted = deaths.iter().filter(|d| d.restarted.is_some()).count();
    println!(
        "  processes that died: {}, started again: {restarted}{}",
        deaths.len(),
        if args.no_restart {
            " (--no-restart)"
        } else {
            ""
        }
    );
    let all: BTreeSet<u64> = presented.values().flatten().copied().collect();
    for d in deaths {
        let secs = |t: Instant| t.saturating_duration_since(origin).as_secs_f64();
        // The first frame whose state was made after the death.
        let next = sent.partition_point(|&t| t <= d.at) as u64;
        let back = match d.restarted {
            Some(t) => format!("started again at {:.2} s", secs(t)),
            None => "not started again".to_owned(),
        };
        let wall = (presented.iter()).find(|(wall, _)| node_name(wall) == d.name);
        let shown = wall.map_or(String::new(), |(name, shown)| {
            let again = wall_again(shown, &all, next, (sent, d.at));
            format!("; wall {name} {again}")
        });
        println!(
            "    {} died at {:.2} s before frame {next} ({}, after running {:.2} s); {back}{shown}",
            d.name,
            secs(d.at),
            d.how,
            d.ran.as_secs_f64()
        );
    }
}

/// Whether a wall (its presented frames `shown`) presented again after its node died at
/// `died` before frame `next`, from which frame and how long after the death (to when that
/// frame's state was made, by `sent`); and how many of the frames some wall presented
/// (`all`) it missed from its last frame before the death to its first after.
fn wall_again(
    shown: &BTreeSet<u64>,
    all: &BTreeSet<u64>,
    next: u64,
    (sent, died): (&[Instant], Instant),
) -> String {
    let from = shown.range(..next).next_back().map_or(0, |f| f + 1);
    let again = shown.range(next..).next().copied();
    let missed = (all.range(from..again.unwrap_or(u64::MAX)))
        .filter(|f| !shown.contains(f))
        .count();
    let Some(again) = again else {
        return format!("presented no frame after it: {missed} frames missed");
    };
    let after = sent.get(again as usize).map_or(String::new(), |t| {
        let s = t.saturating_duration_since(died).as_secs_f64();
        format!(", {s:.2} s after the death")
    });
    format!("presenting again from frame {again}{after}: {missed} frames missed")
}

/// The light field the walls draw: none with `--no-vlf`, else `--vlf` (a bake set, a
/// folder, as it is) or the one kept beside the output, baked first where it is not there.
fn light_field(args: &SimArgs, scene: &super::render::SharedScene) -> Result<Option<PathBuf>> {
    if args.no_vlf {
        return Ok(None);
    }
    let path =
        (args.vlf.clone()).unwrap_or_else(|| super::kept_beside(&args.out, &args.scene, "vlf"));
    if path.is_dir() {
        return Ok(Some(path));
    }
    Ok(Some(super::vlf::baked_default(&*scene.get()?, &path)?))
}

/// The CAVE's walls unfolded, at `--scale`.
fn unfolded_walls(args: &SimArgs, cave: &Cave) -> Unfolded {
    unfold(
        &cave
            .walls
            .iter()
            .map(|w| (w.name.clone(), w.pixels.scaled(args.scale, 8)))
            .collect::<Vec<_>>(),
    )
}

/// The CAVE with `sim`'s overrides, the flags checked, and the tracker defaulted (the
/// shipped log if it is there, else a synthetic walk).
fn checked_cave(args: &mut SimArgs) -> Result<Cave> {
    let mut cave = load_cave(&args.config)?;
    cave.set_dead_node_ms(args.dead_node_ms)
        .map_err(|e| anyhow::anyhow!("--dead-node-ms {e}"))?;
    cave.set_rate(args.rate)
        .map_err(|e| anyhow::anyhow!("--rate {e}"))?;
    args.windows.check()?;
    if !(args.scale > 0.0 && args.scale <= 1.0) {
        bail!("--scale {}: expected a fraction in (0, 1]", args.scale);
    }
    if args.head.tracker.is_none() {
        if Path::new(DEFAULT_LOG).exists() {
            args.head.tracker = Some(format!("file:{DEFAULT_LOG}"));
            args.head.recenter = true;
        } else {
            args.head.tracker = Some("synthetic:walk".into());
        }
    }
    Ok(cave)
}

/// The CAVE's holodeck, hosted in this process for the workers and nodes (unless
/// `--no-holodeck`).
fn host_holodeck(args: &SimArgs, cave: &Cave, credentials: &Credentials) -> Result<Option<Hosted>> {
    Ok(if args.no_holodeck {
        None
    } else {
        let path = (args.holodeck.clone())
            .unwrap_or_else(|| super::kept_beside(&args.out, &args.scene, "hdk"));
        Some(host(HostSpec {
            path: &path,
            cave,
            scene_path: &args.scene,
            threads: 0,
            listen: "127.0.0.1:0",
            credentials: credentials.clone(),
            daylight: args.daylight.daylight.as_deref(),
            moment: args.daylight.moment()?,
            made_by: "sim",
            sections: &args.section,
            // Not Ctrl-C's flag: the nodes draw from it until the master tells them to
            // shut down, and `sim` stops it after that.
            stop: Arc::default(),
            follows_scene: args.holodeck.is_none(),
        })?)
    })
}

/// `--workers` worker processes tracing for the holodeck `hosted` (none without one),
/// each logging to `workerN.log` (fresh each run; a restart appends).
fn worker_children(
    args: &SimArgs,
    exe: &Path,
    hosted: Option<&Hosted>,
    credentials: &Credentials,
) -> Result<Vec<(String, Relaunch)>> {
    let Some(h) = hosted else {
        return Ok(Vec::new());
    };
    let addr = h.addr.to_string();
    (0..args.workers)
        .map(|i| {
            let log = args.out.join(format!("worker{i}.log"));
            std::fs::File::create(&log).with_context(|| format!("{}", log.display()))?;
            let command =
                worker_command(exe, &addr, &args.scene, &args.daylight.args(), credentials);
            Ok((format!("worker {i}"), Relaunch::new(&command, &log)))
        })
        .collect()
}

/// The supervisor's name for `wall`'s node.
fn node_name(wall: &str) -> String {
    format!("node {wall}")
}

/// What every wall's node process is started with.
struct Nodes<'a> {
    exe: &'a Path,
    /// The master's address.
    master: &'a str,
    /// The walls' eye images, laid out.
    unfolded: &'a Unfolded,
    /// Their windows, placed on the desktop.
    placed: &'a [Place],
    vlf: Option<&'a Path>,
    secret: &'a str,
}

impl Nodes<'_> {
    /// `wall`'s node, its output in `OUT/<wall>/` (a fresh presented log and `node.log`;
    /// a restart appends to both), to be started by the supervisor.
    fn child(&self, args: &SimArgs, wall: &Wall) -> Result<(String, Relaunch)> {
        let eye = (self.unfolded.place(&wall.name))
            .with_context(|| format!("wall {:?} is not in the unfolded CAVE", wall.name))?
            .size;
        let dir = args.out.join(&wall.name);
        std::fs::create_dir_all(&dir)?;
        // A fresh presented.log (and present-times.log) per run.
        let _ = std::fs::remove_file(dir.join(PRESENTED_LOG));
        let _ = std::fs::remove_file(dir.join("present-times.log"));
        let log = dir.join("node.log");
        std::fs::File::create(&log).with_context(|| format!("{}", log.display()))?;
        let mut command = Command::new(self.exe);
        command
            .arg("node")
            .args(["--master", self.master, "--wall", &wall.name])
            .args(args.windows.node_args(self.placed, wall, &args.out))
            .arg("--config")
            .arg(&args.config)
            .arg("--scene")
            .arg(&args.scene)
            .args(args.daylight.args())
            .arg("--out")
            .arg(&args.out)
            .args(["--tone", args.tone.name()])
            .args([
                "--size",
                &eye.to_string(),
                "--every",
                &args.every.to_string(),
            ])
            // The light field the master names, read before joining (a node reading it
            // after the welcome would hold up the first frames).
            .args(
                self.vlf
                    .iter()
                    .flat_map(|p| [std::ffi::OsStr::new("--vlf"), p.as_os_str()]),
            )
            .args(["--rays", &args.rays.to_string()])
            .args(args.sky_per_pixel.then_some("--sky-per-pixel"))
            .env(credentials::SECRET_VAR, self.secret)
            // Four nodes share this machine's cores: one tracing thread each.
            .env("RAYON_NUM_THREADS", "1");
        Ok((node_name(&wall.name), Relaunch::new(&command, &log)))
    }
}

/// Whether every wall presented the same frames; with windows, how far apart the walls
/// presented them; without, the unfolded CAVE's mosaics of the written frames.
fn report_frames(
    args: &SimArgs,
    cave: &Cave,
    unfolded: &Unfolded,
    presented: &BTreeMap<String, BTreeSet<u64>>,
) -> Result<()> {
    let all = report_presented(presented);
    if args.windows.window {
        let logs: Vec<(String, PathBuf)> = cave
            .walls
            .iter()
            .map(|w| {
                let p = args.out.join(&w.name).join("present-times.log");
                (w.name.clone(), p)
            })
            .collect();
        let skew = present_skew(&logs).map_err(|e| anyhow::anyhow!(e))?;
        let q = |p: f64| skew.quantile(p).unwrap_or(f64::NAN);
        println!(
            "present skew between the walls' windows over {} frames: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            skew.spreads.len(),
            q(0.5),
            q(0.99),
            q(1.0)
        );
    } else {
        let every = args.every.max(1);
        let written: Vec<u64> = all.into_iter().filter(|f| f % every == 0).collect();
        let mosaics = write_mosaics(&args.out, cave, unfolded, &written)?;
        for p in &mosaics {
            println!("mosaic {}", p.display());
        }
        println!(
            "{} mosaics in {}; frame states in {}; room → scene transforms in {}",
            mosaics.len(),
            args.out.join("mosaic").display(),
            args.out.join("states.bin").display(),
            args.out.join("navigation.csv").display()
        );
    }
    Ok(())
}

/// Whether every wall presented the same frames (`presented`); the frames some wall
/// presented.
fn report_presented(presented: &BTreeMap<String, BTreeSet<u64>>) -> BTreeSet<u64> {
    let all: BTreeSet<u64> = presented.values().flatten().copied().collect();
    match presented.values().all(|p| p.len() == all.len()) {
        true => println!(
            "presented logs: identical on all {} walls ({} frames)",
            presented.len(),
            all.len()
        ),
        false => {
            for (wall, p) in presented {
                println!(
                    "presented logs: wall {wall} lacks {} of the {} frames some wall showed",
                    all.len() - p.len(),
                    all.len()
                );
            }
        }
    }
    all
}

/// The glare of every frame's view, from the frame states the master wrote.
fn measure_glare(
    args: &SimArgs,
    scene: &std::sync::Arc<holocave_scene::Scene>,
    vlf: &Path,
    size: u32,
) -> Result<()> {
    let meter = holocave_glare::meter::GlareMeter::of_light_field(scene, vlf, size)?;
    let states = args.out.join("states.bin");
    let start = args.daylight.when.map(|w| w.to_string());
    let (views, other_times) = frame_views(&states, start.as_deref())?;
    if other_times > 0 {
        println!(
            "glare: {other_times} frames at another time of day than --when not measured \
             (the meter draws the session's light field at its start)"
        );
    }
    let csv = args.out.join(holocave_glare::log::GLARE_CSV);
    let summary = measure_session(&meter, &views, &csv)?;
    println!(
        "glare of {} eye views in {}: {summary}",
        views.len(),
        csv.display()
    );
    Ok(())
}

/// Every frame state's views (each eye) at the time of day `start`, from the states log,
/// and how many frames were at another time.
fn frame_views(states: &Path, start: Option<&str>) -> Result<(Vec<FrameView>, usize)> {
    let mut r = std::io::BufReader::new(
        std::fs::File::open(states).with_context(|| format!("{}", states.display()))?,
    );
    let (mut views, mut other_times) = (Vec::new(), 0);
    loop {
        match read_frame::<_, MasterMsg>(&mut r, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(f)) if f.when.as_deref() != start => other_times += 1,
            Ok(MasterMsg::Frame(f)) => views.extend(views_of(&f)),
            Ok(_) => {}
            Err(FrameError::Closed) => break,
            Err(e) => return Err(anyhow::anyhow!("{}: {e}", states.display())),
        }
    }
    Ok((views, other_times))
}

/// Each wall's presented frames in this run (its `presented.log`).
fn presented_logs(out: &Path, cave: &Cave) -> Result<BTreeMap<String, BTreeSet<u64>>> {
    cave.walls
        .iter()
        .map(|wall| {
            let frames = read_presented(&out.join(&wall.name))?;
            Ok((wall.name.clone(), frames.into_iter().collect()))
        })
        .collect()
}

/// The mosaic of each of `frames` from the walls' first-eye previews (a wall that did not
/// write the frame is left grey); the paths written.
fn write_mosaics(
    out: &Path,
    cave: &Cave,
    layout: &Unfolded,
    frames: &[u64],
) -> Result<Vec<PathBuf>> {
    let dir = out.join("mosaic");
    std::fs::create_dir_all(&dir)?;
    let mut written = Vec::new();
    for &frame in frames {
        let mut images = Vec::new();
        for wall in &cave.walls {
            let eye = Eye::for_mode(wall.stereo)[0];
            let p = frame_png(&out.join(&wall.name), frame, eye);
            if let Ok(img) = image::open(&p) {
                images.push((wall.name.as_str(), img.to_rgb8()));
            }
        }
        let walls: Vec<(&str, &image::RgbImage)> = images.iter().map(|(n, i)| (*n, i)).collect();
        let path = dir.join(format!("{frame:05}.png"));
        cave_mosaic(layout, &walls)
            .save(&path)
            .with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}
