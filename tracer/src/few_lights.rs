//! Choosing among a few emissive triangles by what each can send to the shading point.
//!
//! A scene lit by a handful of emissive triangles (a Cornell box's lamp, Khronos'
//! EmissiveStrengthTest's five cubes: 60 triangles) can afford to weigh every one of them
//! at every shading point. A triangle's weight is its power over its squared distance
//! (never less than its own squared radius, so a point on or beside it does not make the
//! weight infinite), and zero when the point lies behind a one-sided emitter: from any
//! point outside a glowing cube, half or more of its faces turn away, and chosen by power
//! alone they took that share of the shadow rays for nothing. Every triangle that can
//! light the point keeps a positive probability, so the estimate stays unbiased;
//! [`FewLights::probability`] gives the same probability again for MIS.

use glam::{Vec3, Vec4};

/// The most emissive triangles weighed one by one at every shading point.
pub const MAX_LIGHTS: usize = 64;

/// Triangles weighed together, in lanes: four of each field side by side in a `Vec4`,
/// so the per-point loop is vector arithmetic.
const LANE: usize = 4;

/// Four triangles' planes, centres and powers (unused slots have zero power).
#[derive(Clone, Copy)]
struct Lane {
    /// Emitting-side plane `n · p + d` (positive in front); zero normal and `d = 1` for a
    /// double-sided emitter, which faces everywhere.
    nx: Vec4,
    ny: Vec4,
    nz: Vec4,
    d: Vec4,
    /// A point counts as in front down to `-slack` (a rounding margin scaled to the
    /// triangle), so rounding can only waste a sample, never drop light.
    slack: Vec4,
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    /// Squared radius of the sphere about the centre holding the triangle.
    radius2: Vec4,
    power: Vec4,
}

impl Default for Lane {
    fn default() -> Self {
        Self {
            nx: Vec4::ZERO,
            ny: Vec4::ZERO,
            nz: Vec4::ZERO,
            d: Vec4::ONE,
            slack: Vec4::ZERO,
            cx: Vec4::ZERO,
            cy: Vec4::ZERO,
            cz: Vec4::ZERO,
            // Unused slots: zero power, and a radius that keeps their weight finite.
            radius2: Vec4::ONE,
            power: Vec4::ZERO,
        }
    }
}

pub struct FewLights {
    lanes: Vec<Lane>,
    count: usize,
}

impl FewLights {
    /// The emissive triangles `vertices[k]` with unit face normals `normal[k]`, sides and
    /// powers; `None` when there are more than [`MAX_LIGHTS`] (or none).
    pub fn new(
        vertices: &[[Vec3; 3]],
        normal: &[Vec3],
        double_sided: &[bool],
        power: &[f32],
    ) -> Option<Self> {
        if vertices.is_empty() || vertices.len() > MAX_LIGHTS {
            return None;
        }
        let mut lanes = vec![Lane::default(); vertices.len().div_ceil(LANE)];
        for (k, v) in vertices.iter().enumerate() {
            let (lane, i) = (&mut lanes[k / LANE], k % LANE);
            let centre = (v[0] + v[1] + v[2]) / 3.0;
            let radius2 = v
                .iter()
                .map(|x| x.distance_squared(centre))
                .fold(f32::MIN_POSITIVE, f32::max);
            let (n, d) = if double_sided[k] {
                (Vec3::ZERO, 1.0)
            } else {
                (normal[k], -normal[k].dot(v[0]))
            };
            lane.nx[i] = n.x;
            lane.ny[i] = n.y;
            lane.nz[i] = n.z;
            lane.d[i] = d;
            // The plane's offset is only known to within a few ulps of the vertices'
            // magnitude; a point closer to the plane than that may be on either side.
            lane.slack[i] = 1e-5 * (v[0].abs().max_element() + radius2.sqrt());
            lane.cx[i] = centre.x;
            lane.cy[i] = centre.y;
            lane.cz[i] = centre.z;
            lane.radius2[i] = radius2;
            lane.power[i] = power[k].max(0.0);
        }
        Some(Self {
            lanes,
            count: vertices.len(),
        })
    }

    /// Every triangle's weight seen from `p`, lane by lane, and their sum.
    fn weights(&self, p: Vec3) -> ([Vec4; MAX_LIGHTS / LANE], f32) {
        let mut w = [Vec4::ZERO; MAX_LIGHTS / LANE];
        let mut sums = Vec4::ZERO;
        let (px, py, pz) = (Vec4::splat(p.x), Vec4::splat(p.y), Vec4::splat(p.z));
        for (lane, out) in self.lanes.iter().zip(&mut w) {
            let side = lane.nx * px + lane.ny * py + lane.nz * pz + lane.d;
            let (dx, dy, dz) = (px - lane.cx, py - lane.cy, pz - lane.cz);
            let dist2 = (dx * dx + dy * dy + dz * dz).max(lane.radius2);
            let facing = side.cmpgt(-lane.slack);
            *out = Vec4::select(facing, lane.power, Vec4::ZERO) / dist2;
            sums += *out;
        }
        (w, sums.element_sum())
    }

