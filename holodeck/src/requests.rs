//! The request list (paper §2.2): entries (section, beam, wanted samples), served lowest
//! `computed / wanted` first. Since Monte Carlo error falls as `M^-½`, this serves the
//! beam with the largest remaining error relative to its target first.
//!
//! A lazy min-heap: each entry's key is its ratio when pushed; a popped entry whose ratio
//! has grown since (samples arrived or were assigned) is pushed back with the new ratio.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::beam_index::BeamKey;
use crate::cache::BeamMap;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Item {
    ratio: f64,
    key: BeamKey,
}

impl Eq for Item {}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap, we want the lowest ratio; ties by key.
        o.ratio
            .total_cmp(&self.ratio)
            .then_with(|| o.key.cmp(&self.key))
    }
}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

/// Requested beams and how many samples each should have.
#[derive(Default)]
pub struct RequestList {
    wanted: BeamMap<BeamKey, f64>,
    heap: BinaryHeap<Item>,
}

impl RequestList {
    /// Sets (replacing) the list. `have` gives each beam's computed (+ assigned) samples.
    pub fn set(&mut self, wanted: BeamMap<BeamKey, f64>, have: impl Fn(BeamKey) -> u32) {
        self.heap = wanted
            .iter()
            .filter(|(_, w)| **w > 0.0)
            .map(|(&key, &w)| Item {
                ratio: f64::from(have(key)) / w,
                key,
            })
            .collect();
        self.wanted = wanted;
    }

    pub fn len(&self) -> usize {
        self.wanted.len()
    }

    pub fn is_empty(&self) -> bool {
        self.wanted.is_empty()
    }

    /// Samples wanted for a beam (0 if not requested).
    pub fn wanted(&self, key: BeamKey) -> f64 {
        self.wanted.get(&key).copied().unwrap_or(0.0)
    }

    /// The beam with the lowest computed/wanted ratio, with that ratio, if any is below
    /// `limit`. The caller assigns samples to it and then calls [`RequestList::requeue`].
    pub fn pop(&mut self, have: impl Fn(BeamKey) -> u32, limit: f64) -> Option<(BeamKey, f64)> {
        while let Some(item) = self.heap.pop() {
            let Some(&w) = self.wanted.get(&item.key) else {
                continue;
            };
            let ratio = f64::from(have(item.key)) / w;
            if ratio > item.ratio {
                self.heap.push(Item {
                    ratio,
                    key: item.key,
                });
                continue;
            }
            if ratio >= limit {
                self.heap.push(item);
                return None;
            }
            return Some((item.key, ratio));
        }
        None
    }

    /// Puts a popped beam back with its current ratio.
    pub fn requeue(&mut self, key: BeamKey, have: u32) {
        if let Some(&w) = self.wanted.get(&key) {
            self.heap.push(Item {
                ratio: f64::from(have) / w,
                key,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    #[test]
    fn serves_lowest_ratio_first_and_fills_evenly() {
        let have = RefCell::new(BeamMap::<BeamKey, u32>::default());
        let get = |k| *have.borrow().get(&k).unwrap_or(&0);
        let mut r = RequestList::default();
        let wanted: BeamMap<BeamKey, f64> = [
            (BeamKey::new(0, 1), 10.0),
            (BeamKey::new(0, 2), 30.0),
            (BeamKey::new(1, 0), 60.0),
        ]
        .into_iter()
        .collect();
        have.borrow_mut().insert(BeamKey::new(1, 0), 30);
        r.set(wanted.clone(), get);
        let (k, ratio) = r.pop(get, f64::INFINITY).unwrap();
        assert_eq!((k, ratio), (BeamKey::new(0, 1), 0.0));
        // Assign one sample at a time, 100 times: ratios end within one sample of equal.
        *have.borrow_mut().entry(k).or_default() += 1;
        r.requeue(k, get(k));
        for _ in 0..99 {
            let (k, _) = r.pop(get, f64::INFINITY).unwrap();
            *have.borrow_mut().entry(k).or_default() += 1;
            r.requeue(k, get(k));
        }
        let ratios: Vec<f64> = wanted.iter().map(|(k, w)| f64::from(get(*k)) / w).collect();
        let (lo, hi) = ratios
            .iter()
            .fold((f64::MAX, 0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi - lo <= 1.0 / 10.0 + 1e-9, "{ratios:?}");
        // Nothing below a limit the beams have all reached.
        assert!(r.pop(get, lo).is_none());
    }
}
