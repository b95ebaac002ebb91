//! VRPN's wire format, byte for byte (VRPN 07.x, TCP): the version cookie, message
//! framing, sender and message-type descriptions, and `vrpn_Tracker Pos_Quat` reports.
//!
//! A connection starts with each side sending a 24-byte cookie: `vrpn: ver. 07.38`, two
//! spaces, a log-mode digit, NUL padding. Then messages follow, each a 24-byte big-endian
//! header (total length = header + payload, seconds, microseconds, sender id, message-type
//! id, sequence number) and the payload padded with zeros to a multiple of 8. Sender and
//! type ids are each side's own: a side announces them with sender descriptions (type
//! −1) and type descriptions (type −2), whose header sender field holds the id being
//! described and whose payload is a big-endian `u32` length followed by the NUL-terminated
//! name. A tracker report (`vrpn_Tracker Pos_Quat`) carries the sensor number twice (the
//! second copy pads to 8 bytes), then position x, y, z and quaternion x, y, z, w as
//! big-endian `f64`.

use std::collections::HashMap;

use glam::{Quat, Vec3};

use crate::pose::{Pose, Sample};

/// The version this implementation announces (the one the captured server runs).
pub const MAGIC: &[u8; 16] = b"vrpn: ver. 07.38";
/// Cookie bytes both sides send first.
pub const COOKIE_LEN: usize = 24;
/// Message header bytes.
pub const HEADER_LEN: usize = 24;
/// Payloads are padded to this alignment.
pub const ALIGN: usize = 8;
/// Largest message accepted (VRPN's own TCP buffer is 64000 bytes); checked before
/// anything is allocated for the message.
pub const MAX_MESSAGE_LEN: usize = 64_000;
/// Message type of a sender description.
pub const SENDER_DESCRIPTION: i32 = -1;
/// Message type of a message-type description.
pub const TYPE_DESCRIPTION: i32 = -2;
/// Message type of the goodbye a server sends when it shuts down.
pub const DISCONNECT_MESSAGE: i32 = -5;
/// The tracker pose report's type name.
pub const POS_QUAT: &str = "vrpn_Tracker Pos_Quat";
/// Payload length of a `Pos_Quat` report.
pub const POS_QUAT_LEN: usize = 64;

/// The stream broke VRPN's protocol.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WireError {
    #[error("not a VRPN peer: expected a cookie starting `vrpn: ver. `, got {got:?}")]
    BadCookie { got: String },
    #[error("VRPN major version mismatch: we speak 07, the peer speaks {theirs}")]
    Version { theirs: String },
    #[error("message header announces {len} bytes, less than the {HEADER_LEN}-byte header itself")]
    TooShort { len: u32 },
    #[error("message header announces {len} bytes, more than the limit of {MAX_MESSAGE_LEN}")]
    TooLong { len: u32 },
    #[error("{what} description of id {id} is malformed: {problem}")]
    BadDescription {
        what: &'static str,
        id: i32,
        problem: String,
    },
    #[error("`{POS_QUAT}` payload is {len} bytes, expected {POS_QUAT_LEN}")]
    BadPosQuat { len: usize },
}

/// The cookie this side sends; `log_mode` is VRPN's digit asking the peer to log (0: no).
pub fn cookie(log_mode: u8) -> [u8; COOKIE_LEN] {
    let mut c = [0u8; COOKIE_LEN];
    c[..16].copy_from_slice(MAGIC);
    c[16] = b' ';
    c[17] = b' ';
    c[18] = b'0' + log_mode.min(9);
    c
}

/// Checks a peer's cookie: the magic text and the major version (minor versions interoperate).
pub fn check_cookie(bytes: &[u8]) -> Result<(), WireError> {
    let text: String = bytes
        .iter()
        .take_while(|&&b| b != 0)
        .map(|&b| b as char)
        .collect();
    let Some(version) = text.strip_prefix("vrpn: ver. ") else {
        return Err(WireError::BadCookie { got: text });
    };
    let major = version.split('.').next().unwrap_or("");
    if major != "07" {
        return Err(WireError::Version {
            theirs: version.trim().to_owned(),
        });
    }
    Ok(())
}

/// One VRPN message.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub sec: u32,
    pub usec: u32,
    pub sender: i32,
    pub kind: i32,
    pub seq: u32,
    pub payload: Vec<u8>,
}

