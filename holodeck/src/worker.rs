//! Workers (paper §2.3): whatever computes radiance and distance for rays, run as threads
//! in the server's process or as separate processes connected over TCP.
//!
//! The holodeck does not depend on the tracer: a sample generator plugs in through
//! [`SampleSource`] (`holocave_tracer::HolodeckTracer` is the path tracer; tests use
//! analytic ones).

use std::io::{BufReader, BufWriter, Write};
use std::net::{TcpStream, ToSocketAddrs};

pub use crate::file::DistanceKind;
use glam::Vec3;

use crate::auth::{self, Credentials};
use holocave_protocol::frame::{FrameError, MAX_FRAME_BYTES};
use holocave_protocol::handshake::{HandshakeError, Role};
use holocave_protocol::holodeck::{
    PROTOCOL_VERSION, RayPacket, RecordError, SamplePacket, ServerMsg, WorkerHello, WorkerMsg,
};
use holocave_protocol::session::Opener;

/// A ray a worker traces (scene coordinates, single precision as packets carry it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceRay {
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

/// What a worker answers for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SourceResult {
    /// Linear RGB radiance arriving along the ray.
    pub radiance: [f32; 3],
    /// Distance from the ray's origin, of the kind asked for; `+Inf` if it escapes.
    pub distance: f32,
}

/// A sample generator.
pub trait SampleSource: Send + Sync {
    /// Radiance and distance from the origin of the kind asked for (`+Inf` if the ray, or
    /// for [`DistanceKind::Virtual`] its specular continuation, escapes) for each ray,
    /// deterministic for a seed, on the calling thread.
    fn trace(&self, rays: &[SourceRay], seed: u64, distance: DistanceKind) -> Vec<SourceResult>;
}

/// Traces one packet.
pub fn trace_packet(
    source: &dyn SampleSource,
    packet: &RayPacket,
    distance: DistanceKind,
) -> Result<SamplePacket, RecordError> {
    let n = packet.len();
    Ok(
        trace_packet_in_parts(source, packet, distance, |_| Some(n))?
            .expect("one part of the whole packet"),
    )
}

/// Traces one packet in parts: `part(left)` says how many of the `left` rays still to
/// trace to trace next (at least one), or `None` to give the packet up (then the answer
/// is `None`). The first part is traced with the packet's seed, a part from ray `i > 0`
/// on with a seed of its own, so a packet traced in one part is [`trace_packet`]'s and
/// parts never reuse a ray's random numbers.
pub fn trace_packet_in_parts(
    source: &dyn SampleSource,
    packet: &RayPacket,
    distance: DistanceKind,
    mut part: impl FnMut(usize) -> Option<usize>,
) -> Result<Option<SamplePacket>, RecordError> {
    let rays: Vec<SourceRay> = packet
        .rays()?
        .into_iter()
        .map(|(o, d)| SourceRay {
            origin: Vec3::from_array(o),
            dir: Vec3::from_array(d),
        })
        .collect();
    let mut results = Vec::with_capacity(rays.len());
    while results.len() < rays.len() {
        let first = results.len();
        let Some(n) = part(rays.len() - first) else {
            return Ok(None);
        };
        let n = n.clamp(1, rays.len() - first);
        let seed = if first == 0 {
            packet.seed
        } else {
            packet.seed ^ (first as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        };
        let traced = source.trace(&rays[first..first + n], seed, distance);
        let short = traced.len() != n;
        results.extend(traced);
        if short {
            // A source that answers the wrong count: the server refuses the packet.
            break;
        }
    }
    let mut out = SamplePacket {
        id: packet.id,
        results: Vec::with_capacity(results.len() * 16),
    };
    for r in results {
        out.push(r.radiance, r.distance);
    }
    Ok(Some(out))
}

#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    #[error("cannot connect to holodeck server {addr}: {source}")]
    Connect {
        addr: String,
        source: std::io::Error,
    },
    #[error("holodeck server {addr}: {source}")]
    Frame { addr: String, source: FrameError },
    #[error("holodeck server {addr}: {source}")]
    Handshake {
        addr: String,
        source: holocave_protocol::handshake::HandshakeError,
    },
    #[error("holodeck server {addr} sent {what} where {expected} was expected")]
    Unexpected {
        addr: String,
        what: &'static str,
        expected: &'static str,
    },
    #[error("holodeck server {addr}: {source}")]
    Records { addr: String, source: RecordError },
}

impl WorkerError {
    /// Whether the server could not be reached or went away at once: none listens at its
    /// address (yet), or its connection broke during the handshake or the hello (a dying
    /// server's last accepted connections). Worth trying again, unlike a refusal.
    pub fn is_unreachable(&self) -> bool {
        match self {
            WorkerError::Connect { .. } => true,
            WorkerError::Frame { source, .. } => server_gone(source),
            WorkerError::Handshake {
                source: HandshakeError::Frame(f),
                ..
            } => server_gone(f),
            _ => false,
        }
    }
}

/// Whether a frame error means the server closed the connection.
fn server_gone(e: &FrameError) -> bool {
    use std::io::ErrorKind::{BrokenPipe, ConnectionAborted, ConnectionReset};
    match e {
        FrameError::Closed => true,
        FrameError::Io(io) => matches!(io.kind(), BrokenPipe | ConnectionReset | ConnectionAborted),
        _ => false,
    }
}

