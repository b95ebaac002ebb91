//! The live meter on a generated sky scene, and the per-frame log and its summary.

use std::f64::consts::PI;
use std::sync::Arc;

use glam::{Quat, Vec3};
use holocave_glare::draw::Drawing;
use holocave_glare::figures::Figures;
use holocave_glare::log::{GlareLog, HEADER, Summary};
use holocave_glare::meter::GlareMeter;
use holocave_glare::{GlareError, Rules};
use holocave_scene::generate::GltfWriter;
use holocave_scene::{LoadOptions, Photometry, Scene};
use holocave_tracer::{TraceSettings, Tracer};

/// One small grey square 100 m below the eye under a uniform sky of radiance 1.
fn sky_scene() -> Arc<Scene> {
    scene_with("[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\nground_albedo = 0.0\n")
}

/// The same square under the daylight `daylight` (TOML).
fn scene_with(daylight_toml: &str) -> Arc<Scene> {
    let dir = tempfile::tempdir().unwrap();
    let mut w = GltfWriter::default();
    let m = w.material(serde_json::json!({
        "name": "grey",
        "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0 }
    }));
    let p = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ];
    let mesh = w.mesh("floor", &p, &[Vec3::Y; 4], &[0, 2, 1, 0, 3, 2], m);
    w.node(
        "floor",
        mesh,
        Vec3::new(0.0, -100.0, 0.0),
        Quat::IDENTITY,
        Vec3::ONE,
    );
    let scene = dir.path().join("sky.gltf");
    std::fs::write(&scene, w.finish()).unwrap();
    let daylight = dir.path().join("sky.daylight.toml");
    std::fs::write(&daylight, daylight_toml).unwrap();
    let opts = LoadOptions {
        daylight: Some(daylight),
        ..LoadOptions::default()
    };
    Arc::new(Scene::load(&scene, &opts).unwrap())
}

/// Looking up into the sky from any head position, Ev = π·179 lx within the fisheye's
/// discretisation (2.5 π²/N², `figures.rs`) — also looking straight along the meter's
/// up, where the meter takes another axis as the fisheye's up. Looking at the horizon
/// the lower half sees the black ground (albedo 0): Ev is half, within the same bound
/// plus the rim pixels' band around the horizon line (`√2/2 px · 2c px · k²` sr, cos ≤ 1,
/// radiance 1: `√2 k` of π).
#[test]
fn meter_measures_each_pose() {
    let scene = sky_scene();
    let tracer = Tracer::new(scene, TraceSettings::default());
    let drawing = Drawing::PathTraced {
        tracer: Box::new(tracer),
        spp: 1,
        seed: 7,
    };
    let n = 48;
    let meter =
        GlareMeter::new(drawing, n, Vec3::Y, Rules::default(), Photometry::default()).unwrap();
    let l = 179.0;
    let bound = 2.5 * PI * PI / f64::from(n * n);
    for (eye, look) in [
        (Vec3::ZERO, Vec3::Y),
        (Vec3::new(3.0, 1.0, -2.0), Vec3::new(0.0, 1.0, 0.0)),
        (Vec3::ZERO, Vec3::new(0.1, 1.0, 0.0)),
    ] {
        let f = meter.measure(eye, look).unwrap();
        let up_cos = f64::from(look.normalize().y);
        // A tilted view sees some ground near its rim: Ev = L·π·(1 + cos tilt)/2 for a
        // black ground (the sky's part of the tilted hemisphere, cosine-weighted).
        let expect = PI * l * (1.0 + up_cos) / 2.0;
        let rim = 2f64.sqrt() * (PI / f64::from(n));
        assert!(
            ((f.ev_lux - expect) / expect).abs() < bound + rim,
            "{look}: {} against {expect}",
            f.ev_lux
        );
        assert!(f.sources.is_empty());
    }
    let half = meter.measure(Vec3::ZERO, Vec3::X).unwrap();
    let expect = PI * l / 2.0;
    let rim = 2f64.sqrt() * (PI / f64::from(n));
    assert!(
        ((half.ev_lux - expect) / expect).abs() < 2.0 * (bound + rim),
        "{}",
        half.ev_lux
    );
    assert!(matches!(
        meter.measure(Vec3::ZERO, Vec3::ZERO),
        Err(GlareError::BadView(_))
    ));
}

fn figures(dgp: f64) -> Figures {
    Figures {
        ev_lux: 1234.5,
        dgp,
        ugr: if dgp > 0.2 { Some(21.0) } else { None },
        background_cd_m2: 100.0,
        average_cd_m2: 150.0,
        threshold_cd_m2: 2000.0,
        sources: Vec::new(),
    }
}

