//! `holocave node`: one render node. `--standalone --headless` runs one wall by itself
//! (`render_node::node::standalone`): its own tracker source, path tracer and GPU render cache,
//! writing each frame's images. With `--holodeck H.hdk` the samples come from a holodeck
//! server in this process (with `--threads` tracer threads), which keeps every ray it
//! traces in the file. `--master HOST:PORT` joins a cluster (`render_node::node::cluster`)
//! and writes the frames the master swaps.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;
use glam::{Quat, Vec3};
use holocave_cave::{Cave, Eye, Size, Wall, load_cave};
use holocave_glare::session::views_at;
use holocave_holodeck::auth::Port;
use holocave_holodeck::run::Running;
use holocave_master::head::Clock;
use holocave_render_node::feed::holodeck::HolodeckCounts;
use holocave_render_node::node::cluster::{
    self, ClusterOutput, DisplayMaker, Membership, VlfOptions,
};
use holocave_render_node::node::standalone::{
    OwnHolodeck, Schedule, StandaloneRun, StandaloneSpec, StandaloneWall,
};
use holocave_render_node::present::output::{FrameImages, PresentedLog, eye_name};
use holocave_render_node::present::wall_windows::WindowOutput;
use holocave_render_node::present::window::Screens;
use holocave_render_node::{EyeView, ToneMapper};
use holocave_scene::Scene;
use holocave_tracer::{TraceSettings, Tracer};
use holocave_tracking::Pose;

use super::master::open_head;
use super::tone::Tone;

/// A node's windows and the tone mapping they show (a histogram adjustment: the tone
/// curve is applied on the GPU; Reinhard's operator exists only for the PNG previews).
struct Windows<'a> {
    screens: &'a mut Screens,
    tone: ToneMapper,
}

#[derive(Args)]
pub struct NodeArgs {
    /// Run one wall by itself, with its own tracker, tracer and (optionally) holodeck.
    #[arg(long, conflicts_with = "master")]
    pub(crate) standalone: bool,
    /// Join a cluster: draw the frames the master at HOST:PORT sends, in its lockstep.
    #[arg(long)]
    pub(crate) master: Option<String>,
    /// The CAVE config (TOML).
    #[arg(long)]
    pub(crate) config: PathBuf,
    /// The wall to draw (its name in the config).
    #[arg(long)]
    pub(crate) wall: String,
    /// The scene (glTF).
    #[arg(long)]
    pub(crate) scene: PathBuf,
    #[command(flatten)]
    pub(crate) daylight: super::daylight_flags::DaylightFlags,
    /// Standalone: move the scene's moving objects along these paths (CSV
    /// `object,time_s,tx,ty,tz,qx,qy,qz,qw`, on the frames' clock). In a cluster the
    /// master's frame states place them.
    #[arg(long, value_name = "FILE", requires = "standalone")]
    pub(crate) objects: Option<PathBuf>,
    /// Draw from this holodeck file (created if missing: one interior section, the CAVE's
    /// inside volume in scene coordinates), served in this process by `--threads` tracer
    /// threads that add every ray they trace to it. Without it the node traces its own
    /// samples and keeps none.
    #[arg(long)]
    pub(crate) holodeck: Option<PathBuf>,
    /// Tracer threads of the in-process holodeck server (default: the cores).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// Draw this baked light field (`holocave vlf bake`) under the samples: every pixel
    /// shows it until exact samples refine it. In a cluster the master's file is used
    /// unless this is given.
    #[arg(long)]
    pub(crate) vlf: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) drawing: super::drawing_flags::DrawingFlags,
    /// With --vlf and no holodeck, the node's own samples are gathers over the light field
    /// (the direct light exact at the point seen and after one bounce, the field beyond)
    /// instead of full paths: far less noise, the field's error only after a bounce.
    #[arg(long)]
    pub(crate) gather: bool,
    /// Standalone: measure the glare of the head's view while the wall runs (SIZE²
    /// fisheyes drawn from the light field, on a thread of its own that takes the newest
    /// frame whenever it is free): OUT/WALL/glare.csv and the time above DGP
    /// 0.35/0.40/0.45 at the end. In a cluster the master measures it (`master --glare`).
    #[arg(long, value_name = "SIZE", requires_all = ["standalone", "vlf"])]
    pub(crate) glare: Option<u32>,
    /// Also accept holodeck workers and displays on this address (with --holodeck).
    #[arg(long)]
    pub(crate) listen: Option<String>,
    /// Tracker source (file:PATH, synthetic:NAME, vrpn://...); default: the config's.
    #[arg(long)]
    pub(crate) tracker: Option<String>,
    /// Place the tracker's first position at the room's inside point (for logs recorded
    /// in another room, such as ../shared/tracking/pred6dof).
    #[arg(long)]
    pub(crate) recenter: bool,
    /// Predict head poses with the config's predictor (default: the last pose; a headless
    /// node has no display latency to hide).
    #[arg(long)]
    pub(crate) prediction: bool,
    /// Hold the head still at X,Y,Z (room coordinates), looking at -Z.
    #[arg(long, value_parser = super::parse::vec3)]
    pub(crate) still: Option<Vec3>,
    /// Write images (the default; `--window` shows the wall instead).
    #[arg(long)]
    pub(crate) headless: bool,
    #[command(flatten)]
    pub(crate) window: super::window::WindowArgs,
    /// Output folder: images go to DIR/<wall>/<frame>-<eye>.exr and .png.
    #[arg(long, default_value = "out/node")]
    pub(crate) out: PathBuf,
    /// Stop after this many frames.
    #[arg(long)]
    pub(crate) frames: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub(crate) seconds: Option<f64>,
    /// Image size per eye, WxH (default: the wall's pixels).
    #[arg(long)]
    pub(crate) size: Option<Size>,
    /// Samples traced per eye and frame (default: a sixteenth of the pixels).
    #[arg(long)]
    pub(crate) samples: Option<u32>,
    /// Display rate (Hz) that sets the tracker time of each frame.
    #[arg(long, default_value_t = 60.0)]
    pub(crate) fps: f64,
    /// Also write each frame's priority image and chosen pixels (-priority, -chosen).
    #[arg(long)]
    pub(crate) debug_images: bool,
    /// Tone mapping of the PNG previews: Ward Larson's histogram adjustment in `camera` or
    /// `human` mode, or `reinhard` (the tracer's preview). EXR files are always linear.
    #[arg(long, value_enum, default_value_t = Tone::Camera)]
    pub(crate) tone: Tone,
    /// Trace between frames on the display's thread (deterministic output) instead of on a
    /// tracer thread that frames never wait for.
    #[arg(long)]
    pub(crate) sync: bool,
    /// Write images every K frames (and always the last).
    #[arg(long, default_value_t = 1)]
    pub(crate) every: u64,
    /// With --master: sleep this many milliseconds per frame after drawing, a wall made
    /// slow on purpose (to see the cluster's frame lock wait for it).
    #[arg(long, default_value_t = 0)]
    pub(crate) slow_ms: u64,
}

