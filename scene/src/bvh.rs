//! Ray queries over the scene's triangles.
//!
//! [`spatial_split`] builds a binary tree with spatial splits (SBVH) as obvhs' `Bvh2`,
//! [`collapse`] makes it eight children per node with leaves of up to four triangles (by
//! the surface area heuristic, with our walks' costs), in the layout of [`wide_node`],
//! and the traversal below visits children nearest first. Each leaf's triangles are one
//! block of four lanes ([`triangle`]), blocks in the order their leaves are met breadth
//! first.
//!
//! Two pitfalls of obvhs 0.4 do not reach us: its traversal (which missed every hit for a
//! `-0.0` direction component) is not used, and neither is its `compute_barycentric`
//! (scaled by the triangle's area); the tests below keep both cases.

#[cfg(target_arch = "x86_64")]
mod avx2;
mod collapse;
mod flat;
mod packet;
mod spatial_split;
mod triangle;
mod wide_node;

use std::cell::RefCell;
use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A};
use obvhs::triangle::Triangle;

use crate::ray::{Hit, Ray};
pub use flat::{
    FLAT_COUNT_SHIFT, FLAT_EMPTY, FLAT_LEAF, FLAT_NODE_WORDS, FLAT_TRIANGLE_WORDS, FlatBvh,
};
pub use packet::PACKET;
pub use triangle::EDGE_TOLERANCE;
use triangle::{BlockRay, IsectTriangle, TriangleBlock};
use wide_node::{BoxRay, Child, WideNode, safe_inverse};

/// Children a traversal may hold back per level: all but the one it descends into.
const PENDING_PER_LEVEL: usize = 7;

/// A child put aside during a walk: where the ray enters it, and (for a leaf) its parent
/// node and slot.
#[derive(Clone, Copy)]
struct Waiting {
    child: Child,
    distance: f32,
    parent: u32,
    slot: u32,
}

impl Waiting {
    const NONE: Waiting = Waiting {
        child: Child::EMPTY,
        distance: 0.0,
        parent: 0,
        slot: 0,
    };
}

/// The BVH and its triangles, stored in the BVH's leaf order.
#[derive(Clone)]
pub struct Bvh {
    nodes: Vec<WideNode>,
    /// Each leaf's triangles, in the order the leaves are first met breadth first (a
    /// triangle may appear in more than one leaf with spatial splits).
    blocks: Vec<TriangleBlock>,
    /// The most entries a traversal's stack can hold.
    stack_size: usize,
    /// The eight-wide single-ray walk, where the CPU has it and the tree fits its stack.
    #[cfg(target_arch = "x86_64")]
    avx2: Option<avx2::Kernel>,
    /// The length of the scene's bounding box diagonal.
    size: f32,
    build_time: Duration,
}

/// A ray's origin and direction as the traversal uses them; `None` for one that cannot
/// hit anything (non-finite origin or direction, zero direction, NaN `tmax`).
fn usable(ray: &Ray, tmax: f32) -> Option<(Vec3A, Vec3A)> {
    let (origin, dir) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
    // 0 · x is 0 for a finite x and NaN for ±∞ or NaN: one test for all six coordinates.
    let finite = (origin * 0.0 + dir * 0.0).cmpeq(Vec3A::ZERO).all();
    (finite && dir != Vec3A::ZERO && !tmax.is_nan()).then_some((origin, dir))
}

