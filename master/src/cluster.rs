//! The running master: the frame clock, the broadcast of each frame's state, the swap
//! barrier over TCP, node membership, and the operator's status line.
//!
//! Threads: one accepts connections; each connection gets a thread that runs the
//! handshake (with a timeout, so a silent or hostile peer costs nothing but its thread).
//! An accepted node's socket then moves to the frame loop, which runs on one thread with
//! tokio: every node's messages are read there as they arrive, so a Ready reaches the
//! barrier without a hand-over between threads (the barrier's round trip is most of a
//! frame's overhead). Everything meets in one channel of [`Event`]s.

use std::collections::BTreeMap;
use std::io::Write;
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use holocave_protocol::cluster::{
    DeskInput, FrameState, MAX_CLUSTER_FRAME, MAX_VEIL_SOURCES, MasterMsg, NodeMsg, NodeStats,
    VeilSource, WireObject,
};
use holocave_protocol::frame::{FrameError, encode};
use holocave_protocol::handshake::{self, Role, Welcome};
use holocave_protocol::session::{Opener, Sealer, SessionKeys};
use holocave_protocol::stats::quantile_duration;
use tokio::io::AsyncWriteExt;
use tokio::net::tcp::OwnedWriteHalf;
use tokio::sync::mpsc::{UnboundedReceiver, UnboundedSender, unbounded_channel};
use tokio::time::timeout_at;

use crate::barrier::{Barrier, NodeId};
use crate::frame_state::{FrameTimes, FrameWorld, frame_state};
use crate::head::{Clock, Head};
use crate::navigation::log::NavigationLog;
use crate::navigation::placement::Placement;
use crate::navigation::run::NavigationRun;
use crate::pacing::Pacer;
use crate::session::{SessionClock, SessionState, StateKeeper};
use crate::sun_clock::SunClock;
use holocave_cave::Cave;
use holocave_cave::CaveFrusta;

/// How long a peer has for the whole handshake.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(2);

/// How often the master, waiting for the walls' nodes before its first frame, looks whether
/// Ctrl-C was pressed.
const STOP_LOOK: Duration = Duration::from_millis(100);
/// Most handshakes in progress at once; more connections are closed at once.
const MAX_HANDSHAKES: usize = 64;
/// A node whose socket does not take a frame state within this long is dropped (it
/// reconnects); the frame loop never waits longer on one node.
const WRITE_TIMEOUT: Duration = Duration::from_millis(20);

/// What the master calls with every frame state it sends.
pub type FrameHook = Box<dyn FnMut(&FrameState) + Send>;

/// How to run.
pub struct MasterOptions {
    pub clock: Clock,
    /// Stop after this many frames.
    pub frames: Option<u64>,
    /// Stop after this long.
    pub seconds: Option<f64>,
    /// Stop when a recorded tracker source ends.
    pub stop_at_end_of_log: bool,
    /// The holodeck server's address for displays, told to every node.
    pub holodeck: Option<String>,
    /// The light field file the walls draw under their samples, told to every node.
    pub vlf: Option<String>,
    /// Append every frame state (as its wire frame) to this file.
    pub states_log: Option<PathBuf>,
    /// Print a status line this often.
    pub status_every: Duration,
    /// Set from outside (the binary's Ctrl-C handler, a test) to stop after the current
    /// frame; the nodes are then told to shut down, not left to retry.
    pub stop: Arc<AtomicBool>,
    /// Before the first frame, wait this long at most for a node of every wall.
    pub wait_for_walls: Duration,
    /// Appended to each status line (the holodeck's fill and ray rate, when the master
    /// hosts it).
    pub status_extra: Option<Box<dyn FnMut() -> String + Send>>,
    /// Navigation from input devices; `None`: the config's start transform every frame.
    pub navigation: Option<NavigationRun>,
    /// Write each frame's room → scene transform to this `navigation.csv`.
    pub navigation_log: Option<PathBuf>,
    /// The moving objects (their paths, the wand that carries them); `None`: the scene
    /// has none.
    pub objects: Option<crate::objects::ObjectMotion>,
    /// Called with every frame state as it is sent (live glare); must not block.
    pub on_frame: Option<FrameHook>,
    /// Keep the session's state in this file (`session.json`), every frame on disk
    /// before its Swap.
    pub session_state: Option<PathBuf>,
    /// Go on with this session: frames numbered from its frame + 1, the clock, the room's
    /// place and the objects as it left them.
    pub resume: Option<SessionState>,
    /// The scene's time of day (from `--when`), sent with every frame and kept in the
    /// session's state; `None`: the scene has no time.
    pub sun: Option<SunClock>,
}

/// What a run measured.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    pub frames: u64,
    pub elapsed: Duration,
    /// Per frame: from sending the state to sending Swap.
    pub barrier: Vec<Duration>,
    /// Per frame with a tracker sample (live clock): from the sample's arrival to Swap.
    pub motion_to_photon: Vec<Duration>,
    /// Per wall: frames swapped, times declared out (missed the dead-node timeout).
    pub walls: BTreeMap<String, (u64, u64)>,
    /// Per wall: frames on which its Ready came last (it set the pace), and by how much
    /// in all (from the Ready before it, or from the state sent when it was alone).
    pub pace: BTreeMap<String, (u64, Duration)>,
    /// The frame period the master ran at in the end (pacing: the slowest wall's, never
    /// shorter than the configured rate's).
    pub paced_period: Duration,
    /// Frames that swapped with every wall present.
    pub full_frames: u64,
    /// Connections refused (bad handshake, wrong secret, unknown wall).
    pub refused: u64,
    /// Connections dropped for bad messages (too large, undecodable) or write failures.
    pub dropped: u64,
    /// The walls' per-pixel light-field passes, summed over every Ready: pixels traced
    /// anew, drawn again from the last frame's, and that took direct-light estimates.
    pub pixels: PixelWork,
}

