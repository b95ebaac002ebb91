//! One module per subcommand: argument structs and the calls into the crates.

pub mod cave;
pub mod cave_holodeck;
pub mod compare;
pub mod credentials;
pub mod fill;
pub mod holodeck;
pub mod interrupt;
pub mod master;
pub mod node;
pub mod parse;
pub mod render;
pub mod scene;
pub mod sim;
pub mod tracking;
pub mod vlf;
pub mod window;
pub mod worker;
