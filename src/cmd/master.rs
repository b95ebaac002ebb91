//! `holocave master`: the cluster's master. It reads the head tracker, runs the frame clock
//! and the swap barrier for the render nodes, and prints a status line every second.

use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;

use super::render::SharedScene;
use glam::DVec3;
use holocave_cave::{Cave, load_cave};
use holocave_glare::live::LiveGlare;
use holocave_glare::session::views_of;
use holocave_holodeck::auth::Credentials;
use holocave_master::cluster::{FrameHook, MasterOptions, Summary, pacer_since, run as run_master};
use holocave_master::head::{Clock, Head};
use holocave_master::navigation::log::FILE_NAME as NAVIGATION_CSV;
use holocave_master::navigation::run::{Devices, NavigationRun};
use holocave_master::objects::ObjectMotion;
use holocave_master::session::{FILE_NAME as SESSION_STATE, SessionClock, SessionState};
use holocave_master::sun_clock::SunClock;
use holocave_protocol::cluster::FrameState;
use holocave_protocol::stats::quantile_duration;
use holocave_tracking::source::SourceSpec;

use holocave_tracer::cave_holodeck::{HostSpec, Hosted};

#[derive(Args)]
pub struct MasterArgs {
    /// The CAVE config (TOML); its [cluster] section says where to listen.
    #[arg(long)]
    pub config: PathBuf,
    /// Listen here instead of the config's cluster.master.
    #[arg(long)]
    pub listen: Option<String>,
    #[command(flatten)]
    pub head: HeadArgs,
    /// Stop after this many frames.
    #[arg(long)]
    pub frames: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Write every frame state, as sent, to this file (a resumed session appends to it).
    #[arg(long)]
    pub states: Option<PathBuf>,
    /// Output folder: DIR/navigation.csv, the room → scene transform of every frame, and
    /// DIR/session.json, the session's state, from which `--resume DIR` goes on.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Go on with the session whose output folder is DIR (its master died): frames are
    /// numbered on from the last one DIR/session.json holds, the clock, a replay's
    /// position, the navigation and the moving objects go on from there. The other flags
    /// are the session's own; DIR stays the output folder.
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// The session's output folder, for a master that a supervisor starts again with the
    /// same command: `--resume DIR` when DIR holds a session's state (a master died
    /// there, or was stopped), else `--out DIR`. Give each new session a new folder.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["out", "resume"])]
    pub session: Option<PathBuf>,
    /// A baked light field (`holocave vlf bake`) the walls draw under their samples: its
    /// path is told to every node, which reads it there.
    #[arg(long)]
    pub vlf: Option<PathBuf>,
    /// Measure the glare of the head's view while the session runs (SIZE² fisheyes drawn
    /// from --vlf, each eye, on a thread of its own: the newest frame whenever it is free):
    /// DIR/glare.csv, the latest DGP in the status line and the time above DGP
    /// 0.35/0.40/0.45 at the end. Needs --scene, --vlf and --out.
    #[arg(long, value_name = "SIZE", requires_all = ["scene", "vlf", "out"])]
    pub glare: Option<u32>,
    /// Move the scene's moving objects along these paths (CSV
    /// `object,time_s,tx,ty,tz,qx,qy,qz,qw`, time from the first frame); every frame state
    /// carries their placements. Needs --scene.
    #[arg(long, value_name = "FILE", requires = "scene")]
    pub objects: Option<PathBuf>,
    /// Frame rate (default: the config's cluster.rate_hz).
    #[arg(long)]
    pub rate: Option<f64>,
    /// The dead-node timeout in milliseconds (default: the config's cluster.dead_node_ms).
    #[arg(long)]
    pub dead_node_ms: Option<f64>,
    /// Before the first frame, wait up to this many seconds for a node of every wall.
    #[arg(long, default_value_t = 0.0)]
    pub wait_for_walls: f64,
    #[command(flatten)]
    pub holodeck: HolodeckArgs,
}

