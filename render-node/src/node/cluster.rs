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
use holocave_protocol::cluster::FrameState;
use holocave_scene::Scene;
use holocave_scene::daylight::When;
use holocave_tracer::Tracer;
use holocave_vlf::baked::{self, Opened};
use holocave_vlf::hours::{BakeSet, open_blended};
use holocave_vlf::split::Split;

use crate::gpu_rays::Rays;
use crate::light_field::time_of_day::TimeOfDay;
use crate::node::follow::{Ended, LinkError, MasterLink, NodeCounters, Presentation, follow};
use crate::present::output::{FrameImages, PresentedLog};
use crate::present::wall_windows::{ClusterWindows, WindowOutput};
use crate::{
    DisplayBuilder, Feed, Gpu, HolodeckSource, LightField, Prior, RenderCache, RenderNodeError,
    VlfBase, VlfDrawing, WallDisplay,
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
    /// master names (read once per path and time of day).
    vlf: Option<Arc<VlfChoice>>,
    /// How the scene is lit for another time of day (`None`: the node has no time).
    time: Option<TimeOfDay>,
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
    /// The field last opened, by its path and the time of day it is lit for.
    loaded: Mutex<Option<(FieldKey, Arc<VlfBase>)>>,
    /// The last bakes read ([`KEPT_BAKES`] at most): a single bake is drawn again under
    /// the scene lit for each time of day, a bake set's two around it blended again.
    bakes: Mutex<Vec<(PathBuf, Arc<Opened>)>>,
}

/// How many bakes a node keeps read: a bake set's two around the time and the next one a
/// step reaches.
const KEPT_BAKES: usize = 3;

/// A light field's path and the time of day it is lit for (`None`: the node's start).
type FieldKey = (PathBuf, Option<String>);

impl VlfChoice {
    /// The bake at `path` opened with the scene lit for the bake's own time (`scene`,
    /// made only when the bake is read), read once while it is among the last
    /// [`KEPT_BAKES`].
    fn bake(
        &self,
        path: &std::path::Path,
        scene: impl FnOnce() -> Result<Arc<Scene>, String>,
    ) -> Result<Arc<Opened>, String> {
        let mut bakes = self.bakes.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(i) = bakes.iter().position(|(p, _)| p == path) {
            let kept = bakes.remove(i);
            bakes.push(kept);
        } else {
            let opened = baked::open(path, &*scene()?).map_err(|e| e.to_string())?;
            if bakes.len() == KEPT_BAKES {
                bakes.remove(0);
            }
            bakes.push((path.to_owned(), Arc::new(opened)));
        }
        Ok(bakes.last().map(|(_, o)| o.clone()).expect("just kept"))
    }

    /// The light field to draw given what the master names, lit for `at` (a time of day
    /// other than the start's, and the scene lit for it; `None`: the start's); `None` when
    /// there is none or it cannot be read (said in the log: the wall then shows its
    /// samples alone).
    fn base(
        self: &Arc<Self>,
        named: Option<&str>,
        at: Option<(When, &Arc<Scene>)>,
        time: Option<&TimeOfDay>,
    ) -> Option<Arc<VlfBase>> {
        let path = (self.options.own.clone()).or_else(|| named.map(PathBuf::from))?;
        let key = (path, at.map(|(w, _)| w.to_string()));
        let mut loaded = self.loaded.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((k, b)) = loaded.as_ref()
            && *k == key
        {
            return Some(b.clone());
        }
        match self.open(&key.0, at, time) {
            Ok(b) => {
                let b = Arc::new(b);
                if let (true, None, Some(time)) = (key.0.is_dir(), at, time) {
                    self.read_next_ahead(&key.0, time);
                }
                *loaded = Some((key, b.clone()));
                Some(b)
            }
            Err(e) => {
                tracing::error!("{e}; this wall draws its samples without the light field");
                None
            }
        }
    }

    /// On a thread of its own, reads the bake set `dir`'s next bake after the start's
    /// time and draws it once (its remainder smoothed and kept:
    /// `holocave_vlf::plane_smooth`), so that the first step forward into the next pair
    /// of bakes finds both ready instead of reading and smoothing one (seconds, on a
    /// node sharing its cores).
    fn read_next_ahead(self: &Arc<Self>, dir: &std::path::Path, time: &TimeOfDay) {
        let (me, dir, time) = (self.clone(), dir.to_owned(), time.clone());
        let reading = std::thread::Builder::new()
            .name("next bake".into())
            .spawn(move || {
                if let Err(e) = me.draw_next(&dir, &time) {
                    tracing::warn!("{}: the next bake not read ahead: {e}", dir.display());
                }
            });
        if let Err(e) = reading {
            tracing::warn!("the next bake not read ahead: {e}");
        }
    }

