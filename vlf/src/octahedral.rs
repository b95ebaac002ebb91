//! The hemisphere of directions above a surface as a `k × k` square of bins: the
//! hemi-octahedral map. A local direction `(x, y, z)` (`z ≥ 0`, the normal along `+z`)
//! is projected onto the diamond `|x| + |y| ≤ 1` by dividing by `|x| + |y| + z`, and the
//! diamond turned by 45° onto the square `[−1, 1]²`: `(a, b) = (x + y, x − y)`. Bin
//! `(i, j)` covers `a ∈ [i, i + 1]·2/k − 1`, `b ∈ [j, j + 1]·2/k − 1`; bin `(i, j)` is at
//! index `j k + i`. The map is continuous and its bins' solid angles differ by less than a
//! factor 3.5 (the map's area distortion), so a radiance stored at bin centres is interpolated bilinearly like an
//! image (the directional radiance tiles of `tiles`).

use glam::{DVec3, Vec3};

/// The continuous map coordinates `(x, y) ∈ [0, k]²` of local direction `d`; a direction
/// below the horizon (`z < 0`) is taken at the horizon.
pub fn encode(d: Vec3, k: u32) -> (f32, f32) {
    let z = d.z.max(0.0);
    let s = d.x.abs() + d.y.abs() + z;
    let (px, py) = if s > 0.0 {
        (d.x / s, d.y / s)
    } else {
        (0.0, 0.0)
    };
    let kf = k as f32;
    (
        ((px + py + 1.0) * 0.5 * kf).clamp(0.0, kf),
        ((px - py + 1.0) * 0.5 * kf).clamp(0.0, kf),
    )
}

/// The local direction at map coordinates `(x, y) ∈ [0, k]²`.
pub fn decode(x: f64, y: f64, k: u32) -> DVec3 {
    let kf = f64::from(k);
    let (a, b) = (x / kf * 2.0 - 1.0, y / kf * 2.0 - 1.0);
    let (px, py) = ((a + b) * 0.5, (a - b) * 0.5);
    DVec3::new(px, py, (1.0 - px.abs() - py.abs()).max(0.0)).normalize()
}

/// The direction at the centre of every bin, in index order.
pub fn centres(k: u32) -> Vec<Vec3> {
    (0..k * k)
        .map(|b| {
            let (i, j) = (b % k, b / k);
            decode(f64::from(i) + 0.5, f64::from(j) + 0.5, k).as_vec3()
        })
        .collect()
}

/// The direction at the centre of every bin and the bin's cosine-weighted solid angle
/// `∫ cos θ dω` over the bin (what a bin's radiance gives as exitance; they sum to `π`),
/// in index order.
pub fn centres_and_projected(k: u32) -> (Vec<Vec3>, Vec<f32>) {
    let projected = (0..k * k)
        .map(|b| (sub_quads(k, b, MEASURE_SUB).map(|(d, omega)| omega * d.z)).sum::<f64>() as f32)
        .collect();
    (centres(k), projected)
}

/// Each bin cut into `sub × sub` small quads: the direction at each one's centre and its
/// share of the bin's cosine-weighted solid angle (`cos θ Δω`, summing to one over the
/// bin), bin after bin. A lobe as narrow as a bin is seen through these, averaged over
/// the bin, rather than at its centre alone (`tiles`).
pub fn bin_samples(k: u32, sub: u32) -> Vec<(Vec3, f32)> {
    let mut out = Vec::with_capacity((k * k * sub * sub) as usize);
    for b in 0..k * k {
        let first = out.len();
        out.extend(sub_quads(k, b, sub).map(|(d, omega)| (d.as_vec3(), (omega * d.z) as f32)));
        let total: f32 = out[first..].iter().map(|s| s.1).sum();
        for s in &mut out[first..] {
            s.1 /= total.max(f32::MIN_POSITIVE);
        }
    }
    out
}

/// Sub-quads per side that a bin's solid angle is measured with.
const MEASURE_SUB: u32 = 8;

/// Bin `b` cut into `sub × sub` small quads: each one's centre direction and its solid
/// angle (two spherical triangles).
fn sub_quads(k: u32, b: u32, sub: u32) -> impl Iterator<Item = (DVec3, f64)> {
    let (i, j) = (f64::from(b % k), f64::from(b / k));
    (0..sub * sub).map(move |q| {
        let (si, sj) = (f64::from(q % sub), f64::from(q / sub));
        let at = |di: f64, dj: f64| {
            decode(
                i + (si + di) / f64::from(sub),
                j + (sj + dj) / f64::from(sub),
                k,
            )
        };
        let (p00, p10, p01, p11) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0), at(1.0, 1.0));
        let omega = spherical_triangle(p00, p10, p11) + spherical_triangle(p00, p11, p01);
        (at(0.5, 0.5), omega)
    })
}

