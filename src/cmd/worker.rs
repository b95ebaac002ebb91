//! `holocave worker --server HOST:PORT --scene S`: a holodeck worker process. It loads the
//! scene, connects to the holodeck server (proving the cluster's secret, from
//! `HOLOCAVE_SECRET`) and traces the ray packets it is sent until the server says goodbye;
//! a server that goes away without one (its master died) is connected to again.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use holocave_holodeck::worker::{WorkerError, WorkerReport, run_remote};
use holocave_tracer::holodeck::{sample_source, scene_identity};

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
    /// When the holodeck server goes away without a goodbye (its master died), connect to
    /// it again every 0.2 s for up to this many seconds (a resumed master is back within
    /// them), then fail.
    #[arg(long, default_value_t = 30.0, value_name = "SECONDS")]
    pub reconnect_for: f64,
}

/// How long a worker that lost its server waits between tries to connect again.
const RECONNECT_EVERY: Duration = Duration::from_millis(200);

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
    let loaded = super::render::load_scene(&args.scene, args.daylight.clone(), false)?;
    let scene = scene_identity(&args.scene, &loaded);
    let source = sample_source(Arc::new(loaded));
    let source = &*source;
    let name = format!("pid {}", std::process::id());
    let mut report = run_remote(&args.server, &credentials, &name, &scene, source)?;
    while !report.said_goodbye {
        tracing::warn!(
            "worker {}: the holodeck server at {} went away; connecting again",
            report.worker_id,
            args.server
        );
        report = reconnect(&args, || {
            run_remote(&args.server, &credentials, &name, &scene, source)
        })?;
    }
    tracing::info!(
        "worker {} done: {} packets, {} rays ({} distance)",
        report.worker_id,
        report.packets,
        report.rays,
        report.distance.name()
    );
    Ok(())
}

/// Runs `session` again until the server takes this worker, for up to `--reconnect-for`
/// seconds: a server that cannot be reached yet ([`WorkerError::is_unreachable`]) is tried
/// again; any other failure (a refused secret, a wrong scene) ends the worker.
fn reconnect(
    args: &WorkerArgs,
    mut session: impl FnMut() -> Result<WorkerReport, WorkerError>,
) -> anyhow::Result<WorkerReport> {
    let since = Instant::now();
    loop {
        match session() {
            Err(e) if e.is_unreachable() && since.elapsed().as_secs_f64() < args.reconnect_for => {
                std::thread::sleep(RECONNECT_EVERY)
            }
            Err(e) => {
                return Err(e).with_context(|| {
                    format!(
                        "the holodeck server went away {:.1} s ago",
                        since.elapsed().as_secs_f64()
                    )
                });
            }
            Ok(report) => return Ok(report),
        }
    }
}
