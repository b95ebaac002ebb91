//! The cluster handshake: a fixed preamble (magic and protocol version, so that another
//! program or another version is told apart before anything is decoded), then a mutual
//! HMAC-SHA256 challenge–response over a shared secret: neither side sends the secret, and
//! each proves it knows it by signing both sides' fresh nonces.
//!
//! Every cluster port uses it: master ← render nodes, holodeck server ← workers and
//! displays. Below, "node" is the side that connects and "master" the side that accepts.
//!
//! ```text
//! node   → master  preamble, Hello { cluster, role, node nonce }
//! master → node    Challenge { master nonce, master proof }   (or Refused)
//! node   → master  Proof { node proof }                      (node checked the master)
//! master → node    Welcome { .. }                             (or Refused)
//! ```
//!
//! Both sides then derive the link's keys from the secret and both nonces
//! ([`crate::session`]): every later message is sealed with them.

use std::io::{Read, Write};

use hmac::{Hmac, Mac};
use rand::TryRngCore;
use serde::{Deserialize, Serialize};
use sha2::Sha256;

use crate::frame::{FrameError, read_frame, write_frame};
use crate::session::SessionKeys;

/// First bytes of every cluster connection.
pub const MAGIC: [u8; 8] = *b"HOLOCAVE";
/// Version of the cluster messages (this module, [`crate::cluster`] and the sealing of
/// [`crate::session`]: 2 since messages are tagged with keyed BLAKE3, 3 since a frame
/// carries the time of day).
pub const CLUSTER_PROTOCOL_VERSION: u32 = 3;
/// Handshake messages are small; a larger frame is hostile or garbage.
const MAX_HANDSHAKE_FRAME: u32 = 4096;

type HmacSha256 = Hmac<Sha256>;
pub type Nonce = [u8; 32];
pub type Tag = [u8; 32];

/// Who connects.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Eq)]
pub enum Role {
    /// A render node drawing the wall of this name (to the master).
    Node { wall: String },
    /// A holodeck worker tracing rays (to the holodeck server).
    Worker,
    /// A display drawing from the holodeck (to the holodeck server).
    Display,
}

