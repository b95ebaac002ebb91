//! Sections proposed from a scene's free space (`holocave holodeck sections`): one
//! interior section per room a person can stand in, so a walk-through finds a section
//! wherever it goes (paper §2.1: "multiple interior sections might define regions of free
//! movement in each room of a house").
//!
//! How rooms are found, on a grid over the floor plan at standing height:
//! 1. The floors are the heights with much upward-facing area ([`floor_levels`]; or one
//!    given): each level is searched for rooms on its own.
//! 2. A cell is *free* where a person could stand: a ray down from eye height meets a
//!    floor's front face near the floor's height, the ray up meets no back face first
//!    (the eye is not inside a solid), and nothing comes within the body's clearance at
//!    eye and waist height.
//! 3. Rooms are the free regions that stay apart when the free space is eroded by half a
//!    doorway's width (so doorways and narrow gaps separate rooms); every free cell then
//!    joins the room nearest to it through free space.
//! 4. Each room's box spans its cells, from just above the floor to the lowest ceiling
//!    over its core (the cells left after erosion; not a doorway's lintel), and is cut
//!    down (`holocave_scene::empty_box`) until no surface lies inside it, keeping the
//!    room's most open cell: a section only holds rays passing through it, so a surface
//!    inside would vanish from every view. Where columns or furniture leave parts of the
//!    room outside that box, more boxes are cut around the most open cell not yet
//!    covered, up to [`MAX_SECTIONS_PER_ROOM`].

use std::collections::VecDeque;

use glam::{DVec3, Vec3};
use holocave_scene::Scene;
use holocave_scene::empty_box::{Aabb, empty_box};
use holocave_scene::ray::Ray;
use rayon::prelude::*;

/// How rooms are looked for.
#[derive(Clone, Debug)]
pub struct FreeSpaceOptions {
    /// Grid cell size, metres (scene units).
    pub cell: f64,
    /// Eye height above the floor.
    pub eye_height: f64,
    /// How far a standing person keeps from walls and furniture.
    pub clearance: f64,
    /// Openings up to this wide separate rooms (doorways, gaps between columns).
    pub doorway: f64,
    /// The floor's height; `None`: every level [`floor_levels`] finds.
    pub floor: Option<f64>,
    /// Rooms with less free floor than this (m²) are left out.
    pub min_area: f64,
}

impl Default for FreeSpaceOptions {
    fn default() -> Self {
        FreeSpaceOptions {
            cell: 0.1,
            eye_height: 1.6,
            clearance: 0.25,
            doorway: 1.2,
            floor: None,
            min_area: 2.0,
        }
    }
}

/// Why no sections could be proposed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FreeSpaceError {
    #[error("the scene has no upward-facing surface to stand on")]
    NoFloor,
    #[error("{0} must be finite and positive")]
    BadOption(&'static str),
    #[error("no room of at least {min_area} m² to stand in at eye height {eye:.2}")]
    NoRoom { min_area: f64, eye: f64 },
}

/// A room found, and the sections proposed for it.
#[derive(Clone, Debug)]
pub struct Room {
    /// The sections' boxes (scene coordinates), each empty of surfaces; the first around
    /// the room's most open point.
    pub sections: Vec<Aabb>,
    /// Free floor area of the room, m².
    pub area: f64,
    /// The fraction of that floor under one of its sections.
    pub covered: f64,
}

/// At most this many sections are cut for one room.
pub const MAX_SECTIONS_PER_ROOM: usize = 6;

/// The grid of the floor plan: cell `(i, k)` at `x = lo.x + (i + ½)·cell`, likewise z.
struct Plan {
    lo: DVec3,
    cell: f64,
    nx: usize,
    nz: usize,
}

impl Plan {
    fn centre(&self, i: usize, k: usize, y: f64) -> DVec3 {
        DVec3::new(
            self.lo.x + (i as f64 + 0.5) * self.cell,
            y,
            self.lo.z + (k as f64 + 0.5) * self.cell,
        )
    }

