//! Moving objects as the master sends them: every frame, each movable object's placement
//! at the frame's display time, from keyframed paths (`--objects FILE`), or carried by the
//! wand (press the object button pointing at one, carry it while held — it stops where its
//! vertices would pass through a wall, a table or the floor — release: it stays),
//! in the frame state, so every wall draws the same placement. A replay's display times and
//! wand are the log's, so a replayed session gives the same placements bit for bit.

use std::sync::Arc;

use glam::Vec3;
use holocave_protocol::cluster::WireObject;
use holocave_scene::objects::PathError;
use holocave_scene::{MovableObject, ObjectPaths, Placement, Ray, Scene};

use crate::navigation::input::WandPose;
use crate::session::SavedObject;

/// How far the wand picks an object (m).
const REACH: f32 = 20.0;

/// Vertices per object whose paths are checked against the static scene while it is
/// carried (spread over its triangles).
const PROBES: usize = 256;

/// Up to [`PROBES`] of `object`'s vertices (its own frame), spread evenly over its
/// triangles.
fn probe_points(object: &MovableObject) -> Vec<Vec3> {
    let triangles = object.local_triangles();
    let step = (3 * triangles.len()).div_ceil(PROBES).max(1);
    triangles.iter().flatten().step_by(step).copied().collect()
}

/// An object in the wand's hand: which, and where it sits in the wand's frame.
#[derive(Clone, Copy, Debug)]
struct Carried {
    object: usize,
    in_hand: Placement,
}

/// The scene's movable objects, the paths that move them and the wand that carries them.
pub struct ObjectMotion {
    scene: Arc<Scene>,
    paths: ObjectPaths,
    /// Where each object stood at the last frame.
    now: Vec<Placement>,
    /// Objects the wand has moved leave their paths for good.
    off_path: Vec<bool>,
    carried: Option<Carried>,
    button_before: bool,
    /// Per object, the vertices whose paths a carried move must keep clear of walls.
    probes: Vec<Vec<Vec3>>,
}

/// The wand as a placement (scene coordinates, f32).
fn hand(w: &WandPose) -> Placement {
    Placement::new(w.position.as_vec3(), w.orientation.normalize().as_quat())
}

impl ObjectMotion {
    /// Moves `scene`'s objects along `paths` (empty: they stand until carried); refuses
    /// paths of objects the scene does not have.
    pub fn new(scene: Arc<Scene>, paths: ObjectPaths) -> Result<Self, PathError> {
        paths.check(&scene)?;
        let now = scene.rest_placements();
        Ok(ObjectMotion {
            off_path: vec![false; now.len()],
            now,
            scene: scene.clone(),
            paths,
            carried: None,
            button_before: false,
            probes: scene.objects().iter().map(probe_points).collect(),
        })
    }

    /// Every object's placement at `display_ns` (ns since the run started), in the
    /// scene's object order, the wand (scene coordinates) and its object button as they
    /// are this frame: a press picks the object the wand points at, holding carries it,
    /// releasing leaves it there.
    pub fn frame(
        &mut self,
        display_ns: u64,
        wand: Option<WandPose>,
        button: bool,
    ) -> Vec<WireObject> {
        let t = display_ns as f64 * 1e-9;
        for (k, o) in self.scene.objects().iter().enumerate() {
            if !self.off_path[k]
                && let Some(p) = self.paths.placement_at(&o.name, t)
            {
                self.now[k] = p;
            }
        }
        let pressed = button && !self.button_before;
        self.button_before = button;
        match (wand, button) {
            (Some(w), true) => {
                let hand = hand(&w);
                if pressed {
                    self.carried = self.pick(&w).map(|object| Carried {
                        object,
                        in_hand: hand.relative(&self.now[object]),
                    });
                }
                if let Some(c) = self.carried {
                    let to = hand.then(&c.in_hand);
                    if self.clear(c.object, &self.now[c.object], &to) {
                        self.now[c.object] = to;
                    }
                    self.off_path[c.object] = true;
                }
            }
            _ => self.carried = None,
        }
        self.scene
            .objects()
            .iter()
            .zip(&self.now)
            .map(|(o, p)| WireObject {
                name: o.name.clone(),
                position: p.translation.to_array(),
                orientation: p.rotation.to_array(),
            })
            .collect()
    }

    /// Where every object stands and whether the wand took it off its path, for the
    /// session's state.
    pub fn saved(&self) -> Vec<SavedObject> {
        (self
            .scene
            .objects()
            .iter()
            .zip(&self.now)
            .zip(&self.off_path))
        .map(|((o, p), &off_path)| SavedObject {
            name: o.name.clone(),
            position: p.translation.to_array(),
            orientation: p.rotation.to_array(),
            off_path,
        })
        .collect()
    }

