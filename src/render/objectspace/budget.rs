//! A stable budget (Oxide's object space lighting): when a frame needs more
//! than the physical atlas holds, or shades more texels than the shading
//! budget, every pixel's mip level is biased coarser until it fits, and the
//! bias falls back when there is room, so memory and the shading cost per
//! frame stay flat while quality gives.
//!
//! The controller sees each frame's load (demand over budget, the larger of
//! the two) a few frames late (the
//! counters' read-back never stalls the frame), so it corrects the bias that
//! frame was shaded with, not the current one: frames still in flight would
//! otherwise push the same error in again and again, and the bias would
//! overshoot and swing. Texels and pages scale as 4^-bias (a level coarser
//! has a quarter of the texels), so the bias that fits a load `l` is half of
//! log2(l) more than the frame's; half of that step is taken.

/// Largest bias the controller adds (levels).
pub const MAX_BIAS: f32 = 8.0;
/// Below this share of the budget, the bias falls back.
const ROOM: f64 = 0.7;
/// Share of the computed step taken per observation.
const GAIN: f32 = 0.5;
/// Smallest step (levels): near the budget the computed steps shrink, and
/// per-pixel levels round, so without it the count would creep in slowly.
const MIN_STEP: f32 = 1.0 / 16.0;

/// The bias the budget currently adds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Budget {
    /// Levels added to every pixel's mip level, in [0, MAX_BIAS].
    pub bias: f32,
    /// The newest frame observed (older counts arriving late are ignored).
    newest: Option<u64>,
}

impl Budget {
    /// Takes frame `frame`'s load (its demand over the budget: 1 is at the
    /// budget), at `used` (the bias this controller gave that frame), into
    /// account.
    pub fn observe(&mut self, frame: u64, used: f32, load: f64) {
        if self.newest.is_some_and(|n| frame <= n) {
            return;
        }
        self.newest = Some(frame);
        let over = load > 1.0;
        let room = load < ROOM && used > 0.0;
        if over || room {
            let step = GAIN * 0.5 * load.max(1e-6).log2() as f32;
            let step = if over { step.max(MIN_STEP) } else { step.min(-MIN_STEP) };
            self.bias = (used + step).clamp(0.0, MAX_BIAS);
        }
    }
}

/// Levels of the budget's bias that every object takes alike; past them
/// the rest goes to the objects that cover less of the screen first.
pub const UNIFORM_BIAS: f32 = 1.0;

/// Per-object share of the budget's `bias`, by screen importance (`shares`:
/// each object's share of the screen; `None` for objects outside the atlas
/// or the view, which take the plain bias): every object takes the bias up
/// to [`UNIFORM_BIAS`]; of the rest, an object takes twice as much times
/// one minus its importance rank (0 for the object covering most of the
/// screen, 2 for the one covering least), so that on average the rest is
/// taken once, but the objects the viewer sees most stay sharpest.
pub fn object_biases(bias: f32, shares: &[Option<f32>]) -> Vec<f32> {
    let uniform = bias.min(UNIFORM_BIAS);
    let rest = (bias - UNIFORM_BIAS).max(0.0);
    let mut ranked: Vec<(usize, f32)> = shares.iter().enumerate().filter_map(|(i, s)| s.map(|s| (i, s))).collect();
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let mut out = vec![bias; shares.len()];
    let last = ranked.len().saturating_sub(1).max(1) as f32;
    for (rank, (object, _)) in ranked.iter().enumerate() {
        // rank 0: the smallest share; `last`: the largest.
        let importance = if ranked.len() == 1 { 0.5 } else { rank as f32 / last };
        out[*object] = uniform + rest * 2.0 * (1.0 - importance);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn past_one_level_the_least_seen_objects_take_the_bias() {
        // Under one level every object alike.
        assert_eq!(object_biases(0.6, &[Some(0.5), Some(0.01), None]), vec![0.6, 0.6, 0.6]);
        // Past it: the largest object keeps one level, the smallest takes 1 + 2 x 1.5.
        let b = object_biases(2.5, &[Some(0.5), Some(0.01), None, Some(0.1)]);
        assert_eq!(b, vec![1.0, 4.0, 2.5, 2.5]);
        // On average over the visible objects the rest is taken once.
        let visible = [b[0], b[1], b[3]];
        assert!((visible.iter().sum::<f32>() / 3.0 - 2.5).abs() < 1e-6);
    }

    /// Against a model where shaded texels fall 4x per level of bias, the
    /// controller settles inside [ROOM, 1] of the budget, comes back down
    /// when demand drops, and ignores counts older than one it has seen.
    #[test]
    fn settles_within_budget_and_falls_back() {
        let demand = |bias: f32, base: f64| base * 4f64.powf(-bias as f64);
        // Counts arrive LAG frames late, as the read-back delivers them.
        const LAG: usize = 3;
        let mut b = Budget::default();
        let mut used = Vec::new();
        let mut base = 16.0e6;
        for frame in 0..80usize {
            if frame == 40 {
                base = 0.5e6;
            }
            used.push(b.bias);
            if frame >= LAG {
                let seen = frame - LAG;
                b.observe(seen as u64, used[seen], demand(used[seen], base) / 1.0e6);
            }
            if frame == 39 {
                let shaded = demand(b.bias, 16.0e6);
                assert!((ROOM * 1.0e6..=1.0e6 * 1.01).contains(&shaded), "shaded {shaded} at bias {}", b.bias);
                assert!((b.bias - 2.0).abs() < 0.1, "bias {}", b.bias);
                // Settled: no swing over the last frames.
                let last = &used[30..40];
                assert!(last.iter().all(|u| (u - b.bias).abs() < 0.1), "swinging: {last:?}");
            }
        }
        assert_eq!(b.bias, 0.0, "demand under the budget needs no bias");
        let before = b.clone();
        b.observe(10, 0.0, 1.0e3);
        assert_eq!(b, before, "a late count of an old frame changes nothing");
    }
}
