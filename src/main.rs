//! `holocave`: the one binary every machine of the cluster runs. The subcommand picks the
//! role. This file only parses arguments and hands them to the crates; no algorithms here.

mod cmd;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "holocave",
    version,
    about = "A clustered CAVE renderer with full global illumination"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a whole simulated CAVE on this machine: the master and one render-node process
    /// per wall on loopback, headless; writes every wall's frames and mosaics.
    Sim(cmd::sim::SimArgs),
    /// Run the cluster's master: head tracking, the frame clock and the swap barrier.
    Master(cmd::master::MasterArgs),
    /// Render one off-axis view of a scene as a CAVE wall sees it (EXR + PNG preview).
    Render(cmd::render::RenderArgs),
    /// Inspect a scene.
    #[command(subcommand)]
    Scene(cmd::scene::SceneCommand),
    /// Record tracker sources; evaluate and tune head-pose prediction.
    #[command(subcommand)]
    Tracking(cmd::tracking::TrackingCommand),
    /// Check a CAVE configuration and show its walls and frusta.
    #[command(subcommand)]
    Cave(cmd::cave::CaveCommand),
    /// Inspect, check, optimize or serve a holodeck file.
    #[command(subcommand)]
    Holodeck(cmd::holodeck::HolodeckCommand),
    /// Batch-fill a holodeck with worker threads or processes.
    Fill(cmd::fill::FillArgs),
    /// Run a holodeck worker process for a server.
    Worker(cmd::worker::WorkerArgs),
    /// Keep one process of a cluster running on its host (a master, a node, a worker):
    /// started again when it dies, as `sim` keeps its children.
    Supervise(cmd::supervise::SuperviseArgs),
    /// Run a render node: one wall's display process (GPU render cache), in stereo, in a
    /// cluster (--master) or by itself (--standalone).
    Node(cmd::node::NodeArgs),
    /// Bake, inspect, check or view a scene's Virtual Light Field.
    #[command(subcommand)]
    Vlf(cmd::vlf::VlfCommand),
    /// Run time against error: replay a head trace through one wall with every display
    /// method at the same ray budget, against converged references.
    Compare(cmd::compare::CompareArgs),
    /// Glare figures of one view (Ev, DGP, UGR, the glare sources, as evalglare) from its
    /// 180° fisheye, drawn from the light field or path-traced (EXR + PNG, or --json).
    Glare(cmd::glare::GlareArgs),
    /// The sun and sky of a site at a time (SPA; with an EPW weather file, the hour's DNI,
    /// DHI and Perez sky), or the sky's luminance towards given directions.
    Daylight(cmd::daylight::DaylightArgs),
}

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    // Before any command runs: every command and phase ends on Ctrl-C or SIGTERM.
    cmd::interrupt::install();
    let cli = Cli::parse();
    match cli.command {
        Command::Sim(a) => cmd::sim::run(a),
        Command::Master(a) => cmd::master::run(a),
        Command::Render(args) => cmd::render::run(args),
        Command::Scene(c) => cmd::scene::run(c),
        Command::Tracking(c) => cmd::tracking::run(c),
        Command::Cave(c) => cmd::cave::run(c),
        Command::Holodeck(c) => cmd::holodeck::run(c),
        Command::Fill(a) => cmd::fill::run(a),
        Command::Worker(a) => cmd::worker::run(a),
        Command::Supervise(a) => cmd::supervise::run(a),
        Command::Node(a) => cmd::node::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Vlf(c) => cmd::vlf::run(c),
        Command::Daylight(a) => cmd::daylight::run(a),
        Command::Glare(a) => cmd::glare::run(a),
    }
}
