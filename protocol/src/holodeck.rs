//! Messages between the holodeck server and its workers (paper §2.3) and displays (§2.4).
//! Rays, results, requests and samples travel as packed little-endian records, not as one
//! serde struct per sample.
//!
//! A worker session: the worker sends [`WorkerMsg::Hello`]; the server answers
//! [`ServerMsg::Welcome`] and then [`ServerMsg::Rays`] packets, as many as keep the
//! worker's queue about three seconds deep; the worker answers each with a
//! [`WorkerMsg::Samples`] packet of the same id, results in ray order. Either side may
//! close at any time; the server re-assigns packets a vanished worker had in flight.
//!
//! A display session, on the same listener (told apart by the first message): the display
//! sends [`WorkerMsg::DisplayHello`]; the server answers [`ServerMsg::DisplayWelcome`]
//! (the holodeck's sections), then the display sends [`WorkerMsg::Request`]s whenever its
//! wanted beams change and the server sends [`ServerMsg::Beams`]: at once the stored
//! samples of newly requested beams, then new samples as workers return them (for any
//! display's beams). The server never waits for a display's answer.

use serde::{Deserialize, Serialize};

/// Version of this message set; a worker or display with another version is refused.
/// 2: the welcome says which distance the holodeck stores.
/// 3: displays (hello, welcome with the sections, beam requests, samples).
pub const PROTOCOL_VERSION: u32 = 3;
/// Bytes per beam request record: section `u16`, beam `u32`, wanted samples `f32`.
pub const REQUEST_RECORD_BYTES: usize = 10;
/// Bytes per stored sample (the holodeck file's record: RGBE, entry and exit positions,
/// distance code).
pub const SAMPLE_RECORD_BYTES: usize = 10;
/// Bytes of a beam header in [`BeamBatch`]: section `u16`, beam `u32`, sample count `u32`.
pub const BEAM_HEADER_BYTES: usize = 10;
/// Bytes per ray record: origin `[f32; 3]`, unit direction `[f32; 3]`.
pub const RAY_RECORD_BYTES: usize = 24;
/// Bytes per result record: radiance `[f32; 3]`, distance `f32` (`+Inf` if escaped), the
/// distance being the kind the welcome asked for.
pub const RESULT_RECORD_BYTES: usize = 16;

/// A ray as sent: origin and unit direction.
pub type WireRay = ([f32; 3], [f32; 3]);
/// A result as sent: radiance and distance.
pub type WireResult = ([f32; 3], f32);

/// A record buffer whose length is not a whole number of records.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{what}: {len} bytes is not a whole number of {record}-byte records")]
pub struct RecordError {
    pub what: &'static str,
    pub len: usize,
    pub record: usize,
}

/// Worker or display → server.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum WorkerMsg {
    Hello(WorkerHello),
    Samples(SamplePacket),
    /// A display's first message.
    DisplayHello(DisplayHello),
    /// A display's wanted beams (replacing its previous request for the same eye).
    Request(BeamRequest),
}

/// Server → worker or display.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum ServerMsg {
    Welcome(WorkerWelcome),
    Rays(RayPacket),
    /// The server is done; the worker (or display) should stop.
    Bye,
    DisplayWelcome(DisplayWelcome),
    /// Samples for a display.
    Beams(BeamBatch),
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct DisplayHello {
    pub protocol: u32,
    /// The display's number (e.g. its wall); the server keeps one request per display and
    /// eye slot.
    pub display: u32,
    /// Host name or other label, for logs.
    pub name: String,
}

/// A holodeck section as sent to displays: what `holocave_holodeck::Section::new` takes.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WireSection {
    pub origin: [f64; 3],
    pub edges: [[f64; 3]; 3],
    pub grid: [u32; 3],
    /// 0 interior, 1 exterior.
    pub class: u8,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct DisplayWelcome {
    /// The scene the holodeck was made with.
    pub scene: String,
    pub sections: Vec<WireSection>,
}

