//! `holocave daylight` end to end, and `--when` reaching a scene through the shared
//! daylight flags: the sun against SPA's published case, an hour of the shared Chicago
//! weather file, the sky's luminance towards given directions, and errors that name their
//! input.

mod common;

use std::path::PathBuf;
use std::process::{Command, Output};

fn holocave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_holocave"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap()
}

fn stdout(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout.clone()).unwrap()
}

fn last_json(o: &Output) -> serde_json::Value {
    let out = stdout(o);
    serde_json::from_str(out.lines().last().unwrap()).unwrap()
}

/// The shared Chicago TMY3 file; the test is skipped without it (and fails in CI).
fn chicago() -> Option<PathBuf> {
    common::require::shared("weather/USA_IL_Chicago-OHare.725300_TMY3.epw")
}

/// SPA's published case, with the site's standard atmosphere (812 mbar, 15 °C) and an
/// estimated ΔT instead of the case's 820 mbar, 11 °C and 67 s: within 0.01°.
#[test]
fn the_sun_of_spas_published_case() {
    let o = holocave(&[
        "daylight",
        "--site",
        "39.742476,-105.1786,1830.14",
        "--tz",
        "-7",
        "--when",
        "2003-10-17T12:30:30",
        "--json",
    ]);
    let sun = &last_json(&o)["sun"];
    let zenith = sun["zenith_deg"].as_f64().unwrap();
    let azimuth = sun["azimuth_deg"].as_f64().unwrap();
    assert!((zenith - 50.11162).abs() < 0.01, "{sun}");
    assert!((azimuth - 194.34024).abs() < 0.01, "{sun}");
    // North −Z, east +X: the afternoon sun, south-south-west, is towards +Z and −X.
    let d = &sun["direction"];
    assert!(
        d[0].as_f64().unwrap() < 0.0 && d[2].as_f64().unwrap() > 0.0,
        "{d}"
    );
    assert!(last_json(&o)["sky"].is_null());
}

#[test]
fn an_hour_of_weather_and_its_sky() {
    let Some(epw) = chicago() else {
        return;
    };
    let epw = epw.to_str().unwrap();
    let base = ["daylight", "--weather", epw, "--when", "2026-06-16T07:30"];
    let j = last_json(&holocave(&[&base[..], &["--json"]].concat()));
    // Line 4000 of the file: 06-16 hour 8 (07:00-08:00), DNI 536, DHI 171.
    assert_eq!(
        (j["dni"].as_f64(), j["dhi"].as_f64()),
        (Some(536.0), Some(171.0))
    );
    assert_eq!(j["sky"]["model"], "perez");
    let zenith = j["sky"]["zenith_radiance"].as_f64().unwrap();

    let dir = tempfile::tempdir().unwrap();
    let dirs = dir.path().join("dirs.txt");
    std::fs::write(&dirs, "# east north up\n0 0 1\n1, 0, 0.5\n0 -1 -1\n").unwrap();
    let o = holocave(&[&base[..], &["--sky-at", dirs.to_str().unwrap()]].concat());
    let lum: Vec<f64> = stdout(&o).lines().map(|l| l.parse().unwrap()).collect();
    assert_eq!(lum.len(), 3);
    assert!(
        (lum[0] / (179.0 * zenith) - 1.0).abs() < 1e-4,
        "{lum:?} {zenith}"
    );
    // Morning: the east is brighter than the zenith; the ground below is lit.
    assert!(lum[1] > lum[0] && lum[2] > 0.0, "{lum:?}");
}

#[test]
fn when_reaches_a_loaded_scene() {
    let dir = tempfile::tempdir().unwrap();
    let daylight = dir.path().join("room.daylight.toml");
    std::fs::write(
        &daylight,
        "[site]\nlatitude = 41.98\nlongitude = -87.92\nelevation = 201.0\ntime_zone = -6.0\n\
         [sun]\nirradiance = [800.0, 800.0, 800.0]\n",
    )
    .unwrap();
    let when = "2026-12-21T09:00";
    let info = stdout(&holocave(&[
        "scene",
        "info",
        "scenes/room.gltf",
        "--daylight",
        daylight.to_str().unwrap(),
        "--when",
        when,
    ]));
    let j = last_json(&holocave(&[
        "daylight",
        "--site",
        "41.98,-87.92,201",
        "--tz",
        "-6",
        "--when",
        when,
        "--json",
    ]));
    let d: Vec<f64> = (0..3)
        .map(|i| j["sun"]["direction"][i].as_f64().unwrap())
        .collect();
    let shown = format!("towards [{:.3}, {:.3}, {:.3}]", d[0], d[1], d[2]);
    assert!(info.contains(&shown), "{info} should show the sun {shown}");
    // Without a time, a [sun] without a direction is an error naming the way out.
    let o = holocave(&[
        "scene",
        "info",
        "scenes/room.gltf",
        "--daylight",
        daylight.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("[site] and a time"));
}

#[test]
fn bad_input_is_named() {
    let o = holocave(&[
        "daylight",
        "--site",
        "41,-87,200",
        "--tz",
        "-6",
        "--when",
        "2026-13-01T09:00",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("2026-13-01T09:00"));
    let o = holocave(&[
        "daylight",
        "--site",
        "41,-87",
        "--tz",
        "-6",
        "--when",
        "2026-12-01T09:00",
    ]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("--site"));
    let dir = tempfile::tempdir().unwrap();
    let dirs = dir.path().join("dirs.txt");
    std::fs::write(&dirs, "0 0 1\nup\n").unwrap();
    let o = holocave(&[
        "daylight",
        "--site",
        "41,-87,200",
        "--tz",
        "-6",
        "--when",
        "2026-12-01T09:00",
        "--sky-at",
        dirs.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--weather"), "{e}");
    if let Some(epw) = chicago() {
        let o = holocave(&[
            "daylight",
            "--weather",
            epw.to_str().unwrap(),
            "--when",
            "2026-12-01T09:00",
            "--sky-at",
            dirs.to_str().unwrap(),
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains("dirs.txt:2"), "{e}");
    }
}
