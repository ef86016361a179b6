//! Data derived from content (a mesh's chart islands and clusters, a
//! texture's mip chain, the procedural relief), remembered for the rest of
//! the process under a hash of what the derivation reads.
//!
//! Programs that build many renderers of one scene (the viewer, one per
//! switch of pipeline or option; experiments, one per cell; the tests)
//! derived the same data each time: on a CPU driver, a sixth of a viewer
//! switch went to islands and clusters, and a tenth of a quality
//! experiment's cell to filtering texture mips. A changed input hashes
//! differently and is derived again.

use std::collections::HashMap;
use std::sync::{Arc, LazyLock, Mutex};

/// Derived values of one kind, keyed by a content hash, within a budget of
/// `weight` units: a process that loads scene after scene forgets them all
/// past it rather than grow without bound.
pub struct Memo<T> {
    entries: LazyLock<Mutex<Entries<T>>>,
    budget: usize,
    weight: fn(&T) -> usize,
}

struct Entries<T> {
    map: HashMap<u64, Arc<T>>,
    used: usize,
}

impl<T> Entries<T> {
    fn empty() -> Self {
        Self { map: HashMap::new(), used: 0 }
    }

    fn locked() -> Mutex<Self> {
        Mutex::new(Self::empty())
    }
}

impl<T> Memo<T> {
    /// A memo holding values whose `weight`s sum to at most `budget`.
    pub const fn new(budget: usize, weight: fn(&T) -> usize) -> Self {
        Self { entries: LazyLock::new(Entries::locked), budget, weight }
    }

    /// The value remembered under `key`, or `derive`'s, then remembered.
    pub fn get(&self, key: u64, derive: impl FnOnce() -> T) -> Arc<T> {
        let lock = || self.entries.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(value) = lock().map.get(&key) {
            return value.clone();
        }
        // Derived outside the lock: derivations may be long, and may use
        // other memos (or this one, for another key).
        let value = Arc::new(derive());
        let weight = (self.weight)(&value);
        if weight <= self.budget {
            let mut entries = lock();
            if entries.used + weight > self.budget {
                *entries = Entries::empty();
            }
            if entries.map.insert(key, value.clone()).is_none() {
                entries.used += weight;
            }
        }
        value
    }

    /// The weight of the values remembered now.
    pub fn used(&self) -> usize {
        self.entries.lock().unwrap_or_else(|e| e.into_inner()).used
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembers_by_key_and_forgets_everything_past_the_budget() {
        static MEMO: Memo<Vec<u8>> = Memo::new(10, Vec::len);
        let derived = std::cell::Cell::new(0);
        let get = |key: u64, len: usize| {
            MEMO.get(key, || {
                derived.set(derived.get() + 1);
                vec![0; len]
            })
        };
        assert_eq!(get(1, 4).len(), 4);
        assert_eq!(get(1, 4).len(), 4);
        assert_eq!(get(2, 6).len(), 6);
        assert_eq!(derived.get(), 2, "a remembered key is not derived again");
        assert_eq!(MEMO.used(), 10);
        get(3, 1);
        assert_eq!(MEMO.used(), 1, "past the budget everything is forgotten, then the new value kept");
        get(1, 4);
        assert_eq!(derived.get(), 4);
        get(4, 11);
        assert_eq!(MEMO.used(), 5, "a value over the whole budget is not kept");
    }
}
