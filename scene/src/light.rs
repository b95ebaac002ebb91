//! `KHR_lights_punctual`: point, spot and directional lights.
//!
//! Intensities are read as radiometric: a point or spot light's `intensity` is radiant
//! intensity (radiance units × m²), so it gives `I / d²` at distance `d`; a directional
//! light's is irradiance normal to its direction.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    Point,
    /// Cone angles as cosines; the falloff between them is glTF's squared linear ramp.
    Spot {
        cos_inner: f32,
        cos_outer: f32,
    },
    Directional,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    pub name: String,
    pub kind: PunctualKind,
    /// World position (unused for directional lights).
    pub position: Vec3,
    /// Unit vector the light points along (the node's −Z).
    pub direction: Vec3,
    /// Colour × intensity.
    pub intensity: Vec3,
    /// glTF `range`: beyond it the light contributes nothing.
    pub range: Option<f32>,
}

impl PunctualLight {
    /// The spot cone's attenuation for light leaving along `dir_from_light` (1 for other
    /// kinds).
    pub fn spot_factor(&self, dir_from_light: Vec3) -> f32 {
        match self.kind {
            PunctualKind::Spot {
                cos_inner,
                cos_outer,
            } => {
                let cd = dir_from_light.dot(self.direction);
                let t = ((cd - cos_outer) / (cos_inner - cos_outer).max(1e-3)).clamp(0.0, 1.0);
                t * t
            }
            _ => 1.0,
        }
    }

    /// glTF's recommended smooth range window: 1 well inside the range, 0 at it.
    pub fn range_factor(&self, distance: f32) -> f32 {
        match self.range {
            Some(r) if r > 0.0 => {
                let x = distance / r;
                (1.0 - x.powi(4)).clamp(0.0, 1.0)
            }
            _ => 1.0,
        }
    }
}
