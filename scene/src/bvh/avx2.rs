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
//! the portable test, never less, so both walks find the same hits.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use glam::Vec3A;

use super::wide_node::{Child, FAR_GROWTH, WideNode};

/// The deepest stack the walks keep on the thread's stack: a tree deeper than
/// `(STACK - 8) / 7` levels is walked by the portable code.
pub(super) const STACK: usize = 256;

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

/// Proof that the CPU runs AVX2: only [`Kernel::detect`] makes one.
#[derive(Clone, Copy, Debug)]
pub(super) struct Kernel(());

/// The octant of a ray's direction, as [`WideNode::order`] numbers them: bit 2 for a
/// negative x, bit 1 for y, bit 0 for z.
fn octant(inv: Vec3A) -> usize {
    let negative = inv.is_negative_bitmask() as usize; // bit 0 for x
    ((negative & 1) << 2) | (negative & 2) | (negative >> 2)
}

/// Calls `walk::<OCTANT>(args)` for the octant given: each octant has its own copy of a
/// walk, with the plane rows it reads and the shift of its orders fixed when compiled.
macro_rules! for_octant {
    ($octant:expr, $walk:ident($($arg:expr),*)) => {
        match $octant {
            0 => $walk::<0>($($arg),*),
            1 => $walk::<1>($($arg),*),
            2 => $walk::<2>($($arg),*),
            3 => $walk::<3>($($arg),*),
            4 => $walk::<4>($($arg),*),
            5 => $walk::<5>($($arg),*),
            6 => $walk::<6>($($arg),*),
            _ => $walk::<7>($($arg),*),
        }
    };
}

impl Kernel {
    /// The kernel, where the CPU has AVX2 and FMA (`HOLOCAVE_NO_AVX2` set in the environment
    /// turns it off, to compare the two walks).
    pub fn detect() -> Option<Kernel> {
        (is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
            && std::env::var_os("HOLOCAVE_NO_AVX2").is_none())
        .then_some(Kernel(()))
    }

    /// Visits the leaves the ray (origin, [`super::wide_node::safe_inverse`] direction)
    /// enters, nearest first as far as the layout tells it.
    /// `leaf(block)` tests a leaf's triangles and returns the new bound; a child entered
    /// beyond the bound is skipped. `nodes` must be no deeper than the [`STACK`] allows.
    #[inline(always)]
    pub fn walk(
        self,
        nodes: &[WideNode],
        origin: Vec3A,
        inv: Vec3A,
        bound: f32,
        leaf: impl FnMut(usize) -> f32,
    ) {
        // SAFETY: a Kernel exists only where the CPU has AVX2 and FMA.
        unsafe { for_octant!(octant(inv), nearest_first(nodes, origin, inv, bound, leaf)) }
    }

    /// Visits the leaves the ray enters before `tmax`, in no particular order, until
    /// `leaf(block)` returns true (then returns true). No ordering, no distances kept:
    /// what an occlusion query needs. `nodes` as for [`Kernel::walk`].
    #[inline(always)]
    pub fn any_order(
        self,
        nodes: &[WideNode],
        origin: Vec3A,
        inv: Vec3A,
        tmax: f32,
        leaf: impl FnMut(usize) -> bool,
    ) -> bool {
        // SAFETY: a Kernel exists only where the CPU has AVX2 and FMA.
        unsafe { for_octant!(octant(inv), any_order(nodes, origin, inv, tmax, leaf)) }
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
    #[target_feature(enable = "avx2,fma")]
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
    /// where it enters each, eight lanes at once. `OCTANT` is the ray's [`octant`].
    ///
    /// # Safety
    /// The CPU has AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
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
#[target_feature(enable = "avx2,fma")]
#[inline]
fn packing(mask: usize) -> __m256i {
    // SAFETY: a table row is eight u32 (an unaligned load).
    unsafe { _mm256_loadu_si256(PACK[mask].as_ptr() as *const __m256i) }
}

/// Writes the node's eight children, permuted by `pick`, at `top` of a walk's stack.
///
/// # Safety
/// The CPU has AVX2 and FMA, and `top` has room for eight entries.
#[target_feature(enable = "avx2,fma")]
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

#[target_feature(enable = "avx2,fma")]
unsafe fn nearest_first<const OCTANT: usize>(
    nodes: &[WideNode],
    origin: Vec3A,
    inv: Vec3A,
    mut bound: f32,
    mut leaf: impl FnMut(usize) -> f32,
) {
    if nodes.is_empty() {
        return;
    }
    let ray = BoxRay8::new(origin, inv);
    // Shifts a node's orders to the ray's octant (a permutation reads three low bits).
    let shift = _mm_cvtsi32_si128(3 * OCTANT as i32);
    let mut children = [MaybeUninit::<u32>::uninit(); STACK];
    let mut distances = [MaybeUninit::<f32>::uninit(); STACK];
    let mut len = 0usize;
    let mut current = Child::node(0);
    // SAFETY: the caller checked for AVX2; node and child indices come from the tree,
    // whose depth leaves every eight-wide store inside the stack (see `STACK`); only
    // entries written are read.
    unsafe {
        loop {
            // Down the inner nodes, nearest child first, until a leaf.
            while let Some(index) = current.as_node() {
                let node = nodes.get_unchecked(index);
                let (hit, t_near) = ray.enter::<OCTANT>(node, bound);
                let mask = _mm256_movemask_ps(hit) as u32;
                if mask == 0 {
                    current = Child::EMPTY;
                    break;
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
            if current != Child::EMPTY {
                bound = leaf(current.leaf_block().0);
            }
            // Resume with the nearest waiting child still within the bound.
            loop {
                if len == 0 {
                    return;
                }
                len -= 1;
                if distances.get_unchecked(len).assume_init() <= bound {
                    current = Child(children.get_unchecked(len).assume_init());
                    break;
                }
            }
        }
    }
}

#[target_feature(enable = "avx2,fma")]
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
    let mut children = [MaybeUninit::<u32>::uninit(); STACK];
    let mut len = 0usize;
    let mut current = Child::node(0);
    // SAFETY: as in `nearest_first`.
    unsafe {
        loop {
            while let Some(index) = current.as_node() {
                let node = nodes.get_unchecked(index);
                let mask = _mm256_movemask_ps(ray.enter::<OCTANT>(node, tmax).0) as usize;
                if mask == 0 {
                    current = Child::EMPTY;
                    break;
                }
                // All entered children are pushed in slot order; the walk goes on with
                // the last of them (the highest slot), read from the node.
                push_children(children.as_mut_ptr().add(len), node, packing(mask));
                len += mask.count_ones() as usize - 1;
                current = *node
                    .children
                    .get_unchecked(31 - (mask as u32).leading_zeros() as usize);
            }
            if current != Child::EMPTY && leaf(current.leaf_block().0) {
                return true;
            }
            if len == 0 {
                return false;
            }
            len -= 1;
            current = Child(children.get_unchecked(len).assume_init());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::wide_node::safe_inverse;

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
            // SAFETY: the kernel exists, so the CPU has AVX2 and FMA.
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
