//! The display service (paper §2.4.2): displays tell the server which beams they want and
//! where their eyes are; the server answers at once with the stored samples of the beams
//! they asked for, then sends new samples as workers return them.
//!
//! The server side is a [`Hub`] of subscribed displays next to the [`Server`] (locked after
//! it). Each subscriber remembers how many samples of each beam it has received (a prefix:
//! beams only grow at the end), so a display that repeats its request gets each sample
//! once, and new samples of a beam it is up to date on are sent to it even when another
//! display asked for them (they are welcome: the render cache keeps what fits its views).
//!
//! The client side, [`DisplayClient`], is the same for a display in the server's process
//! ([`crate::run::Running::display`]) and one over TCP ([`DisplayClient::connect`]):
//! [`DisplayClient::request`] and [`DisplayClient::collect`] never block; a background
//! thread talks to the server.

use std::collections::BTreeMap;
use std::io::{BufReader, BufWriter, Write};
use std::net::{Shutdown, SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use glam::DVec3;
use holocave_protocol::frame::{self, FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::{
    BeamBatch, BeamRequest, DisplayHello, DisplayWelcome, PROTOCOL_VERSION, RecordError,
    SAMPLE_RECORD_BYTES, ServerMsg, WireSection, WorkerMsg,
};

use crate::cache::{BeamKey, BeamMap};
use crate::proximity::Eye;
use crate::sample::Sample;
use crate::section::{Section, ViewClass};
use crate::server::{BeamSamples, DisplayId, Server, ServerError};

/// Eye slots per display (requests of slot `k` of display `d` are the server's display
/// `d * SLOTS + k`).
pub const SLOTS: u32 = 4;

/// One eye's wanted beams (replacing that eye's previous request).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EyeRequest {
    /// Which eye of the display (`0..SLOTS`).
    pub slot: u8,
    /// Where new rays should pass (Appendix A); `None`: anywhere in the beam.
    pub eye: Option<Eye>,
    /// Beams and how many samples each should have in all.
    pub wanted: Vec<(BeamKey, f64)>,
}

/// Samples that arrived for a display, as the server grouped them.
pub type Arrival = Arc<Vec<BeamSamples>>;

type Deliver = Box<dyn Fn(Arrival) -> bool + Send>;

struct Subscriber {
    display: u32,
    known: BeamMap<BeamKey, u32>,
    deliver: Deliver,
}

/// The displays subscribed to a server's samples.
#[derive(Default)]
pub struct Hub {
    subs: BTreeMap<u64, Subscriber>,
    next: u64,
}

impl Hub {
    /// Adds a display; `deliver` hands it samples and returns false once it is gone.
    pub fn subscribe(&mut self, display: u32, deliver: Deliver) -> u64 {
        let token = self.next;
        self.next += 1;
        self.subs.insert(
            token,
            Subscriber {
                display,
                known: BeamMap::default(),
                deliver,
            },
        );
        token
    }

    /// Removes a display and its requests.
    pub fn unsubscribe(&mut self, server: &mut Server, token: u64) {
        if let Some(s) = self.subs.remove(&token) {
            let still = self.subs.values().any(|o| o.display == s.display);
            if !still {
                for k in 0..SLOTS {
                    server.remove_display(s.display * SLOTS + k);
                }
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.subs.is_empty()
    }

    /// Serves one eye's request: sets it on the server and sends the display the stored
    /// samples it does not have yet.
    pub fn request(
        &mut self,
        server: &mut Server,
        token: u64,
        req: EyeRequest,
    ) -> Result<(), ServerError> {
        let Some(sub) = self.subs.get_mut(&token) else {
            return Ok(());
        };
        let id: DisplayId = sub.display * SLOTS + u32::from(req.slot) % SLOTS;
        let got = server.set_requests_once(id, req.wanted, req.eye, &mut sub.known)?;
        if !got.is_empty() && !(sub.deliver)(Arc::new(got)) {
            self.unsubscribe(server, token);
        }
        Ok(())
    }

    /// Sends new samples (as [`Server::complete`] returned them, already added) to every
    /// display up to date on their beams.
    pub fn distribute(&mut self, server: &mut Server, new: &[BeamSamples]) {
        if new.is_empty() || self.subs.is_empty() {
            return;
        }
        // One packet may hold several bundles of a beam: what is new per beam.
        let mut added: BeamMap<BeamKey, u32> = BeamMap::default();
        for b in new {
            *added.entry(b.key).or_default() += b.samples.len() as u32;
        }
        let mut gone = Vec::new();
        for (&token, sub) in &mut self.subs {
            let mut out = Vec::new();
            for b in new {
                let n = server.cache().count(b.key);
                let before = n.saturating_sub(added[&b.key]);
                let k = sub.known.entry(b.key).or_default();
                if *k == before {
                    *k = n;
                }
                // Sent only to displays that have all the earlier samples (the others ask
                // again and get the rest with what they lack).
                if *k == n {
                    out.push(b.clone());
                }
            }
            if !out.is_empty() && !(sub.deliver)(Arc::new(out)) {
                gone.push(token);
            }
        }
        for t in gone {
            self.unsubscribe(server, t);
        }
    }
}

/// Sections as sent to displays.
pub fn wire_sections(sections: &[Section]) -> Vec<WireSection> {
    sections
        .iter()
        .map(|s| WireSection {
            origin: s.origin().to_array(),
            edges: s.edges().map(|e| e.to_array()),
            grid: s.grid(),
            class: s.class().to_byte(),
        })
        .collect()
}

/// Sections as a display rebuilds them.
pub fn sections_from_wire(wire: &[WireSection]) -> Result<Vec<Section>, DisplayError> {
    wire.iter()
        .enumerate()
        .map(|(i, w)| {
            let class = ViewClass::from_byte(w.class).ok_or_else(|| {
                DisplayError::Protocol(format!("section {i}: view class {}", w.class))
            })?;
            Section::new(
                DVec3::from_array(w.origin),
                w.edges.map(DVec3::from_array),
                w.grid,
                class,
            )
            .map_err(|e| DisplayError::Protocol(format!("section {i}: {e}")))
        })
        .collect()
}

/// Packs samples into batches of at most about `max_bytes` each.
pub fn pack(beams: &[BeamSamples], max_bytes: usize) -> Vec<BeamBatch> {
    let mut out = vec![BeamBatch::default()];
    let mut rec = Vec::new();
    for b in beams {
        for chunk in b.samples.chunks((max_bytes / SAMPLE_RECORD_BYTES).max(1)) {
            if out.last().is_some_and(|l| {
                !l.is_empty() && l.len_bytes() + chunk.len() * SAMPLE_RECORD_BYTES > max_bytes
            }) {
                out.push(BeamBatch::default());
            }
            rec.clear();
            Sample::write_all(chunk, &mut rec);
            out.last_mut()
                .expect("never empty")
                .push(b.key.0, b.key.1, &rec);
        }
    }
    out.retain(|b| !b.is_empty());
    out
}

/// Unpacks a batch.
pub fn unpack(batch: &BeamBatch) -> Result<Vec<BeamSamples>, RecordError> {
    Ok(batch
        .beams()?
        .into_iter()
        .map(|(s, b, rec)| {
            let mut samples = Vec::new();
            Sample::read_all(rec, &mut samples);
            BeamSamples {
                key: (s, b),
                samples,
            }
        })
        .collect())
}

#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("cannot connect to holodeck server {addr}: {source}")]
    Connect {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("holodeck server {addr}: {source}")]
    Frame {
        addr: SocketAddr,
        source: FrameError,
    },
    #[error("holodeck server: {0}")]
    Protocol(String),
}

/// A display's link to a holodeck server, in its process or over TCP.
pub struct DisplayClient {
    sections: Vec<Section>,
    requests: Option<Sender<EyeRequest>>,
    arrivals: Receiver<Arrival>,
    connected: Arc<AtomicBool>,
    socket: Option<TcpStream>,
    threads: Vec<JoinHandle<()>>,
}

impl DisplayClient {
    /// A client whose requests go to `serve` on a thread of its own and whose samples
    /// come through `arrivals` (for [`crate::run::Running::display`]).
    pub(crate) fn local(
        sections: Vec<Section>,
        arrivals: Receiver<Arrival>,
        mut serve: impl FnMut(EyeRequest) + Send + 'static,
        on_close: impl FnOnce() + Send + 'static,
    ) -> DisplayClient {
        let (tx, rx) = channel::<EyeRequest>();
        let connected = Arc::new(AtomicBool::new(true));
        let handle = std::thread::Builder::new()
            .name("holodeck display".into())
            .spawn(move || {
                while let Ok(first) = rx.recv() {
                    // Only the newest request of each slot matters.
                    let mut newest = BTreeMap::new();
                    for r in std::iter::once(first).chain(rx.try_iter()) {
                        newest.insert(r.slot, r);
                    }
                    for r in newest.into_values() {
                        serve(r);
                    }
                }
                on_close();
            })
            .expect("spawn the display thread");
        DisplayClient {
            sections,
            requests: Some(tx),
            arrivals,
            connected,
            socket: None,
            threads: vec![handle],
        }
    }

    /// Connects to the holodeck server at `addr` as display `display` (the wall's number;
    /// its eyes are slots of it). Blocks only for the handshake (at most 10 s).
    pub fn connect(addr: SocketAddr, display: u32) -> Result<DisplayClient, DisplayError> {
        let err = |source| DisplayError::Connect { addr, source };
        let ferr = |source| DisplayError::Frame { addr, source };
        let sock = TcpStream::connect_timeout(&addr, Duration::from_secs(10)).map_err(err)?;
        sock.set_nodelay(true).ok();
        sock.set_read_timeout(Some(Duration::from_secs(10)))
            .map_err(err)?;
        let mut w = BufWriter::new(sock.try_clone().map_err(err)?);
        let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "display".into());
        frame::write_frame(
            &mut w,
            &WorkerMsg::DisplayHello(DisplayHello {
                protocol: PROTOCOL_VERSION,
                display,
                name: format!("{host} display {display}"),
            }),
            MAX_FRAME_BYTES,
        )
        .map_err(ferr)?;
        w.flush().map_err(|e| ferr(e.into()))?;
        let mut r = BufReader::new(sock.try_clone().map_err(err)?);
        let welcome: DisplayWelcome = match frame::read_frame(&mut r, MAX_FRAME_BYTES) {
            Ok(ServerMsg::DisplayWelcome(w)) => w,
            Ok(other) => {
                return Err(DisplayError::Protocol(format!(
                    "expected a display welcome, got {}",
                    msg_name(&other)
                )));
            }
            Err(FrameError::Closed) => {
                return Err(DisplayError::Protocol(
                    "the server closed the connection (another protocol version?)".into(),
                ));
            }
            Err(e) => return Err(ferr(e)),
        };
        sock.set_read_timeout(None).map_err(err)?;
        let sections = sections_from_wire(&welcome.sections)?;
        let connected = Arc::new(AtomicBool::new(true));
        let (atx, arrivals) = channel();
        let (tx, rx) = channel::<EyeRequest>();
        let reader = {
            let connected = connected.clone();
            std::thread::Builder::new()
                .name("holodeck display reader".into())
                .spawn(move || {
                    loop {
                        match frame::read_frame::<_, ServerMsg>(&mut r, MAX_FRAME_BYTES) {
                            Ok(ServerMsg::Beams(b)) => match unpack(&b) {
                                Ok(v) => {
                                    if atx.send(Arc::new(v)).is_err() {
                                        break;
                                    }
                                }
                                Err(e) => {
                                    tracing::warn!("holodeck server {addr}: {e}");
                                    break;
                                }
                            },
                            Ok(ServerMsg::Bye) | Err(FrameError::Closed) => break,
                            Ok(other) => {
                                tracing::warn!(
                                    "holodeck server {addr} sent {}: closing",
                                    msg_name(&other)
                                );
                                break;
                            }
                            Err(e) => {
                                tracing::warn!("holodeck server {addr}: {e}");
                                break;
                            }
                        }
                    }
                    connected.store(false, Ordering::SeqCst);
                })
                .expect("spawn the display reader")
        };
        let writer = {
            let connected = connected.clone();
            std::thread::Builder::new()
                .name("holodeck display writer".into())
                .spawn(move || {
                    while let Ok(req) = rx.recv() {
                        let mut m = BeamRequest {
                            slot: req.slot,
                            eye: req.eye.map_or([0.0; 3], |e| e.pos.to_array()),
                            radius: req.eye.map_or(0.0, |e| e.radius),
                            wanted: Vec::with_capacity(req.wanted.len() * 10),
                        };
                        for ((s, b), n) in req.wanted {
                            m.push(s, b, n as f32);
                        }
                        let sent =
                            frame::write_frame(&mut w, &WorkerMsg::Request(m), MAX_FRAME_BYTES)
                                .and_then(|()| w.flush().map_err(FrameError::from));
                        if let Err(e) = sent {
                            tracing::warn!("holodeck server {addr}: {e}");
                            break;
                        }
                    }
                    connected.store(false, Ordering::SeqCst);
                    let _ = w.get_ref().shutdown(Shutdown::Both);
                })
                .expect("spawn the display writer")
        };
        Ok(DisplayClient {
            sections,
            requests: Some(tx),
            arrivals,
            connected,
            socket: Some(sock),
            threads: vec![reader, writer],
        })
    }

    /// The holodeck's sections (to turn eye rays into beams and samples into points).
    pub fn sections(&self) -> &[Section] {
        &self.sections
    }

    /// Sends one eye's wanted beams (never blocks).
    pub fn request(&self, req: EyeRequest) {
        if let Some(tx) = &self.requests {
            let _ = tx.send(req);
        }
    }

    /// The samples that arrived since the last call (never blocks).
    pub fn collect(&self) -> Vec<Arrival> {
        self.arrivals.try_iter().collect()
    }

    /// Whether the link to the server is up (false once a TCP server went away).
    pub fn is_connected(&self) -> bool {
        self.connected.load(Ordering::SeqCst)
    }
}

impl Drop for DisplayClient {
    fn drop(&mut self) {
        self.requests = None;
        if let Some(s) = &self.socket {
            let _ = s.shutdown(Shutdown::Both);
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn msg_name(m: &ServerMsg) -> &'static str {
    match m {
        ServerMsg::Welcome(_) => "a worker welcome",
        ServerMsg::Rays(_) => "rays",
        ServerMsg::Bye => "bye",
        ServerMsg::DisplayWelcome(_) => "a display welcome",
        ServerMsg::Beams(_) => "samples",
    }
}

/// The request message as the server reads it.
pub(crate) fn eye_request(m: &BeamRequest) -> Result<EyeRequest, RecordError> {
    Ok(EyeRequest {
        slot: m.slot,
        eye: (m.radius > 0.0 && m.eye.iter().all(|v| v.is_finite())).then(|| Eye {
            pos: DVec3::from_array(m.eye),
            radius: m.radius,
        }),
        wanted: m
            .beams()?
            .into_iter()
            .filter(|r| r.2.is_finite() && r.2 > 0.0)
            .map(|(s, b, n)| ((s, b), f64::from(n)))
            .collect(),
    })
}

/// The welcome a display gets.
pub(crate) fn welcome(server: &Server, scene: &str) -> DisplayWelcome {
    DisplayWelcome {
        scene: scene.into(),
        sections: wire_sections(server.cache().file().sections()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_splits_big_beams_and_round_trips() {
        let s = |i: u8| Sample {
            rgbe: [i, 1, 2, 128],
            entry: [i, i],
            exit: [3, 4],
            dist: u16::from(i),
        };
        let beams = vec![
            BeamSamples {
                key: (0, 5),
                samples: (0..50).map(s).collect(),
            },
            BeamSamples {
                key: (1, 7),
                samples: (0..3).map(s).collect(),
            },
        ];
        let packed = pack(&beams, 200);
        assert!(packed.len() >= 3);
        assert!(packed.iter().all(|b| b.len_bytes() <= 200 + 10));
        let mut back: Vec<(BeamKey, Sample)> = Vec::new();
        for b in &packed {
            for bs in unpack(b).unwrap() {
                back.extend(bs.samples.iter().map(|x| (bs.key, *x)));
            }
        }
        let want: Vec<(BeamKey, Sample)> = beams
            .iter()
            .flat_map(|b| b.samples.iter().map(move |x| (b.key, *x)))
            .collect();
        assert_eq!(back, want);
    }
}