/// The cluster's holodeck: hosted by the master (the default way) or on its own host.
#[derive(Args, Clone)]
pub struct HolodeckArgs {
    /// Host this holodeck file (created for the CAVE if missing) in the master; the
    /// render nodes draw from it and `holocave worker` processes fill it. Needs --scene.
    #[arg(long, conflicts_with = "holodeck_server")]
    pub holodeck: Option<PathBuf>,
    /// The scene the hosted holodeck is traced from (the nodes' scene), and that walking,
    /// flying and teleporting collide with (without it, navigation has no walls or floor).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Accept the holodeck's workers and render nodes here (default: the config's
    /// cluster.holodeck).
    #[arg(long, requires = "holodeck")]
    pub holodeck_listen: Option<String>,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// Tracer threads in the master for the hosted holodeck (workers on other hosts add
    /// more).
    #[arg(long, default_value_t = 0, requires = "holodeck")]
    pub tracer_threads: usize,
    /// An interior section a new holodeck file gets besides the CAVE's,
    /// `x0,y0,z0,x1,y1,z1` in scene coordinates (repeatable; `holocave holodeck sections`
    /// proposes them, one per room).
    #[arg(long, requires = "holodeck", value_parser = super::parse::aabb)]
    pub section: Vec<[DVec3; 2]>,
    /// The nodes draw from a holodeck served elsewhere (`holocave holodeck serve
    /// --interactive`) at HOST:PORT.
    #[arg(long)]
    pub holodeck_server: Option<String>,
}

impl HolodeckArgs {
    /// Starts the hosted holodeck, if any, and says where the nodes find theirs.
    pub fn start(
        &self,
        cave: &Cave,
        credentials: Credentials,
        made_by: &str,
    ) -> Result<(Option<Hosted>, Option<String>)> {
        let Some(path) = &self.holodeck else {
            return Ok((None, self.holodeck_server.clone()));
        };
        let scene = self
            .scene
            .as_ref()
            .context("--holodeck needs --scene: the scene its rays are traced in")?;
        let listen = self
            .holodeck_listen
            .as_ref()
            .unwrap_or(&cave.cluster.holodeck);
        let hosted = host(HostSpec {
            path,
            cave,
            scene_path: scene,
            threads: self.tracer_threads,
            listen,
            credentials,
            daylight: self.daylight.daylight.as_deref(),
            moment: self.daylight.moment()?,
            made_by,
            sections: &self.section,
            stop: super::interrupt::ctrl_c_flag(),
            follows_scene: false,
        })?;
        let addr = hosted.addr.to_string();
        Ok((Some(hosted), Some(addr)))
    }
}

/// Hosts a cluster's holodeck and says what it holds and where it listens.
pub fn host(spec: HostSpec) -> Result<Hosted> {
    let (hosted, described) = spec.host()?;
    println!("{described}");
    println!(
        "holodeck workers and displays may connect to {}",
        hosted.addr
    );
    Ok(hosted)
}

/// Where head poses come from, shared by `master` and `sim`.
#[derive(Args, Clone)]
pub struct HeadArgs {
    /// Tracker source (file:PATH, synthetic:NAME, vrpn://...); default: the config's.
    #[arg(long)]
    pub tracker: Option<String>,
    /// Move the tracker's first position to the room's inside point (for logs recorded in
    /// another room, such as ../shared/tracking/pred6dof).
    #[arg(long)]
    pub recenter: bool,
    /// Deterministic replay: the master's clock is virtual (frame × period) and a log's
    /// samples arrive at their own times, so the same log gives the same frame states, bit
    /// for bit.
    #[arg(long)]
    pub replay: bool,
    /// The wand: a tracker sensor (vrpn://Wand0@HOST#1) or a session log (file:PATH);
    /// default: the config's navigation.wand, or the --tracker session log's wand rows.
    #[arg(long)]
    pub wand: Option<String>,
    /// The wand's buttons: vrpn://Buttons0@HOST or file:PATH (a session log); default: the
    /// config's navigation.buttons.
    #[arg(long)]
    pub buttons: Option<String>,
    /// The joystick's axes: vrpn://Joystick0@HOST or file:PATH (a session log); default:
    /// the config's navigation.axes.
    #[arg(long)]
    pub axes: Option<String>,
    /// Navigate from the keyboard and mouse of the nodes' windows (`node --window`,
    /// `sim --window`): W/S forward and back, A/D turn, drag to steer, Space teleport, F
    /// walk/fly (docs/usage/navigation.md); written to DIR/desk.csv with --out.
    #[arg(long)]
    pub desk: bool,
}

impl HeadArgs {
    /// The master's clock: virtual with `--replay`, real otherwise.
    pub fn clock(&self) -> Clock {
        if self.replay {
            Clock::Replay
        } else {
            Clock::Live
        }
    }

    /// The input devices bound: these flags, else the config's, else the devices of a
    /// `--tracker` session log.
    pub fn devices(&self, cave: &Cave) -> Result<Devices> {
        let given = Devices {
            wand: self.wand.clone(),
            buttons: self.buttons.clone(),
            axes: self.axes.clone(),
            desk: self.desk,
        };
        Ok(given.resolve(cave, self.tracker.as_deref())?)
    }

