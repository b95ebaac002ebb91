//! A VRPN client over TCP, as a background thread that hands reports and connection events
//! to the caller through a channel: a tracker's sensor (`Tracker0@host:port#1`: the head,
//! a wand), or a button or analog device (`Buttons0@host`, `Joystick0@host`).
//!
//! The session follows VRPN's own client: connect, send our cookie, check the server's,
//! announce our sender and the message type we use, then read the server's descriptions
//! and reports. Any protocol violation closes the connection with an error naming the
//! server and the problem; the client then reconnects with exponential back-off, so a
//! restarted server is picked up again without the CAVE stopping.

use std::fmt;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::str::FromStr;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use crate::input::InputSample;
use crate::pose::Sample;
use crate::vrpn_input::{InputKind, InputSelector, InputWireError};
use crate::vrpn_wire::{
    Message, POS_QUAT, RemoteNames, SENDER_DESCRIPTION, StreamDecoder, TYPE_DESCRIPTION,
    TrackerSelector, WireError, cookie,
};

/// VRPN's well-known server port.
pub const DEFAULT_PORT: u16 = 3883;

/// Which tracker to follow: `DEVICE@HOST[:PORT][#SENSOR]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VrpnTarget {
    pub device: String,
    pub host: String,
    pub port: u16,
    pub sensor: i32,
}

impl FromStr for VrpnTarget {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (rest, sensor) = match s.split_once('#') {
            Some((r, n)) => (
                r,
                n.parse()
                    .map_err(|_| format!("sensor `{n}` in `{s}` is not an integer"))?,
            ),
            None => (s, 0),
        };
        let (device, addr) = rest
            .split_once('@')
            .ok_or_else(|| format!("`{s}` is not DEVICE@HOST[:PORT][#SENSOR]"))?;
        let (host, port) = match addr.rsplit_once(':') {
            Some((h, p)) => (
                h,
                p.parse()
                    .map_err(|_| format!("port `{p}` in `{s}` is not a number"))?,
            ),
            None => (addr, DEFAULT_PORT),
        };
        if device.is_empty() || host.is_empty() {
            return Err(format!("`{s}` needs both a device name and a host"));
        }
        Ok(VrpnTarget {
            device: device.to_owned(),
            host: host.to_owned(),
            port,
            sensor,
        })
    }
}

impl fmt::Display for VrpnTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}@{}:{}#{}",
            self.device, self.host, self.port, self.sensor
        )
    }
}

/// A connection to a VRPN server failed or ended.
#[derive(Debug, thiserror::Error)]
pub enum VrpnError {
    #[error("VRPN server {addr}: {source}")]
    Io { addr: String, source: io::Error },
    #[error("VRPN server {addr} broke the protocol: {source}")]
    Protocol { addr: String, source: WireError },
    #[error("VRPN server {addr} sent a bad input report: {source}")]
    Input {
        addr: String,
        source: InputWireError,
    },
    #[error("VRPN server {addr} closed the connection")]
    Closed { addr: String },
}

/// What a client follows on its device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Follow {
    /// `Pos_Quat` reports of the target's sensor.
    Tracker,
    /// Button or analog reports.
    Input(InputKind),
}

/// What the client thread reports.
#[derive(Debug)]
pub enum VrpnEvent {
    /// The handshake with the server completed.
    Connected { addr: String },
    /// A report of the selected device and sensor (time: the server's clock), and when it
    /// was read off the socket here.
    Sample(Sample, std::time::Instant),
    /// A button or analog report of the device (time: the server's clock), and when it was
    /// read off the socket here.
    Input(InputSample, std::time::Instant),
    /// The connection ended (or could not be made); the client retries.
    Disconnected(VrpnError),
}

/// Timing of the client.
#[derive(Clone, Copy, Debug)]
pub struct ClientOptions {
    pub connect_timeout: Duration,
    /// First wait before reconnecting; doubles on each failure up to `retry_max`.
    pub retry_min: Duration,
    pub retry_max: Duration,
    /// How often a blocked read wakes up to see whether the client was dropped.
    pub poll: Duration,
}

impl Default for ClientOptions {
    fn default() -> Self {
        ClientOptions {
            connect_timeout: Duration::from_secs(2),
            retry_min: Duration::from_millis(50),
            retry_max: Duration::from_secs(2),
            poll: Duration::from_millis(100),
        }
    }
}

