//! Photometry: the scene's radiance in cd/m² and its irradiance in lux.
//!
//! Scenes give radiance in W·sr⁻¹·m⁻² of linear Rec. 709 RGB ([`crate::color`]). A
//! luminous efficacy turns its luminance into candela per square metre; the default is
//! Radiance's 179 lm/W for its equal-energy white, so figures read as Radiance's do. A
//! scene whose emitters were given in other units overrides it in its daylight file:
//!
//! ```toml
//! [photometry]
//! efficacy = 179.0   # lm/W: cd/m² per unit of the scene's radiance luminance
//! ```

use glam::Vec3;

use crate::color::luminance;

/// Radiance's luminous efficacy of its white, lm/W (Radiance's `WHTEFFICACY`).
pub const RADIANCE_WHITE_EFFICACY: f32 = 179.0;

/// How the scene's radiance units map to photometric ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photometry {
    /// cd/m² per unit of the scene's radiance luminance (lm/W).
    pub efficacy: f32,
}

impl Default for Photometry {
    fn default() -> Self {
        Self {
            efficacy: RADIANCE_WHITE_EFFICACY,
        }
    }
}

impl Photometry {
    /// Luminance, cd/m², of radiance `c` in the scene's units.
    pub fn luminance_cd(&self, c: Vec3) -> f32 {
        self.efficacy * luminance(c)
    }

    /// Illuminance, lux, of an irradiance luminance `e` in the scene's units.
    pub fn illuminance_lux(&self, e: f32) -> f32 {
        self.efficacy * e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_radiance_of_one_is_179_candela() {
        let p = Photometry::default();
        assert_eq!(p.luminance_cd(Vec3::ONE), 179.0);
        assert_eq!(p.illuminance_lux(2.0), 358.0);
        let q = Photometry { efficacy: 683.0 };
        assert!((q.luminance_cd(Vec3::Y) - 683.0 * 0.7152).abs() < 1e-3);
    }
}
