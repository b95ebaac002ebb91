//! The display service's messages as the protocol carries them: sections, eye requests
//! and sample batches (packed 10-byte records).

use glam::DVec3;
use holocave_protocol::holodeck::{
    BeamBatch, BeamRequest, DisplayWelcome, RecordError, SAMPLE_RECORD_BYTES, WireSection,
};

use super::{DisplayError, EyeRequest};
use crate::beam_index::BeamKey;
use crate::proximity::EyeSphere;
use crate::sample::PackedSample;
use crate::section::{Section, ViewClass};
use crate::server::{BeamSamples, Server};

/// Sections as sent to displays.
pub fn wire_sections(sections: &[Section]) -> Vec<WireSection> {
    sections
        .iter()
        .map(|s| WireSection {
            origin: s.origin().to_array(),
            edges: s.edges().map(|e| e.to_array()),
            grid: s.grid(),
            class: s.class().to_byte(),
        })
        .collect()
}

/// Sections as a display rebuilds them.
pub fn sections_from_wire(wire: &[WireSection]) -> Result<Vec<Section>, DisplayError> {
    wire.iter()
        .enumerate()
        .map(|(i, w)| {
            let class = ViewClass::from_byte(w.class).ok_or_else(|| {
                DisplayError::Protocol(format!("section {i}: view class {}", w.class))
            })?;
            Section::new(
                DVec3::from_array(w.origin),
                w.edges.map(DVec3::from_array),
                w.grid,
                class,
            )
            .map_err(|e| DisplayError::Protocol(format!("section {i}: {e}")))
        })
        .collect()
}

/// Packs samples into batches of at most about `max_bytes` each.
pub fn pack(beams: &[BeamSamples], max_bytes: usize) -> Vec<BeamBatch> {
    let mut out = vec![BeamBatch::default()];
    let mut rec = Vec::new();
    for b in beams {
        for chunk in b.samples.chunks((max_bytes / SAMPLE_RECORD_BYTES).max(1)) {
            if out.last().is_some_and(|l| {
                !l.is_empty() && l.len_bytes() + chunk.len() * SAMPLE_RECORD_BYTES > max_bytes
            }) {
                out.push(BeamBatch::default());
            }
            rec.clear();
            PackedSample::write_all(chunk, &mut rec);
            out.last_mut()
                .expect("never empty")
                .push(b.key.section, b.key.beam, &rec);
        }
    }
    out.retain(|b| !b.is_empty());
    out
}

/// Unpacks a batch.
pub fn unpack(batch: &BeamBatch) -> Result<Vec<BeamSamples>, RecordError> {
    Ok(batch
        .beams()?
        .into_iter()
        .map(|(s, b, rec)| {
            let mut samples = Vec::new();
            PackedSample::read_all(rec, &mut samples);
            BeamSamples {
                key: BeamKey::new(s, b),
                samples,
            }
        })
        .collect())
}

/// The request message as a display writes it.
pub fn request_message(req: EyeRequest) -> BeamRequest {
    let mut m = BeamRequest {
        slot: req.slot,
        eye: req.eye.map_or([0.0; 3], |e| e.pos.to_array()),
        radius: req.eye.map_or(0.0, |e| e.radius),
        wanted: Vec::with_capacity(req.wanted.len() * 10),
    };
    for (k, n) in req.wanted {
        m.push(k.section, k.beam, n as f32);
    }
    m
}

/// The request message as the server reads it.
pub fn eye_request(m: &BeamRequest) -> Result<EyeRequest, RecordError> {
    Ok(EyeRequest {
        slot: m.slot,
        eye: (m.radius > 0.0 && m.eye.iter().all(|v| v.is_finite())).then(|| EyeSphere {
            pos: DVec3::from_array(m.eye),
            radius: m.radius,
        }),
        wanted: m
            .beams()?
            .into_iter()
            .filter(|r| r.2.is_finite() && r.2 > 0.0)
            .map(|(s, b, n)| (BeamKey::new(s, b), f64::from(n)))
            .collect(),
    })
}

/// The welcome a display gets.
pub fn welcome(server: &Server, scene: &str) -> DisplayWelcome {
    DisplayWelcome {
        scene: scene.into(),
        sections: wire_sections(server.cache().file().sections()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam_index::BeamKey;

    #[test]
    fn packing_splits_big_beams_and_round_trips() {
        let s = |i: u8| PackedSample {
            rgbe: [i, 1, 2, 128],
            entry: [i, i],
            exit: [3, 4],
            dist: u16::from(i),
        };
        let beams = vec![
            BeamSamples {
                key: BeamKey::new(0, 5),
                samples: (0..50).map(s).collect(),
            },
            BeamSamples {
                key: BeamKey::new(1, 7),
                samples: (0..3).map(s).collect(),
            },
        ];
        let packed = pack(&beams, 200);
        assert!(packed.len() >= 3);
        assert!(packed.iter().all(|b| b.len_bytes() <= 200 + 10));
        let mut back: Vec<(BeamKey, PackedSample)> = Vec::new();
        for b in &packed {
            for bs in unpack(b).unwrap() {
                back.extend(bs.samples.iter().map(|x| (bs.key, *x)));
            }
        }
        let want: Vec<(BeamKey, PackedSample)> = beams
            .iter()
            .flat_map(|b| b.samples.iter().map(move |x| (b.key, *x)))
            .collect();
        assert_eq!(back, want);
    }
}
