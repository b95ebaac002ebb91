//! Choosing an emitter by where the light is wanted.
//!
//! Emissive triangles chosen by their power alone send most shadow rays to the strongest
//! lamp, even from a point right beside a weak one (Khronos' EmissiveStrengthTest: cubes
//! of strength 1 to 16, the strongest drawing half the samples everywhere). Here the
//! triangles are grouped by material (one lamp, one group, in most scenes), and at each
//! shading point a group is chosen in proportion to its power over its squared distance
//! (never less than its own radius, so a point on or inside a group does not make it
//! infinite), then a triangle of the group by power. Every group keeps a positive
//! probability, so the estimate stays unbiased; [`LightGroups::probability`] gives the
//! same probability again for MIS.
//!
//! Scenes with one group choose by power as before; scenes with more than [`MAX_GROUPS`]
//! groups too (the per-point weights would cost more than they save).

use glam::Vec3;

use crate::sampling::Distribution;

/// The most groups weighed at every shading point.
pub const MAX_GROUPS: usize = 16;

pub struct LightGroups {
    groups: Vec<Group>,
    /// For each area light, its group and its probability within the group.
    group_of: Vec<u32>,
    within: Vec<f32>,
}

struct Group {
    centre: Vec3,
    /// Squared radius of a sphere about `centre` holding the group's triangles.
    radius2: f32,
    power: f32,
    /// Area-light indices of the members, and their choice by power.
    members: Vec<u32>,
    choose: Distribution,
}

impl LightGroups {
    /// Groups of the area lights `vertices[k]` by `material[k]`, weighed by `power[k]`;
    /// `None` when there would be fewer than two groups or more than [`MAX_GROUPS`].
    pub fn new(vertices: &[[Vec3; 3]], material: &[u32], power: &[f32]) -> Option<Self> {
        let mut keys: Vec<u32> = material.to_vec();
        keys.sort_unstable();
        keys.dedup();
        if !(2..=MAX_GROUPS).contains(&keys.len()) {
            return None;
        }
        let mut group_of = vec![0u32; material.len()];
        let mut within = vec![0f32; material.len()];
        let mut groups = Vec::with_capacity(keys.len());
        for (g, key) in keys.iter().enumerate() {
            let members: Vec<u32> = (0..material.len() as u32)
                .filter(|&k| material[k as usize] == *key)
                .collect();
            let weights: Vec<f32> = members.iter().map(|&k| power[k as usize]).collect();
            let choose = Distribution::new(&weights)?;
            let count = (members.len() * 3) as f32;
            let centre = members
                .iter()
                .flat_map(|&k| vertices[k as usize])
                .sum::<Vec3>()
                / count;
            let radius2 = members
                .iter()
                .flat_map(|&k| vertices[k as usize])
                .map(|v| v.distance_squared(centre))
                .fold(0.0f32, f32::max);
            for (i, &k) in members.iter().enumerate() {
                group_of[k as usize] = g as u32;
                within[k as usize] = choose.probability(i);
            }
            groups.push(Group {
                centre,
                radius2: radius2.max(f32::MIN_POSITIVE),
                power: weights.iter().sum(),
                members,
                choose,
            });
        }
        Some(Self {
            groups,
            group_of,
            within,
        })
    }

    /// Each group's weight seen from `p`, and their sum.
    fn weights(&self, p: Vec3) -> ([f32; MAX_GROUPS], f32) {
        let mut w = [0.0f32; MAX_GROUPS];
        let mut total = 0.0;
        for (g, group) in self.groups.iter().enumerate() {
            w[g] = group.power / p.distance_squared(group.centre).max(group.radius2);
            total += w[g];
        }
        (w, total)
    }

    /// An area light for shading point `p`, and the probability it was chosen with.
    /// `u` picks the group, and rescaled, the triangle within it.
    pub fn sample(&self, p: Vec3, u: f32) -> Option<(usize, f32)> {
        let (w, total) = self.weights(p);
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let target = u * total;
        let mut before = 0.0;
        let mut g = self.groups.len() - 1;
        for (i, &wi) in w[..self.groups.len()].iter().enumerate() {
            if target < before + wi {
                g = i;
                break;
            }
            before += wi;
        }
        let p_group = w[g] / total;
        let rest = ((target - before) / w[g]).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        let group = &self.groups[g];
        let i = group.choose.sample(rest);
        let k = group.members[i] as usize;
        Some((k, p_group * self.within[k]))
    }

    /// The probability with which [`LightGroups::sample`] picks area light `k` for
    /// shading point `p`.
    pub fn probability(&self, p: Vec3, k: usize) -> f32 {
        let (w, total) = self.weights(p);
        if !(total > 0.0 && total.is_finite()) {
            return 0.0;
        }
        w[self.group_of[k] as usize] / total * self.within[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::check_choice;

    fn tri(at: Vec3) -> [Vec3; 3] {
        [at, at + Vec3::X * 0.1, at + Vec3::Y * 0.1]
    }

    /// The choice is a distribution (its probabilities sum to one at any point), sampling
    /// lands in proportion to it, and the nearer of two equal lamps is favoured.
    #[test]
    fn probabilities_sum_to_one_and_match_the_samples() {
        let vertices = [
            tri(Vec3::ZERO),
            tri(Vec3::new(0.1, 0.0, 0.0)),
            tri(Vec3::new(5.0, 0.0, 0.0)),
        ];
        let groups = LightGroups::new(&vertices, &[0, 0, 1], &[1.0, 3.0, 4.0]).unwrap();
        for p in [
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(4.0, 0.0, 1.0),
            Vec3::ZERO,
        ] {
            check_choice(
                3,
                |u| groups.sample(p, u),
                |k| groups.probability(p, k),
                &p.to_string(),
            );
        }
        let near = Vec3::new(0.5, 1.0, 0.0);
        assert!(groups.probability(near, 0) + groups.probability(near, 1) > 0.9);
        // One material is one group: nothing to choose by place.
        assert!(LightGroups::new(&vertices, &[2, 2, 2], &[1.0, 1.0, 1.0]).is_none());
    }
}
