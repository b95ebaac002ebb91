//! Worker threads and TCP worker processes (here: threads running the same client loop)
//! filling one holodeck together; a worker that dies mid-packet loses only that packet,
//! which another worker computes. Every worker is asked for the distance the file records.
//! Threads held to a ray allowance trace exactly the rays granted.

use crate::common;

use std::net::TcpListener;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use common::{Analytic, credentials, options};
use glam::DVec3;
use holocave_holodeck::auth;
use holocave_holodeck::distance_code::DistanceCode;
use holocave_holodeck::file::DISTANCE_SETTING;
use holocave_holodeck::run::{RayAllowance, Running, Settled, run, start_held};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{DistanceKind, SampleSource, SourceRay, SourceResult, run_remote};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_protocol::frame::MAX_FRAME_BYTES;
use holocave_protocol::handshake::Role;
use holocave_protocol::holodeck::{PROTOCOL_VERSION, ServerMsg, WorkerHello, WorkerMsg};

#[test]
fn threads_and_tcp_workers_fill_together_and_survive_a_dying_worker() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("w.hdk");
    let s = Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [3, 3, 3], ViewClass::Interior).unwrap();
    HoloFile::create(
        &path,
        vec![s],
        [
            ("scene".to_string(), "analytic".to_string()),
            (DISTANCE_SETTING.to_string(), "virtual".to_string()),
        ]
        .into(),
    )
    .unwrap();
    let server = Server::new(
        HoloFile::open_rw(&path).unwrap(),
        Mode::Batch,
        ServerConfig::default(),
    );
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let remotes: Vec<_> = (0..2)
        .map(|i| {
            let a = addr.clone();
            std::thread::spawn(move || {
                run_remote(
                    &a,
                    &credentials(),
                    &format!("remote-{i}"),
                    "analytic",
                    &Analytic,
                )
            })
        })
        .collect();
    let dying = dying_worker(addr);
    let opts = options(2, Some(listener), Duration::from_millis(300));
    // The analytic source returns millions of samples a second on one core: even at a
    // hundredth of that (with a commit on top), the fill is done by this deadline.
    const SAMPLES: u64 = 200_000;
    let deadline = Duration::from_secs_f64(SAMPLES as f64 / 10_000.0) + 2 * opts.commit_every;
    let mut max_workers = 0;
    let mut last = None;
    let server = run(server, opts, |p| {
        max_workers = max_workers.max(p.stats.workers);
        last = Some(*p);
        let done = p.stats.added >= SAMPLES && p.stats.packets_reassigned >= 1 && p.commits >= 1;
        done || p.elapsed > deadline
    })
    .unwrap();
    let last = last.unwrap();
    assert!(
        last.stats.added >= SAMPLES && last.stats.packets_reassigned >= 1 && last.commits >= 1,
        "not done after {deadline:?}: {} samples added (want {SAMPLES}), {} packets \
         reassigned (want 1: the dying worker's), {} commits (want 1)",
        last.stats.added,
        last.stats.packets_reassigned,
        last.commits
    );
    dying.join().unwrap();
    let stats = server.stats();
    assert!(
        max_workers >= 4,
        "2 threads and at least 2 TCP workers were seen ({max_workers})"
    );
    for r in remotes {
        let report = r.join().unwrap().unwrap();
        assert_eq!(report.server_scene, "analytic");
        assert_eq!(report.distance, DistanceKind::Virtual);
        assert!(report.rays > 0, "every TCP worker traced rays");
    }
    assert_eq!(stats.workers, 0, "all workers have left");
    let h = server.into_file().unwrap();
    drop(h);
    assert_stored_as_traced(&path, stats.samples);
}

/// A worker at `addr` that takes a packet and dies.
fn dying_worker(addr: String) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut c = std::net::TcpStream::connect(&addr).unwrap();
        let (mut sealer, mut opener) = auth::connect(&mut c, &credentials(), Role::Worker).unwrap();
        let hello = WorkerMsg::Hello(WorkerHello {
            protocol: PROTOCOL_VERSION,
            name: "dying".into(),
            scene: "analytic".into(),
        });
        sealer.write(&mut c, &hello, MAX_FRAME_BYTES).unwrap();
        assert!(matches!(
            opener.read(&mut c, MAX_FRAME_BYTES).unwrap(),
            ServerMsg::Welcome(_)
        ));
        assert!(matches!(
            opener.read(&mut c, MAX_FRAME_BYTES).unwrap(),
            ServerMsg::Rays(_)
        ));
    })
}