impl Message {
    /// The message's timestamp in nanoseconds since the Unix epoch.
    pub fn t_ns(&self) -> u64 {
        self.sec as u64 * 1_000_000_000 + self.usec as u64 * 1_000
    }

    /// The framed bytes: header, payload, zero padding to [`ALIGN`].
    pub fn encode(&self) -> Vec<u8> {
        let len = HEADER_LEN + self.payload.len();
        let mut out = Vec::with_capacity(padded(len));
        out.extend_from_slice(&(len as u32).to_be_bytes());
        out.extend_from_slice(&self.sec.to_be_bytes());
        out.extend_from_slice(&self.usec.to_be_bytes());
        out.extend_from_slice(&self.sender.to_be_bytes());
        out.extend_from_slice(&self.kind.to_be_bytes());
        out.extend_from_slice(&self.seq.to_be_bytes());
        out.extend_from_slice(&self.payload);
        out.resize(padded(len), 0);
        out
    }

    /// A sender (`kind` = [`SENDER_DESCRIPTION`]) or type ([`TYPE_DESCRIPTION`])
    /// description announcing that `id` means `name`.
    pub fn description(
        kind: i32,
        id: i32,
        name: &str,
        seq: u32,
        (sec, usec): (u32, u32),
    ) -> Message {
        let mut payload = Vec::with_capacity(name.len() + 5);
        payload.extend_from_slice(&(name.len() as u32 + 1).to_be_bytes());
        payload.extend_from_slice(name.as_bytes());
        payload.push(0);
        Message {
            sec,
            usec,
            sender: id,
            kind,
            seq,
            payload,
        }
    }
}

/// Bytes a message of `len` occupies on the wire.
pub fn padded(len: usize) -> usize {
    len.div_ceil(ALIGN) * ALIGN
}

/// Splits a TCP byte stream (which may deliver several messages or part of one per read)
/// into the peer's cookie and messages.
#[derive(Debug, Default)]
pub struct StreamDecoder {
    buf: Vec<u8>,
    start: usize,
    cookie_seen: bool,
}

impl StreamDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends bytes read from the socket.
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.start > 0 && self.start * 2 >= self.buf.len() {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// The next complete message, `None` when more bytes are needed. The cookie is checked
    /// first; an error means the stream cannot be resynchronised and must be closed.
    pub fn next_message(&mut self) -> Result<Option<Message>, WireError> {
        let avail = &self.buf[self.start..];
        if !self.cookie_seen {
            if avail.len() < COOKIE_LEN {
                return Ok(None);
            }
            check_cookie(&avail[..COOKIE_LEN])?;
            self.cookie_seen = true;
            self.start += COOKIE_LEN;
            return self.next_message();
        }
        if avail.len() < HEADER_LEN {
            return Ok(None);
        }
        let word =
            |i: usize| u32::from_be_bytes(avail[i * 4..i * 4 + 4].try_into().expect("4 bytes"));
        let len = word(0);
        if (len as usize) < HEADER_LEN {
            return Err(WireError::TooShort { len });
        }
        if len as usize > MAX_MESSAGE_LEN {
            return Err(WireError::TooLong { len });
        }
        let total = padded(len as usize);
        if avail.len() < total {
            return Ok(None);
        }
        let msg = Message {
            sec: word(1),
            usec: word(2),
            sender: word(3) as i32,
            kind: word(4) as i32,
            seq: word(5),
            payload: avail[HEADER_LEN..len as usize].to_vec(),
        };
        self.start += total;
        Ok(Some(msg))
    }
}

/// What the peer's ids mean, learnt from its descriptions.
#[derive(Clone, Debug, Default)]
pub struct RemoteNames {
    senders: HashMap<i32, String>,
    types: HashMap<i32, String>,
}

impl RemoteNames {
    /// Learns from a description; `Ok(true)` when `msg` was one.
    pub fn absorb(&mut self, msg: &Message) -> Result<bool, WireError> {
        let (what, map) = match msg.kind {
            SENDER_DESCRIPTION => ("sender", &mut self.senders),
            TYPE_DESCRIPTION => ("type", &mut self.types),
            _ => return Ok(false),
        };
        let name =
            parse_description(&msg.payload).map_err(|problem| WireError::BadDescription {
                what,
                id: msg.sender,
                problem,
            })?;
        map.insert(msg.sender, name);
        Ok(true)
    }

    pub fn sender(&self, id: i32) -> Option<&str> {
        self.senders.get(&id).map(String::as_str)
    }

