//! Triangle meshes of simple shapes, as (positions, normals, indices).

use glam::Vec3;
use std::f32::consts::PI;

pub type Shape = (Vec<Vec3>, Vec<Vec3>, Vec<u32>);

/// A quad with corners `o`, `o + a`, `o + a + b`, `o + b`; its front faces along `a × b`.
pub fn quad(o: Vec3, a: Vec3, b: Vec3) -> Shape {
    let n = a.cross(b).normalize();
    (
        vec![o, o + a, o + a + b, o + b],
        vec![n; 4],
        vec![0, 1, 2, 0, 2, 3],
    )
}

/// Appends `s` to `acc`.
pub fn append(acc: &mut Shape, s: Shape) {
    let base = acc.0.len() as u32;
    acc.0.extend(s.0);
    acc.1.extend(s.1);
    acc.2.extend(s.2.into_iter().map(|i| i + base));
}

/// An axis-aligned unit cube centred at the origin (edge 1), faces outward.
pub fn cube() -> Shape {
    let mut acc = (vec![], vec![], vec![]);
    let h = 0.5;
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
            a[(axis + 1) % 3] = 1.0;
            b[(axis + 2) % 3] = 1.0;
            if sign < 0.0 {
                std::mem::swap(&mut a, &mut b);
            }
            append(&mut acc, quad(n * h - (a + b) * h, a, b));
        }
    }
    acc
}

/// A UV sphere of radius 1 with smooth normals.
pub fn sphere(rings: u32, segments: u32) -> Shape {
    let mut p = Vec::new();
    for r in 0..=rings {
        let theta = r as f32 / rings as f32 * PI;
        for s in 0..=segments {
            let phi = s as f32 / segments as f32 * 2.0 * PI;
            p.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            ));
        }
    }
    let mut idx = Vec::new();
    let w = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * w + s,
                r * w + s + 1,
                (r + 1) * w + s,
                (r + 1) * w + s + 1,
            );
            // Skip the zero-area triangles at the poles.
            if r != 0 {
                idx.extend([a, c, b]);
            }
            if r != rings - 1 {
                idx.extend([b, c, d]);
            }
        }
    }
    (p.clone(), p, idx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_point_outward() {
        let (p, n, idx) = cube();
        for t in idx.chunks(3) {
            let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
            let face = (b - a).cross(c - a).normalize();
            assert!(face.dot(n[t[0] as usize]) > 0.999);
            assert!(face.dot((a + b + c) / 3.0) > 0.0, "outward");
        }
    }

    #[test]
    fn sphere_winding_is_outward() {
        let (p, _, idx) = sphere(8, 12);
        for t in idx.chunks(3) {
            let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 0.0);
            assert!(face.dot((a + b + c) / 3.0) > 0.0, "outward");
        }
    }
}
