//! One module per subcommand: argument structs and the calls into the crates.

pub mod cave;
pub mod compare;
pub mod credentials;
pub mod daylight;
pub mod daylight_flags;
pub mod drawing_flags;
pub mod fill;
pub mod glare;
pub mod glare_annual;
pub mod holodeck;
pub mod interrupt;
pub mod master;
pub mod node;
pub mod parse;
pub mod render;
pub mod scene;
pub mod sim;
pub mod supervise;
pub mod tone;
pub mod tracking;
pub mod view;
pub mod vlf;
pub mod window;
pub mod worker;

/// `DIR/<scene's stem>.<ext>`: where a command keeps a scene's holodeck or light field
/// unless told.
pub fn kept_beside(
    out: &std::path::Path,
    scene: &std::path::Path,
    ext: &str,
) -> std::path::PathBuf {
    let stem = scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    out.join(format!("{stem}.{ext}"))
}