pub fn run(args: NodeArgs) -> Result<()> {
    if args.master.is_none() && !args.standalone {
        bail!("say how the node runs: --standalone, or --master HOST:PORT to join a cluster");
    }
    let cave = load_cave(&args.config)?;
    // The wall's display id at the holodeck is its place in the config (every node reads
    // the same config).
    let index = cave
        .wall_index(&args.wall)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.config.display()))?;
    let (display_id, wall) = (index as u32, cave.walls[index].clone());
    // `--layout` and `--window-*` for this run; a standalone wall keeps its own eyes when
    // they include the layout's.
    let wall = args.window.wall_for_run(&wall, args.master.is_none())?;
    let size = args.size.unwrap_or(wall.pixels);
    if args.window.window {
        // Windows take only the histogram tone curves: checked before any window opens.
        // The scene's efficacy is set once it is loaded.
        let tone = args.tone.mapper(179.0).context(
            "--tone reinhard is for PNG previews; windows tone-map with camera, human or falsecolor",
        )?;
        let specs = args.window.specs(&wall, size);
        return holocave_render_node::present::window::run(&specs, |mut screens| {
            match &args.master {
                Some(master) => in_cluster(
                    &args,
                    master,
                    cave,
                    wall,
                    display_id,
                    size,
                    Some(Windows {
                        screens: &mut screens,
                        tone,
                    }),
                ),
                None => standalone(
                    &args,
                    &cave,
                    &wall,
                    size,
                    Some(Windows {
                        screens: &mut screens,
                        tone,
                    }),
                ),
            }
        })?;
    }
    match &args.master {
        Some(master) => in_cluster(&args, master, cave, wall, display_id, size, None),
        None => standalone(&args, &cave, &wall, size, None),
    }
}

/// How the node's flags draw the light field.
fn vlf_options(args: &NodeArgs) -> VlfOptions {
    VlfOptions {
        own: args.vlf.clone(),
        prior: args.drawing.vlf_prior,
        gather: args.gather,
        drawing: args.drawing.drawing(),
    }
}

fn load_tracer(
    path: &Path,
    daylight: super::daylight_flags::DaylightFlags,
) -> Result<(Arc<Scene>, Arc<Tracer>)> {
    let scene = Arc::new(super::render::load_scene(path, daylight, false)?);
    let tracer = Arc::new(Tracer::new(scene.clone(), TraceSettings::default()));
    Ok((scene, tracer))
}

