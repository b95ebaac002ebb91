//! The closest-hit walk of a single ray with AVX2, chosen at run time where the CPU has
//! it.
//!
//! The portable walk ([`super::Bvh`]'s) tests a node's eight boxes in two four-wide halves
//! and sorts the children it enters by distance; on Sponza that bookkeeping was half of a
//! ray's time. Here, as in tinybvh's `BVH8_CPU` kernel, one eight-wide pass tests all
//! eight boxes, and the children entered are ordered without sorting: obvhs lays a node's
//! children out in its eight slots by where they lie (Ylitie et al., "Efficient incoherent
//! ray traversal on GPUs through compressed wide BVHs", 2017), so a ray whose direction
//! has signs `octant` meets them roughly in slot order `k ^ octant`, k = 0, 1, …. One
//! permutation puts the entered children in that order, farthest first, a second packs
//! them together, and two stores push them all; the nearest is popped next. The box test
//! is the same slab test with the same rounding guard as the portable one, so both
//! walks enter the same boxes.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use glam::Vec3A;

use super::wide_node::{Child, FAR_GROWTH, WideNode};

/// The deepest stack the kernel keeps on the thread's stack: a tree deeper than
/// `(STACK - 8) / 7` levels is walked by the portable code.
pub(super) const STACK: usize = 256;

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

    /// Visits the leaves the ray (origin, [`super::wide_node::safe_inverse`] direction,
    /// direction signs `octant`) enters, nearest first as far as the layout tells it.
    /// `leaf(block)` tests a leaf's triangles and returns the new bound; a child entered
    /// beyond the bound is skipped. `nodes` must be no deeper than the [`STACK`] allows.
    #[inline(always)]
    pub fn walk(
        self,
        nodes: &[WideNode],
        origin: Vec3A,
        inv: Vec3A,
        octant: usize,
        bound: f32,
        leaf: impl FnMut(usize) -> f32,
    ) {
        // SAFETY: a Kernel exists only where the CPU has AVX2.
        unsafe { walk(nodes, origin, inv, octant, bound, leaf) }
    }
}

#[target_feature(enable = "avx2")]
unsafe fn walk(
    nodes: &[WideNode],
    origin: Vec3A,
    inv: Vec3A,
    octant: usize,
    mut bound: f32,
    mut leaf: impl FnMut(usize) -> f32,
) {
    // SAFETY: the caller checked for AVX2; node and child indices come from the tree,
    // whose depth leaves every eight-wide store inside the stack (see `STACK`); only
    // entries written are read.
    unsafe {
        if nodes.is_empty() {
            return;
        }
        let mut children = [MaybeUninit::<u32>::uninit(); STACK];
        let mut distances = [MaybeUninit::<f32>::uninit(); STACK];
        let o = [
            _mm256_set1_ps(origin.x),
            _mm256_set1_ps(origin.y),
            _mm256_set1_ps(origin.z),
        ];
        let d = [
            _mm256_set1_ps(inv.x),
            _mm256_set1_ps(inv.y),
            _mm256_set1_ps(inv.z),
        ];
        // Per axis the plane row met first (minimum or maximum) and the one met last.
        let near = |axis: usize, negative: bool| if negative { axis + 3 } else { axis };
        let rows_near = [
            near(0, inv.x < 0.0),
            near(1, inv.y < 0.0),
            near(2, inv.z < 0.0),
        ];
        let rows_far = rows_near.map(|row| (row + 3) % 6);
        // Lane k of the order holds the slot met k-th from last: farthest first.
        let order = _mm256_xor_si256(
            _mm256_setr_epi32(7, 6, 5, 4, 3, 2, 1, 0),
            _mm256_set1_epi32(octant as i32),
        );
        let zero = _mm256_setzero_ps();
        let growth = _mm256_set1_ps(FAR_GROWTH);
        let mut len = 0usize;
        let mut current = Child::node(0);
        loop {
            // Down the inner nodes, nearest child first, until a leaf.
            while let Some(index) = current.as_node() {
                let node = nodes.get_unchecked(index);
                let planes = node.planes.as_ptr() as *const f32;
                let slab = |row: usize, axis: usize| {
                    let plane = _mm256_load_ps(planes.add(8 * row));
                    _mm256_mul_ps(_mm256_sub_ps(plane, o[axis]), d[axis])
                };
                let t_near = _mm256_max_ps(
                    _mm256_max_ps(slab(rows_near[0], 0), slab(rows_near[1], 1)),
                    _mm256_max_ps(slab(rows_near[2], 2), zero),
                );
                let t_far = _mm256_mul_ps(
                    _mm256_min_ps(
                        _mm256_min_ps(slab(rows_far[0], 0), slab(rows_far[1], 1)),
                        slab(rows_far[2], 2),
                    ),
                    growth,
                );
                let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(
                    t_near,
                    _mm256_min_ps(t_far, _mm256_set1_ps(bound)),
                );
                let mask = _mm256_movemask_ps(hit) as u32;
                if mask == 0 {
                    current = Child::EMPTY;
                    break;
                }
                let slots = node.children.as_ptr() as *const __m256i;
                if mask.is_power_of_two() {
                    current = *node.children.get_unchecked(mask.trailing_zeros() as usize);
                    continue;
                }
                let entered = _mm256_movemask_ps(_mm256_permutevar8x32_ps(hit, order)) as usize;
                let pick = _mm256_permutevar8x32_epi32(
                    order,
                    _mm256_loadu_si256(PACK.get_unchecked(entered).as_ptr() as *const __m256i),
                );
                _mm256_storeu_si256(
                    children.as_mut_ptr().add(len) as *mut __m256i,
                    _mm256_permutevar8x32_epi32(_mm256_loadu_si256(slots), pick),
                );
                _mm256_storeu_ps(
                    distances.as_mut_ptr().add(len) as *mut f32,
                    _mm256_permutevar8x32_ps(t_near, pick),
                );
                len += entered.count_ones() as usize - 1;
                // The nearest is the last lane packed: the highest lane entered, whose
                // slot is read from the node rather than back from the stack.
                let lane = 31 - (entered as u32).leading_zeros();
                current = *node.children.get_unchecked((7 - lane as usize) ^ octant);
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
