//! Which section serves a ray when a holodeck has several (paper §2.1, as rholo chooses):
//! the section holding the ray's origin — the eye — and, when none does, the one the ray
//! enters first. A section stores only rays passing through its box, so a ray from an eye
//! inside a section is there; an eye outside every section sees through the nearest one
//! the ray reaches, which holds the light arriving through its far side.

use glam::DVec3;

use crate::section::{Crossing, Section};

/// The section serving the ray from `origin` along `dir`, and where the ray crosses it;
/// `None` when the ray reaches no section ahead. Among sections holding the origin the
/// first listed serves (sections may overlap); otherwise the least entry distance.
pub fn serving_section(
    sections: &[Section],
    origin: DVec3,
    dir: DVec3,
) -> Option<(usize, Crossing)> {
    let mut nearest: Option<(usize, Crossing)> = None;
    for (i, s) in sections.iter().enumerate() {
        let Some(c) = s.crossing(origin, dir) else {
            continue;
        };
        if c.t_exit <= 0.0 {
            continue;
        }
        if c.t_entry <= 0.0 {
            return Some((i, c));
        }
        if nearest.is_none_or(|(_, n)| c.t_entry < n.t_entry) {
            nearest = Some((i, c));
        }
    }
    nearest
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::section::ViewClass;

    fn boxes() -> Vec<Section> {
        // Two rooms along X joined by a doorway's gap, and a hall above the second.
        [
            ([0.0, 0.0, 0.0], [4.0, 3.0, 4.0]),
            ([4.5, 0.0, 0.0], [9.0, 3.0, 5.0]),
            ([5.0, 3.5, 1.0], [8.0, 6.0, 4.0]),
        ]
        .iter()
        .map(|&(lo, hi)| {
            Section::of_box(
                DVec3::from(lo),
                DVec3::from(hi),
                Some([4, 3, 4]),
                ViewClass::Interior,
            )
            .unwrap()
        })
        .collect()
    }

    /// The rule by brute force: walk along the ray in small steps from the origin; the
    /// first step that lies in some box names the section (the first listed on ties).
    fn by_marching(sections: &[Section], origin: DVec3, dir: DVec3) -> Option<usize> {
        let step = 1e-3;
        (0..40_000).find_map(|k| {
            let p = origin + dir * (f64::from(k) * step);
            sections.iter().position(|s| {
                let u = s.unit_coords(p);
                u.cmpgt(DVec3::ZERO).all() && u.cmplt(DVec3::ONE).all()
            })
        })
    }

    proptest! {
        #[test]
        fn the_serving_section_is_the_first_one_the_ray_is_in(
            o in prop::array::uniform3(-2.0f64..11.0),
            d in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let (o, d) = (DVec3::from(o), DVec3::from(d));
            prop_assume!(d.length() > 0.1);
            let d = d.normalize();
            let sections = boxes();
            let got = serving_section(&sections, o, d).map(|(i, _)| i);
            let want = by_marching(&sections, o, d);
            // The march steps 1 mm: a ray grazing a box for less than a step, or starting
            // within a step of a face, may be told apart by the step alone.
            if got != want {
                let near_face = |p: DVec3| sections.iter().any(|s| {
                    let u = s.unit_coords(p);
                    let e = 2e-3 / s.edges().iter().map(|e| e.length()).fold(f64::MAX, f64::min);
                    (0..3).any(|a| u[a].abs() < e || (u[a] - 1.0).abs() < e)
                });
                let graze = got.or(want).is_some_and(|i| {
                    sections[i].crossing(o, d).is_some_and(|c| {
                        let len = sections[i].edges()[0].length();
                        (c.t_exit - c.t_entry.max(0.0)) < 2e-3 * len.max(1.0)
                    })
                });
                prop_assert!(near_face(o) || graze, "{o} {d}: rule {got:?}, march {want:?}");
            }
        }
    }

    #[test]
    fn an_eye_in_a_section_is_served_by_it_whatever_the_direction() {
        let s = boxes();
        let eye = DVec3::new(2.0, 1.6, 2.0);
        for d in [
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            DVec3::new(1.0, 0.2, 0.1).normalize(),
        ] {
            assert_eq!(serving_section(&s, eye, d).map(|(i, _)| i), Some(0));
        }
        // From the doorway's gap, looking into the second room and up into the hall.
        let gap = DVec3::new(4.25, 1.6, 2.0);
        assert_eq!(serving_section(&s, gap, DVec3::X).map(|(i, _)| i), Some(1));
        assert_eq!(serving_section(&s, gap, -DVec3::X).map(|(i, _)| i), Some(0));
        assert_eq!(serving_section(&s, gap, DVec3::Z), None);
        let up = DVec3::new(6.0, 3.2, 2.0);
        assert_eq!(serving_section(&s, up, DVec3::Y).map(|(i, _)| i), Some(2));
    }
}
