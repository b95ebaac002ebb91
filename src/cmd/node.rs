//! `holocave node`: one render node. `--standalone --headless` runs one wall by itself:
//! its own tracker source, path tracer and GPU render cache, writing each frame's images.
//! With `--holodeck H.hdk` the samples come from a holodeck server in this process (with
//! `--workers` tracer threads), which keeps every ray it traces in the file.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::{DVec3, Quat, Vec3};
use holocave_holodeck::run::Running;
use holocave_master::frustum::{Eye, eye_position, off_axis};
use holocave_master::head::Clock;
use holocave_master::load_cave;
use holocave_render_node::display::contact_sheet;
use holocave_render_node::{
    DisplayProcess, EyeView, Gpu, HolodeckOptions, HolodeckSource, RenderCache, ToneMapper,
    ToneMode, TracerSource,
};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::view::WallView;
use holocave_tracer::{TraceSettings, Tracer};
use holocave_tracking::Pose;

use super::cave_holodeck;
use super::master::open_head;

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
    /// Draw from this holodeck file (created if missing: one interior section, the CAVE's
    /// inside volume in scene coordinates), served in this process by `--workers` tracer
    /// threads that add every ray they trace to it. Without it the node traces its own
    /// samples and keeps none.
    #[arg(long)]
    pub(crate) holodeck: Option<PathBuf>,
    /// Tracer threads of the in-process holodeck server (default: the cores).
    #[arg(long)]
    pub(crate) workers: Option<usize>,
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
    #[arg(long, value_parser = parse_vec3)]
    pub(crate) still: Option<Vec3>,
    /// Write images instead of opening a window (the only mode so far).
    #[arg(long)]
    pub(crate) headless: bool,
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
    #[arg(long, value_parser = parse_size)]
    pub(crate) size: Option<(u32, u32)>,
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
    #[arg(long, default_value = "camera")]
    pub(crate) tone: String,
    /// Trace between frames on the display's thread (deterministic output) instead of on a
    /// tracer thread that frames never wait for.
    #[arg(long)]
    pub(crate) sync: bool,
    /// Write images every K frames (and always the last).
    #[arg(long, default_value_t = 1)]
    pub(crate) every: u64,
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("{s:?}: expected X,Y,Z")),
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("{s:?}: expected WxH"))?;
    let p = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("{s:?}: {v:?} is not a positive size"))
    };
    Ok((p(w)?, p(h)?))
}

pub(crate) fn eye_name(eye: Eye) -> &'static str {
    match eye {
        Eye::Left => "left",
        Eye::Right => "right",
        Eye::Centre => "centre",
    }
}

