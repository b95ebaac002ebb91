//! Moving objects as the master sends them: every frame, each movable object's placement
//! at the frame's display time, from keyframed paths (`--objects FILE`), in the frame
//! state, so every wall draws the same placement. A replay's display times are virtual
//! (frame × period), so a replayed path gives the same placements bit for bit.

use holocave_protocol::cluster::WireObject;
use holocave_scene::objects::PathError;
use holocave_scene::{ObjectPaths, Placement, Scene};

/// The scene's movable objects and the paths that move them.
pub struct ObjectMotion {
    names: Vec<String>,
    rest: Vec<Placement>,
    paths: ObjectPaths,
}

impl ObjectMotion {
    /// Moves `scene`'s objects along `paths`; refuses paths of objects the scene does not
    /// have.
    pub fn new(scene: &Scene, paths: ObjectPaths) -> Result<Self, PathError> {
        paths.check(scene)?;
        Ok(ObjectMotion {
            names: scene.objects().iter().map(|o| o.name.clone()).collect(),
            rest: scene.rest_placements(),
            paths,
        })
    }

    /// Every object's placement at `display_ns` (ns since the run started), in the
    /// scene's object order; an object without a path stays where the scene put it.
    pub fn at(&self, display_ns: u64) -> Vec<WireObject> {
        let t = display_ns as f64 * 1e-9;
        self.names
            .iter()
            .zip(&self.rest)
            .map(|(name, rest)| {
                let p = self.paths.placement_at(name, t).unwrap_or(*rest);
                WireObject {
                    name: name.clone(),
                    position: p.translation.to_array(),
                    orientation: p.rotation.to_array(),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::{LoadOptions, ObjectSpec};
    use std::path::Path;

    fn room() -> Scene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
        let object = |name: &str| ObjectSpec {
            name: name.into(),
            nodes: vec![name.into()],
        };
        let opts = LoadOptions {
            objects: vec![object("block"), object("lamp")],
            ..Default::default()
        };
        Scene::load(&path, &opts).unwrap()
    }

    /// Every frame's placements follow the path at the frame's display time, the same
    /// bits on every call (a replay's frame states are equal), and an object without a
    /// path stands at rest; a path for an object the scene lacks is refused by name.
    #[test]
    fn frames_carry_the_paths_placements() {
        let scene = room();
        let text = "object,time_s,tx,ty,tz,qx,qy,qz,qw\n\
                    block,0,0,0,0,0,0,0,1\n\
                    block,2,2,0,-4,0,0.7071068,0,0.7071068\n";
        let paths = ObjectPaths::parse(text, Path::new("path.csv")).unwrap();
        let motion = ObjectMotion::new(&scene, paths.clone()).unwrap();
        let at = motion.at(1_000_000_000);
        assert_eq!(at.len(), 2);
        assert_eq!(
            (at[0].name.as_str(), at[0].position),
            ("block", [1.0, 0.0, -2.0])
        );
        let half = glam::Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(glam::Quat::from_array(at[0].orientation).dot(half).abs() > 1.0 - 1e-6);
        let rest = scene.rest_placements()[1];
        assert_eq!(at[1].position, rest.translation.to_array());
        assert_eq!(
            motion.at(1_000_000_000),
            at,
            "the same frame, the same bits"
        );
        let other = ObjectPaths::parse(
            "object,time_s,tx,ty,tz,qx,qy,qz,qw\nsofa,0,0,0,0,0,0,0,1\n",
            Path::new("sofa.csv"),
        )
        .unwrap();
        let e = ObjectMotion::new(&scene, other)
            .err()
            .expect("refused")
            .to_string();
        assert!(e.contains("sofa") && e.contains("sofa.csv"), "{e}");
    }
}
