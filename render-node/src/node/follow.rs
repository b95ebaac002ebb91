//! A render node in a cluster: its link to the master and the frame cycle — take the
//! newest frame state, draw it, say Ready, show it on Swap. A node that falls behind skips
//! to the newest state instead of drawing a backlog, so it catches up in one frame.

use std::net::TcpStream;
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError, channel};
use std::time::{Duration, Instant};

use glam::DMat4;
use holocave_cave::{Size, Wall};
use holocave_protocol::cluster::{
    DeskInput, FrameState, MAX_CLUSTER_FRAME, MasterMsg, NodeMsg, NodeStats, VeilSource,
};
use holocave_protocol::handshake::{self, Role, Welcome};
use holocave_protocol::session::Sealer;

use crate::display::FrameReport;
use crate::{EyeView, WallDisplay};

/// How long the handshake may take.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(2);

/// Why the link to the master failed or ended.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("cannot reach the master at {addr}: {source}")]
    Connect {
        addr: String,
        source: std::io::Error,
    },
    #[error("handshake with the master at {addr}: {source}")]
    Handshake {
        addr: String,
        source: handshake::HandshakeError,
    },
    #[error("link to the master lost: {0}")]
    Lost(String),
}

impl LinkError {
    /// Whether the master (or what answers at its address) said no: a refusal, a failed
    /// authentication, another cluster or protocol version, not a holocave peer. Trying
    /// again changes nothing. A connection that ended or failed during the handshake (a
    /// master dying, or one not yet serving its port) is not a refusal.
    pub fn is_refusal(&self) -> bool {
        use holocave_protocol::frame::FrameError;
        match self {
            LinkError::Handshake { source, .. } => !matches!(
                source,
                handshake::HandshakeError::Frame(
                    FrameError::Io(_) | FrameError::Closed | FrameError::Truncated { .. }
                )
            ),
            _ => false,
        }
    }
}

/// An authenticated connection to the master. A reader thread turns its messages into a
/// channel, so waiting for the next one has a timeout and never blocks a frame.
pub struct MasterLink {
    writer: TcpStream,
    sealer: Sealer,
    messages: Receiver<Result<MasterMsg, String>>,
    pub welcome: Welcome,
}

impl MasterLink {
    /// Connects and authenticates as the node of `wall`.
    pub fn connect(
        addr: &str,
        cluster: &str,
        wall: &str,
        secret: &[u8],
    ) -> Result<MasterLink, LinkError> {
        let mut stream = TcpStream::connect(addr).map_err(|source| LinkError::Connect {
            addr: addr.to_owned(),
            source,
        })?;
        let _ = stream.set_nodelay(true);
        let _ = stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT));
        let role = Role::Node {
            wall: wall.to_owned(),
        };
        let linked = handshake::connect(&mut stream, cluster, role, secret).map_err(|source| {
            LinkError::Handshake {
                addr: addr.to_owned(),
                source,
            }
        })?;
        let (sealer, mut opener) = linked.keys.connector();
        let _ = stream.set_read_timeout(None);
        let mut reader = stream
            .try_clone()
            .map_err(|e| LinkError::Lost(e.to_string()))?;
        let (tx, messages) = channel();
        std::thread::Builder::new()
            .name("master link".into())
            .spawn(move || {
                loop {
                    let msg = opener
                        .read::<_, MasterMsg>(&mut reader, MAX_CLUSTER_FRAME)
                        .map_err(|e| e.to_string());
                    let end = msg.is_err();
                    if tx.send(msg).is_err() || end {
                        return;
                    }
                }
            })
            .map_err(|e| LinkError::Lost(e.to_string()))?;
        Ok(MasterLink {
            writer: stream,
            sealer,
            messages,
            welcome: linked.welcome,
        })
    }

    /// The next message, waiting at most `timeout` (`None` when none came).
    pub fn recv(&self, timeout: Duration) -> Result<Option<MasterMsg>, LinkError> {
        match self.messages.recv_timeout(timeout) {
            Ok(m) => m.map(Some).map_err(LinkError::Lost),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(LinkError::Lost("reader ended".into())),
        }
    }

    /// The next message if one is already here.
    pub fn try_recv(&self) -> Result<Option<MasterMsg>, LinkError> {
        match self.messages.try_recv() {
            Ok(m) => m.map(Some).map_err(LinkError::Lost),
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(LinkError::Lost("reader ended".into())),
        }
    }

    /// Tells the master this node is going away (so it is not waited for).
    pub fn leaving(&mut self, reason: &str) -> Result<(), LinkError> {
        self.sealer
            .write(
                &mut self.writer,
                &NodeMsg::Leaving {
                    reason: reason.to_owned(),
                },
                MAX_CLUSTER_FRAME,
            )
            .map_err(|e| LinkError::Lost(e.to_string()))
    }

    /// The desk user's keys and mouse, as navigation input.
    pub fn desk(&mut self, input: DeskInput) -> Result<(), LinkError> {
        self.sealer
            .write(
                &mut self.writer,
                &NodeMsg::DeskInput(input),
                MAX_CLUSTER_FRAME,
            )
            .map_err(|e| LinkError::Lost(e.to_string()))
    }

    /// This wall's veiling sources, for the master to relay to the other walls.
    pub fn veil(&mut self, sources: Vec<VeilSource>) -> Result<(), LinkError> {
        self.sealer
            .write(
                &mut self.writer,
                &NodeMsg::Veil { sources },
                MAX_CLUSTER_FRAME,
            )
            .map_err(|e| LinkError::Lost(e.to_string()))
    }

    /// Tells the master that `frame` is drawn.
    pub fn ready(&mut self, frame: u64, stats: NodeStats) -> Result<(), LinkError> {
        self.sealer
            .write(
                &mut self.writer,
                &NodeMsg::Ready { frame, stats },
                MAX_CLUSTER_FRAME,
            )
            .map_err(|e| LinkError::Lost(e.to_string()))
    }
}

