//! Reading VRPN's own log files (`vrpn_server -lo`, `.vrpn`): the version cookie, then
//! entries of six big-endian 32-bit fields (message type, sender, seconds, microseconds,
//! payload length, unused), each followed by its unpadded payload. Sender and type ids
//! are resolved through the descriptions the log holds, exactly as on the wire.

use std::path::{Path, PathBuf};

use crate::pose::Sample;
use crate::vrpn_wire::{
    COOKIE_LEN, MAX_MESSAGE_LEN, Message, RemoteNames, TrackerSelector, WireError, check_cookie,
};

const ENTRY_HEADER_LEN: usize = 24;

/// A log file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum VrpnLogError {
    #[error("cannot read VRPN log {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("VRPN log {path} at byte {offset}: {source}")]
    Wire {
        path: PathBuf,
        offset: usize,
        source: WireError,
    },
    #[error(
        "VRPN log {path} at byte {offset}: entry announces a {len}-byte payload (limit {MAX_MESSAGE_LEN})"
    )]
    BadLength {
        path: PathBuf,
        offset: usize,
        len: i64,
    },
}

/// The samples of one device and sensor in a log.
#[derive(Clone, Debug)]
pub struct VrpnLog {
    /// In file order, times in ns since the Unix epoch (the server's clock).
    pub samples: Vec<Sample>,
    /// Entries read (all devices and types).
    pub entries: usize,
    /// Set when the file ends inside an entry: the byte offset of that entry. The samples
    /// before it are kept; nothing is invented for the rest.
    pub truncated_at: Option<usize>,
}

/// Reads `path` and picks the reports of `selector`.
pub fn read_vrpn_log(path: &Path, selector: &TrackerSelector) -> Result<VrpnLog, VrpnLogError> {
    let bytes = std::fs::read(path).map_err(|source| VrpnLogError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_vrpn_log(&bytes, selector).map_err(|e| match e {
        ParseError::Wire { offset, source } => VrpnLogError::Wire {
            path: path.to_owned(),
            offset,
            source,
        },
        ParseError::Length { offset, len } => VrpnLogError::BadLength {
            path: path.to_owned(),
            offset,
            len,
        },
    })
}

enum ParseError {
    Wire { offset: usize, source: WireError },
    Length { offset: usize, len: i64 },
}

fn parse_vrpn_log(bytes: &[u8], selector: &TrackerSelector) -> Result<VrpnLog, ParseError> {
    if bytes.len() < COOKIE_LEN {
        return Err(ParseError::Wire {
            offset: 0,
            source: WireError::BadCookie {
                got: format!("{} bytes", bytes.len()),
            },
        });
    }
    check_cookie(&bytes[..COOKIE_LEN]).map_err(|source| ParseError::Wire { offset: 0, source })?;
    let mut names = RemoteNames::default();
    let mut log = VrpnLog {
        samples: Vec::new(),
        entries: 0,
        truncated_at: None,
    };
    let mut at = COOKIE_LEN;
    while at < bytes.len() {
        if bytes.len() - at < ENTRY_HEADER_LEN {
            log.truncated_at = Some(at);
            break;
        }
        let word = |i: usize| {
            i32::from_be_bytes(
                bytes[at + 4 * i..at + 4 * i + 4]
                    .try_into()
                    .expect("4 bytes"),
            )
        };
        let len = word(4) as i64;
        if !(0..=MAX_MESSAGE_LEN as i64).contains(&len) {
            return Err(ParseError::Length { offset: at, len });
        }
        let end = at + ENTRY_HEADER_LEN + len as usize;
        if end > bytes.len() {
            log.truncated_at = Some(at);
            break;
        }
        let msg = Message {
            kind: word(0),
            sender: word(1),
            sec: word(2) as u32,
            usec: word(3) as u32,
            seq: 0,
            payload: bytes[at + ENTRY_HEADER_LEN..end].to_vec(),
        };
        let wire = |source| ParseError::Wire { offset: at, source };
        if !names.absorb(&msg).map_err(wire)? {
            log.samples
                .extend(selector.sample(&names, &msg).map_err(wire)?);
        }
        log.entries += 1;
        at = end;
    }
    Ok(log)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose;

    fn server_log() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/tracking/vrpn/server-out.vrpn")
    }

    fn sel(device: &str, sensor: i32) -> TrackerSelector {
        TrackerSelector {
            device: device.into(),
            sensor,
        }
    }

    #[test]
    fn real_server_log_holds_the_spinning_and_the_still_tracker() {
        let log = read_vrpn_log(&server_log(), &sel("Tracker0", 0)).unwrap();
        assert_eq!(log.entries, 2018);
        assert_eq!(log.truncated_at, None);
        assert_eq!(log.samples.len(), 264, "528 reports, half of them sensor 1");
        assert_eq!(
            read_vrpn_log(&server_log(), &sel("Tracker0", 1))
                .unwrap()
                .samples
                .len(),
            264
        );
        crate::vrpn::tests::assert_spins_about_y_at_half_rev_per_second(&log.samples);
        let head = read_vrpn_log(&server_log(), &sel("Head", 0)).unwrap();
        assert_eq!(head.samples.len(), 133);
        assert!(head.samples.iter().all(|s| s.pose == Pose::IDENTITY));
        assert!(
            read_vrpn_log(&server_log(), &sel("Tracker0", 5))
                .unwrap()
                .samples
                .is_empty()
        );
    }

    #[test]
    fn truncated_and_corrupt_logs_say_where() {
        let bytes = std::fs::read(server_log()).unwrap();
        let cut = &bytes[..bytes.len() - 10];
        let log = parse_vrpn_log(cut, &sel("Tracker0", 0)).ok().unwrap();
        assert!(log.truncated_at.is_some());
        assert!(log.samples.len() >= 263);

        let dir = tempfile::tempdir().unwrap();
        let mut bad = bytes.clone();
        bad[24 + 16..24 + 20].copy_from_slice(&(-3i32).to_be_bytes());
        let path = dir.path().join("bad.vrpn");
        std::fs::write(&path, &bad).unwrap();
        let err = read_vrpn_log(&path, &sel("Tracker0", 0))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("bad.vrpn at byte 24") && err.contains("-3-byte payload"),
            "{err}"
        );
        std::fs::write(&path, b"not a vrpn log at all, no").unwrap();
        let err = read_vrpn_log(&path, &sel("Tracker0", 0))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("bad.vrpn at byte 0") && err.contains("not a VRPN peer"),
            "{err}"
        );
    }
}