    /// The 4-neighbours of cell `c` (index `k · nx + i`).
    fn neighbours(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let (i, k) = (c % self.nx, c / self.nx);
        [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
            .into_iter()
            .filter_map(move |(di, dk)| {
                let (a, b) = (i as i64 + di, k as i64 + dk);
                (a >= 0 && b >= 0 && (a as usize) < self.nx && (b as usize) < self.nz)
                    .then(|| b as usize * self.nx + a as usize)
            })
    }
}

/// The rooms of `scene` and a section for each, largest first.
pub fn propose_sections(scene: &Scene, o: &FreeSpaceOptions) -> Result<Vec<Room>, FreeSpaceError> {
    for (name, v) in [
        ("cell", o.cell),
        ("eye_height", o.eye_height),
        ("clearance", o.clearance),
        ("doorway", o.doorway),
        ("min_area", o.min_area),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(FreeSpaceError::BadOption(name));
        }
    }
    let floors = match o.floor {
        Some(f) if f.is_finite() => vec![f],
        Some(_) => return Err(FreeSpaceError::BadOption("floor")),
        None => floor_levels(scene, o.cell, 0.3 * o.eye_height),
    };
    if floors.is_empty() {
        return Err(FreeSpaceError::NoFloor);
    }
    let (lo, hi) = scene.bounds();
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    // At most 1024 cells a side: a coarser grid for a very large scene.
    let cell = o.cell.max((hi.x - lo.x).max(hi.z - lo.z) / 1024.0);
    let plan = Plan {
        lo,
        cell,
        nx: ((hi.x - lo.x) / cell).ceil().max(1.0) as usize,
        nz: ((hi.z - lo.z) / cell).ceil().max(1.0) as usize,
    };
    let mut out: Vec<Room> = (floors.iter())
        .flat_map(|&f| rooms_on_floor(scene, &plan, f, hi.y, o))
        .collect();
    if out.is_empty() {
        return Err(FreeSpaceError::NoRoom {
            min_area: o.min_area,
            eye: floors[0] + o.eye_height,
        });
    }
    out.sort_by(|a, b| b.area.total_cmp(&a.area));
    Ok(out)
}

/// The rooms of one floor level: where a person stands on a floor at about `floor`.
fn rooms_on_floor(
    scene: &Scene,
    plan: &Plan,
    floor: f64,
    top: f64,
    o: &FreeSpaceOptions,
) -> Vec<Room> {
    let eye = floor + o.eye_height;
    let ceilings: Vec<Option<f64>> = (0..plan.nx * plan.nz)
        .into_par_iter()
        .map(|c| standing(scene, plan, c, floor, o).then(|| ceiling(scene, plan, c, eye, top)))
        .collect();
    let free: Vec<bool> = ceilings.iter().map(Option::is_some).collect();
    // Erode by half a doorway, label what is left, and let every free cell join the
    // nearest label through free space.
    let depth = distance_to_blocked(plan, &free);
    let core_cells = (0.5 * o.doorway / plan.cell).ceil() as u32;
    let core: Vec<bool> = depth.iter().map(|&d| d > core_cells).collect();
    let (label, rooms) = label_rooms(plan, &free, &core);
    let level = Level {
        scene,
        plan,
        floor,
        eye,
        ceilings: &ceilings,
        core: &core,
        depth: &depth,
        o,
    };
    (0..rooms)
        .filter_map(|r| level.room((0..free.len()).filter(|&c| label[c] == r).collect()))
        .collect()
}

/// Each free cell's room (`u32::MAX`: none) and how many rooms: the connected parts of
/// `core`, each grown through free space to the free cells nearest it.
fn label_rooms(plan: &Plan, free: &[bool], core: &[bool]) -> (Vec<u32>, u32) {
    let mut label = vec![u32::MAX; free.len()];
    let mut rooms = 0u32;
    let mut queue = VecDeque::new();
    for start in 0..free.len() {
        if !core[start] || label[start] != u32::MAX {
            continue;
        }
        label[start] = rooms;
        queue.push_back(start);
        while let Some(c) = queue.pop_front() {
            for n in plan.neighbours(c) {
                if core[n] && label[n] == u32::MAX {
                    label[n] = rooms;
                    queue.push_back(n);
                }
            }
        }
        rooms += 1;
    }
    queue.extend((0..free.len()).filter(|&c| label[c] != u32::MAX));
    while let Some(c) = queue.pop_front() {
        for n in plan.neighbours(c) {
            if free[n] && label[n] == u32::MAX {
                label[n] = label[c];
                queue.push_back(n);
            }
        }
    }
    (label, rooms)
}

