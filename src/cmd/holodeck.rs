//! `holocave holodeck info|check|optimize|serve|view|sections`: inspecting, repairing,
//! compacting, serving and viewing a holodeck file, and proposing its sections.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use clap::{Args, Subcommand};
use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_holodeck::HoloFile;
use holocave_holodeck::auth::Port;
use holocave_holodeck::file::check::{check, holds, salvage};
use holocave_holodeck::file::info::Info;
use holocave_holodeck::file::optimize::optimize;
use holocave_holodeck::free_space::{FreeSpaceOptions, propose_sections};
use holocave_holodeck::run::{RunOptions, run as run_server};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::view::{ViewOptions, reconstruct};

use super::view::ViewFlags;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::film::Image;

#[derive(Subcommand)]
pub enum HolodeckCommand {
    /// Sections, beams, samples, bytes, fragmentation, samples-per-beam histogram.
    Info { file: PathBuf },
    /// Verify every structure and beam checksum; optionally copy every intact beam out.
    Check {
        file: PathBuf,
        /// Write the intact beams to this new file.
        #[arg(long)]
        salvage: Option<PathBuf>,
        /// Also verify that every sample of this earlier copy (e.g. a salvage taken while
        /// the file was being filled) is still in the file, unchanged.
        #[arg(long)]
        holds: Option<PathBuf>,
    },
    /// Rewrite with neighbouring beams together and no free fragments (atomic replace).
    Optimize { file: PathBuf },
    /// Serve the holodeck to TCP worker processes (`holocave worker`): batch-fill it, or
    /// with --interactive answer a cluster's render nodes.
    Serve(ServeArgs),
    /// Make a picture of one view from the stored samples alone (reprojection, no tracing).
    View(ViewArgs),
    /// Propose interior sections from the scene's free space at standing height, one per
    /// room, printed as `--section` boxes for `fill`, `master` and `sim`.
    Sections(SectionsArgs),
}

#[derive(Args)]
pub struct SectionsArgs {
    #[arg(long)]
    pub scene: PathBuf,
    /// Grid cell of the floor plan, metres.
    #[arg(long, default_value_t = 0.1)]
    pub cell: f64,
    /// Eye height above the floor, metres.
    #[arg(long, default_value_t = 1.6)]
    pub eye_height: f64,
    /// Openings up to this wide (metres) separate rooms.
    #[arg(long, default_value_t = 1.2)]
    pub doorway: f64,
    /// How far a standing person keeps from walls and furniture, metres.
    #[arg(long, default_value_t = 0.25)]
    pub clearance: f64,
    /// The floor's height (default: the lowest height with about the most upward-facing
    /// area).
    #[arg(long)]
    pub floor: Option<f64>,
    /// Leave out rooms with less free floor than this, m².
    #[arg(long, default_value_t = 2.0)]
    pub min_area: f64,
}

#[derive(Args)]
pub struct ViewArgs {
    pub file: PathBuf,
    /// The scene, for --camera.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub view: ViewFlags,
    /// Image size WxH in pixels.
    #[arg(long, default_value = "256x256")]
    pub size: Size,
    /// Largest angle in degrees between a sample's ray and the eye's line of sight to it.
    #[arg(long, default_value_t = 10.0)]
    pub max_angle: f64,
    /// Fill empty pixels from their neighbours, this many pixels deep.
    #[arg(long, default_value_t = 2)]
    pub fill_holes: u32,
    /// Output OpenEXR file; a tone-mapped PNG is written beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// A `holocave render` EXR of the same view: report the relative MSE against it and
    /// use its exposure for the PNG.
    #[arg(long)]
    pub reference: Option<PathBuf>,
}

fn view_of(a: &ViewArgs) -> anyhow::Result<WallView> {
    let scene = match (&a.scene, &a.view.camera) {
        (Some(path), Some(_)) => Some((
            super::render::load_scene(path, Default::default(), false)?,
            path,
        )),
        _ => None,
    };
    a.view
        .view(scene.as_ref().map(|(s, p)| (s, p.as_path())), a.size)
}

