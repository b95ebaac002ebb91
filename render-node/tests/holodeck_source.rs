//! A render node's holodeck source over TCP against a holodeck server on loopback (no
//! GPU needed): the chosen pixels of two eyes become beam requests, worker threads trace
//! rays near the eyes (an analytic scene), and the samples come back as render-cache
//! samples at the pixels where their points project, with the scene's colour there.

use std::collections::HashSet;
use std::net::TcpListener;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::{DVec3, Vec2, Vec3};
use holocave_cave::{Size, WallView};
use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::run::{RayAllowance, RunOptions, Running, start_held};
use holocave_holodeck::server::{Mode, Server, ServerConfig};
use holocave_holodeck::worker::{DistanceKind, SampleSource, SourceRay, SourceResult};
use holocave_holodeck::{HoloFile, Section, ViewClass};
use holocave_render_node::{EyeView, HolodeckSource, NewSample};

/// A back plane z = -3: red where x < 0, green where x ≥ 0; everything else escapes.
struct Plane;

impl SampleSource for Plane {
    fn trace(&self, rays: &[SourceRay], _seed: u64, _distance: DistanceKind) -> Vec<SourceResult> {
        rays.iter()
            .map(|&SourceRay { origin: o, dir: d }| {
                if d.z >= 0.0 {
                    return SourceResult {
                        radiance: [0.0; 3],
                        distance: f32::INFINITY,
                    };
                }
                let t = (-3.0 - o.z) / d.z;
                let x = o.x + t * d.x;
                SourceResult {
                    radiance: if x < 0.0 {
                        [1.0, 0.0, 0.0]
                    } else {
                        [0.0, 1.0, 0.0]
                    },
                    distance: t,
                }
            })
            .collect()
    }
}

const SIZE: u32 = 24;

fn eye_view(eye: Vec3) -> EyeView {
    EyeView::looking_at(
        WallView {
            eye,
            pa: Vec3::new(-1.0, -1.0, -1.0),
            pb: Vec3::new(1.0, -1.0, -1.0),
            pc: Vec3::new(-1.0, 1.0, -1.0),
            size: Size::new(SIZE, SIZE),
        },
        0.05,
    )
    .expect("the eye is in front of the wall")
}

fn credentials() -> Credentials {
    Credentials {
        cluster: "test".into(),
        secret: b"source-test-secret".to_vec(),
    }
}

#[test]
fn tcp_holodeck_source_turns_requests_into_samples_at_the_right_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let (running, allowance) = held_server_on_loopback(&dir.path().join("plane.hdk"));
    let source = HolodeckSource::connect(running.local_addr().unwrap(), 2, &credentials()).unwrap();
    assert!(source.is_connected());
    let views = [
        eye_view(Vec3::new(-0.032, 0.1, 0.3)),
        eye_view(Vec3::new(0.032, 0.1, 0.3)),
    ];
    let all: Vec<u32> = (0..SIZE * SIZE).collect();
    let mut source = check_frames_never_wait_for_samples(source, views, &all);

    // Now rays for the threads: the requests become samples.
    allowance.grant(u64::MAX / 2);
    let (got, took) = samples_until_most_pixels_are_covered(&mut source, &views, &all);
    let counts = source.counts();
    eprintln!(
        "{:?} samples per eye in {:.2} s; {counts:?}",
        got.iter().map(Vec::len).collect::<Vec<_>>(),
        took.as_secs_f64()
    );
    assert!(
        counts.received > 0 && counts.near * 10 >= counts.used * 8,
        "{counts:?}"
    );
    for (eye, samples) in got.iter().enumerate() {
        check_samples_land_in_their_pixels_with_the_planes_colour(eye, samples, &views[eye]);
    }
    drop(source);
    running.stop().unwrap();
}

/// A holodeck file at `path` with an interior section around the eyes, its far face
/// the screen, served on loopback by a held server that traces `Plane` with 2 threads,
/// and the allowance that grants its rays.
fn held_server_on_loopback(path: &Path) -> (Running, Arc<RayAllowance>) {
    let section = Section::with_target_beams(
        DVec3::new(-1.0, -1.0, -1.0),
        [DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0],
        ViewClass::Interior,
        20_000,
    )
    .unwrap();
    HoloFile::create(path, vec![section], Default::default()).unwrap();
    let server = Server::new(
        HoloFile::open_rw(path).unwrap(),
        Mode::Interactive,
        ServerConfig::default(),
    );
    // Held: its threads trace only the rays granted.
    let allowance = Arc::new(RayAllowance::new());
    let running = start_held(
        server,
        RunOptions {
            threads: 2,
            source: Some(Arc::new(Plane)),
            listener: Some(Port {
                listener: TcpListener::bind("127.0.0.1:0").unwrap(),
                credentials: credentials(),
            }),
            scene: "plane".into(),
            commit_every: Duration::from_secs(60),
            stop: Default::default(),
        },
        allowance.clone(),
    )
    .unwrap();
    (running, allowance)
}

