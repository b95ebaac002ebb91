//! The BVH as flat 32-bit words, for walkers that live outside this crate (the render
//! node's GPU ray engine uploads these words to storage buffers as they are).
//!
//! Nothing is re-laid out: a [`FlatBvh`] is the very eight-wide tree and triangle blocks
//! the CPU walks, so a walker over it and [`Bvh::closest_hit`] meet the same boxes and the
//! same triangles and can only differ by the rounding of their arithmetic.

use super::Bvh;
use super::wide_node::{Child, WideNode};

/// Words per node in [`FlatBvh::nodes`].
pub const FLAT_NODE_WORDS: usize = 64;
/// Words per triangle slot in [`FlatBvh::triangles`].
pub const FLAT_TRIANGLE_WORDS: usize = 12;
/// A child word's bit for a leaf (clear for an inner node, whose word is its index).
pub const FLAT_LEAF: u32 = 1 << 31;
/// A leaf word's triangle count (1 to 4) sits at this bit, above the first block's index.
pub const FLAT_COUNT_SHIFT: u32 = 27;
/// An empty child slot's word.
pub const FLAT_EMPTY: u32 = u32::MAX;

/// The tree and its triangles as words.
///
/// - `nodes[i]`, node `i` (the root is node 0), 64 words: words `8 · row + slot`
///   (`row` 0 to 5) hold, as `f32` bits, child `slot`'s box: rows min x, min y, min z,
///   max x, max y, max z (an empty slot's box is inverted: +∞ minimum, −∞ maximum).
///   Words 48 + slot are the children: [`FLAT_EMPTY`], an inner node's index, or a leaf
///   `FLAT_LEAF | count << FLAT_COUNT_SHIFT | block` whose triangles are slots `4 · block`
///   to `4 · block + count − 1` of `triangles`. Words 56 + k: for each octant of ray
///   directions (bit 2 set for a negative x, bit 1 for y, bit 0 for z), bits `3 · octant`
///   to `3 · octant + 2` of word 56 + k name the slot such a ray meets k-th from last.
/// - `triangles[4 · block + lane]`, 12 words: the first vertex (`f32` x, y, z) and the
///   triangle's index in the caller's numbering (`u32`, `u32::MAX` in an unused lane),
///   then the first edge (x, y, z, 0) and the second edge (x, y, z, 0), as the CPU's
///   Möller–Trumbore test uses them. An unused lane is all zeros but its index.
pub struct FlatBvh {
    pub nodes: Vec<[u32; FLAT_NODE_WORDS]>,
    pub triangles: Vec<[u32; FLAT_TRIANGLE_WORDS]>,
    /// The most entries a walk that pushes every child it enters can hold: seven per
    /// level below the root's, and a node's eight at the deepest.
    pub stack_size: usize,
}

const _: () = {
    assert!(std::mem::size_of::<WideNode>() == 4 * FLAT_NODE_WORDS);
    assert!(Child::EMPTY.0 == FLAT_EMPTY);
};

impl Bvh {
    /// The tree and its triangles as words (see [`FlatBvh`]).
    pub fn flat(&self) -> FlatBvh {
        let nodes = self
            .nodes
            .iter()
            .map(|node| {
                let mut words = [0u32; FLAT_NODE_WORDS];
                for (row, halves) in node.planes.iter().enumerate() {
                    for (half, lanes) in halves.iter().enumerate() {
                        for lane in 0..4 {
                            words[8 * row + 4 * half + lane] = lanes[lane].to_bits();
                        }
                    }
                }
                for slot in 0..8 {
                    words[48 + slot] = node.children[slot].0;
                    words[56 + slot] = node.order[slot];
                }
                words
            })
            .collect();
        let mut triangles = Vec::with_capacity(4 * self.blocks.len());
        for block in &self.blocks {
            for lane in 0..4 {
                let tri = block.lane(lane);
                let mut words = [0u32; FLAT_TRIANGLE_WORDS];
                for axis in 0..3 {
                    words[axis] = tri.v0[axis].to_bits();
                    words[4 + axis] = tri.e1[axis].to_bits();
                    words[8 + axis] = tri.e2[axis].to_bits();
                }
                words[3] = block.ids[lane];
                triangles.push(words);
            }
        }
        FlatBvh {
            nodes,
            triangles,
            stack_size: self.stack_size,
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn every_triangle_is_in_the_words_and_every_leaf_points_at_its_lanes() {
        let tris: Vec<[Vec3; 3]> = (0..300)
            .map(|i| {
                let c = Vec3::new((i % 7) as f32, (i % 11) as f32 * 0.5, (i / 7) as f32 * 0.3);
                [c, c + Vec3::X * 0.4, c + Vec3::Y * 0.4]
            })
            .collect();
        let flat = Bvh::build(&tris).flat();
        let mut seen = vec![false; tris.len()];
        for node in &flat.nodes {
            for &child in &node[48..56] {
                if child == FLAT_EMPTY || child & FLAT_LEAF == 0 {
                    continue;
                }
                let count = (child & !FLAT_LEAF) >> FLAT_COUNT_SHIFT;
                let block = child & ((1 << FLAT_COUNT_SHIFT) - 1);
                for lane in 0..count {
                    let words = flat.triangles[(4 * block + lane) as usize];
                    let id = words[3] as usize;
                    let v0 = Vec3::new(
                        f32::from_bits(words[0]),
                        f32::from_bits(words[1]),
                        f32::from_bits(words[2]),
                    );
                    assert_eq!(v0, tris[id][0]);
                    seen[id] = true;
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
    }
}
