//! The free-space list: extents of the file that no committed structure references. It is
//! saved in every root block, so holes survive restarts (the original kept it in memory
//! only and lost every hole at each restart).

use std::collections::{BTreeMap, BTreeSet};

use super::format::Extent;

/// Coalesced free extents, by offset and by size (best fit in `O(log n)`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FreeList {
    map: BTreeMap<u64, u64>,
    by_size: BTreeSet<(u64, u64)>,
}

impl FreeList {
    pub fn from_extents(extents: &[Extent]) -> Self {
        let mut f = Self::default();
        for e in extents {
            f.insert(*e);
        }
        f
    }

    fn put(&mut self, offset: u64, len: u64) {
        self.map.insert(offset, len);
        self.by_size.insert((len, offset));
    }

    fn take(&mut self, offset: u64) -> Option<u64> {
        let len = self.map.remove(&offset)?;
        self.by_size.remove(&(len, offset));
        Some(len)
    }

    pub fn extents(&self) -> Vec<Extent> {
        self.map
            .iter()
            .map(|(&offset, &len)| Extent { offset, len })
            .collect()
    }

    pub fn total(&self) -> u64 {
        self.map.values().sum()
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }

    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// Adds an extent, merging it with its neighbours.
    pub fn insert(&mut self, e: Extent) {
        if e.len == 0 {
            return;
        }
        let (mut start, mut end) = (e.offset, e.end());
        if let Some((&o, &l)) = self.map.range(..=start).next_back()
            && o + l >= start
        {
            start = o;
            end = end.max(o + l);
            self.take(o);
        }
        while let Some((&o, &l)) = self.map.range(start..=end).next() {
            end = end.max(o + l);
            self.take(o);
        }
        self.put(start, end - start);
    }

    /// Takes `len` bytes from the smallest extent large enough (best fit keeps large
    /// holes for large beams).
    pub fn allocate(&mut self, len: u64) -> Option<u64> {
        let &(l, o) = self.by_size.range((len, 0)..).next()?;
        self.take(o);
        if l > len {
            self.put(o + len, l - len);
        }
        Some(o)
    }

    /// Takes exactly `[offset, offset + len)` if it is free (to extend a beam in place).
    pub fn take_at(&mut self, offset: u64, len: u64) -> bool {
        let Some((&o, &l)) = self.map.range(..=offset).next_back() else {
            return false;
        };
        if o + l < offset + len {
            return false;
        }
        self.take(o);
        if offset > o {
            self.put(o, offset - o);
        }
        if o + l > offset + len {
            self.put(offset + len, o + l - offset - len);
        }
        true
    }

    /// Removes free space at or beyond `end` (space past the committed end of the file).
    pub fn truncate(&mut self, end: u64) {
        let beyond: Vec<u64> = self.map.range(end..).map(|(&o, _)| o).collect();
        for o in beyond {
            self.take(o);
        }
        if let Some((&o, &l)) = self.map.range(..end).next_back()
            && o + l > end
        {
            self.take(o);
            self.put(o, end - o);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(offset: u64, len: u64) -> Extent {
        Extent { offset, len }
    }

    #[test]
    fn coalesces_and_allocates_best_fit() {
        let mut f = FreeList::default();
        f.insert(e(100, 10));
        f.insert(e(120, 10));
        f.insert(e(110, 10));
        assert_eq!(f.extents(), vec![e(100, 30)]);
        f.insert(e(200, 50));
        assert_eq!(f.allocate(40), Some(200));
        assert_eq!(f.allocate(5), Some(240), "the 10-byte hole fits best");
        assert_eq!(f.allocate(5), Some(245));
        assert_eq!(f.allocate(5), Some(100));
        f.insert(e(240, 10));
        assert_eq!(f.extents(), vec![e(105, 25), e(240, 10)]);
        assert_eq!(f.allocate(100), None);
        assert!(f.take_at(110, 5));
        assert_eq!(f.extents(), vec![e(105, 5), e(115, 15), e(240, 10)]);
        assert!(!f.take_at(112, 5));
        f.truncate(241);
        assert_eq!(f.extents(), vec![e(105, 5), e(115, 15), e(240, 1)]);
        assert_eq!(f.total(), 21);
    }
}