/// The eye views of `wall` in a frame state, at `size` pixels; `None` if the state has no
/// such wall (a master with another config).
pub fn eye_views(state: &FrameState, wall: &Wall, size: Size) -> Option<Vec<EyeView>> {
    let w = state.wall(&wall.name)?;
    let nav = DMat4::from_cols_array(&state.navigation);
    Some(
        w.eyes
            .iter()
            .map(|e| EyeView::from_state(e, wall, &nav, size))
            .collect(),
    )
}

/// What a node does with the frames it draws. Headless, `show` writes a swapped frame (a
/// closure is one); a window `prepare`s each frame before Ready (draws it into the surface
/// and waits for the GPU), `show`s it on Swap (present), and `abandon`s it when a newer
/// frame state comes first.
pub trait Presentation {
    /// After drawing, before Ready.
    fn prepare(&mut self, _state: &FrameState, _display: &mut WallDisplay) {}
    /// On the frame's Swap.
    fn show(&mut self, state: &FrameState, display: &mut WallDisplay) -> Result<(), String>;
    /// The prepared frame will not be swapped.
    fn abandon(&mut self, _state: &FrameState) {}
    /// The user asked the node to stop (a window closed): `Some(reason)`.
    fn closed(&self) -> Option<String> {
        None
    }
    /// The desk user's input changes since the last call (windows), oldest first.
    fn desk_inputs(&mut self) -> Vec<DeskInput> {
        Vec::new()
    }
    /// Another wall's veiling sources, relayed by the master (human mode).
    fn import_veil(&mut self, _wall: &str, _sources: &[VeilSource]) {}
    /// This wall's veiling sources found in the frame just prepared (on `display`'s
    /// device), to share once.
    fn export_veil(&mut self, _display: &WallDisplay) -> Option<Vec<VeilSource>> {
        None
    }
}

/// Sends the desk user's input changes to the master.
fn send_desk(link: &mut MasterLink, present: &mut dyn Presentation) -> Result<(), LinkError> {
    for input in present.desk_inputs() {
        link.desk(input)?;
    }
    Ok(())
}

impl<F> Presentation for F
where
    F: FnMut(&FrameState, &mut WallDisplay) -> Result<(), String>,
{
    fn show(&mut self, state: &FrameState, display: &mut WallDisplay) -> Result<(), String> {
        self(state, display)
    }
}

/// What the node has done so far (kept across reconnections).
#[derive(Clone, Copy, Debug, Default)]
pub struct NodeCounters {
    pub presented: u64,
    pub skipped: u64,
    pub last_presented: Option<u64>,
}

/// A frame's Ready figures: its drawing took `drawn`, did what `report` says, and the
/// node's `counters` so far.
fn ready_stats(drawn: Duration, report: &FrameReport, counters: &NodeCounters) -> NodeStats {
    let clamp = |n: usize| n.min(u32::MAX as usize) as u32;
    NodeStats {
        draw_us: drawn.as_micros().min(u128::from(u32::MAX)) as u32,
        samples: clamp(report.inserted),
        presented: counters.presented,
        skipped: counters.skipped,
        traced: clamp(report.vlf_work.traced),
        reused: clamp(report.vlf_work.reused),
        estimated: clamp(report.vlf_work.estimated),
    }
}

/// How following the master ended.
#[derive(Debug)]
pub enum Ended {
    /// The master said so.
    Shutdown(String),
    /// The link failed; the caller may reconnect.
    Lost(LinkError),
    /// The display's holodeck server went away (the master link is still up): the caller
    /// makes a new display and follows on.
    SourceLost,
    /// The user closed the node (its window); the master has been told.
    Closed(String),
    /// This frame is for another time of day than the display is lit for: the caller
    /// makes the display again for it and follows on from this frame.
    Relight(Box<FrameState>),
}

