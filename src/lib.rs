//! What the `holocave` binary shares with its end-to-end tests: launching and watching the
//! `holocave` processes a command starts ([`launch`]), and starting them again when they
//! die ([`supervise`]). The roles themselves are built by their crates; the command line
//! is in `main.rs` and `cmd/`.

pub mod launch;
pub mod supervise;

#[cfg(test)]
mod doc_links;
