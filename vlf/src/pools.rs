//! Pools of small elements: what keeps the light that reaches elements smaller than a
//! line's reach. A line's light is spread over at least `least` (a quarter of a line's
//! cross-section, see `bake`), so that two tiny elements facing each other along one line
//! cannot pass light back and forth with a gain above 1; alone, an element smaller than
//! that keeps only `A / least` of what reaches it and the rest is lost (a scene of many
//! small triangles — chairs, cups — came out too dark by tens of per cent). Elements
//! smaller than `least` are pooled with their neighbours of the same material and
//! orientation (the same side, the same dominant axis of its normal) in a cell of side
//! `2 √least`: a pool receives the light of all its members over their summed area, never
//! less than `least`, so the gain stays bounded as before and none of the light that
//! arrived is thrown away while the pool reaches `least`.
//!
//! Only elements drawn diffuse are pooled: a glossy element that small gets no tile
//! ([`Tiles::new`]) and is drawn diffuse with its BSDF's albedo, so it is pooled here too.
//! (Pooling tiles — the binned arrivals of a pool's tiles summed and reflected by each
//! member's BSDF — was tried: on the breakfast room that bake's bounces grew after the
//! sixth.) Measured on the breakfast room's `CameraMain` against `render`: pools of diffuse
//! elements took the walls from −24 % to −16 % (92 directions, 64 lines); with the small
//! glossy elements pooled as well, +1.4 % (162 / 96; `docs/vlf-direct.md`).

use std::collections::HashMap;

use glam::Vec3;
use holocave_scene::{Hit, Scene};

use crate::elements::{Elements, cell_index};
use crate::tiles::Tiles;

/// The pools of one bake.
pub struct Pools {
    /// Each element's pool (`u32::MAX`: not pooled).
    pub of: Vec<u32>,
    /// Each pool's members, in element order.
    pub members: Vec<Vec<u32>>,
    /// Each pool's area (the sum of its members').
    pub area: Vec<f32>,
    pub least: f32,
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
        let mut index: HashMap<(u32, u32, u32, bool, [i32; 3]), u32> = HashMap::new();
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
                        if area[e as usize] >= least || !needed[e as usize] || tiles.of(e).is_some()
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
                        let key = (material, side, dir, tiles.of(e).is_some(), voxel);
                        let k = *index.entry(key).or_insert_with(|| {
                            members.push(Vec::new());
                            (members.len() - 1) as u32
                        });
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
        }
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
