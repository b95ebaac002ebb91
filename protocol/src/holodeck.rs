//! Messages between the holodeck server and its workers (paper §2.3). Rays and results
//! travel as packed little-endian records, not as one serde struct per sample.
//!
//! A session: the worker sends [`WorkerMsg::Hello`]; the server answers
//! [`ServerMsg::Welcome`] and then [`ServerMsg::Rays`] packets, as many as keep the
//! worker's queue about three seconds deep; the worker answers each with a
//! [`WorkerMsg::Samples`] packet of the same id, results in ray order. Either side may
//! close at any time; the server re-assigns packets a vanished worker had in flight.

use serde::{Deserialize, Serialize};

/// Version of this message set; a worker with another version is refused.
/// 2: the welcome says which distance the holodeck stores.
pub const PROTOCOL_VERSION: u32 = 2;
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

/// Worker → server.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum WorkerMsg {
    Hello(WorkerHello),
    Samples(SamplePacket),
}

/// Server → worker.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum ServerMsg {
    Welcome(Welcome),
    Rays(RayPacket),
    /// The server is done; the worker should exit.
    Bye,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WorkerHello {
    pub protocol: u32,
    /// Host name or other label, for logs.
    pub name: String,
    /// The scene the worker loaded (file name), checked against the holodeck's.
    pub scene: String,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct Welcome {
    pub worker_id: u64,
    /// The scene the holodeck was made with, as recorded in its settings.
    pub scene: String,
    /// Which distance the results must carry (a setting of the holodeck file).
    pub distance: DistanceKind,
}

/// Which distance a sample generator answers for a ray (the holodeck paper's `VDISTANCE`,
/// §2.3): measured from the ray's origin either way.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DistanceKind {
    /// To the first surface the ray hits (`VDISTANCE=False`).
    FirstHit,
    /// To the first non-specular surface, continuing through flat mirrors and flat glass
    /// (`VDISTANCE=True`): samples seen in a mirror reproject to where the reflected object
    /// appears, so reflections keep their parallax and stereo depth.
    #[default]
    Virtual,
}

impl DistanceKind {
    /// The name used in holodeck settings and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DistanceKind::FirstHit => "first-hit",
            DistanceKind::Virtual => "virtual",
        }
    }

    /// Parses [`DistanceKind::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "first-hit" => Some(DistanceKind::FirstHit),
            "virtual" => Some(DistanceKind::Virtual),
            _ => None,
        }
    }
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
        for d in [DistanceKind::FirstHit, DistanceKind::Virtual] {
            assert_eq!(DistanceKind::from_name(d.name()), Some(d));
            let m = ServerMsg::Welcome(Welcome {
                worker_id: 7,
                scene: "cornell.gltf".into(),
                distance: d,
            });
            let frame = encode(&m, MAX_FRAME_BYTES).unwrap();
            assert_eq!(decode::<ServerMsg>(&frame[4..]).unwrap(), m);
        }
        assert_eq!(DistanceKind::from_name("vdistance"), None);
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
