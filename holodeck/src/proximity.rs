//! Choosing sample rays within a beam (paper §2.3 and Appendix A).
//!
//! Uniform sampling picks four random bytes: a point in the entry cell and one in the exit
//! cell. Viewpoint proximity sampling keeps rays within a radius of the requesting eye:
//! the entry region is bounded by the conics in which the cones from two opposite exit-cell
//! corners around the eye sphere cut the entry wall (steps 1–4); an entry point is drawn
//! there, then an exit point inside the bounding box of the cone from it (steps 6–9). As
//! the paper notes, these regions are approximate, so a drawn ray is kept only if it truly
//! passes within the radius, with `n + 2` failures allowed per packet before falling back
//! to uniform sampling (steps 5 and 8).

use glam::DVec3;
use rand::Rng;

use crate::beam_index::Cell;
use crate::section::Section;

/// A viewpoint sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeSphere {
    pub pos: DVec3,
    pub radius: f64,
}

/// A ray within a beam: entry and exit byte positions.
pub type RayCode = ([u8; 2], [u8; 2]);

/// `n` uniformly distributed rays of a beam.
pub fn uniform<R: Rng>(n: usize, rng: &mut R) -> Vec<RayCode> {
    (0..n).map(|_| (rng.random(), rng.random())).collect()
}

/// `n` rays of `beam`, each passing within `eye.radius` of `eye.pos` where the method finds
/// one; the second value counts the rays that fell back to uniform sampling.
pub fn near_eye<R: Rng>(
    section: &Section,
    beam: u32,
    eye: EyeSphere,
    n: usize,
    rng: &mut R,
) -> (Vec<RayCode>, usize) {
    let Some((ca, cb)) = section.index().cells(beam) else {
        return (uniform(n, rng), n);
    };
    // Steps 1–4: the entry region. The paper bounds it by the cones from two opposite
    // exit corners; when only one of their conics meets the entry cell (the beam is seen
    // from the eye through a corner of that cell), that bound shrinks to a few centimetres
    // of the true region and every ray of the beam goes through it (one pixel of the view,
    // traced again and again while the rest of the beam's pixels wait). Here the region is
    // the box around the central projections of all four exit corners through the eye,
    // widened by the eye sphere's cone, and the two-corner conics as the paper has them;
    // step 9 still keeps only rays that truly pass near the eye.
    let entry_box = [[0.0, 0.0], [1.0, 1.0]]
        .iter()
        .filter_map(|&f| conic_box(section.cell_point_f(cb, f), eye, section, ca))
        .chain(projected_box(section, ca, cb, eye))
        .reduce(|a, b| {
            [
                a[0].min(b[0]),
                a[1].max(b[1]),
                a[2].min(b[2]),
                a[3].max(b[3]),
            ]
        });
    // Step 5.
    let Some(eb) = entry_box else {
        return (uniform(n, rng), n);
    };
    let mut out = Vec::with_capacity(n);
    let mut failures = 0;
    while out.len() < n {
        if failures > n + 2 {
            let rest = n - out.len();
            out.extend(uniform(rest, rng));
            return (out, rest);
        }
        // Step 6.
        let fa = [
            rng.random_range(eb[0]..=eb[1]),
            rng.random_range(eb[2]..=eb[3]),
        ];
        let ea = bytes(fa);
        let a = section.cell_point(ca, ea);
        // Steps 7–8.
        let Some(xb) = conic_box(a, eye, section, cb) else {
            failures += 1;
            continue;
        };
        // Step 9, keeping only rays that truly pass near the eye.
        let xb_bytes = bytes([
            rng.random_range(xb[0]..=xb[1]),
            rng.random_range(xb[2]..=xb[3]),
        ]);
        let b = section.cell_point(cb, xb_bytes);
        if line_distance(a, b, eye.pos) <= eye.radius {
            out.push((ea, xb_bytes));
        } else {
            failures += 1;
        }
    }
    (out, 0)
}

