//! The single-ray walks with AVX2 and FMA, chosen at run time where the CPU has them:
//! closest hit and any hit (occlusion).
//!
//! The portable walk ([`super::Bvh`]'s) tests a node's eight boxes in two four-wide halves
//! and sorts the children it enters by distance; on Sponza that bookkeeping was half of a
//! ray's time. Here, as in tinybvh's `BVH8_CPU` kernel, one eight-wide pass tests all
//! eight boxes, and the children entered are ordered without sorting: each node stores,
//! for each of the eight octants of ray directions, the order a ray of that octant meets
//! its children in ([`WideNode::order`]). One permutation puts the entered children in
//! the ray's octant's order, farthest first, a second packs them together, and two stores
//! push them all; the nearest is taken next. The any-hit
//! walk skips the ordering and the distances: it packs and pushes in slot order. The box
//! test is a slab test of one fused multiply-subtract per plane, eight lanes at once, with
//! a rounding guard of its own ([`BoxRay8`]): it may enter a box by a few ulps more than
//! the portable test, never less, so no triangle the portable walk reaches is skipped.
//! The closest-hit and occlusion walks test a leaf's four triangles themselves
//! ([`leaf_hits`], with fused multiply-adds), so their hits equal the portable walk's to
//! within Möller–Trumbore's rounding. The bottom of the stack holds an end marker
//! ([`END`]), so a pop needs no test for an empty stack.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use glam::Vec3A;

use super::triangle::{EDGE_TOLERANCE, TriangleBlock};
use super::usable;
use super::wide_node::{Child, FAR_GROWTH, WideNode, safe_inverse};
use crate::ray::Ray;

/// The deepest stack the walks keep on the thread's stack: a tree deeper than
/// `(STACK - 8) / 7` levels is walked by the portable code.
pub(super) const STACK: usize = 256;

/// The entry at the bottom of a walk's stack (below its [`STACK`] entries): popping it
/// ends the walk, so the pops need no test for an empty stack. No tree has it as a child
/// (a leaf of 15 triangles at slot 2^27 − 2).
const END: Child = Child(u32::MAX - 1);

// The loads below read a node's plane row as eight contiguous f32 at a 32-byte boundary,
// and its children as eight u32.
const _: () = assert!(std::mem::size_of::<[glam::Vec4; 2]>() == 32);
const _: () = assert!(std::mem::align_of::<WideNode>() >= 32);
const _: () = assert!(std::mem::size_of::<[Child; 8]>() == 32);
const _: () = assert!(std::mem::offset_of!(WideNode, order) % 32 == 0);

/// For each 8-bit mask, the lanes set, lowest first, then zeros: a permutation that packs
/// the chosen lanes at the front.
static PACK: [[u32; 8]; 256] = pack_table();

