//! The GGX (Trowbridge–Reitz) microfacet distribution with Smith masking, and sampling of
//! its visible normals (Heitz 2018). Directions are in the local frame where the
//! macro-surface normal is +Z; `alpha` is glTF's roughness squared.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this `alpha` a lobe is treated as a perfect (delta) reflector or refractor.
pub const SMOOTH_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    pub fn from_roughness(roughness: f32) -> Self {
        Self {
            alpha: (roughness * roughness).max(SMOOTH_ALPHA),
        }
    }

    pub fn is_smooth(roughness: f32) -> bool {
        roughness * roughness < SMOOTH_ALPHA
    }

    /// Normal distribution D(m).
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let t = c2 * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    /// Smith's Λ(w).
    fn lambda(&self, w: Vec3) -> f32 {
        let c2 = w.z * w.z;
        if c2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (1.0 - c2).max(0.0) / c2;
        ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0) * 0.5
    }

    /// Masking G1(w).
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2(wo, wi).
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals from `w` (w.z > 0): G1(w) max(0, w·m) D(m) / w.z.
    pub fn visible_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        self.g1(w) * w.dot(m).max(0.0) * self.d(m) / w.z
    }

    /// A visible normal seen from `w` (w.z > 0), by sampling a spherical cap (Dupuy and
    /// Benyoub 2023), which is exact and branch-free.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let wh = Vec3::new(self.alpha * w.x, self.alpha * w.y, w.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wh.z) - wh.z;
        let sin_t = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let c = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), z);
        let h = c + wh;
        Vec3::new(self.alpha * h.x, self.alpha * h.y, h.z.max(1e-7)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D(m) cos θm dm = 1: the projected microfacet area equals the macro area.
    #[test]
    fn distribution_is_normalised() {
        for alpha in [0.05f32, 0.2, 0.5, 1.0] {
            let g = Ggx { alpha };
            let n = 2000;
            let mut sum = 0.0f64;
            for i in 0..n {
                // Stratify cos θ finely near 1 where narrow lobes live.
                let c = 1.0 - ((i as f32 + 0.5) / n as f32).powi(3);
                let dc = 3.0 * ((i as f32 + 0.5) / n as f32).powi(2) / n as f32;
                sum += f64::from(g.d(Vec3::new((1.0 - c * c).sqrt(), 0.0, c)) * c * dc * 2.0 * PI);
            }
            assert!((sum - 1.0).abs() < 0.01, "alpha {alpha}: {sum}");
        }
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let g = Ggx { alpha: 0.6 };
        let w = Vec3::new(0.8, 0.0, 0.6);
        for i in 0..64 {
            for j in 0..64 {
                let m = g.sample_visible(
                    w,
                    Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0),
                );
                assert!(m.z > 0.0 && w.dot(m) >= -1e-5 && (m.length() - 1.0).abs() < 1e-4);
            }
        }
    }
}
