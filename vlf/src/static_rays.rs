//! Where a batch of rays against the static scene is traced: the CPU's walk here, or a
//! GPU's (the render node's `gpu_rays`). The passes that take whole batches — a wall's
//! shadow rays, a batch of gather samples — are written once against this interface and
//! give the same answers from either, up to the walks' rounding (stated where the GPU's
//! walk is). Moving objects are never here: they are tested on the CPU, where the frame
//! places them.

use holocave_scene::{Hit, Ray, Scene};
use rayon::prelude::*;

use crate::ShadowQuery;

/// A walk over the static scene's BVH that answers rays in batches.
pub trait StaticRays: Sync {
    /// The closest hit of each ray in the static scene (no distance limit).
    fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<Hit>>;

    /// Whether the static scene blocks each shadow query's ray before its `tmax`: every
    /// group's queries in order, the groups one after another (a group is one pixel's or
    /// one sample's rays, which a walk may keep together in a batch).
    fn blocked(&self, groups: &[Vec<ShadowQuery>]) -> Vec<bool>;
}

/// `answers` to `groups`' items one after another (as [`StaticRays::blocked`] gives
/// them), split into each group's.
pub fn per_group<'a, T>(groups: &[Vec<T>], answers: &'a [bool]) -> Vec<&'a [bool]> {
    let mut rest = answers;
    groups
        .iter()
        .map(|g| {
            let (mine, tail) = rest.split_at(g.len().min(rest.len()));
            rest = tail;
            mine
        })
        .collect()
}

/// The CPU's walk over `scene`'s static BVH, on all cores.
pub struct CpuRays<'a>(pub &'a Scene);

impl StaticRays for CpuRays<'_> {
    fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        rays.par_iter()
            .map(|r| self.0.closest_hit(r, f32::INFINITY))
            .collect()
    }

    fn blocked(&self, groups: &[Vec<ShadowQuery>]) -> Vec<bool> {
        let per_group: Vec<Vec<bool>> = groups
            .par_iter()
            .map(|g| g.iter().map(|q| self.0.occluded(&q.ray, q.tmax)).collect())
            .collect();
        per_group.into_iter().flatten().collect()
    }
}
