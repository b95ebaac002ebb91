//! `holocave sim`: a whole CAVE cluster on one machine — the master and the holodeck's
//! server in this process, one render-node process per wall and holodeck worker processes,
//! on loopback with real sockets — headless. Each node writes its frames; at the end the
//! walls of every written frame are laid out as the unfolded CAVE (left | front | right,
//! the floor under the front wall). The nodes and workers run under a [`Supervisor`]: one
//! that dies during the frames is started again (unless `--no-restart`), its wall presents
//! again, and the status line and the summary say who died, when, and when it was back.

use std::ffi::OsString;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::DVec3;
use holocave::sim::frames::{self, ShownIn};
use holocave::sim::{SimCluster, SimSpec};
use holocave_cave::{Cave, load_cave, unfold};
use holocave_glare::session::measure_states_log;
use holocave_holodeck::auth::Credentials;
use holocave_master::cluster::{MasterOptions, run as run_master};
use holocave_master::sun_clock::SunClock;
use holocave_tracer::cave_holodeck::{HostSpec, Hosted};

use super::credentials;
use super::interrupt::{ctrl_c_flag, ending_at_once, exit_interrupted, interrupted};
use super::master::{HeadArgs, host, print_summary};
use super::render::SharedScene;

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
    #[arg(long, conflicts_with_all = ["vlf", "sky_per_pixel"])]
    pub no_vlf: bool,
    /// Also measure the glare of every frame's view (a SIZE×SIZE fisheye drawn from the
    /// light field with the direct light per pixel): `glare.csv` and a summary, computed
    /// after the run from the frame states, so the walls are not slowed.
    #[arg(long, value_name = "SIZE", conflicts_with = "no_vlf")]
    pub glare: Option<u32>,
    /// How every node draws the light field per pixel (`node`'s flags).
    #[command(flatten)]
    pub drawing: super::drawing_flags::DrawingFlags,
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
    let scene = SharedScene::new(&args.scene, args.daylight.clone());
    // A fresh secret for this run; the nodes and workers get it through their environment.
    let credentials = credentials::fresh(&cave.cluster.id)?;
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
    let opts = master_options(&args, &scene, &cave, hosted.as_ref(), vlf.as_deref())?;
    // One layout of the unfolded CAVE for the windows and the mosaics.
    let unfolded = unfold(
        &(cave.walls.iter())
            .map(|w| (w.name.clone(), w.pixels.scaled(args.scale, 8)))
            .collect::<Vec<_>>(),
    );
    let placed = unfolded.fit(args.windows.desktop);
    let walls: Vec<_> = (cave.walls.iter())
        .map(|w| (w, args.windows.node_args(&placed, w, &args.out)))
        .collect();
    let daylight = args.daylight.args();
    let spec = SimSpec {
        exe: &exe,
        master: &addr,
        out: &args.out,
        scene: &args.scene,
        daylight: &daylight,
        credentials: &credentials,
        workers: args.workers,
        unfolded: &unfolded,
        node_flags: node_flags(&args, vlf.as_deref()),
        restart: !args.no_restart,
    };
    let cluster = SimCluster::start(&spec, &walls, hosted, ctrl_c_flag())?;
    let (status_extra, on_frame) = cluster.master_hooks(args.frames);
    let opts = MasterOptions {
        status_extra: Some(status_extra),
        on_frame: Some(on_frame),
        ..opts
    };
    let head = args.head.open(&cave)?;
    let kept = kept_on_ctrl_c(&args, vlf.as_deref());
    let again = format!("{kept}; run again to go on");
    let (summary, ended) = cluster.run_master(&|| exit_interrupted(&again), || {
        run_master(&cave, head, listener, credentials.secret.clone(), opts)
    })?;
    let was_interrupted = interrupted();
    let summary = summary?;
    let limit = Duration::from_secs(if was_interrupted { 1 } else { 20 });
    let report = ended.report(limit, &args.out, &cave.walls, !args.no_restart);
    print_summary(&summary);
    let (lines, all) = report?;
    lines.iter().for_each(|l| println!("{l}"));
    if was_interrupted {
        exit_interrupted(&format!(
            "{kept} (no mosaics or glare made); run again to go on"
        ));
    }
    // The mosaics and the glare read what is written and write their own: Ctrl-C ends
    // them at once.
    ending_at_once(again, || {
        let shown = match args.windows.window {
            true => ShownIn::Windows,
            false => ShownIn::Images {
                every: args.every,
                unfolded: &unfolded,
            },
        };
        frames::shown(&args.out, &cave.walls, shown, &all)?
            .iter()
            .for_each(|l| println!("{l}"));
        // A session's glare, windows or not: every frame's view from the frame states.
        if let (Some(size), Some(vlf)) = (args.glare, &vlf) {
            measure_glare(&args, &scene, vlf, size)?;
        }
        Ok(())
    })
}

