//! Length-prefixed frames: a `u32` little-endian payload length, then the payload, a
//! bincode 2 (standard configuration) encoding of one message. The length is checked
//! against the reader's maximum *before* the payload buffer is allocated, and a payload
//! must decode exactly, with no bytes left over.

use std::io::{Read, Write};

use serde::Serialize;
use serde::de::DeserializeOwned;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// The default hard limit on a frame's payload (64 MiB).
pub const MAX_FRAME_BYTES: u32 = 64 << 20;

/// Errors reading or writing frames.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error("connection closed")]
    Closed,
    #[error("frame of {len} bytes exceeds the maximum of {max} bytes")]
    TooLarge { len: u64, max: u32 },
    #[error("frame truncated: {got} of {expected} bytes arrived before the connection closed")]
    Truncated { expected: u64, got: u64 },
    #[error("undecodable frame of {len} bytes: {detail}")]
    Decode { len: usize, detail: String },
    #[error("message could not be encoded: {0}")]
    Encode(String),
    #[error(
        "message {seq} of this link failed authentication: forged, altered, replayed or out of order"
    )]
    Forged { seq: u64 },
    #[error("i/o error: {0}")]
    Io(#[from] std::io::Error),
}

fn config() -> bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Varint,
    bincode::config::Limit<{ MAX_FRAME_BYTES as usize }>,
> {
    bincode::config::standard().with_limit::<{ MAX_FRAME_BYTES as usize }>()
}

/// Encodes `msg` as a complete frame (length prefix included).
pub fn encode<T: Serialize>(msg: &T, max: u32) -> Result<Vec<u8>, FrameError> {
    let mut out = vec![0u8; 4];
    bincode::serde::encode_into_std_write(msg, &mut out, config())
        .map_err(|e| FrameError::Encode(e.to_string()))?;
    let len = (out.len() - 4) as u64;
    if len > u64::from(max) {
        return Err(FrameError::TooLarge { len, max });
    }
    out[..4].copy_from_slice(&(len as u32).to_le_bytes());
    Ok(out)
}

/// Decodes one payload (without its length prefix).
pub fn decode<T: DeserializeOwned>(payload: &[u8]) -> Result<T, FrameError> {
    let (msg, used) =
        bincode::serde::decode_from_slice(payload, config()).map_err(|e| FrameError::Decode {
            len: payload.len(),
            detail: e.to_string(),
        })?;
    if used != payload.len() {
        return Err(FrameError::Decode {
            len: payload.len(),
            detail: format!("{} trailing bytes after the message", payload.len() - used),
        });
    }
    Ok(msg)
}

fn check_len(prefix: [u8; 4], max: u32) -> Result<usize, FrameError> {
    let len = u32::from_le_bytes(prefix);
    if len > max {
        return Err(FrameError::TooLarge {
            len: u64::from(len),
            max,
        });
    }
    Ok(len as usize)
}

