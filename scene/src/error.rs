//! Errors of scene loading. Every variant names the input it is about.

use std::path::PathBuf;

/// What went wrong while loading or building a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read file: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a valid glTF file: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: invalid glTF: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("{path}: required extension {extension} is not supported (strict loading)")]
    UnsupportedExtension { path: PathBuf, extension: String },
    #[error("{path}: buffer {buffer}: {message}")]
    Buffer {
        path: PathBuf,
        buffer: usize,
        message: String,
    },
    #[error("{path}: mesh {mesh:?} primitive {primitive}: {message}")]
    Geometry {
        path: PathBuf,
        mesh: String,
        primitive: usize,
        message: String,
    },
    #[error("{path}: the scene has no triangles")]
    Empty { path: PathBuf },
    #[error("{path}: movable objects: {message}")]
    Objects { path: PathBuf, message: String },
    #[error("{path}: daylight: {message}")]
    Daylight { path: PathBuf, message: String },
}
