//! The field's remainder smoothed over planes, across triangles: the lines' ray effects.
//!
//! The field carries light along a fixed set of directions. A bright patch (the sun's on
//! the floor, the window's sky) seen by a surface from a few metres reaches it along each
//! direction from a shifted place, so the surface's irradiance from the patch steps as each
//! direction's lines cross the patch's edge: the discrete-ordinates "ray effect", diagonal
//! streaks a few tens of centimetres apart on a plain wall (the distance to the patch times
//! the directions' spacing), which the bake's smoothing within a triangle's own cells
//! ([`crate::bake::smooth_indirect`]) is too small to reach. What the field keeps once the
//! direct light is drawn per pixel ([`crate::split`]) is inter-reflected light and the
//! sky's, smooth at that scale but for contact shadows and corners. So each element of a
//! large triangle takes the mean of the elements on its plane and side within [`RADIUS`]
//! element sizes, across triangle edges: a tent in distance, weighted by area, and by how
//! alike the two values are (a Gaussian in log luminance, [`RANGE_SIGMA`]): ray effects
//! differ by tens of per cent from place to place, a wall's foot in the floor's shadow by
//! a factor, which stays. A glossy element's tile is averaged bin by bin with the tiles of
//! its plane (they share one frame, so a bin is the same direction in each).
//!
//! Measured (`docs/performance/history.md`): the room's front wall (the front wall of `sim`)
//! 0.0060 → 0.0052 against two 2048-path renders whose own error is 0.0043, the streaks
//! gone; the room's floor view 0.0035 → 0.0027 (its varnished table top's streaks were in
//! its tiles); the breakfast room unchanged (0.0494 → 0.0496).

use std::collections::HashMap;
use std::sync::Mutex;

use glam::{IVec3, Vec3};
use holocave_scene::{Hit, Scene, luminance};
use rayon::prelude::*;

use crate::elements::Elements;
use crate::tiles::Tiles;

/// The radius of the mean, in element sizes (22 cm at the room's default bake).
pub const RADIUS: f32 = 4.0;
/// How alike two values must be to be averaged: the Gaussian's width in log luminance.
pub const RANGE_SIGMA: f32 = 0.25;

/// Two elements lie on one plane when their normals part by less than this cosine...
const SAME_NORMAL: f32 = 0.995;
/// ...and each lies within this fraction of an element's size of the other's plane (a
/// skirting board a centimetre in front of its wall is not the wall).
const PLANE_TOLERANCE: f32 = 0.02;
/// Only elements of triangles at least this fraction of the disc the radius spans take
/// part: the large flat surfaces where ray effects show (walls, floors, table tops);
/// small triangles (a chair's shell) are pooled and smoothed by the bake.
const LARGE: f32 = 0.25;
/// ...and only elements at least this fraction of an element size squared: a long thin
/// triangle's slivers (a skirting board's, a table's apron) would put thousands of
/// neighbours in one tent (the breakfast room opened in 6 s instead of 2.4) for streaks no
/// one sees on a strip a few centimetres wide.
const LEAST_ELEMENT: f32 = 0.25;

/// The last fields smoothed in this process ([`KEPT`] at most, the newest last), by a
/// checksum of their values and layout: a node lighting its wall for another time of day
/// draws the same bake again, or a bake set's same two bakes blended anew, and smoothing
/// them is most of that work (1.3 s of 1.5 on the room, four nodes on two cores).
static LAST: Mutex<Vec<Smoothed>> = Mutex::new(Vec::new());

/// How many smoothed fields are kept: a bake set's two around the time of day.
const KEPT: usize = 2;

/// A field smoothed, and the checksum of what it was smoothed from.
struct Smoothed {
    key: u32,
    values: Vec<[f32; 3]>,
}

/// `values` (the elements', then the tiles') with each element of a large triangle
/// averaged over the elements of its plane and side within [`RADIUS`] element sizes that
/// are alike in value, diffuse with diffuse, a tile with tiles bin by bin. The last fields
/// smoothed are kept, and given again for the same values and layout.
pub fn smooth_over_planes(
    scene: &Scene,
    elements: &Elements,
    tiles: &Tiles,
    values: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let key = checksum(scene, elements, values);
    let mut last = LAST.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(at) = last.iter().position(|kept| kept.key == key) {
        let kept = last.remove(at);
        let values = kept.values.clone();
        last.push(kept);
        return values;
    }
    let smoothed = smoothed_anew(scene, elements, tiles, values);
    if last.len() == KEPT {
        last.remove(0);
    }
    last.push(Smoothed {
        key,
        values: smoothed.clone(),
    });
    smoothed
}

/// A checksum of what a smoothing depends on: the values, the elements' count and the
/// scene's triangles (not its light).
fn checksum(scene: &Scene, elements: &Elements, values: &[[f32; 3]]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    let mut eat = |x: [f32; 3]| {
        for c in x {
            h.update(&c.to_le_bytes());
        }
    };
    values.iter().for_each(|&v| eat(v));
    for t in 0..scene.triangle_count() as u32 {
        scene.triangle(t).iter().for_each(|p| eat(p.to_array()));
    }
    h.update(&(elements.count as u64).to_le_bytes());
    h.finalize()
}

fn smoothed_anew(
    scene: &Scene,
    elements: &Elements,
    tiles: &Tiles,
    values: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let mut out = values.to_vec();
    if elements.count == 0 {
        return out;
    }
    let planes = &Planes::new(scene, elements, tiles, values);
    // Cell by cell: the elements of a cell share the neighbours they look at.
    let cells: Vec<(&IVec3, &Vec<u32>)> = planes.grid.iter().collect();
    let smoothed: Vec<(usize, Vec<Vec3>)> = cells
        .into_par_iter()
        .flat_map_iter(|(&at, list)| {
            let around = planes.around(at);
            list.iter()
                .map(move |&e| (e as usize, planes.mean_among(e as usize, &around, values)))
                .collect::<Vec<_>>()
        })
        .collect();
    for (e, v) in smoothed {
        for (o, x) in out[planes.range_of(e)].iter_mut().zip(v) {
            *o = x.to_array();
        }
    }
    out
}

