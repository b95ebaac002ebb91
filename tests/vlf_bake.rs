//! `holocave vlf bake` end to end: the same light field, bit for bit, from the bake's own
//! threads and from `holocave worker --vlf` processes that the bake hands subfields to;
//! workers with a wrong secret or another scene are refused and the bake goes on.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use common::holocave;

const SECRET: &str = "vlf-bake-test-secret";

/// Small settings: a bake of the Cornell box (mirror and glass: links too) in a second.
const SETTINGS: [&str; 4] = ["--directions", "42", "--resolution", "32"];

fn bake_args(out: &Path) -> Command {
    let mut c = holocave();
    c.args(["vlf", "bake", "--scene", "scenes/cornell.gltf"])
        .args(SETTINGS)
        .arg("--out")
        .arg(out)
        .env("HOLOCAVE_SECRET", SECRET);
    c
}

fn worker(addr: &str, scene: &str, secret: &str) -> Child {
    holocave()
        .args(["worker", "--vlf", "--server", addr, "--scene", scene])
        .env("HOLOCAVE_SECRET", secret)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start a worker")
}

#[test]
fn worker_processes_bake_the_same_light_field_as_threads() {
    let dir = tempfile::tempdir().unwrap();
    let threads = dir.path().join("threads.vlf");
    let status = bake_args(&threads).stdout(Stdio::null()).status().unwrap();
    assert!(status.success());

    // Only worker processes cast lines (--threads 0): two good ones, one with a wrong
    // secret and one with another scene, which must be refused.
    let remote = dir.path().join("remote.vlf");
    let mut bake = bake_args(&remote)
        .args(["--listen", "127.0.0.1:0", "--threads", "0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(bake.stdout.take().unwrap()).lines();
    let addr = loop {
        let line = lines
            .next()
            .expect("the bake says where it listens")
            .unwrap();
        if let Some(a) = line.strip_prefix("accepting bake workers on ") {
            break a.to_owned();
        }
    };
    // The refused ones first, each to its end: the bake cannot finish without a good
    // worker, so they meet a bake that is listening.
    for (name, scene, secret) in [
        ("wrong secret", "scenes/cornell.gltf", "not the secret"),
        ("other scene", "scenes/room.gltf", SECRET),
    ] {
        let out = worker(&addr, scene, secret).wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success(),
            "a worker with the {name} was not refused"
        );
        assert!(
            err.contains("handshake") || err.contains("the bake refused this worker"),
            "{name}: {err}"
        );
    }
    let good = [
        worker(&addr, "scenes/cornell.gltf", SECRET),
        worker(&addr, "scenes/cornell.gltf", SECRET),
    ];
    for l in lines.by_ref() {
        let _ = l;
    }
    assert!(
        bake.wait().unwrap().success(),
        "the bake with workers failed"
    );
    for w in good {
        let out = w.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let a = std::fs::read(&threads).unwrap();
    let b = std::fs::read(&remote).unwrap();
    assert_eq!(a.len(), b.len());
    assert!(a == b, "the light fields differ");
}

/// Ctrl-C ends a bake at once, keeping what it finished, and so does SIGTERM (a session's
/// supervisor, `kill`, systemd stopping a unit): either signal as the room's default bake
/// (half a minute on two cores) starts casting ends the process with status 130 (a bake
/// that ran to its end exits 0) and says what the file keeps; the file is either not
/// written yet or a light field that reads whole (its finished bounces: every save is
/// written aside and renamed). Before, SIGINT let the bake run to its end and exit 0, and
/// SIGTERM killed it without a word.
#[test]
fn ctrl_c_ends_a_bake_at_once_keeping_what_it_finished() {
    for signal in ["-INT", "-TERM"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("room.vlf");
        let mut child = holocave()
            .args(["vlf", "bake", "--scene", "scenes/room.gltf", "--out"])
            .arg(&out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start a bake");
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut line = String::new();
        stdout.read_line(&mut line).unwrap();
        assert!(line.starts_with("baking "), "{line:?}");
        let pid = child.id().to_string();
        let sent = Command::new("kill").args([signal, &pid]).status().unwrap();
        assert!(sent.success(), "kill {signal} {pid}");
        let output = child.wait_with_output().unwrap();
        let said = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(130), "{signal}: {said}");
        assert!(
            said.contains("keeps the bounces it finished"),
            "{signal}: {said}"
        );
        if out.exists() {
            holocave_vlf::VlfFile::read(&out).expect("the kept light field reads whole");
        }
    }
}

/// Ctrl-C during `sim`'s first-run bake of the room's light field ends sim at once with
/// 130, keeping the bounces the bake finished (the light field reads whole, or is not
/// written yet), before any node is started.
#[test]
fn ctrl_c_ends_sims_first_bake_at_once_keeping_what_it_finished() {
    let dir = common::scratch("sim-ctrl-c-bake");
    let out = dir.join("out");
    let mut sim = common::Logged::start(
        holocave()
            .args(["sim", "--config", "configs/cave4-room.toml"])
            .args(["--scene", "scenes/room.gltf", "--no-holodeck"])
            .args(["--tracker", "synthetic:walk", "--scale", "0.05", "--out"])
            .arg(&out),
        &dir,
    );
    sim.wait_for_line("baking the light field");
    let (status, took) = sim.interrupt("INT", false);
    let said = sim.stderr();
    assert_eq!(status.code(), Some(130), "{status} after {took:?}: {said}");
    assert!(said.contains("keeps the bounces it finished"), "{said}");
    assert!(
        !out.join("front").join("node.log").exists(),
        "sim started its nodes"
    );
    let vlf = out.join("room.vlf");
    if vlf.exists() {
        holocave_vlf::VlfFile::read(&vlf).expect("the kept light field reads whole");
    }
}

/// The room set in Chicago: the daylight file's sun light, a CIE clear sky following the
/// sun, which the site and `--when` place.
const SITE_DAYLIGHT: &str = "[site]\nlatitude = 41.98\nlongitude = -87.92\nelevation = 201.0\n\
    time_zone = -6.0\nnorth = [0.0, 0.0, -1.0]\n[sun]\nirradiance = [600.0, 560.0, 500.0]\n\
    [sky]\nmodel = \"cie_clear\"\nzenith_radiance = [12.0, 16.0, 26.0]\n";

/// `vlf view` of `file` (a bake or a bake set) at `when`, into `out`.
fn view_at(file: &Path, daylight: &Path, when: &str, out: &Path) -> std::process::Output {
    holocave()
        .args(["vlf", "view"])
        .arg(file)
        .args(["--scene", "scenes/room.gltf", "--daylight"])
        .arg(daylight)
        .args(["--when", when, "--eye", "0,1.6,0.5"])
        .args([
            "--screen",
            "-1.5,0,-1.5;1.5,0,-1.5;-1.5,3,-1.5",
            "--size",
            "32x32",
        ])
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// `vlf bake --until` bakes a set, one bake every `--step` minutes. A set of two hours draws a time between them from both (a quarter of the later
/// half an hour after the first), a baked time exactly as that bake alone draws it (bit for bit: the blend's
/// weight of the other is 0), and refuses a time outside its bakes, naming them.
#[test]
fn a_bake_set_draws_the_times_between_its_bakes() {
    let dir = tempfile::tempdir().unwrap();
    let daylight = dir.path().join("room.daylight.toml");
    std::fs::write(&daylight, SITE_DAYLIGHT).unwrap();
    let set = dir.path().join("set");
    let o = holocave()
        .args(["vlf", "bake", "--scene", "scenes/room.gltf", "--daylight"])
        .arg(&daylight)
        .args([
            "--when",
            "2026-06-21T14:00",
            "--until",
            "2026-06-21T16:30",
            "--step",
            "120",
        ])
        .args(SETTINGS)
        .arg("--out")
        .arg(&set)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<String> = (std::fs::read_dir(&set).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["2026-06-21T14-00.vlf", "2026-06-21T16-00.vlf"]);
    let o = view_at(
        &set,
        &daylight,
        "2026-06-21T14:30",
        &dir.path().join("mid.exr"),
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("blended, 0.250 of the later"), "{stdout}");
    let (from_set, alone) = (dir.path().join("set14.exr"), dir.path().join("alone14.exr"));
    assert!(
        view_at(&set, &daylight, "2026-06-21T14:00", &from_set)
            .status
            .success()
    );
    let bake = set.join("2026-06-21T14-00.vlf");
    assert!(
        view_at(&bake, &daylight, "2026-06-21T14:00", &alone)
            .status
            .success()
    );
    assert_eq!(
        std::fs::read(&from_set).unwrap(),
        std::fs::read(&alone).unwrap()
    );
    let o = view_at(
        &set,
        &daylight,
        "2026-06-21T17:00",
        &dir.path().join("late.exr"),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("outside") && err.contains("16:00"),
        "{err}"
    );
}
