//! The swap barrier's round trip on loopback: the master sends a frame state to four
//! nodes, each answers Ready at once (no drawing), the master sends Swap; every message
//! sealed (a keyed BLAKE3 tag per message, as on every cluster link). The time from
//! sending the state to sending Swap is the barrier's cost. Goal (issue 6, after VR
//! Juggler's software swap lock): p99 ≤ 100 µs.
//!
//! `cargo bench -p holocave-master --bench barrier` prints p50 and p99 over 3000 frames,
//! then criterion's mean per frame. It first prints the floor: the same exchange as raw
//! 64-byte TCP messages, with no master, protocol or decoding.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use holocave_cave::{Cave, parse_cave};
use holocave_master::cluster::{MasterOptions, Summary, run};
use holocave_protocol::stats::quantile_duration;

/// The `q` quantile of durations (zero for none).
fn quantile(v: &[Duration], q: f64) -> Duration {
    quantile_duration(v, q).unwrap_or_default()
}
use holocave_master::head::{Clock, Head};
use holocave_protocol::cluster::{MAX_CLUSTER_FRAME, MasterMsg, NodeMsg, NodeStats};
use holocave_protocol::handshake::{Role, connect};

const SECRET: &[u8] = b"bench";
/// Frames at the start left out: nodes enter the barrier with their first Ready.
const WARM_UP: usize = 10;

fn cave() -> Cave {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../configs/cave4.toml"
    ))
    .unwrap()
    .replace("vrpn://Tracker0@localhost:3883", "synthetic:still");
    let mut cave = parse_cave(&text, "cave4.toml").unwrap();
    // Fast enough that the barrier, not the clock, is what a frame waits for.
    cave.cluster.rate_hz = 500.0;
    cave
}

/// A node that answers every frame state with Ready at once.
fn echo_node(addr: String, wall: String) {
    let mut s = TcpStream::connect(&addr).unwrap();
    s.set_nodelay(true).unwrap();
    let linked = connect(&mut s, "holocave", Role::Node { wall }, SECRET).unwrap();
    let (mut sealer, mut opener) = linked.keys.connector();
    let mut w = s.try_clone().unwrap();
    loop {
        match opener.read::<_, MasterMsg>(&mut s, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(f)) => {
                let ready = NodeMsg::Ready {
                    frame: f.frame,
                    stats: NodeStats::default(),
                };
                if sealer.write(&mut w, &ready, MAX_CLUSTER_FRAME).is_err() {
                    return;
                }
            }
            Ok(MasterMsg::Swap { .. } | MasterMsg::Veil { .. }) => {}
            Ok(MasterMsg::Shutdown { .. }) | Err(_) => return,
        }
    }
}

/// Runs a master and four echo nodes for `frames` frames.
fn cluster(frames: u64) -> Summary {
    let cave = cave();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let nodes: Vec<_> = cave
        .walls
        .iter()
        .map(|w| {
            let (a, n) = (addr.clone(), w.name.clone());
            std::thread::spawn(move || echo_node(a, n))
        })
        .collect();
    let head = Head::open(&cave, None, Clock::Replay, true, false).unwrap();
    let summary = run(
        &cave,
        head,
        listener,
        SECRET.to_vec(),
        MasterOptions {
            clock: Clock::Replay,
            frames: Some(frames + WARM_UP as u64),
            seconds: None,
            stop_at_end_of_log: false,
            holodeck: None,
            vlf: None,
            states_log: None,
            status_every: Duration::from_secs(3600),
            stop: Arc::new(AtomicBool::new(false)),
            wait_for_walls: Duration::from_secs(10),
            status_extra: None,
            navigation: None,
            navigation_log: None,
            objects: None,
            on_frame: None,
            session_state: None,
            resume: None,
            sun: None,
        },
    )
    .unwrap();
    for n in nodes {
        n.join().unwrap();
    }
    summary
}

/// The floor under the barrier on this machine: the same exchange with no protocol at
/// all (64 bytes out to four echo threads and back, blocking sockets), one frame period
/// apart as in the master's loop. On a virtual machine most of this is waking idle vCPUs;
/// back to back the same exchange is several times faster.
fn raw_round_trips(frames: usize, period: Duration) -> Vec<Duration> {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    for _ in 0..4 {
        std::thread::spawn(move || {
            let mut s = TcpStream::connect(addr).unwrap();
            s.set_nodelay(true).unwrap();
            let mut b = [0u8; 64];
            while s.read_exact(&mut b).is_ok() && s.write_all(&b).is_ok() {}
        });
    }
    let mut nodes: Vec<TcpStream> = (0..4)
        .map(|_| {
            let (s, _) = listener.accept().unwrap();
            s.set_nodelay(true).unwrap();
            s
        })
        .collect();
    let mut b = [1u8; 64];
    (0..frames)
        .map(|_| {
            std::thread::sleep(period);
            let start = Instant::now();
            for n in &mut nodes {
                n.write_all(&b).unwrap();
            }
            for n in &mut nodes {
                n.read_exact(&mut b).unwrap();
            }
            start.elapsed()
        })
        .collect()
}

fn barrier(c: &mut Criterion) {
    let raw = raw_round_trips(3000, cave().frame_period());
    println!(
        "raw TCP round trip (no protocol), 4 echo threads, one frame period apart: p50 {:.1} µs, p99 {:.1} µs",
        quantile(&raw, 0.5).as_secs_f64() * 1e6,
        quantile(&raw, 0.99).as_secs_f64() * 1e6,
    );
    let s = cluster(3000);
    let b = &s.barrier[WARM_UP..];
    println!(
        "barrier round trip, 4 nodes on loopback, {} frames ({} with a node late): p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        b.len(),
        s.frames - s.full_frames,
        quantile(b, 0.5).as_secs_f64() * 1e6,
        quantile(b, 0.99).as_secs_f64() * 1e6,
        quantile(b, 1.0).as_secs_f64() * 1e6,
    );
    let mut g = c.benchmark_group("barrier");
    g.sample_size(10);
    g.bench_function("round trip, 4 nodes", |bench| {
        bench.iter_custom(|iters| {
            let s = cluster(iters);
            s.barrier[WARM_UP..].iter().sum()
        })
    });
    g.finish();
}

criterion_group!(benches, barrier);
criterion_main!(benches);