/// The walls' per-pixel work, in pixels ([`holocave_protocol::cluster::NodeStats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelWork {
    pub traced: u64,
    pub reused: u64,
    pub estimated: u64,
}

impl PixelWork {
    /// Adds one Ready's counts.
    fn add(&mut self, s: &NodeStats) {
        self.traced += u64::from(s.traced);
        self.reused += u64::from(s.reused);
        self.estimated += u64::from(s.estimated);
    }

    /// `traced / reused / estimated` as shares of the pixels drawn, e.g. `traced 40 %,
    /// reused 60 %, estimated 12 %`; empty where none were drawn.
    pub fn shares(&self) -> String {
        percent_of_drawn([self.traced, self.reused, self.estimated])
            .map_or_else(String::new, |[t, r, e]| {
                format!("pixels traced {t:.0} %, reused {r:.0} %, estimated {e:.0} %")
            })
    }
}

/// Pixel counts `[traced, reused, estimated]` as percentages of the pixels drawn (traced
/// and reused); `None` where none were drawn.
fn percent_of_drawn(counts: [u64; 3]) -> Option<[f64; 3]> {
    let drawn = counts[0] + counts[1];
    (drawn > 0).then(|| counts.map(|n| 100.0 * n as f64 / drawn as f64))
}

enum Event {
    Joined {
        id: NodeId,
        wall: String,
        stream: TcpStream,
        keys: SessionKeys,
    },
    Msg {
        id: NodeId,
        msg: NodeMsg,
    },
    Left {
        id: NodeId,
        why: FrameError,
    },
    Refused {
        peer: SocketAddr,
        why: String,
    },
}

struct Accepting {
    cluster: String,
    secret: Vec<u8>,
    walls: Vec<String>,
    welcome: Welcome,
    next_id: AtomicU64,
    handshakes: AtomicUsize,
    stop: AtomicBool,
}

fn accept_loop(listener: TcpListener, shared: Arc<Accepting>, events: UnboundedSender<Event>) {
    for conn in listener.incoming() {
        if shared.stop.load(Ordering::Relaxed) {
            return;
        }
        let Ok(stream) = conn else { continue };
        if shared.handshakes.fetch_add(1, Ordering::AcqRel) >= MAX_HANDSHAKES {
            shared.handshakes.fetch_sub(1, Ordering::AcqRel);
            let _ = stream.shutdown(Shutdown::Both);
            continue;
        }
        let (shared, events) = (shared.clone(), events.clone());
        let _ = std::thread::Builder::new()
            .name("master connection".into())
            .spawn(move || serve_connection(stream, &shared, &events));
    }
}

/// One connection's handshake; an accepted node goes to the frame loop.
fn serve_connection(mut stream: TcpStream, shared: &Accepting, events: &UnboundedSender<Event>) {
    let peer = stream
        .peer_addr()
        .unwrap_or_else(|_| SocketAddr::from(([0, 0, 0, 0], 0)));
    let refuse = |why: String| {
        let _ = events.send(Event::Refused { peer, why });
    };
    let _ = stream.set_nodelay(true);
    let _ = stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT));
    let _ = stream.set_write_timeout(Some(HANDSHAKE_TIMEOUT));
    let accepted = handshake::accept(&mut stream, &shared.cluster, &shared.secret);
    shared.handshakes.fetch_sub(1, Ordering::AcqRel);
    let accepted = match accepted {
        Ok(a) => a,
        Err(e) => return refuse(e.to_string()),
    };
    let Role::Node { wall } = accepted.role.clone() else {
        let why = format!(
            "a {} connected to the master's port (render nodes only)",
            accepted.role
        );
        let _ = accepted.refuse(&mut stream, &why);
        return refuse(why);
    };
    if !shared.walls.contains(&wall) {
        let why = format!(
            "no wall {wall:?} in this CAVE (walls: {})",
            shared.walls.join(", ")
        );
        let _ = accepted.refuse(&mut stream, &why);
        return refuse(why);
    }
    let id = shared.next_id.fetch_add(1, Ordering::Relaxed);
    let welcome = Welcome {
        node_id: id,
        ..shared.welcome.clone()
    };
    let keys = match accepted.welcome(&mut stream, welcome) {
        Ok(k) => k,
        Err(e) => return refuse(format!("welcome: {e}")),
    };
    if stream.set_nonblocking(true).is_ok() {
        let _ = events.send(Event::Joined {
            id,
            wall,
            stream,
            keys,
        });
    }
}

/// Reads one node's messages until it closes or sends something undecodable or forged.
async fn read_node(
    id: NodeId,
    mut reader: tokio::net::tcp::OwnedReadHalf,
    mut opener: Opener,
    events: UnboundedSender<Event>,
) {
    loop {
        match opener
            .read_async::<_, NodeMsg>(&mut reader, MAX_CLUSTER_FRAME)
            .await
        {
            Ok(msg) => {
                if events.send(Event::Msg { id, msg }).is_err() {
                    return;
                }
            }
            Err(why) => {
                let _ = events.send(Event::Left { id, why });
                return;
            }
        }
    }
}

