//! The summary's lines on the frames a `sim` run's walls presented: whether every wall
//! presented the same frames; then, with windows, how far apart they presented them, or
//! without, the unfolded CAVE's mosaics of the frames written.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use anyhow::Result;
use holocave_cave::{Unfolded, Wall};
use holocave_render_node::present::mosaic::write_mosaics;
use holocave_render_node::present::wall_windows::present_skew;

/// Where the frames went: windows, whose present times each node logged, or images
/// written every `every` frames.
pub enum ShownIn<'a> {
    Windows,
    Images { every: u64, unfolded: &'a Unfolded },
}

/// With windows, how far apart `walls` presented each frame; with images, the mosaics of
/// the frames written among those some wall presented (`all`). The lines to print.
pub fn shown(
    out: &Path,
    walls: &[Wall],
    shown: ShownIn,
    all: &BTreeSet<u64>,
) -> Result<Vec<String>> {
    let ShownIn::Images { every, unfolded } = shown else {
        let logs: Vec<(String, PathBuf)> = (walls.iter())
            .map(|w| (w.name.clone(), out.join(&w.name).join("present-times.log")))
            .collect();
        let skew = present_skew(&logs).map_err(|e| anyhow::anyhow!(e))?;
        let q = |p: f64| skew.quantile(p).unwrap_or(f64::NAN);
        return Ok(vec![format!(
            "present skew between the walls' windows over {} frames: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
            skew.spreads.len(),
            q(0.5),
            q(0.99),
            q(1.0)
        )]);
    };
    let written: Vec<u64> = all
        .iter()
        .copied()
        .filter(|f| f % every.max(1) == 0)
        .collect();
    let mosaics = write_mosaics(out, walls, unfolded, &written)?;
    let mut lines: Vec<String> = (mosaics.iter())
        .map(|p| format!("mosaic {}", p.display()))
        .collect();
    lines.push(format!(
        "{} mosaics in {}; frame states in {}; room → scene transforms in {}",
        mosaics.len(),
        out.join("mosaic").display(),
        out.join("states.bin").display(),
        out.join("navigation.csv").display()
    ));
    Ok(lines)
}

/// Whether every wall presented the same frames (`presented`), as lines; and the frames
/// some wall presented.
pub fn presented(presented: &BTreeMap<String, BTreeSet<u64>>) -> (Vec<String>, BTreeSet<u64>) {
    let all: BTreeSet<u64> = presented.values().flatten().copied().collect();
    let lines = if presented.values().all(|p| p.len() == all.len()) {
        vec![format!(
            "presented logs: identical on all {} walls ({} frames)",
            presented.len(),
            all.len()
        )]
    } else {
        (presented.iter())
            .map(|(wall, p)| {
                format!(
                    "presented logs: wall {wall} lacks {} of the {} frames some wall showed",
                    all.len() - p.len(),
                    all.len()
                )
            })
            .collect()
    };
    (lines, all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_that_missed_frames_is_named_with_how_many() {
        let mut walls = BTreeMap::new();
        walls.insert("front".to_owned(), BTreeSet::from([0, 1, 2]));
        walls.insert("floor".to_owned(), BTreeSet::from([0, 1, 2]));
        let (lines, all) = presented(&walls);
        assert_eq!(
            lines,
            ["presented logs: identical on all 2 walls (3 frames)"]
        );
        assert_eq!(all.len(), 3);
        walls.insert("left".to_owned(), BTreeSet::from([0, 2]));
        let (lines, _) = presented(&walls);
        assert!(
            lines.contains(
                &"presented logs: wall left lacks 1 of the 3 frames some wall showed".to_owned()
            ),
            "{lines:?}"
        );
    }
}
