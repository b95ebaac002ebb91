//! The BVH as the CPU traverses it: eight children per node, their boxes in full `f32`.
//!
//! obvhs collapses the binary tree to eight children per node (by the surface area
//! heuristic) and stores it compressed for GPUs: child boxes quantised to bytes, children
//! found by bit tricks. Decoding that per node was 88% of a Sponza primary ray on the CPU.
//! Here the same tree is unpacked once at build time: each node holds its eight child boxes
//! as plane arrays, so one ray meets all eight with a handful of four-wide SIMD operations
//! (glam's `Vec4` is SSE on x86-64), and each child says directly whether it is a node or
//! a leaf and where it lives. The boxes are recomputed exactly from the triangles, so they
//! are tighter than the quantised ones.

use glam::{Vec3A, Vec4};
use obvhs::cwbvh::CwBvh;

use super::triangle::IsectTriangle;

/// One child slot: an inner node, a leaf (a run of triangles in leaf order), or empty.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub(super) struct Child(pub(super) u32);

const LEAF: u32 = 1 << 31;
/// The most triangles in a leaf made from a node of leaves (see [`unpack`]).
const COLLAPSE: usize = 4;
const COUNT_SHIFT: u32 = 27;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

impl Child {
    pub const EMPTY: Child = Child(u32::MAX);

    pub fn node(index: u32) -> Child {
        debug_assert!(index < LEAF);
        Child(index)
    }

    /// `count` triangles (1 to 15) starting at leaf-order slot `first` while the tree is
    /// unpacked; once compacted, `count` lanes (1 to 4) of triangle block `first`.
    fn leaf(first: u32, count: u32) -> Child {
        debug_assert!((1..=15).contains(&count) && first <= FIRST_MASK);
        Child(LEAF | (count << COUNT_SHIFT) | first)
    }

    /// The node index, or `None` for a leaf.
    #[inline(always)]
    pub fn as_node(self) -> Option<usize> {
        (self.0 & LEAF == 0).then_some(self.0 as usize)
    }

    /// The leaf's triangle block and how many of its lanes hold triangles.
    #[inline(always)]
    pub fn leaf_block(self) -> (usize, usize) {
        let range = self.leaf_slots();
        (range.start, range.len())
    }

    /// The leaf's triangle slots (while unpacking; see [`Child::leaf_block`] after).
    #[inline(always)]
    fn leaf_slots(self) -> std::ops::Range<usize> {
        let first = (self.0 & FIRST_MASK) as usize;
        let count = ((self.0 & !LEAF) >> COUNT_SHIFT) as usize;
        first..first + count
    }
}

/// The direction's inverse for slab tests. A zero component becomes a tiny one of the
/// same sign: no `0 · ∞ = NaN` when the origin lies on a box plane, and a practically
/// infinite distance to planes the ray runs along.
pub(super) fn safe_inverse(dir: Vec3A) -> Vec3A {
    Vec3A::ONE / dir.abs().max(Vec3A::splat(1e-30)).copysign(dir)
}

/// A ray prepared for box tests against all eight children at once, from its origin and
/// [`safe_inverse`] direction.
pub(super) struct BoxRay {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Per axis, the plane row met first (0..3 for the minimum, 3..6 for the maximum),
    /// and the row met last.
    near: [usize; 3],
    far: [usize; 3],
}

/// Round-off guard for the slab test (Ize, "Robust BVH Ray Traversal", 2013): growing the
/// far distance by `1 + 2γ₃` keeps a box from being missed by a ray that grazes it.
pub(super) const FAR_GROWTH: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

impl BoxRay {
    pub fn new(origin: Vec3A, inv: Vec3A) -> Self {
        let near = |i: f32| if i >= 0.0 { 0 } else { 3 };
        let near = [near(inv.x), near(inv.y) + 1, near(inv.z) + 2];
        Self {
            origin: [
                Vec4::splat(origin.x),
                Vec4::splat(origin.y),
                Vec4::splat(origin.z),
            ],
            inv_dir: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near,
            far: near.map(|row| (row + 3) % 6),
        }
    }
}