/// A connected node's socket for writing, and the sealer of its link.
struct Link {
    wall: String,
    writer: OwnedWriteHalf,
    sealer: Sealer,
}

/// The master's state between frames.
struct Master<'a> {
    cave: &'a Cave,
    events: UnboundedReceiver<Event>,
    /// For the node readers' messages.
    tx: UnboundedSender<Event>,
    barrier: Barrier,
    links: BTreeMap<NodeId, Link>,
    /// Ready arrivals for the frame being collected, in order.
    arrivals: Vec<(NodeId, Instant)>,
    /// Desk inputs received since the last frame, in order (`None`: the node is gone).
    desk: Vec<(NodeId, Option<DeskInput>)>,
    /// Each wall's newest veiling sources not yet relayed to the other walls.
    veils: BTreeMap<String, Vec<VeilSource>>,
    /// Where each frame's session state goes before its Swap.
    keeper: Option<StateKeeper>,
    summary: Summary,
}

impl Master<'_> {
    fn new(
        cave: &Cave,
        events: UnboundedReceiver<Event>,
        tx: UnboundedSender<Event>,
    ) -> Master<'_> {
        Master {
            cave,
            events,
            tx,
            barrier: Barrier::default(),
            links: BTreeMap::new(),
            arrivals: Vec::new(),
            desk: Vec::new(),
            veils: BTreeMap::new(),
            keeper: None,
            summary: Summary::default(),
        }
    }

    /// Where the room is in the scene this frame: the navigation's placement (the desks'
    /// input handed to it first), else the config's.
    fn navigate(
        &mut self,
        navigation: Option<&mut NavigationRun>,
        master_ns: u64,
        pose: &holocave_tracking::Pose,
        recentring: glam::Vec3,
    ) -> Placement {
        let Some(nav) = navigation else {
            return Placement::from_mat4(&self.cave.room_to_scene);
        };
        for (id, input) in self.desk.drain(..) {
            nav.desk_message(id, input);
        }
        nav.frame(master_ns, pose, recentring)
    }

    /// When every wall swapped frame `frame`, sent at `sent`. Every wall starts on the same
    /// frame: on the run's first frame every joined node is held (its first draw may take
    /// long: pipelines, caches) up to the wait for walls, later ones up to the dead-node
    /// time.
    async fn swapped(
        &mut self,
        (frame, first): (u64, bool),
        sent: Instant,
        wait_for_walls: Duration,
        dead_node: Duration,
    ) -> std::io::Result<Instant> {
        if first {
            let hold = wait_for_walls.max(dead_node);
            self.swap_barrier(frame, sent, hold, true).await
        } else {
            self.swap_barrier(frame, sent, dead_node, false).await
        }
    }

    /// The run's summary after `frames` frames, its nodes forgotten.
    fn finish(mut self, frames: u64, paced_period: Duration, elapsed: Duration) -> Summary {
        self.summary.frames = frames;
        self.summary.paced_period = paced_period;
        self.summary.elapsed = elapsed;
        let ids: Vec<NodeId> = self.barrier.members().keys().copied().collect();
        for id in ids {
            self.forget(id);
        }
        self.summary
    }

    /// Waits for the tick `until`, handling joins and stale messages meanwhile, then
    /// whatever else has arrived.
    async fn handle_all_until(&mut self, until: Instant) {
        self.handle_until(until).await;
        while let Ok(e) = self.events.try_recv() {
            self.handle(e);
        }
    }

    /// Tells every node the master is stopping and closes their links.
    async fn shut_down(&mut self) -> std::io::Result<()> {
        let bye = MasterMsg::Shutdown {
            reason: "the master is stopping".into(),
        };
        self.send(&bye, None).await?;
        for l in self.links.values_mut() {
            let _ = l.writer.shutdown().await;
        }
        Ok(())
    }

    fn handle(&mut self, e: Event) {
        match e {
            Event::Joined {
                id,
                wall,
                stream,
                keys,
            } => {
                let stream = match tokio::net::TcpStream::from_std(stream) {
                    Ok(s) => s,
                    Err(e) => return tracing::warn!("node {id}: {e}"),
                };
                let (reader, writer) = stream.into_split();
                let (sealer, opener) = keys.acceptor();
                tokio::spawn(read_node(id, reader, opener, self.tx.clone()));
                tracing::info!("node {id} joined for wall {wall:?}");
                self.barrier.join(id, &wall);
                self.links.insert(
                    id,
                    Link {
                        wall,
                        writer,
                        sealer,
                    },
                );
            }
            Event::Msg {
                id,
                msg: NodeMsg::Ready { frame, stats },
            } => {
                if frame == self.barrier.frame() {
                    self.arrivals.push((id, Instant::now()));
                }
                self.summary.pixels.add(&stats);
                self.barrier.ready(id, frame, stats);
            }
            Event::Msg {
                id,
                msg: NodeMsg::DeskInput(input),
            } => self.desk.push((id, Some(input))),
            Event::Msg {
                id,
                msg: NodeMsg::Veil { sources },
            } => {
                let Some(link) = self.links.get(&id) else {
                    return;
                };
                if sources.len() > MAX_VEIL_SOURCES || !sources.iter().all(VeilSource::is_valid) {
                    tracing::warn!(
                        "node {id} (wall {:?}): {} veiling sources, not all finite unit \
                         directions with non-negative flux (at most {MAX_VEIL_SOURCES}); ignored",
                        link.wall,
                        sources.len()
                    );
                    return;
                }
                self.veils.insert(link.wall.clone(), sources);
            }
            Event::Msg {
                id,
                msg: NodeMsg::Leaving { reason },
            } => {
                if let Some(l) = self.links.remove(&id) {
                    tracing::info!("node {id} (wall {:?}) leaves: {reason}", l.wall);
                }
                self.forget(id);
            }
            Event::Left { id, why } => {
                if let Some(l) = self.links.remove(&id) {
                    // A node whose link ends leaves; one that sent garbage is dropped.
                    let bad = matches!(
                        why,
                        FrameError::TooLarge { .. }
                            | FrameError::Decode { .. }
                            | FrameError::Forged { .. }
                    );
                    self.summary.dropped += u64::from(bad);
                    tracing::warn!("node {id} (wall {:?}) left: {why}", l.wall);
                }
                self.forget(id);
            }
            Event::Refused { peer, why } => {
                self.summary.refused += 1;
                tracing::warn!("refused a connection from {peer}: {why}");
            }
        }
    }

    /// Handles events until `until` or until the channel closes.
    async fn handle_until(&mut self, until: Instant) {
        while Instant::now() < until {
            match next_event(&mut self.events, until).await {
                Some(e) => self.handle(e),
                None => break,
            }
        }
    }

    /// Handles events until the barrier is complete or `until`.
    async fn collect_until(&mut self, until: Instant) {
        while !self.barrier.complete() {
            match next_event(&mut self.events, until).await {
                Some(e) => self.handle(e),
                None => break,
            }
        }
    }

    /// Before the first frame: waits up to `limit` for a node of every wall.
    async fn wait_for_walls(&mut self, limit: Duration, stop: &AtomicBool) {
        let until = Instant::now() + limit;
        let absent = |m: &Self| -> Vec<String> {
            m.cave
                .walls
                .iter()
                .filter(|w| !m.links.values().any(|l| l.wall == w.name))
                .map(|w| w.name.clone())
                .collect()
        };
        while !absent(self).is_empty() && !stop.load(Ordering::Relaxed) {
            if Instant::now() >= until {
                if !limit.is_zero() {
                    tracing::warn!(
                        "starting without walls {:?}: no node joined for them",
                        absent(self)
                    );
                }
                return;
            }
            // Woken at least every STOP_LOOK to see Ctrl-C while no node comes.
            let look = until.min(Instant::now() + STOP_LOOK);
            match timeout_at(tokio::time::Instant::from_std(look), self.events.recv()).await {
                Ok(Some(e)) => self.handle(e),
                Ok(None) => return,
                Err(_) => {}
            }
        }
    }

    /// Frame `frame`'s swap barrier, its state sent at `sent` (frame lock): collects Ready
    /// until every node in the barrier is ready or `timeout` has passed, declares out the
    /// nodes that were not, sends Swap to the ready ones and counts the frame. `hold_all`
    /// (the first frame) waits for every joined node, drawing yet or not. Returns when
    /// Swap went.
    async fn swap_barrier(
        &mut self,
        frame: u64,
        sent: Instant,
        timeout: Duration,
        hold_all: bool,
    ) -> std::io::Result<Instant> {
        self.barrier.begin(frame);
        if hold_all {
            self.barrier.hold_all();
        }
        self.collect_until(sent + timeout).await;
        // No wall shows a frame the session's state does not reach yet.
        if let Some(k) = &mut self.keeper {
            k.written();
        }
        let closed = self.barrier.close();
        self.send(&MasterMsg::Swap { frame }, Some(&closed.swap))
            .await?;
        let swapped = Instant::now();
        self.summary.barrier.push(swapped - sent);
        let arrivals = std::mem::take(&mut self.arrivals);
        let mut walls_swapped: Vec<&str> = closed
            .swap
            .iter()
            .filter_map(|id| self.links.get(id).map(|l| l.wall.as_str()))
            .collect();
        walls_swapped.sort();
        walls_swapped.dedup();
        if walls_swapped.len() == self.cave.walls.len() {
            self.summary.full_frames += 1;
        }
        // The pace: the last Ready of the frame, and how long after the one before it.
        if let Some(&(id, at)) = arrivals.last()
            && closed.swap.contains(&id)
            && let Some(link) = self.links.get(&id)
        {
            let before = arrivals
                .len()
                .checked_sub(2)
                .map_or(sent, |k| arrivals[k].1);
            let e = self.summary.pace.entry(link.wall.clone()).or_default();
            e.0 += 1;
            e.1 += at - before;
        }
        for id in &closed.out {
            if let Some(mem) = self.barrier.members().get(id) {
                tracing::warn!(
                    "frame {frame}: wall {:?} (node {id}) declared out: not ready within {timeout:?}; \
                     the other walls go on without it until it is ready again",
                    mem.wall
                );
            }
        }
        Ok(swapped)
    }

    /// Removes a node from the barrier, keeping its counts in the summary.
    fn forget(&mut self, id: NodeId) {
        self.desk.push((id, None));
        if let Some(mem) = self.barrier.leave(id) {
            let e = self.summary.walls.entry(mem.wall).or_default();
            e.0 += mem.swapped;
            e.1 += mem.outs;
        }
    }

    /// Relays each wall's newest veiling sources to the nodes of the other walls.
    async fn relay_veils(&mut self) -> std::io::Result<()> {
        for (wall, sources) in std::mem::take(&mut self.veils) {
            let others: Vec<NodeId> = (self.links.iter())
                .filter(|(_, l)| l.wall != wall)
                .map(|(id, _)| *id)
                .collect();
            self.send(&MasterMsg::Veil { wall, sources }, Some(&others))
                .await?;
        }
        Ok(())
    }

    /// Sends `bytes` to the given nodes (all when `None`); drops a node that fails or
    /// does not take them within [`WRITE_TIMEOUT`].
    async fn send(&mut self, msg: &MasterMsg, to: Option<&[NodeId]>) -> std::io::Result<()> {
        let ids: Vec<NodeId> = match to {
            Some(ids) => ids.to_vec(),
            None => self.links.keys().copied().collect(),
        };
        for id in ids {
            let Some(link) = self.links.get_mut(&id) else {
                continue;
            };
            // Sealed for this link: its own keys and message number.
            let bytes = link
                .sealer
                .seal(msg, MAX_CLUSTER_FRAME)
                .map_err(|e| std::io::Error::other(e.to_string()))?;
            let wrote = tokio::time::timeout(WRITE_TIMEOUT, link.writer.write_all(&bytes)).await;
            let failed = match wrote {
                Ok(Ok(())) => None,
                Ok(Err(e)) => Some(e.to_string()),
                Err(_) => Some(format!(
                    "took more than {WRITE_TIMEOUT:?} to take a message"
                )),
            };
            if let Some(e) = failed {
                tracing::warn!("node {id} (wall {:?}): {e}; dropping it", link.wall);
                self.links.remove(&id);
                self.forget(id);
                self.summary.dropped += 1;
            }
        }
        Ok(())
    }

    /// One status line: the rate, each wall's draw time (and whether it is out), the wall
    /// that set the pace since `pace_before` and by how much, the barrier, the tracker.
    fn status_line(
        &self,
        frame: u64,
        rate: f64,
        tracker_hz: f64,
        head: &Head,
        pace_before: &BTreeMap<String, (u64, Duration)>,
    ) -> String {
        let mut line = format!("frame {frame:6} {rate:5.1} Hz |");
        for wall in &self.cave.walls {
            let m = self
                .barrier
                .members()
                .values()
                .filter(|m| m.wall == wall.name)
                .max_by_key(|m| m.swapped);
            line += &match m {
                Some(m) => format!(
                    " {} {:.1} ms{}{} |",
                    wall.name,
                    m.stats.draw_us as f64 / 1e3,
                    pixel_shares(&m.stats),
                    if m.in_barrier { "" } else { " (out)" },
                ),
                None => format!(" {} absent |", wall.name),
            };
        }
        if let Some((wall, frames, mean)) = pacer_since(&self.summary.pace, pace_before) {
            line += &format!(
                " pace: {wall} ({frames} frames last, {:.1} ms after the next) |",
                mean.as_secs_f64() * 1e3
            );
        }
        let n = self.summary.barrier.len();
        let recent = &self.summary.barrier[n.saturating_sub(120)..];
        line += &format!(
            " barrier p50 {:.2} ms | tracker {tracker_hz:.0} Hz, {}",
            quantile_duration(recent, 0.5)
                .unwrap_or_default()
                .as_secs_f64()
                * 1e3,
            head.fault_line()
        );
        line
    }
}

