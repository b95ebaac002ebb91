//! `holocave node --master HOST:PORT`: a render node in a cluster. It draws the frames the
//! master sends, in lockstep with the other walls, and reconnects whenever the link drops.
//! Its samples come from the cluster's holodeck when the master names one (requests for
//! its eyes' pixels, answered from the file or traced by the workers), else from a tracer
//! thread of its own.

use std::io::Write;
use std::net::{IpAddr, SocketAddr, ToSocketAddrs};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use holocave_master::frustum::Eye;
use holocave_master::load_cave;
use holocave_render_node::cluster::{Ended, MasterLink, NodeCounters, follow};
use holocave_render_node::{
    DisplayProcess, Gpu, HolodeckSource, RenderCache, ToneMapper, ToneMode, TracerSource,
};
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
    // The wall's display id at the holodeck is its place in the config (every node reads
    // the same config).
    let (display_id, wall) = cave
        .walls
        .iter()
        .enumerate()
        .find(|(_, w)| w.name == args.wall)
        .map(|(i, w)| (i as u32, w.clone()))
        .with_context(|| format!("{}: no wall {:?}", args.config.display(), args.wall))?;
    let size = args.size.unwrap_or((wall.pixels[0], wall.pixels[1]));
    let eyes = Eye::for_mode(wall.stereo);
    let scene = Scene::load(&args.scene, &LoadOptions::default())
        .with_context(|| format!("loading {}", args.scene.display()))?;
    let tracer = Arc::new(Tracer::new(Arc::new(scene), TraceSettings::default()));
    let make = Maker {
        size,
        eyes: eyes.len() as u32,
        samples: args.samples.unwrap_or((size.0 * size.1 / 16).max(1)),
        tracer,
        seed: wall
            .name
            .bytes()
            .fold(1u64, |h, b| h.wrapping_mul(31) ^ u64::from(b)),
        display_id,
        master_ip: master
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .map(|a| a.ip()),
    };
    // The display and the holodeck it draws from (`None`: tracing locally).
    let mut display: Option<(Option<String>, DisplayProcess)> = None;
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
        let wanted = link.welcome.holodeck.clone();
        loop {
            // Keep the display while it serves what the master names: a live link to that
            // holodeck, or local tracing when it names none. A wall tracing locally because
            // the holodeck was unreachable tries it again here.
            let made = match display.take() {
                Some((using, d)) if using == wanted && !d.source_lost() => (using, d),
                old => {
                    drop(old);
                    make.display(wanted.as_deref())?
                }
            };
            let display = &mut display.insert(made).1;
            match follow(&mut link, display, &wall, size, &mut counters, &mut present) {
                Ended::SourceLost => tracing::warn!(
                    "wall {:?}: the holodeck went away; reconnecting to it (or tracing locally)",
                    wall.name
                ),
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
                    break;
                }
            }
        }
    }
}

/// Makes the node's display process for the holodeck the master names.
struct Maker {
    size: (u32, u32),
    eyes: u32,
    samples: u32,
    tracer: Arc<Tracer>,
    seed: u64,
    display_id: u32,
    /// The master's address: a holodeck on an unspecified address (0.0.0.0) is there.
    master_ip: Option<IpAddr>,
}

impl Maker {
    /// The display, and the holodeck address it draws from (`None`: tracing locally).
    fn display(&self, holodeck: Option<&str>) -> Result<(Option<String>, DisplayProcess)> {
        let gpu = Gpu::new()?;
        let pixels = self.size.0 * self.size.1;
        let capacity = pixels * self.eyes * 5 / 4;
        let sizes = vec![self.size; self.eyes as usize];
        let cache = RenderCache::new(gpu, &sizes, capacity, self.samples * 2);
        let local = |cache| {
            let source = TracerSource::new(self.tracer.clone(), self.seed);
            DisplayProcess::threaded(cache, source, self.samples)
        };
        let Some(addr) = holodeck else {
            return Ok((None, local(cache)));
        };
        let connected = self.resolve(addr).and_then(|a| {
            HolodeckSource::connect(a, self.display_id).map_err(|e| anyhow!("{a}: {e}"))
        });
        Ok(match connected {
            Ok(source) => {
                tracing::info!("drawing from the holodeck at {addr}");
                let display = DisplayProcess::holodeck(cache, source, self.samples);
                (Some(addr.to_owned()), display)
            }
            Err(e) => {
                // A wall that shows something beats a black one: trace locally.
                tracing::warn!("holodeck {addr}: {e:#}; tracing this wall's samples locally");
                (None, local(cache))
            }
        })
    }

    fn resolve(&self, addr: &str) -> Result<SocketAddr> {
        let mut a = addr
            .to_socket_addrs()
            .with_context(|| format!("the holodeck address {addr:?}"))?
            .next()
            .with_context(|| format!("the holodeck address {addr:?} resolves to nothing"))?;
        if a.ip().is_unspecified()
            && let Some(ip) = self.master_ip
        {
            a.set_ip(ip);
        }
        Ok(a)
    }
}