/// Whether the server's last messages, still to be read after it went away, end with its
/// goodbye (packets before it are dropped: nobody takes their results).
fn goodbye_waiting(opener: &mut Opener, rd: &mut impl std::io::Read) -> bool {
    loop {
        match opener.read(rd, MAX_FRAME_BYTES) {
            Ok(ServerMsg::Rays(_)) => continue,
            Ok(ServerMsg::Bye) => return true,
            _ => return false,
        }
    }
}

/// What a remote worker did before the server said goodbye or went away.
#[derive(Debug, Default, PartialEq)]
pub struct WorkerReport {
    pub worker_id: u64,
    pub server_scene: String,
    /// The distance the server asked for.
    pub distance: DistanceKind,
    pub packets: u64,
    pub rays: u64,
    /// The server said goodbye (its session ended); `false`: it went away without one
    /// (it died, or its connection broke).
    pub said_goodbye: bool,
}

/// A TCP connection to the server at `addr`, without Nagle's delay.
fn connect(addr: &str) -> Result<TcpStream, WorkerError> {
    let conn = addr
        .to_socket_addrs()
        .and_then(|mut it| it.next().ok_or_else(|| std::io::Error::other("no address")))
        .and_then(TcpStream::connect)
        .map_err(|source| WorkerError::Connect {
            addr: addr.to_string(),
            source,
        })?;
    conn.set_nodelay(true).ok();
    Ok(conn)
}

/// A worker process's loop: connects to `addr`, proves `credentials`, says hello, then
/// traces every ray packet it receives and sends the results back, until the server says
/// goodbye or closes ([`WorkerReport::said_goodbye`] tells which).
pub fn run_remote(
    addr: &str,
    credentials: &Credentials,
    name: &str,
    scene: &str,
    source: &dyn SampleSource,
) -> Result<WorkerReport, WorkerError> {
    let a = addr.to_string();
    let mut conn = connect(addr)?;
    let (mut sealer, mut opener) =
        auth::connect(&mut conn, credentials, Role::Worker).map_err(|source| {
            WorkerError::Handshake {
                addr: a.clone(),
                source,
            }
        })?;
    let frame_err = |source| WorkerError::Frame {
        addr: a.clone(),
        source,
    };
    let mut rd = BufReader::new(conn.try_clone().map_err(|e| frame_err(e.into()))?);
    let mut wr = BufWriter::new(conn);
    let hello = WorkerMsg::Hello(WorkerHello {
        protocol: PROTOCOL_VERSION,
        name: name.into(),
        scene: scene.into(),
    });
    sealer
        .write(&mut wr, &hello, MAX_FRAME_BYTES)
        .map_err(frame_err)?;
    wr.flush().map_err(|e| frame_err(e.into()))?;
    let mut report = WorkerReport::default();
    match opener.read(&mut rd, MAX_FRAME_BYTES).map_err(frame_err)? {
        ServerMsg::Welcome(w) => {
            report.worker_id = w.worker_id;
            report.server_scene = w.scene;
            report.distance = w.distance.into();
        }
        ServerMsg::Rays(_) | ServerMsg::DisplayWelcome(_) | ServerMsg::Beams(_) => {
            return Err(WorkerError::Unexpected {
                addr: a,
                what: "rays or a display message",
                expected: "welcome",
            });
        }
        ServerMsg::Bye => {
            report.said_goodbye = true;
            return Ok(report);
        }
    }
    loop {
        match opener.read(&mut rd, MAX_FRAME_BYTES) {
            Ok(ServerMsg::Rays(p)) => {
                let out = trace_packet(source, &p, report.distance).map_err(|source| {
                    WorkerError::Records {
                        addr: a.clone(),
                        source,
                    }
                })?;
                report.packets += 1;
                report.rays += p.len() as u64;
                let sent = sealer
                    .write(&mut wr, &WorkerMsg::Samples(out), MAX_FRAME_BYTES)
                    .and_then(|()| wr.flush().map_err(FrameError::from));
                match sent {
                    Ok(()) => {}
                    // The server stopped (or died) while this packet was traced: the packet
                    // is lost, as any in-flight packet of a stopping server is; a goodbye
                    // may wait behind the packets it sent last.
                    Err(e) if server_gone(&e) => {
                        report.said_goodbye = goodbye_waiting(&mut opener, &mut rd);
                        return Ok(report);
                    }
                    Err(e) => return Err(frame_err(e)),
                }
            }
            Ok(ServerMsg::Bye) => {
                report.said_goodbye = true;
                return Ok(report);
            }
            Err(FrameError::Closed) => return Ok(report),
            Err(e) if server_gone(&e) => return Ok(report),
            Ok(ServerMsg::Welcome(_) | ServerMsg::DisplayWelcome(_) | ServerMsg::Beams(_)) => {
                return Err(WorkerError::Unexpected {
                    addr: a,
                    what: "a second welcome or a display message",
                    expected: "rays",
                });
            }
            Err(e) => return Err(frame_err(e)),
        }
    }
}