pub fn run(args: NodeArgs) -> Result<()> {
    if let Some(master) = &args.master {
        return super::cluster_node::run(&args, master);
    }
    if !args.standalone {
        bail!("say how the node runs: --standalone, or --master HOST:PORT to join a cluster");
    }
    if !args.headless {
        bail!("only --headless is supported: the windowed display is not built yet");
    }
    if args.frames.is_none() && args.seconds.is_none() {
        bail!("say when to stop: --frames N or --seconds S");
    }
    if args.holodeck.is_none() && (args.workers.is_some() || args.listen.is_some()) {
        bail!("--workers and --listen are for the holodeck's server: give --holodeck H.hdk");
    }
    if args.holodeck.is_some() && args.sync {
        tracing::warn!(
            "--sync is ignored with --holodeck: samples arrive as the workers trace them"
        );
    }
    let cave = load_cave(&args.config)?;
    let wall = cave
        .walls
        .iter()
        .find(|w| w.name == args.wall)
        .with_context(|| {
            format!(
                "{}: no wall {:?} (walls: {})",
                args.config.display(),
                args.wall,
                cave.walls
                    .iter()
                    .map(|w| w.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?
        .clone();
    let (width, height) = args.size.unwrap_or((wall.pixels[0], wall.pixels[1]));
    let eyes = Eye::for_mode(wall.stereo);

    let scene = Arc::new(
        Scene::load(&args.scene, &LoadOptions::default())
            .with_context(|| format!("loading {}", args.scene.display()))?,
    );
    let tracer = Arc::new(Tracer::new(scene.clone(), TraceSettings::default()));

    // The replay clock: frame k shows the head at k / fps after the first sample.
    let mut head = match args.still {
        Some(_) => None,
        None => Some(open_head(
            &cave,
            args.tracker.as_deref(),
            Clock::Replay,
            args.prediction,
            args.recenter,
        )?),
    };

    let gpu = Gpu::new()?;
    let pixels = width * height;
    let samples = args.samples.unwrap_or((pixels / 16).max(1));
    let capacity = (pixels * eyes.len() as u32) * 5 / 4;
    let sizes = vec![(width, height); eyes.len()];
    let cache = RenderCache::new(gpu, &sizes, capacity, samples.saturating_mul(2));
    let mut holodeck = None;
    let mut display = match &args.holodeck {
        Some(path) => {
            let file = cave_holodeck::open_or_create(path, &cave, &args.scene, &scene, "node")?;
            let workers = args.workers.unwrap_or_else(|| {
                std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
            });
            let listener = args
                .listen
                .as_ref()
                .map(|a| TcpListener::bind(a).with_context(|| format!("--listen {a}")))
                .transpose()?;
            let name = super::worker::scene_name(&args.scene);
            let running = cave_holodeck::serve(file, workers, Some(scene.clone()), name, listener)?;
            let source = HolodeckSource::new(running.display(0), HolodeckOptions::default(), 1);
            holodeck = Some(running);
            DisplayProcess::holodeck(cache, source, samples)
        }
        None => {
            let source = TracerSource::new(tracer, 1);
            if args.sync {
                DisplayProcess::new(cache, source, samples)
            } else {
                DisplayProcess::threaded(cache, source, samples)
            }
        }
    };
    println!(
        "wall {:?}: {} eye(s) at {width}x{height}, {} points, {samples} samples per eye and frame, GPU {}",
        wall.name,
        eyes.len(),
        display.cache.capacity(),
        display.cache.gpu().adapter
    );

    let mut tone = match args.tone.as_str() {
        "camera" => Some(ToneMapper::new(ToneMode::Camera)),
        "human" => Some(ToneMapper::new(ToneMode::Human)),
        "reinhard" => None,
        other => bail!("--tone {other:?}: expected camera, human or reinhard"),
    };
    let dir = args.out.join(&wall.name);
    let to_scene = cave.room_to_scene;
    let scene_pt = |p: DVec3| to_scene.transform_point3(p).as_vec3();
    let mut views: Vec<EyeView> = Vec::new();
    let start = Instant::now();
    let mut frame = 0u64;
    let mut totals = (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    let mut inserted = 0usize;
    loop {
        let done = args.frames.is_some_and(|n| frame >= n)
            || args
                .seconds
                .is_some_and(|s| start.elapsed().as_secs_f64() >= s);
        if done || holodeck.as_ref().is_some_and(Running::stopping) {
            break;
        }
        let dt = Duration::from_secs_f64(frame as f64 / args.fps);
        let pose = match (&mut head, args.still) {
            (_, Some(p)) => Pose::new(p, Quat::IDENTITY),
            (Some(h), None) => {
                let ns = dt.as_nanos() as u64;
                h.advance(ns);
                h.pose_at(ns).0
            }
            (None, None) => unreachable!(),
        };
        let mut fresh = Vec::with_capacity(eyes.len());
        for &eye in eyes {
            let e = eye_position(&cave, &pose, eye);
            match off_axis(&wall, e, cave.near, &to_scene) {
                Ok(f) => fresh.push(EyeView {
                    view_proj: f.view_proj().as_mat4(),
                    near: f.near as f32,
                    wall: WallView {
                        eye: scene_pt(e),
                        pa: scene_pt(wall.pa),
                        pb: scene_pt(wall.pb),
                        pc: scene_pt(wall.pc),
                        width,
                        height,
                    },
                }),
                Err(fault) => {
                    tracing::warn!("frame {frame}: {fault}; keeping the last good views");
                    break;
                }
            }
        }
        if fresh.len() == eyes.len() {
            views = fresh;
        }
        if views.is_empty() {
            frame += 1;
            continue;
        }
        let report = display.frame(&views, false);
        totals.0 += report.draw;
        totals.1 += report.trace;
        totals.2 += report.insert;
        inserted += report.inserted;
        let last = args.frames.is_some_and(|n| frame + 1 == n);
        if frame.is_multiple_of(args.every.max(1)) || last {
            write_images(
                &dir,
                frame,
                eyes,
                &mut display,
                &mut tone,
                args.debug_images,
            )?;
        }
        tracing::debug!(
            "frame {frame}: head {:.3?}, chosen {:?}, draw {:?}, trace {:?}",
            pose.position,
            report.chosen,
            report.draw,
            report.trace
        );
        frame += 1;
    }
    let n = frame.max(1) as f64;
    let holo_counts = match &display.sampler {
        holocave_render_node::Sampler::Holodeck(h) => Some(h.counts()),
        _ => None,
    };
    drop(display);
    if let (Some(running), Some(path)) = (holodeck, &args.holodeck) {
        let server = running.stop()?;
        let s = server.stats();
        let c = holo_counts.unwrap_or_default();
        println!(
            "{}: {} samples received ({} used, {} passing near an eye), {} traced and added by this run, {} in the holodeck",
            path.display(),
            c.received,
            c.used,
            c.near,
            s.added,
            s.samples
        );
    }
    println!(
        "{frame} frames in {:.2} s; per frame: draw + choose {:.2} ms, trace {:.2} ms{}, insert {:.2} ms, {:.0} samples inserted; images in {}",
        start.elapsed().as_secs_f64(),
        totals.0.as_secs_f64() * 1e3 / n,
        totals.1.as_secs_f64() * 1e3 / n,
        if args.holodeck.is_some() {
            " (the holodeck's workers)"
        } else if args.sync {
            ""
        } else {
            " (on the tracer thread)"
        },
        totals.2.as_secs_f64() * 1e3 / n,
        inserted as f64 / n,
        dir.display()
    );
    Ok(())
}

/// Writes frame `frame`'s images of every eye: `DIR/<frame>-<eye>.exr` (linear) and
/// `.png` (tone-mapped preview), and with `debug` the priority image, the chosen pixels
/// and a contact sheet of all three.
pub(crate) fn write_images(
    dir: &Path,
    frame: u64,
    eyes: &[Eye],
    display: &mut DisplayProcess,
    tone: &mut Option<ToneMapper>,
    debug: bool,
) -> Result<()> {
    let mut sheet = Vec::new();
    let mut width = 1;
    for (i, &eye) in eyes.iter().enumerate() {
        let img = display.cache.image(i);
        width = img.width;
        let stem = format!("{frame:05}-{}", eye_name(eye));
        std::fs::create_dir_all(dir)?;
        img.write_exr(&dir.join(format!("{stem}.exr")))?;
        let preview = match tone {
            Some(tm) => {
                if i == 0 && tm.update(&img, false) {
                    tracing::debug!("frame {frame}: tone mapping recomputed");
                }
                tm.apply(&img)
            }
            None => {
                let exposure = display.exposure(&img);
                img.to_preview(exposure)
            }
        };
        preview.save(dir.join(format!("{stem}.png")))?;
        if debug {
            let pr = display.cache.priority_image(i).to_preview(0.5);
            pr.save(dir.join(format!("{stem}-priority.png")))?;
            let ch = display.cache.chosen_image(i).to_preview(100.0);
            ch.save(dir.join(format!("{stem}-chosen.png")))?;
            sheet.push(vec![preview, pr, ch]);
        }
    }
    if debug {
        let zoom = (512 / width).max(1);
        contact_sheet(&sheet, zoom).save(dir.join(format!("{frame:05}-sheet.png")))?;
    }
    Ok(())
}