    /// Places the objects as a resumed session left them; an object this scene does not
    /// have is an error naming it.
    pub fn resume(&mut self, saved: &[SavedObject]) -> Result<(), String> {
        for s in saved {
            let Some(k) = self.scene.objects().iter().position(|o| o.name == s.name) else {
                return Err(format!(
                    "the resumed session moved an object {:?} that this scene does not have",
                    s.name
                ));
            };
            let (at, turn) = (
                Vec3::from_array(s.position),
                glam::Quat::from_array(s.orientation),
            );
            if !at.is_finite() || !turn.is_finite() || (turn.length() - 1.0).abs() > 1e-3 {
                return Err(format!(
                    "object {:?}: not a finite position and unit rotation",
                    s.name
                ));
            }
            self.now[k] = Placement::new(at, turn.normalize());
            self.off_path[k] = s.off_path;
        }
        Ok(())
    }

    /// Whether object `k` may move from `from` to `to`: none of its probe vertices'
    /// straight paths crosses the static scene (a carried chair stops at a wall or a
    /// table instead of passing through; sliding along the floor it touches is free).
    fn clear(&self, k: usize, from: &Placement, to: &Placement) -> bool {
        self.probes[k].iter().all(|&p| {
            let (a, b) = (from.to_world_point(p), to.to_world_point(p));
            let d = b - a;
            let len = d.length();
            len <= 1e-6 || !self.scene.occluded(&Ray::new(a, d / len), len)
        })
    }

    /// The moving object the wand points at, if the first thing it points at is one.
    fn pick(&self, w: &WandPose) -> Option<usize> {
        let dir = (w.orientation * glam::DVec3::NEG_Z).as_vec3().normalize();
        let ray = Ray::new(w.position.as_vec3(), dir);
        let placed = self.scene.placed(&self.now);
        let hit = placed.closest_hit(&ray, REACH)?;
        placed.object_of(hit.triangle)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, Quat, Vec3};
    use holocave_scene::LoadOptions;
    use std::path::Path;

