//! One triangle's ray test, by Möller–Trumbore.
//!
//! Möller–Trumbore in `f32` is not watertight: a ray through the edge two triangles share
//! can get a barycentric of −1e-7 in both and slip through a closed surface. The bounds
//! are therefore widened by [`EDGE_TOLERANCE`] (far above the rounding error, far below
//! anything visible); the BVH clamps the barycentrics of the hit it keeps back into the
//! triangle.
//!
//! A leaf's triangles (up to four) are stored as one [`TriangleBlock`], in
//! structure-of-arrays form, and a single ray meets all four in one pass of four-wide
//! operations, with no branch per triangle.

use glam::{BVec4A, Vec3A, Vec4};

/// How far outside `[0, 1]` a barycentric may fall and still hit: 50 times the rounding
/// error seen on shared edges, i.e. 10 µm on a 1 m triangle.
pub const EDGE_TOLERANCE: f32 = 1e-5;

/// A triangle prepared for intersection: first vertex and the two edges from it.
#[derive(Clone, Copy, Debug)]
pub(super) struct IsectTriangle {
    pub v0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
}

impl From<&obvhs::triangle::Triangle> for IsectTriangle {
    fn from(t: &obvhs::triangle::Triangle) -> Self {
        IsectTriangle {
            v0: t.v0,
            e1: t.v1 - t.v0,
            e2: t.v2 - t.v0,
        }
    }
}

impl IsectTriangle {
    /// The box around every point the widened test accepts, and how far (per axis) it
    /// reaches beyond the vertices' box: the tolerance along the edges, and a few ulps
    /// of the coordinates for rounding.
    pub fn bounds(&self) -> (Vec3A, Vec3A, Vec3A) {
        let (a, b, c) = (self.v0, self.v0 + self.e1, self.v0 + self.e2);
        let (min, max) = (a.min(b).min(c), a.max(b).max(c));
        let edge = self
            .e1
            .abs()
            .max(self.e2.abs())
            .max((self.e2 - self.e1).abs());
        let magnitude = min.abs().max(max.abs());
        let pad = edge * (2.0 * EDGE_TOLERANCE) + magnitude * (4.0 * f32::EPSILON);
        (min - pad, max + pad, pad)
    }
}

/// Up to four triangles, lane by lane; an unused lane is all zeros (its determinant is
/// zero, so every ray misses it). Each lane's triangle index in the caller's numbering is
/// kept with it: the cache lines a hit was just found in also name it.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(super) struct TriangleBlock {
    pub v0: [Vec4; 3],
    pub e1: [Vec4; 3],
    pub e2: [Vec4; 3],
    /// The caller's index of each lane's triangle (`u32::MAX` for an unused lane).
    pub ids: [u32; 4],
}

/// A ray spread over four lanes, for [`TriangleBlock::intersect`].
pub(super) struct BlockRay {
    origin: [Vec4; 3],
    dir: [Vec4; 3],
}

impl BlockRay {
    pub fn new(origin: Vec3A, dir: Vec3A) -> Self {
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Self {
            origin: splat(origin),
            dir: splat(dir),
        }
    }
}

/// What a ray met in a block: per lane the distance (infinite on a miss) and the
/// barycentrics, and the lanes hit as bits.
pub(super) struct BlockHits {
    pub t: Vec4,
    pub u: Vec4,
    pub v: Vec4,
    pub lanes: u32,
}

impl BlockHits {
    /// The nearest lane hit, if any, with its `(t, u, v)`.
    #[inline(always)]
    pub fn nearest(&self) -> Option<(usize, f32, f32, f32)> {
        if self.lanes == 0 {
            return None;
        }
        let t = self.t.min_element();
        let lane = (self.t.cmpeq(Vec4::splat(t)).bitmask() & self.lanes).trailing_zeros() as usize;
        Some((lane, t, self.u[lane], self.v[lane]))
    }
}

