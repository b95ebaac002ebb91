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