/// The box (cell fractions of `entry`, clipped to it) around the points where the lines from
/// the corners of `exit` through the eye's centre meet the entry wall, each widened by the
/// size of the eye sphere's cone there; `None` if it misses the cell.
fn projected_box(section: &Section, entry: Cell, exit: Cell, eye: EyeSphere) -> Option<[f64; 4]> {
    let (eu, ev) = section.cell_edges(entry.wall);
    let o = section.cell_point_f(entry, [0.0, 0.0]);
    let n = eu.cross(ev);
    // Fractions (u, v) of a point of the wall plane: solve the 2×2 Gram system.
    let (guu, guv, gvv) = (eu.dot(eu), eu.dot(ev), ev.dot(ev));
    let det = guu * gvv - guv * guv;
    if det.abs() <= 1e-18 * guu * gvv {
        return None;
    }
    let frac = |p: DVec3| {
        let d = p - o;
        let (a, b) = (d.dot(eu), d.dot(ev));
        ((gvv * a - guv * b) / det, (guu * b - guv * a) / det)
    };
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for f in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]] {
        let c = section.cell_point_f(exit, f);
        let dir = eye.pos - c;
        let den = n.dot(dir);
        if den.abs() <= 1e-12 * n.length() * dir.length() {
            return None;
        }
        let t = n.dot(o - c) / den;
        if t.is_nan() || t <= 1.0 {
            // The entry wall is not behind the eye as seen from this corner.
            return None;
        }
        let (u, v) = frac(c + dir * t);
        // The cone around the sphere is `radius × t` wide there; over the wall's slant.
        let slant = (n.length() * dir.length() / den.abs()).min(10.0);
        let m = eye.radius * t * slant;
        let (mu, mv) = (m / guu.sqrt(), m / gvv.sqrt());
        b = [
            b[0].min(u - mu),
            b[1].max(u + mu),
            b[2].min(v - mv),
            b[3].max(v + mv),
        ];
    }
    let b = [b[0].max(0.0), b[1].min(1.0), b[2].max(0.0), b[3].min(1.0)];
    (b[0] <= b[1] && b[2] <= b[3]).then_some(b)
}

fn bytes(f: [f64; 2]) -> [u8; 2] {
    f.map(|x| (x * 256.0).floor().clamp(0.0, 255.0) as u8)
}

/// Distance from `p` to the line through `a` and `b`.
pub fn line_distance(a: DVec3, b: DVec3, p: DVec3) -> f64 {
    let d = (b - a).normalize();
    let w = p - a;
    (w - d * w.dot(d)).length()
}

/// Bounding box `[u_min, u_max, v_min, v_max]` (cell fractions) of the points `X` of `cell`
/// such that the line from `apex` through `X` passes within the eye sphere: the region
/// `f(u, v) ≥ 0` of the conic in which the double cone around the sphere cuts the wall,
/// clipped to the cell. `None` if the region misses the cell.
fn conic_box(apex: DVec3, eye: EyeSphere, section: &Section, cell: Cell) -> Option<[f64; 4]> {
    let s = eye.pos - apex;
    let k = s.length_squared() - eye.radius * eye.radius;
    if k <= 0.0 {
        return Some([0.0, 1.0, 0.0, 1.0]);
    }
    // f(d) = (d·s)² - k |d|² with d = c + u a + v b.
    let (a, b) = section.cell_edges(cell.wall);
    let c = section.cell_point_f(cell, [0.0, 0.0]) - apex;
    let q = |x: DVec3, y: DVec3| x.dot(s) * y.dot(s) - k * x.dot(y);
    let (ca, cb, cc, cd, ce, cf) = (
        q(a, a),
        2.0 * q(a, b),
        q(b, b),
        2.0 * q(a, c),
        2.0 * q(b, c),
        q(c, c),
    );
    let f = |u: f64, v: f64| ca * u * u + cb * u * v + cc * v * v + cd * u + ce * v + cf;
    let tol = 1e-9 * (ca.abs() + cb.abs() + cc.abs() + cd.abs() + ce.abs() + cf.abs());
    let mut pts: Vec<(f64, f64)> = Vec::new();
    for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        if f(u, v) >= 0.0 {
            pts.push((u, v));
        }
    }
    for e in [0.0, 1.0] {
        // Conic meets the edges v = e and u = e.
        for u in roots(ca, cb * e + cd, cc * e * e + ce * e + cf) {
            pts.push((u, e));
        }
        for v in roots(cc, cb * e + ce, ca * e * e + cd * e + cf) {
            pts.push((e, v));
        }
    }
    // Extremes of u on the conic (∂f/∂v = 0: v = αu + β), and of v (∂f/∂u = 0).
    if cc.abs() > tol {
        let (al, be) = (-cb / (2.0 * cc), -ce / (2.0 * cc));
        let qa = ca + cb * al + cc * al * al;
        let qb = cb * be + 2.0 * cc * al * be + cd + ce * al;
        let qc = cc * be * be + ce * be + cf;
        for u in roots(qa, qb, qc) {
            pts.push((u, al * u + be));
        }
    }
    if ca.abs() > tol {
        let (al, be) = (-cb / (2.0 * ca), -cd / (2.0 * ca));
        let qa = cc + cb * al + ca * al * al;
        let qb = cb * be + 2.0 * ca * al * be + ce + cd * al;
        let qc = ca * be * be + cd * be + cf;
        for v in roots(qa, qb, qc) {
            pts.push((al * v + be, v));
        }
    }
    let inside = |x: f64| (-1e-12..=1.0 + 1e-12).contains(&x);
    let pts: Vec<(f64, f64)> = pts
        .into_iter()
        .filter(|&(u, v)| inside(u) && inside(v) && f(u, v) >= -tol)
        .map(|(u, v)| (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)))
        .collect();
    let first = pts.first()?;
    Some(
        pts.iter()
            .fold([first.0, first.0, first.1, first.1], |b, &(u, v)| {
                [b[0].min(u), b[1].max(u), b[2].min(v), b[3].max(v)]
            }),
    )
}

