//! Crash safety (issue 3, "done when" 2): a child process fills a holodeck file and is
//! SIGKILLed at random moments, at least 50 times, each child continuing the file the last
//! one left. After every kill the file must open cleanly and hold every beam the child had
//! reported as committed (no lost samples), and every stored sample must be exactly the one
//! the writer wrote at that position (nothing invented).

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use glam::DVec3;
use holocave_holodeck::file::check::check;
use holocave_holodeck::sample::PackedSample;
use holocave_holodeck::{HoloFile, Section, ViewClass};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

#[path = "../src/file/crash_pattern.rs"]
mod crash_pattern;
use crash_pattern::expected;

#[test]
fn sigkill_at_random_moments_loses_nothing_flushed() {
    const KILLS: usize = 60;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("crash.hdk");
    let s = Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
    HoloFile::create(&path, vec![s], Default::default()).unwrap();
    let mut rng = SmallRng::seed_from_u64(3);
    let mut reported: HashMap<u32, u32> = HashMap::new();
    let (mut unreadable, mut lost, mut invented) = (0, 0, 0);
    let mut commits_seen = 0;
    for kill in 0..KILLS {
        let mut child = Command::new(env!("CARGO_BIN_EXE_holodeck-crash-writer"))
            .arg(&path)
            .arg(kill.to_string())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let reader = std::thread::spawn(move || {
            let mut r = BufReader::new(stdout);
            let mut line = String::new();
            // Only complete lines count as reported.
            while r.read_line(&mut line).unwrap_or(0) > 0 {
                if !line.ends_with('\n') || tx.send(std::mem::take(&mut line)).is_err() {
                    break;
                }
            }
        });
        // The random moment of the kill: every other child anywhere in its start-up or its
        // writing; the others after their first commit, so that half the kills land while
        // writing however long a start-up takes on this machine.
        let mut lines = Vec::new();
        if kill % 2 == 1 {
            let first = rx
                .recv_timeout(Duration::from_secs(120))
                .expect("the writer reports a first commit");
            lines.push(first);
        }
        std::thread::sleep(Duration::from_micros(rng.random_range(500..40_000)));
        child.kill().unwrap(); // SIGKILL on Unix
        child.wait().unwrap();
        reader.join().unwrap();
        lines.extend(rx.try_iter());
        let mut last_seq = 0;
        for l in &lines {
            let mut parts = l.split_whitespace();
            assert_eq!(parts.next(), Some("C"), "{l}");
            last_seq = parts.next().unwrap().parse::<u64>().unwrap();
            for bc in parts {
                let (b, c) = bc.split_once(':').unwrap();
                reported.insert(b.parse().unwrap(), c.parse().unwrap());
            }
        }
        commits_seen += lines.len();
        let h = match HoloFile::open(&path) {
            Ok(h) => h,
            Err(e) => {
                eprintln!("kill {kill}: unreadable: {e}");
                unreadable += 1;
                continue;
            }
        };
        assert!(
            h.seq() >= last_seq,
            "kill {kill}: commit {last_seq} was reported, the file is at {}",
            h.seq()
        );
        for beam in 0..h.sections()[0].beam_count() {
            let mut got = Vec::new();
            if let Err(e) = h.read_beam(0, beam, &mut got) {
                eprintln!("kill {kill}: beam {beam}: {e}");
                unreadable += 1;
                continue;
            }
            let want = reported.get(&beam).copied().unwrap_or(0) as usize;
            if got.len() < want {
                eprintln!(
                    "kill {kill}: beam {beam} has {} samples, {want} were reported flushed",
                    got.len()
                );
                lost += 1;
            }
            for (i, s) in got.iter().enumerate() {
                if *s != expected(beam, i as u32) {
                    invented += 1;
                }
            }
        }
        assert!(
            check(&path).unwrap().is_clean(),
            "kill {kill}: check found damage"
        );
    }
    eprintln!(
        "{KILLS} SIGKILLs, {commits_seen} reported commits: {unreadable} unreadable, {lost} lost flushed beams, {invented} invented samples"
    );
    assert_eq!((unreadable, lost, invented), (0, 0, 0));
}