/// A wall's last frame's per-pixel work, as shares of its pixels: ` (traced 100 %, est
/// 35 %)`; empty without a light field.
fn pixel_shares(s: &NodeStats) -> String {
    let counts = [s.traced, s.reused, s.estimated].map(u64::from);
    percent_of_drawn(counts).map_or_else(String::new, |[t, _, e]| {
        format!(" (traced {t:.0} %, est {e:.0} %)")
    })
}

/// The wall whose Ready came last most often between two snapshots of the pace counts:
/// its name, how many frames, and by how much on average.
pub fn pacer_since(
    now: &BTreeMap<String, (u64, Duration)>,
    before: &BTreeMap<String, (u64, Duration)>,
) -> Option<(String, u64, Duration)> {
    now.iter()
        .map(|(wall, &(n, total))| {
            let (n0, t0) = before.get(wall).copied().unwrap_or_default();
            (wall, n - n0, total - t0)
        })
        .filter(|&(_, n, _)| n > 0)
        .max_by_key(|&(_, n, _)| n)
        .map(|(wall, n, total)| (wall.clone(), n, total / n as u32))
}

/// Runs the master on `listener` until a stop condition; then tells every node to shut
/// down and returns what it measured.
pub fn run(
    cave: &Cave,
    head: Head,
    listener: TcpListener,
    secret: Vec<u8>,
    opts: MasterOptions,
) -> std::io::Result<Summary> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?
        .block_on(run_frames(cave, head, listener, secret, opts))
}

