//! Off-axis frusta per wall and eye (Kooima, *Generalized Perspective Projection*): the
//! wall's screen basis, the extents of the wall at the near plane seen from the eye, and
//! view and projection matrices for wgpu (clip depth 0..1), with reversed Z and an
//! infinite far plane: depth = near / distance along the wall's normal, 1 at the near
//! plane, → 0 far away, so precision is spread evenly over distance.
//!
//! Computed in f64 (the f32 matrices for the GPU are derived from them). The near plane
//! is `min(room.near, distance to the wall / 2)`, so it never clips the wall itself. An eye
//! closer than [`MIN_EYE_DISTANCE`] to a wall's plane, on it, behind it, or not finite is a
//! tracking fault: that wall keeps its last good frustum, and the fault is counted and
//! reported. No NaN or infinity leaves this module.

use std::fmt;

use glam::{DMat4, DQuat, DVec3, DVec4, Mat4};
use holocave_tracking::Pose;

use crate::config::StereoMode;
use crate::validate::{Cave, MIN_EYE_DISTANCE, Wall};

/// The near plane is at most this fraction of the eye's distance to the wall.
pub const NEAR_FRACTION: f64 = 0.5;

/// Which eye a view is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Eye {
    Left,
    Right,
    /// Between the eyes (mono walls).
    Centre,
}

impl Eye {
    /// The eyes a wall in this stereo mode needs.
    pub fn for_mode(mode: StereoMode) -> &'static [Eye] {
        match mode {
            StereoMode::Pair => &[Eye::Left, Eye::Right],
            StereoMode::Mono => &[Eye::Centre],
            StereoMode::Left => &[Eye::Left],
            StereoMode::Right => &[Eye::Right],
        }
    }

    /// Offset along the head's +X axis, as a fraction of the IPD.
    fn side(self) -> f64 {
        match self {
            Eye::Left => -0.5,
            Eye::Right => 0.5,
            Eye::Centre => 0.0,
        }
    }
}

/// One view: scene → eye (`view`), eye → clip (`proj`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    pub view: DMat4,
    pub proj: DMat4,
    pub near: f64,
    /// The eye in room coordinates.
    pub eye: DVec3,
}

impl Frustum {
    pub fn view_proj(&self) -> DMat4 {
        self.proj * self.view
    }

    /// The matrices for the GPU.
    pub fn view_f32(&self) -> Mat4 {
        self.view.as_mat4()
    }

    pub fn proj_f32(&self) -> Mat4 {
        self.proj.as_mat4()
    }

    /// Every matrix entry is finite.
    pub fn is_finite(&self) -> bool {
        self.view.is_finite()
            && self.proj.is_finite()
            && self.near.is_finite()
            && self.eye.is_finite()
    }
}

/// Why no frustum could be made for an eye.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrustumFault {
    NonFiniteEye,
    /// Within [`MIN_EYE_DISTANCE`] of the wall's plane, or on it (distance in m).
    OnWall {
        distance: f64,
    },
    /// Behind the wall (distance in m, negative).
    Behind {
        distance: f64,
    },
}

impl fmt::Display for FrustumFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrustumFault::NonFiniteEye => write!(f, "eye position is NaN or infinite"),
            FrustumFault::OnWall { distance } => write!(
                f,
                "eye is {:.3e} m from the wall's plane (minimum {MIN_EYE_DISTANCE} m)",
                distance
            ),
            FrustumFault::Behind { distance } => {
                write!(f, "eye is {:.3e} m behind the wall", -distance)
            }
        }
    }
}

