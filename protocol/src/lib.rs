//! Wire messages of holocave (DESIGN.md, "Wire format"): serde + bincode 2.0.1 inside
//! length-prefixed frames whose size is checked against a hard maximum before any
//! allocation. Bulk data travels as packed fixed-size little-endian records.
//!
//! - [`frame`]: framing, sync and async, with its errors.
//! - [`handshake`]: the cluster's preamble and mutual HMAC authentication, on every port;
//! - [`session`]: the messages after it, sealed (a keyed BLAKE3 tag per message,
//!   numbered: no injection, no replay).
//! - [`cluster`]: master ↔ render node messages (frame state, ready, swap).
//! - [`holodeck`]: holodeck server ↔ worker messages (hello, ray packets, sample packets).
//! - [`stats`]: the one quantile the cluster's figures (p50, p99) are quoted with.

pub mod cluster;
pub mod frame;
pub mod handshake;
pub mod holodeck;
pub mod session;
pub mod stats;

pub use frame::{FrameError, MAX_FRAME_BYTES};