/// One eye's wanted beams: the eye (for proximity sampling, Appendix A) and packed
/// `(section u16, beam u32, wanted f32)` records.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct BeamRequest {
    /// Which eye of the display (0..4).
    pub slot: u8,
    /// Eye position (scene coordinates) and the radius new rays should pass within; no
    /// eye when `radius` is not positive.
    pub eye: [f64; 3],
    pub radius: f64,
    #[serde(with = "serde_bytes")]
    pub wanted: Vec<u8>,
}

/// Samples of some beams: per beam a header (section `u16`, beam `u32`, count `u32`) then
/// `count` 10-byte sample records, all packed.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct BeamBatch {
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

impl BeamRequest {
    /// Appends a wanted beam.
    pub fn push(&mut self, section: u16, beam: u32, wanted: f32) {
        self.wanted.extend_from_slice(&section.to_le_bytes());
        self.wanted.extend_from_slice(&beam.to_le_bytes());
        self.wanted.extend_from_slice(&wanted.to_le_bytes());
    }

    /// The wanted beams; fails if the buffer is not whole records.
    pub fn beams(&self) -> Result<Vec<(u16, u32, f32)>, RecordError> {
        if !self.wanted.len().is_multiple_of(REQUEST_RECORD_BYTES) {
            return Err(RecordError {
                what: "beam request",
                len: self.wanted.len(),
                record: REQUEST_RECORD_BYTES,
            });
        }
        Ok(self
            .wanted
            .chunks_exact(REQUEST_RECORD_BYTES)
            .map(|c| {
                (
                    u16::from_le_bytes([c[0], c[1]]),
                    u32::from_le_bytes([c[2], c[3], c[4], c[5]]),
                    f32::from_le_bytes([c[6], c[7], c[8], c[9]]),
                )
            })
            .collect())
    }
}

/// One beam of a [`BeamBatch`]: section, beam and its sample records.
pub type BatchBeam<'a> = (u16, u32, &'a [u8]);

impl BeamBatch {
    /// Appends one beam's samples, given as consecutive 10-byte records.
    pub fn push(&mut self, section: u16, beam: u32, records: &[u8]) {
        debug_assert!(records.len().is_multiple_of(SAMPLE_RECORD_BYTES));
        let n = (records.len() / SAMPLE_RECORD_BYTES) as u32;
        self.data.extend_from_slice(&section.to_le_bytes());
        self.data.extend_from_slice(&beam.to_le_bytes());
        self.data.extend_from_slice(&n.to_le_bytes());
        self.data.extend_from_slice(records);
    }

    pub fn len_bytes(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The beams as `(section, beam, records)`; fails on a truncated buffer.
    pub fn beams(&self) -> Result<Vec<BatchBeam<'_>>, RecordError> {
        let mut out = Vec::new();
        let mut rest = &self.data[..];
        let bad = || RecordError {
            what: "beam batch",
            len: self.data.len(),
            record: SAMPLE_RECORD_BYTES,
        };
        while !rest.is_empty() {
            if rest.len() < BEAM_HEADER_BYTES {
                return Err(bad());
            }
            let section = u16::from_le_bytes([rest[0], rest[1]]);
            let beam = u32::from_le_bytes([rest[2], rest[3], rest[4], rest[5]]);
            let n = u32::from_le_bytes([rest[6], rest[7], rest[8], rest[9]]) as usize;
            let len = n.checked_mul(SAMPLE_RECORD_BYTES).ok_or_else(bad)?;
            let body = &rest[BEAM_HEADER_BYTES..];
            if body.len() < len {
                return Err(bad());
            }
            out.push((section, beam, &body[..len]));
            rest = &body[len..];
        }
        Ok(out)
    }
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WorkerHello {
    pub protocol: u32,
    /// Host name or other label, for logs.
    pub name: String,
    /// The scene the worker loaded (file name), checked against the holodeck's.
    pub scene: String,
}

/// The server's answer to a worker's hello.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WorkerWelcome {
    pub worker_id: u64,
    /// The scene the holodeck was made with, as recorded in its settings.
    pub scene: String,
    /// Which distance the results must carry (a setting of the holodeck file).
    pub distance: WireDistanceKind,
}