/// A bundle of rays whose directions share an octant, prepared for one conservative box
/// test for all of them (interval arithmetic over their origins and inverse directions).
/// A box that this test misses is missed by every ray of the bundle; the entry distance it
/// gives is at most each ray's own.
pub(super) struct IntervalRay {
    /// Per axis: the origin that makes the entry distance smallest, and the one that makes
    /// the exit distance largest.
    origin_near: [Vec4; 3],
    origin_far: [Vec4; 3],
    /// Per axis: the inverse direction of smallest and of largest magnitude (same sign).
    inv_small: [Vec4; 3],
    inv_large: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl IntervalRay {
    /// The bundle of rays given by origin and [`safe_inverse`] direction, all in the
    /// octant of the first (the caller groups them so).
    pub fn new(rays: &[(Vec3A, Vec3A)]) -> Self {
        let (mut o_min, mut o_max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let (mut inv_small, mut inv_large) = (Vec3A::INFINITY, Vec3A::ZERO);
        for &(o, inv) in rays {
            debug_assert_eq!(inv.is_negative_bitmask(), rays[0].1.is_negative_bitmask());
            o_min = o_min.min(o);
            o_max = o_max.max(o);
            inv_small = inv_small.min(inv.abs());
            inv_large = inv_large.max(inv.abs());
        }
        let negative = rays.first().map_or(0, |r| r.1.is_negative_bitmask());
        let positive = |axis: usize| negative & (1 << axis) == 0;
        let sign = |axis: usize| if positive(axis) { 1.0 } else { -1.0 };
        let pick = |axis: usize, a: Vec3A, b: Vec3A| {
            Vec4::splat(if positive(axis) { a[axis] } else { b[axis] })
        };
        let signed = |axis: usize, magnitude: Vec3A| Vec4::splat(sign(axis) * magnitude[axis]);
        let near = |axis: usize| if positive(axis) { axis } else { axis + 3 };
        Self {
            // Entering a slab happens earliest from the origin furthest along the
            // direction, leaving it latest from the one furthest back.
            origin_near: [
                pick(0, o_max, o_min),
                pick(1, o_max, o_min),
                pick(2, o_max, o_min),
            ],
            origin_far: [
                pick(0, o_min, o_max),
                pick(1, o_min, o_max),
                pick(2, o_min, o_max),
            ],
            inv_small: [
                signed(0, inv_small),
                signed(1, inv_small),
                signed(2, inv_small),
            ],
            inv_large: [
                signed(0, inv_large),
                signed(1, inv_large),
                signed(2, inv_large),
            ],
            near: [near(0), near(1), near(2)],
            far: [(near(0) + 3) % 6, (near(1) + 3) % 6, (near(2) + 3) % 6],
        }
    }
}

/// A node: its eight children's boxes as six plane rows (min x, y, z, max x, y, z) of
/// eight lanes each, what each child is, and the order a ray meets them in.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct WideNode {
    pub planes: [[Vec4; 2]; 6],
    pub children: [Child; 8],
    /// For each octant of ray directions (bit 2 set for a negative x, bit 1 for y, bit 0
    /// for z), the slots from the one such a ray meets last to the one it meets first:
    /// lane `k`, bits `3·octant` to `3·octant + 2`, holds the slot met `k`-th from last.
    pub order: [u32; 8],
}

impl WideNode {
    pub(super) const EMPTY: WideNode = WideNode {
        // An empty slot's box is inverted (min +∞, max −∞): every ray misses it.
        planes: [
            [Vec4::INFINITY; 2],
            [Vec4::INFINITY; 2],
            [Vec4::INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
            [Vec4::NEG_INFINITY; 2],
        ],
        children: [Child::EMPTY; 8],
        order: [0; 8],
    };

    /// Fills [`WideNode::order`]: for each octant, the children sorted by their box's
    /// centre along the octant's diagonal. One slot layout cannot be in order for all
    /// eight octants (obvhs' layout, read as slot `k ^ octant`, let Sponza's primary rays
    /// test 2.7 leaves each where a sorted walk tests 1.6); eight stored orders can.
    /// tinybvh's `BVH8_CPU` stores eight orders too, by the box corner a ray enters at;
    /// by the centre, Sponza's rays visited fewer nodes and leaves (diffuse: 12.4 nodes and
    /// 2.7 leaves per ray against 12.7 and 3.0).
    fn set_order(&mut self) {
        self.order = [0; 8];
        for octant in 0..8 {
            let sign = |bit: usize| if octant & (1 << bit) != 0 { -1.0 } else { 1.0 };
            let dir = Vec3A::new(sign(2), sign(1), sign(0));
            let mut keys: [(f32, usize); 8] = std::array::from_fn(|slot| {
                if self.children[slot] == Child::EMPTY {
                    return (f32::INFINITY, slot);
                }
                let (min, max) = self.child_box(slot);
                (dir.dot(min + max), slot)
            });
            keys.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            for (lane, &(_, slot)) in keys.iter().enumerate() {
                self.order[lane] |= (slot as u32) << (3 * octant);
            }
        }
    }

    fn set_box(&mut self, slot: usize, min: Vec3A, max: Vec3A) {
        let (half, lane) = (slot / 4, slot % 4);
        for axis in 0..3 {
            self.planes[axis][half][lane] = min[axis];
            self.planes[axis + 3][half][lane] = max[axis];
        }
    }

    /// One child's box: minimum and maximum corner.
    #[inline(always)]
    pub fn child_box(&self, slot: usize) -> (Vec3A, Vec3A) {
        let (half, lane) = (slot / 4, slot % 4);
        let plane = |row: usize| self.planes[row][half][lane];
        (
            Vec3A::new(plane(0), plane(1), plane(2)),
            Vec3A::new(plane(3), plane(4), plane(5)),
        )
    }

    /// The node as one leaf, when all its children are leaves whose triangles lie next to
    /// each other, [`COLLAPSE`] at most.
    fn as_one_leaf(&self) -> Option<Child> {
        let (mut first, mut end, mut total) = (usize::MAX, 0, 0);
        for child in self.children.iter().filter(|c| **c != Child::EMPTY) {
            if child.as_node().is_some() {
                return None;
            }
            let slots = child.leaf_slots();
            (first, end, total) = (
                first.min(slots.start),
                end.max(slots.end),
                total + slots.len(),
            );
        }
        (total > 0 && total == end - first && total <= COLLAPSE)
            .then(|| Child::leaf(first as u32, total as u32))
    }

    /// Merges sibling leaves into one while that lowers the expected number of leaf
    /// tests (the surface area heuristic): two leaves whose triangles lie next to each
    /// other, [`COLLAPSE`] at most between them, whose common box has less surface than
    /// their two boxes together (a ray enters a box with a chance in proportion to its
    /// surface, and a block of four triangles costs one test, as one triangle does).
    /// obvhs' leaves hold three triangles at most; Sponza's held 1.6 on average, and
    /// 58 933 merges take its 176 658 leaves to about 118 000.
    fn merge_leaves(&mut self) {
        let half_area = |(min, max): (Vec3A, Vec3A)| {
            let e = (max - min).max(Vec3A::ZERO);
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        loop {
            let mut best: Option<(usize, usize, f32)> = None;
            for a in 0..8 {
                for b in 0..8 {
                    let (ca, cb) = (self.children[a], self.children[b]);
                    if a == b || ca == Child::EMPTY || cb == Child::EMPTY {
                        continue;
                    }
                    if ca.as_node().is_some() || cb.as_node().is_some() {
                        continue;
                    }
                    let (sa, sb) = (ca.leaf_slots(), cb.leaf_slots());
                    if sa.end != sb.start || sa.len() + sb.len() > COLLAPSE {
                        continue;
                    }
                    let (box_a, box_b) = (self.child_box(a), self.child_box(b));
                    let union = (box_a.0.min(box_b.0), box_a.1.max(box_b.1));
                    let gain = half_area(box_a) + half_area(box_b) - half_area(union);
                    if gain > 0.0 && best.is_none_or(|(_, _, g)| gain > g) {
                        best = Some((a, b, gain));
                    }
                }
            }
            let Some((a, b, _)) = best else {
                return;
            };
            let (box_a, box_b) = (self.child_box(a), self.child_box(b));
            let (sa, sb) = (self.children[a].leaf_slots(), self.children[b].leaf_slots());
            self.set_box(a, box_a.0.min(box_b.0), box_a.1.max(box_b.1));
            self.children[a] = Child::leaf(sa.start as u32, (sa.len() + sb.len()) as u32);
            self.set_box(b, Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            self.children[b] = Child::EMPTY;
        }
    }

    /// The box around all eight children.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let mut min = Vec3A::INFINITY;
        let mut max = Vec3A::NEG_INFINITY;
        for axis in 0..3 {
            for half in 0..2 {
                min[axis] = min[axis].min(self.planes[axis][half].min_element());
                max[axis] = max[axis].max(self.planes[axis + 3][half].max_element());
            }
        }
        (min, max)
    }

    /// Which children the ray enters before `tmax` (bit `i` for slot `i`), and where.
    #[inline(always)]
    pub fn intersect(&self, ray: &BoxRay, tmax: f32) -> (u32, [f32; 8]) {
        let mut mask = 0;
        let mut entry = [0.0; 8];
        for half in 0..2 {
            let slab = |row: usize, axis: usize| {
                (self.planes[row][half] - ray.origin[axis]) * ray.inv_dir[axis]
            };
            let t_near = slab(ray.near[0], 0)
                .max(slab(ray.near[1], 1))
                .max(slab(ray.near[2], 2).max(Vec4::ZERO));
            let t_far = slab(ray.far[0], 0)
                .min(slab(ray.far[1], 1))
                .min(slab(ray.far[2], 2))
                * FAR_GROWTH;
            let hit = t_near.cmple(t_far.min(Vec4::splat(tmax)));
            mask |= hit.bitmask() << (4 * half);
            entry[4 * half..4 * half + 4].copy_from_slice(&t_near.to_array());
        }
        (mask, entry)
    }
}

impl WideNode {
    /// Which children any ray of the bundle may enter before `tmax`, and a distance no
    /// larger than where any of them enters. Rounding cannot break the bound: the
    /// distances are monotonic in the origin and the inverse direction chosen.
    #[inline(always)]
    pub fn intersect_interval(&self, ray: &IntervalRay, tmax: f32) -> (u32, [f32; 8]) {
        let mut mask = 0;
        let mut entry = [0.0; 8];
        for half in 0..2 {
            // For a fixed offset to the plane the distance is monotonic in the inverse
            // direction, so its extremes over the bundle lie at the two ends.
            let entry_at = |axis: usize| {
                let d = self.planes[ray.near[axis]][half] - ray.origin_near[axis];
                (d * ray.inv_small[axis]).min(d * ray.inv_large[axis])
            };
            let exit_at = |axis: usize| {
                let d = self.planes[ray.far[axis]][half] - ray.origin_far[axis];
                (d * ray.inv_small[axis]).max(d * ray.inv_large[axis])
            };
            let t_near = entry_at(0)
                .max(entry_at(1))
                .max(entry_at(2).max(Vec4::ZERO));
            let t_far = exit_at(0).min(exit_at(1)).min(exit_at(2)) * FAR_GROWTH;
            let hit = t_near.cmple(t_far.min(Vec4::splat(tmax)));
            mask |= hit.bitmask() << (4 * half);
            entry[4 * half..4 * half + 4].copy_from_slice(&t_near.to_array());
        }
        (mask, entry)
    }
}

/// Unpacks obvhs' compressed tree over `triangles` (in its leaf order). Node 0 is the
/// root. Returns the nodes and the tree's depth.
///
/// A node whose children are all leaves, with [`COLLAPSE`] triangles or fewer between
/// them, becomes one leaf of its parent: its triangles are tested without first testing
/// their boxes, which on Sponza's primary rays is faster both for single rays (1.7 → 1.8
/// Mrays/s) and for packets (2.9 → 3.3 Mrays/s), where a leaf box is tested once per
/// group of four rays.
pub(super) fn unpack(
    cw: &CwBvh,
    triangles: &[IsectTriangle],
    block: impl FnMut(std::ops::Range<usize>) -> u32,
) -> (Vec<WideNode>, usize) {
    let mut nodes = vec![WideNode::EMPTY; cw.nodes.len()];
    // A compressed node's children come after it, so walking backwards meets every child
    // before its parent and each child node's bounds are ready when its parent needs them.
    let mut depth = vec![1usize; cw.nodes.len()];
    for (index, c) in cw.nodes.iter().enumerate().rev() {
        let mut node = WideNode::EMPTY;
        let mut inner = 0;
        for slot in 0..8 {
            let meta = c.child_meta[slot];
            if meta == 0 {
                continue;
            }
            if c.imask & (1 << slot) != 0 {
                let child = (c.child_base_idx + inner) as usize;
                inner += 1;
                let (min, max) = nodes[child].bounds();
                node.set_box(slot, min, max);
                node.children[slot] = match nodes[child].as_one_leaf() {
                    Some(leaf) => leaf,
                    None => {
                        depth[index] = depth[index].max(depth[child] + 1);
                        Child::node(child as u32)
                    }
                };
            } else {
                let first = c.primitive_base_idx + u32::from(meta & 0b1_1111);
                let count = u32::from(meta >> 5).count_ones();
                let (mut min, mut max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
                let mut pad = Vec3A::ZERO;
                for s in first..first + count {
                    let (lo, hi, p) = triangles[s as usize].bounds();
                    min = min.min(lo);
                    max = max.max(hi);
                    pad = pad.max(p);
                }
                // With spatial splits a leaf holds only the part of a triangle inside
                // the builder's clipped box for it (as obvhs stored it, rounded
                // outwards): the two boxes' overlap, grown by what the widened test
                // accepts beyond the triangle.
                let split = c.child_aabb(slot);
                node.set_box(slot, min.max(split.min - pad), max.min(split.max + pad));
                node.children[slot] = Child::leaf(first, count);
            }
        }
        node.merge_leaves();
        nodes[index] = node;
    }
    let depth = depth.first().copied().unwrap_or(0);
    (compact(&nodes, block), depth)
}

/// The nodes still reachable from the root (node 0) once small nodes became leaves,
/// renumbered breadth first, so that siblings lie next to each other. Each leaf's run of
/// triangle slots becomes one triangle block, numbered in the same order by `block`: a
/// leaf then names its block and how many of its lanes hold triangles.
fn compact(
    nodes: &[WideNode],
    mut block: impl FnMut(std::ops::Range<usize>) -> u32,
) -> Vec<WideNode> {
    let Some(root) = nodes.first() else {
        return Vec::new();
    };
    let mut kept = vec![*root];
    let mut next = 0;
    while next < kept.len() {
        let mut node = kept[next];
        for child in node.children.iter_mut() {
            if *child == Child::EMPTY {
                continue;
            }
            match child.as_node() {
                Some(old) => {
                    *child = Child::node(kept.len() as u32);
                    kept.push(nodes[old]);
                }
                None => {
                    let slots = child.leaf_slots();
                    *child = Child::leaf(block(slots.clone()), slots.len() as u32);
                }
            }
        }
        node.set_order();
        kept[next] = node;
        next += 1;
    }
    kept
}
