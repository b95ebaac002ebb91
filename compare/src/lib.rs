//! Run time against error (DESIGN.md, "How accuracy is judged"): a head trace replayed
//! through one wall, both eyes, on a fixed frame clock, by every display method with the
//! same ray budget per frame and the same cores; every K-th frame each method's image is
//! compared with a converged path-traced reference of exactly that view.
//!
//! - [`method`]: the ways of drawing a wall (path tracing from scratch, accumulation while
//!   the view stays put, the render cache fed by the tracer, the render cache fed by a
//!   holodeck);
//! - [`reference`]: converged references, cached on disk by a hash of scene and view, with
//!   their own noise;
//! - [`report`]: the rows measured, the CSV files, the summary and the plot.
//! - [`run`]: the replay.

pub mod method;
pub mod reference;
pub mod report;
pub mod run;

pub use method::Method;
pub use run::{Compare, CompareError, Settings, VlfSetting};