    /// Navigation from the devices bound (`None` without any); `scene` is what it
    /// collides with (loaded only when a device is bound).
    pub fn navigation(
        &self,
        cave: &Cave,
        scene: Option<&SharedScene>,
    ) -> Result<Option<NavigationRun>> {
        let devices = self.devices(cave)?;
        if devices.is_empty() {
            return Ok(None);
        }
        let scene = scene.map(SharedScene::get).transpose()?;
        println!(
            "navigation: {:?} mode; wand {}, buttons {}, axes {}{}{}",
            cave.navigation.mode,
            devices.wand.as_deref().unwrap_or("none"),
            devices.buttons.as_deref().unwrap_or("none"),
            devices.axes.as_deref().unwrap_or("none"),
            if devices.desk {
                "; the windows' keyboard and mouse"
            } else {
                ""
            },
            if scene.is_some() {
                ""
            } else {
                " (no scene: no walls, no floor)"
            }
        );
        Ok(NavigationRun::open(cave, &devices, self.clock(), scene)?)
    }

    pub fn open(&self, cave: &Cave) -> Result<Head> {
        open_head(
            cave,
            self.tracker.as_deref(),
            self.clock(),
            true,
            self.recenter,
        )
    }
}

/// Opens the head source `tracker` (a source spec; the config's source when `None`) with
/// the config's predictor when `predict`, or none.
pub fn open_head(
    cave: &Cave,
    tracker: Option<&str>,
    clock: Clock,
    predict: bool,
    recenter: bool,
) -> Result<Head> {
    let spec: Option<SourceSpec> = match tracker {
        Some(t) => Some(t.parse().map_err(|e| anyhow!("--tracker {t:?}: {e}"))?),
        None => None,
    };
    Head::open(cave, spec.as_ref(), clock, predict, recenter).with_context(|| {
        format!(
            "opening tracker {:?}",
            spec.as_ref().unwrap_or(&cave.source)
        )
    })
}

/// The end-of-run summary.
pub fn print_summary(s: &Summary) {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let quantile = |v: &[Duration], q: f64| quantile_duration(v, q).unwrap_or_default();
    println!(
        "{} frames in {:.2} s ({:.1} Hz); {} with every wall",
        s.frames,
        s.elapsed.as_secs_f64(),
        s.frames as f64 / s.elapsed.as_secs_f64().max(1e-9),
        s.full_frames
    );
    for (wall, (swapped, outs)) in &s.walls {
        let (paced, by) = s.pace.get(wall).copied().unwrap_or_default();
        println!(
            "  wall {wall:6}: {swapped} frames swapped, declared out {outs} times; last ready on {paced} frames ({:.1} ms after the next on average)",
            ms(by) / paced.max(1) as f64
        );
    }
    if let Some((wall, frames, by)) = pacer_since(&s.pace, &Default::default()) {
        println!(
            "  pace set by wall {wall} (last ready on {frames} of {} frames, {:.1} ms after the next); paced to {:.1} Hz at the end",
            s.frames,
            ms(by),
            1.0 / s.paced_period.as_secs_f64().max(1e-9)
        );
    }
    println!(
        "  barrier (state sent → swap sent): p50 {:.3} ms, p99 {:.3} ms",
        ms(quantile(&s.barrier, 0.5)),
        ms(quantile(&s.barrier, 0.99))
    );
    if !s.motion_to_photon.is_empty() {
        println!(
            "  motion to photon (tracker sample's arrival → swap sent): p50 {:.2} ms, p99 {:.2} ms",
            ms(quantile(&s.motion_to_photon, 0.5)),
            ms(quantile(&s.motion_to_photon, 0.99))
        );
    }
    let shares = s.pixels.shares();
    if !shares.is_empty() {
        println!("  the light field's per-pixel pass, over every wall's frames: {shares}");
    }
    println!(
        "  connections refused: {}, dropped for bad messages: {}",
        s.refused, s.dropped
    );
}

