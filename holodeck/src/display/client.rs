//! A display's link to a holodeck server: [`DisplayClient`] is the same for a display in
//! the server's process ([`crate::run::Running::display`]) and one over TCP
//! ([`DisplayClient::connect`]); [`DisplayClient::request`] and [`DisplayClient::collect`]
//! never block; a background thread talks to the server.

use std::collections::BTreeMap;
use std::io::{BufReader, BufWriter, Write};
use std::net::{Shutdown, SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use holocave_protocol::frame::{FrameError, MAX_FRAME_BYTES};
use holocave_protocol::handshake::{HandshakeError, Role};
use holocave_protocol::holodeck::{
    DisplayHello, DisplayWelcome, PROTOCOL_VERSION, ServerMsg, WorkerMsg,
};
use holocave_protocol::session::{Opener, Sealer};

use super::wire::{self, sections_from_wire, unpack};
use super::{Arrival, EyeRequest};
use crate::auth::{self, Credentials};
use crate::section::Section;

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
    #[error("holodeck server {addr}: {source}")]
    Handshake {
        addr: SocketAddr,
        source: HandshakeError,
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
    /// its eyes are slots of it), proving `credentials`. Blocks only for the handshake (at
    /// most 10 s).
    pub fn connect(
        addr: SocketAddr,
        display: u32,
        credentials: &Credentials,
    ) -> Result<DisplayClient, DisplayError> {
        let err = |source| DisplayError::Connect { addr, source };
        let ferr = |source| DisplayError::Frame { addr, source };
        let mut sock = TcpStream::connect_timeout(&addr, Duration::from_secs(10)).map_err(err)?;
        sock.set_nodelay(true).ok();
        sock.set_read_timeout(Some(Duration::from_secs(10)))
            .map_err(err)?;
        let (mut sealer, mut opener) = auth::connect(&mut sock, credentials, Role::Display)
            .map_err(|e| DisplayError::Handshake { addr, source: e })?;
        let mut w = BufWriter::new(sock.try_clone().map_err(err)?);
        let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "display".into());
        sealer
            .write(
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
        let welcome: DisplayWelcome = match opener.read(&mut r, MAX_FRAME_BYTES) {
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
                    read_beams(addr, (&mut opener, &mut r), &atx);
                    connected.store(false, Ordering::SeqCst);
                })
                .expect("spawn the display reader")
        };
        let writer = {
            let connected = connected.clone();
            std::thread::Builder::new()
                .name("holodeck display writer".into())
                .spawn(move || {
                    write_requests(addr, (&mut sealer, &mut w), &rx);
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

/// The display's reader: every batch of beams the server at `addr` sends, unpacked, to
/// `arrivals`, until it says goodbye, closes, sends something else or the display is gone.
fn read_beams(
    addr: SocketAddr,
    (opener, r): (&mut Opener, &mut BufReader<TcpStream>),
    arrivals: &Sender<Arrival>,
) {
    loop {
        match opener.read::<_, ServerMsg>(r, MAX_FRAME_BYTES) {
            Ok(ServerMsg::Beams(b)) => match unpack(&b) {
                Ok(v) => {
                    if arrivals.send(Arc::new(v)).is_err() {
                        return;
                    }
                }
                Err(e) => return tracing::warn!("holodeck server {addr}: {e}"),
            },
            Ok(ServerMsg::Bye) | Err(FrameError::Closed) => return,
            Ok(other) => {
                return tracing::warn!("holodeck server {addr} sent {}: closing", msg_name(&other));
            }
            Err(e) => return tracing::warn!("holodeck server {addr}: {e}"),
        }
    }
}

/// The display's writer: every eye request from `requests` to the server at `addr`, until
/// the display drops its side or a write fails.
fn write_requests(
    addr: SocketAddr,
    (sealer, w): (&mut Sealer, &mut BufWriter<TcpStream>),
    requests: &Receiver<EyeRequest>,
) {
    while let Ok(req) = requests.recv() {
        let m = wire::request_message(req);
        let sent = sealer
            .write(w, &WorkerMsg::Request(m), MAX_FRAME_BYTES)
            .and_then(|()| w.flush().map_err(FrameError::from));
        if let Err(e) = sent {
            return tracing::warn!("holodeck server {addr}: {e}");
        }
    }
}