impl std::fmt::Display for Role {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Role::Node { wall } => write!(f, "node for wall {wall:?}"),
            Role::Worker => write!(f, "holodeck worker"),
            Role::Display => write!(f, "holodeck display"),
        }
    }
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
struct Hello {
    cluster: String,
    role: Role,
    nonce: Nonce,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
enum Challenge {
    Challenge { nonce: Nonce, proof: Tag },
    Refused(String),
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
struct Proof {
    proof: Tag,
}

/// What the accepting side tells an accepted peer.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct Welcome {
    /// This connection's number (for logs).
    pub node_id: u64,
    /// The frame rate the master runs at (0 from a holodeck server).
    pub rate_hz: f64,
    /// Where the holodeck server takes displays, if the master runs one.
    pub holodeck: Option<String>,
    /// The baked light field the walls draw under their samples (a path every node
    /// reads), if the master names one.
    pub vlf: Option<String>,
}

/// An authenticated link, as the connecting side sees it after the handshake.
#[derive(Debug)]
pub struct Linked {
    pub welcome: Welcome,
    /// The keys every later message is sealed with.
    pub keys: SessionKeys,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
enum Verdict {
    Welcome(Welcome),
    Refused(String),
}

/// Why a handshake failed.
#[derive(Debug, thiserror::Error)]
pub enum HandshakeError {
    #[error("not a holocave peer: the connection began with {0:02x?} instead of \"HOLOCAVE\"")]
    BadMagic([u8; 8]),
    #[error("peer speaks cluster protocol version {peer}; this program speaks {ours}")]
    Version { peer: u32, ours: u32 },
    #[error("peer belongs to cluster {peer:?}, not {ours:?}")]
    Cluster { peer: String, ours: String },
    #[error("the peer failed authentication (wrong or missing shared secret)")]
    Authentication,
    #[error("refused by the master: {0}")]
    Refused(String),
    #[error("handshake message: {0}")]
    Frame(#[from] FrameError),
}

impl From<std::io::Error> for HandshakeError {
    fn from(e: std::io::Error) -> Self {
        HandshakeError::Frame(FrameError::Io(e))
    }
}

/// A fresh random nonce from the operating system.
fn nonce() -> Nonce {
    let mut n = [0u8; 32];
    rand::rngs::OsRng
        .try_fill_bytes(&mut n)
        .expect("the operating system's random source");
    n
}

/// The tag one side computes: `label` keeps the master's and the node's proofs distinct
/// (so one cannot be replayed as the other).
fn tag(secret: &[u8], label: &str, hello: &Hello, master_nonce: &Nonce) -> HmacSha256 {
    let mut mac = HmacSha256::new_from_slice(secret).expect("HMAC takes keys of any length");
    for part in [
        label.as_bytes(),
        hello.cluster.as_bytes(),
        hello.role.to_string().as_bytes(),
    ] {
        mac.update(&(part.len() as u64).to_le_bytes());
        mac.update(part);
    }
    mac.update(&hello.nonce);
    mac.update(master_nonce);
    mac
}

fn read_preamble<R: Read>(r: &mut R) -> Result<(), HandshakeError> {
    let mut pre = [0u8; 12];
    r.read_exact(&mut pre)?;
    let magic: [u8; 8] = pre[..8].try_into().expect("8 bytes");
    if magic != MAGIC {
        return Err(HandshakeError::BadMagic(magic));
    }
    let peer = u32::from_le_bytes(pre[8..].try_into().expect("4 bytes"));
    if peer != CLUSTER_PROTOCOL_VERSION {
        return Err(HandshakeError::Version {
            peer,
            ours: CLUSTER_PROTOCOL_VERSION,
        });
    }
    Ok(())
}

fn write_preamble<W: Write>(w: &mut W) -> Result<(), HandshakeError> {
    let mut pre = [0u8; 12];
    pre[..8].copy_from_slice(&MAGIC);
    pre[8..].copy_from_slice(&CLUSTER_PROTOCOL_VERSION.to_le_bytes());
    w.write_all(&pre)?;
    Ok(())
}

/// The link's shared session secret: only holders of `secret` who saw both nonces know it.
fn session_keys(secret: &[u8], hello: &Hello, master_nonce: &Nonce) -> SessionKeys {
    SessionKeys::derive(
        &tag(secret, "session", hello, master_nonce)
            .finalize()
            .into_bytes(),
    )
}

/// The connecting side: proves the secret, checks the master's proof, returns the welcome
/// and the link's keys.
pub fn connect<S: Read + Write>(
    stream: &mut S,
    cluster: &str,
    role: Role,
    secret: &[u8],
) -> Result<Linked, HandshakeError> {
    write_preamble(stream)?;
    let hello = Hello {
        cluster: cluster.to_owned(),
        role,
        nonce: nonce(),
    };
    write_frame(stream, &hello, MAX_HANDSHAKE_FRAME)?;
    read_preamble(stream)?;
    let (master_nonce, master_ok) = match read_frame(stream, MAX_HANDSHAKE_FRAME)? {
        Challenge::Challenge { nonce, proof } => (
            nonce,
            tag(secret, "master", &hello, &nonce)
                .verify_slice(&proof)
                .is_ok(),
        ),
        Challenge::Refused(why) => return Err(HandshakeError::Refused(why)),
    };
    // The proof goes out even when the master's failed, so that the master too sees (and
    // logs) the mismatch instead of a dropped connection.
    let proof = tag(secret, "node", &hello, &master_nonce)
        .finalize()
        .into_bytes()
        .into();
    write_frame(stream, &Proof { proof }, MAX_HANDSHAKE_FRAME)?;
    if !master_ok {
        return Err(HandshakeError::Authentication);
    }
    match read_frame(stream, MAX_HANDSHAKE_FRAME)? {
        Verdict::Welcome(welcome) => Ok(Linked {
            welcome,
            keys: session_keys(secret, &hello, &master_nonce),
        }),
        Verdict::Refused(why) => Err(HandshakeError::Refused(why)),
    }
}

/// The master's side, first half: reads and checks the hello, proves the secret, checks
/// the node's proof. On success the caller decides (by the role) and calls
/// [`Accepted::welcome`] or [`Accepted::refuse`].
pub fn accept<S: Read + Write>(
    stream: &mut S,
    cluster: &str,
    secret: &[u8],
) -> Result<Accepted, HandshakeError> {
    read_preamble(stream)?;
    write_preamble(stream)?;
    let hello: Hello = read_frame(stream, MAX_HANDSHAKE_FRAME)?;
    if hello.cluster != cluster {
        let e = HandshakeError::Cluster {
            peer: hello.cluster.clone(),
            ours: cluster.to_owned(),
        };
        write_frame(
            stream,
            &Challenge::Refused(e.to_string()),
            MAX_HANDSHAKE_FRAME,
        )?;
        return Err(e);
    }
    let master_nonce = nonce();
    let proof = tag(secret, "master", &hello, &master_nonce)
        .finalize()
        .into_bytes()
        .into();
    write_frame(
        stream,
        &Challenge::Challenge {
            nonce: master_nonce,
            proof,
        },
        MAX_HANDSHAKE_FRAME,
    )?;
    let answer: Proof = read_frame(stream, MAX_HANDSHAKE_FRAME)?;
    if tag(secret, "node", &hello, &master_nonce)
        .verify_slice(&answer.proof)
        .is_err()
    {
        let why = "authentication failed (wrong or missing shared secret)".to_owned();
        write_frame(stream, &Verdict::Refused(why), MAX_HANDSHAKE_FRAME)?;
        return Err(HandshakeError::Authentication);
    }
    Ok(Accepted {
        keys: session_keys(secret, &hello, &master_nonce),
        role: hello.role,
    })
}

/// A peer that proved the secret.
#[derive(Debug)]
pub struct Accepted {
    pub role: Role,
    /// The keys every later message is sealed with.
    pub keys: SessionKeys,
}

impl Accepted {
    /// Welcomes the peer; the link's keys.
    pub fn welcome<W: Write>(
        self,
        stream: &mut W,
        welcome: Welcome,
    ) -> Result<SessionKeys, FrameError> {
        write_frame(stream, &Verdict::Welcome(welcome), MAX_HANDSHAKE_FRAME)?;
        Ok(self.keys)
    }

