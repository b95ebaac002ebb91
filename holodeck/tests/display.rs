//! The display service: a display over TCP on loopback and one in the server's process
//! ask for beams near their eyes and receive samples — the stored ones at once, then new
//! ones as worker threads trace them, each sample once; a second display is sent the new
//! samples of beams it is up to date on; the stored samples survive a restart.

use std::collections::HashMap;
use std::net::TcpListener;
use std::time::{Duration, Instant};

use crate::common;

use common::{credentials, options};
use glam::DVec3;
use holocave_holodeck::beam_index::BeamKey;
use holocave_holodeck::display::{DisplayClient, EyeRequest};
use holocave_holodeck::distance_code::DistanceCode;
use holocave_holodeck::proximity::EyeSphere;
use holocave_holodeck::run::start;
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::view::WorldSample;
use holocave_holodeck::{HoloFile, PackedSample, Section, ViewClass};

fn section() -> Section {
    Section::axis_aligned(
        DVec3::ZERO,
        DVec3::new(2.0, 2.0, 2.0),
        [4, 4, 4],
        ViewClass::Interior,
    )
    .unwrap()
}

/// The beams the lines of sight from `eye` along a few directions cross, 50 samples each.
fn wanted(s: &Section, eye: DVec3) -> Vec<(BeamKey, f64)> {
    let mut out: Vec<(BeamKey, f64)> = Vec::new();
    for d in [
        DVec3::new(0.1, 0.2, -1.0),
        DVec3::new(-0.3, 0.1, -1.0),
        DVec3::new(1.0, 0.2, 0.3),
        DVec3::new(0.0, -1.0, 0.2),
    ] {
        let c = s.crossing(eye, d).unwrap();
        if !out.iter().any(|w| w.0 == BeamKey::new(0, c.beam)) {
            out.push((BeamKey::new(0, c.beam), 50.0));
        }
    }
    out
}

/// Collects until `enough` holds for the per-beam samples received, or 20 s pass.
fn receive(
    c: &DisplayClient,
    got: &mut HashMap<BeamKey, Vec<PackedSample>>,
    enough: impl Fn(&HashMap<BeamKey, Vec<PackedSample>>) -> bool,
) -> bool {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) {
        for a in c.collect() {
            for b in a.iter() {
                got.entry(b.key).or_default().extend(&b.samples);
            }
        }
        if enough(got) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    false
}

/// Collects until display `id` has received every sample the server has given it (at
/// most 20 s), then checks that these are the holodeck's samples, each once: the server
/// holds only the beams the displays asked for, and nothing more is being traced.
fn assert_each_sample_once(
    running: &holocave_holodeck::run::Running,
    c: &DisplayClient,
    id: u32,
    got: &mut HashMap<BeamKey, Vec<PackedSample>>,
) {
    let given = running.display_tally(id).samples;
    let count =
        |g: &HashMap<BeamKey, Vec<PackedSample>>| g.values().map(|v| v.len() as u64).sum::<u64>();
    assert!(
        receive(c, got, |g| count(g) >= given),
        "display {id} was given {given} samples and received {}",
        count(got)
    );
    assert_eq!(
        (count(got), given),
        (running.stats().samples, running.stats().samples),
        "display {id}: samples received and given, against the samples the holodeck holds"
    );
}

/// A new holodeck at `path` served in interactive mode with `threads` worker threads,
/// accepting TCP workers and displays on a loopback port.
fn interactive_on_loopback(
    path: &std::path::Path,
    threads: usize,
) -> holocave_holodeck::run::Running {
    HoloFile::create(path, vec![section()], Default::default()).unwrap();
    let server = Server::new(
        HoloFile::open_rw(path).unwrap(),
        Mode::Interactive,
        ServerConfig::default(),
    );
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    start(
        server,
        options(threads, Some(listener), Duration::from_millis(500)),
    )
    .unwrap()
}

type Got = HashMap<BeamKey, Vec<PackedSample>>;

/// Whether `g` holds at least the wanted number of samples of every beam of `want`.
fn holds_wanted(want: &[(BeamKey, f64)], g: &Got) -> bool {
    want.iter()
        .all(|(k, n)| g.get(k).is_some_and(|v| v.len() as f64 >= *n))
}

#[test]
fn displays_over_tcp_and_in_process_receive_stored_and_new_samples() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.hdk");
    let running = interactive_on_loopback(&path, 2);
    let addr = running.local_addr().unwrap();

    let tcp = DisplayClient::connect(addr, 3, &credentials()).unwrap();
    assert_eq!(
        tcp.sections(),
        &[section()],
        "the welcome carries the sections"
    );
    let s = &tcp.sections()[0];
    let eye = DVec3::new(0.7, 1.1, 1.3);
    let want = wanted(s, eye);
    let near_eye = |wanted: Vec<(BeamKey, f64)>| EyeRequest {
        slot: 0,
        eye: Some(EyeSphere {
            pos: eye,
            radius: 0.05,
        }),
        wanted,
    };
    tcp.request(near_eye(want.clone()));
    let mut got = HashMap::new();
    assert!(
        receive(&tcp, &mut got, |g| holds_wanted(&want, g)),
        "the TCP display received traced samples: {:?}",
        got.iter().map(|(k, v)| (*k, v.len())).collect::<Vec<_>>()
    );
    assert_new_rays_pass_near(s, &got, eye);
    let local = running.display(9);
    let mut got_local = stored_reach_a_local_display_once(&running, &local, &want, &got);
    // The TCP display asks for more: the new samples reach both displays (the local one
    // is up to date on these beams), and each sample arrives once.
    let more: Vec<(BeamKey, f64)> = want.iter().map(|(k, _)| (*k, 120.0)).collect();
    tcp.request(near_eye(more.clone()));
    assert!(receive(&tcp, &mut got, |g| holds_wanted(&more, g)));
    assert!(receive(&local, &mut got_local, |g| holds_wanted(&more, g)));
    // Every sample traced (nothing more is wanted) has reached both displays, once.
    assert_each_sample_once(&running, &tcp, 3, &mut got);
    assert_each_sample_once(&running, &local, 9, &mut got_local);
    assert_same_samples(&got, &got_local);
    drop(local);
    drop(tcp);
    let server = running.stop().unwrap();
    let total: u64 = server.stats().samples;
    drop(server);
    reopened_serves_what_it_stored(&path, total, &more);
}