/// One floor level's plan: each cell's ceiling where a person stands there, the eroded
/// core, and each cell's distance to a blocked one.
struct Level<'a> {
    scene: &'a Scene,
    plan: &'a Plan,
    floor: f64,
    eye: f64,
    ceilings: &'a [Option<f64>],
    core: &'a [bool],
    depth: &'a [u32],
    o: &'a FreeSpaceOptions,
}

impl Level<'_> {
    /// The room of `cells`, if it is one: at least the least area, its ceiling above eye
    /// height, and empty boxes covering it.
    fn room(&self, cells: Vec<usize>) -> Option<Room> {
        let (plan, cell) = (self.plan, self.plan.cell);
        let area = cells.len() as f64 * cell * cell;
        if area < self.o.min_area {
            return None;
        }
        let gap = (0.01 * self.o.eye_height).max(1e-3);
        let (mut blo, mut bhi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for &c in &cells {
            let p = plan.centre(c % plan.nx, c / plan.nx, 0.0);
            blo = blo.min(p - 0.5 * cell);
            bhi = bhi.max(p + 0.5 * cell);
        }
        // The ceiling over the room's core: a lintel over its doorway does not lower it.
        let lowest_ceiling = (cells.iter())
            .filter(|&&c| self.core[c])
            .filter_map(|&c| self.ceilings[c])
            .fold(f64::INFINITY, f64::min);
        blo.y = self.floor + gap;
        bhi.y = lowest_ceiling - gap;
        if bhi.y <= self.eye {
            return None;
        }
        let sections = self.sections(&cells, Aabb { lo: blo, hi: bhi }, gap);
        if sections.is_empty() {
            return None;
        }
        let covered = (cells.iter())
            .filter(|&&c| sections.iter().any(|b| self.inside(c, b)))
            .count();
        Some(Room {
            sections,
            area,
            covered: covered as f64 / cells.len() as f64,
        })
    }

    /// Boxes cut from the room's `bounds` around its most open cell not yet covered,
    /// until what is left is smaller than a room (columns or furniture standing in a room
    /// leave parts no single empty box reaches).
    fn sections(&self, cells: &[usize], bounds: Aabb, gap: f64) -> Vec<Aabb> {
        let (plan, cell, min_area) = (self.plan, self.plan.cell, self.o.min_area);
        let mut uncovered = cells.to_vec();
        let mut sections = Vec::new();
        while uncovered.len() as f64 * cell * cell >= min_area
            && sections.len() < MAX_SECTIONS_PER_ROOM
        {
            let most_open = *uncovered
                .iter()
                .max_by_key(|&&c| self.depth[c])
                .expect("cells are left");
            let keep = plan.centre(most_open % plan.nx, most_open / plan.nx, self.eye);
            match empty_box(self.scene, bounds, keep, gap) {
                Some(b) if (b.hi.x - b.lo.x) * (b.hi.z - b.lo.z) >= min_area => {
                    let before = uncovered.len();
                    uncovered.retain(|&c| !self.inside(c, &b));
                    // A box over floor the others already cover adds no room to stand in.
                    if (before - uncovered.len()) as f64 * cell * cell >= min_area {
                        sections.push(b);
                    }
                }
                // No room-sized empty box around this cell: leave it out.
                _ => uncovered.retain(|&c| c != most_open),
            }
        }
        sections
    }

    /// Whether cell `c`'s centre lies within `b` across the floor.
    fn inside(&self, c: usize, b: &Aabb) -> bool {
        let p = self
            .plan
            .centre(c % self.plan.nx, c / self.plan.nx, self.eye);
        p.x >= b.lo.x && p.x <= b.hi.x && p.z >= b.lo.z && p.z <= b.hi.z
    }
}

