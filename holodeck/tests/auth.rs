//! The holodeck's port takes only peers that prove the cluster's secret, and only sealed
//! messages from them: a worker or display with the wrong secret, a peer that skips the
//! handshake, random bytes, truncated and oversized frames, an unsealed (injected) message
//! on an authenticated link and a replayed sealed one are all refused — and not one of
//! their samples reaches the file (checked against a copy taken before, as
//! `holodeck check --holds` does).

use crate::common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::Duration;

use common::{Analytic, credentials, credentials_with, options};
use glam::DVec3;
use holocave_holodeck::auth;
use holocave_holodeck::display::DisplayClient;
use holocave_holodeck::file::DISTANCE_SETTING;
use holocave_holodeck::file::check::holds;
use holocave_holodeck::run::{run, start};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{DistanceKind, WorkerError, run_remote, trace_packet};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_protocol::frame::{MAX_FRAME_BYTES, encode};
use holocave_protocol::handshake::{HandshakeError, Role};
use holocave_protocol::holodeck::{PROTOCOL_VERSION, ServerMsg, WorkerHello, WorkerMsg};

/// How often the tests' servers commit.
const COMMIT: Duration = Duration::from_millis(200);

/// An honest worker's link, after the handshake and hello: the stream and its keys.
fn honest_worker(
    addr: &str,
) -> (
    TcpStream,
    holocave_protocol::session::Sealer,
    holocave_protocol::session::Opener,
) {
    let mut c = TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let (mut sealer, mut opener) = auth::connect(&mut c, &credentials(), Role::Worker).unwrap();
    let hello = WorkerMsg::Hello(WorkerHello {
        protocol: PROTOCOL_VERSION,
        name: "honest".into(),
        scene: "analytic".into(),
    });
    sealer.write(&mut c, &hello, MAX_FRAME_BYTES).unwrap();
    assert!(matches!(
        opener.read(&mut c, MAX_FRAME_BYTES).unwrap(),
        ServerMsg::Welcome(_)
    ));
    (c, sealer, opener)
}

/// Reads until the server closes the connection (it refused what it was sent).
fn closed_by_server(c: &mut TcpStream) -> bool {
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut rest = Vec::new();
    // A close, or a reset when it hung up on bytes it had not read; not a time-out.
    match c.read_to_end(&mut rest) {
        Ok(_) => true,
        Err(e) => !matches!(
            e.kind(),
            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
        ),
    }
}

#[test]
fn unauthenticated_injected_and_replayed_traffic_is_refused_and_the_file_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let (path, before, stored) = filled_with_a_copy(dir.path());
    // The port, with no tracer threads: only TCP workers could add samples.
    let server = Server::new(
        HoloFile::open_rw(&path).unwrap(),
        Mode::Batch,
        ServerConfig::default(),
    );
    let running = start(
        server,
        options(0, Some(TcpListener::bind("127.0.0.1:0").unwrap()), COMMIT),
    )
    .unwrap();
    let addr = running.local_addr().unwrap();
    wrong_secrets_are_refused(addr);
    traffic_without_a_handshake_is_refused(addr);
    an_injected_packet_is_refused(addr);
    let honest = a_replayed_packet_is_refused(addr);

    let server = running.stop().unwrap();
    drop(server);
    let report = holds(&path, &before).unwrap();
    assert!(report.holds_all(), "{report:?}");
    let now = HoloFile::open(&path).unwrap().total_samples();
    assert_eq!(
        now,
        stored + honest,
        "only the honest packet was added ({stored} before, {honest} honest)"
    );
}

/// A holodeck in `dir` with some samples, by worker threads, committed; a copy of it; how
/// many samples it holds.
fn filled_with_a_copy(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf, u64) {
    let path = dir.join("a.hdk");
    let section =
        Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [3, 3, 3], ViewClass::Interior).unwrap();
    let settings = [(DISTANCE_SETTING.to_string(), "virtual".to_string())].into();
    HoloFile::create(&path, vec![section], settings).unwrap();
    let server = Server::new(
        HoloFile::open_rw(&path).unwrap(),
        Mode::Batch,
        ServerConfig::default(),
    );
    run(server, options(1, None, COMMIT), |p| {
        p.stats.samples >= 2000
    })
    .unwrap();
    let before = dir.join("before.hdk");
    std::fs::copy(&path, &before).unwrap();
    let stored = HoloFile::open(&before).unwrap().total_samples();
    assert!(stored >= 2000);
    (path, before, stored)
}

/// A worker and a display with the wrong secret are refused.
fn wrong_secrets_are_refused(addr: std::net::SocketAddr) {
    let wrong = credentials_with(b"a guess");
    let w = run_remote(&addr.to_string(), &wrong, "intruder", "analytic", &Analytic);
    assert!(
        matches!(
            w,
            Err(WorkerError::Handshake {
                source: HandshakeError::Authentication,
                ..
            })
        ),
        "{w:?}"
    );
    let d = DisplayClient::connect(addr, 7, &wrong);
    assert!(d.is_err(), "a display with the wrong secret was let in");
}

/// No handshake at all: a worker's hello as the first bytes; then random bytes, an
/// oversized length and a truncated frame. Each connection is closed by the server.
fn traffic_without_a_handshake_is_refused(addr: std::net::SocketAddr) {
    let hello = WorkerMsg::Hello(WorkerHello {
        protocol: PROTOCOL_VERSION,
        name: "no handshake".into(),
        scene: "analytic".into(),
    });
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut random = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng.to_le_bytes()
    };
    let noise: Vec<u8> = (0..512).flat_map(|_| random()).collect();
    for bad in [
        encode(&hello, MAX_FRAME_BYTES).unwrap(),
        noise,
        u32::MAX.to_le_bytes().to_vec(),
        [&200u32.to_le_bytes()[..], &[7u8; 20]].concat(),
    ] {
        let mut c = TcpStream::connect(addr).unwrap();
        let _ = c.write_all(&bad);
        assert!(closed_by_server(&mut c));
    }
}

/// An authenticated link that sends an unsealed (injected) sample packet for the rays it
/// was given: refused, the link dropped.
fn an_injected_packet_is_refused(addr: std::net::SocketAddr) {
    let (mut c, _, mut opener) = honest_worker(&addr.to_string());
    let ServerMsg::Rays(p) = opener.read(&mut c, MAX_FRAME_BYTES).unwrap() else {
        panic!("expected rays");
    };
    let samples = trace_packet(&Analytic, &p, DistanceKind::Virtual).unwrap();
    c.write_all(&encode(&WorkerMsg::Samples(samples), MAX_FRAME_BYTES).unwrap())
        .unwrap();
    assert!(closed_by_server(&mut c));
}

/// A sealed sample packet sent twice: the first is an honest worker's and is kept, the
/// replay is refused. How many samples the honest packet holds.
fn a_replayed_packet_is_refused(addr: std::net::SocketAddr) -> u64 {
    let (mut c, mut sealer, mut opener) = honest_worker(&addr.to_string());
    let ServerMsg::Rays(p) = opener.read(&mut c, MAX_FRAME_BYTES).unwrap() else {
        panic!("expected rays");
    };
    let honest = p.len() as u64;
    let samples = trace_packet(&Analytic, &p, DistanceKind::Virtual).unwrap();
    let sealed = sealer
        .seal(&WorkerMsg::Samples(samples), MAX_FRAME_BYTES)
        .unwrap();
    c.write_all(&sealed).unwrap();
    c.write_all(&sealed).unwrap();
    assert!(closed_by_server(&mut c));
    honest
}
