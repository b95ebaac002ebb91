//! The free-space list: extents of the file that no committed structure references. It is
//! saved in every root block, so holes survive restarts (the original kept it in memory
//! only and lost every hole at each restart).

use std::collections::BTreeMap;

use super::format::Extent;

/// Coalesced free extents, by offset.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FreeList {
    map: BTreeMap<u64, u64>,
}

impl FreeList {
    pub fn from_extents(extents: &[Extent]) -> Self {
        let mut f = Self::default();
        for e in extents {
            f.insert(*e);
        }
        f
    }

    pub fn extents(&self) -> Vec<Extent> {
        self.map.iter().map(|(&offset, &len)| Extent { offset, len }).collect()
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
            self.map.remove(&o);
        }
        while let Some((&o, &l)) = self.map.range(start..=end).next() {
            end = end.max(o + l);
            self.map.remove(&o);
        }
        self.map.insert(start, end - start);
    }

    /// Takes `len` bytes from the first extent large enough (lowest address first, which
    /// keeps the file compact).
    pub fn allocate(&mut self, len: u64) -> Option<u64> {
        let (&o, &l) = self.map.iter().find(|&(_, &l)| l >= len)?;
        self.map.remove(&o);
        if l > len {
            self.map.insert(o + len, l - len);
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
        self.map.remove(&o);
        if offset > o {
            self.map.insert(o, offset - o);
        }
        if o + l > offset + len {
            self.map.insert(offset + len, o + l - offset - len);
        }
        true
    }

    /// Removes free space at or beyond `end` (space past the committed end of the file).
    pub fn truncate(&mut self, end: u64) {
        let beyond: Vec<u64> = self.map.range(end..).map(|(&o, _)| o).collect();
        for o in beyond {
            self.map.remove(&o);
        }
        if let Some((&o, l)) = self.map.range_mut(..end).next_back()
            && o + *l > end
        {
            *l = end - o;
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
    fn coalesces_and_allocates_first_fit() {
        let mut f = FreeList::default();
        f.insert(e(100, 10));
        f.insert(e(120, 10));
        f.insert(e(110, 10));
        assert_eq!(f.extents(), vec![e(100, 30)]);
        f.insert(e(200, 50));
        assert_eq!(f.allocate(40), Some(200));
        assert_eq!(f.allocate(5), Some(100));
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