/// The file at `path` stores every one of the `samples` that came back, with the virtual
/// distances (3) measured from the entry point: interior rays are traced from the exit
/// point, one chord further on.
fn assert_stored_as_traced(path: &std::path::Path, samples: u64) {
    let h = HoloFile::open(path).unwrap();
    let stored: u64 = h.directory(0).iter().map(|e| u64::from(e.count)).sum();
    assert_eq!(stored, samples, "every sample that came back was stored");
    let mut v = Vec::new();
    h.read_beam(0, 0, &mut v).unwrap();
    assert!(!v.is_empty());
    let section = &h.sections()[0];
    let code = DistanceCode::new(section.size());
    for beam in [0, 17, section.beam_count() - 1] {
        v.clear();
        h.read_beam(0, beam, &mut v).unwrap();
        for s in &v {
            let (p0, p1) = section.sample_points(beam, s.entry, s.exit).unwrap();
            let want = 3.0 + (p1 - p0).length();
            let got = f64::from(code.decode(s.dist));
            assert!((got - want).abs() < 1e-3 * want, "{got} vs {want}");
        }
    }
}

/// Counts the rays it traces and whether any was traced beyond what `allowance` had
/// granted at the time.
struct Counted {
    inner: Analytic,
    allowance: Arc<RayAllowance>,
    traced: AtomicU64,
    over: AtomicBool,
}

impl SampleSource for Counted {
    fn trace(&self, rays: &[SourceRay], seed: u64, distance: DistanceKind) -> Vec<SourceResult> {
        let before = self.traced.fetch_add(rays.len() as u64, Ordering::SeqCst);
        if before + rays.len() as u64 > self.allowance.totals().granted {
            self.over.store(true, Ordering::SeqCst);
        }
        self.inner.trace(rays, seed, distance)
    }
}

fn held_run(mode: Mode, threads: usize) -> (Running, Arc<Counted>, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("held.hdk");
    let s = Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [3, 3, 3], ViewClass::Interior).unwrap();
    let settings = [("scene".to_string(), "analytic".to_string())].into();
    HoloFile::create(&path, vec![s], settings).unwrap();
    let server = Server::new(
        HoloFile::open_rw(&path).unwrap(),
        mode,
        ServerConfig::default(),
    );
    let allowance = Arc::new(RayAllowance::new());
    let source = Arc::new(Counted {
        inner: Analytic,
        allowance: allowance.clone(),
        traced: AtomicU64::new(0),
        over: AtomicBool::new(false),
    });
    let mut opts = options(threads, None, Duration::from_secs(3600));
    opts.source = Some(source.clone());
    (start_held(server, opts, allowance).unwrap(), source, dir)
}

/// Worker threads held to an allowance trace exactly what is granted, never a ray more,
/// even when a grant is not a whole number of packets (a batch fill always has work; the
/// analytic source would trace millions of rays a second if let go).
#[test]
fn held_threads_trace_exactly_the_rays_granted() {
    let (running, source, _dir) = held_run(Mode::Batch, 3);
    let allowance = running.allowance().unwrap();
    let mut granted = 0;
    for grant in [1000, 1, 777, 4096, 65_537, 3] {
        allowance.grant(grant);
        granted += grant;
        assert_eq!(
            allowance.settle(),
            Settled {
                traced: grant,
                withdrawn: 0
            }
        );
        assert_eq!(source.traced.load(Ordering::SeqCst), granted);
    }
    let server = running.stop().unwrap();
    assert!(
        !source.over.load(Ordering::SeqCst),
        "a ray traced beyond the grants"
    );
    assert_eq!(source.traced.load(Ordering::SeqCst), granted);
    // A packet traced in part when the run stopped is not stored: at most one per thread,
    // each short of a whole packet (at most 65 536 rays).
    let added = server.stats().added;
    assert!(
        added <= granted && granted - added < 3 * 65_536,
        "{added} stored of {granted} traced"
    );
}

/// With nothing to trace (an interactive server no display has asked anything of), a
/// grant is withdrawn once every thread has asked for work and got none: the holder is
/// not kept waiting, and the rays are not saved up for later.
#[test]
fn a_grant_with_nothing_to_trace_is_withdrawn() {
    let (running, source, _dir) = held_run(Mode::Interactive, 2);
    let allowance = running.allowance().unwrap();
    allowance.grant(500);
    assert_eq!(
        allowance.settle(),
        Settled {
            traced: 0,
            withdrawn: 500
        }
    );
    allowance.grant(20);
    assert_eq!(allowance.settle().withdrawn, 20);
    running.stop().unwrap();
    assert_eq!(source.traced.load(Ordering::SeqCst), 0);
}