    fn room() -> Arc<Scene> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
        let opts = LoadOptions::with_objects(&["block", "lamp"]);
        Arc::new(Scene::load(&path, &opts).unwrap())
    }

    /// Every frame's placements follow the path at the frame's display time, the same
    /// bits for the same frame (a replay's frame states are equal), and an object without
    /// a path stands at rest; a path for an object the scene lacks is refused by name.
    #[test]
    fn frames_carry_the_paths_placements() {
        let scene = room();
        let text = "object,time_s,tx,ty,tz,qx,qy,qz,qw\n\
                    block,0,0,0,0,0,0,0,1\n\
                    block,2,2,0,-4,0,0.7071068,0,0.7071068\n";
        let paths = ObjectPaths::parse(text, Path::new("path.csv")).unwrap();
        let mut motion = ObjectMotion::new(scene.clone(), paths.clone()).unwrap();
        let at = motion.frame(1_000_000_000, None, false);
        assert_eq!(at.len(), 2);
        assert_eq!(
            (at[0].name.as_str(), at[0].position),
            ("block", [1.0, 0.0, -2.0])
        );
        let half = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(Quat::from_array(at[0].orientation).dot(half).abs() > 1.0 - 1e-6);
        let rest = scene.rest_placements()[1];
        assert_eq!(at[1].position, rest.translation.to_array());
        let mut again = ObjectMotion::new(scene.clone(), paths).unwrap();
        assert_eq!(
            again.frame(1_000_000_000, None, false),
            at,
            "the same frame, the same bits"
        );
        let other = ObjectPaths::parse(
            "object,time_s,tx,ty,tz,qx,qy,qz,qw\nsofa,0,0,0,0,0,0,0,1\n",
            Path::new("sofa.csv"),
        )
        .unwrap();
        let e = ObjectMotion::new(scene, other)
            .err()
            .expect("refused")
            .to_string();
        assert!(e.contains("sofa") && e.contains("sofa.csv"), "{e}");
    }

    /// The room's objects, none on a path; the block's rest placement, its bounds (its own
    /// frame) and centre, and a wand spot 1.5 m in front of it (+Z side).
    fn block_in_front(scene: &Arc<Scene>) -> (ObjectMotion, Placement, (Vec3, Vec3), Vec3, Vec3) {
        let motion = ObjectMotion::new(scene.clone(), ObjectPaths::default()).unwrap();
        let bounds = scene.objects()[0].local_bounds();
        let rest = scene.rest_placements()[0];
        let centre = rest.to_world_point(0.5 * (bounds.0 + bounds.1));
        (
            motion,
            rest,
            bounds,
            centre,
            centre + Vec3::new(0.0, 0.0, 1.5),
        )
    }

    /// Pointing the wand at the block and pressing picks it up; moving and turning the
    /// wand carries it rigidly (its offset in the hand kept); releasing leaves it where it
    /// was carried, and the wand moves on alone. Pointing at a wall picks nothing.
    #[test]
    fn the_wand_carries_the_block_and_lets_it_go() {
        let scene = room();
        let (mut motion, rest, (lo, hi), centre, from) = block_in_front(&scene);
        let wand = |p: Vec3, q: DQuat| WandPose {
            position: p.as_dvec3(),
            orientation: q,
        };
        let level = DQuat::IDENTITY;
        let at = |w: &[WireObject]| Vec3::from_array(w[0].position);
        // Pointing away (at the room, +Z): nothing picked, nothing moves.
        let away = DQuat::from_rotation_y(std::f64::consts::PI);
        let w = motion.frame(0, Some(wand(from, away)), true);
        assert_eq!(at(&w), rest.translation);
        motion.frame(1, Some(wand(from, away)), false);
        // Press pointing at it, carry 1 m along +X and a quarter turn about the wand.
        motion.frame(2, Some(wand(from, level)), true);
        let turn = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let moved_to = from + Vec3::X;
        let w = motion.frame(3, Some(wand(moved_to, turn)), true);
        let carried = Placement::new(
            Vec3::from_array(w[0].position),
            Quat::from_array(w[0].orientation),
        );
        let expect_centre = moved_to + turn.as_quat() * (centre - from);
        let got_centre = carried.to_world_point(0.5 * (lo + hi));
        assert!(
            (got_centre - expect_centre).length() < 1e-4,
            "{got_centre} against {expect_centre}"
        );
        // Released: it stays; the wand moves on alone.
        motion.frame(4, Some(wand(moved_to, turn)), false);
        let w = motion.frame(5, Some(wand(from - Vec3::X * 3.0, level)), false);
        assert!((at(&w) - carried.translation).length() < 1e-6);
    }

    /// An object the wand carried, saved and resumed into a new motion that has a path for
    /// it, stands where it was left and does not follow the path; one the scene does not have
    /// is refused by name.
    #[test]
    fn saved_objects_resume_where_they_were_left() {
        let scene = room();
        let text = "object,time_s,tx,ty,tz,qx,qy,qz,qw\n\
                    block,0,0,0,0,0,0,0,1\n\
                    block,2,2,0,-4,0,0,0,1\n";
        let paths = ObjectPaths::parse(text, Path::new("path.csv")).unwrap();
        let (mut motion, _, _, _, from) = block_in_front(&scene);
        let wand = |p: Vec3| WandPose {
            position: p.as_dvec3(),
            orientation: DQuat::IDENTITY,
        };
        motion.frame(0, Some(wand(from)), true);
        let left = motion.frame(1, Some(wand(from + Vec3::Y * 0.3)), true);
        let saved = motion.saved();
        assert!(saved[0].off_path && !saved[1].off_path);
        let mut again = ObjectMotion::new(scene.clone(), paths).unwrap();
        again.resume(&saved).unwrap();
        let later = again.frame(1_000_000_000, None, false);
        assert_eq!(later[0], left[0], "the carried block stays off its path");
        let mut other = saved.clone();
        other[0].name = "sofa".into();
        let e = again.resume(&other).unwrap_err();
        assert!(e.contains("sofa"), "{e}");
    }

    /// Carried 10 m towards a wall in 5 cm steps, the block stops inside the room (no
    /// vertex of it ever beyond the wall's plane), and carried back it follows again.
    #[test]
    fn a_carried_object_stops_at_the_wall() {
        let scene = room();
        let (mut motion, rest, _, _, from) = block_in_front(&scene);
        let wand = |p: Vec3| WandPose {
            position: p.as_dvec3(),
            orientation: DQuat::IDENTITY,
        };
        let (room_lo, _) = scene.bounds();
        let inside = |w: &[WireObject]| {
            let p = Placement::new(
                Vec3::from_array(w[0].position),
                Quat::from_array(w[0].orientation),
            );
            (scene.objects()[0].local_triangles().iter().flatten())
                .map(|&v| p.to_world_point(v).x)
                .fold(f32::INFINITY, f32::min)
        };
        motion.frame(0, Some(wand(from)), true);
        let mut last = Vec3::ZERO;
        for k in 1..=200u64 {
            let w = motion.frame(k, Some(wand(from - Vec3::X * 0.05 * k as f32)), true);
            assert!(
                inside(&w) >= room_lo.x - 1e-4,
                "frame {k}: a vertex at x = {} beyond the wall at {}",
                inside(&w),
                room_lo.x
            );
            last = Vec3::from_array(w[0].position);
        }
        assert!(
            (last - rest.translation).length() > 0.1,
            "it moved before it stopped"
        );
        let w = motion.frame(201, Some(wand(from - Vec3::X * 0.5)), true);
        assert!(
            (Vec3::from_array(w[0].position) - last).length() > 0.1,
            "carried back, it follows"
        );
    }
}