    /// [`Self::read_next_ahead`]'s work. The bake is drawn through [`Split`] as a
    /// relight would draw it, so its smoothed remainder is the very one a relight looks
    /// for (by its values); the split itself is dropped.
    fn draw_next(&self, dir: &std::path::Path, time: &TimeOfDay) -> Result<(), String> {
        let start = self.scene.daylight.local_time(time.start)?;
        let Some((at, path)) = BakeSet::read(dir)?.next_after(start).cloned() else {
            return Ok(());
        };
        let scene = Arc::new(time.scene_at(&self.scene, When::Local(at))?);
        let opened = self.bake(&path, || Ok(scene.clone()))?;
        let layout = (&opened.elements, &opened.tiles);
        let sky = self.options.drawing.sky_per_pixel;
        Split::new(
            scene,
            &opened.file.settings,
            &opened.file.state,
            layout,
            sky,
        )?;
        tracing::info!("{}: read ahead", path.display());
        Ok(())
    }

    /// Opens the file (or the bake set's field at the time) as the options draw it, under
    /// the scene lit for `at` (else the start's scene).
    fn open(
        &self,
        path: &std::path::Path,
        at: Option<(When, &Arc<Scene>)>,
        time: Option<&TimeOfDay>,
    ) -> Result<VlfBase, RenderNodeError> {
        let scene = at.map_or(&self.scene, |(_, s)| s).clone();
        let vlf_error = |e: String| RenderNodeError::Vlf(format!("{}: {e}", path.display()));
        let opened = if path.is_dir() {
            let time = time.ok_or_else(|| {
                vlf_error("a bake set is drawn at a time of day: give --when".into())
            })?;
            let when = at.map_or(time.start, |(w, _)| w);
            let local = scene.daylight.local_time(when).map_err(vlf_error)?;
            let open_at = |t, p: &std::path::Path| {
                self.bake(p, || {
                    time.scene_at(&self.scene, When::Local(t)).map(Arc::new)
                })
            };
            let (opened, bracket) = open_blended(path, local, open_at).map_err(vlf_error)?;
            tracing::info!(
                "the light field at {local}: {} and {} blended, {:.3} of the later",
                bracket.before.1.display(),
                bracket.after.1.display(),
                bracket.t
            );
            opened
        } else {
            if at.is_some() {
                tracing::warn!(
                    "{}: one bake: its indirect light stays that of its own time (give a bake \
                     set, a folder, for the field to follow the time)",
                    path.display()
                );
            }
            // The node's scene is lit for the bake's own time (its fingerprint checks).
            let bake = self.bake(path, || Ok(self.scene.clone()));
            Arc::unwrap_or_clone(bake.map_err(vlf_error)?)
        };
        VlfBase::drawn(opened, scene, self.options.drawing, self.gpu.as_ref(), path)
    }
}

