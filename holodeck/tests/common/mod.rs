//! What the holodeck's integration tests share: an analytic sample source, the cluster
//! credentials their peers prove, and a server's run options.
#![allow(dead_code)]

use std::net::TcpListener;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use holocave_holodeck::auth::{Credentials, Port};
use holocave_holodeck::run::RunOptions;
use holocave_holodeck::worker::{DistanceKind, SampleSource, SourceRay, SourceResult};

/// Radiance from the direction; everything at first-hit distance 2 and virtual distance 3.
pub struct Analytic;

impl SampleSource for Analytic {
    fn trace(&self, rays: &[SourceRay], _seed: u64, distance: DistanceKind) -> Vec<SourceResult> {
        let d = match distance {
            DistanceKind::FirstHit => 2.0,
            DistanceKind::Virtual => 3.0,
        };
        rays.iter()
            .map(|r| SourceResult {
                radiance: r.dir.abs().to_array(),
                distance: d,
            })
            .collect()
    }
}

/// The secret the tests' servers ask for.
pub const SECRET: &[u8] = b"holodeck-test-secret";

/// The credentials of the tests' cluster with `secret`.
pub fn credentials_with(secret: &[u8]) -> Credentials {
    Credentials {
        cluster: "test".into(),
        secret: secret.to_vec(),
    }
}

/// The credentials every honest peer of these tests proves.
pub fn credentials() -> Credentials {
    credentials_with(SECRET)
}

/// A run of `threads` analytic tracer threads, taking TCP peers on `listener` (if any),
/// committing every `commit_every`.
pub fn options(
    threads: usize,
    listener: Option<TcpListener>,
    commit_every: Duration,
) -> RunOptions {
    RunOptions {
        threads,
        source: Some(Arc::new(Analytic)),
        listener: listener.map(|listener| Port {
            listener,
            credentials: credentials(),
        }),
        scene: "analytic".into(),
        commit_every,
        stop: Arc::new(AtomicBool::new(false)),
    }
}