/// What a mean looks at of an element taking part: where it lies, its side's normal, its
/// area and log luminance, and whether it has a tile.
#[derive(Clone, Copy)]
struct Taker {
    index: u32,
    place: Vec3,
    normal: Vec3,
    area: f32,
    log_lum: f32,
    tiled: bool,
}

/// The elements that take part, where they lie, a grid of them by place, and their log
/// luminance: what each element's mean looks at.
struct Planes<'a> {
    tiles: &'a Tiles,
    radius: f32,
    /// How far an element may lie off another's plane.
    tolerance: f32,
    /// The taking part elements by cell of `radius`.
    grid: HashMap<IVec3, Vec<u32>>,
    /// Each element as the means look at it (meaningful where it takes part).
    takers: Vec<Taker>,
}

impl<'a> Planes<'a> {
    fn new(scene: &Scene, elements: &Elements, tiles: &'a Tiles, values: &[[f32; 3]]) -> Self {
        let radius = RADIUS * elements.element_size;
        let (area, centres) = elements.areas_and_centres(scene);
        let large_area = LARGE * std::f32::consts::PI * radius * radius;
        let least_element = LEAST_ELEMENT * elements.element_size * elements.element_size;
        let taking: Vec<bool> = (0..elements.count)
            .map(|e| scene.triangle_area(centres[e].0) >= large_area && area[e] >= least_element)
            .collect();
        let mut planes = Planes {
            tiles,
            radius,
            tolerance: PLANE_TOLERANCE * elements.element_size,
            grid: HashMap::new(),
            takers: Vec::new(),
        };
        planes.takers = (0..elements.count)
            .into_par_iter()
            .map(|e| {
                let mut taker = Taker {
                    index: e as u32,
                    place: Vec3::ZERO,
                    normal: Vec3::ZERO,
                    area: area[e],
                    log_lum: 0.0,
                    tiled: tiles.of(e as u32).is_some(),
                };
                if !taking[e] {
                    return taker;
                }
                let (t, u, v) = centres[e];
                let c = elements.triangles[t as usize];
                let back = e as u32 >= c.base(1);
                taker.normal = scene.face_normal(t) * if back { -1.0 } else { 1.0 };
                let hit = Hit {
                    triangle: t,
                    t: 0.0,
                    u,
                    v,
                };
                taker.place = scene.surface(&hit).position;
                let r = planes.range_of(e);
                let n = r.len() as f32;
                let mean = values[r]
                    .iter()
                    .map(|v| luminance(Vec3::from(*v)))
                    .sum::<f32>()
                    / n;
                taker.log_lum = mean.max(f32::MIN_POSITIVE).ln();
                taker
            })
            .collect();
        for (e, t) in planes.takers.iter().enumerate() {
            if taking[e] {
                let at = planes.cell(t.place);
                planes.grid.entry(at).or_default().push(e as u32);
            }
        }
        planes
    }

    fn cell(&self, p: Vec3) -> IVec3 {
        (p / self.radius).floor().as_ivec3()
    }

    /// An element's values: its irradiance, or its tile's bins (a plane's tiles share one
    /// frame, so their bins are the same directions).
    fn range_of(&self, e: usize) -> std::ops::Range<usize> {
        match self.tiles.of(e as u32) {
            Some(g) => {
                let k = self.tiles.per_tile();
                let at = self.tiles.elements as usize + g as usize * k;
                at..at + k
            }
            None => e..e + 1,
        }
    }

    /// The elements an element of cell `at` may take its mean over: those of the cell and
    /// its 26 neighbours, in a fixed order.
    fn around(&self, at: IVec3) -> Vec<Taker> {
        let mut around = Vec::new();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(list) = self.grid.get(&(at + IVec3::new(dx, dy, dz))) {
                        around.extend(list.iter().map(|&j| self.takers[j as usize]));
                    }
                }
            }
        }
        around
    }

    /// Element `e`'s mean of `values` over the elements `around` it that lie on its plane
    /// and side within the radius and are alike in value, diffuse with diffuse, a tile
    /// with tiles.
    fn mean_among(&self, e: usize, around: &[Taker], values: &[[f32; 3]]) -> Vec<Vec3> {
        let me = self.takers[e];
        let mut sum = vec![Vec3::ZERO; self.range_of(e).len()];
        let mut w = 0.0f32;
        for j in around {
            if j.tiled != me.tiled || me.normal.dot(j.normal) < SAME_NORMAL {
                continue;
            }
            let d = j.place - me.place;
            if me.normal.dot(d).abs() > self.tolerance {
                continue;
            }
            let dist = d.length();
            if dist >= self.radius {
                continue;
            }
            let range = (j.log_lum - me.log_lum).powi(2);
            let weight = j.area
                * (1.0 - dist / self.radius)
                * (-range / (2.0 * RANGE_SIGMA * RANGE_SIGMA)).exp();
            match sum.as_mut_slice() {
                [s] => *s += Vec3::from(values[j.index as usize]) * weight,
                bins => {
                    let theirs = &values[self.range_of(j.index as usize)];
                    for (s, v) in bins.iter_mut().zip(theirs) {
                        *s += Vec3::from(*v) * weight;
                    }
                }
            }
            w += weight;
        }
        sum.into_iter()
            .map(|s| s / w.max(f32::MIN_POSITIVE))
            .collect()
    }
}
