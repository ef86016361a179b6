//! How much of the atlas budget is resident: the physical atlas follows the
//! pages the frames need, by whole layers, between one layer and the budget
//! ([`super::ObjectSpaceConfig::atlas_budget_texels`]), so that memory
//! tracks what a view sees rather than the most any view of the scene could
//! (Sponza at 3840x2160 sees 1.7 to 3.1 M texels along its path: a fixed
//! atlas sized for the busiest frames holds 2.4 times the emptiest's).
//!
//! Like the budget, it sees each frame's page count a few frames late. It
//! grows at once when a frame fills most of the atlas (pages a frame cannot
//! get are shaded forward until then), and shrinks only after a run of
//! frames that each needed little of it, to the most any of them needed, so
//! that a passing dip does not cost a resize. Both leave the atlas about
//! [`FILL`] full. Shrinking first moves the pages in use beyond the new
//! size below it, onto free or less recently used pages, with their shades
//! (`paging::resize`; pages that find none are evicted, and their tiles
//! shaded again the next time they are seen); growing copies nothing but
//! what is there.

// Chosen by replaying the pages Sponza's path needs at 1920x1080 and
// 3840x2160 (H100 runs, with the read-back's lag of 3 frames): every frame
// within 1.85 times its pages, 2 to 5 resizes in 330 frames, no page
// request failing; waiting 12 frames to shrink let the atlas reach 2.2x.

/// A frame needing more than this share of the resident pages grows the atlas.
pub const GROW_AT: f64 = 0.9;
/// Frames needing less than this share of the resident pages ...
pub const SHRINK_AT: f64 = 0.6;
/// ... this many in a row shrink the atlas.
pub const SHRINK_AFTER: u32 = 4;
/// The share of the resident pages a resize aims the frames' need at.
pub const FILL: f64 = 0.75;

/// The atlas's size in layers, as the frames' needs ask.
#[derive(Clone, Debug, PartialEq)]
pub struct Residency {
    /// Pages per layer.
    layer_pages: u32,
    /// The budget, in layers.
    max_layers: u32,
    /// The layers the observed frames ask for.
    wanted: u32,
    /// Frames in a row that needed less than [`SHRINK_AT`], and the most
    /// pages any of them needed.
    low_run: u32,
    low_peak: f64,
    /// The newest frame observed (older counts arriving late are ignored).
    newest: Option<u64>,
}

impl Residency {
    /// Starts at the whole budget: the first frames' needs are not known
    /// until their counts come back, and a single frame must fit.
    pub fn new(layer_pages: u32, max_layers: u32) -> Self {
        Self { layer_pages, max_layers, wanted: max_layers, low_run: 0, low_peak: 0.0, newest: None }
    }

    /// Takes frame `frame` into account: it needed `needed` pages (in use
    /// and failed) with `resident` pages in the atlas.
    pub fn observe(&mut self, frame: u64, needed: f64, resident: u32) {
        if self.newest.is_some_and(|n| frame <= n) {
            return;
        }
        self.newest = Some(frame);
        let resident = resident as f64;
        if needed > GROW_AT * resident {
            self.wanted = self.wanted.max(self.layers_for(needed));
            (self.low_run, self.low_peak) = (0, 0.0);
        } else if needed < SHRINK_AT * resident {
            self.low_run += 1;
            self.low_peak = self.low_peak.max(needed);
            if self.low_run >= SHRINK_AFTER {
                self.wanted = self.layers_for(self.low_peak);
                (self.low_run, self.low_peak) = (0, 0.0);
            }
        } else {
            (self.low_run, self.low_peak) = (0, 0.0);
        }
    }

    /// The layers the atlas should have, when it has `layers` and that
    /// is not what the frames ask for.
    pub fn resize(&self, layers: u32) -> Option<u32> {
        (self.wanted != layers).then_some(self.wanted)
    }

    /// Layers that hold `pages` at [`FILL`], within the budget.
    fn layers_for(&self, pages: f64) -> u32 {
        ((pages / FILL / self.layer_pages as f64).ceil() as u32).clamp(1, self.max_layers)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `needs` (pages per frame) to a residency of 100-page layers
    /// that resizes as soon as asked; returns the resident pages per frame.
    fn follow(needs: &[f64], max_layers: u32) -> Vec<u32> {
        let mut r = Residency::new(100, max_layers);
        let mut layers = max_layers;
        needs
            .iter()
            .enumerate()
            .map(|(frame, &need)| {
                r.observe(frame as u64, need, layers * 100);
                layers = r.resize(layers).unwrap_or(layers);
                layers * 100
            })
            .collect()
    }

    #[test]
    fn shrinks_after_a_run_of_small_frames_to_their_peak() {
        let mut needs = vec![1000.0; SHRINK_AFTER as usize - 1];
        needs.push(3000.0);
        let resident = follow(&needs, 40);
        // All but the last frame below 60 % of 4000: no shrink yet.
        assert!(resident.iter().all(|&r| r == 4000), "{resident:?}");
        let resident = follow(&[1000.0; 2 * SHRINK_AFTER as usize], 40);
        // 1000 pages at 75 %: 14 layers, then steady (1000 is 71 % of them).
        assert_eq!(resident[SHRINK_AFTER as usize - 2], 4000);
        assert_eq!(resident[SHRINK_AFTER as usize - 1], 1400);
        assert!(resident[SHRINK_AFTER as usize..].iter().all(|&r| r == 1400), "{resident:?}");
    }

    #[test]
    fn grows_at_once_when_a_frame_fills_the_atlas_and_never_past_the_budget() {
        let mut needs = vec![1000.0; SHRINK_AFTER as usize];
        needs.extend([1200.0, 1300.0, 1700.0, 5000.0]);
        let resident = follow(&needs, 40);
        let n = SHRINK_AFTER as usize;
        assert_eq!(resident[n - 1], 1400);
        // 1200 is 86 %: stays; 1300 is 93 %: 1800 pages (18 layers); 1700 is
        // 94 % of those: 23 layers; 5000 asks for 67 and gets the budget.
        assert_eq!(&resident[n..], &[1400, 1800, 2300, 4000]);
    }

    #[test]
    fn every_frame_of_a_slow_path_stays_within_twice_its_pages() {
        // Need swinging between 1.7 and 3.1 M texels (Sponza at 4K) over a
        // few hundred frames, in pages of 64 texels; budget 4.2 M texels.
        let needs: Vec<f64> =
            (0..600).map(|f| (2.4e6 + 0.7e6 * (f as f64 * std::f64::consts::TAU / 300.0).sin()) / 64.0).collect();
        let resident = follow(&needs, 656);
        for (f, (&r, &n)) in resident.iter().zip(&needs).enumerate().skip(SHRINK_AFTER as usize) {
            let ratio = r as f64 / n;
            assert!((1.0..=2.0).contains(&ratio), "frame {f}: {r} pages resident for {n:.0} needed ({ratio:.2}x)");
        }
    }

    #[test]
    fn late_counts_of_older_frames_are_ignored() {
        let mut r = Residency::new(100, 40);
        r.observe(5, 3900.0, 4000);
        r.observe(3, 10.0, 4000);
        assert_eq!(r.resize(40), None);
        assert_eq!(r.layers_for(0.0), 1);
    }
}
