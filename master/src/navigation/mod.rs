//! Navigation: the room → scene transform, integrated each frame from the input devices
//! (a tracked wand, buttons, joystick axes) with the frame's time step. The modes, one a
//! file: [`walk`] and [`fly`] (the joystick's travel), [`turn`], [`grab`] (the world follows
//! the wand while a button is held) and [`teleport`]; [`body`] holds the scene queries
//! they collide with. The master sends the result in every frame state, so every wall and
//! eye uses the same transform and a replayed log gives the same transforms.

pub mod body;
pub mod desk;
pub mod fly;
pub mod grab;
pub mod input;
pub mod log;
pub mod placement;
pub mod run;
pub mod teleport;
pub mod turn;
pub mod walk;

#[cfg(test)]
mod tests;

use glam::{DMat4, DVec3};
use holocave_cave::{Navigation, TravelMode};
use holocave_scene::Scene;
use holocave_tracking::Pose;

pub use input::{InputState, Inputs, WandPose};
pub use placement::Placement;

/// An axis value with the dead zone removed and the rest rescaled to reach ±1.
pub fn shaped(raw: f64, dead_zone: f64) -> f64 {
    if !raw.is_finite() || raw.abs() <= dead_zone {
        return 0.0;
    }
    (raw.signum() * (raw.abs() - dead_zone) / (1.0 - dead_zone)).clamp(-1.0, 1.0)
}

/// The navigation state: where the room is in the scene, and what the last frame's input
/// was (for grabbing).
#[derive(Clone, Debug)]
pub struct Navigator {
    settings: Navigation,
    place: Placement,
    /// The wand at the last frame, and whether the grab button was held then.
    wand_before: Option<WandPose>,
    grab_before: bool,
}

impl Navigator {
    /// Starts at `start` (room → scene, rigid).
    pub fn new(settings: Navigation, start: &DMat4) -> Navigator {
        Navigator {
            settings,
            place: Placement::from_mat4(start),
            wand_before: None,
            grab_before: false,
        }
    }

    pub fn placement(&self) -> Placement {
        self.place
    }

    /// Puts the room where a resumed session had it.
    pub fn resume_at(&mut self, place: Placement) {
        self.place = place;
    }

    pub fn settings(&self) -> &Navigation {
        &self.settings
    }

    /// Walk becomes fly and fly walk (each press of the mode button); `none` stays.
    pub fn toggle_mode(&mut self) {
        self.settings.mode = match self.settings.mode {
            TravelMode::Walk => TravelMode::Fly,
            TravelMode::Fly => TravelMode::Walk,
            TravelMode::None => TravelMode::None,
        };
        tracing::info!("navigation: {:?}", self.settings.mode);
    }

    /// One frame of `dt` seconds: the head at `head` (room), the devices' state `input`,
    /// the scene to collide with. Returns the new room → scene transform.
    pub fn step(
        &mut self,
        head: &Pose,
        input: &InputState,
        dt: f64,
        scene: Option<&Scene>,
    ) -> Placement {
        let presses = (self.settings.mode_button)
            .and_then(|b| input.presses.get(b).copied())
            .unwrap_or(0);
        for _ in 0..presses {
            self.toggle_mode();
        }
        let s = &self.settings;
        let head_at = head.position.as_dvec3();
        let feet = DVec3::new(head_at.x, 0.0, head_at.z);
        let dt = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
        let body = body::Body {
            radius: s.radius,
            step_height: s.step_height,
        };

        let held = input.held(s.grab_button);
        let grabbing = held && self.grab_before;
        if grabbing && let (Some(before), Some(now)) = (self.wand_before, input.wand) {
            let was = self.place.point(feet);
            grab::grab(&mut self.place, &before, &now, s.grab_yaw_only);
            // The body goes where the grab takes it only as far as walking would: stopped
            // `radius` short of a wall, and slid along it.
            if let Some(scene) = scene {
                let wanted = self.place.point(feet) - was;
                let moved = body::travel(scene, was, wanted, body.radius, body.step_height);
                self.place.shift(moved - wanted);
            }
        }

        let turning = shaped(input.axis(s.turn_axis), s.dead_zone) * s.turn_sign;
        if turning != 0.0 {
            turn::turn(&mut self.place, head_at, turning * s.turn_rate, dt);
        }

        let forward = shaped(input.axis(s.forward_axis), s.dead_zone) * s.forward_sign;
        let pointing = match input.wand {
            Some(w) => w.forward(),
            None => head.orientation.as_dquat() * DVec3::NEG_Z,
        };
        if forward != 0.0 && !held {
            match s.mode {
                TravelMode::Walk => walk::walk(
                    &mut self.place,
                    pointing,
                    feet,
                    forward * s.walk_speed,
                    dt,
                    scene,
                    body,
                ),
                TravelMode::Fly => fly::fly(
                    &mut self.place,
                    pointing,
                    feet,
                    forward * s.fly_speed,
                    dt,
                    scene,
                    body,
                ),
                TravelMode::None => {}
            }
        }

        // Without a wand, teleport aims where the head looks (as walking goes).
        let aim = input.wand.unwrap_or(WandPose {
            position: head_at,
            orientation: head.orientation.as_dquat().normalize(),
        });
        if input.pressed(s.teleport_button)
            && let Some(scene) = scene
        {
            let wand = aim;
            teleport::teleport(
                &mut self.place,
                &wand,
                feet,
                scene,
                s.teleport_range,
                s.radius,
            );
        }

        if s.mode == TravelMode::Walk
            && !held
            && let Some(scene) = scene
        {
            walk::follow_floor(&mut self.place, feet, scene, s.step_height, s.max_drop);
        }

        self.grab_before = held;
        self.wand_before = input.wand;
        self.place
    }
}
