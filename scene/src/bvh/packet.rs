//! Closest hits of coherent rays, traced sixteen at a time.
//!
//! Neighbouring primary rays (and the rays of one holodeck beam) pass through the same
//! nodes. A packet walks the tree once for all its rays: one conservative box test per
//! node for the whole packet ([`IntervalRay`]), children nearest first, and at a leaf each
//! triangle tested against four rays at once. What a single ray pays per node (box test,
//! ordering, stack, mispredicted branches) is paid once per packet.
//!
//! Rays whose directions do not share an octant cannot share the interval test; they are
//! split by octant, and a ray alone in its octant is traced on its own.

use glam::{Vec3A, Vec4};

use super::triangle::{IsectTriangle, intersect4};
use super::wide_node::{FAR_GROWTH, IntervalRay, safe_inverse};
use super::{Bvh, usable};
use crate::ray::{Hit, Ray};

/// Rays per packet.
pub const PACKET: usize = 16;
const GROUPS: usize = PACKET / 4;
/// The fewest rays worth a shared walk.
const MIN_SHARED: usize = 4;
/// The widest angle (radians) between a packet's directions: 16 neighbouring pixels of a
/// wall at 128 pixels across a 90° view span about 0.05 rad.
const MAX_SPREAD: f32 = 0.1;
/// How far apart (relative to the scene's size) a packet's origins may be: a holodeck
/// beam's rays start within one cell, about a tenth of the section.
const MAX_APART: f32 = 0.1;

/// Four rays in structure-of-arrays form, with the closest hit each has found so far.
#[derive(Clone, Copy)]
struct RayGroup {
    origin: [Vec4; 3],
    dir: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// How far each ray still looks; an unused lane has −1 and so never hits.
    tmax: Vec4,
    u: Vec4,
    v: Vec4,
    slot: [u32; 4],
}

impl RayGroup {
    const UNUSED: RayGroup = RayGroup {
        origin: [Vec4::ZERO; 3],
        dir: [Vec4::ZERO; 3],
        inv_dir: [Vec4::ONE; 3],
        tmax: Vec4::splat(-1.0),
        u: Vec4::ZERO,
        v: Vec4::ZERO,
        slot: [u32::MAX; 4],
    };

    fn set(&mut self, lane: usize, origin: Vec3A, dir: Vec3A, inv: Vec3A, tmax: f32) {
        for axis in 0..3 {
            self.origin[axis][lane] = origin[axis];
            self.dir[axis][lane] = dir[axis];
            self.inv_dir[axis][lane] = inv[axis];
        }
        self.tmax[lane] = tmax;
    }

    /// Whether any of the four rays enters the box before its closest hit so far (the same
    /// slab test as a single ray's). `near` and `far` are the box's corners met first and
    /// last along the rays' shared octant.
    #[inline(always)]
    fn enters(&self, near: Vec3A, far: Vec3A) -> bool {
        let mut t_near = Vec4::ZERO;
        let mut t_far = self.tmax;
        for axis in 0..3 {
            let t0 = (Vec4::splat(near[axis]) - self.origin[axis]) * self.inv_dir[axis];
            let t1 = (Vec4::splat(far[axis]) - self.origin[axis]) * self.inv_dir[axis];
            t_near = t_near.max(t0);
            t_far = t_far.min(t1 * FAR_GROWTH);
        }
        t_near.cmple(t_far).any()
    }

    /// Möller–Trumbore for one triangle and four rays, the same test as a single ray's.
    #[inline(always)]
    fn intersect(&mut self, tri: &IsectTriangle, slot: usize) {
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        let corner = [splat(tri.v0), splat(tri.e1), splat(tri.e2)];
        let (t, u, v, hit) = intersect4(
            &self.origin,
            &self.dir,
            [&corner[0], &corner[1], &corner[2]],
            self.tmax,
        );
        let lanes = hit.bitmask();
        if lanes == 0 {
            return;
        }
        self.tmax = Vec4::select(hit, t, self.tmax);
        self.u = Vec4::select(hit, u, self.u);
        self.v = Vec4::select(hit, v, self.v);
        for lane in 0..4 {
            if lanes & (1 << lane) != 0 {
                self.slot[lane] = slot as u32;
            }
        }
    }
}