/// Waits for `e` until `until` (`None` when the time is up first).
async fn next_event(events: &mut UnboundedReceiver<Event>, until: Instant) -> Option<Event> {
    timeout_at(tokio::time::Instant::from_std(until), events.recv())
        .await
        .ok()
        .flatten()
}

/// The thread that accepts the nodes' connections for `cave`'s cluster, handing them to
/// the frame loop through `tx`; stopped by setting its `stop` and connecting once.
fn start_accepting(
    cave: &Cave,
    listener: TcpListener,
    secret: Vec<u8>,
    opts: &MasterOptions,
    tx: UnboundedSender<Event>,
) -> std::io::Result<(Arc<Accepting>, std::thread::JoinHandle<()>)> {
    let accepting = Arc::new(Accepting {
        cluster: cave.cluster.id.clone(),
        secret,
        walls: cave.walls.iter().map(|w| w.name.clone()).collect(),
        welcome: Welcome {
            node_id: 0,
            rate_hz: cave.cluster.rate_hz,
            holodeck: opts.holodeck.clone(),
            vlf: opts.vlf.clone(),
        },
        next_id: AtomicU64::new(1),
        handshakes: AtomicUsize::new(0),
        stop: AtomicBool::new(false),
    });
    let a = accepting.clone();
    let acceptor = std::thread::Builder::new()
        .name("master accept".into())
        .spawn(move || accept_loop(listener, a, tx))?;
    Ok((accepting, acceptor))
}

