//! One wall by itself (`holocave node --standalone`): the node's own frame clock and head
//! poses instead of a master's frame states. Each frame takes the head pose at that
//! frame's time, makes the wall's eye views from it through the CAVE's frusta (a wall
//! whose eye faults keeps its last good views), draws them and hands the frame to
//! `present` every `every` frames and at the last one.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use holocave_cave::{Cave, Eye, Size, Wall, wall_frusta};
use holocave_holodeck::auth::Port;
use holocave_holodeck::run::Running;
use holocave_scene::{ObjectPaths, Scene};
use holocave_tracer::Tracer;
use holocave_tracer::cave_holodeck::{CaveHolodeck, Serving};
use holocave_tracking::Pose;

use crate::feed::holodeck::HolodeckCounts;
use crate::node::cluster::VlfOptions;
use crate::present::output::FrameImages;
use crate::present::wall_windows::WindowOutput;
use crate::{
    DisplayBuilder, EyeView, Feed, Gpu, HolodeckOptions, HolodeckSource, LightField, RenderCache,
    RenderNodeError, VlfBase, WallDisplay,
};

/// The holodeck a standalone wall draws from, served in its own process.
pub struct OwnHolodeck<'a> {
    /// The file, created for the CAVE if missing.
    pub path: &'a Path,
    pub scene_path: &'a Path,
    /// Tracer threads adding to it.
    pub threads: usize,
    /// Also accept TCP workers and displays here.
    pub port: Option<Port>,
    pub stop: Arc<AtomicBool>,
}

/// What a standalone wall is built from.
pub struct StandaloneSpec<'a> {
    pub cave: &'a Cave,
    pub wall: &'a Wall,
    /// Pixels per eye.
    pub size: Size,
    /// Samples traced per eye and frame (`None`: the render cache's default for the size).
    pub samples: Option<u32>,
    pub scene: Arc<Scene>,
    /// The path tracer of the inline and threaded feeds.
    pub tracer: Arc<Tracer>,
    /// The device to draw on (a window's); `None`: a new one.
    pub gpu: Option<Gpu>,
    /// The light field drawn under the samples (`own`; none: the samples alone), and how.
    pub vlf: VlfOptions,
    /// The holodeck it serves itself; `None`: the path tracer feeds it.
    pub holodeck: Option<OwnHolodeck<'a>>,
    /// Without a holodeck, trace between frames on the display's thread (deterministic)
    /// instead of on a tracer thread that frames never wait for.
    pub sync: bool,
}

/// A standalone wall's display and the holodeck it serves itself, if any.
pub struct StandaloneWall {
    pub display: WallDisplay,
    pub holodeck: Option<Running>,
    /// What the holodeck opened holds (its [`CaveHolodeck::describe`]).
    pub holodeck_described: Option<String>,
    /// What the wall draws, and on which device, in a line.
    pub described: String,
}

impl StandaloneWall {
    /// The wall of `spec`: its display with the light field and its feed.
    pub fn build(spec: StandaloneSpec) -> Result<StandaloneWall, RenderNodeError> {
        let gpu = match spec.gpu {
            Some(gpu) => gpu,
            None => Gpu::new()?,
        };
        let eyes = Eye::for_mode(spec.wall.stereo).len();
        let samples = (spec.samples).unwrap_or_else(|| RenderCache::default_samples(spec.size));
        let mut builder = DisplayBuilder::new(spec.size, eyes, samples, spec.tracer);
        builder.gpu = Some(gpu.clone());
        builder.gather = spec.vlf.gather;
        if let Some(path) = &spec.vlf.own {
            let base = VlfBase::for_wall(path, spec.scene.clone(), spec.vlf.drawing, Some(&gpu))?;
            builder.light_field = Some(LightField {
                base: Arc::new(base),
                prior: spec.vlf.prior,
            });
        }
        let (display, holodeck) = fed(&builder, spec.cave, &spec.scene, spec.holodeck, spec.sync)?;
        let described = format!(
            "wall {:?}: {eyes} eye(s) at {}, {} points, {samples} samples per eye and frame, GPU {}",
            spec.wall.name,
            spec.size,
            display.cache.capacity(),
            display.cache.gpu().adapter
        );
        let (holodeck, holodeck_described) = holodeck.unzip();
        Ok(StandaloneWall {
            display,
            holodeck,
            holodeck_described,
            described,
        })
    }
}