fn run_view(a: ViewArgs) -> anyhow::Result<()> {
    let view = view_of(&a)?;
    let h = HoloFile::open(&a.file)?;
    let start = std::time::Instant::now();
    let opts = ViewOptions {
        max_angle: a.max_angle.to_radians(),
        ..Default::default()
    };
    let mut pic = reconstruct(&h, &view, &opts)?;
    let secs = start.elapsed().as_secs_f64();
    let coverage = pic.coverage();
    pic.fill_holes(a.fill_holes);
    let image = Image {
        width: pic.width,
        height: pic.height,
        pixels: pic.pixels.iter().map(|p| Vec3::from_array(*p)).collect(),
    };
    image.write_exr(&a.out)?;
    let used: Vec<u32> = pic.counts.iter().copied().filter(|&c| c > 0).collect();
    println!(
        "{}: {} samples read, {} used, {:.1}% of pixels covered, {:.1} samples per covered \
         pixel, {:.2} s",
        a.file.display(),
        pic.samples_read,
        pic.samples_used,
        100.0 * coverage,
        pic.samples_used as f64 / used.len().max(1) as f64,
        secs
    );
    let mut exposure = image.auto_exposure();
    if let Some(r) = &a.reference {
        let reference = super::render::read_reference(r, &image)?;
        exposure = reference.auto_exposure();
        let mean = |i: &Image| i.pixels.iter().sum::<Vec3>() / i.pixels.len() as f32;
        let (m, mr) = (mean(&image), mean(&reference));
        println!(
            "against {}: relative MSE {:.4} ({:.4} in 8x8-pixel blocks); mean RGB {:.4} {:.4} \
             {:.4}, reference {:.4} {:.4} {:.4}",
            r.display(),
            image.relative_mse(&reference),
            image.block_means(8).relative_mse(&reference.block_means(8)),
            m.x,
            m.y,
            m.z,
            mr.x,
            mr.y,
            mr.z
        );
    }
    let png = a.out.with_extension("png");
    image.write_png(&png, exposure)?;
    println!("wrote {} and {}", a.out.display(), png.display());
    Ok(())
}

#[derive(Args)]
pub struct ServeArgs {
    pub file: PathBuf,
    /// Address to accept workers on.
    #[arg(long, default_value = "127.0.0.1:7878")]
    pub listen: String,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long)]
    pub time: Option<f64>,
    /// Beam cache budget in MiB.
    #[arg(long, default_value_t = 256)]
    pub cache_mb: usize,
    /// Serve render nodes (a cluster's holodeck on its own host: `holocave master
    /// --holodeck-server ADDR`): trace what their eyes ask for, not the whole volume.
    #[arg(long)]
    pub interactive: bool,
    /// The cluster's name; its shared secret, which every worker and display must prove,
    /// comes from HOLOCAVE_SECRET.
    #[arg(long, default_value = super::credentials::DEFAULT_CLUSTER)]
    pub cluster: String,
}

pub fn run(c: HolodeckCommand) -> anyhow::Result<()> {
    match c {
        HolodeckCommand::Sections(a) => sections(&a)?,
        HolodeckCommand::Info { file } => {
            let h = HoloFile::open(&file)?;
            print!("{}", Info::of(&h));
        }
        HolodeckCommand::Check {
            file,
            salvage: out,
            holds: old,
        } => check_file(&file, out.as_deref(), old.as_deref())?,
        HolodeckCommand::Optimize { file } => {
            let r = optimize(&file)?;
            println!(
                "{}: {} beams, {} samples; {} -> {} bytes; {} free fragments removed",
                file.display(),
                r.beams,
                r.samples,
                r.bytes_before,
                r.bytes_after,
                r.fragments_before
            );
        }
        HolodeckCommand::View(a) => run_view(a)?,
        HolodeckCommand::Serve(a) => serve(a)?,
    }
    Ok(())
}