/// What a run that Ctrl-C ends keeps: the holodeck's samples (committed), the light field,
/// the walls' frames and the frame states written so far.
fn kept_on_ctrl_c(args: &SimArgs, vlf: Option<&Path>) -> String {
    let hdk = (!args.no_holodeck).then(|| {
        let hdk = (args.holodeck.clone())
            .unwrap_or_else(|| super::kept_beside(&args.out, &args.scene, "hdk"));
        format!(
            "the holodeck {} keeps its samples (committed)",
            hdk.display()
        )
    });
    let vlf = vlf.map(|v| format!("the light field {} is whole", v.display()));
    let frames = format!(
        "the walls' frames and the frame states so far are in {}",
        args.out.display()
    );
    (hdk.into_iter().chain(vlf).chain([frames]))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The master's options for the run (less the status line's extra part and the frame
/// hook, which the cluster makes): the head's clock, the frames asked, the holodeck and
/// light field told to the nodes, the logs, navigation and moving objects.
fn master_options(
    args: &SimArgs,
    scene: &SharedScene,
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
        stop: ctrl_c_flag(),
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

/// The flags every wall's node takes besides its wall's own, its size, scene, daylight
/// and output: the CAVE, the tone mapping, how often to write, the light field the master
/// names (read before joining: a node reading it after the welcome would hold up the
/// first frames) and how to draw it.
fn node_flags(args: &SimArgs, vlf: Option<&Path>) -> Vec<OsString> {
    let mut flags: Vec<OsString> = vec!["--config".into(), args.config.clone().into()];
    flags.extend(["--tone", args.tone.name(), "--every"].map(OsString::from));
    flags.push(args.every.to_string().into());
    if let Some(v) = vlf {
        flags.extend(["--vlf".into(), v.into()]);
    }
    flags.extend(args.drawing.node_args());
    flags
}

/// The glare of every frame's view at `--when`, from the frame states the master wrote.
fn measure_glare(args: &SimArgs, scene: &SharedScene, vlf: &Path, size: u32) -> Result<()> {
    let meter = holocave_glare::meter::GlareMeter::of_light_field(&scene.get()?, vlf, size)?;
    let start = args.daylight.when.map(|w| w.to_string());
    let csv = args.out.join(holocave_glare::log::GLARE_CSV);
    let states = args.out.join("states.bin");
    let (summary, views, other_times) =
        measure_states_log(&meter, &states, start.as_deref(), &csv)?;
    if other_times > 0 {
        println!(
            "glare: {other_times} frames at another time of day than --when not measured \
             (the meter draws the session's light field at its start)"
        );
    }
    println!("glare of {views} eye views in {}: {summary}", csv.display());
    Ok(())
}

/// The light field the walls draw: none with `--no-vlf`, else `--vlf` (a bake set, a
/// folder, as it is) or the one kept beside the output, baked first where it is not there.
fn light_field(args: &SimArgs, scene: &SharedScene) -> Result<Option<PathBuf>> {
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
            stop: std::sync::Arc::default(),
            follows_scene: args.holodeck.is_none(),
        })?)
    })
}
