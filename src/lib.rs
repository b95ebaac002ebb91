//! What the `holocave` binary shares with its end-to-end tests: launching and watching the
//! `holocave` processes a command starts ([`launch`]), and starting them again when they
//! die ([`supervise`]), and `sim`'s whole cluster of them on one machine ([`sim`]). The roles themselves are built by their crates; the command line
//! is in `main.rs` and `cmd/`.

pub mod launch;
pub mod sim;
pub mod supervise;

#[cfg(test)]
mod doc_links;
