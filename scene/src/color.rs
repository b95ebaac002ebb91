//! Colour: the scene's radiance is linear RGB with Rec. 709 primaries (DESIGN.md,
//! Conventions), and its luminance is the one weighting of those primaries that every
//! crate uses (the GPU's twin is `luminance()` in `render-node/src/gpu/common.wgsl`).

use glam::Vec3;

/// Rec. 709 (sRGB) luminance weights of linear R, G, B (ITU-R BT.709, the Y row of the
/// RGB → XYZ matrix for D65 white).
pub const REC709_LUMINANCE: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// The Rec. 709 luminance of linear RGB `c`, in `c`'s units.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(REC709_LUMINANCE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_is_one_and_the_primaries_are_the_rec709_weights() {
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert_eq!(luminance(Vec3::X), 0.2126);
        assert_eq!(luminance(Vec3::Y), 0.7152);
        assert_eq!(luminance(Vec3::Z), 0.0722);
        assert_eq!(luminance(Vec3::new(2.0, 0.0, 0.0)), 2.0 * 0.2126);
    }
}
