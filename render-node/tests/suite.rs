//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

// `common` and `ray_sets` each include `tests/common/require.rs` by path, as the benches
// that include either of them alone need it.
#![allow(clippy::duplicate_mod)]

mod common;
mod ray_sets;

mod cache;
mod gpu_rays;
mod holodeck_source;
mod moving_objects;
mod moving_viewer;
mod repeatable;
mod still_viewer;
mod threaded;
mod vlf_base;

/// Every test file of this folder is a module above (the binary is declared by hand, so a
/// file left out would never run).
#[test]
fn every_test_file_is_a_module_of_the_suite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if let Some(module) = name.strip_suffix(".rs").filter(|m| *m != "suite") {
            assert!(
                suite.contains(&format!("\nmod {module};\n")),
                "tests/{name} is not a module of tests/suite.rs: its tests would not run"
            );
        }
    }
}
