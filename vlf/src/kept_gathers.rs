//! Gather samples kept where the light field keeps its light. A gather
//! ([`crate::gather`]) that lands on a diffuse element estimates, after one bounce, the
//! very irradiance the element holds (its one-bounce part divided by the lookup's weight
//! towards the eye); averaged per element and blended with the bake's value by the light
//! field's worth in samples (the measured prior `k`: `(k · baked + Σ estimates) / (k +
//! n)`), the estimates of every pixel that sees the element, in every frame, add up. Kept
//! on the screen, in a render cache's points, they are lost as the head moves and each
//! pixel has only its own; kept in the field they survive the motion, and a still view and
//! a moving one alike converge to the one-bounce image the gathers converge to.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use rand::{Rng, SeedableRng, rngs::SmallRng};

use crate::gather::gather_all;
use crate::pixel_direct::PixelDirect;
use crate::static_rays::StaticRays;
use crate::view::Visibility;

/// How many gathers a baked value is worth in `holocave vlf view --gathers` by default:
/// what a node measures on the Cornell box's front wall (`docs/performance/compare.md`); on the
/// breakfast room 8 to 128 drew alike after 300 frames.
pub const STILL_VIEW_PRIOR: f32 = 43.0;

/// The light field's values with the gathers kept in its elements.
pub struct KeptGathers {
    baked: Arc<Vec<[f32; 3]>>,
    /// What the baked value of an element is worth, in gather samples.
    prior: f32,
    /// Per element that took any: the weighted sum of its estimates and their weight.
    sums: HashMap<u32, (Vec3, f32)>,
    values: Vec<[f32; 3]>,
    /// Per block of [`BLOCK`] values, whether one changed since last asked.
    changed: Vec<bool>,
}

/// Values per block of [`KeptGathers::take_changed`]: changed values go to the GPU a
/// block at a time (a visible surface's elements lie together, a triangle's in a row).
pub const BLOCK: usize = 4096;

impl KeptGathers {
    /// Over the values `baked` (the elements' irradiance, then the tiles': only elements
    /// take estimates), the baked value of an element worth `prior` samples.
    pub fn new(baked: Arc<Vec<[f32; 3]>>, prior: f32) -> Self {
        let blocks = baked.len().div_ceil(BLOCK);
        KeptGathers {
            values: baked.to_vec(),
            baked,
            prior: prior.max(0.0),
            sums: HashMap::new(),
            changed: vec![false; blocks],
        }
    }

    /// What a baked value is worth from now on (the prior as measured); every element
    /// that took estimates blended again.
    pub fn set_prior(&mut self, prior: f32) {
        self.prior = prior.max(0.0);
        let elements: Vec<u32> = self.sums.keys().copied().collect();
        for e in elements {
            self.blend(e);
        }
    }

    /// Adds each sample's estimate of the irradiance where it landed to the four
    /// elements the lookups interpolate there, with the weights they read it by (the
    /// interpolation's adjoint: a sample counts where it is drawn, and a flat light stays
    /// flat); one that is not finite, or names no element, is left out.
    pub fn add(&mut self, estimates: impl IntoIterator<Item = ([(u32, f32); 4], Vec3)>) {
        for (cells, estimate) in estimates {
            if !estimate.is_finite() || cells.iter().any(|&(e, _)| e as usize >= self.values.len())
            {
                continue;
            }
            for (e, w) in cells {
                if w > 0.0 {
                    let s = self.sums.entry(e).or_insert((Vec3::ZERO, 0.0));
                    s.0 += estimate * w;
                    s.1 += w;
                    self.blend(e);
                }
            }
        }
    }

    fn blend(&mut self, e: u32) {
        let Some(&(sum, n)) = self.sums.get(&e) else {
            return;
        };
        let baked = Vec3::from(self.baked[e as usize]);
        let k = self.prior;
        self.values[e as usize] = ((baked * k + sum) / (k + n)).to_array();
        self.changed[e as usize / BLOCK] = true;
    }

    /// The values with the estimates kept in them.
    pub fn values(&self) -> &[[f32; 3]] {
        &self.values
    }

    /// The ranges of values (whole blocks of [`BLOCK`], runs merged) that changed since
    /// this was last asked.
    pub fn take_changed(&mut self) -> Vec<std::ops::Range<usize>> {
        let mut ranges: Vec<std::ops::Range<usize>> = Vec::new();
        for (b, changed) in self.changed.iter_mut().enumerate() {
            if std::mem::take(changed) {
                let r = b * BLOCK..((b + 1) * BLOCK).min(self.values.len());
                match ranges.last_mut() {
                    Some(last) if last.end == r.start => last.end = r.end,
                    _ => ranges.push(r),
                }
            }
        }
        ranges
    }

