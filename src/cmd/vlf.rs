//! `holocave vlf`: bake a scene's Virtual Light Field, inspect and check the file, and
//! draw a view from it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use holocave_scene::Scene;
use holocave_scene::daylight::When;
use holocave_vlf::bake::{Settings, Stage};
use holocave_vlf::baked::{self, BakeJob, Opened, Start};
use holocave_vlf::file_summary;
use holocave_vlf::hours::{Share, open_blended};
use holocave_vlf::remote::Workers;
use holocave_vlf::{Casting, Threads, WallPass};
use indicatif::{ProgressBar, ProgressStyle};

use super::render::load_scene;
use super::view::ViewFlags;
use holocave_cave::Size;

#[derive(Subcommand)]
pub enum VlfCommand {
    /// Bake a scene's light field into a .vlf file (resumes a killed bake of the same file).
    Bake(BakeArgs),
    /// Print what a .vlf file holds.
    Info { file: PathBuf },
    /// Check a .vlf file's chunks and checksums (and, with --scene, that it fits the scene).
    Check {
        file: PathBuf,
        #[arg(long)]
        scene: Option<PathBuf>,
        #[command(flatten)]
        daylight: super::daylight_flags::DaylightFlags,
    },
    /// Draw one view from the light field alone (EXR + PNG), with `render`'s view flags.
    View(ViewArgs),
}

#[derive(Args)]
pub struct BakeArgs {
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    #[arg(long)]
    pub out: PathBuf,
    /// Directions over the sphere (rounded up to a geodesic sphere: 42, 92, 162, 252, 362,
    /// 492, 642, 812, 1002, …).
    #[arg(long, default_value_t = Settings::default().directions)]
    pub directions: usize,
    /// Lines across each parallel subfield (N of the N × N grid).
    #[arg(long, default_value_t = Settings::default().resolution)]
    pub resolution: u32,
    /// Element size in scene units (default: twice the lines' spacing).
    #[arg(long)]
    pub element_size: Option<f32>,
    /// Next-event samples per element for small lights and the sun.
    #[arg(long, default_value_t = Settings::default().direct_samples)]
    pub direct_samples: u32,
    /// Stop when the light still to propagate is below this fraction of the
    /// inter-reflected light.
    #[arg(long, default_value_t = Settings::default().tolerance)]
    pub tolerance: f64,
    /// Surfaces whose GGX alpha (roughness squared) is below this get directional
    /// radiance tiles (glossy); rougher ones are drawn as diffuse. 0: no tiles.
    #[arg(long, default_value_t = Settings::default().glossy_alpha)]
    pub glossy_alpha: f32,
    /// Bins along each side of a glossy tile (k x k over the hemisphere).
    #[arg(long, default_value_t = Settings::default().tile_bins)]
    pub tile_bins: u32,
    /// Threads of this process (default: all cores); 0 with --listen: only the worker
    /// processes cast lines.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also hand subfields out to `holocave worker --vlf` processes connecting here
    /// (the cluster's secret from HOLOCAVE_SECRET); the result is the same bit for bit.
    #[arg(long)]
    pub listen: Option<String>,
    /// The cluster's name (for --listen).
    #[arg(long, default_value = super::credentials::DEFAULT_CLUSTER)]
    pub cluster: String,
    /// A bake set: one bake every --step from --when to this time (local standard time),
    /// each into --out (a folder) named by its time, YYYY-MM-DDTHH-MM.vlf.
    #[arg(
        long,
        value_name = "TIME",
        requires = "when",
        conflicts_with = "listen"
    )]
    pub until: Option<When>,
    /// Minutes between a bake set's bakes.
    #[arg(long, default_value_t = 60, requires = "until", value_parser = clap::value_parser!(u32).range(1..))]
    pub step: u32,
    /// This machine's share of a bake set, K/N: the K-th of every N times. N machines
    /// running the same command with 1/N … N/N bake the set between them; the files of
    /// their --out folders together are the set.
    #[arg(long, value_name = "K/N", requires = "until")]
    pub share: Option<Share>,
}

