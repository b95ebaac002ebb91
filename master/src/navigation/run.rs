//! Navigation in the master's frame loop: the devices read up to the frame's time, the
//! navigator stepped by the frame clock's time step (so a replay does not depend on how
//! fast the machine is), the scene it collides with.

use std::sync::Arc;

use glam::DMat4;
use holocave_scene::Scene;
use holocave_tracking::Pose;

use super::Navigator;
use super::input::Inputs;
use super::placement::Placement;

/// The navigation the master runs each frame.
pub struct NavigationRun {
    pub navigator: Navigator,
    pub inputs: Inputs,
    /// What walking, flying and teleporting collide with (`None`: no collisions, no floor).
    pub scene: Option<Arc<Scene>>,
    last_ns: Option<u64>,
}

impl NavigationRun {
    pub fn new(navigator: Navigator, inputs: Inputs, scene: Option<Arc<Scene>>) -> Self {
        NavigationRun {
            navigator,
            inputs,
            scene,
            last_ns: None,
        }
    }

    /// The transform of the frame at `now_ns` on the master's clock, for the head at `head`
    /// (room). The first frame's step is zero long.
    pub fn frame(&mut self, now_ns: u64, head: &Pose) -> Placement {
        let dt = self
            .last_ns
            .map_or(0.0, |t| now_ns.saturating_sub(t) as f64 * 1e-9);
        self.last_ns = Some(now_ns);
        let input = self.inputs.advance(now_ns).clone();
        self.navigator.step(head, &input, dt, self.scene.as_deref())
    }

    /// The transform the frame state sends.
    pub fn matrix(p: &Placement) -> DMat4 {
        p.to_mat4()
    }
}