/// Solid angle of the spherical triangle `a, b, c` (Van Oosterom–Strackee).
fn spherical_triangle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// The solid angle every bin covers, in index order (each bin cut into 8 × 8 small
/// quads, each measured as two spherical triangles); they sum to `2π`.
pub fn solid_angles(k: u32) -> Vec<f32> {
    (0..k * k)
        .map(|b| {
            sub_quads(k, b, MEASURE_SUB)
                .map(|(_, omega)| omega)
                .sum::<f64>() as f32
        })
        .collect()
}

/// The four bins nearest map coordinates `(x, y)` and their bilinear weights (summing to
/// one; clamped at the edges, where neighbours coincide).
pub fn bilinear(k: u32, (x, y): (f32, f32)) -> [(u32, f32); 4] {
    let (x, y) = ((x - 0.5).max(0.0), (y - 0.5).max(0.0));
    let (i0, j0) = ((x as u32).min(k - 1), (y as u32).min(k - 1));
    let (i1, j1) = ((i0 + 1).min(k - 1), (j0 + 1).min(k - 1));
    let (fx, fy) = (
        (x - i0 as f32).clamp(0.0, 1.0),
        (y - j0 as f32).clamp(0.0, 1.0),
    );
    [
        (j0 * k + i0, (1.0 - fx) * (1.0 - fy)),
        (j0 * k + i1, fx * (1.0 - fy)),
        (j1 * k + i0, (1.0 - fx) * fy),
        (j1 * k + i1, fx * fy),
    ]
}

/// The value at map coordinates `(x, y)` interpolated bilinearly between the four
/// nearest bin centres of the tile whose first bin is `base` (clamped at the edges).
/// The render node's shader (`render-node/src/cache/shade_field.wgsl`) does the same.
pub fn interpolate(values: &[[f32; 3]], base: u32, k: u32, x: f32, y: f32) -> Vec3 {
    bilinear(k, (x, y))
        .iter()
        .map(|&(bin, w)| Vec3::from(values[(base + bin) as usize]) * w)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_inverts_decode_and_bins_cover_the_hemisphere() {
        for k in [1, 4, 8, 13] {
            for b in 0..k * k {
                let (i, j) = (b % k, b / k);
                let (x, y) = (i as f32 + 0.3, j as f32 + 0.8);
                let d = decode(f64::from(x), f64::from(y), k).as_vec3();
                assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                let (ex, ey) = encode(d, k);
                assert!(
                    (ex - x).abs() < 1e-4 && (ey - y).abs() < 1e-4,
                    "{k}: {x},{y}"
                );
            }
            let total: f64 = solid_angles(k).iter().map(|&s| f64::from(s)).sum();
            assert!(
                (total - std::f64::consts::TAU).abs() < 1e-4,
                "k {k}: {total}"
            );
        }
        // The normal is the square's centre; the horizon its edge.
        assert_eq!(encode(Vec3::Z, 8), (4.0, 4.0));
        let (x, _) = encode(Vec3::new(1.0, 1.0, 0.0).normalize(), 8);
        assert!((x - 8.0).abs() < 1e-5);
    }

    #[test]
    fn bins_are_even_to_a_factor_of_three_and_a_half() {
        let s = solid_angles(8);
        let (lo, hi) = s
            .iter()
            .fold((f32::MAX, 0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(hi / lo < 3.5, "{lo}..{hi}");
    }

    #[test]
    fn interpolation_is_exact_at_centres_and_for_linear_values() {
        let k = 6;
        let values: Vec<[f32; 3]> = (0..k * k)
            .map(|b| {
                let (x, y) = ((b % k) as f32 + 0.5, (b / k) as f32 + 0.5);
                [x, y, 2.0 * x - y]
            })
            .collect();
        for (x, y) in [(0.5, 0.5), (1.7, 2.2), (3.1, 5.4), (5.5, 0.9)] {
            let got = interpolate(&values, 0, k, x, y);
            assert!(
                (got - Vec3::new(x, y, 2.0 * x - y)).length() < 1e-5,
                "{got}"
            );
        }
    }
}