fn read_payload<R: Read>(r: &mut R, len: usize) -> Result<Vec<u8>, FrameError> {
    let mut buf = vec![0u8; len];
    let mut got = 0;
    while got < len {
        match r.read(&mut buf[got..]) {
            Ok(0) => {
                return Err(FrameError::Truncated {
                    expected: len as u64,
                    got: got as u64,
                });
            }
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(buf)
}

/// Writes one frame.
pub fn write_frame<W: Write, T: Serialize>(w: &mut W, msg: &T, max: u32) -> Result<(), FrameError> {
    w.write_all(&encode(msg, max)?)?;
    Ok(())
}

/// Reads one frame; [`FrameError::Closed`] if the stream ends cleanly before it.
pub fn read_frame<R: Read, T: DeserializeOwned>(r: &mut R, max: u32) -> Result<T, FrameError> {
    decode(&read_payload_of_frame(r, max)?)
}

/// Reads one frame's payload, undecoded (at most `max` bytes).
pub fn read_payload_of_frame<R: Read>(r: &mut R, max: u32) -> Result<Vec<u8>, FrameError> {
    let mut prefix = [0u8; 4];
    let mut got = 0;
    while got < 4 {
        match r.read(&mut prefix[got..]) {
            Ok(0) if got == 0 => return Err(FrameError::Closed),
            Ok(0) => {
                return Err(FrameError::Truncated {
                    expected: 4,
                    got: got as u64,
                });
            }
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
    }
    let len = check_len(prefix, max)?;
    read_payload(r, len)
}

/// Writes one frame to an async stream.
pub async fn write_frame_async<W: AsyncWrite + Unpin, T: Serialize>(
    w: &mut W,
    msg: &T,
    max: u32,
) -> Result<(), FrameError> {
    w.write_all(&encode(msg, max)?).await?;
    Ok(())
}

/// Reads one frame from an async stream; [`FrameError::Closed`] on a clean end.
pub async fn read_frame_async<R: AsyncRead + Unpin, T: DeserializeOwned>(
    r: &mut R,
    max: u32,
) -> Result<T, FrameError> {
    decode(&read_payload_of_frame_async(r, max).await?)
}

/// Reads one frame's payload from an async stream, undecoded (at most `max` bytes).
pub async fn read_payload_of_frame_async<R: AsyncRead + Unpin>(
    r: &mut R,
    max: u32,
) -> Result<Vec<u8>, FrameError> {
    let mut prefix = [0u8; 4];
    let mut got = 0;
    while got < 4 {
        let n = r.read(&mut prefix[got..]).await?;
        if n == 0 {
            return Err(if got == 0 {
                FrameError::Closed
            } else {
                FrameError::Truncated {
                    expected: 4,
                    got: got as u64,
                }
            });
        }
        got += n;
    }
    let len = check_len(prefix, max)?;
    let mut buf = vec![0u8; len];
    let mut got = 0;
    while got < len {
        let n = r.read(&mut buf[got..]).await?;
        if n == 0 {
            return Err(FrameError::Truncated {
                expected: len as u64,
                got: got as u64,
            });
        }
        got += n;
    }
    Ok(buf)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Serialize, Deserialize, Debug, PartialEq)]
    struct Msg {
        a: u32,
        b: String,
    }

    #[test]
    fn round_trip_sync_and_async() {
        let m = Msg {
            a: 7,
            b: "x".into(),
        };
        let mut v = Vec::new();
        write_frame(&mut v, &m, MAX_FRAME_BYTES).unwrap();
        write_frame(&mut v, &m, MAX_FRAME_BYTES).unwrap();
        let mut r = &v[..];
        assert_eq!(read_frame::<_, Msg>(&mut r, MAX_FRAME_BYTES).unwrap(), m);
        assert_eq!(read_frame::<_, Msg>(&mut r, MAX_FRAME_BYTES).unwrap(), m);
        assert!(matches!(
            read_frame::<_, Msg>(&mut r, MAX_FRAME_BYTES),
            Err(FrameError::Closed)
        ));
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(async {
            let mut w = Vec::new();
            write_frame_async(&mut w, &m, MAX_FRAME_BYTES)
                .await
                .unwrap();
            let mut r = &w[..];
            assert_eq!(
                read_frame_async::<_, Msg>(&mut r, MAX_FRAME_BYTES)
                    .await
                    .unwrap(),
                m
            );
        });
    }

    #[test]
    fn bad_frames_give_clear_errors() {
        // Length above the maximum: rejected before allocating.
        let huge = [0xff, 0xff, 0xff, 0xff, 1, 2];
        let e = read_frame::<_, Msg>(&mut &huge[..], 1024).unwrap_err();
        assert!(
            matches!(
                e,
                FrameError::TooLarge {
                    len: 0xffff_ffff,
                    max: 1024
                }
            ),
            "{e}"
        );
        // Truncated prefix and payload.
        assert!(matches!(
            read_frame::<_, Msg>(&mut &[5u8, 0][..], 1024),
            Err(FrameError::Truncated { .. })
        ));
        assert!(matches!(
            read_frame::<_, Msg>(&mut &[5u8, 0, 0, 0, 1][..], 1024),
            Err(FrameError::Truncated { .. })
        ));
        // Garbage payload and trailing bytes.
        let bad = [3u8, 0, 0, 0, 0xff, 0xff, 0xff];
        assert!(matches!(
            read_frame::<_, Msg>(&mut &bad[..], 1024),
            Err(FrameError::Decode { .. })
        ));
        let mut v = encode(
            &Msg {
                a: 1,
                b: String::new(),
            },
            1024,
        )
        .unwrap();
        v.push(0);
        v[0] += 1;
        let e = read_frame::<_, Msg>(&mut &v[..], 1024).unwrap_err();
        assert!(e.to_string().contains("trailing"), "{e}");
        // Encoding above the maximum.
        assert!(matches!(
            encode(
                &Msg {
                    a: 1,
                    b: "y".repeat(100)
                },
                10
            ),
            Err(FrameError::TooLarge { .. })
        ));
    }
}