impl DisplayMaker {
    /// Displays of the member's wall at `size` pixels per eye asking for `samples` per eye
    /// and frame (`None`: the render cache's default for the size), tracing locally with
    /// `tracer` when there is no holodeck. `display_id` names the
    /// wall at the holodeck (its place in the config, which every node reads alike).
    pub fn new(
        member: &Membership,
        display_id: u32,
        size: Size,
        samples: Option<u32>,
        tracer: Arc<Tracer>,
    ) -> DisplayMaker {
        let wall = &member.wall;
        let samples = samples.unwrap_or_else(|| RenderCache::default_samples(size));
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
            time: None,
        }
    }

    /// Lights the wall for the time of day of each frame ([`crate::light_field::time_of_day`]).
    pub fn with_time_of_day(mut self, time: TimeOfDay) -> DisplayMaker {
        self.time = Some(time);
        self
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
        let choice = Arc::new(VlfChoice {
            scene,
            options,
            gpu: self.builder.gpu.clone(),
            loaded: Mutex::new(None),
            bakes: Mutex::new(Vec::new()),
        });
        // The node's own file is read now, before it joins: reading it after the welcome
        // would hold up the cluster's first frames.
        if choice.options.own.is_some() {
            choice.base(None, None, self.time.as_ref());
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

    /// The display lit for the frame's time of day `when`, and the holodeck address it
    /// draws from (`None`: tracing locally). At a time other than the start's it traces
    /// its own samples ([`crate::light_field::time_of_day`]) and is kept for the holodeck named all
    /// the same, until the time changes.
    fn display(
        &self,
        holodeck: Option<&str>,
        vlf: Option<&str>,
        when: Option<&str>,
    ) -> Result<(Option<String>, WallDisplay), RenderNodeError> {
        if let Some(time) = &self.time
            && let Some(at) = time.other_time(when)
        {
            return Ok((holodeck.map(String::from), self.display_at(time, at, vlf)?));
        }
        let builder = self.builder_with_field(vlf, None);
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

    /// The builder with the light field the master names (or the node's own), lit for
    /// `at` (a time of day other than the start's and the scene lit for it; `None`: the
    /// start's).
    fn builder_with_field(
        &self,
        vlf: Option<&str>,
        at: Option<(When, &Arc<Scene>)>,
    ) -> DisplayBuilder {
        let mut builder = self.builder.clone();
        builder.gather = self.vlf.as_ref().is_some_and(|c| c.options.gather);
        builder.light_field = self.vlf.as_ref().and_then(|c| {
            Some(LightField {
                base: c.base(vlf, at, self.time.as_ref())?,
                prior: c.options.prior,
            })
        });
        builder
    }

    /// The display lit for `when`: the scene, its tracer and the light field at that time,
    /// its samples traced here.
    fn display_at(
        &self,
        time: &TimeOfDay,
        when: When,
        vlf: Option<&str>,
    ) -> Result<WallDisplay, RenderNodeError> {
        let started = Instant::now();
        let old = &self.builder.tracer;
        let scene = (time.scene_at(old.scene(), when))
            .map_err(|e| RenderNodeError::Vlf(format!("the time of day {when}: {e}")))?;
        let scene = Arc::new(scene);
        let mut builder = self.builder_with_field(vlf, Some((when, &scene)));
        builder.tracer = Arc::new(Tracer::new(scene.clone(), old.settings()));
        let display = builder.build(Feed::Thread)?;
        tracing::info!(
            "lit for {when} in {:.0} ms",
            started.elapsed().as_secs_f64() * 1e3
        );
        Ok(display)
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

/// Where a cluster node's swapped frames go: each into its presented log, then shown in its
/// windows, or written as images every `every` frames.
pub struct ClusterOutput<'a> {
    pub log: PresentedLog,
    pub windows: Option<WindowOutput<'a>>,
    pub images: FrameImages,
    pub every: u64,
}

/// [`run`], presenting into `output`; with windows, their summary is printed at the end.
pub fn run_into(
    member: &Membership,
    maker: &DisplayMaker,
    output: ClusterOutput,
) -> Result<(NodeCounters, String), NodeError> {
    let ClusterOutput {
        mut log,
        windows,
        mut images,
        every,
    } = output;
    let windowed = windows.is_some();
    let mut present = |state: &FrameState, display: &mut WallDisplay| -> Result<(), String> {
        log.presented(state.frame).map_err(|e| e.to_string())?;
        if !windowed && state.frame.is_multiple_of(every.max(1)) {
            images.write(state.frame, display)?;
        }
        Ok(())
    };
    let Some(output) = windows else {
        return run(member, maker, &mut present);
    };
    let mut windows = ClusterWindows {
        output,
        then: present,
    };
    let ended = run(member, maker, &mut windows)?;
    print!("{}", windows.output.summary());
    Ok(ended)
}

/// Runs the node until the master shuts it down (its reason is returned with the
/// counters) or it cannot go on. `present` shows each swapped frame.
pub fn run(
    member: &Membership,
    maker: &DisplayMaker,
    present: &mut dyn Presentation,
) -> Result<(NodeCounters, String), NodeError> {
    let wall = &member.wall;
    // The display, the holodeck it was made for (`None`: tracing locally) and the time of
    // day it is lit for.
    let mut display: Option<(Option<String>, Option<String>, WallDisplay)> = None;
    // A frame to draw first: the one whose time of day the display was made again for.
    let mut first: Option<FrameState> = None;
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
            let when = first.as_ref().map_or_else(
                || display.as_ref().and_then(|d| d.1.clone()),
                |f| f.when.clone(),
            );
            let made = match display.take() {
                Some((using, lit, d)) if using == wanted && lit == when && !d.source_lost() => {
                    (using, lit, d)
                }
                old => {
                    drop(old);
                    let (using, d) = maker.display(
                        wanted.as_deref(),
                        link.welcome.vlf.as_deref(),
                        when.as_deref(),
                    )?;
                    (using, when, d)
                }
            };
            let (_, lit, display) = display.insert(made);
            match follow(
                &mut link,
                (display, lit.as_deref(), first.take()),
                wall,
                maker.size(),
                member.slow_by,
                &mut counters,
                present,
            ) {
                Ended::Relight(state) => first = Some(*state),
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
