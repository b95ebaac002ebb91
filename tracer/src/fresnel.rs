//! Fresnel reflectance: Schlick's approximation for the metallic-roughness model and the
//! exact dielectric formula for glass; plus the reflect/refract geometry that goes with it.

use glam::Vec3;

/// Schlick: `F0 + (F90 − F0)(1 − cos)^5`, per channel.
pub fn schlick(f0: Vec3, f90: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    f0 + (f90 - f0) * m
}

/// Unpolarised Fresnel reflectance of a dielectric interface for light arriving at
/// `cos_i` (negative from the inside), `eta` = n_inside / n_outside. 1 under total
/// internal reflection.
pub fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let (mut cos_i, mut eta) = (cos_i.clamp(-1.0, 1.0), eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Mirror `wo` about `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refract `wo` through the interface with normal `n` (either side) and relative index
/// `eta` (inside over outside, inside being opposite `n`). Returns the transmitted
/// direction and the relative index actually crossed, or `None` under total internal
/// reflection.
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let (mut cos_i, mut eta, mut n) = (n.dot(wo), eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + (cos_i / eta - cos_t) * n, eta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_limits() {
        // Normal incidence: ((η−1)/(η+1))².
        assert!((dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
        // Grazing: total reflection; inside beyond the critical angle: TIR.
        assert!((dielectric(1e-6, 1.5) - 1.0).abs() < 1e-3);
        assert_eq!(dielectric(-0.5, 1.5), 1.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let (wt, eta) = refract(wo, n, 1.5).unwrap();
        assert!((wt.length() - 1.0).abs() < 1e-5 && wt.z < 0.0);
        let sin_i = 0.6f32;
        let sin_t = (1.0 - wt.z * wt.z).sqrt();
        assert!((sin_i - eta * sin_t).abs() < 1e-5);
        // And back out again: refracting the transmitted direction (now on the inside)
        // gives the original one, with the inverse relative index.
        let (back, eta_back) = refract(wt, n, 1.5).unwrap();
        assert!((back - wo).length() < 1e-5);
        assert!((eta_back - 1.0 / 1.5).abs() < 1e-6);
        assert!(refract(Vec3::new(0.9, 0.0, -0.436).normalize(), n, 1.5).is_none());
    }
}
