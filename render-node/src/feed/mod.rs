//! Where a wall's exact samples come from: the chosen pixels' rays traced by the node's
//! own path tracer, as full paths or gathers over the light field, inline or on a thread
//! ([`tracer`]), or asked of a holodeck server as beams ([`holodeck`]).

pub mod holodeck;
pub mod tracer;
