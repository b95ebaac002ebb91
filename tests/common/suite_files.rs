//! The guard of a crate whose `tests/` folder is one binary (`tests/suite.rs`, declared by
//! hand with `autotests = false`): every file of the folder must be a module of the suite,
//! or its tests would never run. Each suite includes this file by path.

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