    /// An emissive triangle for shading point `p` and the probability it was chosen
    /// with; `None` when no triangle faces `p`.
    pub fn sample(&self, p: Vec3, u: f32) -> Option<(usize, f32)> {
        let (w, total) = self.weights(p);
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let target = u * total;
        let mut before = 0.0;
        let mut chosen = None;
        'lanes: for (l, lane) in w[..self.lanes.len()].iter().enumerate() {
            let in_lane = lane.element_sum();
            if target >= before + in_lane {
                before += in_lane;
                continue;
            }
            for i in 0..LANE {
                before += lane[i];
                if target < before && lane[i] > 0.0 {
                    chosen = Some(l * LANE + i);
                    break 'lanes;
                }
            }
        }
        // Should rounding carry the target past the sum: the last triangle with a weight.
        let k = chosen.or_else(|| (0..self.count).rev().find(|&k| weight(&w, k) > 0.0))?;
        Some((k, weight(&w, k) / total))
    }

    /// The probability with which [`FewLights::sample`] picks triangle `k` for `p`.
    pub fn probability(&self, p: Vec3, k: usize) -> f32 {
        let (w, total) = self.weights(p);
        if !(total > 0.0 && total.is_finite()) {
            return 0.0;
        }
        weight(&w, k) / total
    }
}

/// Triangle `k`'s weight in lanes `w`.
fn weight(w: &[Vec4], k: usize) -> f32 {
    w[k / LANE][k % LANE]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::check_choice;

    /// A unit square at height `y` facing down (two triangles), as a lamp.
    fn lamp(y: f32) -> [[Vec3; 3]; 2] {
        let (a, b) = (Vec3::new(0.0, y, 0.0), Vec3::new(1.0, y, 0.0));
        let (c, d) = (Vec3::new(1.0, y, 1.0), Vec3::new(0.0, y, 1.0));
        [[a, b, c], [a, c, d]]
    }

    /// The choice is a distribution over the triangles facing the point (probabilities
    /// sum to one, sampling lands in proportion to them), a triangle turned away is never
    /// chosen, and a double-sided one always may be.
    #[test]
    fn only_triangles_facing_the_point_are_chosen_in_proportion() {
        let [t0, t1] = lamp(2.0);
        let [t2, t3] = lamp(3.0);
        let vertices = [t0, t1, t2, t3];
        let down = Vec3::NEG_Y;
        let normal = [down, down, down, down];
        let double_sided = [false, false, false, true];
        let lights =
            FewLights::new(&vertices, &normal, &double_sided, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        let below = Vec3::new(0.5, 0.0, 0.5);
        let between = Vec3::new(0.5, 2.5, 0.5);
        for p in [below, between] {
            check_choice(
                4,
                |u| lights.sample(p, u),
                |k| lights.probability(p, k),
                &p.to_string(),
            );
        }
        // Between the lamps: the lower one's one-sided triangles face away.
        assert_eq!(lights.probability(between, 0), 0.0);
        assert_eq!(lights.probability(between, 1), 0.0);
        assert!(lights.probability(between, 2) > 0.0);
        assert!(lights.probability(between, 3) > 0.0);
        // Above both, only the double-sided triangle; behind a lone one-sided triangle,
        // nothing at all.
        assert_eq!(lights.probability(Vec3::new(0.5, 4.0, 0.5), 3), 1.0);
        let lone = FewLights::new(&[t0], &[down], &[false], &[1.0]).unwrap();
        assert!(lone.sample(Vec3::new(0.5, 5.0, 0.5), 0.5).is_none());
        assert_eq!(lone.sample(below, 0.5), Some((0, 1.0)));
        // Too many triangles to weigh one by one.
        let many = vec![t0; MAX_LIGHTS + 1];
        let normals = vec![down; MAX_LIGHTS + 1];
        let sides = vec![false; MAX_LIGHTS + 1];
        let powers = vec![1.0; MAX_LIGHTS + 1];
        assert!(FewLights::new(&many, &normals, &sides, &powers).is_none());
    }

    /// A point in the plane of a one-sided triangle, or a rounding step behind it, may
    /// still be chosen: only points clearly behind are culled.
    #[test]
    fn points_on_the_plane_are_not_culled() {
        let [t0, _] = lamp(1000.0);
        let lights = FewLights::new(&[t0], &[Vec3::NEG_Y], &[false], &[1.0]).unwrap();
        assert!(lights.sample(Vec3::new(3.0, 1000.0, 0.5), 0.5).is_some());
        assert!(lights.sample(Vec3::new(3.0, 1000.0001, 0.5), 0.5).is_some());
        assert!(lights.sample(Vec3::new(3.0, 1000.1, 0.5), 0.5).is_none());
    }
}
