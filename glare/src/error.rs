//! What can be wrong with a glare evaluation's input: each error names the input and the
//! problem.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum GlareError {
    /// The fisheye has no pixels.
    #[error("the fisheye is {size} × {size} pixels: it needs at least one")]
    EmptyImage { size: u32 },
    /// An image of another size than its fisheye view.
    #[error("the image is {width} × {height} pixels, its fisheye view {size} × {size}")]
    SizeMismatch { width: u32, height: u32, size: u32 },
    /// Luminance values of another count than the fisheye's pixels.
    #[error("{count} luminance values for a {size} × {size} fisheye")]
    WrongCount { count: usize, size: u32 },
    /// A pixel whose value cannot be a luminance.
    #[error(
        "pixel ({x}, {y}) of the fisheye is {value}: luminance must be finite and non-negative"
    )]
    BadPixel { x: u32, y: u32, value: String },
    /// A view that gives no direction: a look or up vector that is zero, not finite, or
    /// up along look.
    #[error("the fisheye view: {0}")]
    BadView(String),
    /// Evaluation rules out of their range.
    #[error("glare rules: {0}")]
    BadRules(String),
    /// Writing a file (picture, log).
    #[error("writing {path}: {message}")]
    Write { path: PathBuf, message: String },
    /// The light field a session's fisheyes are drawn from.
    #[error("the light field {path}: {message}")]
    LightField { path: PathBuf, message: String },
    /// The master's log of frame states a session's views are read from.
    #[error("the frame states {path}: {message}")]
    StatesLog { path: PathBuf, message: String },
}