impl Bvh {
    /// The closest hit before `tmax` of each ray, as [`Bvh::closest_hit`] would give it.
    /// Rays next to each other in `rays` are traced together, so give them in a coherent
    /// order (e.g. pixels in small tiles) to gain from it.
    pub fn closest_hits(&self, rays: &[Ray], tmax: f32) -> Vec<Option<Hit>> {
        let mut out = vec![None; rays.len()];
        for (chunk, out) in rays.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            self.closest_hits_of_packet(chunk, tmax, out);
        }
        out
    }

    /// Whether rays are close enough to share a walk: at least [`MIN_SHARED`] of them,
    /// directions within [`MAX_SPREAD`] of the first's, origins within [`MAX_APART`] of
    /// the scene's size of the first's. A packet of scattered rays enters nearly every
    /// node one of them enters, so each ray is walked alone instead.
    fn coherent(&self, mut rays: impl ExactSizeIterator<Item = (Vec3A, Vec3A)>) -> bool {
        if rays.len() < MIN_SHARED {
            return false;
        }
        let Some((o, d)) = rays.next() else {
            return false;
        };
        // Squared forms, to spare square roots: cos² of the angle against cos² of the
        // spread, the squared distance against the squared allowance.
        let cos2 = MAX_SPREAD.cos().powi(2);
        let apart2 = (MAX_APART * self.size).powi(2);
        let d2 = d.length_squared();
        rays.all(|(oi, di)| {
            let dot = di.dot(d);
            dot > 0.0
                && dot * dot >= cos2 * d2 * di.length_squared()
                && oi.distance_squared(o) <= apart2
        })
    }

    /// One packet: its rays split by direction octant, each octant walked once.
    fn closest_hits_of_packet(&self, rays: &[Ray], tmax: f32, out: &mut [Option<Hit>]) {
        let mut origin = [Vec3A::ZERO; PACKET];
        let mut dir = [Vec3A::ZERO; PACKET];
        let mut inv = [Vec3A::ZERO; PACKET];
        let mut octant = [0u32; PACKET];
        let mut pending = 0u32;
        for (i, ray) in rays.iter().enumerate() {
            if let Some((o, d)) = usable(ray, tmax) {
                (origin[i], dir[i], inv[i]) = (o, d, safe_inverse(d));
                octant[i] = inv[i].is_negative_bitmask();
                pending |= 1 << i;
            }
        }
        while pending != 0 {
            let lead = pending.trailing_zeros() as usize;
            let mut members = [0usize; PACKET];
            let mut n = 0;
            let mut bits = pending;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if octant[i] == octant[lead] {
                    members[n] = i;
                    n += 1;
                    pending &= !(1 << i);
                }
            }
            let members = &members[..n];
            if !self.coherent(members.iter().map(|&i| (origin[i], dir[i]))) {
                for &i in members {
                    out[i] = self.closest_hit(&rays[i], tmax);
                }
                continue;
            }
            let mut groups = [RayGroup::UNUSED; GROUPS];
            let mut bundle = [(Vec3A::ZERO, Vec3A::ZERO); PACKET];
            for (k, &i) in members.iter().enumerate() {
                groups[k / 4].set(k % 4, origin[i], dir[i], inv[i], tmax);
                bundle[k] = (origin[i], inv[i]);
            }
            let groups = &mut groups[..n.div_ceil(4)];
            let interval = IntervalRay::new(&bundle[..n]);
            let negative = inv[lead].cmplt(Vec3A::ZERO);
            self.walk_nearest_first(
                tmax,
                |node, bound| node.intersect_interval(&interval, bound),
                |node, child, (block, count)| {
                    let (min, max) = node.child_box(child);
                    let (near, far) = (
                        Vec3A::select(negative, max, min),
                        Vec3A::select(negative, min, max),
                    );
                    for group in groups.iter_mut() {
                        if group.enters(near, far) {
                            for lane in 0..count {
                                let triangle = self.blocks[block].lane(lane);
                                group.intersect(&triangle, 4 * block + lane);
                            }
                        }
                    }
                    groups
                        .iter()
                        .fold(Vec4::NEG_INFINITY, |m, g| m.max(g.tmax))
                        .max_element()
                },
            );
            for (k, &i) in members.iter().enumerate() {
                let g = &groups[k / 4];
                let lane = k % 4;
                if g.slot[lane] != u32::MAX {
                    out[i] =
                        Some(self.hit(g.slot[lane] as usize, g.tmax[lane], g.u[lane], g.v[lane]));
                }
            }
        }
    }
}