fn standalone(
    args: &NodeArgs,
    cave: &Cave,
    wall: &Wall,
    size: Size,
    windows: Option<Windows>,
) -> Result<()> {
    check_standalone_flags(args)?;
    let eyes = Eye::for_mode(wall.stereo);
    let (scene, tracer) = load_tracer(&args.scene, args.daylight.clone())?;
    let objects = standalone_objects(args, &scene)?;
    let mut pose_at = replayed_head(args, cave)?;
    let built = StandaloneWall::build(StandaloneSpec {
        cave,
        wall,
        size,
        samples: args.samples,
        scene: scene.clone(),
        tracer,
        gpu: windows.as_ref().map(|w| w.screens.gpu.clone()),
        vlf: vlf_options(args),
        holodeck: own_holodeck(args, cave)?,
        sync: args.sync,
    })?;
    (built.holodeck_described.iter()).for_each(|d| println!("{d}"));
    if let Some(a) = built.holodeck.as_ref().and_then(Running::local_addr) {
        println!("holodeck workers and displays may connect to {a}");
    }
    println!("{}", built.described);
    let dir = args.out.join(&wall.name);
    let (images, windows) = frame_images(args, &scene, &dir, eyes, windows);
    let windows = windows
        .map(|w| WindowOutput::new(w.screens, wall, w.tone, args.window.present_log.as_deref()))
        .transpose()?;
    let glare = match (args.glare, &args.vlf) {
        (Some(size), Some(vlf)) => Some(super::glare::start_live(&scene, vlf, size, &dir)?),
        _ => None,
    };
    let mut shown = |frame: u64, ns: u64, pose: &Pose, views: &[EyeView]| {
        if let Some(g) = &glare {
            let seen = eyes
                .iter()
                .zip(views)
                .map(|(e, v)| (eye_name(*e), v.wall.eye));
            let orientation = pose.orientation.as_dquat();
            g.offer(views_at(frame, ns, &cave.room_to_scene, orientation, seen));
        }
    };
    let run = StandaloneRun {
        cave,
        wall,
        size,
        schedule: Schedule {
            frames: args.frames,
            seconds: args.seconds,
            fps: args.fps,
            every: args.every,
        },
        head: &mut pose_at,
        objects: objects.as_ref(),
        windows,
        images,
        linger: args.window.linger,
    };
    let ran = built.run(run, &mut shown).map_err(|e| anyhow!(e))?;
    if let Some(g) = glare {
        super::glare::finish_live(g, &dir)?;
    }
    if let (Some((running, counts)), Some(path)) = (ran.holodeck, &args.holodeck) {
        stop_own_holodeck(running, path, counts)?;
    }
    let feed = match (&args.holodeck, args.sync) {
        (Some(_), _) => " (the holodeck's workers)",
        (None, true) => "",
        (None, false) => " (on the tracer thread)",
    };
    let images = match args.window.window {
        true => "windows".to_owned(),
        false => dir.display().to_string(),
    };
    println!("{}; images in {images}", ran.totals.describe(feed));
    Ok(())
}

/// The moving objects' paths of `--objects` for a standalone wall (a warning where the
/// scene has objects but no light field draws them).
fn standalone_objects(
    args: &NodeArgs,
    scene: &Arc<Scene>,
) -> Result<Option<holocave_scene::ObjectPaths>> {
    let objects = args
        .objects
        .as_deref()
        .map(|p| super::render::read_object_paths(p, scene))
        .transpose()?;
    if !scene.objects().is_empty() && args.vlf.is_none() {
        tracing::warn!(
            "the scene's moving objects are drawn over a light field only: give --vlf to see them"
        );
    }
    Ok(objects)
}

/// The wall's frames written as images in `dir`, and its windows, each tone-mapped for
/// the scene's luminous efficacy.
fn frame_images<'a>(
    args: &NodeArgs,
    scene: &Scene,
    dir: &Path,
    eyes: &'static [Eye],
    windows: Option<Windows<'a>>,
) -> (FrameImages, Option<Windows<'a>>) {
    let efficacy = scene.daylight.photometry.efficacy;
    let images = FrameImages {
        dir: dir.to_owned(),
        eyes,
        tone: args.tone.mapper(efficacy),
        debug: args.debug_images,
    };
    let windows = windows.map(|mut w| {
        w.tone.efficacy = efficacy;
        w
    });
    (images, windows)
}