#[derive(Args)]
pub struct ViewArgs {
    /// The light field (.vlf), or a bake set: a folder of bakes named by their times
    /// (YYYY-MM-DDTHH-MM.vlf), drawn at --when from the two around it, blended.
    pub file: PathBuf,
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    #[command(flatten)]
    pub view: ViewFlags,
    /// Image size WxH in pixels.
    #[arg(long, default_value = "512x512")]
    pub size: Size,
    /// Lookups per pixel along each axis (k × k, antialiasing).
    #[arg(long, default_value_t = 2)]
    pub aa: u32,
    #[arg(long)]
    pub out: PathBuf,
    /// Tone mapping of the PNG preview (default: the tracer's auto-exposed Reinhard).
    #[arg(long, value_enum)]
    pub tone: Option<super::tone::Tone>,
    /// A converged render of the same view (EXR): print the relative MSE against it.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Leave out the direct light computed per pixel: draw the light field alone, its
    /// baked direct light included (as before the walls computed it).
    #[arg(long)]
    pub no_direct: bool,
    /// Take the sky's light per pixel (two samples of the sky a frame, each with its
    /// shadow ray) and the light field less the sky's first arrival; without, the sky is
    /// the field's, its reflection sharpened per pixel where a tile widened a glossy lobe.
    #[arg(long, conflicts_with = "no_direct")]
    pub sky_per_pixel: bool,
    /// With --sky-per-pixel: the light field's sky as a prior worth K of a pixel's sky
    /// samples (default: the walls'; 0: the pixel's samples alone).
    #[arg(
        long,
        value_name = "K",
        default_value_t = holocave_vlf::view::SKY_PRIOR_SAMPLES,
        requires = "sky_per_pixel"
    )]
    pub sky_prior: f32,
    /// Frames of per-pixel direct light averaged, and of the glossy reflections'
    /// directions (up to 32): what a still wall shows after that many frames; 1: the
    /// first frame.
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// Also take N frames of gathers, one through every pixel a frame, kept in the
    /// field's elements (what a still node with --gather shows after N frames; the
    /// direct light averaged over as many frames, at least --frames).
    #[arg(long, value_name = "N", default_value_t = 0, conflicts_with_all = ["no_direct", "sky_per_pixel"])]
    pub gathers: u32,
    /// With --gathers: a baked value worth K gathers.
    #[arg(long, value_name = "K", default_value_t = holocave_vlf::kept_gathers::STILL_VIEW_PRIOR, requires = "gathers")]
    pub gather_prior: f32,
    #[command(flatten)]
    pub objects: super::render::ObjectsAt,
    /// Leave out the moving objects' darkening of the light field near them (to measure
    /// what it does; the walls always darken).
    #[arg(long)]
    pub no_darkening: bool,
}

pub fn run(c: VlfCommand) -> Result<()> {
    match c {
        VlfCommand::Bake(a) => bake(a),
        VlfCommand::Info { file } => info(&file),
        VlfCommand::Check {
            file,
            scene,
            daylight,
        } => check(&file, scene.as_deref(), daylight),
        VlfCommand::View(a) => view(a),
    }
}

/// Bakes (or finishes baking) `job`'s file with a progress bar (none when `quiet`), and
/// prints what the bake did. Ctrl-C ends it at once: its finished bounces are in the file,
/// each written whole, and the next run resumes from them.
fn run_bake(job: &BakeJob, quiet: bool, casting: &dyn Casting) -> Result<()> {
    super::interrupt::ending_at_once(bounces_kept(job.out), || {
        if !quiet {
            println!(
                "baking {} (Ctrl-C keeps the finished bounces)",
                job.out.display()
            );
        }
        bake_steps(job, quiet, casting)
    })
}

/// What a bake into `out` that Ctrl-C ends keeps.
fn bounces_kept(out: &Path) -> String {
    format!(
        "{} keeps the bounces it finished; run again to resume",
        out.display()
    )
}