/// Frames hand over their pixels and never wait for samples: with no ray granted
/// nothing is traced, and a hundred frames still go by. A source that waited for its
/// requests' answers would wait for ever; the frames run on a thread of their own, so
/// that shows as no word from it within a minute. Returns the source.
fn check_frames_never_wait_for_samples(
    mut source: HolodeckSource,
    views: [EyeView; 2],
    all: &[u32],
) -> HolodeckSource {
    let (done, finished) = std::sync::mpsc::channel();
    let frames = std::thread::spawn({
        let all = all.to_vec();
        move || {
            let mut received = 0;
            for _ in 0..100 {
                source.submit(&views, vec![all.clone(), all.clone()]);
                received += source.collect().len();
            }
            done.send(()).unwrap();
            (source, received)
        }
    });
    finished
        .recv_timeout(Duration::from_secs(60))
        .expect("a frame waited for samples that no one traces");
    let (source, received) = frames.join().unwrap();
    assert_eq!(received, 0, "samples arrived with no ray granted");
    source
}

/// Each eye's samples from submitting every pixel frame after frame, until 95 % of
/// each eye's pixels have one or 20 s have gone by; and the time that took.
fn samples_until_most_pixels_are_covered(
    source: &mut HolodeckSource,
    views: &[EyeView; 2],
    all: &[u32],
) -> (Vec<Vec<NewSample>>, Duration) {
    let mut got: Vec<Vec<NewSample>> = vec![Vec::new(), Vec::new()];
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) {
        source.submit(views, vec![all.to_vec(), all.to_vec()]);
        for (eye, s) in source.collect() {
            got[eye].extend(s);
        }
        let covered = got
            .iter()
            .map(|g| g.iter().map(NewSample::pixel).collect::<HashSet<_>>().len())
            .min()
            .unwrap();
        if covered * 20 >= (SIZE * SIZE) as usize * 19 {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    (got, t.elapsed())
}

/// One eye's samples: at least one per pixel on average, each point projecting into its
/// pixel with the plane's colour there and a weight of at least 1, and 90 % of the
/// pixels covered.
fn check_samples_land_in_their_pixels_with_the_planes_colour(
    eye: usize,
    samples: &[NewSample],
    v: &EyeView,
) {
    assert!(
        samples.len() >= (SIZE * SIZE) as usize,
        "eye {eye}: {} samples",
        samples.len()
    );
    let mut pixels = HashSet::new();
    let mut wrong = 0;
    for s in samples {
        let p = s.pixel();
        pixels.insert(p);
        let (x, y) = (p % SIZE, p / SIZE);
        // The point projects into its pixel.
        let (px, py, _) = v.project(s.position()).unwrap();
        assert!(
            px.floor() as u32 == x && py.floor() as u32 == y,
            "eye {eye}: point at ({px}, {py}) for pixel ({x}, {y})"
        );
        // Its colour is the plane's where the eye's line of sight meets it (pixels
        // within one of the colour boundary may be mixed).
        let r = v.wall.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let t = (-3.0 - r.origin.z) / r.dir.z;
        let bx = r.origin.x + t * r.dir.x;
        let pixel_width = 2.0 / SIZE as f32 * (3.0 + r.origin.z) / (1.0 + r.origin.z);
        let c = s.radiance();
        if bx.abs() > 1.5 * pixel_width && ((bx < 0.0) != (c.x > c.y)) {
            wrong += 1;
        }
        assert!(s.weight() >= 1.0);
    }
    assert_eq!(wrong, 0, "eye {eye}: samples with the wrong colour");
    assert!(
        pixels.len() * 10 >= (SIZE * SIZE) as usize * 9,
        "eye {eye}: {} of {} pixels have samples",
        pixels.len(),
        SIZE * SIZE
    );
}
