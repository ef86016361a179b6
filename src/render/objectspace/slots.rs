//! The page directory's slots: a range of virtual page numbers per object
//! in view, so that the page directory and the request bits (a word per
//! block, a bit per page and per tile of the virtual space) are sized by the
//! objects in view, not by every object's largest texture.
//!
//! An object gets a slot ([`super::atlas::ObjectAtlas::span`] page numbers,
//! its levels numbered within it) the first frame a view's frustum holds it,
//! before that frame marks anything, so no pixel finds its object without
//! one; it keeps the slot while it stays in view and for
//! [`super::ObjectSpaceConfig::slot_timeout`] frames after, then gives it
//! back: its backed pages are freed (`paging/release.wgsl`) and their
//! chunks with them, and the range is given out again from the frame after
//! (that frame's paging clears the directory words of the freed chunks).
//! An object without a slot costs its atlas-table row and nothing in the
//! page table. The space grows (by a quarter at least) when a frame's
//! objects do not fit (the directory keeps its words) up to `max_pages`; an
//! object that still finds no room is shaded forward until one does.

use std::collections::BTreeMap;

use super::atlas::{AtlasLayout, SLOT_ALIGN};

/// The fewest page numbers the directory covers (a few KiB).
pub const MIN_PAGES: u32 = 1 << 16;
/// A slot holding this many more levels than its object needs (it went
/// away from every view) moves to a smaller one.
pub const REGROW_LEVELS: usize = 2;

/// What [`Slots::update`] changed this frame.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct SlotChanges {
    /// Objects whose slot was given or taken away (their table rows changed).
    pub moved: Vec<usize>,
    /// Ranges (first page, end) given back this frame: their backed pages
    /// must be freed before this frame marks.
    pub released: Vec<[u32; 2]>,
    /// The directory's new page numbers, when it grew.
    pub grown: Option<u32>,
}

/// The slots of one renderer's atlas layout.
#[derive(Clone, Debug)]
pub struct Slots {
    /// Page numbers the directory covers.
    pages: u32,
    /// Most it may grow to.
    max_pages: u32,
    /// Free ranges: first page -> length (coalesced).
    free: BTreeMap<u32, u32>,
    /// Ranges given back this frame, free from the next.
    quarantine: Vec<[u32; 2]>,
    /// Per object: the last frame a view held it.
    last_seen: Vec<u64>,
    /// Frames out of view before a slot goes back.
    timeout: u32,
    /// Objects in view that found no room this frame.
    unplaced: u32,
}

impl Slots {
    /// Takes every object of `layout` out of its slot (the layout's page
    /// count becomes the directory's first size).
    pub fn new(layout: &mut AtlasLayout, max_pages: u32, timeout: u32) -> Self {
        for o in 0..layout.objects.len() {
            layout.place(o, None, 0);
        }
        let max_pages = max_pages.max(MIN_PAGES);
        let pages = MIN_PAGES;
        layout.set_page_count(pages);
        Self {
            pages,
            max_pages,
            free: BTreeMap::from([(0, pages)]),
            quarantine: Vec::new(),
            last_seen: vec![0; layout.objects.len()],
            timeout,
            unplaced: 0,
        }
    }

    /// Page numbers the directory covers.
    pub fn pages(&self) -> u32 {
        self.pages
    }

    /// Objects in view that found no room (shaded forward) in the last update.
    pub fn unplaced(&self) -> u32 {
        self.unplaced
    }

