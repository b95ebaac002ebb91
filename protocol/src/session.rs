//! An authenticated link: every message after the handshake carries a keyed BLAKE3 tag
//! (BLAKE3's MAC mode) under a key only the two peers know (derived in the handshake from
//! the shared secret and both fresh nonces), over the message's sequence number on the
//! link and its bytes. BLAKE3 rather than HMAC-SHA256 for the messages because a sample
//! packet is 64 kB: HMAC-SHA256 cost a holodeck fill 6% of its rate (README, "Cluster").
//! A peer on the network can therefore neither inject a message (no key), alter one (the
//! tag fails), nor replay, drop or reorder one (the receiver's counter no longer matches):
//! the first such message ends the link with [`FrameError::Forged`]. Each direction has
//! its own key, so a message cannot be reflected back to its sender.
//!
//! On the wire a sealed message is an ordinary frame whose payload is the message's
//! bincode bytes followed by the 32-byte tag; the sequence number is not sent.

use std::io::{Read, Write};

use hmac::{Hmac, Mac};
use serde::Serialize;
use serde::de::DeserializeOwned;
use sha2::Sha256;
use tokio::io::{AsyncRead, AsyncWrite, AsyncWriteExt};

use crate::frame::{
    FrameError, decode, encode, read_payload_of_frame, read_payload_of_frame_async,
};

type HmacSha256 = Hmac<Sha256>;

/// Bytes of the tag after each sealed message.
pub const TAG_BYTES: usize = 32;

/// The two directions' keys of one link, as the handshake derived them.
#[derive(Clone)]
pub struct SessionKeys {
    /// For messages from the side that connected (node, worker, display) to the side that
    /// accepted (master, holodeck server).
    pub to_acceptor: [u8; 32],
    /// For messages the other way.
    pub to_connector: [u8; 32],
}

impl std::fmt::Debug for SessionKeys {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SessionKeys(..)")
    }
}

impl SessionKeys {
    /// The keys of a link whose handshake produced `session` (a secret only both peers can
    /// compute): one HMAC of it per direction.
    pub fn derive(session: &[u8]) -> SessionKeys {
        let key = |label: &[u8]| -> [u8; 32] {
            let mut mac = HmacSha256::new_from_slice(session).expect("any key length");
            mac.update(label);
            mac.finalize().into_bytes().into()
        };
        SessionKeys {
            to_acceptor: key(b"holocave link: to acceptor"),
            to_connector: key(b"holocave link: to connector"),
        }
    }

    /// The connecting side's (sealer, opener).
    pub fn connector(&self) -> (Sealer, Opener) {
        (
            Sealer::new(&self.to_acceptor),
            Opener::new(&self.to_connector),
        )
    }

    /// The accepting side's (sealer, opener).
    pub fn acceptor(&self) -> (Sealer, Opener) {
        (
            Sealer::new(&self.to_connector),
            Opener::new(&self.to_acceptor),
        )
    }
}

/// The tag of message `seq` with bytes `payload`.
fn tag(key: &[u8; 32], seq: u64, payload: &[u8]) -> blake3::Hash {
    let mut mac = blake3::Hasher::new_keyed(key);
    mac.update(&seq.to_le_bytes());
    mac.update(payload);
    mac.finalize()
}

/// Seals the messages one side sends, numbering them.
#[derive(Clone)]
pub struct Sealer {
    key: [u8; 32],
    seq: u64,
}

impl Sealer {
    fn new(key: &[u8; 32]) -> Sealer {
        Sealer { key: *key, seq: 0 }
    }

    /// The next message as a complete sealed frame (its payload at most `max` bytes).
    pub fn seal<T: Serialize>(&mut self, msg: &T, max: u32) -> Result<Vec<u8>, FrameError> {
        let mut frame = encode(msg, max)?;
        let t = tag(&self.key, self.seq, &frame[4..]);
        self.seq += 1;
        frame.extend_from_slice(t.as_bytes());
        let len = (frame.len() - 4) as u32;
        frame[..4].copy_from_slice(&len.to_le_bytes());
        Ok(frame)
    }

    /// Seals and writes the next message.
    pub fn write<W: Write, T: Serialize>(
        &mut self,
        w: &mut W,
        msg: &T,
        max: u32,
    ) -> Result<(), FrameError> {
        w.write_all(&self.seal(msg, max)?)?;
        Ok(())
    }

    /// Seals and writes the next message to an async stream.
    pub async fn write_async<W: AsyncWrite + Unpin, T: Serialize>(
        &mut self,
        w: &mut W,
        msg: &T,
        max: u32,
    ) -> Result<(), FrameError> {
        w.write_all(&self.seal(msg, max)?).await?;
        Ok(())
    }
}

