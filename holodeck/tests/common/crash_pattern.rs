//! What the crash writer stores, as a known function of the beam and the index: the
//! writer (`holodeck-crash-writer`) and the test that checks its files (`tests/crash.rs`)
//! both include this file.

use holocave_holodeck::sample::PackedSample;

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