impl TriangleBlock {
    /// The block of `triangles` (one to four), with their indices `ids`.
    pub fn new(triangles: &[IsectTriangle], ids: &[u32]) -> Self {
        debug_assert!((1..=4).contains(&triangles.len()) && ids.len() == triangles.len());
        let mut block = TriangleBlock {
            v0: [Vec4::ZERO; 3],
            e1: [Vec4::ZERO; 3],
            e2: [Vec4::ZERO; 3],
            ids: [u32::MAX; 4],
        };
        block.ids[..ids.len()].copy_from_slice(ids);
        for (lane, tri) in triangles.iter().enumerate() {
            for axis in 0..3 {
                block.v0[axis][lane] = tri.v0[axis];
                block.e1[axis][lane] = tri.e1[axis];
                block.e2[axis][lane] = tri.e2[axis];
            }
        }
        block
    }

    /// One lane's triangle.
    #[inline(always)]
    pub fn lane(&self, lane: usize) -> IsectTriangle {
        let get = |p: &[Vec4; 3]| Vec3A::new(p[0][lane], p[1][lane], p[2][lane]);
        IsectTriangle {
            v0: get(&self.v0),
            e1: get(&self.e1),
            e2: get(&self.e2),
        }
    }

    /// Möller–Trumbore for the four lanes at once.
    #[inline(always)]
    pub fn intersect(&self, ray: &BlockRay, tmax: f32) -> BlockHits {
        let (t, u, v, hit) = intersect4(
            &ray.origin,
            &ray.dir,
            [&self.v0, &self.e1, &self.e2],
            Vec4::splat(tmax),
        );
        BlockHits {
            t: Vec4::select(hit, t, Vec4::INFINITY),
            u,
            v,
            lanes: hit.bitmask(),
        }
    }
}

/// Möller–Trumbore in four lanes, each lane its own ray and triangle (a caller splats what
/// its lanes share: one ray against a block of four triangles, or one triangle against
/// four rays), with the single-triangle tolerance: hits within [`EDGE_TOLERANCE`] outside
/// the edges count, and any NaN along the way is a miss. Returns `t`, `u`, `v` and the
/// lanes hit before their `tmax`.
#[inline(always)]
pub(super) fn intersect4(
    origin: &[Vec4; 3],
    dir: &[Vec4; 3],
    [v0, e1, e2]: [&[Vec4; 3]; 3],
    tmax: Vec4,
) -> (Vec4, Vec4, Vec4, BVec4A) {
    let [dx, dy, dz] = *dir;
    let [e1x, e1y, e1z] = *e1;
    let [e2x, e2y, e2z] = *e2;
    let px = dy * e2z - dz * e2y;
    let py = dz * e2x - dx * e2z;
    let pz = dx * e2y - dy * e2x;
    let det = e1x * px + e1y * py + e1z * pz;
    let inv = Vec4::ONE / det;
    let sx = origin[0] - v0[0];
    let sy = origin[1] - v0[1];
    let sz = origin[2] - v0[2];
    let u = (sx * px + sy * py + sz * pz) * inv;
    let qx = sy * e1z - sz * e1y;
    let qy = sz * e1x - sx * e1z;
    let qz = sx * e1y - sy * e1x;
    let v = (dx * qx + dy * qy + dz * qz) * inv;
    let t = (e2x * qx + e2y * qy + e2z * qz) * inv;
    let low = Vec4::splat(-EDGE_TOLERANCE);
    let high = Vec4::splat(1.0 + EDGE_TOLERANCE);
    // A zero determinant (a ray in the triangle's plane, or an unused lane) needs no test
    // of its own: u is then ±∞ or NaN, and fails its bounds.
    let hit = u.cmpge(low)
        & u.cmple(high)
        & v.cmpge(low)
        & (u + v).cmple(high)
        & t.cmpge(Vec4::ZERO)
        & t.cmplt(tmax);
    (t, u, v, hit)
}
