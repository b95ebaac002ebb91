//! The section of a CAVE's holodeck: the box around the CAVE's walls (the room's inside
//! volume) in scene coordinates, interior (looking out), so every eye in the room lies in
//! it and every line of sight through a wall crosses it — cut down, where the scene has
//! surfaces inside the CAVE (a floor, a table), to the empty box around the room's inside
//! point: a section only holds rays passing through it (paper §2.1), so a surface inside
//! it would vanish from every view.

use glam::DVec3;
use holocave_cave::Cave;
use holocave_scene::Scene;
use holocave_scene::empty_box::{Aabb, empty_box};

use crate::section::{Section, SectionError, ViewClass};

/// Surfaces are kept outside a CAVE's section by at least this fraction of the CAVE's
/// size (its box's largest edge in the scene): 1 cm for a 3 m CAVE. Relative, so a CAVE
/// placed in a scene at another scale keeps the same margin.
pub const SURFACE_GAP: f64 = 1.0 / 300.0;

/// Why a CAVE has no holodeck section.
#[derive(Debug, thiserror::Error)]
pub enum CaveSectionError {
    #[error(
        "the scene has a surface within {gap:.3e} m of the CAVE's inside point \
         {inside:.3} (scene coordinates): no holodeck section fits around the viewer"
    )]
    NoRoom { inside: DVec3, gap: f64 },
    #[error("the CAVE's section: {0}")]
    Section(#[from] SectionError),
}

/// A CAVE's section and the box it was cut from (equal when nothing was in the way).
#[derive(Clone, Debug)]
pub struct CaveSection {
    pub section: Section,
    /// The box around the walls, in scene coordinates.
    pub walls_box: Aabb,
    /// The section's box: `walls_box` cut to leave the scene's surfaces outside.
    pub cut: Aabb,
}

impl CaveSection {
    /// The section for `cave` in `scene`.
    pub fn new(cave: &Cave, scene: &Scene) -> Result<CaveSection, CaveSectionError> {
        let walls_box = walls_box(cave);
        let inside = cave.room_to_scene.transform_point3(cave.inside);
        let gap = SURFACE_GAP * (walls_box.hi - walls_box.lo).max_element();
        let cut = empty_box(scene, walls_box, inside, gap)
            .ok_or(CaveSectionError::NoRoom { inside, gap })?;
        let d = cut.hi - cut.lo;
        let section = Section::with_default_grid(
            cut.lo,
            [DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z],
            ViewClass::Interior,
        )?;
        Ok(CaveSection {
            section,
            walls_box,
            cut,
        })
    }

    /// True when scene surfaces made the section smaller than the walls' box.
    pub fn was_cut(&self) -> bool {
        self.cut != self.walls_box
    }
}

/// The box (scene coordinates, axis-aligned) around the CAVE's walls and inside point.
fn walls_box(cave: &Cave) -> Aabb {
    let mut lo = cave.inside;
    let mut hi = cave.inside;
    for w in &cave.walls {
        for p in [w.pa, w.pb, w.pc, w.pd()] {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    // The walls' box may be flat (a single wall): give it depth toward the inside point,
    // and at least 1 m on every axis.
    let mid = (lo + hi) * 0.5;
    let half = ((hi - lo) * 0.5).max(DVec3::splat(0.5));
    let (lo, hi) = (mid - half, mid + half);
    let m = cave.room_to_scene;
    let mut out = Aabb {
        lo: DVec3::splat(f64::INFINITY),
        hi: DVec3::splat(f64::NEG_INFINITY),
    };
    for i in 0..8 {
        let pick = |bit: usize, a: f64, b: f64| if i & bit == 0 { a } else { b };
        let p = m.transform_point3(DVec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        ));
        out.lo = out.lo.min(p);
        out.hi = out.hi.max(p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_cave::load_cave;
    use holocave_scene::LoadOptions;
    use holocave_scene::empty_box::triangles_inside;
    use std::path::Path;

    fn project_file(name: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name)
    }

    #[test]
    fn the_section_holds_every_eye_and_no_surface() {
        let cave = load_cave(&project_file("configs/cave4.toml")).unwrap();
        let scene =
            Scene::load(&project_file("scenes/room.gltf"), &LoadOptions::default()).unwrap();
        let s = CaveSection::new(&cave, &scene).unwrap();
        let inside = cave.room_to_scene.transform_point3(cave.inside);
        assert!(s.section.contains(inside));
        assert!(
            triangles_inside(&scene, &s.walls_box) > 0,
            "the room reaches into the CAVE"
        );
        assert!(s.was_cut(), "{:?}", s.cut);
        assert_eq!(triangles_inside(&scene, &s.cut), 0);
    }

    #[test]
    fn a_cave_and_scene_scaled_together_get_the_same_section_scaled() {
        // The stress runs of `holocave compare --scale`: the margin is relative, so a
        // millimetre-sized CAVE in a millimetre-sized room gets a section too.
        let at_scale = |scale: f64| {
            let mut cave = load_cave(&project_file("configs/cave4.toml")).unwrap();
            cave.place_in_scene(scale, DVec3::ZERO);
            let scene = Scene::load(&project_file("scenes/room.gltf"), &LoadOptions::default())
                .unwrap()
                .transformed(scale as f32, glam::Vec3::ZERO)
                .unwrap();
            CaveSection::new(&cave, &scene).unwrap().cut
        };
        let one = at_scale(1.0);
        for scale in [1e-3, 1e4] {
            let s = at_scale(scale);
            for (a, b) in [(s.lo, one.lo), (s.hi, one.hi)] {
                let err = (a / scale - b).abs().max_element();
                assert!(err < 1e-4, "at scale {scale}: {a} against {b} (×{scale})");
            }
        }
    }
}