/// Which distance a worker must answer, as the welcome carries it (the holodeck's
/// `holocave_holodeck::file::DistanceKind`, mapped at the boundary).
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WireDistanceKind {
    /// To the first surface the ray hits.
    FirstHit,
    /// To the first non-specular surface, through flat mirrors and glass.
    #[default]
    Virtual,
}

/// Rays to trace.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct RayPacket {
    pub id: u64,
    /// Seed for the tracer's random numbers (deterministic results per packet).
    pub seed: u64,
    #[serde(with = "serde_bytes")]
    pub rays: Vec<u8>,
}

/// Traced results for one ray packet.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq, Default)]
pub struct SamplePacket {
    pub id: u64,
    #[serde(with = "serde_bytes")]
    pub results: Vec<u8>,
}

fn f32s<const N: usize>(b: &[u8]) -> [f32; N] {
    std::array::from_fn(|i| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().expect("4 bytes")))
}

impl RayPacket {
    /// Appends a ray.
    pub fn push(&mut self, origin: [f32; 3], dir: [f32; 3]) {
        for v in origin.iter().chain(&dir) {
            self.rays.extend_from_slice(&v.to_le_bytes());
        }
    }

    /// Number of whole ray records.
    pub fn len(&self) -> usize {
        self.rays.len() / RAY_RECORD_BYTES
    }

    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// The rays as `(origin, dir)`; fails if the buffer is not whole records.
    pub fn rays(&self) -> Result<Vec<WireRay>, RecordError> {
        if !self.rays.len().is_multiple_of(RAY_RECORD_BYTES) {
            return Err(RecordError {
                what: "ray packet",
                len: self.rays.len(),
                record: RAY_RECORD_BYTES,
            });
        }
        Ok(self
            .rays
            .chunks_exact(RAY_RECORD_BYTES)
            .map(|c| {
                let v: [f32; 6] = f32s(c);
                ([v[0], v[1], v[2]], [v[3], v[4], v[5]])
            })
            .collect())
    }
}

impl SamplePacket {
    /// Appends a result.
    pub fn push(&mut self, radiance: [f32; 3], distance: f32) {
        for v in radiance.iter().chain(std::iter::once(&distance)) {
            self.results.extend_from_slice(&v.to_le_bytes());
        }
    }

    pub fn len(&self) -> usize {
        self.results.len() / RESULT_RECORD_BYTES
    }

    pub fn is_empty(&self) -> bool {
        self.results.is_empty()
    }

