//! Loss of colour in dim light (Ward Larson, Rushmeier & Piatko 1997, human visual limits;
//! Radiance `pcond3.c`): below the mesopic range only the rods see, and they see no colour.
//! A pixel of photopic luminance `L` keeps the fraction `f = (L − L_bot)/(L_top − L_bot)`
//! (clamped to 0..1) of its colour and shows the rest as a grey of its scotopic luminance:
//!
//! ```text
//! out = f · c + (1 − f) · S(c)/S(white) · (1, 1, 1)
//! ```
//!
//! with the mesopic range's ends `L_top` = 5.62 cd/m² (photopic above) and `L_bot` =
//! 0.00562 cd/m² (scotopic below), and the scotopic luminance from CIE XYZ
//! `S = Y·(1.33·(1 + (Y + Z)/X) − 1.68)`, normalised by its value for the RGB white so that
//! white keeps its luminance.

use glam::Vec3;

/// Top of the mesopic range, cd/m²: full colour at and above (`pcond`'s `TopMesopic`).
pub const TOP_MESOPIC: f32 = 5.62;
/// Bottom of the mesopic range, cd/m²: grey at and below (`pcond`'s `BotMesopic`).
pub const BOT_MESOPIC: f32 = 5.62e-3;

/// CIE XYZ of linear Rec. 709 RGB (D65).
pub fn xyz(c: Vec3) -> Vec3 {
    Vec3::new(
        0.4124 * c.x + 0.3576 * c.y + 0.1805 * c.z,
        holocave_scene::luminance(c),
        0.0193 * c.x + 0.1192 * c.y + 0.9505 * c.z,
    )
}

/// Scotopic luminance of linear RGB `c` (relative units: the same as `c`'s photopic ones
/// times the scotopic/photopic ratio of its spectrum's approximation from XYZ).
pub fn scotopic(c: Vec3) -> f32 {
    let v = xyz(c);
    if v.x <= 0.0 {
        return 0.0;
    }
    v.y * (1.33 * (1.0 + (v.y + v.z) / v.x) - 1.68)
}

/// The fraction of colour kept at photopic luminance `l` cd/m².
pub fn colour_kept(l: f32) -> f32 {
    ((l - BOT_MESOPIC) / (TOP_MESOPIC - BOT_MESOPIC)).clamp(0.0, 1.0)
}

/// `c` (scene radiance) as seen at its own luminance `l` (cd/m²): its colour blended
/// toward the grey of its scotopic luminance.
pub fn mesopic(c: Vec3, l: f32) -> Vec3 {
    let f = colour_kept(l);
    if f >= 1.0 {
        return c;
    }
    let grey = scotopic(c) / scotopic(Vec3::ONE);
    c * f + Vec3::splat(grey * (1.0 - f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_keeps_its_luminance_and_blue_looks_brighter_than_red_to_the_rods() {
        let w = Vec3::splat(0.3);
        assert!((mesopic(w, 1e-3) - w).abs().max_element() < 1e-6);
        // The Purkinje shift: equal photopic luminance, blue far brighter at night.
        let (r, b) = (Vec3::X / 0.2126, Vec3::Z / 0.0722);
        assert!(scotopic(b) > 5.0 * scotopic(r));
    }
}