/// A running client; dropping it stops the thread.
pub struct VrpnClient {
    events: Receiver<VrpnEvent>,
    stop: Option<Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl VrpnClient {
    /// Starts connecting to `target`'s tracker sensor in the background.
    pub fn spawn(target: VrpnTarget, options: ClientOptions) -> VrpnClient {
        Self::spawn_following(target, Follow::Tracker, options)
    }

    /// Starts connecting to `target` in the background, following `follow`.
    pub fn spawn_following(
        target: VrpnTarget,
        follow: Follow,
        options: ClientOptions,
    ) -> VrpnClient {
        let (tx, events) = mpsc::channel();
        let (stop, stop_rx) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name(format!("vrpn {target}"))
            .spawn(move || run(target, follow, options, tx, stop_rx))
            .expect("spawning the VRPN client thread");
        VrpnClient {
            events,
            stop: Some(stop),
            thread: Some(thread),
        }
    }

    /// The next event, waiting at most `timeout`.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<VrpnEvent, RecvTimeoutError> {
        self.events.recv_timeout(timeout)
    }
}

impl Drop for VrpnClient {
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Why a session ended without an error.
enum Stop {
    Requested,
}

fn stop_requested(stop: &Receiver<()>) -> bool {
    !matches!(stop.try_recv(), Err(TryRecvError::Empty))
}

fn run(
    target: VrpnTarget,
    follow: Follow,
    options: ClientOptions,
    tx: Sender<VrpnEvent>,
    stop: Receiver<()>,
) {
    let mut backoff = options.retry_min;
    let mut failing = false;
    loop {
        match session(&target, follow, &options, &tx, &stop) {
            Ok(Stop::Requested) => return,
            Err((error, was_connected)) => {
                if was_connected {
                    backoff = options.retry_min;
                }
                if was_connected || !failing {
                    tracing::warn!("{error}; reconnecting");
                    if tx.send(VrpnEvent::Disconnected(error)).is_err() {
                        return;
                    }
                }
                failing = !was_connected;
            }
        }
        match stop.recv_timeout(backoff) {
            Err(RecvTimeoutError::Timeout) => {}
            _ => return,
        }
        backoff = (backoff * 2).min(options.retry_max);
    }
}

/// One connection, until it fails or the client is dropped. The flag says whether the
/// handshake had completed.
/// A connection to the server at `addr`, without Nagle's delay and reading with the
/// client's poll timeout.
fn connect(addr: &str, options: &ClientOptions) -> io::Result<TcpStream> {
    let sock = (addr.to_socket_addrs()?.next())
        .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "host has no address"))?;
    let stream = TcpStream::connect_timeout(&sock, options.connect_timeout)?;
    // With no server on a local port, the kernel may give the client that very port and
    // connect it to itself (a simultaneous open): it would read its own greeting back,
    // and hold the port a restarted server needs. Taken for a refusal.
    if stream.local_addr().ok() == stream.peer_addr().ok() {
        return Err(io::Error::new(
            io::ErrorKind::ConnectionRefused,
            "no server listening (the connection reached itself)",
        ));
    }
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(options.poll))?;
    Ok(stream)
}

fn session(
    target: &VrpnTarget,
    follow: Follow,
    options: &ClientOptions,
    tx: &Sender<VrpnEvent>,
    stop: &Receiver<()>,
) -> Result<Stop, (VrpnError, bool)> {
    let addr = format!("{}:{}", target.host, target.port);
    let io = |source| {
        (
            VrpnError::Io {
                addr: addr.clone(),
                source,
            },
            false,
        )
    };
    let mut stream = connect(&addr, options).map_err(io)?;
    let types: &[&str] = match follow {
        Follow::Tracker => &[POS_QUAT],
        Follow::Input(kind) => kind.types(),
    };
    stream
        .write_all(&hello(&target.device, types))
        .map_err(io)?;

    let mut following = Following::new(target, follow);
    let mut buf = vec![0u8; 16 * 1024];
    loop {
        let n = match stream.read(&mut buf) {
            Ok(0) => return Err((VrpnError::Closed { addr }, following.connected)),
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                if stop_requested(stop) {
                    return Ok(Stop::Requested);
                }
                continue;
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(source) => return Err((VrpnError::Io { addr, source }, following.connected)),
        };
        // Every message in these bytes arrived now.
        let arrived = std::time::Instant::now();
        if following.deliver(&buf[..n], arrived, &addr, tx)?.is_some() || stop_requested(stop) {
            return Ok(Stop::Requested);
        }
    }
}

