//! `holocave render`: one off-axis view of a scene, as a CAVE wall sees it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::render::render;
use holocave_tracer::view::WallView;
use holocave_tracer::{TraceSettings, Tracer};
use indicatif::{ProgressBar, ProgressStyle};

/// Which view of a scene: an eye and a wall, or a glTF camera; and the image size (the
/// flags of `render` and `vlf view`).
#[derive(Args)]
pub struct ViewFlags {
    /// Eye position X,Y,Z in scene metres.
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// The screen rectangle "PA;PB;PC": lower-left, lower-right and upper-left corners.
    #[arg(long, value_parser = super::parse::wall, allow_hyphen_values = true)]
    pub wall: Option<[Vec3; 3]>,
    /// Use a glTF camera of the scene instead of --eye/--wall.
    #[arg(long, conflicts_with_all = ["eye", "wall"])]
    pub camera: Option<String>,
    /// Image size WxH in pixels.
    #[arg(long, default_value = "512x512", value_parser = super::parse::size)]
    pub size: (u32, u32),
}

#[derive(Args)]
pub struct RenderArgs {
    /// The scene (glTF 2.0: .gltf or .glb).
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub view: ViewFlags,
    /// Path samples per pixel.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Output OpenEXR file; a tone-mapped PNG preview is written beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Daylight file (default: <scene>.daylight.toml beside the scene, if present).
    #[arg(long)]
    pub daylight: Option<PathBuf>,
    /// Refuse scenes that require glTF extensions holocave does not implement.
    #[arg(long)]
    pub strict: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn load_scene(path: &Path, daylight: Option<PathBuf>, strict: bool) -> Result<Scene> {
    let opts = LoadOptions { strict, daylight };
    // The loader logs its own warnings.
    Scene::load(path, &opts).with_context(|| format!("loading scene {}", path.display()))
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

/// The view the flags give.
pub fn wall_view(scene: &Scene, scene_path: &Path, flags: &ViewFlags) -> Result<WallView> {
    let (width, height) = flags.size;
    let (camera, eye, wall) = (&flags.camera, flags.eye, flags.wall);
    match (camera, eye, wall) {
        (Some(name), _, _) => {
            let cam = scene
                .cameras
                .iter()
                .find(|c| &c.name == name)
                .with_context(|| {
                    let names: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
                    format!(
                        "{} has no camera {name:?} (it has {names:?})",
                        scene_path.display()
                    )
                })?;
            Ok(WallView::through_camera(cam, width, height))
        }
        (None, Some(eye), Some([pa, pb, pc])) => Ok(WallView {
            eye,
            pa,
            pb,
            pc,
            width,
            height,
        }),
        _ => bail!("give --eye and --wall, or --camera"),
    }
}

pub fn run(args: RenderArgs) -> Result<()> {
    let scene = load_scene(&args.scene, args.daylight.clone(), args.strict)?;
    let (width, height) = args.view.size;
    let view = wall_view(&scene, &args.scene, &args.view)?;
    let tracer = Tracer::new(Arc::new(scene), TraceSettings::default());
    let bar = ProgressBar::new(u64::from(height)).with_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} rows, {elapsed} (eta {eta})")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message(format!("{}x{} at {} spp", width, height, args.spp));
    let start = std::time::Instant::now();
    let image = render(&tracer, &view, args.spp, args.seed, &|| bar.inc(1));
    bar.finish();
    let secs = start.elapsed().as_secs_f64();
    let paths = f64::from(width) * f64::from(height) * f64::from(args.spp);
    image.write_exr(&args.out)?;
    let png = args.out.with_extension("png");
    image.write_png(&png, image.auto_exposure())?;
    println!(
        "wrote {} and {} ({:.1} s, {:.2} M paths/s)",
        args.out.display(),
        png.display(),
        secs,
        paths / secs / 1e6
    );
    Ok(())
}
