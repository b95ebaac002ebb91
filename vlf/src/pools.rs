//! Pools of small elements: what keeps the light that reaches elements smaller than a
//! line's reach. A line's light is spread over at least `least` (a quarter of a line's
//! cross-section, see `bake`), so that two tiny elements facing each other along one line
//! cannot pass light back and forth with a gain above 1; alone, an element smaller than
//! that keeps only `A / least` of what reaches it and the rest is lost (a scene of many
//! small triangles — chairs, cups — came out too dark by tens of per cent), and one a
//! few times larger receives a few dozen lines, its light patchy. Elements smaller than
//! [`POOLED_BELOW`] `× least` are pooled with their neighbours of the same material and
//! orientation (the same side, the same dominant axis of its normal) in a cell of side
//! `2 √least`: a pool receives the light of all its members over their summed area, never
//! less than `least`, so the gain stays bounded as before and none of the light that
//! arrived is thrown away while the pool reaches `least`. A pool's one value would show
//! as a patch the size of its cell: once converged, each pooled element is drawn from the
//! trilinear blend of the pools around it ([`Pools::smooth`]).
//!
//! Only elements drawn diffuse are pooled: a glossy element that small gets no tile
//! ([`Tiles::new`]) and is drawn diffuse with its BSDF's albedo, so it is pooled here too.
//! (Pooling tiles — the binned arrivals of a pool's tiles summed and reflected by each
//! member's BSDF — was tried: on the breakfast room that bake's bounces grew after the
//! sixth.) Measured on the breakfast room's `CameraMain` against `render`: pools of diffuse
//! elements took the walls from −24 % to −16 % (92 directions, 64 lines); with the small
//! glossy elements pooled as well, +1.4 % (162 / 96; `docs/performance/history.md`).

use std::collections::HashMap;

use glam::Vec3;
use holocave_scene::{Hit, Scene};

use crate::elements::{Elements, cell_index};
use crate::tiles::Tiles;

/// Elements smaller than this many times the least area are pooled (and get no tile).
pub const POOLED_BELOW: f32 = 4.0;

/// Whether an element of `area` is pooled (and has no tile) where a line's light is
/// spread over at least `least`.
pub fn pooled(area: f32, least: f32) -> bool {
    area < POOLED_BELOW * least
}

/// What pools a small element with others: its material, side, dominant normal axis and
/// the cell it lies in.
type PoolKey = (u32, u32, u32, [i32; 3]);

/// The pools of one bake.
pub struct Pools {
    /// Each element's pool (`u32::MAX`: not pooled).
    pub of: Vec<u32>,
    /// Each pool's members, in element order.
    pub members: Vec<Vec<u32>>,
    /// Each pool's area (the sum of its members').
    pub area: Vec<f32>,
    pub least: f32,
    /// Each pool's key, and the pools by key.
    keys: Vec<PoolKey>,
    index: HashMap<PoolKey, u32>,
    /// Each pooled element's position in cells (its position over the cell's side).
    at: HashMap<u32, Vec3>,
}

impl Pools {
    /// Pools every diffuse element smaller than `least` (not a delta: `needed`; not
    /// glossy: `tiles`) with its neighbours; deterministic (pools are numbered in element
    /// order).
    pub fn new(
        scene: &Scene,
        elements: &Elements,
        tiles: &Tiles,
        area: &[f32],
        needed: &[bool],
        least: f32,
    ) -> Pools {
        let cell = 2.0 * least.sqrt();
        let mut of = vec![u32::MAX; elements.count];
        let mut members: Vec<Vec<u32>> = Vec::new();
        let mut index: HashMap<PoolKey, u32> = HashMap::new();
        let mut keys = Vec::new();
        let mut at = HashMap::new();
        for (t, cells) in elements.triangles.iter().enumerate() {
            let r = cells.res;
            let material = scene.triangle_shading(t as u32).material;
            for side in 0..2u32 {
                let n = if side == 0 {
                    scene.face_normal(t as u32)
                } else {
                    -scene.face_normal(t as u32)
                };
                let a = n.abs();
                let axis = if a.x >= a.y && a.x >= a.z {
                    0
                } else if a.y >= a.z {
                    1
                } else {
                    2
                };
                let dir = axis * 2 + u32::from(n[axis as usize] < 0.0);
                for j in 0..r {
                    for i in 0..r - j {
                        let e = cells.base(side) + cell_index(i, j, r);
                        if !pooled(area[e as usize], least)
                            || !needed[e as usize]
                            || tiles.of(e).is_some()
                        {
                            continue;
                        }
                        let (u, v) = (
                            (i as f32 + 1.0 / 3.0) / r as f32,
                            (j as f32 + 1.0 / 3.0) / r as f32,
                        );
                        let p = scene
                            .surface(&Hit {
                                triangle: t as u32,
                                t: 0.0,
                                u,
                                v,
                            })
                            .position;
                        let voxel = (p / cell).floor().as_ivec3().to_array();
                        let key = (material, side, dir, voxel);
                        let k = *index.entry(key).or_insert_with(|| {
                            members.push(Vec::new());
                            keys.push(key);
                            (members.len() - 1) as u32
                        });
                        at.insert(e, p / cell);
                        members[k as usize].push(e);
                        of[e as usize] = k;
                    }
                }
            }
        }
        let pool_area = members
            .iter()
            .map(|m| m.iter().map(|&e| area[e as usize]).sum())
            .collect();
        Pools {
            of,
            members,
            area: pool_area,
            least,
            keys,
            index,
            at,
        }
    }