/// A session's reading of the server's messages: the device and sensor (or input kind) it
/// follows, the stream's decoder, the names the server has given, and whether any message
/// has come yet.
struct Following {
    selector: TrackerSelector,
    inputs: Option<InputSelector>,
    decoder: StreamDecoder,
    names: RemoteNames,
    connected: bool,
}

impl Following {
    fn new(target: &VrpnTarget, follow: Follow) -> Following {
        Following {
            selector: TrackerSelector {
                device: target.device.clone(),
                sensor: target.sensor,
            },
            inputs: match follow {
                Follow::Tracker => None,
                Follow::Input(kind) => Some(InputSelector {
                    device: target.device.clone(),
                    kind,
                }),
            },
            decoder: StreamDecoder::new(),
            names: RemoteNames::default(),
            connected: false,
        }
    }

    /// Sends on `tx` what the messages in `bytes` (from `addr`, arrived at `arrived`) say:
    /// the connection on the first, then each sample or input event. `Some(Stop)` where
    /// the receiver has gone.
    fn deliver(
        &mut self,
        bytes: &[u8],
        arrived: std::time::Instant,
        addr: &str,
        tx: &Sender<VrpnEvent>,
    ) -> Result<Option<Stop>, (VrpnError, bool)> {
        self.decoder.feed(bytes);
        let protocol = |source| {
            let addr = addr.to_string();
            (VrpnError::Protocol { addr, source }, true)
        };
        loop {
            let connected = self.connected;
            let next = self.decoder.next_message().map_err(|source| {
                let addr = addr.to_string();
                (VrpnError::Protocol { addr, source }, connected)
            })?;
            let Some(msg) = next else {
                return Ok(None);
            };
            if !self.connected {
                self.connected = true;
                let addr = addr.to_string();
                if tx.send(VrpnEvent::Connected { addr }).is_err() {
                    return Ok(Some(Stop::Requested));
                }
            }
            if self.names.absorb(&msg).map_err(protocol)? {
                continue;
            }
            if let Some(event) = self.event(&msg, arrived, addr)?
                && tx.send(event).is_err()
            {
                return Ok(Some(Stop::Requested));
            }
        }
    }

    /// The sample or input event `msg` carries, if it is of what this session follows.
    fn event(
        &self,
        msg: &Message,
        arrived: std::time::Instant,
        addr: &str,
    ) -> Result<Option<VrpnEvent>, (VrpnError, bool)> {
        let addr = || addr.to_string();
        match &self.inputs {
            None => Ok(self
                .selector
                .sample(&self.names, msg)
                .map_err(|source| {
                    (
                        VrpnError::Protocol {
                            addr: addr(),
                            source,
                        },
                        true,
                    )
                })?
                .map(|s| VrpnEvent::Sample(s, arrived))),
            Some(inputs) => Ok(inputs
                .event(&self.names, msg)
                .map_err(|source| {
                    (
                        VrpnError::Input {
                            addr: addr(),
                            source,
                        },
                        true,
                    )
                })?
                .map(|e| VrpnEvent::Input(e, arrived))),
        }
    }
}