    pub fn kind(&self, id: i32) -> Option<&str> {
        self.types.get(&id).map(String::as_str)
    }
}

fn parse_description(p: &[u8]) -> Result<String, String> {
    if p.len() < 4 {
        return Err(format!("payload of {} bytes has no length field", p.len()));
    }
    let n = u32::from_be_bytes(p[..4].try_into().expect("4 bytes")) as usize;
    if n == 0 || 4 + n > p.len() {
        return Err(format!(
            "name length {n} does not fit the {}-byte payload",
            p.len()
        ));
    }
    let name = &p[4..4 + n];
    if name[n - 1] != 0 {
        return Err("name is not NUL-terminated".to_owned());
    }
    String::from_utf8(name[..n - 1].to_vec()).map_err(|_| "name is not UTF-8".to_owned())
}

/// A decoded `vrpn_Tracker Pos_Quat` report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosQuat {
    pub sensor: i32,
    pub position: [f64; 3],
    /// `(x, y, z, w)`.
    pub quat: [f64; 4],
}

impl PosQuat {
    pub fn decode(p: &[u8]) -> Result<PosQuat, WireError> {
        if p.len() != POS_QUAT_LEN {
            return Err(WireError::BadPosQuat { len: p.len() });
        }
        let f =
            |i: usize| f64::from_be_bytes(p[8 + i * 8..16 + i * 8].try_into().expect("8 bytes"));
        Ok(PosQuat {
            sensor: i32::from_be_bytes(p[..4].try_into().expect("4 bytes")),
            position: [f(0), f(1), f(2)],
            quat: [f(3), f(4), f(5), f(6)],
        })
    }

    /// The payload as VRPN's `vrpn_Tracker::encode_to` writes it.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(POS_QUAT_LEN);
        out.extend_from_slice(&self.sensor.to_be_bytes());
        out.extend_from_slice(&self.sensor.to_be_bytes());
        for v in self.position.iter().chain(self.quat.iter()) {
            out.extend_from_slice(&v.to_be_bytes());
        }
        out
    }

    pub fn pose(&self) -> Pose {
        let [x, y, z] = self.position.map(|v| v as f32);
        let [qx, qy, qz, qw] = self.quat.map(|v| v as f32);
        Pose::new(Vec3::new(x, y, z), Quat::from_xyzw(qx, qy, qz, qw))
    }
}

/// Picks one device's sensor out of a stream of messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TrackerSelector {
    pub device: String,
    pub sensor: i32,
}