/// The new rays pass near the eye (Appendix A; a few may fall back to uniform ones).
fn assert_new_rays_pass_near(s: &Section, got: &Got, eye: DVec3) {
    let code = DistanceCode::new(s.size());
    let (mut near, mut total) = (0, 0);
    for (k, v) in got {
        for smp in v {
            let ws = WorldSample::decode(s, &code, k.beam, smp).unwrap();
            assert!((ws.point(0.0) - ws.exit).length() > 0.0);
            total += 1;
            near += usize::from(ws.miss(eye) <= 0.05 + 1e-3);
        }
    }
    assert!(
        near * 10 >= total * 9,
        "{near} of {total} rays pass near the eye"
    );
}

/// A display in the server's process asking for the beams of `want` gets what is stored
/// (`got`) at once, with no worker involved (its requests ask for no more than is there);
/// repeating the request sends nothing twice. What it received.
fn stored_reach_a_local_display_once(
    running: &holocave_holodeck::run::Running,
    local: &DisplayClient,
    want: &[(BeamKey, f64)],
    got: &Got,
) -> Got {
    let stored: HashMap<BeamKey, usize> = want.iter().map(|(k, _)| (*k, got[k].len())).collect();
    let request = || EyeRequest {
        slot: 1,
        eye: None,
        wanted: want.iter().map(|(k, _)| (*k, 1.0)).collect(),
    };
    local.request(request());
    let mut got_local = HashMap::new();
    assert!(receive(local, &mut got_local, |g| {
        stored
            .iter()
            .all(|(k, n)| g.get(k).is_some_and(|v| v.len() >= *n))
    }));
    // Once the server has served the repeat, the display has been given each sample the
    // holodeck holds exactly once.
    local.request(request());
    let t = Instant::now();
    while running.display_tally(9).requests < 2 {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "the repeated request was not served"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_each_sample_once(running, local, 9, &mut got_local);
    got_local
}

/// Both displays hold every sample of every beam, once.
fn assert_same_samples(got: &Got, got_local: &Got) {
    for (k, v) in got {
        assert_eq!(
            got_local.get(k).map(Vec::len),
            Some(v.len()),
            "beam {k:?}: both displays have every sample, once"
        );
        let mut a = v.clone();
        let mut b = got_local[k].clone();
        a.sort_by_key(|s| s.to_bytes());
        b.sort_by_key(|s| s.to_bytes());
        assert_eq!(a, b);
    }
}

/// The holodeck at `path` reopened without workers holds its `total` samples, and a new
/// TCP display gets the stored samples of `more`.
fn reopened_serves_what_it_stored(path: &std::path::Path, total: u64, more: &[(BeamKey, f64)]) {
    let server = Server::new(
        HoloFile::open_rw(path).unwrap(),
        Mode::Interactive,
        ServerConfig::default(),
    );
    assert_eq!(server.stats().samples, total, "every sample was committed");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let running = start(
        server,
        options(0, Some(listener), Duration::from_millis(500)),
    )
    .unwrap();
    let tcp = DisplayClient::connect(running.local_addr().unwrap(), 3, &credentials()).unwrap();
    tcp.request(EyeRequest {
        slot: 0,
        eye: None,
        wanted: more.to_vec(),
    });
    let mut again = HashMap::new();
    assert!(receive(&tcp, &mut again, |g| holds_wanted(more, g)));
    drop(tcp);
    running.stop().unwrap();
}

#[test]
fn a_display_with_another_protocol_is_refused() {
    use holocave_protocol::frame::{MAX_FRAME_BYTES, read_frame, write_frame};
    use holocave_protocol::holodeck::{DisplayHello, ServerMsg, WorkerMsg};
    let dir = tempfile::tempdir().unwrap();
    let running = interactive_on_loopback(&dir.path().join("p.hdk"), 0);
    let mut c = std::net::TcpStream::connect(running.local_addr().unwrap()).unwrap();
    let hello = WorkerMsg::DisplayHello(DisplayHello {
        protocol: 1,
        display: 0,
        name: "old".into(),
    });
    write_frame(&mut c, &hello, MAX_FRAME_BYTES).unwrap();
    assert!(read_frame::<_, ServerMsg>(&mut c, MAX_FRAME_BYTES).is_err());
    running.stop().unwrap();
}