/// What the client sends first: its cookie, a sender description of the device it wants,
/// and the type descriptions of the reports it understands (as VRPN's clients do).
fn hello(device: &str, types: &[&str]) -> Vec<u8> {
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    let time = (now.as_secs() as u32, now.subsec_micros());
    let mut out = cookie(0).to_vec();
    out.extend(Message::description(SENDER_DESCRIPTION, 0, device, 0, time).encode());
    for (id, name) in types.iter().enumerate() {
        out.extend(
            Message::description(TYPE_DESCRIPTION, id as i32, name, id as u32 + 1, time).encode(),
        );
    }
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::pose::Pose;
    use crate::rotation::angle_between;
    use crate::vrpn_wire::{COOKIE_LEN, PosQuat, check_cookie};
    use glam::Vec3;
    use std::net::{SocketAddr, TcpListener};

    /// Failure guard for anything a test waits on; never needed when the code works.
    const GUARD: Duration = Duration::from_secs(20);

    /// Checks the captured spinning tracker: a rotation about +Y at 0.5 rev/s (π rad/s).
    pub(crate) fn assert_spins_about_y_at_half_rev_per_second(samples: &[Sample]) {
        assert!(samples.len() > 10);
        for s in samples {
            let q = s.pose.orientation;
            assert!(q.x.abs() < 1e-6 && q.z.abs() < 1e-6, "not about Y: {q}");
            assert!((q.length() - 1.0).abs() < 1e-6);
            assert_eq!(s.pose.position, Vec3::ZERO);
        }
        let (first, last) = (samples[0], samples[samples.len() - 1]);
        let mut turned = 0.0f64;
        for w in samples.windows(2) {
            let a = angle_between(w[0].pose.orientation, w[1].pose.orientation) as f64;
            // Same sense every step: the Y component of the relative rotation keeps its sign.
            let rel = w[0].pose.orientation.conjugate() * w[1].pose.orientation;
            assert!(rel.y * rel.w > 0.0, "rotation reversed");
            turned += a;
        }
        let secs = (last.t_ns - first.t_ns) as f64 * 1e-9;
        let rate = turned / secs;
        assert!(
            (rate - std::f64::consts::PI).abs() < 0.02 * std::f64::consts::PI,
            "rate {rate} rad/s"
        );
    }

    /// A server that follows VRPN's protocol: checks the client's cookie and reads its
    /// descriptions, then sends what the test gives it.
    struct FakeServer {
        listener: TcpListener,
    }

    struct Conn {
        stream: TcpStream,
        seq: u32,
    }

    impl FakeServer {
        fn bind(addr: &str) -> FakeServer {
            FakeServer {
                listener: TcpListener::bind(addr).unwrap(),
            }
        }

        fn addr(&self) -> SocketAddr {
            self.listener.local_addr().unwrap()
        }

        /// Accepts one client (guarded) and checks what it sends first.
        fn accept(&self, device: &str) -> Conn {
            self.accept_announcing(device, POS_QUAT)
        }

        /// Accepts one client that announces `device` and, as its type 0, `first_type`.
        fn accept_announcing(&self, device: &str, first_type: &str) -> Conn {
            let listener = self.listener.try_clone().unwrap();
            let (tx, rx) = mpsc::channel();
            std::thread::spawn(move || {
                let _ = tx.send(listener.accept().map(|(s, _)| s));
            });
            let mut stream = rx
                .recv_timeout(GUARD)
                .expect("client never connected")
                .unwrap();
            stream.set_read_timeout(Some(GUARD)).unwrap();
            let mut c = [0u8; COOKIE_LEN];
            stream.read_exact(&mut c).unwrap();
            check_cookie(&c).unwrap();
            let mut dec = StreamDecoder::new();
            dec.feed(&c);
            let mut names = RemoteNames::default();
            while names.kind(0) != Some(first_type) {
                let mut b = [0u8; 256];
                let n = stream.read(&mut b).unwrap();
                assert!(n > 0, "client closed during its descriptions");
                dec.feed(&b[..n]);
                while let Some(m) = dec.next_message().unwrap() {
                    assert!(
                        names.absorb(&m).unwrap(),
                        "client sent a non-description first"
                    );
                }
            }
            assert_eq!(names.sender(0), Some(device));
            Conn { stream, seq: 0 }
        }
    }

    impl Conn {
        fn send(&mut self, sender: i32, kind: i32, payload: Vec<u8>, t_ms: u32) {
            let m = Message {
                sec: t_ms / 1000,
                usec: (t_ms % 1000) * 1000,
                sender,
                kind,
                seq: self.seq,
                payload,
            };
            self.seq += 1;
            self.stream.write_all(&m.encode()).unwrap();
        }

        /// Cookie and descriptions: senders 5 = `other`, 7 = `Tracker0`; type 3 = Pos_Quat.
        fn greet(&mut self) {
            self.stream.write_all(&cookie(0)).unwrap();
            let d = |kind, id, name: &str| Message::description(kind, id, name, 0, (0, 0)).payload;
            self.send(5, SENDER_DESCRIPTION, d(SENDER_DESCRIPTION, 5, "other"), 0);
            self.send(
                7,
                SENDER_DESCRIPTION,
                d(SENDER_DESCRIPTION, 7, "Tracker0"),
                0,
            );
            self.send(3, TYPE_DESCRIPTION, d(TYPE_DESCRIPTION, 3, POS_QUAT), 0);
        }

        fn report(&mut self, sender: i32, sensor: i32, x: f64, t_ms: u32) {
            let pq = PosQuat {
                sensor,
                position: [x, 1.5, 0.0],
                quat: [0.0, 0.0, 0.0, 1.0],
            };
            self.send(sender, 3, pq.encode(), t_ms);
        }
    }

    fn client_for(addr: SocketAddr, sensor: i32) -> VrpnClient {
        let target = VrpnTarget {
            device: "Tracker0".into(),
            host: "127.0.0.1".into(),
            port: addr.port(),
            sensor,
        };
        VrpnClient::spawn(target, ClientOptions::default())
    }

    fn next(client: &VrpnClient) -> VrpnEvent {
        client
            .recv_timeout(GUARD)
            .expect("no event from the client")
    }

    fn next_sample(client: &VrpnClient) -> Sample {
        match next(client) {
            VrpnEvent::Sample(s, _) => s,
            other => panic!("expected a sample, got {other:?}"),
        }
    }

    #[test]
    fn a_button_client_reads_changes_and_states_of_its_device_and_refuses_a_bad_one() {
        use crate::input::InputEvent;
        use crate::vrpn_input::{
            BUTTON_CHANGE, BUTTON_STATES, encode_button_change, encode_button_states,
        };
        let server = FakeServer::bind("127.0.0.1:0");
        let target = VrpnTarget {
            device: "Buttons0".into(),
            host: "127.0.0.1".into(),
            port: server.addr().port(),
            sensor: 0,
        };
        let client = VrpnClient::spawn_following(
            target,
            Follow::Input(InputKind::Buttons),
            ClientOptions::default(),
        );
        let mut conn = server.accept_announcing("Buttons0", BUTTON_CHANGE);
        conn.stream.write_all(&cookie(0)).unwrap();
        let d = |kind, id, name: &str| Message::description(kind, id, name, 0, (0, 0)).payload;
        conn.send(
            4,
            SENDER_DESCRIPTION,
            d(SENDER_DESCRIPTION, 4, "Buttons0"),
            0,
        );
        conn.send(
            9,
            TYPE_DESCRIPTION,
            d(TYPE_DESCRIPTION, 9, BUTTON_CHANGE),
            0,
        );
        conn.send(
            8,
            TYPE_DESCRIPTION,
            d(TYPE_DESCRIPTION, 8, BUTTON_STATES),
            0,
        );
        conn.send(4, 8, encode_button_states(&[0, 0]), 1);
        conn.send(4, 9, encode_button_change(1, 1), 2);
        conn.send(4, 9, vec![0, 0, 0, 1], 3); // 4 bytes short
        assert!(matches!(next(&client), VrpnEvent::Connected { .. }));
        let inputs: Vec<_> = (0..2)
            .map(|_| match next(&client) {
                VrpnEvent::Input(e, _) => e,
                other => panic!("expected an input, got {other:?}"),
            })
            .collect();
        assert_eq!(inputs[0].event, InputEvent::Buttons(vec![false, false]));
        assert_eq!(
            (inputs[1].t_ns, &inputs[1].event),
            (
                2_000_000,
                &InputEvent::Button {
                    index: 1,
                    pressed: true
                }
            )
        );
        match next(&client) {
            VrpnEvent::Disconnected(e @ VrpnError::Input { .. }) => {
                assert!(e.to_string().contains("4 bytes, expected 8"), "{e}")
            }
            other => panic!("expected an input error, got {other:?}"),
        }
    }

    #[test]
    fn targets_parse_with_defaults() {
        let t: VrpnTarget = "Tracker0@cave-master".parse().unwrap();
        assert_eq!((t.port, t.sensor), (DEFAULT_PORT, 0));
        let t: VrpnTarget = "Head@10.0.0.2:3884#2".parse().unwrap();
        assert_eq!(
            (t.device.as_str(), t.host.as_str(), t.port, t.sensor),
            ("Head", "10.0.0.2", 3884, 2)
        );
        assert!(
            "nohost"
                .parse::<VrpnTarget>()
                .unwrap_err()
                .contains("DEVICE@HOST")
        );
        assert!(
            "a@b:x"
                .parse::<VrpnTarget>()
                .unwrap_err()
                .contains("port `x`")
        );
    }

    #[test]
    fn receives_selected_sensor_and_survives_a_server_restart() {
        let server = FakeServer::bind("127.0.0.1:0");
        let addr = server.addr();
        let client = client_for(addr, 1);
        let mut conn = server.accept("Tracker0");
        conn.greet();
        conn.report(5, 1, 9.0, 10); // another device: ignored
        conn.report(7, 0, 9.0, 11); // another sensor: ignored
        conn.report(7, 1, 0.25, 12);
        assert!(matches!(next(&client), VrpnEvent::Connected { .. }));
        let s = next_sample(&client);
        assert_eq!(s.t_ns, 12_000_000);
        assert_eq!(
            s.pose,
            Pose::new(Vec3::new(0.25, 1.5, 0.0), glam::Quat::IDENTITY)
        );

        // The server goes away entirely and comes back on the same port.
        drop(conn);
        drop(server);
        assert!(matches!(
            next(&client),
            VrpnEvent::Disconnected(VrpnError::Closed { .. })
        ));
        let server = FakeServer::bind(&addr.to_string());
        let mut conn = server.accept("Tracker0");
        conn.greet();
        conn.report(7, 1, 0.5, 2000);
        let mut event = next(&client);
        while let VrpnEvent::Disconnected(_) = event {
            event = next(&client); // refused attempts while the server was down
        }
        assert!(matches!(event, VrpnEvent::Connected { .. }), "{event:?}");
        assert_eq!(next_sample(&client).pose.position.x, 0.5);
    }

    #[test]
    fn malformed_message_closes_with_a_clear_error_and_the_client_reconnects() {
        let server = FakeServer::bind("127.0.0.1:0");
        let client = client_for(server.addr(), 0);
        let mut conn = server.accept("Tracker0");
        conn.greet();
        conn.report(7, 0, 1.0, 5);
        // A Pos_Quat that is 8 bytes short.
        conn.send(7, 3, vec![0; 56], 6);
        assert!(matches!(next(&client), VrpnEvent::Connected { .. }));
        assert_eq!(next_sample(&client).pose.position.x, 1.0);
        match next(&client) {
            VrpnEvent::Disconnected(e @ VrpnError::Protocol { .. }) => {
                let text = e.to_string();
                assert!(
                    text.contains("127.0.0.1") && text.contains("payload is 56 bytes, expected 64"),
                    "{text}"
                );
            }
            other => panic!("expected a protocol error, got {other:?}"),
        }
        // The client closed its side and comes back by itself.
        let mut b = [0u8; 64];
        let mut old = conn.stream;
        while old.read(&mut b).unwrap() > 0 {}
        let mut conn = server.accept("Tracker0");
        // This time the header itself is broken: a length below the header's size.
        conn.greet();
        conn.stream
            .write_all(&[
                0, 0, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 7, 0, 0, 0, 3, 0, 0, 0, 9,
            ])
            .unwrap();
        assert!(matches!(next(&client), VrpnEvent::Connected { .. }));
        match next(&client) {
            VrpnEvent::Disconnected(e) => {
                assert!(e.to_string().contains("announces 4 bytes"), "{e}")
            }
            other => panic!("{other:?}"),
        }
        let mut conn = server.accept("Tracker0");
        conn.greet();
        conn.report(7, 0, 2.0, 7);
        assert!(matches!(next(&client), VrpnEvent::Connected { .. }));
        assert_eq!(next_sample(&client).pose.position.x, 2.0);
    }

    #[test]
    fn reads_the_captured_real_session_through_a_socket() {
        let records = crate::vrpn_wire::tests::session_records();
        for (device, spins) in [("Tracker0", true), ("Head", false)] {
            let server = FakeServer::bind("127.0.0.1:0");
            let target = VrpnTarget {
                device: device.into(),
                host: "127.0.0.1".into(),
                port: server.addr().port(),
                sensor: 0,
            };
            let client = VrpnClient::spawn(target, ClientOptions::default());
            let mut conn = server.accept(device);
            for (_, _, bytes) in records.iter().filter(|r| r.0 == 1) {
                conn.stream.write_all(bytes).unwrap();
            }
            drop(conn);
            let mut samples = Vec::new();
            loop {
                match next(&client) {
                    VrpnEvent::Connected { .. } => {}
                    VrpnEvent::Sample(s, _) => samples.push(s),
                    VrpnEvent::Disconnected(VrpnError::Closed { .. }) => break,
                    other => panic!("{other:?}"),
                }
            }
            if spins {
                assert!(samples.len() > 100, "{}", samples.len());
                assert_spins_about_y_at_half_rev_per_second(&samples);
            } else {
                assert!(samples.len() > 50);
                assert!(samples.iter().all(|s| s.pose == Pose::IDENTITY));
            }
        }
    }
}