    pub fn refuse<W: Write>(self, stream: &mut W, why: &str) -> Result<(), FrameError> {
        write_frame(
            stream,
            &Verdict::Refused(why.to_owned()),
            MAX_HANDSHAKE_FRAME,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::{TcpListener, TcpStream};

    fn welcome() -> Welcome {
        Welcome {
            node_id: 7,
            rate_hz: 60.0,
            holodeck: None,
            vlf: None,
        }
    }

    /// Runs a master accepting one connection with `master_secret`, and a node with
    /// `node_secret`; returns both sides' results.
    fn pair(
        master_secret: &'static [u8],
        node_secret: &'static [u8],
        node_cluster: &str,
    ) -> (
        Result<(Role, SessionKeys), String>,
        Result<Linked, HandshakeError>,
    ) {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = l.local_addr().unwrap();
        let master = std::thread::spawn(move || {
            let (mut s, _) = l.accept().unwrap();
            match accept(&mut s, "cave", master_secret) {
                Ok(a) => {
                    let role = a.role.clone();
                    let keys = a.welcome(&mut s, welcome()).map_err(|e| e.to_string())?;
                    Ok((role, keys))
                }
                Err(e) => Err(e.to_string()),
            }
        });
        let node = connect(
            &mut TcpStream::connect(addr).unwrap(),
            node_cluster,
            Role::Node {
                wall: "front".into(),
            },
            node_secret,
        );
        (master.join().unwrap(), node)
    }

    #[test]
    fn the_right_secret_is_welcomed_both_ways() {
        let (m, n) = pair(b"s3cret", b"s3cret", "cave");
        let (role, master_keys) = m.unwrap();
        assert_eq!(
            role,
            Role::Node {
                wall: "front".into()
            }
        );
        let linked = n.unwrap();
        assert_eq!(linked.welcome, welcome());
        // Both sides derived the same link keys: what one seals the other opens.
        let (mut node_send, mut node_recv) = linked.keys.connector();
        let (mut master_send, mut master_recv) = master_keys.acceptor();
        let up = node_send.seal(&"ready", 64).unwrap();
        assert_eq!(master_recv.open::<String>(&up[4..]).unwrap(), "ready");
        let down = master_send.seal(&"swap", 64).unwrap();
        assert_eq!(node_recv.open::<String>(&down[4..]).unwrap(), "swap");
    }

    #[test]
    fn every_link_has_its_own_keys() {
        let (m1, _) = pair(b"s3cret", b"s3cret", "cave");
        let (_, n2) = pair(b"s3cret", b"s3cret", "cave");
        let (mut send, _) = n2.unwrap().keys.connector();
        let (_, mut recv) = m1.unwrap().1.acceptor();
        let msg = send.seal(&1u8, 64).unwrap();
        assert!(
            recv.open::<u8>(&msg[4..]).is_err(),
            "a message of another link"
        );
    }

    #[test]
    fn a_wrong_secret_is_refused_and_the_node_is_told() {
        let (m, n) = pair(b"s3cret", b"guess", "cave");
        assert!(m.unwrap_err().contains("authentication"));
        assert!(matches!(n, Err(HandshakeError::Authentication)), "{n:?}");
    }

    #[test]
    fn an_empty_secret_does_not_match_a_real_one() {
        let (m, n) = pair(b"s3cret", b"", "cave");
        assert!(m.is_err());
        assert!(n.is_err());
    }

    #[test]
    fn another_cluster_is_refused_with_its_name() {
        let (m, n) = pair(b"s", b"s", "other");
        assert!(m.unwrap_err().contains("\"other\""));
        assert!(
            matches!(&n, Err(HandshakeError::Refused(w)) if w.contains("other")),
            "{n:?}"
        );
    }

    #[test]
    fn garbage_and_other_versions_are_named() {
        let mut garbage: &[u8] = b"GET / HTTP/1.1\r\n\r\n";
        let mut sink = Vec::new();
        let mut s = ReadWrite(&mut garbage, &mut sink);
        let e = accept(&mut s, "cave", b"s").unwrap_err();
        assert!(e.to_string().contains("not a holocave peer"), "{e}");

        let mut v9 = Vec::from(MAGIC);
        v9.extend(9u32.to_le_bytes());
        let mut r: &[u8] = &v9;
        let mut sink = Vec::new();
        let e = accept(&mut ReadWrite(&mut r, &mut sink), "cave", b"s").unwrap_err();
        assert!(matches!(e, HandshakeError::Version { peer: 9, .. }), "{e}");

        let mut short: &[u8] = b"HOLO";
        let mut sink = Vec::new();
        assert!(accept(&mut ReadWrite(&mut short, &mut sink), "cave", b"s").is_err());
    }

    /// A stream made of a reader and a writer.
    struct ReadWrite<'a>(&'a mut &'a [u8], &'a mut Vec<u8>);
    impl Read for ReadWrite<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            self.0.read(buf)
        }
    }
    impl Write for ReadWrite<'_> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.1.write(buf)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
}
