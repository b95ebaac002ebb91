//! Glare figures of what a viewer sees, as Radiance's `evalglare` computes them: a 180°
//! angular fisheye of the view ([`fisheye`]), drawn as the walls draw it or path-traced
//! ([`draw`]), its luminance in cd/m² by the scene's photometry ([`luminance`]), and from
//! it the vertical eye illuminance Ev, the daylight glare probability DGP, the unified
//! glare rating UGR and the glare sources ([`figures`], [`sources`], [`position_index`],
//! by the [`rules`]). [`meter`] measures a moving head frame after frame, [`log`] writes
//! the figures per frame and a session's summary, [`session`] does both for a recorded
//! session and [`live`] while one runs, [`annual`] a seat over a year's weather; [`picture`] draws the fisheye for a person to look at, the sources outlined. Usage and the limits of validity:
//! `docs/usage/glare.md`.

pub mod annual;
pub mod draw;
pub mod error;
pub mod figures;
pub mod fisheye;
pub mod live;
pub mod log;
pub mod luminance;
pub mod meter;
pub mod picture;
pub mod position_index;
pub mod rules;
pub mod session;
pub mod sources;

pub use error::GlareError;
pub use figures::{Figures, evaluate};
pub use fisheye::Fisheye;
pub use luminance::LuminanceMap;
pub use rules::{Rules, Threshold};
pub use sources::Source;