impl Bvh {
    /// Builds the BVH over triangles given as three vertices each.
    ///
    /// Leaves address at most 2^27 triangle blocks (over 1.3·10^8 triangles, about 15 GB of
    /// loaded scene: beyond any machine the project runs on).
    pub fn build(vertices: &[[Vec3; 3]]) -> Self {
        let start = Instant::now();
        let tris: Vec<Triangle> = vertices
            .iter()
            .map(|t| Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect();
        let triangles: Vec<IsectTriangle> = tris.iter().map(IsectTriangle::from).collect();
        let mut blocks = Vec::new();
        let (nodes, depth) =
            collapse::collapse(&spatial_split::build(&tris), &triangles, |tris, ids| {
                blocks.push(TriangleBlock::new(tris, ids));
                (blocks.len() - 1) as u32
            });
        let size = nodes.first().map_or(0.0, |root| {
            let (min, max) = root.bounds();
            min.distance(max)
        });
        // The deepest walk holds back seven children per level, and a node's eight are
        // written before the top moves.
        let stack_size = depth * PENDING_PER_LEVEL + 8;
        Self {
            #[cfg(target_arch = "x86_64")]
            avx2: avx2::Kernel::detect().filter(|_| stack_size <= avx2::STACK),
            nodes,
            blocks,
            stack_size,
            size,
            build_time: start.elapsed(),
        }
    }

    /// Wall-clock time the build took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Runs `walk` with a stack big enough for this tree: the thread's own, kept between
    /// queries (filling a fresh one per ray cost more than the walk's node tests).
    #[inline(always)]
    fn with_stack<R>(&self, walk: impl FnOnce(&mut [Waiting]) -> R) -> R {
        thread_local! {
            static STACK: RefCell<Vec<Waiting>> = const { RefCell::new(Vec::new()) };
        }
        STACK.with(|stack| match stack.try_borrow_mut() {
            Ok(mut stack) => {
                if stack.len() < self.stack_size {
                    stack.resize(self.stack_size, Waiting::NONE);
                }
                walk(&mut stack)
            }
            // A walk inside a walk (not done today) gets a stack of its own.
            Err(_) => walk(&mut vec![Waiting::NONE; self.stack_size]),
        })
    }

    /// Visits the tree nearest child first. `enter(node, bound)` says which of a node's
    /// children to enter and at what distance; `leaf(parent, slot, (block, count))` tests
    /// a leaf's triangles (the parent node and slot are there for a caller that tests the
    /// leaf's box again) and returns the new bound. A child entered beyond the bound is
    /// skipped.
    #[inline(always)]
    fn walk_nearest_first(
        &self,
        mut bound: f32,
        mut enter: impl FnMut(&WideNode, f32) -> (u32, [f32; 8]),
        mut leaf: impl FnMut(&WideNode, usize, (usize, usize)) -> f32,
    ) {
        if self.nodes.is_empty() {
            return;
        }
        self.with_stack(|stack| {
            let mut len = 0;
            let mut index = 0;
            loop {
                let node = &self.nodes[index];
                let (mask, entry) = enter(node, bound);
                let mut next = None;
                if mask.is_power_of_two() {
                    let slot = mask.trailing_zeros() as usize;
                    match node.children[slot].as_node() {
                        Some(child) => next = Some(child),
                        None => bound = leaf(node, slot, node.children[slot].leaf_block()),
                    }
                } else if mask != 0 {
                    let (keys, n) = Self::entry_order(mask, &entry);
                    let keys = &keys[..n];
                    // Leaves nearer than every inner child are tested now. The nearest
                    // inner child is visited next; the children beyond it wait, farthest
                    // deepest.
                    let distance = |key: u32| f32::from_bits(key & !7);
                    let mut first_inner = n;
                    for (k, &key) in keys.iter().enumerate() {
                        let slot = (key & 7) as usize;
                        if node.children[slot].as_node().is_some() {
                            first_inner = k;
                            break;
                        }
                        if distance(key) <= bound {
                            bound = leaf(node, slot, node.children[slot].leaf_block());
                        }
                    }
                    if first_inner < n {
                        for &key in keys[first_inner + 1..].iter().rev() {
                            if distance(key) <= bound {
                                let slot = (key & 7) as usize;
                                stack[len] = Waiting {
                                    child: node.children[slot],
                                    distance: distance(key),
                                    parent: index as u32,
                                    slot: slot as u32,
                                };
                                len += 1;
                            }
                        }
                        let key = keys[first_inner];
                        if distance(key) <= bound {
                            next = node.children[(key & 7) as usize].as_node();
                        }
                    }
                }
                if let Some(child) = next {
                    index = child;
                    continue;
                }
                // Resume with the nearest waiting child still within the bound; waiting
                // leaves are tested as they come.
                loop {
                    if len == 0 {
                        return;
                    }
                    len -= 1;
                    let w = stack[len];
                    if w.distance > bound {
                        continue;
                    }
                    match w.child.as_node() {
                        Some(child) => {
                            index = child;
                            break;
                        }
                        None => {
                            let parent = &self.nodes[w.parent as usize];
                            bound = leaf(parent, w.slot as usize, w.child.leaf_block());
                        }
                    }
                }
            }
        })
    }

    /// The children entered (`mask`), ordered by their entry distance: each key holds the
    /// distance's bits with the slot in the low three (entry distances are ≥ 0, so their
    /// bits order like the floats), and how many there are.
    #[inline(always)]
    fn entry_order(mask: u32, entry: &[f32; 8]) -> ([u32; 8], usize) {
        let mut keys = [0u32; 8];
        let mut n = 0;
        let mut bits = mask;
        while bits != 0 {
            let slot = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            keys[n] = (entry[slot].to_bits() & !7) | slot as u32;
            n += 1;
        }
        for i in 1..n {
            let key = keys[i];
            let mut j = i;
            while j > 0 && keys[j - 1] > key {
                keys[j] = keys[j - 1];
                j -= 1;
            }
            keys[j] = key;
        }
        (keys, n)
    }

    /// The hit of a block's lane (slot `4 · block + lane`), in the caller's triangle
    /// numbering; `(u, v)` are
    /// clamped back into the triangle (the test accepts points just outside it).
    fn hit(&self, slot: usize, t: f32, u: f32, v: f32) -> Hit {
        // A hit's barycentrics are finite (they passed the edge tests): no NaN to mind.
        let positive = |x: f32| if x > 0.0 { x } else { 0.0 };
        let (u, v) = (positive(u), positive(v));
        let over = positive(u + v - 1.0) * 0.5;
        Hit {
            triangle: self.blocks[slot / 4].ids[slot % 4],
            t,
            u: positive(u - over),
            v: positive(v - over),
        }
    }

    /// The closest hit with `t < tmax`, if any.
    pub fn closest_hit(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(kernel) = self.avx2 {
            return kernel.closest_hit(&self.nodes, &self.blocks, ray, tmax, |slot, t, u, v| {
                self.hit(slot, t, u, v)
            });
        }
        let (origin, dir) = usable(ray, tmax)?;
        self.closest_hit_portable(origin, dir, tmax)
    }

    /// [`Bvh::closest_hit`] by the portable walk (kept out of `closest_hit`, whose
    /// prologue every AVX2 query pays, so its larger stack frame is not set up there).
    #[inline(never)]
    fn closest_hit_portable(&self, origin: Vec3A, dir: Vec3A, tmax: f32) -> Option<Hit> {
        let inv = safe_inverse(dir);
        let block_ray = BlockRay::new(origin, dir);
        let mut best: Option<(usize, f32, f32, f32)> = None;
        let mut nearest = tmax;
        let box_ray = BoxRay::new(origin, inv);
        self.walk_nearest_first(
            tmax,
            |node, bound| node.intersect(&box_ray, bound),
            |_, _, (block, _)| {
                if let Some((lane, t, u, v)) =
                    self.blocks[block].intersect(&block_ray, nearest).nearest()
                {
                    nearest = t;
                    best = Some((4 * block + lane, t, u, v));
                }
                nearest
            },
        );
        best.map(|(slot, t, u, v)| self.hit(slot, t, u, v))
    }

    /// Visits every leaf whose box the ray enters before `tmax`, in no particular order,
    /// until `leaf(block)` returns true (then returns true).
    #[inline(always)]
    fn walk_any_order(
        &self,
        origin: Vec3A,
        dir: Vec3A,
        tmax: f32,
        mut leaf: impl FnMut(usize) -> bool,
    ) -> bool {
        let inv = safe_inverse(dir);
        #[cfg(target_arch = "x86_64")]
        if let Some(kernel) = self.avx2 {
            return kernel.any_order(&self.nodes, origin, inv, tmax, leaf);
        }
        if self.nodes.is_empty() {
            return false;
        }
        let box_ray = &BoxRay::new(origin, inv);
        self.with_stack(|stack| {
            let mut len = 1;
            stack[0].child = Child::node(0);
            while len > 0 {
                len -= 1;
                let child = stack[len].child;
                if let Some(index) = child.as_node() {
                    let (mut mask, _) = self.nodes[index].intersect(box_ray, tmax);
                    while mask != 0 {
                        let slot = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        stack[len].child = self.nodes[index].children[slot];
                        len += 1;
                    }
                } else if leaf(child.leaf_block().0) {
                    return true;
                }
            }
            false
        })
    }

    /// Every hit with `t < tmax`, nearest first, one per triangle (a triangle split over
    /// several leaves is reported once). The light field follows whole lines through the
    /// scene and needs each surface a line crosses, not only the first.
    pub fn all_hits(&self, ray: &Ray, tmax: f32, hits: &mut Vec<Hit>) {
        hits.clear();
        let Some((origin, dir)) = usable(ray, tmax) else {
            return;
        };
        let block_ray = BlockRay::new(origin, dir);
        self.walk_any_order(origin, dir, tmax, |block| {
            let found = self.blocks[block].intersect(&block_ray, tmax);
            let mut lanes = found.lanes;
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                lanes &= lanes - 1;
                let (t, u, v) = (found.t[lane], found.u[lane], found.v[lane]);
                hits.push(self.hit(4 * block + lane, t, u, v));
            }
            false
        });
        // Sorted by (t, triangle), the copies of a triangle split over leaves are adjacent.
        hits.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        hits.dedup_by_key(|h| h.triangle);
    }

