//! `holocave worker --server HOST:PORT --scene S`: a holodeck worker process. It loads the
//! scene, connects to the holodeck server (proving the cluster's secret, from
//! `HOLOCAVE_SECRET`) and traces the ray packets it is sent until the server says goodbye.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use holocave_holodeck::worker::run_remote;
use holocave_tracer::holodeck::{HolodeckTracer, scene_identity};
use holocave_tracer::{TraceSettings, Tracer};

#[derive(Args)]
pub struct WorkerArgs {
    /// The holodeck server to work for.
    #[arg(long)]
    pub server: String,
    /// The scene to trace (the one the holodeck was made with).
    #[arg(long)]
    pub scene: PathBuf,
    /// The cluster's name; its shared secret comes from HOLOCAVE_SECRET.
    #[arg(long, default_value = super::credentials::DEFAULT_CLUSTER)]
    pub cluster: String,
    /// Work for a light-field bake (`holocave vlf bake --listen`) instead of a holodeck.
    #[arg(long)]
    pub vlf: bool,
    #[command(flatten)]
    pub daylight: super::daylight_flags::DaylightFlags,
}

/// Loads a scene (with `daylight`, else the file beside it) and makes its sample generator.
pub fn load_source(
    scene: &Path,
    daylight: super::daylight_flags::DaylightFlags,
) -> anyhow::Result<HolodeckTracer> {
    let s = super::render::load_scene(scene, daylight, false)?;
    Ok(HolodeckTracer(Tracer::new(
        Arc::new(s),
        TraceSettings::default(),
    )))
}

pub fn run(args: WorkerArgs) -> anyhow::Result<()> {
    let credentials = super::credentials::from_env(&args.cluster)?;
    if args.vlf {
        let scene = super::render::load_scene(&args.scene, args.daylight.clone(), false)?;
        let cast = holocave_vlf::remote::work(
            &args.server,
            &credentials.cluster,
            &credentials.secret,
            &scene,
        )
        .with_context(|| format!("light-field bake at {}", args.server))?;
        tracing::info!("bake worker done: {cast} subfields cast");
        return Ok(());
    }
    let source = load_source(&args.scene, args.daylight.clone())?;
    let name = format!("pid {}", std::process::id());
    let report = run_remote(
        &args.server,
        &credentials,
        &name,
        &scene_identity(&args.scene, source.0.scene()),
        &source,
    )?;
    tracing::info!(
        "worker {} done: {} packets, {} rays ({} distance)",
        report.worker_id,
        report.packets,
        report.rays,
        report.distance.name()
    );
    Ok(())
}