/// Real roots of `a x² + b x + c` (a linear equation when `a` is negligible).
fn roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    let scale = a.abs().max(b.abs()).max(c.abs());
    if scale == 0.0 {
        return Vec::new();
    }
    if a.abs() <= 1e-12 * scale {
        return if b.abs() > 1e-12 * scale {
            vec![-c / b]
        } else {
            Vec::new()
        };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return Vec::new();
    }
    let sq = disc.sqrt();
    // Numerically stable form.
    let qq = -0.5 * (b + b.signum() * sq);
    let mut r = vec![qq / a];
    if qq != 0.0 {
        r.push(c / qq);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::ViewClass;
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    #[test]
    fn rays_pass_near_the_eye_or_fall_back() {
        let s = Section::axis_aligned(
            DVec3::ZERO,
            DVec3::new(4.0, 3.0, 5.0),
            [4, 3, 5],
            ViewClass::Interior,
        )
        .unwrap();
        let eye = EyeSphere {
            pos: DVec3::new(2.1, 1.4, 2.6),
            radius: 0.3,
        };
        let mut rng = SmallRng::seed_from_u64(1);
        let (mut near, mut fell, mut beams_hit) = (0, 0, 0);
        for beam in (0..s.beam_count()).step_by(37) {
            let (codes, fallback) = near_eye(&s, beam, eye, 8, &mut rng);
            assert_eq!(codes.len(), 8);
            fell += fallback;
            let close = codes
                .iter()
                .filter(|(e, x)| {
                    let (a, b) = s.sample_points(beam, *e, *x).unwrap();
                    line_distance(a, b, eye.pos) <= eye.radius
                })
                .count();
            assert!(
                close >= 8 - fallback,
                "beam {beam}: {close} close, {fallback} fell back"
            );
            near += close;
            beams_hit += usize::from(fallback == 0);
        }
        assert!(beams_hit > 0 && near > 0);
        // Uniform sampling of the same beams passes near the eye far less often.
        let mut uniform_near = 0;
        for beam in (0..s.beam_count()).step_by(37) {
            for (e, x) in uniform(8, &mut rng) {
                let (a, b) = s.sample_points(beam, e, x).unwrap();
                uniform_near += usize::from(line_distance(a, b, eye.pos) <= eye.radius);
            }
        }
        assert!(
            near > 3 * uniform_near.max(1),
            "proximity {near} vs uniform {uniform_near} (fallbacks {fell})"
        );
    }

    #[test]
    fn eye_inside_cone_apex_or_far_away() {
        let s =
            Section::axis_aligned(DVec3::ZERO, DVec3::ONE, [2, 2, 2], ViewClass::Interior).unwrap();
        let mut rng = SmallRng::seed_from_u64(2);
        // A sphere enclosing the section: every ray qualifies, none falls back.
        let big = EyeSphere {
            pos: DVec3::splat(0.5),
            radius: 2.0,
        };
        assert_eq!(near_eye(&s, 3, big, 5, &mut rng).1, 0);
        // A tiny sphere far off every beam's lines: all fall back to uniform.
        let far = EyeSphere {
            pos: DVec3::new(50.0, -40.0, 0.5),
            radius: 0.01,
        };
        let (codes, fell) = near_eye(&s, 0, far, 5, &mut rng);
        assert_eq!((codes.len(), fell), (5, 5));
    }

    #[test]
    fn quadratic_roots() {
        let mut r = roots(1.0, -3.0, 2.0);
        r.sort_by(f64::total_cmp);
        assert_eq!(r, vec![1.0, 2.0]);
        assert_eq!(roots(0.0, 2.0, -1.0), vec![0.5]);
        assert!(roots(1.0, 0.0, 1.0).is_empty());
    }
}