    /// True when something lies on the ray before `tmax` (any hit ends the query, so the
    /// order of children does not matter).
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(kernel) = self.avx2 {
            return kernel.occluded(&self.nodes, &self.blocks, ray, tmax);
        }
        let Some((origin, dir)) = usable(ray, tmax) else {
            return false;
        };
        let block_ray = BlockRay::new(origin, dir);
        self.walk_any_order(origin, dir, tmax, |block| {
            self.blocks[block].intersect(&block_ray, tmax).lanes != 0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Vec<[Vec3; 3]> {
        // A unit square in the z = 0 plane made of two triangles sharing the diagonal.
        let (a, b, c, d) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        vec![[a, b, c], [a, c, d]]
    }

    #[test]
    fn negative_zero_direction_components_still_hit() {
        let bvh = Bvh::build(&quad());
        let ray = Ray::new(Vec3::new(0.25, 0.6, 1.0), Vec3::new(-0.0, -0.0, -1.0));
        let hit = bvh.closest_hit(&ray, f32::INFINITY).expect("ray must hit");
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(bvh.occluded(&ray, f32::INFINITY));
    }

    #[test]
    fn rays_through_a_shared_edge_hit_one_of_its_triangles() {
        // The quad's diagonal from (0,0) to (1,1), aimed at from scattered origins: plain
        // f32 Möller–Trumbore lets some of these through both triangles.
        let bvh = Bvh::build(&quad());
        let mut missed = 0;
        for i in 0..20_000u32 {
            let f = (i as f32 + 0.5) / 20_000.0;
            let target = Vec3::new(f, f, 0.0);
            let k = i as f32 * 0.618_034;
            let o = Vec3::new(3.0 * k.sin(), 3.0 * (1.7 * k).cos(), 2.0 + k.fract());
            let ray = Ray::new(o, (target - o).normalize());
            match bvh.closest_hit(&ray, f32::INFINITY) {
                Some(h) => {
                    assert!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0, "{h:?}");
                }
                None => missed += 1,
            }
        }
        assert_eq!(missed, 0, "rays slipped between the two triangles");
    }

    #[test]
    fn points_the_widened_triangle_accepts_are_not_lost_to_its_box() {
        // A right triangle whose legs lie on the box's faces: rays aimed a little outside
        // a leg, within the tolerance, hit the widened triangle; its box must let them in.
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let bvh = Bvh::build(&[tri]);
        for i in 1..100 {
            let along = i as f32 / 100.0;
            let outside = EDGE_TOLERANCE * 0.5;
            for target in [
                Vec3::new(along, -outside, 0.0),
                Vec3::new(-outside, along, 0.0),
            ] {
                let origin = target + Vec3::new(0.3, 0.2, 1.0);
                let ray = Ray::new(origin, (target - origin).normalize());
                assert!(bvh.closest_hit(&ray, f32::INFINITY).is_some(), "{target}");
                assert!(bvh.occluded(&ray, f32::INFINITY), "{target}");
                assert!(
                    bvh.closest_hits(&[ray; 2], f32::INFINITY)[0].is_some(),
                    "{target}"
                );
            }
        }
    }

    #[test]
    fn barycentrics_are_not_area_scaled() {
        // A large triangle (area 50): obvhs' own barycentrics would be off by that factor.
        let (a, b, c) = (
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        );
        let bvh = Bvh::build(&[[a, b, c]]);
        let target = Vec3::new(2.0, 3.0, 0.0);
        let ray = Ray::new(target + Vec3::Z, -Vec3::Z);
        let hit = bvh.closest_hit(&ray, f32::INFINITY).unwrap();
        let p = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
        assert!((p - target).length() < 1e-5, "{p} != {target}");
    }

    #[test]
    fn closest_of_several_and_tmax_respected() {
        let mut tris = quad();
        for t in quad() {
            tris.push(t.map(|p| p + Vec3::new(0.0, 0.0, -2.0)));
        }
        let bvh = Bvh::build(&tris);
        let ray = Ray::new(Vec3::new(0.3, 0.2, 1.0), -Vec3::Z);
        let hit = bvh.closest_hit(&ray, f32::INFINITY).unwrap();
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(hit.triangle < 2);
        assert!(bvh.closest_hit(&ray, 0.5).is_none());
        assert!(!bvh.occluded(&ray, 0.999));
        assert!(bvh.occluded(&ray, 1.001));
    }

    #[test]
    fn bad_rays_hit_nothing() {
        let bvh = Bvh::build(&quad());
        for dir in [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, -1.0), Vec3::INFINITY] {
            let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), dir);
            assert!(bvh.closest_hit(&ray, f32::INFINITY).is_none());
            assert!(!bvh.occluded(&ray, f32::INFINITY));
        }
    }

    /// How far two roundings of Möller–Trumbore may part for a ray (unit direction)
    /// meeting `tri` at `t`: in `t`, `u` and `v`. To first order each product and sum
    /// errs by a few ε of its terms' magnitudes: `s · p` (with `p = d × e2`, `|p| ≤ |e2|`)
    /// by ε |s| |e2|, `d · q` (`q = s × e1`) by ε |s| |e1|, `e2 · q` by ε |e2| |s| |e1|,
    /// and the determinant by ε |e1| |e2|, which a quotient carries as that relative error
    /// times itself; dividing by `|det|` amplifies all of it (large for a ray grazing the
    /// triangle). 16 ε covers the handful of roundings on the way; `u`, `v` ≤ 1 here.
    fn rounding(tri: [Vec3; 3], ray: &Ray, t: f32) -> (f32, f32, f32) {
        let (e1, e2, s) = (tri[1] - tri[0], tri[2] - tri[0], ray.origin - tri[0]);
        let (e1, e2, s, det) = (
            e1.length(),
            e2.length(),
            s.length(),
            e1.dot(ray.dir.cross(e2)).abs(),
        );
        let scale = 16.0 * f32::EPSILON / det;
        (
            scale * e1 * e2 * (s + t),
            scale * e2 * (s + e1),
            scale * e1 * (s + e2),
        )
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_avx2_walks_answer_as_the_portable_walks() {
        // Two thousand scattered triangles and rays in every direction: the eight-wide
        // walks visit children in another order, but must find the same closest hit,
        // occlusion and list of hits.
        let uniform = |i: u32| {
            let x = i.wrapping_mul(0x9e37_79b9) ^ (i >> 13).wrapping_mul(0x85eb_ca6b);
            (x.wrapping_mul(0xc2b2_ae35) >> 8) as f32 / (1 << 24) as f32
        };
        let point = |i: u32| Vec3::new(uniform(3 * i), uniform(3 * i + 1), uniform(3 * i + 2));
        let tris: Vec<[Vec3; 3]> = (0..2000u32)
            .map(|i| {
                let c = point(4 * i);
                let offsets = [1, 2, 3].map(|k| (point(4 * i + k) - 0.5) * 0.1);
                offsets.map(|o| c + o)
            })
            .collect();
        let with_kernel = Bvh::build(&tris);
        let Some(_) = with_kernel.avx2 else {
            eprintln!("no AVX2 on this CPU: only the portable walk runs here");
            return;
        };
        let portable = Bvh {
            avx2: None,
            ..Bvh::build(&tris)
        };
        let mut hits = 0;
        for i in 0..20_000u32 {
            let origin = point(1_000_000 + 2 * i) * 1.4 - 0.2;
            let dir = point(2_000_000 + 2 * i) - 0.5;
            let ray = Ray::new(origin, dir.normalize_or(Vec3::X));
            let tmax = if i % 7 == 0 { 0.3 } else { f32::INFINITY };
            let a = with_kernel.closest_hit(&ray, tmax);
            let b = portable.closest_hit(&ray, tmax);
            // The eight-wide walk's leaf test fuses its multiply-adds, so it rounds
            // differently: the same point, to within Möller–Trumbore's rounding.
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    let (t_error, u_error, v_error) =
                        rounding(tris[b.triangle as usize], &ray, b.t);
                    assert!((a.t - b.t).abs() <= t_error, "ray {i}: {a:?} against {b:?}");
                    if a.triangle == b.triangle {
                        assert!(
                            (a.u - b.u).abs() <= u_error && (a.v - b.v).abs() <= v_error,
                            "ray {i}: {a:?} against {b:?}"
                        );
                    } else {
                        // Triangles of the soup cross each other: where two meet the ray
                        // at one point, either is right, if the ray does meet it there.
                        let alone = Bvh {
                            avx2: None,
                            ..Bvh::build(&[tris[a.triangle as usize]])
                        };
                        let t = alone.closest_hit(&ray, tmax).map_or(f32::NAN, |h| h.t);
                        let (t_error, ..) = rounding(tris[a.triangle as usize], &ray, t);
                        assert!((t - a.t).abs() <= t_error, "ray {i}: {a:?} against {b:?}");
                    }
                    hits += 1;
                }
                _ => panic!("ray {i}: {a:?} against {b:?}"),
            }
            assert_eq!(
                with_kernel.occluded(&ray, tmax),
                portable.occluded(&ray, tmax),
                "ray {i}"
            );
            let (mut all_a, mut all_b) = (Vec::new(), Vec::new());
            with_kernel.all_hits(&ray, tmax, &mut all_a);
            portable.all_hits(&ray, tmax, &mut all_b);
            assert_eq!(all_a, all_b, "ray {i}");
        }
        assert!(
            hits > 2_000,
            "too few rays hit ({hits}) to compare the walks"
        );
    }

    #[test]
    fn all_hits_equal_brute_force_in_order() {
        // Stacked quads at z = 0, -1, ..., -5 plus tilted triangles: every crossing is
        // found, nearest first, and agrees with testing each triangle on its own.
        let mut tris = Vec::new();
        for k in 0..6 {
            for t in quad() {
                tris.push(t.map(|p| p + Vec3::new(0.0, 0.0, -(k as f32))));
            }
        }
        tris.push([
            Vec3::new(-1.0, -1.0, -0.5),
            Vec3::new(2.0, -1.0, -2.5),
            Vec3::new(0.5, 2.0, -1.5),
        ]);
        let bvh = Bvh::build(&tris);
        let single: Vec<Bvh> = tris.iter().map(|t| Bvh::build(&[*t])).collect();
        let mut hits = Vec::new();
        for i in 0..500u32 {
            let k = i as f32 * 0.618_034;
            let o = Vec3::new(0.5 + 0.45 * k.sin(), 0.5 + 0.45 * (1.3 * k).cos(), 1.0);
            let d = Vec3::new(0.05 * (2.1 * k).sin(), 0.05 * (0.7 * k).cos(), -1.0).normalize();
            let ray = Ray::new(o, d);
            let tmax = if i % 5 == 0 { 3.2 } else { f32::INFINITY };
            bvh.all_hits(&ray, tmax, &mut hits);
            let mut expected: Vec<(u32, f32)> = single
                .iter()
                .enumerate()
                .filter_map(|(j, b)| b.closest_hit(&ray, tmax).map(|h| (j as u32, h.t)))
                .collect();
            expected.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            // Two triangles of one quad share a diagonal: a ray through it may be
            // reported by either, so compare the distances, and the triangles elsewhere.
            assert_eq!(
                hits.len(),
                expected.len(),
                "ray {i}: {hits:?} vs {expected:?}"
            );
            for (h, (tri, t)) in hits.iter().zip(&expected) {
                assert!((h.t - t).abs() <= 1e-5 * (1.0 + t), "ray {i}");
                if (h.t - t).abs() > 1e-6 {
                    assert_eq!(h.triangle, *tri, "ray {i}");
                }
            }
            assert!(hits.windows(2).all(|w| w[0].t <= w[1].t));
        }
    }
}