    /// The drawn values of pooled elements: a pool holds one value for its whole cell,
    /// which shows as patches on a curved surface of small triangles (a chair's shell).
    /// Each pooled element takes instead the trilinear blend, at its own position, of the
    /// pools of its material, side and orientation in the eight cells around it (those
    /// that exist), each weighed by its area as well (a pool's value is the mean over its
    /// area: a pool of a few tiny elements, hit by few lines and kept to the clamp's
    /// `A / least` of its light, counts as little as its area does; weighed alike, such
    /// pools took the breakfast room's chairs from 0.92 to 0.86 of the path tracer's
    /// inter-reflected light, median at 292 points), each pool's value the area-weighted
    /// mean of its members' `total − sharp`; its `sharp` part (direct light, caustics)
    /// stays its own. Linear in `total`, so a split of the total smooths to the split's
    /// sum.
    /// `area` weighs the members and the pools: the elements' open areas (their parts
    /// inside an object resting on them left out), so that a pool wholly under an object
    /// weighs nothing.
    pub fn smooth(&self, area: &[f32], sharp: &[[f32; 3]], total: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let rest = |e: u32| Vec3::from(total[e as usize]) - Vec3::from(sharp[e as usize]);
        let weight: Vec<f32> = (self.members.iter())
            .map(|m| m.iter().map(|&e| area[e as usize]).sum())
            .collect();
        let value: Vec<Vec3> = (self.members.iter().zip(&weight))
            .map(|(m, a)| {
                m.iter().map(|&e| rest(e) * area[e as usize]).sum::<Vec3>()
                    / a.max(f32::MIN_POSITIVE)
            })
            .collect();
        let mut out = total.to_vec();
        for (&e, &x) in &self.at {
            let (material, side, dir, _) = self.keys[self.of[e as usize] as usize];
            let g = x - Vec3::splat(0.5);
            let base = g.floor();
            let f = g - base;
            let (mut sum, mut w) = (Vec3::ZERO, 0.0);
            for corner in 0..8 {
                let o = Vec3::new(
                    (corner & 1) as f32,
                    ((corner >> 1) & 1) as f32,
                    ((corner >> 2) & 1) as f32,
                );
                let voxel = (base + o).as_ivec3().to_array();
                let Some(&p) = self.index.get(&(material, side, dir, voxel)) else {
                    continue;
                };
                let t = Vec3::ONE - o + f * (2.0 * o - Vec3::ONE);
                let weight = t.x * t.y * t.z * weight[p as usize];
                sum += value[p as usize] * weight;
                w += weight;
            }
            if w > 0.0 {
                out[e as usize] = (Vec3::from(sharp[e as usize]) + sum / w).to_array();
            }
        }
        out
    }

    /// The irradiance of every element from the light (flux) each received, `sums`:
    /// divided by its receiving area (`receiving`) alone, or pooled.
    pub fn irradiance(&self, sums: &[Vec3], receiving: &[f32]) -> Vec<[f32; 3]> {
        let pooled: Vec<Vec3> = self
            .members
            .iter()
            .zip(&self.area)
            .map(|(m, a)| m.iter().map(|&e| sums[e as usize]).sum::<Vec3>() / a.max(self.least))
            .collect();
        sums.iter()
            .zip(receiving)
            .zip(&self.of)
            .map(|((s, a), p)| match *p {
                u32::MAX => (*s / *a).to_array(),
                p => pooled[p as usize].to_array(),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two pools side by side: one of ten elements of area 1 whose light is 1, and one
    /// tiny element (area 0.01) kept to a fifth of its light by the clamp. An element of
    /// the large pool on the cells' common face takes half of each cell by position, but
    /// the tiny pool weighs its area: `(10 + 0.002) / 10.01`, within 0.1 % of 1. Weighed
    /// alike, the two gave 0.6.
    #[test]
    fn a_tiny_pool_weighs_as_little_as_its_area() {
        let key = |x: i32| (0u32, 0u32, 2u32, [x, 0, 0]);
        let members = vec![(0..10).collect::<Vec<u32>>(), vec![10]];
        let mut of = vec![0u32; 10];
        of.push(1);
        let at: HashMap<u32, Vec3> = (0..11)
            .map(|e| (e, Vec3::new(if e == 10 { 1.5 } else { 1.0 }, 0.5, 0.5)))
            .collect();
        let pools = Pools {
            of,
            area: vec![10.0, 0.01],
            members,
            least: 1.0,
            keys: vec![key(0), key(1)],
            index: [(key(0), 0), (key(1), 1)].into_iter().collect(),
            at,
        };
        let mut area = vec![1.0f32; 10];
        area.push(0.01);
        let mut total = vec![[1.0f32; 3]; 10];
        total.push([0.2; 3]);
        let sharp = vec![[0.0f32; 3]; 11];
        let drawn = pools.smooth(&area, &sharp, &total)[0][0];
        assert!((drawn - 1.0).abs() < 1e-3, "drawn {drawn}");
    }
}
