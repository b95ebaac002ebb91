//! What the crash tests store, as a known function of the beam and the index, so that a
//! reopened file can be checked sample by sample: the power-cut test (`power_cut.rs`), the
//! crash writer (`src/bin/holodeck-crash-writer.rs`) and the test that SIGKILLs it
//! (`tests/crash.rs`) include this file, each with `PackedSample` in scope.

use super::PackedSample;

/// The sample the writer stores at `index` of `beam`.
pub fn expected(beam: u32, index: u32) -> PackedSample {
    PackedSample {
        rgbe: [
            beam as u8,
            (beam >> 8) as u8,
            index as u8,
            (index >> 8) as u8,
        ],
        entry: [(index >> 16) as u8, (beam >> 16) as u8],
        exit: [0x5a, 0xa5],
        dist: (beam.wrapping_mul(31) ^ index.wrapping_mul(7)) as u16,
    }
}
