//! The single-ray walks with AVX2, chosen at run time where the CPU has it: closest hit
//! and any hit (occlusion).
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
//! test is the portable one's slab test with the same rounding guard, eight lanes at
//! once, so both walks enter the same boxes.

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

impl Kernel {
    /// The kernel, where the CPU has AVX2 (`HOLOCAVE_NO_AVX2` set in the environment
    /// turns it off, to compare the two walks).
    pub fn detect() -> Option<Kernel> {
        (is_x86_feature_detected!("avx2") && std::env::var_os("HOLOCAVE_NO_AVX2").is_none())
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
        // SAFETY: a Kernel exists only where the CPU has AVX2.
        unsafe { nearest_first(nodes, origin, inv, bound, leaf) }
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
        // SAFETY: a Kernel exists only where the CPU has AVX2.
        unsafe { any_order(nodes, origin, inv, tmax, leaf) }
    }
}

/// A ray prepared for the eight-wide slab test: origin and inverse direction in all
/// lanes, per axis the plane row met first (minimum or maximum) and the one met last, and
/// the octant of its direction as [`WideNode::order`] numbers them (bit 2 for a negative
/// x, bit 1 for y, bit 0 for z).
struct BoxRay8 {
    origin: [__m256; 3],
    inv: [__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
    octant: usize,
}

impl BoxRay8 {
    #[target_feature(enable = "avx2")]
    fn new(origin: Vec3A, inv: Vec3A) -> Self {
        let near = |axis: usize| if inv[axis] < 0.0 { axis + 3 } else { axis };
        let near = [near(0), near(1), near(2)];
        let negative = |axis: usize| usize::from(inv[axis] < 0.0);
        Self {
            origin: [0, 1, 2].map(|axis| _mm256_set1_ps(origin[axis])),
            inv: [0, 1, 2].map(|axis| _mm256_set1_ps(inv[axis])),
            near,
            far: near.map(|row| (row + 3) % 6),
            octant: (negative(0) << 2) | (negative(1) << 1) | negative(2),
        }
    }

    /// The children the ray enters before `bound` (all bits set in a lane entered), and
    /// where it enters each: the portable test's arithmetic, eight lanes at once.
    ///
    /// # Safety
    /// The CPU has AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn enter(&self, node: &WideNode, bound: f32) -> (__m256, __m256) {
        let planes = node.planes.as_ptr() as *const f32;
        // SAFETY: each of the six plane rows is eight f32, 32-byte aligned.
        let slab = |row: usize, axis: usize| unsafe {
            let plane = _mm256_load_ps(planes.add(8 * row));
            _mm256_mul_ps(_mm256_sub_ps(plane, self.origin[axis]), self.inv[axis])
        };
        let t_near = _mm256_max_ps(
            _mm256_max_ps(slab(self.near[0], 0), slab(self.near[1], 1)),
            _mm256_max_ps(slab(self.near[2], 2), _mm256_setzero_ps()),
        );
        let t_far = _mm256_mul_ps(
            _mm256_min_ps(
                _mm256_min_ps(slab(self.far[0], 0), slab(self.far[1], 1)),
                slab(self.far[2], 2),
            ),
            _mm256_set1_ps(FAR_GROWTH),
        );
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t_near, _mm256_min_ps(t_far, _mm256_set1_ps(bound)));
        (hit, t_near)
    }
}

/// The permutation that packs the lanes set in `mask` (8 bits) at the front, lowest first.
#[target_feature(enable = "avx2")]
#[inline]
fn packing(mask: usize) -> __m256i {
    // SAFETY: a table row is eight u32 (an unaligned load).
    unsafe { _mm256_loadu_si256(PACK[mask].as_ptr() as *const __m256i) }
}

/// Writes the node's eight children, permuted by `pick`, at `top` of a walk's stack.
///
/// # Safety
/// The CPU has AVX2, and `top` has room for eight entries.
#[target_feature(enable = "avx2")]
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

#[target_feature(enable = "avx2")]
unsafe fn nearest_first(
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
    let shift = _mm_cvtsi32_si128(3 * ray.octant as i32);
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
                let (hit, t_near) = ray.enter(node, bound);
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
                let slot = (node.order.get_unchecked(lane as usize) >> (3 * ray.octant)) & 7;
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

#[target_feature(enable = "avx2")]
unsafe fn any_order(
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
                let mask = _mm256_movemask_ps(ray.enter(node, tmax).0) as usize;
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
