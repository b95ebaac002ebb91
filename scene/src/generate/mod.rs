//! The project's own scenes (`scenes/` at the repository root), generated in code so
//! that they can be re-made and checked: `holocave scene generate --out scenes`.

mod cornell;
mod gltf_writer;
mod room;
pub mod shapes;

pub use gltf_writer::GltfWriter;

/// Every generated scene: file name and glTF JSON text.
pub fn all() -> Vec<(&'static str, String)> {
    vec![
        ("cornell.gltf", cornell::cornell_box()),
        ("room.gltf", room::room()),
    ]
}

/// Daylight files that go beside the generated scenes.
pub fn daylight_files() -> Vec<(&'static str, &'static str)> {
    vec![("room.daylight.toml", room::DAYLIGHT)]
}