/// `holodeck check`: the file's commit verified, salvaged into `out` where asked, and
/// checked to hold every sample of `old` where given.
fn check_file(file: &Path, out: Option<&Path>, old: Option<&Path>) -> anyhow::Result<()> {
    let r = check(file)?;
    println!(
        "commit {}: {} beams, {} samples verified",
        r.seq, r.beams_ok, r.samples_ok
    );
    for d in &r.damage {
        println!("DAMAGED: {} at byte {}: {}", d.what, d.offset, d.detail);
    }
    if let Some(out) = out {
        let s = salvage(file, out)?;
        println!(
            "salvaged {} beams ({} samples) into {}; {} beams lost",
            s.beams,
            s.samples,
            out.display(),
            s.beams_lost
        );
    }
    if !r.is_clean() {
        anyhow::bail!("{}: {} damaged structures", file.display(), r.damage.len());
    }
    if let Some(old) = old {
        let h = holds(file, old)?;
        println!(
            "holds {}: {} beams, {} samples compared; {} beams short, {} samples changed",
            old.display(),
            h.beams,
            h.samples,
            h.beams_short,
            h.samples_changed
        );
        if !h.holds_all() {
            anyhow::bail!("{} lost samples of {}", file.display(), old.display());
        }
    }
    println!("{}: ok", file.display());
    Ok(())
}

/// `holodeck serve`: the file served to workers and displays until the time asked, or
/// Ctrl-C.
fn serve(a: ServeArgs) -> anyhow::Result<()> {
    let credentials = super::credentials::from_env(&a.cluster)?;
    let h = HoloFile::open_rw(&a.file)?;
    let scene = h.settings().get("scene").cloned().unwrap_or_default();
    let listener =
        TcpListener::bind(&a.listen).with_context(|| format!("listening on {}", a.listen))?;
    // Scripts and tests read the address from this line.
    println!(
        "holodeck workers and displays may connect to {}",
        listener.local_addr()?
    );
    std::io::Write::flush(&mut std::io::stdout())?;
    let (mode, config) = if a.interactive {
        (Mode::Interactive, ServerConfig::interactive())
    } else {
        (Mode::Batch, ServerConfig::default())
    };
    let config = ServerConfig {
        cache_bytes: a.cache_mb << 20,
        ..config
    };
    let server = Server::new(h, mode, config);
    let opts = RunOptions {
        threads: 0,
        source: None,
        listener: Some(Port {
            listener,
            credentials,
        }),
        scene,
        commit_every: Duration::from_secs(5),
        stop: super::interrupt::ctrl_c_flag(),
    };
    let limit = a.time.map(Duration::from_secs_f64);
    let server = run_server(server, opts, |p| limit.is_some_and(|l| p.elapsed >= l))?;
    let s = server.stats();
    println!(
        "added {} samples; the holodeck holds {}",
        s.added, s.samples
    );
    if super::interrupt::interrupted() {
        super::interrupt::exit_interrupted(&format!(
            "{} keeps its {} samples (committed)",
            a.file.display(),
            s.samples
        ));
    }
    Ok(())
}

fn sections(a: &SectionsArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene, &LoadOptions::default())
        .with_context(|| format!("--scene {}", a.scene.display()))?;
    let options = FreeSpaceOptions {
        cell: a.cell,
        eye_height: a.eye_height,
        clearance: a.clearance,
        doorway: a.doorway,
        floor: a.floor,
        min_area: a.min_area,
    };
    let rooms =
        propose_sections(&scene, &options).with_context(|| a.scene.display().to_string())?;
    let mut args = String::new();
    for (i, r) in rooms.iter().enumerate() {
        println!(
            "room {i}: {:.1} m² of floor, {:.0}% of it under its {} section(s)",
            r.area,
            100.0 * r.covered,
            r.sections.len()
        );
        for b in &r.sections {
            let (lo, hi) = (b.lo, b.hi);
            println!("  {lo:.2} .. {hi:.2}");
            args += &format!(
                " --section {:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
            );
        }
    }
    println!("{args}");
    Ok(())
}
