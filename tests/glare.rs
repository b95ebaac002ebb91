//! `holocave glare` end to end on a generated scene: a uniform sky seen straight up gives
//! Ev = π·L·efficacy, the JSON is one object with the figures, and bad flags are errors
//! that name them.

mod common;

use std::path::{Path, PathBuf};

use common::holocave;
use glam::{Quat, Vec3};
use holocave_scene::generate::GltfWriter;

/// The sky's radiance (scene units, white) and the scene's luminous efficacy (its
/// `[photometry]` override of Radiance's 179 lm/W, so the test sees it used).
const SKY: f32 = 2.0;
const EFFICACY: f64 = 100.0;

/// A scene of one small grey square 100 m below the eye and a uniform sky: looking up,
/// the eye sees only sky.
fn sky_scene(dir: &Path) -> (PathBuf, PathBuf) {
    let mut w = GltfWriter::default();
    let m = w.material(serde_json::json!({
        "name": "grey",
        "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 }
    }));
    let positions = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
    ];
    let mesh = w.mesh("floor", &positions, &[Vec3::Y; 4], &[0, 2, 1, 0, 3, 2], m);
    w.node(
        "floor",
        mesh,
        Vec3::new(0.0, -100.0, 0.0),
        Quat::IDENTITY,
        Vec3::ONE,
    );
    let scene = dir.join("sky.gltf");
    std::fs::write(&scene, w.finish()).unwrap();
    let daylight = dir.join("sky.daylight.toml");
    std::fs::write(
        &daylight,
        format!(
            "[sky]\nmodel = \"uniform\"\nradiance = [{SKY}, {SKY}, {SKY}]\nground_albedo = 0.2\n\n[photometry]\nefficacy = {EFFICACY}\n"
        ),
    )
    .unwrap();
    (scene, daylight)
}

