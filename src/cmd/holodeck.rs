//! `holocave holodeck info|check|optimize|serve`: inspecting, repairing, compacting and
//! serving a holodeck file.

use std::net::TcpListener;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, Subcommand};
use holocave_holodeck::HoloFile;
use holocave_holodeck::file::check::{check, salvage};
use holocave_holodeck::file::info::Info;
use holocave_holodeck::file::optimize::optimize;
use holocave_holodeck::run::{RunOptions, run as run_server};
use holocave_holodeck::server::{Mode, Server, ServerConfig};

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
    },
    /// Rewrite with neighbouring beams together and no free fragments (atomic replace).
    Optimize { file: PathBuf },
    /// Batch-fill the holodeck with TCP worker processes (`holocave worker`) only.
    Serve(ServeArgs),
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
}

pub fn run(c: HolodeckCommand) -> anyhow::Result<()> {
    match c {
        HolodeckCommand::Info { file } => {
            let h = HoloFile::open(&file)?;
            print!("{}", Info::of(&h));
        }
        HolodeckCommand::Check { file, salvage: out } => {
            let r = check(&file)?;
            println!(
                "commit {}: {} beams, {} samples verified",
                r.seq, r.beams_ok, r.samples_ok
            );
            for d in &r.damage {
                println!("DAMAGED: {} at byte {}: {}", d.what, d.offset, d.detail);
            }
            if let Some(out) = out {
                let s = salvage(&file, &out)?;
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
            println!("{}: ok", file.display());
        }
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
        HolodeckCommand::Serve(a) => {
            let h = HoloFile::open_rw(&a.file)?;
            let scene = h.settings().get("scene").cloned().unwrap_or_default();
            let listener = TcpListener::bind(&a.listen)
                .with_context(|| format!("listening on {}", a.listen))?;
            tracing::info!(
                "serving {} to workers on {}",
                a.file.display(),
                listener.local_addr()?
            );
            let config = ServerConfig {
                cache_bytes: a.cache_mb << 20,
                ..Default::default()
            };
            let server = Server::new(h, Mode::Batch, config);
            let opts = RunOptions {
                threads: 0,
                source: None,
                listener: Some(listener),
                scene,
                commit_every: Duration::from_secs(5),
            };
            let limit = a.time.map(Duration::from_secs_f64);
            let server = run_server(server, opts, |p| limit.is_some_and(|l| p.elapsed >= l))?;
            let s = server.stats();
            println!(
                "added {} samples; the holodeck holds {}",
                s.added, s.samples
            );
        }
    }
    Ok(())
}
