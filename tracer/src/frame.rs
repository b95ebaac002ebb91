//! An orthonormal shading frame around a normal, for moving directions between world
//! space and the local space where the normal is +Z.

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit `n` (Duff et al. 2017, branchless and continuous except at
    /// one pole).
    pub fn new(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bi = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { t, b: bi, n }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::new(n);
            for v in [f.t, f.b, f.n] {
                assert!((v.length() - 1.0).abs() < 1e-5);
            }
            assert!(
                f.t.dot(f.b).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5 && f.b.dot(f.n).abs() < 1e-5
            );
            let v = Vec3::new(0.2, 0.7, -0.3);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