pub fn run(mut args: MasterArgs) -> Result<()> {
    let resume = resume_of(&mut args)?;
    let cave = cave_of(&args)?;
    if let Some(state) = &resume {
        same_replay_rate(&cave, state)?;
    }
    let credentials = super::credentials::of_cave(&cave, &args.config)?;
    let addr = args.listen.clone().unwrap_or(cave.cluster.master.clone());
    let listener = TcpListener::bind(&addr).with_context(|| format!("listening on {addr}"))?;
    println!("master listening on {}", listener.local_addr()?);
    // Tests and scripts read the address from the first line.
    if let (Some(state), Some(dir)) = (&resume, &args.out) {
        println!(
            "resuming the session in {} after frame {}",
            dir.display(),
            state.frame
        );
    }
    std::io::Write::flush(&mut std::io::stdout())?;
    let head = args.head.open(&cave)?;
    let scene = args
        .holodeck
        .scene
        .as_deref()
        .map(|p| SharedScene::new(p, args.holodeck.daylight.clone()));
    let mut navigation = args.head.navigation(&cave, scene.as_ref())?;
    let objects = match &scene {
        Some(scene) => object_motion(&scene.get()?, args.objects.as_deref())?,
        None => None,
    };
    let navigation_log = match &args.out {
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            Some(dir.join(NAVIGATION_CSV))
        }
        None => None,
    };
    if let (Some(nav), Some(dir)) = (&mut navigation, &args.out) {
        log_desk(nav, dir)?;
    }
    let (hosted, holodeck) = args.holodeck.start(&cave, credentials.clone(), "master")?;
    let live_glare = match (args.glare, &scene, &args.vlf, &args.out) {
        (Some(size), Some(scene), Some(vlf), Some(dir)) => Some(Arc::new(
            super::glare::start_live(&scene.get()?, vlf, size, dir)?,
        )),
        _ => None,
    };
    let status_extra = status_with_glare(hosted.as_ref().map(Hosted::status), live_glare.clone());
    let on_frame = live_glare
        .clone()
        .map(|g| Box::new(move |state: &FrameState| g.offer(views_of(state))) as FrameHook);
    let summary = run_master(
        &cave,
        head,
        listener,
        credentials.secret,
        MasterOptions {
            clock: args.head.clock(),
            frames: args.frames,
            seconds: args.seconds,
            stop_at_end_of_log: false,
            holodeck,
            vlf: args.vlf.as_ref().map(|p| p.display().to_string()),
            states_log: args.states.clone(),
            status_every: Duration::from_secs(1),
            stop: super::interrupt::ctrl_c_flag(),
            wait_for_walls: Duration::from_secs_f64(args.wait_for_walls),
            status_extra,
            navigation,
            navigation_log: navigation_log.clone(),
            objects,
            on_frame,
            session_state: args.out.as_ref().map(|d| d.join(SESSION_STATE)),
            resume,
            sun: args.holodeck.daylight.when.map(SunClock::new),
        },
    );
    // Asked now: stopping the hosted holodeck sets the same flag.
    let interrupted = super::interrupt::interrupted();
    if let (Some(g), Some(dir)) = (live_glare.and_then(Arc::into_inner), &args.out) {
        super::glare::finish_live(g, dir)?;
    }
    if let Some(p) = navigation_log {
        println!("room → scene transform of every frame in {}", p.display());
    }
    // The holodeck commits what was traced even when the master failed.
    if let Some(h) = hosted {
        holocave::sim::stop_hosted(h)?;
    }
    print_summary(&summary?);
    if interrupted {
        let state = (args.out.as_ref()).map(|d| d.join(SESSION_STATE));
        let kept = match state.filter(|s| s.exists()) {
            Some(s) => format!("the session's state in {} (--resume it)", s.display()),
            None => "what the holodeck committed".to_owned(),
        };
        super::interrupt::exit_interrupted(&kept);
    }
    Ok(())
}

/// With `--resume DIR` (or `--session DIR` holding a state): the state DIR/session.json holds, checked against the flags (the
/// same clock, the same time of day, taken from the state when
/// no `--when` is given), and DIR as the output folder.
fn resume_of(args: &mut MasterArgs) -> Result<Option<SessionState>> {
    if let Some(dir) = args.session.take() {
        match dir.join(SESSION_STATE).exists() {
            true => args.resume = Some(dir),
            false => args.out = Some(dir),
        }
    }
    let Some(dir) = args.resume.clone() else {
        return Ok(None);
    };
    if args.out.as_ref().is_some_and(|o| o != &dir) {
        bail!(
            "--resume {} --out {}: a resumed session writes to its own folder; give one of them",
            dir.display(),
            args.out
                .as_ref()
                .map_or(String::new(), |o| o.display().to_string())
        );
    }
    let path = dir.join(SESSION_STATE);
    let state = SessionState::read(&path).context("--resume: the session cannot be resumed")?;
    let clock = match args.head.clock() {
        holocave_master::head::Clock::Live => SessionClock::Live,
        holocave_master::head::Clock::Replay => SessionClock::Replay,
    };
    if clock != state.clock {
        bail!(
            "{}: the session ran on a {} clock, this master on a {clock} one (--replay)",
            path.display(),
            state.clock
        );
    }
    same_time_of_day(&mut args.holodeck.daylight, &state, &path)?;
    args.out = Some(dir);
    Ok(Some(state))
}