/// Whether the run ends before frame `frame`: Ctrl-C, the frames or seconds asked, or
/// the end of a replayed log.
fn stopping(opts: &MasterOptions, frame: u64, start: Instant, head: &Head) -> bool {
    opts.stop.load(Ordering::Relaxed)
        || opts.frames.is_some_and(|n| frame >= n)
        || opts
            .seconds
            .is_some_and(|s| start.elapsed().as_secs_f64() >= s)
        || (opts.stop_at_end_of_log && head.ended())
}

/// The moving objects' placements for the frame shown at `display_ns`, the wand (placed in
/// the scene by `place`) carrying one where its button is held.
fn objects_at(opts: &mut MasterOptions, display_ns: u64, place: &Placement) -> Vec<WireObject> {
    match &mut opts.objects {
        Some(o) => {
            let (wand, button) = opts
                .navigation
                .as_ref()
                .map_or((None, false), |n| n.object_hand(place));
            o.frame(display_ns, wand, button)
        }
        None => Vec::new(),
    }
}

/// The frame's state: the frusta of the eyes at `pose` on the CAVE `placed` in the scene.
/// With navigation (`in_room`: the CAVE in room coordinates) the frusta are made in the
/// room and placed in the scene after, so a wall that holds its last good views holds them
/// where the room is now.
fn frame_state_of(
    frusta: &mut CaveFrusta,
    (placed, in_room): (&Cave, Option<&Cave>),
    (frame, times, pose): (u64, FrameTimes, &holocave_tracking::Pose),
    world: FrameWorld,
) -> FrameState {
    let Some(in_room) = in_room else {
        frusta.update(placed, pose);
        return frame_state(placed, frusta, frame, times, pose, world);
    };
    frusta.update(in_room, pose);
    let to_room = placed.room_to_scene.inverse();
    let mut placed_frusta = frusta.clone();
    for views in &mut placed_frusta.walls {
        for (_, f) in &mut views.eyes {
            f.view *= to_room;
        }
    }
    frame_state(placed, &placed_frusta, frame, times, pose, world)
}

/// The time of day of the frame at `master_ns`: the session's clock advanced by the
/// frame's time inputs (a replayed `time` row, the desk's keys), each change logged and
/// written to `desk.csv` (when kept).
fn time_of_day(opts: &mut MasterOptions, frame: u64, master_ns: u64) -> Option<String> {
    let sun = opts.sun.as_mut()?;
    if let Some(nav) = &mut opts.navigation {
        let (set, step) = nav.time_input();
        if sun.advance(set, step) {
            tracing::info!("frame {frame}: the time of day is now {}", sun.now());
            if let Some(local) = sun.local() {
                nav.log_time(master_ns, local);
            }
        }
    }
    Some(sun.now().to_string())
}