    /// The weight of the estimates an element has taken.
    pub fn taken(&self, e: u32) -> f32 {
        self.sums.get(&e).map_or(0.0, |s| s.1)
    }
}

/// What a still wall fed by gathers keeps in the field after `frames` frames: each
/// frame one gather through a random point of every pixel of `view` (`direct` the
/// next-event part, `remainder` the field's values the walls read, its rays traced by
/// `traced`), kept over `remainder` with a baked value worth `prior` of them.
pub fn of_still_view(
    vis: &Visibility,
    direct: &PixelDirect,
    remainder: &Arc<Vec<[f32; 3]>>,
    view: &WallView,
    (frames, prior): (u32, f32),
    traced: &dyn StaticRays,
) -> KeptGathers {
    let mut kept = KeptGathers::new(remainder.clone(), prior);
    let mut rng = SmallRng::seed_from_u64(0x6A7E);
    let w = view.size.width;
    for frame in 0..frames {
        let rays: Vec<_> = (0..w * view.size.height)
            .map(|i| {
                let at = Vec2::new((i % w) as f32, (i / w) as f32);
                view.ray(at + Vec2::new(rng.random(), rng.random()))
            })
            .collect();
        let seed = u64::from(frame).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let gathered = gather_all(vis, direct, remainder, &rays, seed, traced);
        kept.add(gathered.iter().filter_map(|g| g.kept));
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An element's value is the prior-weighted mean of its baked value and the
    /// estimates it took, by their weights; the others keep theirs; a sample naming no
    /// element or not finite is left out; a new prior blends again.
    #[test]
    fn an_elements_value_blends_its_estimates_with_the_baked_value() {
        let baked = Arc::new(vec![[1.0, 2.0, 3.0], [4.0, 4.0, 4.0], [9.0, 9.0, 9.0]]);
        let mut kept = KeptGathers::new(baked, 2.0);
        assert!(kept.take_changed().is_empty());
        let only = |e: u32| [(e, 1.0), (e, 0.0), (e, 0.0), (e, 0.0)];
        kept.add([
            (only(0), Vec3::splat(4.0)),
            (only(0), Vec3::splat(7.0)),
            ([(0, 0.5), (7, 0.5), (0, 0.0), (0, 0.0)], Vec3::ONE),
            (only(1), Vec3::NAN),
        ]);
        let all = 0..3;
        assert_eq!(kept.take_changed(), [all]);
        assert!(kept.take_changed().is_empty());
        // Nothing of the sample that names element 7, none of the one that is NaN.
        assert_eq!(kept.values()[0], [3.25, 3.75, 4.25]);
        assert_eq!(kept.values()[1..], [[4.0; 3], [9.0; 3]]);
        assert_eq!(
            (kept.taken(0), kept.taken(1), kept.taken(7)),
            (2.0, 0.0, 0.0)
        );
        // Split between two elements by its weights.
        kept.add([([(1, 0.25), (2, 0.75), (1, 0.0), (2, 0.0)], Vec3::ZERO)]);
        // (2 · 4 + 0.25 · 0) / 2.25 and (2 · 9) / 2.75
        assert_eq!(kept.values()[1], [8.0 / 2.25; 3]);
        assert_eq!(kept.values()[2], [18.0 / 2.75; 3]);
        kept.set_prior(0.0);
        assert_eq!(kept.values()[0], [5.5; 3]);
    }

    /// The values that changed are named by whole blocks, neighbouring blocks as one
    /// range, the last block cut at the end.
    #[test]
    fn changed_values_are_named_by_blocks() {
        let n = 3 * BLOCK + 10;
        let mut kept = KeptGathers::new(Arc::new(vec![[1.0; 3]; n]), 1.0);
        let only = |e: usize| [(e as u32, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)];
        kept.add([BLOCK + 5, 2 * BLOCK, n - 1].map(|e| (only(e), Vec3::ONE)));
        let from_the_second = BLOCK..n;
        assert_eq!(kept.take_changed(), [from_the_second]);
        kept.add([(only(7), Vec3::ONE), (only(n - 2), Vec3::ONE)]);
        assert_eq!(kept.take_changed(), [0..BLOCK, 3 * BLOCK..n]);
    }
}