/// The off-axis frustum of `wall` seen from `eye` (room coordinates), with scene
/// coordinates mapped to the room by the inverse of `room_to_scene`.
pub fn off_axis(
    wall: &Wall,
    eye: DVec3,
    max_near: f64,
    room_to_scene: &DMat4,
) -> Result<Frustum, FrustumFault> {
    if !eye.is_finite() {
        return Err(FrustumFault::NonFiniteEye);
    }
    let d = wall.distance(eye);
    if d < 0.0 {
        return Err(FrustumFault::Behind { distance: d });
    }
    if d < MIN_EYE_DISTANCE {
        return Err(FrustumFault::OnWall { distance: d });
    }
    let near = max_near.min(NEAR_FRACTION * d);
    // Extents of the wall on the plane at distance d, in the wall's basis (Kooima's l, r,
    // b, t scaled by d/near: the projection below only needs their ratios to d).
    let (va, vb, vc) = (wall.pa - eye, wall.pb - eye, wall.pc - eye);
    let (l, r) = (wall.right.dot(va), wall.right.dot(vb));
    let (b, t) = (wall.up.dot(va), wall.up.dot(vc));
    let (w, h) = (r - l, t - b);
    // Eye space: x along the wall's right, y up, z toward the eye (looking down −z).
    let proj = DMat4::from_cols(
        DVec4::new(2.0 * d / w, 0.0, 0.0, 0.0),
        DVec4::new(0.0, 2.0 * d / h, 0.0, 0.0),
        DVec4::new((r + l) / w, (t + b) / h, 0.0, -1.0),
        DVec4::new(0.0, 0.0, near, 0.0),
    );
    let basis = DMat4::from_cols(
        wall.right.extend(0.0),
        wall.up.extend(0.0),
        wall.normal.extend(0.0),
        DVec4::W,
    )
    .transpose();
    let view = basis * DMat4::from_translation(-eye) * room_to_scene.inverse();
    let f = Frustum {
        view,
        proj,
        near,
        eye,
    };
    // Unreachable for finite eyes ≥ MIN_EYE_DISTANCE in front of a validated wall; kept as
    // the guarantee that nothing non-finite leaves.
    if f.is_finite() {
        Ok(f)
    } else {
        Err(FrustumFault::NonFiniteEye)
    }
}

/// Fault counts of one wall.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts {
    pub non_finite: u64,
    pub on_wall: u64,
    pub behind: u64,
}

impl FaultCounts {
    pub fn total(&self) -> u64 {
        self.non_finite + self.on_wall + self.behind
    }
}

/// The current views of one wall.
#[derive(Clone, Debug)]
pub struct WallViews {
    pub eyes: Vec<(Eye, Frustum)>,
    pub faults: FaultCounts,
    pub last_fault: Option<FrustumFault>,
    /// True while the views shown are held over from an earlier pose.
    pub holding: bool,
}

/// The frusta of every wall and eye, updated from head poses, holding the last good
/// frustum through faults.
#[derive(Clone, Debug)]
pub struct CaveFrusta {
    pub walls: Vec<WallViews>,
}

/// Eye positions in room coordinates for a head pose in room coordinates.
pub fn eye_position(cave: &Cave, head: &Pose, eye: Eye) -> DVec3 {
    let q = DQuat::from_array(head.orientation.to_array().map(f64::from));
    let centre = head.position.as_dvec3() + q * cave.head_to_eyes;
    centre + q * DVec3::new(eye.side() * cave.ipd, 0.0, 0.0)
}

/// The frusta of `eyes` of `wall` for a head pose in room coordinates: all of them, or the
/// fault of the first eye that has none.
pub fn wall_frusta(
    cave: &Cave,
    wall: &Wall,
    head: &Pose,
    eyes: &[Eye],
) -> Result<Vec<(Eye, Frustum)>, FrustumFault> {
    eyes.iter()
        .map(|&eye| {
            let f = off_axis(
                wall,
                eye_position(cave, head, eye),
                cave.near,
                &cave.room_to_scene,
            )?;
            Ok((eye, f))
        })
        .collect()
}

impl CaveFrusta {
    /// Frusta for an eye at the room's inside point (until tracking delivers a pose).
    pub fn new(cave: &Cave) -> CaveFrusta {
        let walls = cave
            .walls
            .iter()
            .map(|wall| {
                let f = off_axis(wall, cave.inside, cave.near, &cave.room_to_scene).unwrap_or(
                    Frustum {
                        view: DMat4::IDENTITY,
                        proj: DMat4::IDENTITY,
                        near: cave.near,
                        eye: cave.inside,
                    },
                );
                WallViews {
                    eyes: Eye::for_mode(wall.stereo).iter().map(|&e| (e, f)).collect(),
                    faults: FaultCounts::default(),
                    last_fault: None,
                    holding: false,
                }
            })
            .collect();
        CaveFrusta { walls }
    }