impl TrackerSelector {
    /// The sample in `msg` when it is a `Pos_Quat` report of the selected device and sensor.
    pub fn sample(&self, names: &RemoteNames, msg: &Message) -> Result<Option<Sample>, WireError> {
        if msg.kind < 0
            || names.kind(msg.kind) != Some(POS_QUAT)
            || names.sender(msg.sender) != Some(&self.device)
        {
            return Ok(None);
        }
        let report = PosQuat::decode(&msg.payload)?;
        Ok((report.sensor == self.sensor).then(|| Sample::new(msg.t_ns(), report.pose())))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::path::Path;

    /// The captured session's records: (direction, ns since start, bytes).
    pub(crate) fn session_records() -> Vec<(u8, u64, Vec<u8>)> {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/tracking/vrpn/session.bin");
        let d = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut out = Vec::new();
        let mut i = 0;
        while i < d.len() {
            let t = u64::from_le_bytes(d[i + 1..i + 9].try_into().unwrap());
            let n = u32::from_le_bytes(d[i + 9..i + 13].try_into().unwrap()) as usize;
            out.push((d[i], t, d[i + 13..i + 13 + n].to_vec()));
            i += 13 + n;
        }
        out
    }

    /// Every message one direction of the capture holds, decoded read by read.
    fn decode_direction(dir: u8) -> Vec<Message> {
        let mut dec = StreamDecoder::new();
        let mut out = Vec::new();
        for (_, _, bytes) in session_records().into_iter().filter(|r| r.0 == dir) {
            dec.feed(&bytes);
            while let Some(m) = dec.next_message().unwrap() {
                out.push(m);
            }
        }
        assert_eq!(dec.buf.len(), dec.start, "no bytes left over");
        out
    }

    #[test]
    fn cookie_matches_the_captured_one() {
        let recs = session_records();
        assert_eq!(recs[0].2.len(), COOKIE_LEN);
        for dir in [0, 1] {
            let first = recs.iter().find(|r| r.0 == dir).unwrap();
            assert_eq!(first.2, cookie(0), "direction {dir}");
        }
        assert!(check_cookie(b"vrpn: ver. 07.35  0\0\0\0\0\0").is_ok());
        assert!(matches!(
            check_cookie(b"vrpn: ver. 08.00  0\0\0\0\0\0"),
            Err(WireError::Version { .. })
        ));
        assert!(matches!(
            check_cookie(b"HTTP/1.1 200 OK\r\n\0\0\0\0\0\0\0"),
            Err(WireError::BadCookie { .. })
        ));
    }

    #[test]
    fn captured_messages_reencode_byte_for_byte() {
        // VRPN leaves its padding bytes uninitialised, so those are the only ones that differ.
        for dir in [0, 1] {
            let stream: Vec<u8> = session_records()
                .into_iter()
                .filter(|r| r.0 == dir)
                .flat_map(|r| r.2)
                .collect();
            let mut at = COOKIE_LEN;
            for m in decode_direction(dir) {
                let encoded = m.encode();
                let len = HEADER_LEN + m.payload.len();
                assert_eq!(
                    encoded[..len],
                    stream[at..at + len],
                    "direction {dir}, message at byte {at}"
                );
                assert!(encoded[len..].iter().all(|&b| b == 0));
                at += encoded.len();
            }
            assert_eq!(at, stream.len());
        }
    }

    #[test]
    fn captured_server_stream_yields_spinning_tracker0_and_still_head() {
        let msgs = decode_direction(1);
        let mut names = RemoteNames::default();
        let spin = TrackerSelector {
            device: "Tracker0".into(),
            sensor: 0,
        };
        let spin1 = TrackerSelector {
            device: "Tracker0".into(),
            sensor: 1,
        };
        let head = TrackerSelector {
            device: "Head".into(),
            sensor: 0,
        };
        let (mut s0, mut s1, mut h) = (Vec::new(), Vec::new(), Vec::new());
        for m in &msgs {
            if names.absorb(m).unwrap() {
                continue;
            }
            s0.extend(spin.sample(&names, m).unwrap());
            s1.extend(spin1.sample(&names, m).unwrap());
            h.extend(head.sample(&names, m).unwrap());
        }
        assert_eq!(names.sender(1), Some("Tracker0"));
        assert_eq!(names.kind(4), Some(POS_QUAT));
        assert!(
            s0.len() > 100 && s1.len() == s0.len() && h.len() > 50,
            "{} {} {}",
            s0.len(),
            s1.len(),
            h.len()
        );
        crate::vrpn::tests::assert_spins_about_y_at_half_rev_per_second(&s0);
        for s in &h {
            assert_eq!(s.pose, Pose::IDENTITY);
        }
    }

    #[test]
    fn pos_quat_round_trips_and_rejects_wrong_sizes() {
        let pq = PosQuat {
            sensor: 3,
            position: [1.0, -2.0, 0.5],
            quat: [0.0, 0.6, 0.0, 0.8],
        };
        let bytes = pq.encode();
        assert_eq!(bytes.len(), POS_QUAT_LEN);
        assert_eq!(&bytes[..8], &[0, 0, 0, 3, 0, 0, 0, 3]);
        assert_eq!(PosQuat::decode(&bytes), Ok(pq));
        assert_eq!(
            PosQuat::decode(&bytes[..60]),
            Err(WireError::BadPosQuat { len: 60 })
        );
    }

    #[test]
    fn bad_headers_and_descriptions_are_errors() {
        let mut dec = StreamDecoder::new();
        dec.feed(&cookie(0));
        dec.feed(&[
            0, 0, 0, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
        ]);
        assert_eq!(dec.next_message(), Err(WireError::TooShort { len: 8 }));
        let mut dec = StreamDecoder::new();
        dec.feed(&cookie(0));
        dec.feed(&[0x7f, 0, 0, 0]);
        dec.feed(&[0; 20]);
        assert!(matches!(dec.next_message(), Err(WireError::TooLong { .. })));
        let mut names = RemoteNames::default();
        let mut d = Message::description(SENDER_DESCRIPTION, 1, "Tracker0", 0, (0, 0));
        d.payload[3] = 200;
        let err = names.absorb(&d).unwrap_err().to_string();
        assert!(err.contains("sender description of id 1"), "{err}");
    }
}