/// [`run_bake`]'s steps.
fn bake_steps(job: &BakeJob, quiet: bool, casting: &dyn Casting) -> Result<()> {
    if let Start::Resumed { bounces, residual } = job.start()? {
        eprintln!(
            "resuming {} after bounce {bounces} (residual {residual:.2e})",
            job.out.display()
        );
    }
    let style =
        ProgressStyle::with_template("{msg:12} [{bar:40}] {pos}/{len} {elapsed} (eta {eta})")
            .expect("static template")
            .progress_chars("=> ");
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1)
    }
    .with_style(style);
    let max_bounces = job.settings.max_bounces;
    let progress = |s: Stage| match s {
        Stage::Visibility { done, total } => {
            bar.set_message("visibility");
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
        Stage::Direct { done, total } => {
            bar.set_message("direct");
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
        Stage::Bounce { bounce, residual } => {
            bar.set_message(format!("bounce {bounce}"));
            bar.set_length(u64::from(max_bounces));
            bar.set_position(u64::from(bounce));
            bar.println(format!("bounce {bounce}: residual {residual:.3e}"));
        }
    };
    let (file, stats) = job.run(casting, &progress)?;
    bar.finish_and_clear();
    if let (Some(stats), false) = (stats, quiet) {
        let settings = &job.settings;
        let state = &file.state;
        println!(
            "{} directions ({} subfields of {}²), {} lines cast, {} stored with {} crossings and {} links; {} elements, {} glossy tiles of {}² bins ({:.2} MB); {:.2} MB while propagating",
            stats.directions,
            stats.subfields,
            settings.resolution,
            stats.lines_cast,
            stats.lines_stored,
            stats.crossings,
            stats.links,
            stats.elements,
            stats.tiles,
            settings.tile_bins,
            stats.tile_memory as f64 / 1e6,
            stats.memory as f64 / 1e6
        );
        println!(
            "visibility {:.1} s, direct {:.1} s, propagation {:.1} s; {} bounces, residual {:.2e} of the light that arrived, tail {:.2e} of the inter-reflected light",
            stats.visibility.as_secs_f64(),
            stats.direct.as_secs_f64(),
            stats.propagation.as_secs_f64(),
            state.bounces,
            state.residual(),
            state.tail()
        );
    }
    Ok(())
}

/// The light field at `path`, baked with default settings for `scene` if it is missing,
/// unfinished, of an older format or baked for another version of the scene (set aside,
/// not removed), and kept, for `sim` and `compare`.
pub fn baked_default(scene: &Scene, path: &Path) -> Result<PathBuf> {
    let job = BakeJob {
        scene,
        settings: Settings::default(),
        out: path,
        interrupted: &super::interrupt::ctrl_c_flag(),
        kept_by_command: true,
    };
    let start = job
        .start()
        .with_context(|| format!("the light field {}", path.display()))?;
    let t = std::time::Instant::now();
    // Ctrl-C ends the bake at once from the line that says it bakes.
    super::interrupt::ending_at_once(bounces_kept(path), || {
        match start {
            Start::Fresh => println!(
                "baking the light field {} (once; kept for later runs)",
                path.display()
            ),
            _ => println!(
                "light field {} (kept from an earlier run; a bake it left unfinished is finished)",
                path.display()
            ),
        }
        run_bake(&job, true, &Threads)
    })
    .with_context(|| format!("the light field {}", path.display()))?;
    if matches!(start, Start::Fresh) {
        println!("baked in {:.1} s", t.elapsed().as_secs_f64());
    }
    Ok(path.to_owned())
}

fn bake(a: BakeArgs) -> Result<()> {
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("setting the number of bake threads")?;
    }
    let Some(until) = a.until else {
        return bake_one(&a, a.daylight.clone(), &a.out);
    };
    let (Some(When::Local(first)), When::Local(last)) = (a.daylight.when, until) else {
        bail!("a bake set's --when and --until are local standard times, without an offset");
    };
    if last < first {
        bail!("--until {last} is before --when {first}");
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let times = holocave_vlf::hours::times(first, last, a.step).map_err(anyhow::Error::msg)?;
    let share = a.share.unwrap_or(Share { k: 1, n: 1 });
    for time in share.of(&times) {
        let daylight = super::daylight_flags::DaylightFlags {
            when: Some(When::Local(time)),
            ..a.daylight.clone()
        };
        bake_one(
            &a,
            daylight,
            &a.out.join(holocave_vlf::hours::file_name(time)),
        )?;
    }
    Ok(())
}

/// One bake of `a`'s scene and settings, in `daylight`, into `out`.
fn bake_one(
    a: &BakeArgs,
    daylight: super::daylight_flags::DaylightFlags,
    out: &Path,
) -> Result<()> {
    if a.threads == Some(0) && a.listen.is_none() {
        bail!("--threads 0 leaves nobody to bake: give --listen ADDR for worker processes");
    }
    let scene = load_scene(&a.scene, daylight, false)?;
    let settings = Settings {
        directions: a.directions,
        resolution: a.resolution,
        element_size: a.element_size,
        direct_samples: a.direct_samples,
        tolerance: a.tolerance,
        glossy_alpha: a.glossy_alpha,
        tile_bins: a.tile_bins,
        ..Settings::default()
    };
    baked::validate(&settings)?;
    let job = BakeJob {
        scene: &scene,
        settings,
        out,
        interrupted: &super::interrupt::ctrl_c_flag(),
        kept_by_command: false,
    };
    let start = std::time::Instant::now();
    match &a.listen {
        Some(addr) => {
            let credentials = super::credentials::from_env(&a.cluster)?;
            let listener =
                std::net::TcpListener::bind(addr).with_context(|| format!("--listen {addr}"))?;
            println!("accepting bake workers on {}", listener.local_addr()?);
            let workers = Workers {
                listener,
                cluster: credentials.cluster,
                secret: credentials.secret,
                local: a.threads != Some(0),
                fingerprint: scene.fingerprint(),
                settings,
            };
            run_bake(&job, false, &workers)?;
        }
        None => {
            run_bake(&job, false, &Threads)?;
        }
    }
    println!(
        "wrote {} ({:.1} s)",
        out.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn info(file: &Path) -> Result<()> {
    file_summary::describe(file)?
        .iter()
        .for_each(|l| println!("{l}"));
    Ok(())
}

fn check(
    file: &Path,
    scene: Option<&Path>,
    daylight: super::daylight_flags::DaylightFlags,
) -> Result<()> {
    let scene = scene.map(|s| load_scene(s, daylight, false)).transpose()?;
    println!("{}", file_summary::check(file, scene.as_ref())?);
    Ok(())
}

/// The light field `vlf view` draws: the file, or for a bake set (a folder) the blend of
/// the two bakes around `--when`, each opened with the scene at its own time.
fn opened_for_view(a: &ViewArgs, scene: &Scene) -> Result<Opened> {
    if !a.file.is_dir() {
        return Ok(baked::open(&a.file, scene)?);
    }
    let time = (a.daylight.time_of_day(&a.scene)?)
        .context("a bake set is drawn at a time: give --when")?;
    let local = (scene.daylight.local_time(time.start))
        .map_err(|e| anyhow::anyhow!("--when {}: {e}", time.start))?;
    let open_at = |t, path: &Path| {
        let lit = time.scene_at(scene, When::Local(t))?;
        (baked::open(path, &lit).map(std::sync::Arc::new)).map_err(|e| e.to_string())
    };
    let (opened, bracket) = open_blended(&a.file, local, open_at).map_err(anyhow::Error::msg)?;
    println!(
        "the field at {local}: {} and {} blended, {:.3} of the later",
        bracket.before.1.display(),
        bracket.after.1.display(),
        bracket.t
    );
    Ok(opened)
}

fn view(a: ViewArgs) -> Result<()> {
    let scene = load_scene(&a.scene, a.daylight.clone(), false)?;
    let opened = opened_for_view(&a, &scene)?;
    let view = a.view.view(Some((&scene, &a.scene)), a.size)?;
    let efficacy = scene.daylight.photometry.efficacy;
    let start = std::time::Instant::now();
    let scene = std::sync::Arc::new(scene);
    let pass = WallPass::of_opened(scene.clone(), opened, a.sky_per_pixel)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?
        .with_darkening(!a.no_darkening)
        .with_direct(!a.no_direct)
        .with_sky_prior(a.sky_prior.max(0.0));
    pass.visibility()
        .place_objects(&a.objects.placements(&scene)?);
    let image = if pass.direct_per_pixel() {
        println!(
            "direct light per pixel: {} shadow rays per lookup and frame, {} frame(s), {} lookups per pixel",
            pass.direct().shadow_rays(),
            a.frames.max(1),
            a.aa.max(1).pow(2)
        );
        if a.gathers > 0 {
            let kept = holocave_vlf::kept_gathers::of_still_view(
                pass.visibility(),
                pass.direct(),
                pass.remainder(),
                &view,
                (a.gathers, a.gather_prior),
                &holocave_vlf::CpuRays(&scene),
            );
            let frames = a.frames.max(a.gathers);
            println!("{} frames of gathers kept in the field", a.gathers);
            pass.render(&view, kept.values(), a.aa, frames)
        } else {
            pass.render(&view, pass.values(), a.aa, a.frames)
        }
    } else {
        pass.render(&view, pass.values(), a.aa, a.frames)
    };
    let secs = start.elapsed().as_secs_f64();
    image.write_exr(&a.out)?;
    let png = a.out.with_extension("png");
    super::view::write_preview(&image, &view, a.tone, efficacy, &png)?;
    println!(
        "wrote {} and {} ({:.2} s)",
        a.out.display(),
        png.display(),
        secs
    );
    if let Some(r) = &a.reference {
        let reference = super::render::read_reference(r, &image)?;
        println!(
            "against {}: {}",
            r.display(),
            holocave_vlf::accuracy::figures(&image, &reference, 16)
        );
        if !scene.objects().is_empty() {
            let mask = pass.visibility().object_pixels(&view);
            let on = holocave_vlf::accuracy::masked(&image, &reference, &mask, 16);
            println!("on the moving objects ({} pixels): {on}", on.pixels);
            let rest: Vec<bool> = mask.iter().map(|m| !m).collect();
            let off = holocave_vlf::accuracy::masked(&image, &reference, &rest, 16);
            println!("elsewhere ({} pixels): {off}", off.pixels);
        }
    }
    Ok(())
}