/// The flags a standalone node needs together, checked before anything is opened.
fn check_standalone_flags(args: &NodeArgs) -> Result<()> {
    if args.frames.is_none() && args.seconds.is_none() {
        bail!("say when to stop: --frames N or --seconds S");
    }
    if args.holodeck.is_none() && (args.threads.is_some() || args.listen.is_some()) {
        bail!("--threads and --listen are for the holodeck's server: give --holodeck H.hdk");
    }
    if args.holodeck.is_some() && args.sync {
        tracing::warn!(
            "--sync is ignored with --holodeck: samples arrive as the workers trace them"
        );
    }
    Ok(())
}

/// The head pose at a frame's time on the replay clock (frame k shows the head at k / fps
/// after the tracker's first sample), or `--still`'s pose.
fn replayed_head<'a>(args: &NodeArgs, cave: &'a Cave) -> Result<impl FnMut(u64) -> Pose + 'a> {
    let still = args.still;
    let mut head = match still {
        Some(_) => None,
        None => Some(open_head(
            cave,
            args.tracker.as_deref(),
            Clock::Replay,
            args.prediction,
            args.recenter,
        )?),
    };
    Ok(move |ns: u64| match &mut head {
        Some(h) => {
            h.advance(ns);
            h.pose_at(ns).0
        }
        None => Pose::new(still.unwrap_or(Vec3::ZERO), Quat::IDENTITY),
    })
}

/// The holodeck a standalone node opens itself (`--holodeck`), with its tracer threads
/// and, with `--listen`, a port for TCP workers and displays.
fn own_holodeck<'a>(args: &'a NodeArgs, cave: &Cave) -> Result<Option<OwnHolodeck<'a>>> {
    let port = args
        .listen
        .as_ref()
        .map(|a| {
            let listener = TcpListener::bind(a).with_context(|| format!("--listen {a}"))?;
            let credentials = super::credentials::of_cave(cave, &args.config)?;
            anyhow::Ok(Port {
                listener,
                credentials,
            })
        })
        .transpose()?;
    Ok(args.holodeck.as_deref().map(|path| OwnHolodeck {
        path,
        scene_path: &args.scene,
        threads: args.threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        }),
        port,
        stop: super::interrupt::ctrl_c_flag(),
    }))
}

/// Stops the node's own holodeck and says what this run received and added.
fn stop_own_holodeck(running: Running, path: &Path, c: HolodeckCounts) -> Result<()> {
    let server = running.stop()?;
    let s = server.stats();
    println!(
        "{}: {} samples received ({} used, {} passing near an eye), {} traced and added by this run, {} in the holodeck",
        path.display(),
        c.received,
        c.used,
        c.near,
        s.added,
        s.samples
    );
    Ok(())
}

/// `--master`: follows the cluster's frames, appending every presented frame's number to
/// `DIR/<wall>/presented.log` and writing its images every `--every` frames.
#[allow(clippy::too_many_arguments)]
fn in_cluster(
    args: &NodeArgs,
    master: &str,
    cave: Cave,
    wall: Wall,
    display_id: u32,
    size: Size,
    windows: Option<Windows>,
) -> Result<()> {
    let secret = cave
        .secret()
        .map_err(|e| anyhow!("{}: {e}", args.config.display()))?;
    let (scene, tracer) = load_tracer(&args.scene, args.daylight.clone())?;
    let dir = args.out.join(&wall.name);
    let eyes = Eye::for_mode(wall.stereo);
    let (images, windows) = frame_images(args, &scene, &dir, eyes, windows);
    let member = Membership {
        master: master.to_owned(),
        cluster: cave.cluster.id.clone(),
        secret,
        wall,
        give_up_after: args.seconds.map(Duration::from_secs_f64),
        slow_by: Duration::from_millis(args.slow_ms),
    };
    let mut maker = DisplayMaker::new(&member, display_id, size, args.samples, tracer);
    if let Some(w) = &windows {
        maker = maker.with_gpu(w.screens.gpu.clone());
    }
    if let Some(time) = args.daylight.time_of_day(&args.scene)? {
        maker = maker.with_time_of_day(time);
    }
    let maker = maker.with_vlf(scene, vlf_options(args));
    let windows = windows.map(|w| {
        let log = args.window.present_log.as_deref();
        WindowOutput::new(w.screens, &member.wall, w.tone, log)
    });
    let output = ClusterOutput {
        log: PresentedLog::append(&dir)?,
        windows: windows.transpose()?,
        images,
        every: args.every,
    };
    let (counters, reason) = cluster::run_into(&member, &maker, output)?;
    println!(
        "wall {:?}: {} frames presented, {} skipped; master: {reason}",
        member.wall.name, counters.presented, counters.skipped
    );
    Ok(())
}
