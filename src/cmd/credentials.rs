//! The cluster's credentials on the command line: every port (master, holodeck server)
//! asks its peers to prove the cluster's shared secret. It comes from `HOLOCAVE_SECRET`
//! or the config's `[cluster] secret`; a run that starts its own peers (`sim`, `fill`)
//! makes a fresh one and hands it to them through their environment.

use anyhow::{Result, anyhow};
use holocave_cave::Cave;
use holocave_holodeck::auth::Credentials;
use rand::TryRngCore;

pub use holocave::launch::SECRET_VAR;
/// The cluster name of a peer given no config (the config's default `[cluster] id`).
pub const DEFAULT_CLUSTER: &str = "holocave";

/// The credentials of `cave`'s cluster (`config` names the file in errors).
pub fn of_cave(cave: &Cave, config: &std::path::Path) -> Result<Credentials> {
    let secret = cave
        .secret()
        .map_err(|e| anyhow!("{}: {e}", config.display()))?;
    Ok(Credentials {
        cluster: cave.cluster.id.clone(),
        secret,
    })
}

/// The credentials of cluster `cluster` with the secret from [`SECRET_VAR`].
pub fn from_env(cluster: &str) -> Result<Credentials> {
    match std::env::var(SECRET_VAR) {
        Ok(s) if !s.is_empty() => Ok(Credentials {
            cluster: cluster.to_owned(),
            secret: s.into_bytes(),
        }),
        _ => Err(anyhow!(
            "{SECRET_VAR} is not set: holodeck servers only take workers and displays that \
             prove the cluster's shared secret"
        )),
    }
}

/// Fresh credentials for a run that starts its own peers: [`SECRET_VAR`] if set, else a
/// random secret (as hex, so it can travel in an environment variable).
pub fn fresh(cluster: &str) -> Result<Credentials> {
    if let Ok(c) = from_env(cluster) {
        return Ok(c);
    }
    let mut key = [0u8; 16];
    rand::rngs::OsRng
        .try_fill_bytes(&mut key)
        .map_err(|e| anyhow!("reading the operating system's random source: {e}"))?;
    Ok(Credentials {
        cluster: cluster.to_owned(),
        secret: key
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
            .into_bytes(),
    })
}