async fn run_frames(
    cave: &Cave,
    mut head: Head,
    listener: TcpListener,
    secret: Vec<u8>,
    mut opts: MasterOptions,
) -> std::io::Result<Summary> {
    let addr = listener.local_addr()?;
    let (tx, events) = unbounded_channel();
    let (accepting, acceptor) = start_accepting(cave, listener, secret, &opts, tx.clone())?;
    let (mut states, mut nav_log) = open_logs(&opts)?;
    let mut caves = Caves::new(cave, opts.navigation.is_some());
    let mut m = Master::new(cave, events, tx);
    m.keeper = (opts.session_state.clone())
        .map(StateKeeper::start)
        .transpose()?;
    let first = start_of(&mut opts, &mut head)?;
    m.wait_for_walls(opts.wait_for_walls, &opts.stop).await;
    let period = cave.frame_period();
    let dead_node = cave.dead_node_timeout();
    let mut pacer = Pacer::new(period);
    let start = Instant::now();
    let mut next_tick = start;
    let mut status = StatusClock::new(start, first.frame);
    let mut frame = first.frame;
    let mut when: Option<String> = None;
    loop {
        if stopping(&opts, frame, start, &head) {
            break;
        }
        m.handle_all_until(next_tick).await;
        let times = frame_clock(opts.clock, (start, frame, period), &pacer, first.clock_ns);
        let state = caves.state(&mut m, &mut opts, &mut head, &mut nav_log, (frame, times))?;
        let tracker_ns = state.tracker_time_ns;
        let relit = frame != first.frame && state.when != when;
        when.clone_from(&state.when);
        if let Some(k) = &mut m.keeper {
            k.offer(session_state(&opts, &state, period, &head));
        }
        let msg = MasterMsg::Frame(state);
        if let (Some(f), MasterMsg::Frame(state)) = (opts.on_frame.as_mut(), &msg) {
            f(state);
        }
        if let Some(w) = &mut states {
            w.write_all(&encoded(&msg)?)?;
        }
        let sent = Instant::now();
        m.send(&msg, None).await?;
        let swapped = m
            .swapped(
                (frame, frame == first.frame),
                sent,
                opts.wait_for_walls,
                dead_node,
            )
            .await?;
        pacer.record(swapped - sent);
        if relit {
            tracing::info!(
                "frame {frame}: the walls lit for {} swapped {:.0} ms after its state was sent",
                when.as_deref().unwrap_or("no time"),
                (swapped - sent).as_secs_f64() * 1e3
            );
        }
        m.relay_veils().await?;
        if let (Clock::Live, Some(t)) = (opts.clock, tracker_ns) {
            let t = start + Duration::from_nanos(t.saturating_sub(first.clock_ns));
            m.summary
                .motion_to_photon
                .push(swapped.saturating_duration_since(t));
        }
        if swapped - status.since >= opts.status_every {
            let extra = opts.status_extra.as_mut();
            tracing::info!("{}", status.line_with(&m, (frame, swapped), &head, extra));
        }
        frame += 1;
        next_tick = next_tick_after(next_tick, period);
    }
    if let Some(log) = &mut nav_log {
        log.flush()?;
    }
    if let Some(nav) = &mut opts.navigation {
        nav.finish()?;
    }
    m.shut_down().await?;
    stop_accepting(&accepting, addr, acceptor);
    Ok(m.finish(frame - first.frame, pacer.period(), start.elapsed()))
}

/// Where a run starts: its first frame, and its clock's time at its start (ns).
struct RunStart {
    frame: u64,
    clock_ns: u64,
}

/// Where this run starts: at frame 0, or, resuming a session, after its last frame with
/// the room's place and the moving objects as that frame had them.
fn start_of(opts: &mut MasterOptions, head: &mut Head) -> std::io::Result<RunStart> {
    let Some(s) = &opts.resume else {
        return Ok(RunStart {
            frame: 0,
            clock_ns: 0,
        });
    };
    if let Some(nav) = &mut opts.navigation {
        let place = Placement::from_mat4(&glam::DMat4::from_cols_array(&s.navigation));
        nav.navigator.resume_at(place);
    }
    if let Some(origin) = s.recentred_from {
        head.resume_recentring(glam::Vec3::from_array(origin));
    }
    if let Some(o) = &mut opts.objects {
        o.resume(&s.objects).map_err(std::io::Error::other)?;
    }
    if let (Some(sun), Some(now)) = (&mut opts.sun, &s.time_of_day) {
        let now = now.parse().map_err(|e| {
            std::io::Error::other(format!("the session's time of day {now:?}: {e}"))
        })?;
        *sun = SunClock::resumed(sun.start(), now);
    }
    tracing::info!(
        "resuming the session after frame {} (its clock at {:.3} s, {} tracker samples read)",
        s.frame,
        s.master_ns as f64 * 1e-9,
        s.tracker_samples
    );
    Ok(RunStart {
        frame: s.frame + 1,
        clock_ns: s.master_ns + s.period_ns,
    })
}

/// The session's state once `state` is sent: what a new master needs to go on after it.
fn session_state(
    opts: &MasterOptions,
    state: &FrameState,
    period: Duration,
    head: &Head,
) -> SessionState {
    SessionState {
        version: crate::session::VERSION,
        frame: state.frame,
        master_ns: state.master_time_ns,
        display_ns: state.display_time_ns,
        period_ns: period.as_nanos() as u64,
        clock: match opts.clock {
            Clock::Live => SessionClock::Live,
            Clock::Replay => SessionClock::Replay,
        },
        tracker_samples: head.samples,
        recentred_from: head.recentred_from().map(|o| o.to_array()),
        navigation: state.navigation,
        objects: opts.objects.as_ref().map_or_else(Vec::new, |o| o.saved()),
        when: opts.sun.as_ref().map(|s| s.start().to_string()),
        time_of_day: opts.sun.as_ref().map(|s| s.now().to_string()),
    }
}

/// The frame loop's CAVEs: the config's placed in the scene by the navigation, the same in
/// room coordinates, and the eyes' frusta (in the room with navigation).
struct Caves {
    placed: Cave,
    in_room: Cave,
    frusta: CaveFrusta,
}

impl Caves {
    fn new(cave: &Cave, navigated: bool) -> Caves {
        let in_room = in_room(cave);
        let frusta = CaveFrusta::new(if navigated { &in_room } else { cave });
        Caves {
            placed: cave.clone(),
            in_room,
            frusta,
        }
    }