fn glare(scene: &Path, daylight: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    holocave()
        .args(["glare", "--scene"])
        .arg(scene)
        .arg("--daylight")
        .arg(daylight)
        .args(["--eye", "0,1.5,0", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// Looking straight up at a uniform sky of luminance L = efficacy × SKY cd/m², every
/// pixel in the view sees L exactly (escaping paths return the sky's radiance, no noise),
/// so Ev = π L but for the fisheye's discretisation: at most `2.5 π²/N²` relative (the
/// pixels the circle's edge crosses, `2π²/N²`, and each pixel's cosine taken at its
/// centre, `π²/(2N²)`; derived in `glare/tests/figures.rs`). No source (L is under
/// 2000 cd/m²), so DGP is `0.16 + 5.87e-5 Ev` with the low-light factor.
#[test]
fn sky_seen_straight_up_gives_pi_l() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, daylight) = sky_scene(dir.path());
    let out = dir.path().join("up.exr");
    let n = 64u32;
    let size = n.to_string();
    let o = glare(
        &scene,
        &daylight,
        &out,
        &[
            "--look", "0,1,0", "--up", "0,0,-1", "--size", &size, "--spp", "1", "--json",
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
    let ev = v["ev_lux"].as_f64().unwrap();
    let l = EFFICACY * f64::from(SKY);
    let expect = std::f64::consts::PI * l;
    let bound = 2.5 * std::f64::consts::PI.powi(2) / f64::from(n * n);
    assert!(
        ((ev - expect) / expect).abs() < bound,
        "Ev {ev} against {expect}"
    );
    assert!(v["sources"].as_array().unwrap().is_empty());
    let e = (0.024 * ev - 4.0).exp();
    let dgp = (0.16 + 5.87e-5 * ev) * e / (1.0 + e);
    assert!((v["dgp"].as_f64().unwrap() - dgp).abs() < 1e-9);
    assert_eq!(v["ugr"].as_f64(), Some(0.0));
    assert!(out.is_file() && out.with_extension("png").is_file());
}

/// Bad flags stop the command with a message naming them, never a panic.
#[test]
fn bad_flags_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, daylight) = sky_scene(dir.path());
    let out = dir.path().join("x.exr");
    for (flags, says) in [
        (vec!["--look", "0,0,0"], "look direction"),
        (vec!["--look", "0,1,0"], "along the look direction"),
        (vec!["--look", "1,0,0", "--size", "0"], "--size"),
        (vec!["--look", "1,0,0", "--eye", "1,nan,0"], "--eye"),
        (vec!["--look", "1,0,0", "--threshold", "-3"], "threshold"),
    ] {
        let o = glare(&scene, &daylight, &out, &flags);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{flags:?} was accepted");
        assert!(err.contains(says), "{flags:?}: {err}");
        assert!(!err.contains("panicked"), "{flags:?}: {err}");
    }
    let o = glare(
        &scene,
        &daylight,
        &dir.path().join("x.png"),
        &["--look", "1,0,0"],
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains(".exr"));
}

/// A weather file of one June day at Chicago's site, hours 5 to 20 (the stamps' hours
/// ending then): clear, but overcast at 13:00.
fn june_day(dir: &Path) -> PathBuf {
    let mut s = String::from("LOCATION,Here,,,,0,41.98,-87.92,-6.0,201.0\n");
    s += &"HEADER,x\n".repeat(6);
    s += "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n";
    for h in 5..=20 {
        let (dni, dhi) = if h == 13 { (0, 300) } else { (600, 100) };
        s += &format!("1999,6,21,{h},0,f,20,10,50,99000,1300,1360,350,800,{dni},{dhi}\n");
    }
    let path = dir.join("june.epw");
    std::fs::write(&path, s).unwrap();
    path
}

/// `--annual` looking straight up under each hour's Perez sky and sun: every daylit hour
/// has a row, and its Ev is the global horizontal illuminance `efficacy (DHI + DNI sin h)`
/// (the sky normalised to the DHI, the sun's disc in view), within the fisheye's
/// discretisation: `2.5 π²/N²` of the sky's part, and for the sun its cosine taken at the
/// centre of the pixel it falls in, within half a pixel's diagonal `k √2/2` (`k = π/N`) of
/// its own. The summary counts the rows; the temporal map is written beside the CSV.
#[test]
fn a_year_looking_up_sees_the_global_illuminance_each_hour() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, daylight) = sky_scene(dir.path());
    let epw = june_day(dir.path());
    let out = dir.path().join("year.csv");
    let n = 64u32;
    let o = glare(
        &scene,
        &daylight,
        &out,
        &[
            "--look",
            "0,1,0",
            "--up",
            "0,0,-1",
            "--size",
            "64",
            "--spp",
            "1",
            "--annual",
            "--weather",
            epw.to_str().unwrap(),
            "--json",
        ],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let summary: serde_json::Value = serde_json::from_str(stdout.trim()).expect("one JSON object");
    let csv = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = (csv.lines().skip(1))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [4, 5, 6, 7]
                .iter()
                .map(|&i| f[i].parse().unwrap())
                .collect()
        })
        .collect();
    // The sun is up from about 4:15 to 19:30 on 21 June in Chicago's standard time: the
    // hours ending at 5 … 20 have their middles (4:30 … 19:30) up but for the last.
    assert_eq!(rows.len(), 15, "{csv}");
    assert_eq!(summary["daylit_hours"].as_u64(), Some(15));
    let k = std::f64::consts::PI / f64::from(n);
    for r in &rows {
        let (altitude, dni, dhi, ev) = (r[0], r[1], r[2], r[3]);
        let sky = EFFICACY * dhi;
        let sun = EFFICACY * dni * altitude.to_radians().sin();
        let bound = 2.5 * std::f64::consts::PI.powi(2) / f64::from(n * n) * sky
            + EFFICACY * dni * k * 2f64.sqrt() / 2.0
            + 1e-3;
        assert!(
            (ev - sky - sun).abs() < bound,
            "{r:?}: Ev {ev} against {}",
            sky + sun
        );
    }
    assert!(out.with_extension("png").is_file());
}