    /// Recomputes every wall's views for a head pose in room coordinates. A wall where
    /// any of its eyes faults keeps all its last good views (the eyes stay consistent).
    pub fn update(&mut self, cave: &Cave, head: &Pose) {
        for (wall, views) in cave.walls.iter().zip(self.walls.iter_mut()) {
            let eyes: Vec<Eye> = views.eyes.iter().map(|&(e, _)| e).collect();
            match wall_frusta(cave, wall, head, &eyes) {
                Ok(fresh) => {
                    views.eyes = fresh;
                    views.holding = false;
                }
                Err(e) => {
                    match e {
                        FrustumFault::NonFiniteEye => views.faults.non_finite += 1,
                        FrustumFault::OnWall { .. } => views.faults.on_wall += 1,
                        FrustumFault::Behind { .. } => views.faults.behind += 1,
                    }
                    if !views.holding {
                        tracing::warn!("wall {:?}: {e}; keeping its last good frustum", wall.name);
                    }
                    views.last_fault = Some(e);
                    views.holding = true;
                }
            }
        }
    }

    /// One line per wall with faults.
    pub fn fault_report(&self, cave: &Cave) -> String {
        let mut out = String::new();
        for (wall, v) in cave.walls.iter().zip(&self.walls) {
            if v.faults.total() > 0 {
                out += &format!(
                    "wall {:?}: {} frustum faults ({} eye not finite, {} eye on the wall, {} eye behind it); last: {}\n",
                    wall.name,
                    v.faults.total(),
                    v.faults.non_finite,
                    v.faults.on_wall,
                    v.faults.behind,
                    v.last_fault.map(|f| f.to_string()).unwrap_or_default()
                );
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::load_cave;
    use glam::{Quat, Vec3};
    use std::path::Path;

    fn cave4() -> Cave {
        load_cave(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/cave4.toml")).unwrap()
    }

    /// NDC of a room point through a frustum (scene = room · room_to_scene).
    fn ndc(f: &Frustum, cave: &Cave, p: DVec3) -> DVec3 {
        let c = f.view_proj() * (cave.room_to_scene * p.extend(1.0));
        c.truncate() / c.w
    }

    fn assert_corners_map(cave: &Cave, wall: &Wall, f: &Frustum, tol: f64) {
        for (p, want) in [
            (wall.pa, (-1.0, -1.0)),
            (wall.pb, (1.0, -1.0)),
            (wall.pc, (-1.0, 1.0)),
            (wall.pd(), (1.0, 1.0)),
        ] {
            let n = ndc(f, cave, p);
            assert!(
                (n.x - want.0).abs() <= tol && (n.y - want.1).abs() <= tol,
                "wall {} eye {:?}: corner {p} → {n}",
                wall.name,
                f.eye
            );
            assert!(
                n.z > 0.0 && n.z <= NEAR_FRACTION * (1.0 + 1e-9),
                "depth {} not inside 0..1 beyond the near plane",
                n.z
            );
        }
    }

    /// Deterministic points spread through the cube, including ones 1 mm from walls.
    fn eyes_inside() -> Vec<DVec3> {
        let mut out = Vec::new();
        let mut s = 0x2545F491u64;
        let mut u = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let m = 1e-3 + 1e-9;
        for _ in 0..2000 {
            out.push(DVec3::new(
                -1.5 + m + (3.0 - 2.0 * m) * u(),
                m + (3.0 - 2.0 * m) * u(),
                -1.5 + m + (3.0 - 2.0 * m) * u(),
            ));
        }
        for c in [-1.5 + m, 1.5 - m] {
            out.push(DVec3::new(c, 1.5, 0.0));
            out.push(DVec3::new(0.0, 1.5, c));
            out.push(DVec3::new(c, m, c));
        }
        out
    }

    #[test]
    fn wall_corners_map_to_ndc_corners_for_eyes_anywhere_inside() {
        let mut cave = cave4();
        for nav in [
            DMat4::IDENTITY,
            DMat4::from_rotation_translation(
                DQuat::from_rotation_y(0.7),
                DVec3::new(5.0, -2.0, 30.0),
            ),
        ] {
            cave.room_to_scene = nav;
            for eye in eyes_inside() {
                for wall in &cave.walls {
                    let f = off_axis(wall, eye, cave.near, &cave.room_to_scene).unwrap();
                    assert!(f.near < wall.distance(eye), "near plane clips the wall");
                    assert_corners_map(&cave, wall, &f, 1e-5);
                }
            }
        }
    }

    #[test]
    fn f32_matrices_map_corners_for_eyes_away_from_the_walls() {
        let cave = cave4();
        for eye in eyes_inside()
            .into_iter()
            .filter(|e| cave.walls.iter().all(|w| w.distance(*e) > 0.05))
        {
            for wall in &cave.walls {
                let f = off_axis(wall, eye, cave.near, &cave.room_to_scene).unwrap();
                let vp = f.proj_f32() * f.view_f32();
                for (p, want) in [(wall.pa, (-1.0, -1.0)), (wall.pd(), (1.0, 1.0))] {
                    let c = vp * p.as_vec3().extend(1.0);
                    let n = c.truncate() / c.w;
                    assert!(
                        (n.x - want.0).abs() < 1e-4 && (n.y - want.1).abs() < 1e-4,
                        "{} {eye}: {n}",
                        wall.name
                    );
                }
            }
        }
    }

    #[test]
    fn stress_sweep_toward_onto_and_behind_every_wall() {
        let cave = cave4();
        let mut distances: Vec<f64> = (0..=18).map(|k| 10f64.powf(-k as f64 / 2.0)).collect(); // 1 m .. 1e-9 m
        distances.push(0.0);
        distances.extend((0..=18).rev().map(|k| -(10f64.powf(-k as f64 / 2.0))));
        for (wi, wall) in cave.walls.iter().enumerate() {
            let mut frusta = CaveFrusta::new(&cave);
            let centre = (wall.pa + wall.pd()) / 2.0;
            // Face the wall squarely; the pair of eyes is split along the wall's right.
            let rot = Quat::from_mat3(&glam::Mat3::from_cols(
                wall.right.as_vec3(),
                wall.up.as_vec3(),
                wall.normal.as_vec3(),
            ));
            let mut expected_faults = 0;
            let mut last_good = frusta.walls[wi].eyes.clone();
            for &d in &distances {
                let eye_centre = centre + wall.normal * d;
                let head_pos = eye_centre
                    - (DQuat::from_array(rot.to_array().map(f64::from)) * cave.head_to_eyes);
                let head = Pose::new(head_pos.as_vec3(), rot);
                let actual = eye_position(&cave, &head, Eye::Left);
                let dist = wall.distance(actual);
                frusta.update(&cave, &head);
                let v = &frusta.walls[wi];
                for (_, f) in &v.eyes {
                    assert!(
                        f.is_finite(),
                        "wall {} at {d} m: non-finite frustum",
                        wall.name
                    );
                    assert!(f.view_f32().is_finite() && f.proj_f32().is_finite());
                }
                if dist >= MIN_EYE_DISTANCE {
                    assert!(!v.holding, "wall {} at {d} m", wall.name);
                    for (_, f) in &v.eyes {
                        assert_corners_map(&cave, wall, f, 1e-5);
                    }
                    last_good = v.eyes.clone();
                } else {
                    expected_faults += 1;
                    assert!(
                        v.holding,
                        "wall {} at {d} m (eye at {dist} m) should fault",
                        wall.name
                    );
                    assert_eq!(v.eyes, last_good, "the last good frustum is kept");
                    let fault = v.last_fault.unwrap();
                    if dist < 0.0 {
                        assert!(
                            matches!(fault, FrustumFault::Behind { .. }),
                            "{fault:?} at {dist}"
                        );
                    } else {
                        assert!(
                            matches!(fault, FrustumFault::OnWall { .. }),
                            "{fault:?} at {dist}"
                        );
                    }
                }
                // Other walls stay valid: the eye is still inside the cube.
                for (oi, ow) in frusta.walls.iter().enumerate() {
                    if oi != wi {
                        assert!(ow.eyes.iter().all(|(_, f)| f.is_finite()));
                    }
                }
            }
            let v = &frusta.walls[wi];
            assert_eq!(v.faults.total(), expected_faults, "wall {}", wall.name);
            // The head pose is f32, so the smallest offsets round onto the plane.
            assert!(
                v.faults.on_wall >= 7 && v.faults.behind >= 10,
                "{:?}",
                v.faults
            );
            let report = frusta.fault_report(&cave);
            assert!(
                report.contains(&format!(
                    "wall {:?}: {expected_faults} frustum faults",
                    wall.name
                )),
                "{report}"
            );
        }
    }

    #[test]
    fn exact_sweep_in_f64_from_one_metre_to_a_nanometre_and_behind() {
        let cave = cave4();
        for wall in &cave.walls {
            for anchor in [
                (wall.pa + wall.pd()) / 2.0,
                wall.pa,
                wall.pd(),
                wall.pa + wall.right * 0.3 + wall.up * 2.9,
            ] {
                for k in 0..=18 {
                    for sign in [1.0, -1.0] {
                        let eye = anchor + wall.normal * (sign * 10f64.powf(-k as f64 / 2.0));
                        let d = wall.distance(eye);
                        assert!((d.abs() - 10f64.powf(-k as f64 / 2.0)).abs() < 1e-12);
                        match off_axis(wall, eye, cave.near, &cave.room_to_scene) {
                            Ok(f) => {
                                assert!(d >= MIN_EYE_DISTANCE, "{d}");
                                assert!(f.is_finite() && f.near < d, "near plane clips the wall");
                                if anchor == (wall.pa + wall.pd()) / 2.0 {
                                    assert_corners_map(&cave, wall, &f, 1e-5);
                                }
                            }
                            Err(FrustumFault::OnWall { distance }) => {
                                assert!(d > 0.0 && d < MIN_EYE_DISTANCE && distance.is_finite())
                            }
                            Err(FrustumFault::Behind { distance }) => {
                                assert!(d < 0.0 && distance < 0.0)
                            }
                            Err(e) => panic!("{e}"),
                        }
                    }
                }
                assert!(matches!(
                    off_axis(wall, anchor, cave.near, &cave.room_to_scene),
                    Err(FrustumFault::OnWall { .. })
                ));
            }
        }
    }

    #[test]
    fn non_finite_heads_are_faults_and_stereo_modes_pick_eyes() {
        let cave = cave4();
        let mut frusta = CaveFrusta::new(&cave);
        let before = frusta.walls[0].eyes.clone();
        frusta.update(
            &cave,
            &Pose::new(Vec3::new(f32::NAN, 1.5, 0.0), Quat::IDENTITY),
        );
        assert!(
            frusta
                .walls
                .iter()
                .all(|w| w.faults.non_finite == 1 && w.holding)
        );
        assert_eq!(frusta.walls[0].eyes, before);
        frusta.update(&cave, &Pose::new(Vec3::new(0.0, 1.7, 0.0), Quat::IDENTITY));
        let eyes = &frusta.walls[0].eyes;
        assert_eq!(
            eyes.iter().map(|e| e.0).collect::<Vec<_>>(),
            [Eye::Left, Eye::Right]
        );
        assert!(((eyes[1].1.eye - eyes[0].1.eye).length() - 0.064).abs() < 1e-6);
        assert!((eyes[0].1.eye - DVec3::new(-0.032, 1.65, -0.08)).length() < 1e-6);
        assert_eq!(Eye::for_mode(StereoMode::Mono), [Eye::Centre]);
        assert_eq!(Eye::for_mode(StereoMode::Right), [Eye::Right]);
    }
}
