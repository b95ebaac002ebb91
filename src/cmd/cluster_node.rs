//! `holocave node --master HOST:PORT`: a render node in a cluster. It draws the frames the
//! master sends, in lockstep with the other walls, and reconnects whenever the link drops.

use std::io::Write;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use holocave_master::frustum::Eye;
use holocave_master::load_cave;
use holocave_render_node::cluster::{Ended, MasterLink, NodeCounters, follow};
use holocave_render_node::{DisplayProcess, Gpu, RenderCache, ToneMapper, ToneMode, TracerSource};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::{TraceSettings, Tracer};

use super::node::{NodeArgs, write_images};

/// Pause between attempts to reach the master.
const RETRY: Duration = Duration::from_millis(100);

pub fn run(args: &NodeArgs, master: &str) -> Result<()> {
    if !args.headless {
        bail!("only --headless is supported: the windowed display is not built yet");
    }
    let cave = load_cave(&args.config)?;
    let secret = cave
        .secret()
        .map_err(|e| anyhow!("{}: {e}", args.config.display()))?;
    let wall = cave
        .walls
        .iter()
        .find(|w| w.name == args.wall)
        .with_context(|| format!("{}: no wall {:?}", args.config.display(), args.wall))?
        .clone();
    let size = args.size.unwrap_or((wall.pixels[0], wall.pixels[1]));
    let eyes = Eye::for_mode(wall.stereo);
    let scene = Scene::load(&args.scene, &LoadOptions::default())
        .with_context(|| format!("loading {}", args.scene.display()))?;
    let tracer = Arc::new(Tracer::new(Arc::new(scene), TraceSettings::default()));
    let gpu = Gpu::new()?;
    let pixels = size.0 * size.1;
    let samples = args.samples.unwrap_or((pixels / 16).max(1));
    let capacity = (pixels * eyes.len() as u32) * 5 / 4;
    let cache = RenderCache::new(gpu, &vec![size; eyes.len()], capacity, samples * 2);
    let seed = wall
        .name
        .bytes()
        .fold(1u64, |h, b| h.wrapping_mul(31) ^ u64::from(b));
    let mut display = DisplayProcess::threaded(cache, TracerSource::new(tracer, seed), samples);
    let mut tone = Some(ToneMapper::new(ToneMode::Camera));
    let dir = args.out.join(&wall.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let log_path = dir.join("presented.log");
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .with_context(|| format!("opening {}", log_path.display()))?;
    let every = args.every.max(1);
    let mut present = |state: &holocave_protocol::cluster::FrameState,
                       display: &mut DisplayProcess|
     -> Result<(), String> {
        writeln!(log, "{}", state.frame).map_err(|e| format!("{}: {e}", log_path.display()))?;
        if state.frame.is_multiple_of(every) {
            write_images(
                &dir,
                state.frame,
                eyes,
                display,
                &mut tone,
                args.debug_images,
            )
            .map_err(|e| e.to_string())?;
        }
        Ok(())
    };

    let mut counters = NodeCounters::default();
    let mut since = Instant::now();
    let mut warned = false;
    loop {
        let mut link = match MasterLink::connect(master, &cave.cluster.id, &wall.name, &secret) {
            Ok(l) => l,
            Err(e @ holocave_render_node::cluster::LinkError::Handshake { .. }) => {
                // A refusal (wrong secret, unknown wall, other version) will not go away.
                return Err(e.into());
            }
            Err(e) => {
                if !warned {
                    tracing::warn!("{e}; retrying");
                    warned = true;
                }
                if args
                    .seconds
                    .is_some_and(|s| since.elapsed().as_secs_f64() > s)
                {
                    bail!("gave up: {e}");
                }
                std::thread::sleep(RETRY);
                continue;
            }
        };
        tracing::info!(
            "wall {:?}: joined the cluster as node {} ({} Hz)",
            wall.name,
            link.welcome.node_id,
            link.welcome.rate_hz
        );
        warned = false;
        match follow(
            &mut link,
            &mut display,
            &wall,
            size,
            &mut counters,
            &mut present,
        ) {
            Ended::Shutdown(reason) => {
                println!(
                    "wall {:?}: {} frames presented, {} skipped; master: {reason}",
                    wall.name, counters.presented, counters.skipped
                );
                return Ok(());
            }
            Ended::Lost(e) => {
                tracing::warn!("wall {:?}: {e}; reconnecting", wall.name);
                since = Instant::now();
            }
        }
    }
}
