//! `holocave compare`: run time against error. A head trace replayed through one wall by
//! every display method with the same ray budget (`holocave_compare`); this module opens
//! the config, the scene and the tracker, shows progress and prints the summary.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use clap::Args;
use holocave_cave::{Cave, Size, Wall, load_cave};
use holocave_compare::{Compare, Method, Settings, VlfSetting};
use holocave_master::head::Clock;
use holocave_render_node::Prior;
use holocave_scene::Scene;
use holocave_tracking::Pose;
use indicatif::{ProgressBar, ProgressStyle};

use super::master::open_head;

#[derive(Args)]
pub struct CompareArgs {
    /// The scene (glTF).
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// The CAVE config (TOML).
    #[arg(long)]
    pub config: PathBuf,
    /// The wall to compare on (its name in the config), or `all`: every wall in turn, each
    /// in DIR/<wall>/.
    #[arg(long)]
    pub wall: String,
    /// The head trace (file:PATH, synthetic:NAME); default: the config's source.
    #[arg(long)]
    pub tracker: Option<String>,
    /// Move the trace's first position to the room's inside point.
    #[arg(long)]
    pub recenter: bool,
    /// Seconds of the trace to replay.
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// The frame clock (Hz).
    #[arg(long, default_value_t = 30.0)]
    pub fps: f64,
    /// Methods, comma-separated: trace, accumulate, cache, holodeck, vlf, vlf+holodeck,
    /// vlf+gather.
    #[arg(
        long,
        default_value = "trace,accumulate,cache,holodeck,vlf,vlf+holodeck,vlf+gather",
        value_delimiter = ','
    )]
    pub methods: Vec<Method>,
    /// The light field of the vlf methods (default: DIR/<scene>.vlf, baked with default
    /// settings for the scene as compared — scaled and moved — when missing).
    #[arg(long)]
    pub vlf: Option<PathBuf>,
    /// Leave out the direct light computed per pixel in the vlf methods: the light field
    /// alone, its baked direct light included.
    #[arg(long)]
    pub no_direct: bool,
    /// What the light field is worth in samples under vlf+holodeck's and vlf+gather's
    /// samples: `auto` (measured at the first frame from the method's own samples) or a
    /// number.
    #[arg(long, default_value = "auto", value_parser = str::parse::<Prior>)]
    pub vlf_prior: Prior,
    /// Rays per eye and frame for every method (default: one per pixel).
    #[arg(long)]
    pub budget: Option<u32>,
    /// Measure every K-th frame (and the last) against its reference.
    #[arg(long, default_value_t = 15)]
    pub every: u64,
    /// Each eye's image size, WxH (default: an eighth of the wall's pixels).
    #[arg(long)]
    pub size: Option<Size>,
    /// Paths per pixel of the converged references.
    #[arg(long, default_value_t = 1024)]
    pub reference_spp: u32,
    /// The holodeck method's file: drawn from as it is (warm) if it exists, else made
    /// (cold). Default: a new file in --out every run.
    #[arg(long)]
    pub holodeck: Option<PathBuf>,
    /// Stress test: scale the scene and the CAVE by S (about the scene's origin)…
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// …and move both by X,Y,Z metres.
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true)]
    pub offset: Option<glam::Vec3>,
    /// Output folder.
    #[arg(long, default_value = "out/compare")]
    pub out: PathBuf,
}