    /// Frame `frame` (counted from 1) holds the objects `in_view` in some
    /// view (`Some`: the finest level any of its pixels may pick, less a
    /// level of margin): those without a slot get one from that level on,
    /// those whose slot lacks that level, or holds three or more finer ones
    /// than it, move to a new one (their pages freed: shaded again), and
    /// those out of view longer than the timeout give theirs back; `layout`
    /// follows.
    pub fn update(&mut self, layout: &mut AtlasLayout, in_view: &[Option<usize>], frame: u64) -> SlotChanges {
        let mut changes = SlotChanges::default();
        for [start, end] in std::mem::take(&mut self.quarantine) {
            self.give_back(start, end - start);
        }
        let (mut wanted, mut gone) = (Vec::new(), Vec::new());
        for (o, atlas) in layout.objects.iter().enumerate() {
            let Some(atlas) = atlas else { continue };
            let range = atlas.slot.map(|base| [base, base + atlas.span]);
            if let Some(first) = in_view[o] {
                let first = first.min(atlas.levels.len() - 1);
                self.last_seen[o] = frame;
                let fits = first >= atlas.first && first <= atlas.first + REGROW_LEVELS;
                match range {
                    None => wanted.push((atlas.span_from(first), o, first)),
                    Some(range) if !fits => {
                        gone.push((o, range));
                        wanted.push((atlas.span_from(first), o, first));
                    }
                    Some(_) => {}
                }
            } else if let Some(range) = range
                && frame - self.last_seen[o] > self.timeout as u64
            {
                gone.push((o, range));
            }
        }
        for (o, range) in gone {
            layout.place(o, None, 0);
            self.quarantine.push(range);
            changes.released.push(range);
            changes.moved.push(o);
        }
        // The largest first: the small ones fill the gaps they leave.
        wanted.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        self.unplaced = 0;
        for (span, o, first) in wanted {
            let base = self.take(span).or_else(|| {
                self.grow(span);
                self.take(span)
            });
            match base {
                Some(base) => {
                    layout.place(o, Some(base), first);
                    if !changes.moved.contains(&o) {
                        changes.moved.push(o);
                    }
                }
                None => self.unplaced += 1,
            }
        }
        if self.pages != layout.page_count {
            layout.set_page_count(self.pages);
            changes.grown = Some(self.pages);
        }
        changes
    }

    /// Page numbers in slots now (quarantined ranges included).
    pub fn pages_in_slots(&self) -> u64 {
        self.pages as u64 - self.free.values().map(|&n| n as u64).sum::<u64>()
    }

    /// First fit.
    fn take(&mut self, span: u32) -> Option<u32> {
        debug_assert_eq!(span % SLOT_ALIGN, 0);
        let (&start, &len) = self.free.iter().find(|(_, len)| **len >= span)?;
        self.free.remove(&start);
        if len > span {
            self.free.insert(start + span, len - span);
        }
        Some(start)
    }

    fn give_back(&mut self, mut start: u32, mut len: u32) {
        if let Some((&before, &n)) = self.free.range(..start).next_back()
            && before + n == start
        {
            self.free.remove(&before);
            (start, len) = (before, len + n);
        }
        if let Some(n) = self.free.remove(&(start + len)) {
            len += n;
        }
        self.free.insert(start, len);
    }

