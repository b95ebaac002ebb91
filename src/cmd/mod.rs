//! One module per subcommand: argument structs and the calls into the crates.

pub mod cave;
pub mod fill;
pub mod holodeck;
pub mod node;
pub mod render;
pub mod scene;
pub mod tracking;
pub mod worker;