/// The heights people stand at: upward-facing triangle area binned by `bin` metres, the
/// bins holding at least a quarter of the largest bin's area, lowest first, one per
/// `step` (the larger of two closer than that): a ground floor, a raised court, an upper
/// gallery. A roof is a level too, but rooms on it end at the scene's top, below eye
/// height, and are left out.
pub fn floor_levels(scene: &Scene, bin: f64, step: f64) -> Vec<f64> {
    let mut bins: std::collections::BTreeMap<i64, (f64, f64)> = Default::default();
    for t in 0..scene.triangle_count() as u32 {
        if scene.face_normal(t).y < 0.9 {
            continue;
        }
        let [a, b, c] = scene.triangle(t).map(|p| p.as_dvec3());
        let area = 0.5 * (b - a).cross(c - a).length();
        let y = (a.y + b.y + c.y) / 3.0;
        let e = bins.entry((y / bin).floor() as i64).or_default();
        e.0 += area;
        e.1 += area * y;
    }
    let most = bins.values().map(|b| b.0).fold(0.0, f64::max);
    let mut levels: Vec<(f64, f64)> = Vec::new();
    for &(area, ay) in bins.values() {
        if area <= 0.0 || area < 0.25 * most {
            continue;
        }
        let y = ay / area;
        match levels.last_mut() {
            Some(last) if y - last.0 < step => {
                if area > last.1 {
                    *last = (y, area);
                }
            }
            _ => levels.push((y, area)),
        }
    }
    levels.into_iter().map(|l| l.0).collect()
}

/// Whether a person can stand in cell `c`: floor below at about the floor's height, the
/// eye not inside a solid (the rays down and up meet front faces first), nothing within
/// the clearance at eye and waist height.
fn standing(scene: &Scene, plan: &Plan, c: usize, floor: f64, o: &FreeSpaceOptions) -> bool {
    let eye = floor + o.eye_height;
    let p = plan.centre(c % plan.nx, c / plan.nx, eye).as_vec3();
    let front = |ray: &Ray, tmax: f32| -> Option<f32> {
        let h = scene.closest_hit(ray, tmax)?;
        // A back face first (of a one-sided surface): the ray started inside a solid.
        let material = scene.triangle_shading(h.triangle).material as usize;
        let one_sided = scene
            .materials
            .get(material)
            .is_some_and(|m| !m.double_sided);
        Some(
            if one_sided && scene.face_normal(h.triangle).dot(ray.dir) > 0.0 {
                -1.0
            } else {
                h.t
            },
        )
    };
    let down = Ray::new(p, Vec3::NEG_Y);
    let step = (0.3 * o.eye_height) as f32;
    match front(&down, o.eye_height as f32 + step) {
        Some(t) if (t - o.eye_height as f32).abs() <= step => {}
        _ => return false,
    }
    let up = Ray::new(p, Vec3::Y);
    if front(&up, f32::INFINITY).is_some_and(|t| t < 0.0) {
        return false;
    }
    let waist = p - Vec3::Y * (0.5 * o.eye_height) as f32;
    (0..8).all(|k| {
        let a = k as f32 * std::f32::consts::FRAC_PI_4;
        let d = Vec3::new(a.cos(), 0.0, a.sin());
        [p, waist]
            .iter()
            .all(|&q| front(&Ray::new(q, d), o.clearance as f32).is_none())
    })
}

/// The height of the ceiling above cell `c` (the scene's top where the sky is open).
fn ceiling(scene: &Scene, plan: &Plan, c: usize, eye: f64, top: f64) -> f64 {
    let p = plan.centre(c % plan.nx, c / plan.nx, eye).as_vec3();
    scene
        .closest_hit(&Ray::new(p, Vec3::Y), f32::INFINITY)
        .map_or(top, |h| eye + f64::from(h.t))
}

/// Per cell, the number of 4-steps to the nearest cell that is not free (or the plan's
/// edge): 0 for a blocked cell.
fn distance_to_blocked(plan: &Plan, free: &[bool]) -> Vec<u32> {
    let mut d = vec![u32::MAX; free.len()];
    let mut queue = VecDeque::new();
    for c in 0..free.len() {
        let (i, k) = (c % plan.nx, c / plan.nx);
        let edge = i == 0 || k == 0 || i + 1 == plan.nx || k + 1 == plan.nz;
        if !free[c] {
            d[c] = 0;
            queue.push_back(c);
        } else if edge {
            d[c] = 1;
            queue.push_back(c);
        }
    }
    while let Some(c) = queue.pop_front() {
        for n in plan.neighbours(c) {
            if d[n] == u32::MAX {
                d[n] = d[c] + 1;
                queue.push_back(n);
            }
        }
    }
    d
}