    /// Grows the space so that a free range at its end holds `span`: by a
    /// quarter at least (growing copies the directory and request bits, so
    /// not by the page), in whole [`MIN_PAGES`], up to `max_pages`.
    fn grow(&mut self, span: u32) {
        let tail = self.free.iter().next_back().filter(|(s, n)| *s + *n == self.pages).map_or(0, |(_, n)| *n);
        let old = self.pages as u64;
        let needed = old + span.saturating_sub(tail) as u64;
        let pages = needed.max(old + old / 4).next_multiple_of(MIN_PAGES as u64).min(self.max_pages as u64);
        if needed <= pages {
            self.pages = pages as u32;
            self.give_back(old as u32, self.pages - old as u32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Objects in view (`true`) needing every level.
    fn seen(objects: &[bool]) -> Vec<Option<usize>> {
        objects.iter().map(|&v| v.then_some(0)).collect()
    }

    fn layout() -> AtlasLayout {
        // Spans: 4096 at pages of 16 is 256x256 pages plus its mips.
        AtlasLayout::new(&[Some(4096), Some(64), None, Some(64)], 8, 16, 16384, 8).unwrap()
    }

    #[test]
    fn objects_in_view_get_slots_that_do_not_overlap() {
        let mut l = layout();
        let mut s = Slots::new(&mut l, 1 << 24, 2);
        assert!(l.objects.iter().flatten().all(|o| o.slot.is_none()));
        let c = s.update(&mut l, &seen(&[true, true, false, true]), 1);
        assert_eq!(c.moved.len(), 3);
        let mut ranges: Vec<[u32; 2]> =
            l.objects.iter().flatten().map(|o| [o.slot.unwrap(), o.slot.unwrap() + o.span]).collect();
        ranges.sort();
        assert!(ranges.windows(2).all(|w| w[0][1] <= w[1][0]));
        assert!(ranges.last().unwrap()[1] <= s.pages());
        // The large one did not fit the first 64 Ki pages: the space grew.
        assert!(l.objects[0].as_ref().unwrap().span > MIN_PAGES);
        assert_eq!(c.grown, Some(s.pages()));
        assert_eq!(l.page_count, s.pages());
        assert_eq!(s.pages_in_slots(), ranges.iter().map(|r| (r[1] - r[0]) as u64).sum::<u64>());
    }

    #[test]
    fn a_slot_goes_back_after_its_timeout_and_is_given_out_again() {
        let mut l = layout();
        let mut s = Slots::new(&mut l, 1 << 24, 2);
        s.update(&mut l, &seen(&[false, true, false, true]), 1);
        let base = l.objects[1].as_ref().unwrap().slot.unwrap();
        // Out of view for two frames: kept.
        for frame in 2..=3 {
            let c = s.update(&mut l, &seen(&[false, false, false, true]), frame);
            assert!(c.released.is_empty() && c.moved.is_empty());
        }
        let c = s.update(&mut l, &seen(&[false, false, false, true]), 4);
        let span = l.objects[1].as_ref().unwrap().span;
        assert_eq!(c.released, vec![[base, base + span]]);
        assert_eq!(c.moved, vec![1]);
        assert_eq!(l.objects[1].as_ref().unwrap().slot, None);
        // Not given out the frame it went back (its chunks are freed then) ...
        assert_eq!(s.pages_in_slots(), 2 * span as u64);
        // ... but from the next.
        s.update(&mut l, &seen(&[false, false, false, true]), 5);
        assert_eq!(s.pages_in_slots(), span as u64);
        s.update(&mut l, &seen(&[false, true, false, true]), 6);
        assert_eq!(l.objects[1].as_ref().unwrap().slot, Some(base));
    }

    #[test]
    fn a_slot_holds_the_levels_its_object_needs_and_moves_when_it_needs_finer() {
        let mut l = layout();
        let mut s = Slots::new(&mut l, 1 << 24, 2);
        // Far away: levels 3 on (4096 >> 3 = 512).
        s.update(&mut l, &[Some(3), None, None, None], 1);
        let far = l.objects[0].clone().unwrap();
        assert_eq!((far.first, far.span), (3, far.span_from(3)));
        assert!(far.span * 32 < far.span_from(0));
        let e = l.gpu_entry(0);
        assert_eq!((e.size, e.level_count as usize), (512, far.levels.len() - 3));
        assert_eq!(e.levels[0].page_base, far.slot.unwrap());
        // A level or two coarser: the slot stays.
        let c = s.update(&mut l, &[Some(5), None, None, None], 2);
        assert!(c.moved.is_empty() && c.released.is_empty());
        // Nearer: a new slot from level 1, the old one given back.
        let c = s.update(&mut l, &[Some(1), None, None, None], 3);
        let near = l.objects[0].as_ref().unwrap();
        assert_eq!(near.first, 1);
        assert_eq!(c.released, vec![[far.slot.unwrap(), far.slot.unwrap() + far.span]]);
        assert_eq!(c.moved, vec![0]);
        assert_ne!(near.slot, far.slot);
    }

    #[test]
    fn objects_past_the_largest_space_stay_without_a_slot() {
        let mut l = layout();
        let mut s = Slots::new(&mut l, MIN_PAGES, 2);
        s.update(&mut l, &seen(&[true, true, false, false]), 1);
        assert_eq!(l.objects[0].as_ref().unwrap().slot, None);
        assert!(l.objects[1].as_ref().unwrap().slot.is_some());
        assert_eq!((s.unplaced(), s.pages()), (1, MIN_PAGES));
    }
}