/// The wall's display from `builder`: fed by its own holodeck server when given one (with
/// what the holodeck opened holds), else by the path tracer inline (`sync`, deterministic)
/// or on a thread.
fn fed(
    builder: &DisplayBuilder,
    cave: &Cave,
    scene: &Arc<Scene>,
    holodeck: Option<OwnHolodeck>,
    sync: bool,
) -> Result<(WallDisplay, Option<(Running, String)>), RenderNodeError> {
    let Some(h) = holodeck else {
        let feed = if sync { Feed::Inline } else { Feed::Thread };
        return Ok((builder.build(feed)?, None));
    };
    let hd = |e: holocave_tracer::cave_holodeck::CaveHolodeckError| {
        RenderNodeError::Holodeck(e.to_string())
    };
    let opened = CaveHolodeck::open_or_create(h.path, cave, h.scene_path, Some(scene), "node", &[])
        .map_err(hd)?;
    let described = opened.describe();
    let running = opened
        .serve(Serving {
            threads: h.threads,
            scene: Some(scene.clone()),
            port: h.port,
            stop: h.stop,
            allowance: None,
        })
        .map_err(hd)?;
    let source = HolodeckSource::new(running.display(0), HolodeckOptions::default(), 1);
    let display = builder.build(Feed::Holodeck(source))?;
    Ok((display, Some((running, described))))
}

/// When a standalone run stops, its clock, and which frames it presents.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    /// Stop after this many frames.
    pub frames: Option<u64>,
    /// Stop after this many seconds of wall-clock time.
    pub seconds: Option<f64>,
    /// Frame k shows the head at k / fps.
    pub fps: f64,
    /// Present every this many frames (and always the last).
    pub every: u64,
}

impl Schedule {
    fn done(&self, frame: u64, start: Instant) -> bool {
        self.frames.is_some_and(|n| frame >= n)
            || self
                .seconds
                .is_some_and(|s| start.elapsed().as_secs_f64() >= s)
    }
}

/// What a standalone run did.
#[derive(Clone, Copy, Debug, Default)]
pub struct Totals {
    pub frames: u64,
    pub elapsed: Duration,
    /// Summed over frames: drawing and choosing, tracing (inline only), inserting.
    pub draw: Duration,
    pub trace: Duration,
    pub insert: Duration,
    pub inserted: usize,
    /// Summed over frames: the light field's visibility (ray casts per pixel).
    pub vlf: Duration,
}

impl Totals {
    /// The run's times per frame, in a line; `feed` says where the tracing ran.
    pub fn describe(&self, feed: &str) -> String {
        let n = self.frames.max(1) as f64;
        let ms = |d: Duration| d.as_secs_f64() * 1e3 / n;
        format!(
            "{} frames in {:.2} s; per frame: light field visibility {:.2} ms, draw + choose {:.2} ms, trace {:.2} ms{feed}, insert {:.2} ms, {:.0} samples inserted",
            self.frames,
            self.elapsed.as_secs_f64(),
            ms(self.vlf),
            ms(self.draw),
            ms(self.trace),
            ms(self.insert),
            self.inserted as f64 / n,
        )
    }
}

/// How a standalone run goes: its schedule, the head and moving objects it follows, and
/// where its frames go.
pub struct StandaloneRun<'a> {
    pub cave: &'a Cave,
    pub wall: &'a Wall,
    /// Pixels per eye.
    pub size: Size,
    pub schedule: Schedule,
    /// The head pose (room coordinates) at a time in ns from the start.
    pub head: &'a mut dyn FnMut(u64) -> Pose,
    /// The moving objects' paths over the same time.
    pub objects: Option<&'a ObjectPaths>,
    /// The windows the frames are shown in; `None`: they are written as `images`.
    pub windows: Option<WindowOutput<'a>>,
    pub images: FrameImages,
    /// With windows: the last frame kept on screen this many seconds.
    pub linger: f64,
}

/// What a standalone run did, and the holodeck it served (to be stopped) with what its
/// display received from it.
pub struct Ran {
    pub totals: Totals,
    pub holodeck: Option<(Running, HolodeckCounts)>,
}

