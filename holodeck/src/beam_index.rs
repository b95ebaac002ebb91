//! Dense beam numbering (paper §2.1). A beam is an ordered pair (entry cell, exit cell) of
//! cells on two *different* walls. Beams are numbered by entry wall, then entry cell, then
//! exit cell among the cells not on the entry wall, so every index below the count is a
//! beam and the count is `N = 2W²D² + 2W²H² + 2D²H² + 8W²DH + 8WD²H + 8WDH²`.

/// Identifies a beam in the holodeck: the section it belongs to and its number within that
/// section's [`BeamIndex`]. Ordered by section, then beam.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BeamKey {
    /// The section's number.
    pub section: u16,
    /// The beam's number within the section.
    pub beam: u32,
}

impl BeamKey {
    /// The key of beam `beam` of section `section`.
    pub const fn new(section: u16, beam: u32) -> Self {
        Self { section, beam }
    }
}

/// A cell on one wall: the wall number (0..6) and the cell's row along the wall's two axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    pub wall: u8,
    pub u: u32,
    pub v: u32,
}

/// A grid with more beams than a `u32` numbers.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("section grid {grid:?} has {beams} beams, more than the {max} a section can index")]
pub struct TooManyBeams {
    pub grid: [u32; 3],
    pub beams: u64,
    pub max: u64,
}

/// Beam numbering for one grid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BeamIndex {
    grid: [u32; 3],
    /// Cells per wall.
    cells: [u64; 6],
    /// First global cell number of each wall.
    cell_start: [u64; 6],
    /// First beam number of each entry wall.
    beam_start: [u64; 7],
    total_cells: u64,
}

impl BeamIndex {
    /// The numbering for a `W × D × H` grid; fails if the count does not fit a `u32`.
    pub fn new(grid: [u32; 3]) -> Result<Self, TooManyBeams> {
        let g = grid.map(u64::from);
        let per_axis = [g[1] * g[2], g[2] * g[0], g[0] * g[1]];
        let cells: [u64; 6] = std::array::from_fn(|w| per_axis[w / 2]);
        let total_cells: u64 = cells.iter().sum();
        let mut cell_start = [0; 6];
        let mut beam_start = [0; 7];
        for w in 0..6 {
            if w > 0 {
                cell_start[w] = cell_start[w - 1] + cells[w - 1];
            }
            beam_start[w + 1] = beam_start[w] + cells[w] * (total_cells - cells[w]);
        }
        let beams = beam_start[6];
        if beams > u64::from(u32::MAX) {
            return Err(TooManyBeams {
                grid,
                beams,
                max: u64::from(u32::MAX),
            });
        }
        Ok(Self {
            grid,
            cells,
            cell_start,
            beam_start,
            total_cells,
        })
    }

    /// The paper's closed form.
    pub fn count(grid: [u32; 3]) -> u64 {
        let [w, d, h] = grid.map(u64::from);
        2 * w * w * d * d
            + 2 * w * w * h * h
            + 2 * d * d * h * h
            + 8 * w * w * d * h
            + 8 * w * d * d * h
            + 8 * w * d * h * h
    }

    /// Number of beams.
    pub fn beams(&self) -> u32 {
        self.beam_start[6] as u32
    }

    fn wall_dims(&self, wall: u8) -> [u32; 2] {
        let a = usize::from(wall / 2);
        [self.grid[(a + 1) % 3], self.grid[(a + 2) % 3]]
    }

    fn global(&self, c: Cell) -> Option<u64> {
        let [gu, gv] = self.wall_dims(c.wall);
        (c.wall < 6 && c.u < gu && c.v < gv).then(|| {
            self.cell_start[usize::from(c.wall)] + u64::from(c.u) * u64::from(gv) + u64::from(c.v)
        })
    }

    fn cell_of(&self, global: u64) -> Cell {
        let w = (0..6)
            .rev()
            .find(|&w| self.cell_start[w] <= global)
            .expect("cell_start[0] = 0");
        let local = global - self.cell_start[w];
        let [_, gv] = self.wall_dims(w as u8);
        Cell {
            wall: w as u8,
            u: (local / u64::from(gv)) as u32,
            v: (local % u64::from(gv)) as u32,
        }
    }

    /// The beam from `entry` to `exit`; `None` if a cell is off the grid or both are on one
    /// wall.
    pub fn beam(&self, entry: Cell, exit: Cell) -> Option<u32> {
        if entry.wall == exit.wall {
            return None;
        }
        let (a, b) = (self.global(entry)?, self.global(exit)?);
        let w = usize::from(entry.wall);
        let local = a - self.cell_start[w];
        let rank = if b < self.cell_start[w] {
            b
        } else {
            b - self.cells[w]
        };
        Some((self.beam_start[w] + local * (self.total_cells - self.cells[w]) + rank) as u32)
    }

    /// The (entry, exit) cells of a beam; `None` past the count.
    pub fn cells(&self, beam: u32) -> Option<(Cell, Cell)> {
        let b = u64::from(beam);
        if b >= self.beam_start[6] {
            return None;
        }
        let w = (0..6)
            .rev()
            .find(|&w| self.beam_start[w] <= b)
            .expect("beam_start[0] = 0");
        let q = b - self.beam_start[w];
        let others = self.total_cells - self.cells[w];
        let (local, rank) = (q / others, q % others);
        let exit = if rank < self.cell_start[w] {
            rank
        } else {
            rank + self.cells[w]
        };
        Some((self.cell_of(self.cell_start[w] + local), self.cell_of(exit)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn count_matches_formula_for_many_grids() {
        for w in 1..=12 {
            for d in 1..=12 {
                for h in [1, 2, 3, 5, 8, 13, 24] {
                    let idx = BeamIndex::new([w, d, h]).unwrap();
                    assert_eq!(
                        u64::from(idx.beams()),
                        BeamIndex::count([w, d, h]),
                        "{w}x{d}x{h}"
                    );
                }
            }
        }
    }

    #[test]
    fn indexing_is_dense_and_invertible() {
        for grid in [[1, 1, 1], [2, 3, 4], [5, 1, 2], [4, 4, 4]] {
            let idx = BeamIndex::new(grid).unwrap();
            let mut seen = vec![false; idx.beams() as usize];
            for b in 0..idx.beams() {
                let (e, x) = idx.cells(b).unwrap();
                assert_ne!(e.wall, x.wall);
                let back = idx.beam(e, x).unwrap();
                assert_eq!(back, b, "{grid:?}");
                assert!(!seen[b as usize]);
                seen[b as usize] = true;
            }
            assert!(idx.cells(idx.beams()).is_none());
        }
    }

    #[test]
    fn rejects_same_wall_and_off_grid_cells() {
        let idx = BeamIndex::new([2, 2, 2]).unwrap();
        let c = Cell {
            wall: 0,
            u: 0,
            v: 0,
        };
        assert!(
            idx.beam(
                c,
                Cell {
                    wall: 0,
                    u: 1,
                    v: 1
                }
            )
            .is_none()
        );
        assert!(
            idx.beam(
                c,
                Cell {
                    wall: 3,
                    u: 2,
                    v: 0
                }
            )
            .is_none()
        );
        assert!(
            idx.beam(
                c,
                Cell {
                    wall: 6,
                    u: 0,
                    v: 0
                }
            )
            .is_none()
        );
    }
}