    /// The results as `(radiance, distance)`; fails if the buffer is not whole records.
    pub fn results(&self) -> Result<Vec<WireResult>, RecordError> {
        if !self.results.len().is_multiple_of(RESULT_RECORD_BYTES) {
            return Err(RecordError {
                what: "sample packet",
                len: self.results.len(),
                record: RESULT_RECORD_BYTES,
            });
        }
        Ok(self
            .results
            .chunks_exact(RESULT_RECORD_BYTES)
            .map(|c| {
                let v: [f32; 4] = f32s(c);
                ([v[0], v[1], v[2]], v[3])
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{MAX_FRAME_BYTES, decode, encode};
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn packets_round_trip(rays in proptest::collection::vec(any::<[f32; 6]>(), 0..50), id in any::<u64>()) {
            let mut p = RayPacket { id, seed: 3, rays: Vec::new() };
            let mut s = SamplePacket { id, results: Vec::new() };
            for r in &rays {
                p.push([r[0], r[1], r[2]], [r[3], r[4], r[5]]);
                s.push([r[0], r[1], r[2]], r[3]);
            }
            let frame = encode(&ServerMsg::Rays(p.clone()), MAX_FRAME_BYTES).unwrap();
            // Packed: the payload is the records plus a few bytes of header.
            prop_assert!(frame.len() <= rays.len() * RAY_RECORD_BYTES + 32);
            let back: ServerMsg = decode(&frame[4..]).unwrap();
            prop_assert_eq!(&back, &ServerMsg::Rays(p.clone()));
            let got = p.rays().unwrap();
            prop_assert_eq!(got.len(), rays.len());
            for (g, r) in got.iter().zip(&rays) {
                prop_assert_eq!(g.0.map(f32::to_bits), [r[0], r[1], r[2]].map(f32::to_bits));
                prop_assert_eq!(g.1.map(f32::to_bits), [r[3], r[4], r[5]].map(f32::to_bits));
            }
            let frame = encode(&WorkerMsg::Samples(s.clone()), MAX_FRAME_BYTES).unwrap();
            let back: WorkerMsg = decode(&frame[4..]).unwrap();
            prop_assert_eq!(back, WorkerMsg::Samples(s.clone()));
            prop_assert_eq!(s.results().unwrap().len(), rays.len());
        }
    }

    #[test]
    fn welcome_carries_the_distance_kind() {
        for d in [WireDistanceKind::FirstHit, WireDistanceKind::Virtual] {
            let m = ServerMsg::Welcome(WorkerWelcome {
                worker_id: 7,
                scene: "cornell.gltf".into(),
                distance: d,
            });
            let frame = encode(&m, MAX_FRAME_BYTES).unwrap();
            assert_eq!(decode::<ServerMsg>(&frame[4..]).unwrap(), m);
        }
    }

    #[test]
    fn display_messages_are_packed_and_round_trip() {
        let mut r = BeamRequest {
            slot: 1,
            eye: [0.5, 1.0, 3.0],
            radius: 0.01,
            wanted: Vec::new(),
        };
        for b in 0..100u32 {
            r.push(2, b * 7, b as f32 + 0.5);
        }
        let frame = encode(&WorkerMsg::Request(r.clone()), MAX_FRAME_BYTES).unwrap();
        assert!(
            frame.len() <= 100 * REQUEST_RECORD_BYTES + 48,
            "{}",
            frame.len()
        );
        assert_eq!(
            decode::<WorkerMsg>(&frame[4..]).unwrap(),
            WorkerMsg::Request(r.clone())
        );
        let beams = r.beams().unwrap();
        assert_eq!(beams[3], (2, 21, 3.5));
        let mut b = BeamBatch::default();
        let recs: Vec<u8> = (0..30u8).collect();
        b.push(1, 9, &recs);
        b.push(0, 70_000, &[]);
        let frame = encode(&ServerMsg::Beams(b.clone()), MAX_FRAME_BYTES).unwrap();
        assert!(
            frame.len() <= 30 + 2 * BEAM_HEADER_BYTES + 16,
            "{}",
            frame.len()
        );
        assert_eq!(
            decode::<ServerMsg>(&frame[4..]).unwrap(),
            ServerMsg::Beams(b.clone())
        );
        let got = b.beams().unwrap();
        assert_eq!(got, vec![(1, 9, &recs[..]), (0, 70_000, &[][..])]);
        b.data.pop();
        assert!(b.beams().is_err());
        r.wanted.pop();
        assert!(r.beams().is_err());
    }

    #[test]
    fn partial_records_are_errors() {
        let p = RayPacket {
            id: 1,
            seed: 0,
            rays: vec![0; 25],
        };
        let e = p.rays().unwrap_err();
        assert_eq!(
            e.to_string(),
            "ray packet: 25 bytes is not a whole number of 24-byte records"
        );
        let s = SamplePacket {
            id: 1,
            results: vec![0; 15],
        };
        assert!(s.results().is_err());
    }
}
