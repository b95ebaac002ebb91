//! A render node's life in a cluster (`holocave node --master`): join the master (retrying
//! while it is not up; a refused handshake is final), follow its frames, reconnect when the
//! link drops, and draw from the holodeck the master names. The display (and with it the
//! render cache) is kept across reconnections while the master names the same holodeck;
//! a holodeck that cannot be reached, or goes away, is replaced by local tracing, because
//! a wall that shows something beats a black one.

use std::net::{IpAddr, SocketAddr, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use holocave_cave::{Eye, Size, Wall};
use holocave_holodeck::auth::Credentials;
use holocave_scene::Scene;
use holocave_tracer::Tracer;

use crate::cluster::{Ended, LinkError, MasterLink, NodeCounters, Presentation, follow};
use crate::gpu_rays::Rays;
use crate::{
    DisplayBuilder, Feed, Gpu, HolodeckSource, LightField, Prior, RenderNodeError, VlfBase,
    VlfDrawing, WallDisplay,
};

/// Pause between attempts to reach the master.
const RETRY: Duration = Duration::from_millis(100);

/// Why a cluster node stopped without the master telling it to.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A refusal (wrong secret, unknown wall, other version) will not go away by retrying.
    #[error("{0}")]
    Refused(LinkError),
    #[error("gave up after {seconds} s: {source}")]
    GaveUp { seconds: f64, source: LinkError },
    #[error(transparent)]
    Gpu(#[from] RenderNodeError),
}

/// Who the node is in the cluster.
pub struct Membership {
    /// The master's `HOST:PORT`.
    pub master: String,
    /// The cluster's name and shared secret.
    pub cluster: String,
    pub secret: Vec<u8>,
    pub wall: Wall,
    /// Stop retrying a master that cannot be reached after this long.
    pub give_up_after: Option<Duration>,
    /// Added to every frame's drawing: a wall made slow on purpose (tests of frame lock).
    pub slow_by: Duration,
}

/// Makes the wall display for the holodeck the master names.
pub struct DisplayMaker {
    /// The wall's displays, tracing locally when there is no holodeck.
    builder: DisplayBuilder,
    display_id: u32,
    /// The master's address: a holodeck on an unspecified address (0.0.0.0) is there.
    master_ip: Option<IpAddr>,
    /// What the holodeck server asks of its displays: the cluster's name and secret.
    credentials: Credentials,
    /// The light field to draw under the samples: the node's own file, else the one the
    /// master names (read once per path).
    vlf: Option<VlfChoice>,
}

/// How a cluster node draws its light field.
#[derive(Clone, Debug)]
pub struct VlfOptions {
    /// The node's own file; `None`: the one the master names.
    pub own: Option<PathBuf>,
    /// How many samples the light field is worth in a pixel.
    pub prior: Prior,
    /// Without a holodeck, the node's own samples are gathers over the light field.
    pub gather: bool,
    /// What the wall computes per pixel and where its rays go.
    pub drawing: VlfDrawing,
}

struct VlfChoice {
    scene: Arc<Scene>,
    options: VlfOptions,
    /// The device for the GPU's rays (the window's, else one of the light field's own).
    gpu: Option<Gpu>,
    loaded: Mutex<Option<(PathBuf, Arc<VlfBase>)>>,
}

impl VlfChoice {
    /// The light field to draw given what the master names; `None` when there is none or
    /// it cannot be read (said in the log: the wall then shows its samples alone).
    fn base(&self, named: Option<&str>) -> Option<Arc<VlfBase>> {
        let path = (self.options.own.clone()).or_else(|| named.map(PathBuf::from))?;
        let mut loaded = self.loaded.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((p, b)) = loaded.as_ref()
            && *p == path
        {
            return Some(b.clone());
        }
        match self.open(&path) {
            Ok(b) => {
                let b = Arc::new(b);
                *loaded = Some((path, b.clone()));
                Some(b)
            }
            Err(e) => {
                tracing::error!("{e}; this wall draws its samples without the light field");
                None
            }
        }
    }

    /// Opens the file as the options draw it.
    fn open(&self, path: &std::path::Path) -> Result<VlfBase, RenderNodeError> {
        VlfBase::for_wall(
            path,
            self.scene.clone(),
            self.options.drawing,
            self.gpu.as_ref(),
        )
    }
}

impl DisplayMaker {
    /// Displays of the member's wall at `size` pixels per eye asking for `samples` per eye and frame,
    /// tracing locally with `tracer` when there is no holodeck. `display_id` names the
    /// wall at the holodeck (its place in the config, which every node reads alike).
    pub fn new(
        member: &Membership,
        display_id: u32,
        size: Size,
        samples: u32,
        tracer: Arc<Tracer>,
    ) -> DisplayMaker {
        let wall = &member.wall;
        let mut builder =
            DisplayBuilder::new(size, Eye::for_mode(wall.stereo).len(), samples, tracer);
        builder.seed = wall
            .name
            .bytes()
            .fold(1u64, |h, b| h.wrapping_mul(31) ^ u64::from(b));
        DisplayMaker {
            builder,
            display_id,
            master_ip: member
                .master
                .to_socket_addrs()
                .ok()
                .and_then(|mut a| a.next())
                .map(|a| a.ip()),
            credentials: Credentials {
                cluster: member.cluster.clone(),
                secret: member.secret.clone(),
            },
            vlf: None,
        }
    }

    /// Draws a light field under the samples, as `options` say; it must have been baked
    /// for `scene`. Its rays go to the display's device when [`Self::with_gpu`] came
    /// first; without a window's device, one device is opened now for the displays and the
    /// light field's rays alike (the lookups are composed where the cache reads them).
    pub fn with_vlf(mut self, scene: Arc<Scene>, options: VlfOptions) -> DisplayMaker {
        if self.builder.gpu.is_none() && options.drawing.rays != Rays::Cpu {
            match Gpu::new() {
                Ok(gpu) => self.builder.gpu = Some(gpu),
                Err(e) => tracing::warn!("{e}; each display opens its own device"),
            }
        }
        let choice = VlfChoice {
            scene,
            options,
            gpu: self.builder.gpu.clone(),
            loaded: Mutex::new(None),
        };
        // The node's own file is read now, before it joins: reading it after the welcome
        // would hold up the cluster's first frames.
        if choice.options.own.is_some() {
            choice.base(None);
        }
        self.vlf = Some(choice);
        self
    }

    /// Draws on `gpu` (the device that presents to the node's windows).
    pub fn with_gpu(mut self, gpu: Gpu) -> DisplayMaker {
        self.builder.gpu = Some(gpu);
        self
    }

    /// Pixels per eye.
    pub fn size(&self) -> Size {
        self.builder.size
    }

    /// The display, and the holodeck address it draws from (`None`: tracing locally).
    fn display(
        &self,
        holodeck: Option<&str>,
        vlf: Option<&str>,
    ) -> Result<(Option<String>, WallDisplay), RenderNodeError> {
        let mut builder = self.builder.clone();
        builder.gather = self.vlf.as_ref().is_some_and(|c| c.options.gather);
        builder.light_field = self.vlf.as_ref().and_then(|c| {
            Some(LightField {
                base: c.base(vlf)?,
                prior: c.options.prior,
            })
        });
        let Some(addr) = holodeck else {
            return Ok((None, builder.build(Feed::Thread)?));
        };
        let connected = self.resolve(addr).and_then(|a| {
            HolodeckSource::connect(a, self.display_id, &self.credentials)
                .map_err(|e| format!("{a}: {e}"))
        });
        Ok(match connected {
            Ok(source) => {
                tracing::info!("drawing from the holodeck at {addr}");
                (
                    Some(addr.to_owned()),
                    builder.build(Feed::Holodeck(source))?,
                )
            }
            Err(e) => {
                tracing::warn!("holodeck {addr}: {e}; tracing this wall's samples locally");
                (None, builder.build(Feed::Thread)?)
            }
        })
    }

    fn resolve(&self, addr: &str) -> Result<SocketAddr, String> {
        let mut a = addr
            .to_socket_addrs()
            .map_err(|e| format!("the holodeck address {addr:?}: {e}"))?
            .next()
            .ok_or_else(|| format!("the holodeck address {addr:?} resolves to nothing"))?;
        if a.ip().is_unspecified()
            && let Some(ip) = self.master_ip
        {
            a.set_ip(ip);
        }
        Ok(a)
    }
}

/// Runs the node until the master shuts it down (its reason is returned with the
/// counters) or it cannot go on. `present` shows each swapped frame.
pub fn run(
    member: &Membership,
    maker: &DisplayMaker,
    present: &mut dyn Presentation,
) -> Result<(NodeCounters, String), NodeError> {
    let wall = &member.wall;
    // The display and the holodeck it draws from (`None`: tracing locally).
    let mut display: Option<(Option<String>, WallDisplay)> = None;
    let mut counters = NodeCounters::default();
    let mut since = Instant::now();
    let mut warned = false;
    loop {
        let mut link = match MasterLink::connect(
            &member.master,
            &member.cluster,
            &wall.name,
            &member.secret,
        ) {
            Ok(l) => l,
            Err(e) if e.is_refusal() => return Err(NodeError::Refused(e)),
            Err(e) => {
                if !warned {
                    tracing::warn!("{e}; retrying");
                    warned = true;
                }
                if let Some(limit) = member.give_up_after
                    && since.elapsed() > limit
                {
                    return Err(NodeError::GaveUp {
                        seconds: limit.as_secs_f64(),
                        source: e,
                    });
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
                    maker.display(wanted.as_deref(), link.welcome.vlf.as_deref())?
                }
            };
            let display = &mut display.insert(made).1;
            match follow(
                &mut link,
                display,
                wall,
                maker.size(),
                member.slow_by,
                &mut counters,
                present,
            ) {
                Ended::SourceLost => tracing::warn!(
                    "wall {:?}: the holodeck went away; reconnecting to it (or tracing locally)",
                    wall.name
                ),
                Ended::Shutdown(reason) => return Ok((counters, reason)),
                Ended::Closed(reason) => return Ok((counters, format!("left: {reason}"))),
                Ended::Lost(e) => {
                    tracing::warn!("wall {:?}: {e}; reconnecting", wall.name);
                    since = Instant::now();
                    break;
                }
            }
        }
    }
}