const fn pack_table() -> [[u32; 8]; 256] {
    let mut table = [[0u32; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut lane, mut n) = (0, 0);
        while lane < 8 {
            if mask & (1 << lane) != 0 {
                table[mask][n] = lane as u32;
                n += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
}

/// Proof that the CPU runs AVX2, FMA and the bit instructions the walks use: only
/// [`Kernel::detect`] makes one.
#[derive(Clone, Copy, Debug)]
pub(super) struct Kernel(());

/// Calls `walk::<OCTANT>(args)` for the octant of the inverse direction `inv`: each octant
/// has its own copy of a walk, with the plane rows it reads and the shift of its orders
/// fixed when compiled. The match reads the direction's sign bits as they come (bit 0 for
/// x) and names each arm's octant as [`WideNode::order`] numbers them (bit 2 for x, bit 0
/// for z), so the jump table does the reordering.
macro_rules! for_octant {
    ($inv:expr, $walk:ident($($arg:expr),*)) => {
        match $inv.is_negative_bitmask() {
            0 => $walk::<0>($($arg),*),
            1 => $walk::<4>($($arg),*),
            2 => $walk::<2>($($arg),*),
            3 => $walk::<6>($($arg),*),
            4 => $walk::<1>($($arg),*),
            5 => $walk::<5>($($arg),*),
            6 => $walk::<3>($($arg),*),
            _ => $walk::<7>($($arg),*),
        }
    };
}

impl Kernel {
    /// The kernel, where the CPU has AVX2, FMA and the bit instructions that come with them
    /// (BMI1, LZCNT, POPCNT: one instruction each for counting and finding lanes)
    /// (`HOLOCAVE_NO_AVX2` set in the environment
    /// turns it off, to compare the two walks).
    pub fn detect() -> Option<Kernel> {
        (is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("lzcnt")
            && is_x86_feature_detected!("popcnt")
            && std::env::var_os("HOLOCAVE_NO_AVX2").is_none())
        .then_some(Kernel(()))
    }

    /// The closest hit of `ray` with `t < tmax` among the triangles of `blocks`, as
    /// `finish(slot, t, u, v)` with slot `4 · block + lane`; `None` also for a ray that
    /// cannot hit anything ([`usable`]). `nodes` must be no deeper than the [`STACK`]
    /// allows.
    #[inline(always)]
    pub fn closest_hit<H>(
        self,
        nodes: &[WideNode],
        blocks: &[TriangleBlock],
        ray: &Ray,
        tmax: f32,
        finish: impl FnOnce(usize, f32, f32, f32) -> H,
    ) -> Option<H> {
        // SAFETY: a Kernel exists only where the CPU has AVX2, FMA and the bit instructions.
        unsafe { closest_hit(nodes, blocks, ray, tmax, finish) }
    }

    /// Whether any triangle of `blocks` lies on the ray before `tmax` (the ray as for
    /// [`Kernel::closest_hit`]).
    #[inline(always)]
    pub fn occluded(
        self,
        nodes: &[WideNode],
        blocks: &[TriangleBlock],
        ray: &Ray,
        tmax: f32,
    ) -> bool {
        // SAFETY: a Kernel exists only where the CPU has AVX2, FMA and the bit instructions.
        unsafe { occluded(nodes, blocks, ray, tmax) }
    }

    /// Visits the leaves the ray enters before `tmax`, in no particular order, until
    /// `leaf(block)` returns true (then returns true). No ordering, no distances kept:
    /// what the list of all hits needs. `nodes` as for [`Kernel::closest_hit`].
    #[inline(always)]
    pub fn any_order(
        self,
        nodes: &[WideNode],
        origin: Vec3A,
        inv: Vec3A,
        tmax: f32,
        leaf: impl FnMut(usize) -> bool,
    ) -> bool {
        // SAFETY: a Kernel exists only where the CPU has AVX2, FMA and the bit instructions.
        unsafe { for_octant!(inv, any_order(nodes, origin, inv, tmax, leaf)) }
    }
}

/// A ray prepared for the eight-wide slab test: per axis the inverse direction and the
/// origin's offset `origin · inv` for the planes it enters a box through and for those it
/// leaves through.
///
/// A plane's distance is one fused multiply-subtract, `plane · inv − origin · inv`, instead
/// of the portable test's `(plane − origin) · inv`. Its error is then not only relative to
/// the distance (what [`FAR_GROWTH`] absorbs) but also the rounding of `origin · inv`,
/// which is absolute: a ray starting on a box plane far from the scene's origin could get
/// an entry distance past its exit. The offsets carry a guard of two float steps of the
/// product, `2 ε |origin · inv|`, against at most half a step of rounding in it and half a
/// step in adding the guard: the entry planes subtract an offset that much too large and
/// the exit planes one that much too small, so no box the ray meets is missed (test below). In
/// space the boxes grow by about two ulps of the origin's coordinates, the precision the
/// origin has anyway.
struct BoxRay8 {
    inv: [__m256; 3],
    offset_near: [__m256; 3],
    offset_far: [__m256; 3],
}

impl BoxRay8 {
    #[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
    fn new(origin: Vec3A, inv: Vec3A) -> Self {
        // An offset too large for f32 (an origin 10^8 away with a direction along a
        // plane) leaves that axis unconstrained rather than wrong.
        let product = origin * inv;
        let guard = product.abs() * (2.0 * f32::EPSILON);
        let finite_or = |offset: Vec3A, overflow: f32| {
            let offset = Vec3A::select(offset.is_finite_mask(), offset, Vec3A::splat(overflow));
            [0, 1, 2].map(|axis| _mm256_set1_ps(offset[axis]))
        };
        Self {
            inv: [0, 1, 2].map(|axis| _mm256_set1_ps(inv[axis])),
            offset_near: finite_or(product + guard, f32::INFINITY),
            offset_far: finite_or(product - guard, f32::NEG_INFINITY),
        }
    }

    /// The children the ray enters before `bound` (all bits set in a lane entered), and
    /// where it enters each, eight lanes at once. `OCTANT` is the ray's octant (see
    /// [`for_octant`]).
    ///
    /// # Safety
    /// The CPU has AVX2, FMA and the bit instructions.
    #[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
    #[inline]
    unsafe fn enter<const OCTANT: usize>(&self, node: &WideNode, bound: f32) -> (__m256, __m256) {
        // Per axis, the plane row a ray of the octant enters through (the minimum, or the
        // maximum for a negative direction), and the row it leaves through.
        let near = |axis: usize| axis + 3 * ((OCTANT >> (2 - axis)) & 1);
        let far = |axis: usize| (near(axis) + 3) % 6;
        let planes = node.planes.as_ptr() as *const f32;
        // SAFETY: each of the six plane rows is eight f32, 32-byte aligned.
        let slab = |row: usize, axis: usize, offset: __m256| unsafe {
            let plane = _mm256_load_ps(planes.add(8 * row));
            _mm256_fmsub_ps(plane, self.inv[axis], offset)
        };
        let entry = |axis: usize| slab(near(axis), axis, self.offset_near[axis]);
        let exit = |axis: usize| slab(far(axis), axis, self.offset_far[axis]);
        let t_near = _mm256_max_ps(
            _mm256_max_ps(entry(0), entry(1)),
            _mm256_max_ps(entry(2), _mm256_setzero_ps()),
        );
        let t_far = _mm256_mul_ps(
            _mm256_min_ps(_mm256_min_ps(exit(0), exit(1)), exit(2)),
            _mm256_set1_ps(FAR_GROWTH),
        );
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t_near, _mm256_min_ps(t_far, _mm256_set1_ps(bound)));
        (hit, t_near)
    }
}

/// The permutation that packs the lanes set in `mask` (8 bits) at the front, lowest first.
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
fn packing(mask: usize) -> __m256i {
    // SAFETY: a table row is eight u32 (an unaligned load).
    unsafe { _mm256_loadu_si256(PACK[mask].as_ptr() as *const __m256i) }
}

/// Writes the node's eight children, permuted by `pick`, at `top` of a walk's stack.
///
/// # Safety
/// The CPU has AVX2, FMA and the bit instructions, and `top` has room for eight entries.
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
unsafe fn push_children(top: *mut MaybeUninit<u32>, node: &WideNode, pick: __m256i) {
    // SAFETY: the children are eight u32 (see the layout checks above); the caller
    // vouches for the room.
    unsafe {
        let slots = _mm256_loadu_si256(node.children.as_ptr() as *const __m256i);
        _mm256_storeu_si256(
            top as *mut __m256i,
            _mm256_permutevar8x32_epi32(slots, pick),
        );
    }
}

/// A ray spread over four lanes for [`leaf_hits`].
struct LeafRay {
    origin: [__m128; 3],
    dir: [__m128; 3],
}

impl LeafRay {
    #[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
    fn new(origin: Vec3A, dir: Vec3A) -> Self {
        Self {
            origin: [0, 1, 2].map(|axis| _mm_set1_ps(origin[axis])),
            dir: [0, 1, 2].map(|axis| _mm_set1_ps(dir[axis])),
        }
    }
}

/// Möller–Trumbore for a block's four triangles, as [`super::triangle::intersect4`] but
/// with fused multiply-adds: `t`, `u`, `v` and the lanes hit before `tmax` (all bits set).
/// The fused products round once where the portable test rounds twice, so the two may
/// differ in the last bits of `t`, `u` and `v` (and so on a hit within a few ulps of
/// an edge's tolerance); both are the same test, within its rounding.
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
fn leaf_hits(block: &TriangleBlock, ray: &LeafRay, tmax: f32) -> [__m128; 4] {
    let row = |rows: &[glam::Vec4; 3]| rows.map(__m128::from);
    let ([e1x, e1y, e1z], [e2x, e2y, e2z], v0) = (row(&block.e1), row(&block.e2), row(&block.v0));
    let [dx, dy, dz] = ray.dir;
    // a·b − c·d with one rounding for the first product.
    let cross = |a, b, c, d| _mm_fmsub_ps(a, b, _mm_mul_ps(c, d));
    let dot = |a: [__m128; 3], b: [__m128; 3]| {
        _mm_fmadd_ps(a[2], b[2], _mm_fmadd_ps(a[1], b[1], _mm_mul_ps(a[0], b[0])))
    };
    let p = [
        cross(dy, e2z, dz, e2y),
        cross(dz, e2x, dx, e2z),
        cross(dx, e2y, dy, e2x),
    ];
    let inv = _mm_div_ps(_mm_set1_ps(1.0), dot([e1x, e1y, e1z], p));
    let [sx, sy, sz] = [0, 1, 2].map(|axis| _mm_sub_ps(ray.origin[axis], v0[axis]));
    let u = _mm_mul_ps(dot([sx, sy, sz], p), inv);
    let q = [
        cross(sy, e1z, sz, e1y),
        cross(sz, e1x, sx, e1z),
        cross(sx, e1y, sy, e1x),
    ];
    let v = _mm_mul_ps(dot(ray.dir, q), inv);
    let t = _mm_mul_ps(dot([e2x, e2y, e2z], q), inv);
    // Ordered comparisons: a NaN anywhere (a zero determinant, an unused lane) misses.
    let (low, high) = (
        _mm_set1_ps(-EDGE_TOLERANCE),
        _mm_set1_ps(1.0 + EDGE_TOLERANCE),
    );
    let hit = _mm_and_ps(
        _mm_and_ps(
            _mm_cmp_ps::<_CMP_GE_OQ>(u, low),
            _mm_cmp_ps::<_CMP_GE_OQ>(v, low),
        ),
        _mm_and_ps(
            _mm_and_ps(
                _mm_cmp_ps::<_CMP_LE_OQ>(u, high),
                _mm_cmp_ps::<_CMP_LE_OQ>(_mm_add_ps(u, v), high),
            ),
            _mm_and_ps(
                _mm_cmp_ps::<_CMP_GE_OQ>(t, _mm_setzero_ps()),
                _mm_cmp_ps::<_CMP_LT_OQ>(t, _mm_set1_ps(tmax)),
            ),
        ),
    );
    [t, u, v, hit]
}

/// The lane of the nearest hit among the lanes set in `hit`, and its distance (as
/// [`super::triangle::BlockHits::nearest`], in registers).
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
fn nearest_lane(t: __m128, hit: __m128) -> Option<(usize, f32)> {
    let lanes = _mm_movemask_ps(hit) as u32;
    if lanes == 0 {
        return None;
    }
    let t = _mm_blendv_ps(_mm_set1_ps(f32::INFINITY), t, hit);
    // The minimum in every lane: pairs swapped, then halves swapped.
    let nearest = _mm_min_ps(t, _mm_shuffle_ps::<0b10_11_00_01>(t, t));
    let nearest = _mm_min_ps(nearest, _mm_shuffle_ps::<0b01_00_11_10>(nearest, nearest));
    let lane = (_mm_movemask_ps(_mm_cmpeq_ps(t, nearest)) as u32 & lanes).trailing_zeros();
    Some((lane as usize, _mm_cvtss_f32(nearest)))
}

/// [`Kernel::closest_hit`], with the features on: the ray is read and checked, the walk
/// of its octant runs and the hit is made all in here, so nothing passes through memory
/// between them (a function compiled with AVX2 cannot be inlined into one without, so
/// its vector arguments and results would: about 20 instructions per closest-hit ray
/// and 10 per shadow ray on Sponza, counted).
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
unsafe fn closest_hit<H>(
    nodes: &[WideNode],
    blocks: &[TriangleBlock],
    ray: &Ray,
    tmax: f32,
    finish: impl FnOnce(usize, f32, f32, f32) -> H,
) -> Option<H> {
    let (origin, dir) = usable(ray, tmax)?;
    let inv = safe_inverse(dir);
    // SAFETY: the features are on.
    let best = unsafe { for_octant!(inv, nearest_first(nodes, blocks, origin, dir, inv, tmax)) };
    best.map(|(slot, t, u, v)| finish(slot, t, u, v))
}

#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
unsafe fn nearest_first<const OCTANT: usize>(
    nodes: &[WideNode],
    blocks: &[TriangleBlock],
    origin: Vec3A,
    dir: Vec3A,
    inv: Vec3A,
    mut bound: f32,
) -> Option<(usize, f32, f32, f32)> {
    if nodes.is_empty() {
        return None;
    }
    let ray = BoxRay8::new(origin, inv);
    let leaf_ray = LeafRay::new(origin, dir);
    // Shifts a node's orders to the ray's octant (a permutation reads three low bits).
    let shift = _mm_cvtsi32_si128(3 * OCTANT as i32);
    let mut children = [MaybeUninit::<u32>::uninit(); STACK + 1];
    let mut distances = [MaybeUninit::<f32>::uninit(); STACK + 1];
    // At the bottom of the stack, the end: every bound accepts it.
    children[0] = MaybeUninit::new(END.0);
    distances[0] = MaybeUninit::new(f32::NEG_INFINITY);
    let mut len = 1usize;
    let mut current = Child::node(0);
    // The nearest hit so far: its slot, u and v (its t is the bound).
    let mut best: Option<(usize, f32, f32)> = None;
    // SAFETY: the caller checked for AVX2; node, block and child indices come from the
    // tree, whose depth leaves every eight-wide store inside the stack (see `STACK`);
    // only entries written are read, and the end is never popped past.
    unsafe {
        loop {
            'descend: {
                // Down the inner nodes, nearest child first, until a leaf.
                while let Some(index) = current.as_node() {
                    let node = nodes.get_unchecked(index);
                    let (hit, t_near) = ray.enter::<OCTANT>(node, bound);
                    let mask = _mm256_movemask_ps(hit) as u32;
                    if mask == 0 {
                        break 'descend;
                    }
                    if mask.is_power_of_two() {
                        current = *node.children.get_unchecked(mask.trailing_zeros() as usize);
                        continue;
                    }
                    // Lane k of the order: the slot met k-th from last, farthest first.
                    let order = _mm256_srl_epi32(
                        _mm256_load_si256(node.order.as_ptr() as *const __m256i),
                        shift,
                    );
                    let entered = _mm256_movemask_ps(_mm256_permutevar8x32_ps(hit, order)) as usize;
                    let pick = _mm256_permutevar8x32_epi32(order, packing(entered));
                    push_children(children.as_mut_ptr().add(len), node, pick);
                    _mm256_storeu_ps(
                        distances.as_mut_ptr().add(len) as *mut f32,
                        _mm256_permutevar8x32_ps(t_near, pick),
                    );
                    len += entered.count_ones() as usize - 1;
                    // The nearest is the last lane packed: the highest lane entered, whose
                    // slot is read from the node rather than back from the stack.
                    let lane = 31 - (entered as u32).leading_zeros();
                    let slot = (node.order.get_unchecked(lane as usize) >> (3 * OCTANT)) & 7;
                    current = *node.children.get_unchecked(slot as usize);
                }
                if current == END {
                    return best.map(|(slot, u, v)| (slot, bound, u, v));
                }
                if current == Child::EMPTY {
                    break 'descend;
                }
                // The leaf's triangles; a hit (before the bound) becomes the new bound.
                let block = current.leaf_block().0;
                let [t, u, v, hit] = leaf_hits(blocks.get_unchecked(block), &leaf_ray, bound);
                if let Some((lane, t)) = nearest_lane(t, hit) {
                    bound = t;
                    let at_lane = |x: __m128| std::mem::transmute::<__m128, [f32; 4]>(x)[lane];
                    best = Some((4 * block + lane, at_lane(u), at_lane(v)));
                }
            }
            // Resume with the nearest waiting child still within the bound.
            loop {
                len -= 1;
                if distances.get_unchecked(len).assume_init() <= bound {
                    current = Child(children.get_unchecked(len).assume_init());
                    break;
                }
            }
        }
    }
}

/// [`Kernel::occluded`], with the features on: any hit ends the walk.
#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
unsafe fn occluded(nodes: &[WideNode], blocks: &[TriangleBlock], ray: &Ray, tmax: f32) -> bool {
    let Some((origin, dir)) = usable(ray, tmax) else {
        return false;
    };
    let inv = safe_inverse(dir);
    let leaf_ray = LeafRay::new(origin, dir);
    let leaf = |block: usize| {
        // SAFETY: the features are on; block indices come from the tree.
        unsafe { _mm_movemask_ps(leaf_hits(blocks.get_unchecked(block), &leaf_ray, tmax)[3]) != 0 }
    };
    // SAFETY: the features are on.
    unsafe { for_octant!(inv, any_order(nodes, origin, inv, tmax, leaf)) }
}

#[target_feature(enable = "avx2,fma,bmi1,lzcnt,popcnt")]
#[inline]
unsafe fn any_order<const OCTANT: usize>(
    nodes: &[WideNode],
    origin: Vec3A,
    inv: Vec3A,
    tmax: f32,
    mut leaf: impl FnMut(usize) -> bool,
) -> bool {
    if nodes.is_empty() {
        return false;
    }
    let ray = BoxRay8::new(origin, inv);
    let mut children = [MaybeUninit::<u32>::uninit(); STACK + 1];
    children[0] = MaybeUninit::new(END.0);
    let mut len = 1usize;
    let mut current = Child::node(0);
    // SAFETY: as in `nearest_first`.
    unsafe {
        loop {
            'descend: {
                while let Some(index) = current.as_node() {
                    let node = nodes.get_unchecked(index);
                    let mask = _mm256_movemask_ps(ray.enter::<OCTANT>(node, tmax).0) as usize;
                    if mask == 0 {
                        break 'descend;
                    }
                    // All entered children are pushed in slot order; the walk goes on with
                    // the last of them (the highest slot), read from the node.
                    push_children(children.as_mut_ptr().add(len), node, packing(mask));
                    len += mask.count_ones() as usize - 1;
                    current = *node
                        .children
                        .get_unchecked(31 - (mask as u32).leading_zeros() as usize);
                }
                if current == END {
                    return false;
                }
                if current != Child::EMPTY && leaf(current.leaf_block().0) {
                    return true;
                }
            }
            len -= 1;
            current = Child(children.get_unchecked(len).assume_init());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The octant of a ray's direction, as [`WideNode::order`] numbers them.
    fn octant(inv: Vec3A) -> usize {
        let negative = inv.is_negative_bitmask() as usize; // bit 0 for x
        ((negative & 1) << 2) | (negative & 2) | (negative >> 2)
    }

    #[test]
    fn rays_starting_on_a_box_plane_enter_the_box() {
        // A flat box 1000 m from the origin, x and y in [1000, 1000.5], z = 0; rays start
        // exactly on its x-minimum plane, 1 mm above it, heading down and slightly
        // towards +x: they enter it at z = 0, where the x slab has long begun. Computed as
        // `plane · inv − origin · inv`, the x slab's entry is the rounding error of
        // `origin · inv` (up to 0.03 m here) instead of 0, often past where the ray leaves
        // the box through z = 0 (1 mm): the offsets' guard must keep every ray entering.
        let Some(_) = Kernel::detect() else {
            eprintln!("no AVX2 and FMA on this CPU: nothing to test");
            return;
        };
        let mut node = WideNode::EMPTY;
        let (min, max) = (
            Vec3A::new(1000.0, 1000.0, 0.0),
            Vec3A::new(1000.5, 1000.5, 0.0),
        );
        for axis in 0..3 {
            node.planes[axis][0][0] = min[axis];
            node.planes[axis + 3][0][0] = max[axis];
        }
        let mut unguarded_misses = 0;
        for i in 0..1000 {
            let origin = Vec3A::new(1000.0, 1000.0 + 0.4 * (i as f32 / 1000.0), 1e-3);
            let dir = Vec3A::new(1e-3 * (1.0 + (i % 7) as f32), 0.0, -1.0).normalize();
            let inv = safe_inverse(dir);
            // SAFETY: the kernel exists, so the CPU has what the walks use.
            assert_eq!(octant(inv), 1, "a ray down z, towards +x");
            let (hit, _) = unsafe { BoxRay8::new(origin, inv).enter::<1>(&node, f32::INFINITY) };
            assert_eq!(
                unsafe { _mm256_movemask_ps(hit) } & 1,
                1,
                "ray {i} misses the box it starts on"
            );
            // The same slab without the guard, for the record that the case bites.
            let x_entry = min.x.mul_add(inv.x, -(origin.x * inv.x));
            let z_exit = (min.z - origin.z) * inv.z;
            unguarded_misses += usize::from(x_entry > z_exit * FAR_GROWTH);
        }
        assert!(
            unguarded_misses > 100,
            "only {unguarded_misses} of 1000 rays would miss without the guard: the case no longer tests it"
        );
    }
}