/// Checks the messages one side receives, in order.
#[derive(Clone)]
pub struct Opener {
    key: [u8; 32],
    seq: u64,
}

impl Opener {
    fn new(key: &[u8; 32]) -> Opener {
        Opener { key: *key, seq: 0 }
    }

    /// The message in a sealed frame's payload, if its tag is right for the next number.
    pub fn open<T: DeserializeOwned>(&mut self, sealed: &[u8]) -> Result<T, FrameError> {
        let forged = FrameError::Forged { seq: self.seq };
        let Some(split) = sealed.len().checked_sub(TAG_BYTES) else {
            return Err(forged);
        };
        let (payload, t) = sealed.split_at(split);
        // `Hash`'s equality is constant-time.
        let Ok(t) = <[u8; TAG_BYTES]>::try_from(t) else {
            return Err(forged);
        };
        if tag(&self.key, self.seq, payload) != blake3::Hash::from_bytes(t) {
            return Err(forged);
        }
        self.seq += 1;
        decode(payload)
    }

    /// Reads and opens the next message (its payload at most `max` bytes).
    pub fn read<R: Read, T: DeserializeOwned>(
        &mut self,
        r: &mut R,
        max: u32,
    ) -> Result<T, FrameError> {
        let sealed = read_payload_of_frame(r, max.saturating_add(TAG_BYTES as u32))?;
        self.open(&sealed)
    }

    /// Reads and opens the next message from an async stream.
    pub async fn read_async<R: AsyncRead + Unpin, T: DeserializeOwned>(
        &mut self,
        r: &mut R,
        max: u32,
    ) -> Result<T, FrameError> {
        let sealed = read_payload_of_frame_async(r, max.saturating_add(TAG_BYTES as u32)).await?;
        self.open(&sealed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn link() -> ((Sealer, Opener), (Sealer, Opener)) {
        let keys = SessionKeys::derive(b"a session secret");
        (keys.connector(), keys.acceptor())
    }

    #[test]
    fn sealed_messages_arrive_in_order() {
        let ((mut send, _), (_, mut recv)) = link();
        let mut wire = Vec::new();
        for i in 0..3u32 {
            send.write(&mut wire, &i, 1024).unwrap();
        }
        let mut r = &wire[..];
        for i in 0..3u32 {
            assert_eq!(recv.read::<_, u32>(&mut r, 1024).unwrap(), i);
        }
    }

    #[test]
    fn injected_altered_replayed_reflected_and_dropped_messages_are_refused() {
        let frame = |s: &mut Sealer, v: u32| s.seal(&v, 1024).unwrap();
        let payload = |f: &[u8]| f[4..].to_vec();

        // Injected: sealed under a key of another session.
        let ((mut other, _), _) = {
            let keys = SessionKeys::derive(b"another session");
            (keys.connector(), keys.acceptor())
        };
        let ((mut send, mut back), (mut reply, mut recv)) = link();
        let forged = payload(&frame(&mut other, 1));
        assert!(matches!(
            recv.clone().open::<u32>(&forged),
            Err(FrameError::Forged { seq: 0 })
        ));

        // Altered: one bit of the message flipped.
        let mut altered = payload(&frame(&mut send.clone(), 5));
        altered[0] ^= 1;
        assert!(recv.clone().open::<u32>(&altered).is_err());

        // Replayed: the first message again, after it was accepted.
        let first = payload(&frame(&mut send, 7));
        assert_eq!(recv.open::<u32>(&first).unwrap(), 7);
        assert!(matches!(
            recv.clone().open::<u32>(&first),
            Err(FrameError::Forged { seq: 1 })
        ));

        // Reflected: the receiver's own message sent back to it.
        let own = payload(&frame(&mut reply, 9));
        assert!(recv.clone().open::<u32>(&own).is_err());
        assert_eq!(back.open::<u32>(&own).unwrap(), 9);

        // Dropped: message 1 lost, message 2 arrives.
        let _lost = frame(&mut send, 1);
        let third = payload(&frame(&mut send, 2));
        assert!(recv.open::<u32>(&third).is_err());

        // Too short to carry a tag.
        assert!(recv.open::<u32>(&[1, 2, 3]).is_err());
    }

    #[test]
    fn a_frame_over_the_limit_is_refused_before_it_is_read() {
        let ((mut send, _), (_, mut recv)) = link();
        let mut wire = Vec::new();
        send.write(&mut wire, &vec![0u8; 100], 1024).unwrap();
        let mut r = &wire[..];
        assert!(matches!(
            recv.read::<_, Vec<u8>>(&mut r, 50),
            Err(FrameError::TooLarge { .. })
        ));
    }
}