/// `--annual`'s own bad flags are named too.
#[test]
fn bad_annual_flags_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, daylight) = sky_scene(dir.path());
    let epw = june_day(dir.path());
    let epw = epw.to_str().unwrap();
    let csv = dir.path().join("y.csv");
    let exr = dir.path().join("y.exr");
    for (out, flags, says) in [
        (&csv, vec!["--annual"], "--weather"),
        (&exr, vec!["--annual", "--weather", epw], ".csv"),
        (
            &csv,
            vec!["--annual", "--weather", epw, "--occupied", "18-8"],
            "--occupied",
        ),
        (
            &csv,
            vec!["--annual", "--weather", epw, "--glare-limit", "2"],
            "--glare-limit",
        ),
        (&exr, vec!["--weather", epw], "--when"),
    ] {
        let mut flags = flags;
        flags.extend(["--look", "1,0,0"]);
        let o = glare(&scene, &daylight, out, &flags);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{flags:?} was accepted");
        assert!(err.contains(says), "{flags:?}: {err}");
        assert!(!err.contains("panicked"), "{flags:?}: {err}");
    }
}

/// `node --standalone --glare`: the wall runs and a thread beside it measures the newest
/// frame's view whenever it is free. Every measured frame has a line per eye (left, then
/// right, the same frame), frames only move forward and were all drawn, the figures are
/// lit (the Cornell box's lamp is in view) and in range, and the summary is printed.
#[test]
fn a_standalone_node_measures_its_heads_glare_live() {
    let dir = tempfile::tempdir().unwrap();
    let vlf = dir.path().join("cornell.vlf");
    let bake = holocave()
        .args(["vlf", "bake", "--scene", "scenes/cornell.gltf"])
        .args(["--directions", "42", "--resolution", "32", "--out"])
        .arg(&vlf)
        .output()
        .unwrap();
    assert!(
        bake.status.success(),
        "{}",
        String::from_utf8_lossy(&bake.stderr)
    );
    let frames = 8u64;
    let out = common::cornell_front_node()
        .args([
            "--still",
            "0,1.6,0",
            "--headless",
            "--sync",
            "--size",
            "16x12",
        ])
        .args(["--frames", &frames.to_string(), "--glare", "16", "--vlf"])
        .arg(&vlf)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("glare of the head's view in"), "{stdout}");
    let csv = std::fs::read_to_string(dir.path().join("front/glare.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(holocave_glare::log::HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.len() >= 2 && rows.len().is_multiple_of(2), "{csv}");
    let mut last = None;
    for pair in rows.chunks(2) {
        assert_eq!((pair[0][2], pair[1][2]), ("left", "right"), "{csv}");
        assert_eq!(pair[0][0], pair[1][0], "one frame per pair: {csv}");
        let frame: u64 = pair[0][0].parse().unwrap();
        assert!(frame < frames && last.is_none_or(|l| frame > l), "{csv}");
        last = Some(frame);
        for row in pair {
            let ev: f64 = row[3].parse().unwrap();
            let dgp: f64 = row[4].parse().unwrap();
            assert!(ev.is_finite() && ev > 0.0, "{csv}");
            assert!((0.0..=1.0).contains(&dgp), "{csv}");
        }
    }
}

/// Ctrl-C while the fisheye is path traced (the Cornell box at many paths per pixel) ends
/// `glare` at once with status 130, saying it wrote nothing, and writes nothing.
#[test]
fn ctrl_c_ends_glare_at_once() {
    let dir = common::scratch("ctrl-c-glare");
    let out = dir.join("glare.exr");
    let mut glare = common::Logged::start(
        holocave()
            .args(["glare", "--scene", "scenes/cornell.gltf"])
            .args(["--eye", "0,1,3.4", "--look", "0,0,-1"])
            .args(["--size", "256", "--spp", "100000", "--out"])
            .arg(&out)
            .env("RUST_LOG", "info"),
        &dir,
    );
    glare.wait_for_line("Ctrl-C ends it");
    let (status, took) = glare.interrupt("INT", false);
    let said = glare.stderr();
    assert_eq!(status.code(), Some(130), "{status} after {took:?}: {said}");
    assert!(said.contains("interrupted: nothing written"), "{said}");
    assert!(!out.exists(), "a half-written {}", out.display());
}