/// Follows the master's frames until it shuts down or the link fails, drawing on
/// `display` (lit for the time of day `lit`), `first` first when given. `present` shows a
/// swapped frame (writes it, for a headless node). `slow_by` is added to every frame's
/// drawing (a wall made slow on purpose, to see frame lock hold; zero otherwise).
#[allow(clippy::too_many_arguments)]
pub fn follow(
    link: &mut MasterLink,
    (display, lit, first): (&mut WallDisplay, Option<&str>, Option<FrameState>),
    wall: &Wall,
    size: Size,
    slow_by: Duration,
    counters: &mut NodeCounters,
    present: &mut dyn Presentation,
) -> Ended {
    let mut next: Option<FrameState> = first;
    let mut warmed = false;
    loop {
        if let Some(reason) = present.closed() {
            let _ = link.leaving(&reason);
            return Ended::Closed(reason);
        }
        if let Err(e) = send_desk(link, present) {
            return Ended::Lost(e);
        }
        let mut state = match next.take() {
            Some(s) => s,
            None => match link.recv(Duration::from_secs(1)) {
                Ok(Some(MasterMsg::Frame(s))) => s,
                Ok(Some(MasterMsg::Veil { wall, sources })) => {
                    present.import_veil(&wall, &sources);
                    continue;
                }
                Ok(Some(MasterMsg::Swap { .. })) | Ok(None) => continue,
                Ok(Some(MasterMsg::Shutdown { reason })) => return Ended::Shutdown(reason),
                Err(e) => return Ended::Lost(e),
            },
        };
        // The newest state wins: draw only the frame the master is collecting now.
        loop {
            match link.try_recv() {
                Ok(Some(MasterMsg::Frame(s))) => {
                    counters.skipped += 1;
                    state = s;
                }
                Ok(Some(MasterMsg::Swap { .. })) => {}
                Ok(Some(MasterMsg::Veil { wall, sources })) => present.import_veil(&wall, &sources),
                Ok(Some(MasterMsg::Shutdown { reason })) => return Ended::Shutdown(reason),
                Ok(None) => break,
                Err(e) => return Ended::Lost(e),
            }
        }
        // Checked after the master's messages, so a shutdown (which stops a holodeck the
        // master hosts) is seen as one.
        if display.source_lost() {
            return Ended::SourceLost;
        }
        if state.when.as_deref() != lit {
            return Ended::Relight(Box::new(state));
        }
        let Some(views) = eye_views(&state, wall, size) else {
            return Ended::Lost(LinkError::Lost(format!(
                "the master's frame {} has no wall {:?}",
                state.frame, wall.name
            )));
        };
        let t = Instant::now();
        display.place_objects(&state.objects);
        let report = display.frame(&views, false);
        warmed = warmed || told_warmed(display, wall, state.frame);
        if !slow_by.is_zero() {
            std::thread::sleep(slow_by);
        }
        present.prepare(&state, display);
        if let Some(sources) = present.export_veil(display)
            && let Err(e) = link.veil(sources)
        {
            return Ended::Lost(e);
        }
        let stats = ready_stats(t.elapsed(), &report, counters);
        if let Err(e) = send_desk(link, present) {
            return Ended::Lost(e);
        }
        if let Err(e) = link.ready(state.frame, stats) {
            return Ended::Lost(e);
        }
        match await_swap(link, display, present, &state, counters) {
            Ok(newer) => next = newer,
            Err(ended) => return ended,
        }
    }
}

/// Logs, and says, whether the display has drawn samples from its holodeck by `frame`:
/// a node (re)joining a filled holodeck gets its stored samples at once, so its wall is
/// warm in its first frames rather than empty.
fn told_warmed(display: &WallDisplay, wall: &Wall, frame: u64) -> bool {
    let Some(counts) = display.holodeck_counts().filter(|c| c.used > 0) else {
        return false;
    };
    tracing::info!(
        "wall {:?}: drawing {} samples from the holodeck by frame {frame}",
        wall.name,
        counts.used
    );
    true
}

/// Waits for frame `state`'s Swap and shows it; a newer frame instead means the master went
/// on without this node (it was late): that one is returned, to be drawn next. `Err`: how
/// following ended meanwhile.
fn await_swap(
    link: &mut MasterLink,
    display: &mut WallDisplay,
    present: &mut dyn Presentation,
    state: &FrameState,
    counters: &mut NodeCounters,
) -> Result<Option<FrameState>, Ended> {
    loop {
        match link.recv(Duration::from_secs(1)) {
            Ok(Some(MasterMsg::Swap { frame })) if frame == state.frame => {
                if let Err(e) = present.show(state, display) {
                    tracing::error!("frame {}: {e}", state.frame);
                }
                counters.presented += 1;
                counters.last_presented = Some(frame);
                return Ok(None);
            }
            Ok(Some(MasterMsg::Veil { wall, sources })) => present.import_veil(&wall, &sources),
            Ok(Some(MasterMsg::Swap { .. })) | Ok(None) => {
                if let Some(reason) = present.closed() {
                    present.abandon(state);
                    let _ = link.leaving(&reason);
                    return Err(Ended::Closed(reason));
                }
            }
            Ok(Some(MasterMsg::Frame(s))) => {
                counters.skipped += 1;
                present.abandon(state);
                return Ok(Some(s));
            }
            Ok(Some(MasterMsg::Shutdown { reason })) => {
                present.abandon(state);
                return Err(Ended::Shutdown(reason));
            }
            Err(e) => {
                present.abandon(state);
                return Err(Ended::Lost(e));
            }
        }
    }
}
