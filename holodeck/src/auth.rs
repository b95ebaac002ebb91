//! Who may use a holodeck server's port: every worker and display proves the cluster's
//! shared secret in the cluster handshake (`holocave_protocol::handshake`, mutual
//! HMAC-SHA256), and every message after it is sealed with the link's keys
//! (`holocave_protocol::session`: a keyed BLAKE3 tag). Without the secret nobody on the
//! network can add samples to a persistent holodeck or read it; with a stolen connection
//! nobody can inject or replay a message.

use std::net::TcpStream;
use std::time::Duration;

use holocave_protocol::handshake::{self, HandshakeError, Role, Welcome};
use holocave_protocol::session::{Opener, Sealer};

/// How long a peer has for the whole handshake.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(2);

/// The cluster's name and shared secret.
#[derive(Clone)]
pub struct Credentials {
    pub cluster: String,
    pub secret: Vec<u8>,
}

impl std::fmt::Debug for Credentials {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Credentials {{ cluster: {:?}, secret: .. }}",
            self.cluster
        )
    }
}

/// A TCP port of a holodeck server and the credentials its peers must prove.
pub struct Port {
    pub listener: std::net::TcpListener,
    pub credentials: Credentials,
}

/// The connecting side (a worker or a display): the handshake as `role`; the link's
/// sealer and opener.
pub fn connect(
    stream: &mut TcpStream,
    credentials: &Credentials,
    role: Role,
) -> Result<(Sealer, Opener), HandshakeError> {
    let timeouts = stream.read_timeout().ok().flatten();
    stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT))?;
    let linked = handshake::connect(stream, &credentials.cluster, role, &credentials.secret)?;
    stream.set_read_timeout(timeouts)?;
    Ok(linked.keys.connector())
}

/// The server's side on a blocking stream: the handshake, refusing any role but a worker
/// or a display; the role and the link's sealer and opener.
pub(crate) fn accept(
    stream: &mut TcpStream,
    credentials: &Credentials,
    id: u64,
) -> Result<(Role, Sealer, Opener), String> {
    stream
        .set_read_timeout(Some(HANDSHAKE_TIMEOUT))
        .and_then(|()| stream.set_write_timeout(Some(HANDSHAKE_TIMEOUT)))
        .map_err(|e| e.to_string())?;
    let accepted = handshake::accept(stream, &credentials.cluster, &credentials.secret)
        .map_err(|e| e.to_string())?;
    let role = accepted.role.clone();
    if !matches!(role, Role::Worker | Role::Display) {
        let why = format!("a {role} connected to a holodeck server (workers and displays only)");
        let _ = accepted.refuse(stream, &why);
        return Err(why);
    }
    let welcome = Welcome {
        node_id: id,
        ..Welcome::default()
    };
    let keys = accepted
        .welcome(stream, welcome)
        .map_err(|e| e.to_string())?;
    stream
        .set_read_timeout(None)
        .and_then(|()| stream.set_write_timeout(None))
        .map_err(|e| e.to_string())?;
    let (sealer, opener) = keys.acceptor();
    Ok((role, sealer, opener))
}
