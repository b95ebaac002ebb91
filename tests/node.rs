//! `holocave node --standalone --headless` end to end: a few stereo frames of the Cornell
//! box through the front wall, written where the issue says.

use std::process::Command;

#[test]
fn standalone_headless_node_writes_both_eyes_per_frame() {
    let dir = std::env::temp_dir().join(format!("holocave-node-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let root = env!("CARGO_MANIFEST_DIR");
    let out = Command::new(env!("CARGO_BIN_EXE_holocave"))
        .current_dir(root)
        .args([
            "node",
            "--standalone",
            "--config",
            "configs/cave4-cornell.toml",
            "--wall",
            "front",
            "--scene",
            "scenes/cornell.gltf",
            "--tracker",
            "synthetic:walk",
            "--headless",
            "--sync",
            "--frames",
            "3",
            "--size",
            "32x24",
            "--debug-images",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("run holocave node");
    assert!(
        out.status.success(),
        "holocave node failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    for frame in 0..3 {
        for eye in ["left", "right"] {
            for ext in ["exr", "png"] {
                let f = dir.join(format!("front/{frame:05}-{eye}.{ext}"));
                assert!(f.exists(), "{} missing", f.display());
            }
            assert!(
                dir.join(format!("front/{frame:05}-{eye}-priority.png"))
                    .exists()
            );
            assert!(
                dir.join(format!("front/{frame:05}-{eye}-chosen.png"))
                    .exists()
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