    /// Frame `frame`'s state at `(master_ns, display_ns)`: the head read and predicted to
    /// its display, the room placed by the navigation (and logged), the objects moved.
    fn state(
        &mut self,
        m: &mut Master<'_>,
        opts: &mut MasterOptions,
        head: &mut Head,
        nav_log: &mut Option<NavigationLog>,
        (frame, (master_ns, display_ns)): (u64, (u64, u64)),
    ) -> std::io::Result<FrameState> {
        head.advance(master_ns);
        let (pose, tracker_ns) = head.pose_at(display_ns);
        tracing::trace!("frame {frame}: head {:?}", pose.position);
        let place = m.navigate(
            opts.navigation.as_mut(),
            master_ns,
            &pose,
            head.recentring(),
        );
        if opts.navigation.is_some() {
            self.placed.room_to_scene = place.to_mat4();
        }
        if let Some(log) = nav_log {
            log.row(frame, master_ns, &place)?;
        }
        let times = FrameTimes {
            master_ns,
            display_ns,
            tracker_ns,
        };
        let world = FrameWorld {
            objects: objects_at(opts, display_ns, &place),
            when: time_of_day(opts, frame, master_ns),
        };
        let navigated = opts.navigation.is_some().then_some(&self.in_room);
        Ok(frame_state_of(
            &mut self.frusta,
            (&self.placed, navigated),
            (frame, times, &pose),
            world,
        ))
    }
}

/// `cave` in room coordinates (the room as the scene): with navigation the frusta are kept
/// so and placed in the scene each frame, so a wall holding its last good views (an eye on
/// or behind it) holds them where the room is now, not where it was.
fn in_room(cave: &Cave) -> Cave {
    let mut in_room = cave.clone();
    in_room.room_to_scene = glam::DMat4::IDENTITY;
    in_room
}

/// When frame `frame` starts and when it is shown on the master's clock (ns): about one
/// period after it starts (drawn, then swapped), on a live clock the paced period, on a
/// replay clock the configured one (a replay depends on nothing measured). A live clock
/// reads `clock_ns` at `start`; a replay's is `frame` periods.
fn frame_clock(
    clock: Clock,
    (start, frame, period): (Instant, u64, Duration),
    pacer: &Pacer,
    clock_ns: u64,
) -> (u64, u64) {
    let (master_ns, ahead) = match clock {
        Clock::Live => (clock_ns + start.elapsed().as_nanos() as u64, pacer.period()),
        Clock::Replay => (frame * period.as_nanos() as u64, period),
    };
    (master_ns, master_ns + ahead.as_nanos() as u64)
}

/// `msg` as the frame states' log holds it.
fn encoded(msg: &MasterMsg) -> std::io::Result<Vec<u8>> {
    encode(msg, MAX_CLUSTER_FRAME).map_err(|e| std::io::Error::other(e.to_string()))
}

/// Stops the accepting thread: its flag set, then one connection to wake it.
fn stop_accepting(
    accepting: &Accepting,
    addr: std::net::SocketAddr,
    acceptor: std::thread::JoinHandle<()>,
) {
    accepting.stop.store(true, Ordering::Relaxed);
    let _ = TcpStream::connect(addr);
    let _ = acceptor.join();
}

/// The frame states' log and the navigation's log, where asked for.
type Logs = (
    Option<std::io::BufWriter<std::fs::File>>,
    Option<NavigationLog>,
);

fn open_logs(opts: &MasterOptions) -> std::io::Result<Logs> {
    // A resumed session's log goes on after the killed master's (whose unwritten tail is
    // lost: the buffer only ever writes whole states, so the file holds whole ones).
    let states = match &opts.states_log {
        Some(p) if opts.resume.is_some() => {
            let f = std::fs::OpenOptions::new()
                .append(true)
                .create(true)
                .open(p)?;
            Some(std::io::BufWriter::new(f))
        }
        Some(p) => Some(std::io::BufWriter::new(std::fs::File::create(p)?)),
        None => None,
    };
    let nav_log = match &opts.navigation_log {
        Some(p) if opts.resume.is_some() => Some(NavigationLog::append(p)?),
        Some(p) => Some(NavigationLog::create(p)?),
        None => None,
    };
    Ok((states, nav_log))
}

/// The tick after `tick`, one `period` on; from now where the loop fell more than a period
/// behind (a stall), rather than racing to catch up.
fn next_tick_after(tick: Instant, period: Duration) -> Instant {
    let next = tick + period;
    let now = Instant::now();
    if now > next + period { now } else { next }
}

/// Where the last status line left off.
struct StatusClock {
    since: Instant,
    frame: u64,
    samples: u64,
    pace: BTreeMap<String, (u64, Duration)>,
}

impl StatusClock {
    fn new(start: Instant, frame: u64) -> StatusClock {
        StatusClock {
            since: start,
            frame,
            samples: 0,
            pace: BTreeMap::new(),
        }
    }

    /// [`Self::line`], with `extra`'s part after it.
    fn line_with(
        &mut self,
        m: &Master<'_>,
        (frame, now): (u64, Instant),
        head: &Head,
        extra: Option<&mut Box<dyn FnMut() -> String + Send>>,
    ) -> String {
        let line = self.line(m, frame, now, head);
        match extra {
            Some(extra) => format!("{line} | {}", extra()),
            None => line,
        }
    }

    /// The status line for the frames and tracker samples since the last one.
    fn line(&mut self, m: &Master<'_>, frame: u64, now: Instant, head: &Head) -> String {
        let secs = (now - self.since).as_secs_f64();
        let rate = (frame + 1 - self.frame) as f64 / secs;
        let tracker_hz = (head.samples - self.samples) as f64 / secs;
        let line = m.status_line(frame, rate, tracker_hz, head, &self.pace);
        *self = StatusClock {
            since: now,
            frame: frame + 1,
            samples: head.samples,
            pace: m.summary.pace.clone(),
        };
        line
    }
}
