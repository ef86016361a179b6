//! Sets of tiles as bitsets over a flat tile index space: a frame needs a
//! few thousand of millions of tiles, and the studies intersect such sets
//! (two cameras, two frames) thousands of times.

use std::sync::atomic::{AtomicU64, Ordering};

/// A set of tile indices below `len`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileSet {
    words: Vec<u64>,
    len: u32,
}

impl TileSet {
    /// The empty set over tiles `0..len`.
    pub fn new(len: u32) -> Self {
        Self { words: vec![0; (len as usize).div_ceil(64)], len }
    }

    /// The set of `tiles` (each below `len`).
    pub fn from_tiles(len: u32, tiles: impl IntoIterator<Item = u32>) -> Self {
        let mut set = Self::new(len);
        for t in tiles {
            set.insert(t);
        }
        set
    }

    pub fn insert(&mut self, tile: u32) {
        assert!(tile < self.len, "tile {tile} outside 0..{}", self.len);
        self.words[tile as usize / 64] |= 1 << (tile % 64);
    }

    pub fn contains(&self, tile: u32) -> bool {
        tile < self.len && self.words[tile as usize / 64] & (1 << (tile % 64)) != 0
    }

    /// Tiles in the set.
    pub fn count(&self) -> u64 {
        self.words.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// Tiles in both sets (same index space).
    pub fn intersection_count(&self, other: &TileSet) -> u64 {
        self.check_space(other);
        self.words.iter().zip(&other.words).map(|(a, b)| (a & b).count_ones() as u64).sum()
    }

    /// Adds every tile of `other`.
    pub fn union_with(&mut self, other: &TileSet) {
        self.check_space(other);
        for (a, b) in self.words.iter_mut().zip(&other.words) {
            *a |= b;
        }
    }

    fn check_space(&self, other: &TileSet) {
        assert_eq!(self.len, other.len, "tile sets over different index spaces");
    }
}

/// A [`TileSet`] that many threads fill at once.
pub struct ConcurrentTileSet {
    words: Vec<AtomicU64>,
    len: u32,
}

impl ConcurrentTileSet {
    pub fn new(len: u32) -> Self {
        Self { words: (0..(len as usize).div_ceil(64)).map(|_| AtomicU64::new(0)).collect(), len }
    }

    pub fn insert(&self, tile: u32) {
        debug_assert!(tile < self.len);
        let (word, bit) = (&self.words[tile as usize / 64], 1u64 << (tile % 64));
        // Neighbouring pixels mark the same tiles: read first, so that
        // threads do not fight over a cache line for bits already set.
        if word.load(Ordering::Relaxed) & bit == 0 {
            word.fetch_or(bit, Ordering::Relaxed);
        }
    }

    pub fn finish(self) -> TileSet {
        TileSet { words: self.words.into_iter().map(AtomicU64::into_inner).collect(), len: self.len }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_intersections_and_unions() {
        let a = TileSet::from_tiles(200, [0, 63, 64, 130, 199]);
        let b = TileSet::from_tiles(200, [63, 130, 131]);
        assert_eq!((a.count(), b.count()), (5, 3));
        assert_eq!(a.intersection_count(&b), 2);
        let mut u = a.clone();
        u.union_with(&b);
        assert_eq!(u.count(), 6);
        assert!(u.contains(131) && !u.contains(132) && !u.contains(500));
        let c = ConcurrentTileSet::new(200);
        for t in [0, 63, 64, 130, 199, 63] {
            c.insert(t);
        }
        assert_eq!(c.finish(), a);
    }
}
