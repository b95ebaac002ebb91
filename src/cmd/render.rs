//! `holocave render`: one off-axis view of a scene, as a CAVE wall sees it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;

use super::view::ViewFlags;
use holocave_cave::Size;
use holocave_scene::{LoadOptions, ObjectPaths, Placement, Scene};
use holocave_tracer::render::render;
use holocave_tracer::{TraceSettings, Tracer};
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Args)]
pub struct RenderArgs {
    /// The scene (glTF 2.0: .gltf or .glb).
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub view: ViewFlags,
    /// Image size WxH in pixels.
    #[arg(long, default_value = "512x512")]
    pub size: Size,
    /// Path samples per pixel.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Output OpenEXR file; a tone-mapped PNG preview is written beside it.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// Refuse scenes that require glTF extensions holocave does not implement.
    #[arg(long)]
    pub strict: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Tone mapping of the PNG preview (default: the tracer's auto-exposed Reinhard).
    #[arg(long, value_enum)]
    pub tone: Option<super::tone::Tone>,
    #[command(flatten)]
    pub objects: ObjectsAt,
}

/// Where a still image puts the scene's moving objects.
#[derive(Args, Clone, Debug)]
pub struct ObjectsAt {
    /// Moving objects' paths (CSV `object,time_s,tx,ty,tz,qx,qy,qz,qw`); without it the
    /// objects stand where the scene has them.
    #[arg(long, value_name = "FILE")]
    pub objects: Option<PathBuf>,
    /// The time on the paths (seconds) the objects are taken at.
    #[arg(long, default_value_t = 0.0, requires = "objects")]
    pub time: f64,
}

impl ObjectsAt {
    /// Every moving object's placement, in the scene's order.
    pub fn placements(&self, scene: &Scene) -> Result<Vec<Placement>> {
        Ok(match &self.objects {
            Some(path) => read_object_paths(path, scene)?.placements_at(scene, self.time),
            None => scene.rest_placements(),
        })
    }
}

/// Reads a moving objects' path file and checks it against `scene`.
pub fn read_object_paths(path: &Path, scene: &Scene) -> Result<ObjectPaths> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading the objects' paths {}", path.display()))?;
    if scene.objects().is_empty() {
        bail!(
            "{}: scene {} has no moving objects (mark glTF nodes with \
             extras.holocave.movable, or name them in [[object]] of its daylight file)",
            path.display(),
            scene.name
        );
    }
    let paths = ObjectPaths::parse(&text, path)?;
    paths.check(scene)?;
    Ok(paths)
}

pub fn load_scene(
    path: &Path,
    daylight: super::daylight_flags::DaylightFlags,
    strict: bool,
) -> Result<Scene> {
    let opts = LoadOptions {
        strict,
        moment: daylight.moment()?,
        daylight: daylight.daylight,
        ..Default::default()
    };
    // The loader logs its own warnings.
    Scene::load(path, &opts).with_context(|| format!("loading scene {}", path.display()))
}

/// A scene loaded the first time a command needs it and shared after that (a large scene's
/// BVH takes seconds to build).
pub struct SharedScene {
    path: PathBuf,
    daylight: super::daylight_flags::DaylightFlags,
    loaded: std::cell::OnceCell<std::sync::Arc<Scene>>,
}

impl SharedScene {
    pub fn new(path: &Path, daylight: super::daylight_flags::DaylightFlags) -> Self {
        SharedScene {
            path: path.to_owned(),
            daylight,
            loaded: std::cell::OnceCell::new(),
        }
    }

    pub fn get(&self) -> Result<std::sync::Arc<Scene>> {
        if let Some(s) = self.loaded.get() {
            return Ok(s.clone());
        }
        let s = std::sync::Arc::new(load_scene(&self.path, self.daylight.clone(), false)?);
        Ok(self.loaded.get_or_init(|| s).clone())
    }
}

/// A converged render to compare `image` with: read from `path`, the same size.
pub fn read_reference(
    path: &Path,
    image: &holocave_tracer::film::Image,
) -> Result<holocave_tracer::film::Image> {
    let reference = holocave_tracer::film::Image::read_exr(path)
        .with_context(|| format!("reading reference {}", path.display()))?;
    if (reference.width, reference.height) != (image.width, image.height) {
        bail!(
            "{} is {}x{}, the view {}x{}",
            path.display(),
            reference.width,
            reference.height,
            image.width,
            image.height
        );
    }
    Ok(reference)
}

pub fn run(args: RenderArgs) -> Result<()> {
    let scene = load_scene(&args.scene, args.daylight.clone(), args.strict)?;
    // The path tracer sees the moving objects where they stand, as part of the scene.
    let scene = if scene.objects().is_empty() {
        scene
    } else {
        scene.with_objects_at(&args.objects.placements(&scene)?)?
    };
    let efficacy = scene.daylight.photometry.efficacy;
    let Size { width, height } = args.size;
    let view = args.view.view(Some((&scene, &args.scene)), args.size)?;
    let tracer = Tracer::new(Arc::new(scene), TraceSettings::default());
    let bar = ProgressBar::new(u64::from(height)).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} rows, {elapsed} (eta {eta})")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message(format!("{}x{} at {} spp", width, height, args.spp));
    let start = std::time::Instant::now();
    let nothing = format!(
        "nothing written ({} is written once the render ends)",
        args.out.display()
    );
    let image = super::interrupt::ending_at_once(nothing, || {
        tracing::info!(
            "rendering {width}x{height} at {} spp (Ctrl-C ends it, writing nothing)",
            args.spp
        );
        render(&tracer, &view, args.spp, args.seed, &|| bar.inc(1))
    });
    bar.finish();
    let secs = start.elapsed().as_secs_f64();
    let paths = f64::from(width) * f64::from(height) * f64::from(args.spp);
    image.write_exr(&args.out)?;
    let png = args.out.with_extension("png");
    super::view::write_preview(&image, &view, args.tone, efficacy, &png)?;
    println!(
        "wrote {} and {} ({:.1} s, {:.2} M paths/s)",
        args.out.display(),
        png.display(),
        secs,
        paths / secs / 1e6
    );
    Ok(())
}