/// Frames at 0, 1, 2 and 3 s with the eyes' DGP (0.5, 0.2), (0.3, 0.3), (0.1, 0.42),
/// (0.1, 0.1): the higher eye's holds until the next frame, so DGP is above 0.35 and 0.40
/// during [0, 1) and [2, 3) (2/3 of the session) and above 0.45 during [0, 1) (1/3); the
/// CSV has the header and one line per frame and eye.
#[test]
fn log_and_summary() {
    let mut log = GlareLog::new(Vec::new(), std::path::Path::new("mem")).unwrap();
    for (i, (l, r)) in [(0.5, 0.2), (0.3, 0.3), (0.1, 0.42), (0.1, 0.1)]
        .into_iter()
        .enumerate()
    {
        let (l, r) = (figures(l), figures(r));
        log.record(
            i as u64,
            i as u64 * 1_000_000_000,
            &[("left", &l), ("right", &r)],
        )
        .unwrap();
    }
    let (bytes, summary) = log.finish().unwrap();
    let text = String::from_utf8(bytes).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], HEADER);
    assert_eq!(lines.len(), 9);
    assert_eq!(lines[1], "0,0,left,1234.500,0.50000,21.000,0");
    assert_eq!(lines[8], "3,3000000000,right,1234.500,0.10000,,0");
    assert_eq!(summary.frames, 4);
    let [a, b, c] = summary.fractions_above();
    let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
    assert!(
        close(a, 2.0 / 3.0) && close(b, 2.0 / 3.0) && close(c, 1.0 / 3.0),
        "{a} {b} {c}"
    );
    assert_eq!(summary.frames, 4);
    assert!(close(summary.max_dgp, 0.5));
    assert!(summary.to_string().contains("66.7%"));
    // One frame: the fraction of frames.
    let mut one = Summary::default();
    one.add(5, 0.41);
    assert_eq!(one.fractions_above(), [1.0, 1.0, 0.0]);
}

/// A sun of normal irradiance 1 (179 lx) and nothing else, 30° from the line of sight:
/// Ev = 179 cos 30° at every size, though the disc (0.53°) is far smaller than a pixel
/// at 16 × 16 (11°) and not at 256 × 256: its rays count the disc's `L ω` exactly
/// (`draw`), spread over the pixels they fall in, whose cosines are taken at their
/// centres — within half a pixel's diagonal, `k √2/2` rad, of the sun's: an error of at
/// most `179 · sin 30° · k √2/2` lx (plus rounding).
#[test]
fn the_sun_is_counted_once_at_any_size() {
    let scene = scene_with(
        "[sun]\ndirection = [0.5, 0.0, -0.8660254]\nangular_diameter_deg = 0.53\nirradiance = [1.0, 1.0, 1.0]\n",
    );
    // With several rays a pixel some fall in the disc: they must not count it again.
    for (n, spp) in [(16, 1), (37, 4), (64, 16), (256, 64)] {
        let tracer = Tracer::new(scene.clone(), TraceSettings::default());
        let drawing = Drawing::PathTraced {
            tracer: Box::new(tracer),
            spp,
            seed: 3,
        };
        let meter =
            GlareMeter::new(drawing, n, Vec3::Y, Rules::default(), Photometry::default()).unwrap();
        let f = meter.measure(Vec3::ZERO, Vec3::NEG_Z).unwrap();
        let expect = 179.0 * 30f64.to_radians().cos();
        let k = PI / f64::from(n);
        let bound = 179.0 * 0.5 * k * 2f64.sqrt() / 2.0 + 1e-3;
        assert!(
            (f.ev_lux - expect).abs() < bound,
            "{n}: Ev {} against {expect} ± {bound}",
            f.ev_lux
        );
        // The sun is a source (at 16 × 16 its pixels are 0.2 rad apart, over the merging
        // radius, so it may be two).
        assert!(
            !f.sources.is_empty() && f.sources.len() <= 2,
            "{n}: {:?}",
            f.sources
        );
    }
}

/// The light field's drawing (its lookups, the direct light per pixel) of a uniform sky of
/// radiance 1 and a sun of normal irradiance 1 at 30° from the zenith, looking up: the
/// sky is the lookups' `emitted` light, exact, and the sun is counted once by its disc's
/// rays, so Ev = 179 (π + cos 30°) within the sky's discretisation (`2.5 π²/N²` of
/// 179 π, `figures.rs`) and the sun's half-pixel cosine (`179 · sin 30° · k √2/2`).
#[test]
fn light_field_drawing_of_sky_and_sun() {
    let scene = scene_with(
        "[sun]\ndirection = [0.5, 0.8660254, 0.0]\nangular_diameter_deg = 0.53\nirradiance = [1.0, 1.0, 1.0]\n\n[sky]\nmodel = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\nground_albedo = 0.0\n",
    );
    let settings = holocave_vlf::Settings {
        directions: 42,
        resolution: 16,
        ..holocave_vlf::Settings::default()
    };
    let (state, _) =
        holocave_vlf::bake(&scene, &settings, None, &|_| {}, &mut |_| Ok::<(), ()>(())).unwrap();
    let visibility = holocave_vlf::Visibility::of(scene.clone(), &settings);
    let drawing = Drawing::of_state(visibility, (&settings, &state), false, 1, 2);
    let n = 64;
    let meter = GlareMeter::new(
        drawing,
        n,
        Vec3::NEG_Z,
        Rules::default(),
        Photometry::default(),
    )
    .unwrap();
    let f = meter.measure(Vec3::ZERO, Vec3::Y).unwrap();
    let expect = 179.0 * (PI + 30f64.to_radians().cos());
    let k = PI / f64::from(n);
    let bound = 2.5 * PI * PI / f64::from(n * n) * 179.0 * PI + 179.0 * 0.5 * k * 2f64.sqrt() / 2.0;
    assert!(
        (f.ev_lux - expect).abs() < bound,
        "Ev {} against {expect} ± {bound}",
        f.ev_lux
    );
}

