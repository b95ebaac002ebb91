//! `holodeck info`: sections, beams, samples, bytes, fragmentation and a histogram of
//! samples per beam.

use std::fmt;

use super::HoloFile;
use crate::sample::SAMPLE_BYTES;
use crate::section::ViewClass;

/// Statistics of one file.
#[derive(Debug)]
pub struct Info {
    pub sections: Vec<SectionInfo>,
    pub file_bytes: u64,
    pub sample_bytes: u64,
    pub free_bytes: u64,
    pub free_extents: usize,
    /// Commit sequence number.
    pub seq: u64,
    /// `(lowest count, highest count, beams)`: buckets 0, 1, 2–3, 4–7, …
    pub histogram: Vec<(u64, u64, u64)>,
}

#[derive(Debug)]
pub struct SectionInfo {
    pub grid: [u32; 3],
    pub class: ViewClass,
    pub size: f64,
    pub beams: u32,
    pub beams_filled: u64,
    pub samples: u64,
}

impl Info {
    pub fn of(h: &HoloFile) -> Info {
        let mut hist = vec![0u64; 34];
        let mut sections = Vec::new();
        let mut total = 0;
        for (si, s) in h.sections().iter().enumerate() {
            let (mut filled, mut samples) = (0, 0);
            for e in h.directory(si) {
                let c = u64::from(e.count);
                samples += c;
                filled += u64::from(c > 0);
                hist[if c == 0 { 0 } else { 1 + c.ilog2() as usize }] += 1;
            }
            total += samples;
            sections.push(SectionInfo {
                grid: s.grid(),
                class: s.class(),
                size: s.size(),
                beams: s.beam_count(),
                beams_filled: filled,
                samples,
            });
        }
        let free = h.free_extents();
        let histogram = hist
            .iter()
            .enumerate()
            .filter(|(_, n)| **n > 0)
            .map(|(i, &n)| {
                if i == 0 {
                    (0, 0, n)
                } else {
                    (1 << (i - 1), (1 << i) - 1, n)
                }
            })
            .collect();
        Info {
            sections,
            file_bytes: h.file.file().metadata().map_or(0, |m| m.len()),
            sample_bytes: total * SAMPLE_BYTES as u64,
            free_bytes: free.iter().map(|e| e.len).sum(),
            free_extents: free.len(),
            seq: h.seq(),
            histogram,
        }
    }

    /// Free space as a fraction of the file.
    pub fn fragmentation(&self) -> f64 {
        self.free_bytes as f64 / self.file_bytes.max(1) as f64
    }
}

impl fmt::Display for Info {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.sections.iter().enumerate() {
            writeln!(
                f,
                "section {i}: {:?} grid {}x{}x{}, size {:.3} m, {} beams, {} filled, {} samples",
                s.class,
                s.grid[0],
                s.grid[1],
                s.grid[2],
                s.size,
                s.beams,
                s.beams_filled,
                s.samples
            )?;
        }
        let samples: u64 = self.sections.iter().map(|s| s.samples).sum();
        writeln!(
            f,
            "commit {}, {} samples, {} sample bytes, file {} bytes",
            self.seq, samples, self.sample_bytes, self.file_bytes
        )?;
        writeln!(
            f,
            "free space {} bytes in {} fragments ({:.1}% of the file)",
            self.free_bytes,
            self.free_extents,
            100.0 * self.fragmentation()
        )?;
        writeln!(f, "samples per beam:")?;
        let max = self.histogram.iter().map(|h| h.2).max().unwrap_or(1);
        for &(lo, hi, n) in &self.histogram {
            let bar = "#".repeat(((n as f64 / max as f64) * 40.0).ceil() as usize);
            let range = if lo == hi {
                format!("{lo}")
            } else {
                format!("{lo}-{hi}")
            };
            writeln!(f, "  {range:>13} {n:>9} {bar}")?;
        }
        Ok(())
    }
}