impl StandaloneWall {
    /// Runs the wall until its schedule ends, a window is closed or its holodeck stops
    /// (Ctrl-C), presenting every `schedule.every` frames in its windows or as images;
    /// `shown` hears of every frame drawn ([`run_frames`]). Windows linger on the last
    /// frame.
    pub fn run(self, run: StandaloneRun, shown: &mut Shown) -> Result<Ran, String> {
        let StandaloneWall {
            mut display,
            holodeck,
            ..
        } = self;
        let closed = run.windows.as_ref().map(|w| w.screens.closed_flag());
        let (mut windows, mut images) = (run.windows, run.images);
        let stopping = || {
            holodeck.as_ref().is_some_and(Running::stopping)
                || closed.as_ref().is_some_and(|c| c.load(Ordering::Acquire))
        };
        let mut present = |frame: u64, display: &mut WallDisplay| match &mut windows {
            Some(o) => {
                o.prepare(display);
                o.show(frame).map(|_| ())
            }
            None => images.write(frame, display),
        };
        let frames = Frames {
            cave: run.cave,
            wall: run.wall,
            size: run.size,
            schedule: run.schedule,
            head: run.head,
            objects: run.objects,
        };
        let totals = run_frames(&mut display, frames, &stopping, shown, &mut present)?;
        if let Some(o) = &mut windows {
            o.finish(&display, (run.linger, run.schedule.fps), totals.frames);
        }
        drop(windows);
        let counts = display.holodeck_counts().unwrap_or_default();
        Ok(Ran {
            totals,
            holodeck: holodeck.map(|h| (h, counts)),
        })
    }
}

/// The frames a standalone run draws: the wall of the CAVE at its size, when, and the head
/// and moving objects at each frame's time.
struct Frames<'a> {
    cave: &'a Cave,
    wall: &'a Wall,
    size: Size,
    schedule: Schedule,
    head: &'a mut dyn FnMut(u64) -> Pose,
    objects: Option<&'a ObjectPaths>,
}

/// Told of each frame drawn: its number, its time (ns from the start), the head pose and
/// the eyes' views.
pub type Shown<'a> = dyn FnMut(u64, u64, &Pose, &[EyeView]) + 'a;

/// Draws `frames` on `display` until the schedule ends or `stop` says so. `shown` hears
/// of every frame drawn (its number, its time in ns, the head pose and the eyes' views)
/// and must not block; `present` receives every presented frame's number and the display
/// holding its images.
fn run_frames(
    display: &mut WallDisplay,
    frames: Frames,
    stop: &dyn Fn() -> bool,
    shown: &mut Shown,
    present: &mut dyn FnMut(u64, &mut WallDisplay) -> Result<(), String>,
) -> Result<Totals, String> {
    let Frames {
        cave,
        wall,
        size,
        schedule,
        head,
        objects,
    } = frames;
    let eyes = Eye::for_mode(wall.stereo);
    let mut views: Vec<EyeView> = Vec::new();
    let start = Instant::now();
    let mut totals = Totals::default();
    let mut frame = 0u64;
    while !schedule.done(frame, start) && !stop() {
        let ns = Duration::from_secs_f64(frame as f64 / schedule.fps).as_nanos() as u64;
        let pose = head(ns);
        match wall_frusta(cave, wall, &pose, eyes) {
            Ok(frusta) => {
                views = frusta
                    .iter()
                    .map(|(_, f)| EyeView::new(f, wall, &cave.room_to_scene, size))
                    .collect();
            }
            Err(fault) => tracing::warn!("frame {frame}: {fault}; keeping the last good views"),
        }
        if views.is_empty() {
            frame += 1;
            continue;
        }
        if let Some(paths) = objects {
            display.place_objects_on_paths(paths, ns as f64 * 1e-9);
        }
        let report = display.frame(&views, false);
        shown(frame, ns, &pose, &views);
        totals.draw += report.draw;
        totals.trace += report.trace;
        totals.insert += report.insert;
        totals.inserted += report.inserted;
        totals.vlf += report.vlf;
        let last = schedule.frames.is_some_and(|n| frame + 1 == n);
        if frame.is_multiple_of(schedule.every.max(1)) || last {
            present(frame, display)?;
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
    totals.frames = frame;
    totals.elapsed = start.elapsed();
    Ok(totals)
}