/// A session's frames measured in parallel come out in frame order, each line the meter's
/// own figures for that frame's view, and the summary counts every frame.
#[test]
fn a_session_is_measured_frame_by_frame_in_order() {
    use holocave_glare::session::{FrameView, measure_session};
    let scene = sky_scene();
    let drawing = Drawing::PathTraced {
        tracer: Box::new(Tracer::new(scene, TraceSettings::default())),
        spp: 1,
        seed: 7,
    };
    let meter = GlareMeter::new(
        drawing,
        24,
        Vec3::Y,
        Rules::default(),
        Photometry::default(),
    )
    .unwrap();
    // Tilting from the horizon to the zenith: Ev grows frame by frame.
    let views: Vec<FrameView> = (0..6u64)
        .map(|k| {
            let a = k as f32 * 0.3;
            FrameView {
                frame: 10 + k,
                time_ns: k * 33_333_333,
                eye_name: "centre",
                eye: Vec3::ZERO,
                look: Vec3::new(a.cos(), a.sin(), 0.0),
            }
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("glare.csv");
    let summary = measure_session(&meter, &views, &csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let mut last_ev = 0.0;
    for (v, line) in views.iter().zip(lines) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[0].parse::<u64>().unwrap(), v.frame);
        assert_eq!(f[1].parse::<u64>().unwrap(), v.time_ns);
        assert_eq!(f[2], "centre");
        let ev: f64 = f[3].parse().unwrap();
        let own = meter.measure(v.eye, v.look).unwrap().ev_lux;
        assert!((ev - own).abs() <= 5e-4 * own.max(1.0), "{line}: {own}");
        assert!(ev > last_ev, "{line} after Ev {last_ev}");
        last_ev = ev;
    }
    assert_eq!(text.lines().count(), 1 + views.len());
    assert_eq!(summary.frames, views.len() as u64);
}

/// Live: frames offered faster than they are measured are skipped, never reordered; the
/// last one offered is measured before `finish` returns; every line is the meter's own
/// figures for that frame's eye.
#[test]
fn live_glare_measures_the_newest_frames_in_order() {
    use holocave_glare::live::LiveGlare;
    use holocave_glare::session::FrameView;
    let meter = || {
        let drawing = Drawing::PathTraced {
            tracer: Box::new(Tracer::new(sky_scene(), TraceSettings::default())),
            spp: 1,
            seed: 7,
        };
        GlareMeter::new(
            drawing,
            24,
            Vec3::Y,
            Rules::default(),
            Photometry::default(),
        )
        .unwrap()
    };
    let views = |k: u64| {
        let a = k as f32 * 0.1;
        ["left", "right"]
            .into_iter()
            .enumerate()
            .map(|(e, name)| FrameView {
                frame: k,
                time_ns: k * 16_666_667,
                eye_name: name,
                eye: Vec3::new(0.03 * e as f32, 0.0, 0.0),
                look: Vec3::new(a.cos(), a.sin(), 0.0),
            })
            .collect::<Vec<_>>()
    };
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("glare.csv");
    let live = LiveGlare::start(meter(), &csv).unwrap();
    for k in 0..8 {
        live.offer(views(k));
    }
    let summary = live.finish().unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(HEADER));
    let reference = meter();
    let mut frames = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let k: u64 = f[0].parse().unwrap();
        let v = views(k);
        let e = v
            .iter()
            .find(|v| v.eye_name == f[2])
            .expect("an eye's name");
        let own = reference.measure(e.eye, e.look).unwrap().ev_lux;
        let ev: f64 = f[3].parse().unwrap();
        assert!((ev - own).abs() <= 5e-4 * own.max(1.0), "{line}: {own}");
        if frames.last() != Some(&k) {
            frames.push(k);
        }
    }
    assert!(
        frames.windows(2).all(|w| w[0] < w[1]),
        "in order: {frames:?}"
    );
    assert_eq!(frames.last(), Some(&7), "the last offered is measured");
    assert_eq!(summary.frames, frames.len() as u64);
    assert_eq!(text.lines().count(), 1 + 2 * frames.len());
}