pub fn run(args: CompareArgs) -> Result<()> {
    let methods = &args.methods;
    if !(args.fps > 0.0 && args.fps <= 1000.0) {
        bail!("--fps {}: not a frame rate (0 to 1000 Hz)", args.fps);
    }
    if !(args.seconds > 0.0 && args.seconds < 1e5) {
        bail!("--seconds {}: must be positive", args.seconds);
    }
    if !(args.scale > 0.0 && args.scale.is_finite()) {
        bail!("--scale {}: must be a positive factor", args.scale);
    }
    let mut cave = load_cave(&args.config)?;
    let offset = args.offset.unwrap_or_default();
    cave.place_in_scene(args.scale, offset.as_dvec3());
    let cave = cave;
    let walls: Vec<&Wall> = if args.wall == "all" {
        cave.walls.iter().collect()
    } else {
        let index = cave
            .wall_index(&args.wall)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.config.display()))?;
        vec![&cave.walls[index]]
    };
    let scene = super::render::load_scene(&args.scene, args.daylight.clone(), false)?;
    let scene = Arc::new(
        scene
            .transformed(args.scale as f32, offset)
            .with_context(|| format!("{} scaled and moved", args.scene.display()))?,
    );
    let mut head = open_head(
        &cave,
        args.tracker.as_deref(),
        Clock::Replay,
        false,
        args.recenter,
    )?;
    let frames = (args.seconds * args.fps).round().max(1.0) as u64;
    let poses: Vec<_> = (0..frames)
        .map(|k| {
            let ns = Duration::from_secs_f64(k as f64 / args.fps).as_nanos() as u64;
            head.advance(ns);
            head.pose_at(ns).0
        })
        .collect();
    let vlf = if methods.iter().any(|m| m.needs_vlf()) {
        let path =
            (args.vlf.clone()).unwrap_or_else(|| super::kept_beside(&args.out, &args.scene, "vlf"));
        let path = super::vlf::baked_default(&scene, &path)?;
        Some(VlfSetting {
            path,
            prior: args.vlf_prior,
            direct: !args.no_direct,
        })
    } else {
        None
    };
    for wall in walls {
        let out = if args.wall == "all" {
            args.out.join(&wall.name)
        } else {
            args.out.clone()
        };
        // Ctrl-C ends the comparison at once: each reference is written as it is rendered
        // (one cut short is rendered again), so a next run starts from those.
        let kept = format!(
            "{} keeps the converged references rendered so far (refs/); run again to reuse them",
            out.display()
        );
        super::interrupt::ending_at_once(kept, || {
            compare_wall(
                &args,
                &cave,
                wall,
                scene.clone(),
                methods,
                &poses,
                vlf.clone(),
                out,
            )
        })?;
    }
    Ok(())
}

/// Runs the comparison on one wall into `out` and prints its summary.
#[allow(clippy::too_many_arguments)]
fn compare_wall(
    args: &CompareArgs,
    cave: &Cave,
    wall: &Wall,
    scene: Arc<Scene>,
    methods: &[Method],
    poses: &[Pose],
    vlf: Option<VlfSetting>,
    out: PathBuf,
) -> Result<()> {
    let frames = poses.len() as u64;
    let size = args.size.unwrap_or(wall.pixels.scaled(0.125, 8));
    let settings = Settings {
        methods: methods.to_vec(),
        fps: args.fps,
        budget: args.budget.unwrap_or(size.width * size.height),
        every: args.every.max(1),
        size,
        reference_spp: args.reference_spp.max(1),
        out: out.clone(),
        holodeck: args.holodeck.clone(),
        vlf,
    };
    let compare = Compare {
        cave,
        wall,
        scene,
        scene_path: &args.scene,
    };
    println!(
        "comparing {} on wall {:?}: {frames} frames at {} Hz, {size} per eye, {} rays per eye and frame, references at {} spp",
        methods
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", "),
        wall.name,
        args.fps,
        settings.budget,
        settings.reference_spp
    );
    let bar = ProgressBar::new(frames * methods.len() as u64).with_style(
        ProgressStyle::with_template(
            "{msg:12} [{bar:40}] {pos}/{len} frames, {elapsed} (eta {eta})",
        )
        .expect("a valid template"),
    );
    let done_before = |m: Method| methods.iter().position(|x| *x == m).unwrap_or(0) as u64 * frames;
    let outcome = compare.run(&settings, poses, &mut |m, f, _| {
        bar.set_message(m.name());
        bar.set_position(done_before(m) + f);
    })?;
    bar.finish_and_clear();
    println!(
        "{} frames; references' own relative MSE {:.2e}",
        outcome.frames, outcome.reference_noise
    );
    for s in &outcome.summaries {
        println!(
            "  {:10}: time-averaged relative MSE {:.3e}, at the end {:.3e}, frame p50 {:.1} ms, p99 {:.1} ms",
            s.method,
            s.time_averaged,
            s.at_end,
            s.frame_p50.as_secs_f64() * 1e3,
            s.frame_p99.as_secs_f64() * 1e3
        );
    }
    println!(
        "written: {0}/error_time.csv, {0}/error_time.svg, {0}/summary.md, {0}/views.csv, {0}/frames/",
        out.display()
    );
    Ok(())
}
