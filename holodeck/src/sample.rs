//! The 10-byte ray sample (paper §2.1, Table 1): RGBE colour (4 bytes), entry and exit
//! positions within their cells (one byte per axis, 2 + 2 bytes), and the distance from
//! the entry point (2 bytes, [`crate::distance_code`]). On disk and in memory the record is
//! exactly these 10 bytes in this order, the distance little-endian.

use crate::rgbe::Rgbe;

/// Bytes per sample record.
pub const SAMPLE_BYTES: usize = 10;

/// One stored ray sample: the paper's packed 10-byte record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct PackedSample {
    /// Radiance, RGBE.
    pub rgbe: Rgbe,
    /// Position within the entry cell, 1/256 of the cell per step, per wall axis.
    pub entry: [u8; 2],
    /// Position within the exit cell.
    pub exit: [u8; 2],
    /// Distance code (section-relative; see [`crate::distance_code::DistanceCode`]).
    pub dist: u16,
}

impl PackedSample {
    /// The record as stored.
    pub fn to_bytes(&self) -> [u8; SAMPLE_BYTES] {
        let d = self.dist.to_le_bytes();
        [
            self.rgbe[0],
            self.rgbe[1],
            self.rgbe[2],
            self.rgbe[3],
            self.entry[0],
            self.entry[1],
            self.exit[0],
            self.exit[1],
            d[0],
            d[1],
        ]
    }

    /// Parses one record.
    pub fn from_bytes(b: &[u8; SAMPLE_BYTES]) -> Self {
        Self {
            rgbe: [b[0], b[1], b[2], b[3]],
            entry: [b[4], b[5]],
            exit: [b[6], b[7]],
            dist: u16::from_le_bytes([b[8], b[9]]),
        }
    }

    /// Appends the records of `samples` to `out`.
    pub fn write_all(samples: &[PackedSample], out: &mut Vec<u8>) {
        out.reserve(samples.len() * SAMPLE_BYTES);
        for s in samples {
            out.extend_from_slice(&s.to_bytes());
        }
    }

    /// Parses consecutive records (`bytes.len()` must be a multiple of 10; a trailing
    /// partial record is ignored, callers check lengths first).
    pub fn read_all(bytes: &[u8], out: &mut Vec<PackedSample>) {
        out.reserve(bytes.len() / SAMPLE_BYTES);
        out.extend(
            bytes.chunks_exact(SAMPLE_BYTES).map(|c| {
                PackedSample::from_bytes(c.try_into().expect("chunks_exact gives 10 bytes"))
            }),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn bytes_round_trip(rgbe in any::<[u8; 4]>(), entry in any::<[u8; 2]>(), exit in any::<[u8; 2]>(), dist in any::<u16>()) {
            let s = PackedSample { rgbe, entry, exit, dist };
            prop_assert_eq!(PackedSample::from_bytes(&s.to_bytes()), s);
            let mut v = Vec::new();
            PackedSample::write_all(&[s, s], &mut v);
            prop_assert_eq!(v.len(), 20);
            let mut back = Vec::new();
            PackedSample::read_all(&v, &mut back);
            prop_assert_eq!(back, vec![s, s]);
        }
    }

    #[test]
    fn layout_is_little_endian() {
        let s = PackedSample {
            rgbe: [1, 2, 3, 4],
            entry: [5, 6],
            exit: [7, 8],
            dist: 0x0a09,
        };
        assert_eq!(s.to_bytes(), [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
    }
}
