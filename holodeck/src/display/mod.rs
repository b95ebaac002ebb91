//! The display service (paper §2.4.2): displays tell the server which beams they want and
//! where their eyes are; the server answers at once with the stored samples of the beams
//! they asked for, then sends new samples as workers return them — each sample to each
//! display once.
//!
//! - [`hub`]: the subscribed displays and the rule that each sample is sent once (what
//!   each display has of each beam), over what the [`Server`](crate::server::Server)
//!   offers: the merged requests and the stored samples of a beam from an index on.
//! - [`client`]: [`DisplayClient`], a display's link to the server, the same in the
//!   server's process ([`crate::run::Running::display`]) and over TCP.
//! - [`wire`]: requests, sections and sample batches as the protocol carries them.

pub mod client;
pub mod hub;
pub mod wire;

use std::sync::Arc;

pub use client::{DisplayClient, DisplayError};
pub use hub::{DisplayTally, Hub};

use crate::beam_index::BeamKey;
use crate::proximity::EyeSphere;
use crate::server::BeamSamples;

/// EyeSphere slots per display (requests of slot `k` of display `d` are the server's display
/// `d * SLOTS + k`).
pub const SLOTS: u32 = 4;

/// One eye's wanted beams (replacing that eye's previous request).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EyeRequest {
    /// Which eye of the display (`0..SLOTS`).
    pub slot: u8,
    /// Where new rays should pass (Appendix A); `None`: anywhere in the beam.
    pub eye: Option<EyeSphere>,
    /// Beams and how many samples each should have in all.
    pub wanted: Vec<(BeamKey, f64)>,
}

/// Samples that arrived for a display, as the server grouped them.
pub type Arrival = Arc<Vec<BeamSamples>>;
