//! Ctrl-C and SIGTERM mid-phase of the long commands that have no end-to-end test file of
//! their own: `fill`, `render` and `compare`. Each is sent the signal once its phase has
//! begun (a line it logs says so) and must end within `common::INTERRUPT_LIMIT` with status 130,
//! saying what it keeps; what it keeps must read whole.

mod common;

use common::{Logged, holocave, scratch};

/// A fill of the Cornell box (tracer threads, a commit every 0.2 s, no time limit) stopped
/// by SIGINT and by SIGTERM once it has committed: it commits what was traced, says so,
/// exits 130, and its holodeck checks clean; the second fill goes on from the first's
/// samples.
#[test]
fn ctrl_c_ends_a_fill_committing_its_samples() {
    let dir = scratch("ctrl-c-fill");
    let hdk = dir.join("cornell.hdk");
    for signal in ["INT", "TERM"] {
        let mut fill = Logged::start(
            holocave()
                .args(["fill", "--scene", "scenes/cornell.gltf", "--holodeck"])
                .arg(&hdk)
                .args(["--threads", "2", "--commit-every", "0.2"])
                .env("RUST_LOG", "info"),
            &dir,
        );
        fill.wait_for_line("samples durable");
        let (status, took) = fill.interrupt(signal, false);
        let said = fill.stderr();
        assert_eq!(
            status.code(),
            Some(130),
            "SIG{signal}: {status} after {took:?}: {said}"
        );
        assert!(
            said.contains("keeps its") && said.contains("samples (committed)"),
            "SIG{signal}: {said}"
        );
        common::assert_holodeck_clean(&hdk);
    }
}

/// A render of the Cornell box at many paths per pixel, stopped by SIGINT as it renders:
/// it ends at once with 130, says it wrote nothing, and leaves no half-written image.
#[test]
fn ctrl_c_ends_a_render_at_once() {
    let dir = scratch("ctrl-c-render");
    let out = dir.join("front.exr");
    let mut render = Logged::start(
        holocave()
            .args(["render", "--scene", "scenes/cornell.gltf"])
            .args(["--eye", "0,1,3.4", "--screen", "-1,0,1.2;1,0,1.2;-1,2,1.2"])
            .args(["--size", "256x256", "--spp", "100000", "--out"])
            .arg(&out)
            .env("RUST_LOG", "info"),
        &dir,
    );
    render.wait_for_line("Ctrl-C ends it");
    let (status, took) = render.interrupt("INT", false);
    let said = render.stderr();
    assert_eq!(status.code(), Some(130), "{status} after {took:?}: {said}");
    assert!(said.contains("interrupted: nothing written"), "{said}");
    assert!(!out.exists(), "a half-written {}", out.display());
}

/// A comparison (path tracing and accumulation on the Cornell box's front wall) stopped by
/// SIGTERM as it starts: it ends at once with 130 and says what it keeps (the references
/// rendered so far, each written whole or rendered again).
#[test]
fn sigterm_ends_a_comparison_at_once() {
    let dir = scratch("ctrl-c-compare");
    let out = dir.join("out");
    let mut compare = Logged::start(
        holocave()
            .args(["compare", "--scene", "scenes/cornell.gltf"])
            .args(["--config", "configs/cave4-cornell.toml", "--wall", "front"])
            .args(["--tracker", "synthetic:walk", "--seconds", "100"])
            .args(["--methods", "trace,accumulate", "--reference-spp", "100000"])
            .args(["--size", "64x64", "--out"])
            .arg(&out),
        &dir,
    );
    compare.wait_for_line("comparing trace, accumulate");
    let (status, took) = compare.interrupt("TERM", false);
    let said = compare.stderr();
    assert_eq!(status.code(), Some(130), "{status} after {took:?}: {said}");
    assert!(
        said.contains("keeps the converged references rendered so far"),
        "{said}"
    );
}

/// A master waiting for its walls' nodes (none comes) stopped by SIGINT: it ends within
/// the limit with 130 instead of waiting out `--wait-for-walls`.
#[test]
fn ctrl_c_ends_a_master_waiting_for_its_walls() {
    let dir = scratch("ctrl-c-master");
    let mut master = Logged::start(
        holocave()
            .args(["master", "--config", "configs/cave4-cornell.toml"])
            .args(["--listen", "127.0.0.1:0", "--wait-for-walls", "600"])
            .env("HOLOCAVE_SECRET", "ctrl-c-test"),
        &dir,
    );
    let limit = std::time::Duration::from_secs(60);
    master.wait_until(limit, "the master listening", |m| {
        m.stdout().contains("master listening on")
    });
    let (status, took) = master.interrupt("INT", false);
    let said = master.stderr();
    assert_eq!(status.code(), Some(130), "{status} after {took:?}: {said}");
    assert!(said.contains("interrupted: "), "{said}");
}