/// The resumed session's time of day: the state's (kept in `path`) when `--when` is not
/// given; a `--when` that differs from it, or one for a session without one, is refused.
fn same_time_of_day(
    daylight: &mut super::daylight_flags::DaylightFlags,
    state: &SessionState,
    path: &std::path::Path,
) -> Result<()> {
    match (&daylight.when, &state.when) {
        (None, Some(w)) => {
            daylight.when = Some(
                w.parse()
                    .map_err(|e| anyhow!("{}: time of day {w:?}: {e}", path.display()))?,
            );
        }
        (Some(given), Some(w)) if given.to_string() != *w => {
            bail!(
                "{}: the session's time of day is {w}, not --when {given}",
                path.display()
            );
        }
        (Some(given), None) => {
            bail!(
                "{}: the session had no time of day; --when {given} would change its light",
                path.display()
            );
        }
        _ => {}
    }
    Ok(())
}

/// A replayed session resumes only at its own rate: its frames' times are frame × period.
fn same_replay_rate(cave: &Cave, state: &SessionState) -> Result<()> {
    let period_ns = cave.frame_period().as_nanos() as u64;
    if state.clock == SessionClock::Replay && period_ns.abs_diff(state.period_ns) > 1 {
        bail!(
            "the session was replayed at {:.3} Hz, this master runs at {:.3} Hz (--rate): its \
             frames' times would not go on",
            1e9 / state.period_ns as f64,
            1e9 / period_ns as f64
        );
    }
    Ok(())
}

/// The CAVE of `args.config`, with the rate, the dead-node time and the wait for walls the
/// flags set.
fn cave_of(args: &MasterArgs) -> Result<holocave_cave::Cave> {
    let mut cave = load_cave(&args.config)?;
    if let Some(r) = args.rate {
        cave.set_rate(r)
            .map_err(|e| anyhow::anyhow!("--rate {e}"))?;
    }
    if let Some(ms) = args.dead_node_ms {
        cave.set_dead_node_ms(ms)
            .map_err(|e| anyhow::anyhow!("--dead-node-ms {e}"))?;
    }
    if !(args.wait_for_walls >= 0.0 && args.wait_for_walls < 1e6) {
        anyhow::bail!(
            "--wait-for-walls {}: not a number of seconds",
            args.wait_for_walls
        );
    }
    Ok(cave)
}

/// The status line's extra part: the hosted holodeck's, and the latest glare measured live.
fn status_with_glare(
    mut hosted_status: Option<Box<dyn FnMut() -> String + Send>>,
    live_glare: Option<Arc<LiveGlare>>,
) -> Option<Box<dyn FnMut() -> String + Send>> {
    match live_glare {
        None => hosted_status,
        Some(g) => Some(Box::new(move || {
            let glare = g
                .latest()
                .map_or("glare: none measured yet".to_owned(), |(f, d)| {
                    format!("glare: DGP {d:.3} at frame {f}")
                });
            match hosted_status.as_mut() {
                Some(s) => format!("{} | {glare}", s()),
                None => glare,
            }
        })),
    }
}

/// With `--desk`, the desk's input goes to DIR/desk.csv (a session log's button and axes
/// rows: `--buttons file:DIR/desk.csv --axes file:DIR/desk.csv --replay` replays the walk).
/// The scene's moving objects as the master moves them: along the paths in `paths` (if
/// given) and carried by the wand; `None` for a scene without any.
pub fn object_motion(
    scene: &std::sync::Arc<holocave_scene::Scene>,
    paths: Option<&std::path::Path>,
) -> Result<Option<ObjectMotion>> {
    let paths = match paths {
        Some(p) => super::render::read_object_paths(p, scene)?,
        None if scene.objects().is_empty() => return Ok(None),
        None => holocave_scene::ObjectPaths::default(),
    };
    Ok(Some(ObjectMotion::new(scene.clone(), paths)?))
}

pub fn log_desk(nav: &mut NavigationRun, dir: &std::path::Path) -> Result<()> {
    if nav.desk.is_some() {
        let p = dir.join("desk.csv");
        nav.log_desk(&p)
            .with_context(|| format!("creating {}", p.display()))?;
        println!(
            "the desk's keys and mouse of every frame in {}",
            p.display()
        );
    }
    Ok(())
}
