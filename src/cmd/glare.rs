//! `holocave glare`: the glare figures of one view (Ev, DGP, UGR and the glare sources,
//! by `evalglare`'s rules) from its 180° fisheye, drawn from the light field as the walls
//! draw (`--vlf`) or path-traced.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use holocave_glare::draw::Drawing;
use holocave_glare::live::LiveGlare;
use holocave_glare::log::GLARE_CSV;
use holocave_glare::meter::GlareMeter;
use holocave_glare::picture::{write_preview, write_radiance_hdr};
use holocave_glare::{Fisheye, LuminanceMap, Rules, Threshold, evaluate};
use holocave_tracer::{TraceSettings, Tracer};

use super::render::load_scene;

#[derive(Args)]
pub struct GlareArgs {
    /// The scene (glTF 2.0: .gltf or .glb).
    #[arg(long)]
    pub scene: PathBuf,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
    /// Eye position X,Y,Z in scene metres.
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true)]
    pub eye: Vec3,
    /// View direction X,Y,Z (the fisheye's centre).
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true)]
    pub look: Vec3,
    /// Up X,Y,Z (the fisheye's first row; the position index's vertical).
    #[arg(long, value_parser = super::parse::vec3, allow_hyphen_values = true, default_value = "0,1,0")]
    pub up: Vec3,
    /// Draw the fisheye from this light field as the walls draw it (its lookups plus the
    /// direct light per pixel); without it, path-trace it (the reference).
    #[arg(long)]
    pub vlf: Option<PathBuf>,
    /// Path samples per pixel (without --vlf; default 64, with --annual 16).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Light-field lookups per pixel along each axis (with --vlf).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub aa: u32,
    /// With --vlf: frames of per-pixel direct light averaged (a still wall's after that
    /// many frames).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// With --vlf: leave out the direct light per pixel (the light field alone).
    #[arg(long)]
    pub no_direct: bool,
    /// The fisheye's size N (N × N pixels; default 512, with --annual 256).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub size: Option<u32>,
    /// The fisheye's radiance (OpenEXR, the scene's units); a PNG with the glare sources
    /// outlined is written beside it. With --annual: the hours' CSV, and the temporal map
    /// (PNG) beside it.
    #[arg(long)]
    pub out: PathBuf,
    #[command(flatten)]
    pub annual: super::glare_annual::AnnualFlags,
    /// Also write the fisheye's luminance as a Radiance picture (-vta) for evalglare.
    #[arg(long)]
    pub hdr: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Glare source threshold as evalglare's -b: above 100 a luminance in cd/m², else a
    /// factor of the view's mean luminance.
    #[arg(long, default_value_t = 2000.0, allow_negative_numbers = true)]
    pub threshold: f64,
    /// Search radius for merging source pixels, radians (evalglare's -r), at most 0.5.
    #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
    pub search_radius: f64,
    /// No peak extraction (evalglare's -x); otherwise pixels from 50 000 cd/m² up are
    /// sources of their own.
    #[arg(long)]
    pub no_peaks: bool,
    /// No low-light correction of DGP below 1000 lx.
    #[arg(long)]
    pub no_low_light: bool,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(a: GlareArgs) -> Result<()> {
    let rules = rules(&a)?;
    if a.annual.annual {
        let run = super::glare_annual::AnnualRun {
            scene: &a.scene,
            daylight: &a.daylight,
            view: [a.eye, a.look, a.up],
            size: a.size,
            spp: a.spp,
            seed: a.seed,
            out: &a.out,
            json: a.json,
        };
        return super::glare_annual::run(&run, &a.annual, &rules);
    }
    let size = a.size.unwrap_or(512);
    let spp = a.spp.unwrap_or(64);
    let fisheye = Fisheye::new(size, a.eye, a.look, a.up).context("--eye, --look and --up")?;
    if a.out.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "--out {}: give an .exr file (a PNG is written beside it)",
            a.out.display()
        );
    }
    let scene = Arc::new(load_scene(&a.scene, a.daylight.clone(), false)?);
    let photometry = scene.daylight.photometry;
    let (drawing, how) = match &a.vlf {
        Some(path) => {
            let opened = holocave_vlf::baked::open(path, &scene)
                .with_context(|| format!("--vlf {}", path.display()))?;
            let how = format!("from the light field {}", path.display());
            (
                Drawing::light_field(scene.clone(), opened, a.no_direct, a.frames, a.aa),
                how,
            )
        }
        None => (
            Drawing::PathTraced {
                tracer: Box::new(Tracer::new(scene.clone(), TraceSettings::default())),
                spp,
                seed: a.seed,
            },
            format!("path traced at {spp} spp"),
        ),
    };
    let start = std::time::Instant::now();
    let nothing = format!(
        "nothing written ({} is written once the fisheye is drawn)",
        a.out.display()
    );
    let image = super::interrupt::ending_at_once(nothing, || {
        tracing::info!("drawing the {size}x{size} fisheye {how} (Ctrl-C ends it, writing nothing)");
        drawing.draw(&fisheye)
    });
    let secs = start.elapsed().as_secs_f64();
    let map = LuminanceMap::from_radiance(fisheye.clone(), &image, &photometry)
        .context("the drawn fisheye")?;
    let figures = evaluate(&map, &rules)?;
    image.write_exr(&a.out)?;
    let png = a.out.with_extension("png");
    write_preview(&png, &image, &figures)?;
    if let Some(hdr) = &a.hdr {
        write_radiance_hdr(hdr, &fisheye, &map.luminance)?;
    }
    if a.json {
        println!("{}", figures.to_json());
        return Ok(());
    }
    println!(
        "wrote {} and {} ({size}x{size} fisheye {how}, {secs:.1} s; efficacy {} lm/W)",
        a.out.display(),
        png.display(),
        photometry.efficacy
    );
    print!("{}", figures.report());
    Ok(())
}

/// The glare rules the flags ask for.
fn rules(a: &GlareArgs) -> Result<Rules> {
    let rules = Rules {
        threshold: Threshold::from_evalglare(a.threshold).context("--threshold")?,
        search_radius: a.search_radius,
        peak_limit: (!a.no_peaks)
            .then_some(Rules::default().peak_limit)
            .flatten(),
        low_light: !a.no_low_light,
    };
    rules.validate()?;
    Ok(rules)
}

/// Glare measured live while a session runs (`master --glare`, `node --standalone
/// --glare`): `size`² fisheyes from the light field `vlf`, into `dir/glare.csv`.
pub(crate) fn start_live(
    scene: &Arc<holocave_scene::Scene>,
    vlf: &std::path::Path,
    size: u32,
    dir: &std::path::Path,
) -> Result<LiveGlare> {
    Ok(LiveGlare::start_in(
        GlareMeter::of_light_field(scene, vlf, size)?,
        dir,
    )?)
}

/// Stops live glare and prints the session's summary.
pub(crate) fn finish_live(glare: LiveGlare, dir: &std::path::Path) -> Result<()> {
    let summary = glare.finish()?;
    println!(
        "glare of the head's view in {}: {summary}",
        dir.join(GLARE_CSV).display()
    );
    Ok(())
}
