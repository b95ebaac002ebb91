//! The BVH as the CPU traverses it: eight children per node, their boxes in full `f32`.
//!
//! Each node holds its eight child boxes as plane arrays, so one ray meets all eight with
//! a handful of SIMD operations, and each child says directly whether it is a node or a
//! leaf and where it lives ([`super::collapse`] makes them). The boxes are kept in full
//! precision: obvhs' compressed wide BVH, which quantises them to bytes for GPUs and finds
//! children by bit tricks, cost 88% of a Sponza primary ray in decoding on the CPU.

use glam::{Vec3A, Vec4};

/// One child slot: an inner node, a leaf (a run of triangles in leaf order), or empty.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub(super) struct Child(pub(super) u32);

const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 27;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

impl Child {
    pub const EMPTY: Child = Child(u32::MAX);

    pub fn node(index: u32) -> Child {
        debug_assert!(index < LEAF);
        Child(index)
    }

    /// A leaf: the first `count` lanes (1 to 4) of triangle block `first`.
    pub(super) fn leaf(first: u32, count: u32) -> Child {
        debug_assert!((1..=4).contains(&count) && first <= FIRST_MASK);
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
        let first = (self.0 & FIRST_MASK) as usize;
        let count = ((self.0 & !LEAF) >> COUNT_SHIFT) as usize;
        (first, count)
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
    pub(super) fn set_order(&mut self) {
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

    pub(super) fn set_box(&mut self, slot: usize, min: Vec3A, max: Vec3A) {
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
