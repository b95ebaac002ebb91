//! Textures: 8-bit RGBA images sampled bilinearly with wrapping, returning linear values.
//!
//! Colour textures (base colour, emissive) are sRGB-encoded in glTF and are linearised at
//! lookup through a 256-entry table, so the image stays at 4 bytes per texel.

use glam::{Vec2, Vec4};
use std::sync::OnceLock;

/// How the stored bytes map to linear values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB transfer function on RGB; alpha linear.
    Srgb,
    /// Already linear (metallic-roughness, transmission, specular).
    Linear,
}

/// An RGBA8 image.
#[derive(Clone)]
pub struct Texture {
    pub name: String,
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
    encoding: Encoding,
}

/// The linear value of each 8-bit sRGB code: what a colour texture's texel reads as.
pub fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f32 / 255.0;
            if c <= 0.04045 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            }
        })
    })
}

/// `v.floor()` for finite `v`, without the library call that baseline x86-64 (no SSE4.1
/// rounding instruction) makes of it: four of them were a quarter of a texture lookup.
fn floor(v: f32) -> f32 {
    // From 2^23 up every float is an integer.
    if v.abs() < 8_388_608.0 {
        let i = v as i32 as f32;
        if i > v { i - 1.0 } else { i }
    } else {
        v
    }
}

impl Texture {
    /// A texture from RGBA8 texels in row-major order (first row at v = 0).
    pub fn new(
        name: String,
        width: u32,
        height: u32,
        texels: Vec<[u8; 4]>,
        encoding: Encoding,
    ) -> Self {
        assert_eq!(texels.len(), (width * height) as usize, "texel count");
        assert!(width > 0 && height > 0, "empty texture");
        Self {
            name,
            width,
            height,
            texels,
            encoding,
        }
    }

    pub fn encoding(&self) -> Encoding {
        self.encoding
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The texels in row-major order, first row at v = 0.
    pub fn texels(&self) -> &[[u8; 4]] {
        &self.texels
    }

    fn texel(&self, x: i64, y: i64) -> Vec4 {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        let t = self.texels[y * self.width as usize + x];
        match self.encoding {
            Encoding::Srgb => {
                let lut = srgb_table();
                Vec4::new(
                    lut[t[0] as usize],
                    lut[t[1] as usize],
                    lut[t[2] as usize],
                    t[3] as f32 / 255.0,
                )
            }
            Encoding::Linear => Vec4::new(
                t[0] as f32 / 255.0,
                t[1] as f32 / 255.0,
                t[2] as f32 / 255.0,
                t[3] as f32 / 255.0,
            ),
        }
    }

    /// Bilinear lookup with repeat wrapping. Non-finite coordinates read texel (0, 0).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        // Keep the coordinate small so that the f32 → i64 conversion stays exact.
        let uv = uv - Vec2::new(floor(uv.x), floor(uv.y));
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (floor(x), floor(y));
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let a = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let b = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        a.lerp(b, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_is_linearised() {
        let t = Texture::new("t".into(), 1, 1, vec![[188, 0, 255, 255]], Encoding::Srgb);
        let c = t.sample(Vec2::new(0.3, 0.7));
        assert!((c.x - 0.5029).abs() < 1e-3, "{c}");
        assert_eq!(c.y, 0.0);
        assert_eq!(c.z, 1.0);
        let l = Texture::new("t".into(), 1, 1, vec![[128, 0, 0, 0]], Encoding::Linear);
        assert!((l.sample(Vec2::ZERO).x - 128.0 / 255.0).abs() < 1e-6);
    }

    #[test]
    fn floor_equals_the_library_floor() {
        for v in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_8,
            -2.999_999_8,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            1e10,
            -1e10,
            1e-40,
            -1e-40,
        ] {
            assert_eq!(floor(v), v.floor(), "{v}");
        }
    }

    #[test]
    fn bilinear_wraps_and_survives_bad_coordinates() {
        let t = Texture::new(
            "t".into(),
            2,
            1,
            vec![[0, 0, 0, 0], [255, 255, 255, 255]],
            Encoding::Linear,
        );
        // Texel centres.
        assert!((t.sample(Vec2::new(0.25, 0.5)).x - 0.0).abs() < 1e-6);
        assert!((t.sample(Vec2::new(0.75, 0.5)).x - 1.0).abs() < 1e-6);
        // Wrapping: u = 1.25 is u = 0.25.
        assert!((t.sample(Vec2::new(1.25, 0.5)).x - 0.0).abs() < 1e-6);
        assert!((t.sample(Vec2::new(-1e9, 3e9)).x).is_finite());
        assert!(t.sample(Vec2::new(f32::NAN, f32::INFINITY)).x.is_finite());
    }
}
