//! The replay: the head trace's poses → each frame's eye views of the wall (the CAVE's
//! frusta) → every method in turn over the whole trace (one after another, so no method's
//! background work runs during another's frames) → every `every`-th frame and the last,
//! each eye's image against its reference → the rows, files and plot.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use holocave_cave::{Cave, Eye, Wall, wall_frusta};
use holocave_cave::{Size, WallView};
use holocave_holodeck::run::RayAllowance;
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::{
    DisplayBuilder, EyeView, Feed, HolodeckOptions, HolodeckSource, LightField, Prior,
    RenderNodeError, VlfBase, VlfDrawing,
};
use holocave_scene::Scene;
use holocave_tracer::cave_holodeck::{CaveHolodeck, Serving};
use holocave_tracer::film::{FilmError, Image};
use holocave_tracer::{TraceSettings, Tracer};
use holocave_tracking::Pose;

use crate::method::{Drawer, Method, spp_for};
use crate::reference::References;
use crate::report::{self, Row, Summary};

/// Why a comparison could not run.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("no methods to compare")]
    NoMethods,
    #[error("the head trace gives no frame: it has no samples")]
    NoFrames,
    #[error(
        "the head trace does not fit the CAVE: from wall {wall:?} {faults} of {frames} frames \
         have no view (the eye on, behind or too near the wall; try --recenter)"
    )]
    OutsideCave {
        wall: String,
        faults: usize,
        frames: usize,
    },
    #[error(transparent)]
    Gpu(#[from] RenderNodeError),
    #[error("the holodeck: {0}")]
    Holodeck(String),
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    Film(#[from] FilmError),
    #[error("plotting: {0}")]
    Plot(String),
    #[error("the methods vlf and vlf+holodeck need a baked light field (--vlf F.vlf)")]
    NoVlf,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CompareError + '_ {
    move |source| CompareError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// The baked light field of the vlf methods (`holocave vlf bake`).
#[derive(Clone, Debug)]
pub struct VlfSetting {
    pub path: PathBuf,
    /// What it is worth in samples under the samples of vlf+holodeck and vlf+gather.
    pub prior: Prior,
    /// The direct light computed per pixel, as the walls draw it (false: the light field
    /// alone, its baked direct light included).
    pub direct: bool,
}

/// How to compare.
#[derive(Clone, Debug)]
pub struct Settings {
    pub methods: Vec<Method>,
    /// The frame clock: frame k shows the head at k / fps.
    pub fps: f64,
    /// Rays per eye and frame for every method.
    pub budget: u32,
    /// Measure every `every`-th frame (and the last).
    pub every: u64,
    /// Each eye's image size.
    pub size: Size,
    /// Paths per pixel of the references.
    pub reference_spp: u32,
    /// Output folder.
    pub out: PathBuf,
    /// The holodeck method's file: drawn from as it is (warm) if it exists, else created
    /// (cold); `None`: a new file in `out`, replaced every run.
    pub holodeck: Option<PathBuf>,
    /// The baked light field of the vlf methods (`holocave vlf bake`), and what it is
    /// worth in samples under the holodeck's.
    pub vlf: Option<VlfSetting>,
}

/// The display's holodeck options in a comparison: a request every frame (so what is
/// traced for a frame does not depend on how fast this machine draws), its demand fading
/// as fast in trace time as a live node's at `fps` with the default options.
fn holodeck_options(fps: f64) -> HolodeckOptions {
    let d = HolodeckOptions::default();
    let requests_per_fade = d.request_every.as_secs_f64() * fps;
    HolodeckOptions {
        request_every: Duration::ZERO,
        decay: d.decay.powf(1.0 / requests_per_fade.max(1e-9)),
        ..d
    }
}

/// What is compared: a wall of a CAVE in a scene.
pub struct Compare<'a> {
    pub cave: &'a Cave,
    pub wall: &'a Wall,
    pub scene: Arc<Scene>,
    /// The scene's file (its name goes into a new holodeck; its bytes key the references).
    pub scene_path: &'a Path,
}

/// What a comparison produced.
pub struct Outcome {
    pub rows: Vec<Row>,
    /// Per method, every frame's rays traced and rays of its budget left unspent (the
    /// holodeck methods: nothing left to trace).
    pub frame_rays: Vec<(&'static str, Vec<(u64, u64)>)>,
    pub summaries: Vec<Summary>,
    pub reference_noise: f64,
    pub frames: u64,
}

impl Compare<'_> {
    /// Each frame's eye views for the head poses (one pose per frame); a frame whose eye
    /// faults keeps the last good views.
    fn views(&self, poses: &[Pose], size: Size) -> Result<Vec<Vec<EyeView>>, CompareError> {
        let eyes = Eye::for_mode(self.wall.stereo);
        let mut out: Vec<Vec<EyeView>> = Vec::with_capacity(poses.len());
        let mut faults = 0;
        for pose in poses {
            match wall_frusta(self.cave, self.wall, pose, eyes) {
                Ok(f) => out.push(
                    f.iter()
                        .map(|(_, f)| EyeView::new(f, self.wall, &self.cave.room_to_scene, size))
                        .collect(),
                ),
                Err(_) => {
                    faults += 1;
                    if let Some(last) = out.last().cloned() {
                        out.push(last);
                    }
                }
            }
        }
        // More than a tenth of the frames without a view of their own: not this CAVE's trace.
        if faults * 10 > poses.len() || out.len() < poses.len() {
            return Err(CompareError::OutsideCave {
                wall: self.wall.name.clone(),
                faults,
                frames: poses.len(),
            });
        }
        Ok(out)
    }

    /// A method's drawer, its state fresh.
    fn drawer(&self, method: Method, s: &Settings, eyes: usize) -> Result<Drawer, CompareError> {
        let tracer = Arc::new(Tracer::new(self.scene.clone(), TraceSettings::default()));
        let spp = spp_for(s.budget, s.size.width, s.size.height);
        let builder = DisplayBuilder::new(s.size, eyes, s.budget, tracer.clone());
        Ok(match method {
            Method::Trace => Drawer::Trace { tracer, spp },
            Method::Accumulate => Drawer::Accumulate {
                tracer,
                spp,
                sums: Vec::new(),
            },
            // One sample per pixel at most, each the mean of the paths the budget buys;
            // with vlf+gather, gathers over the light field drawn under them.
            Method::Cache | Method::VlfGather => {
                let gather = method == Method::VlfGather;
                let light_field = if gather {
                    Some(self.light_field(s)?)
                } else {
                    None
                };
                let display = DisplayBuilder {
                    samples: s.budget / spp,
                    paths: spp,
                    gather,
                    light_field,
                    ..builder
                }
                .build(Feed::Inline)?;
                Drawer::Cache {
                    display,
                    paths: spp,
                }
            }
            Method::Vlf => {
                let mut cache = builder.cache()?;
                let base = self.vlf_base(s)?;
                cache.set_vlf(base.values(), 0.0)?;
                Drawer::Vlf { cache, base }
            }
            Method::Holodeck | Method::VlfHolodeck => {
                let hd = |e: &dyn std::fmt::Display| CompareError::Holodeck(e.to_string());
                let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
                // The tracer threads trace only what each frame grants: the budget.
                let allowance = Arc::new(RayAllowance::new());
                let running = self
                    .holodeck_file(s)?
                    .serve(Serving {
                        threads,
                        scene: Some(self.scene.clone()),
                        port: None,
                        stop: Arc::new(AtomicBool::new(false)),
                        allowance: Some(allowance.clone()),
                    })
                    .map_err(|e| hd(&e))?;
                let source = HolodeckSource::new(running.display(0), holodeck_options(s.fps), 1);
                let mut builder = builder;
                if method == Method::VlfHolodeck {
                    builder.light_field = Some(self.light_field(s)?);
                }
                let display = builder.build(Feed::Holodeck(source))?;
                Drawer::Holodeck {
                    display,
                    server: running,
                    allowance,
                    grant: u64::from(s.budget) * eyes as u64,
                    requests: 0,
                }
            }
        })
    }

    /// The light field under the samples of vlf+holodeck and vlf+gather, worth the
    /// settings' prior.
    fn light_field(&self, s: &Settings) -> Result<LightField, CompareError> {
        Ok(LightField {
            base: self.vlf_base(s)?,
            prior: s.vlf.as_ref().map_or(Prior::Samples(0.0), |v| v.prior),
        })
    }

    /// The light field of the vlf methods, opened for this scene.
    fn vlf_base(&self, s: &Settings) -> Result<Arc<VlfBase>, CompareError> {
        let v = s.vlf.as_ref().ok_or(CompareError::NoVlf)?;
        Ok(Arc::new(VlfBase::for_wall(
            &v.path,
            self.scene.clone(),
            VlfDrawing {
                direct: v.direct,
                sky_per_pixel: false,
                rays: Rays::Cpu,
            },
            None,
        )?))
    }

    /// The holodeck method's file: the given one if it exists (warm), else a new one for
    /// this CAVE (cold).
    fn holodeck_file(&self, s: &Settings) -> Result<CaveHolodeck, CompareError> {
        let path = match &s.holodeck {
            Some(p) => p.clone(),
            None => {
                let p = s.out.join("holodeck.hdk");
                if p.exists() {
                    std::fs::remove_file(&p).map_err(io(&p))?;
                }
                p
            }
        };
        CaveHolodeck::open_or_create(
            &path,
            self.cave,
            self.scene_path,
            Some(&self.scene),
            "compare",
            &[],
        )
        .map_err(|e| CompareError::Holodeck(e.to_string()))
    }

    /// Replays `poses` (one per frame) through every method; writes `error_time.csv`,
    /// `views.csv`, `summary.md`, `error_time.svg` and the measured frames' images to
    /// `s.out`. `progress` hears (method, frames done, frames).
    pub fn run(
        &self,
        s: &Settings,
        poses: &[Pose],
        progress: &mut dyn FnMut(Method, u64, u64),
    ) -> Result<Outcome, CompareError> {
        if s.methods.is_empty() {
            return Err(CompareError::NoMethods);
        }
        if poses.is_empty() {
            return Err(CompareError::NoFrames);
        }
        std::fs::create_dir_all(&s.out).map_err(io(&s.out))?;
        let views = self.views(poses, s.size)?;
        let frames = views.len() as u64;
        let measured = |f: u64| f.is_multiple_of(s.every.max(1)) || f + 1 == frames;
        let (references, reference_noise) = self.references(s, &views, &measured)?;
        let run = Run {
            views: &views,
            references: &references,
            speed: head_speeds(poses, s.fps),
            measured: &measured,
        };
        let mut rows = Vec::new();
        let mut frame_times = Vec::new();
        let mut frame_rays = Vec::new();
        for &method in &s.methods {
            let (r, times, spent) = self.run_method(method, s, &run, progress)?;
            rows.extend(r);
            frame_times.push((method.name(), times));
            frame_rays.push((method.name(), spent));
        }
        let summaries = report::summarize(&rows, &frame_times);
        self.write_reports(s, &run, (&rows, &summaries, &frame_rays), reference_noise)?;
        Ok(Outcome {
            rows,
            frame_rays,
            summaries,
            reference_noise,
            frames,
        })
    }

    /// Every measured view's reference (read or rendered once for all methods), by frame,
    /// and the references' own noise.
    fn references(
        &self,
        s: &Settings,
        views: &[Vec<EyeView>],
        measured: &dyn Fn(u64) -> bool,
    ) -> Result<(BTreeMap<u64, Vec<Image>>, f64), CompareError> {
        let scene_key = References::scene_key(self.scene_path).map_err(io(self.scene_path))?;
        let reference_tracer = Tracer::new(self.scene.clone(), TraceSettings::default());
        let refs = References {
            tracer: &reference_tracer,
            spp: s.reference_spp,
            dir: s.out.join("refs"),
            scene_key,
        };
        let noise = refs.noise(&views[0][0].wall)?;
        let mut references = BTreeMap::new();
        for (f, eyes) in views.iter().enumerate() {
            if measured(f as u64) {
                let r = eyes
                    .iter()
                    .map(|v| refs.get(&v.wall))
                    .collect::<Result<Vec<_>, _>>()?;
                references.insert(f as u64, r);
            }
        }
        Ok((references, noise))
    }

    /// Draws every frame of `run` with `method`: the measured frames' rows (their images
    /// written under `s.out/frames/METHOD`), every frame's time, and its rays traced and
    /// left unspent.
    fn run_method(
        &self,
        method: Method,
        s: &Settings,
        run: &Run,
        progress: &mut dyn FnMut(Method, u64, u64),
    ) -> Result<MethodFrames, CompareError> {
        let views = run.views;
        let frames = views.len() as u64;
        let mut drawer = self.drawer(method, s, views[0].len())?;
        let dir = s.out.join("frames").join(method.name());
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let (mut seconds, mut rays) = (0.0, 0u64);
        let mut rows = Vec::new();
        let mut times = Vec::with_capacity(views.len());
        let mut spent = Vec::with_capacity(views.len());
        for (f, eyes) in views.iter().enumerate() {
            let f = f as u64;
            let t = Instant::now();
            let drawn = drawer.draw(eyes, f);
            let dt = t.elapsed();
            seconds += dt.as_secs_f64();
            rays += drawn.rays;
            times.push(dt);
            spent.push((drawn.rays, drawn.unspent));
            progress(method, f + 1, frames);
            if !(run.measured)(f) {
                continue;
            }
            let (mut rel, mut sq) = (0.0, 0.0);
            for (e, (img, reference)) in drawn.images.iter().zip(&run.references[&f]).enumerate() {
                rel += img.relative_mse(reference);
                sq += img.mean_squared_error(reference);
                img.write_exr(&dir.join(format!("{f:05}-{e}.exr")))?;
            }
            let n = drawn.images.len().max(1) as f64;
            rows.push(Row {
                method: method.name(),
                frame: f,
                seconds,
                rays,
                rel_mse: rel / n,
                rmse: (sq / n).sqrt(),
                frame_time: dt,
                head_speed: run.speed[f as usize],
            });
        }
        if let Drawer::Holodeck {
            display, server, ..
        } = drawer
        {
            drop(display);
            server
                .stop()
                .map_err(|e| CompareError::Holodeck(e.to_string()))?;
        }
        Ok((rows, times, spent))
    }

    /// `error_time.csv`, `views.csv`, `summary.md` and `error_time.svg` in `s.out`.
    fn write_reports(
        &self,
        s: &Settings,
        run: &Run,
        (rows, summaries, frame_rays): (&[Row], &[Summary], &[MethodRays]),
        reference_noise: f64,
    ) -> Result<(), CompareError> {
        let frames = run.views.len() as u64;
        let measured_views: Vec<(u64, usize, WallView)> = (run.views.iter().enumerate())
            .filter(|(f, _)| (run.measured)(*f as u64))
            .flat_map(|(f, eyes)| {
                eyes.iter()
                    .enumerate()
                    .map(move |(e, v)| (f as u64, e, v.wall))
            })
            .collect();
        let write = |name: &str, r: std::io::Result<()>| r.map_err(io(&s.out.join(name)));
        write(
            "error_time.csv",
            report::write_csv(&s.out.join("error_time.csv"), rows),
        )?;
        write(
            "views.csv",
            report::write_views(&s.out.join("views.csv"), &measured_views),
        )?;
        let heading = format!(
            "Run time against error: wall {:?}, {frames} frames at {} Hz, {} rays per eye and frame",
            self.wall.name, s.fps, s.budget
        );
        let mut md = report::summary_markdown(summaries, reference_noise, &heading);
        md.push_str(&report::unspent_markdown(frame_rays));
        write("summary.md", std::fs::write(s.out.join("summary.md"), md))?;
        let names: Vec<&'static str> = s.methods.iter().map(|m| m.name()).collect();
        report::plot(&s.out.join("error_time.svg"), rows, &names).map_err(CompareError::Plot)
    }
}

/// A comparison's frames: every frame's eye views, the measured frames' references, the
/// head's speed at each frame (m/s) and which frames are measured.
struct Run<'a> {
    views: &'a [Vec<EyeView>],
    references: &'a BTreeMap<u64, Vec<Image>>,
    speed: Vec<f64>,
    measured: &'a dyn Fn(u64) -> bool,
}

/// A method's measured rows, every frame's time, and its rays traced and left unspent.
type MethodFrames = (Vec<Row>, Vec<Duration>, Vec<(u64, u64)>);

/// A method's name and every frame's rays traced and left unspent.
type MethodRays = (&'static str, Vec<(u64, u64)>);

/// The head's speed at each frame (m/s): its move since the frame before, `fps` a second.
fn head_speeds(poses: &[Pose], fps: f64) -> Vec<f64> {
    (0..poses.len())
        .map(|f| {
            let prev = poses[f.saturating_sub(1)].position;
            f64::from(poses[f].position.distance(prev)) * fps
        })
        .collect()
}
