//! The light scenarios of the forward/deferred study (small, big, shadowed,
//! mixed 1:R) as generated light sets of a given count, and the study's
//! light counts.

use std::fmt;
use std::str::FromStr;

use serde::{Serialize, Serializer};

use crate::scene::LightSpec;
use crate::scene::lights::LightPart;

/// One scenario: which kind of lights a set of N lights holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Scenario {
    /// Point lights covering 0.25-5 % of the screen each.
    Small,
    /// Lights covering 20-100 % of the screen, without shadows.
    Big,
    /// Big lights casting shadows.
    Shadowed,
    /// One big shadowed light to `R` small ones.
    Mixed(u32),
}

impl Scenario {
    /// The study's four scenarios, mixed at 1:5 and 1:10.
    pub const STUDY: [Scenario; 5] =
        [Scenario::Small, Scenario::Big, Scenario::Shadowed, Scenario::Mixed(5), Scenario::Mixed(10)];

    /// The light spec of `count` lights (ambient and sun come with every
    /// set and are not counted). Mixed sets hold `round(count / (1 + R))` big
    /// shadowed lights (at least one) and small ones for the rest, so that
    /// every scenario is measured at the same total count.
    pub fn spec(self, count: u32) -> LightSpec {
        if count == 0 {
            return LightSpec::None;
        }
        let parts = match self {
            Scenario::Small => vec![LightPart::Small(count)],
            Scenario::Big => vec![LightPart::Big(count)],
            Scenario::Shadowed => vec![LightPart::Shadowed(count)],
            Scenario::Mixed(r) => {
                let big = ((f64::from(count) / f64::from(1 + r)).round() as u32).clamp(1, count);
                let mut parts = vec![LightPart::Shadowed(big)];
                if count > big {
                    parts.push(LightPart::Small(count - big));
                }
                parts
            }
        };
        LightSpec::Generated(parts)
    }

    /// Whether its sets hold shadowed lights.
    pub fn shadowed(self) -> bool {
        matches!(self, Scenario::Shadowed | Scenario::Mixed(_))
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Scenario::Small => f.write_str("small"),
            Scenario::Big => f.write_str("big"),
            Scenario::Shadowed => f.write_str("shadowed"),
            Scenario::Mixed(r) => write!(f, "mixed-1:{r}"),
        }
    }
}

impl Serialize for Scenario {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl FromStr for Scenario {
    type Err = String;

    /// `small`, `big`, `shadowed`, or `mixed-1:R` (also `mixed:R`) with R >= 1.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("'{s}' is not a scenario (small, big, shadowed, mixed-1:R)");
        match s.trim() {
            "small" => Ok(Scenario::Small),
            "big" => Ok(Scenario::Big),
            "shadowed" => Ok(Scenario::Shadowed),
            other => {
                let r = other.strip_prefix("mixed-1:").or_else(|| other.strip_prefix("mixed:")).ok_or_else(bad)?;
                r.parse::<u32>().ok().filter(|&r| r >= 1).map(Scenario::Mixed).ok_or_else(bad)
            }
        }
    }
}

/// The study's light counts, 1-10 by 1, 10-20 by 2 and 20-100 by 10, and
/// ours beyond them: 200, 500, 1,000, 2,000, 5,000 and 10,000.
pub fn study_counts() -> Vec<u32> {
    let mut counts: Vec<u32> = (1..=10).chain((12..=20).step_by(2)).chain((30..=100).step_by(10)).collect();
    counts.extend([200, 500, 1_000, 2_000, 5_000, 10_000]);
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn study_counts_follow_the_steps() {
        let c = study_counts();
        assert_eq!(c.len(), 10 + 5 + 8 + 6);
        assert_eq!(c[..12], [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 12, 14]);
        assert!(c.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(*c.last().unwrap(), 10_000);
    }

    #[test]
    fn specs_hold_the_count_and_the_ratio() {
        for s in Scenario::STUDY {
            for n in [1, 7, 12, 1000] {
                assert_eq!(s.spec(n).generated_count(), Some(u64::from(n)), "{s} {n}");
            }
            assert_eq!(s.spec(0), LightSpec::None);
            assert_eq!(s.to_string().parse::<Scenario>().unwrap(), s);
        }
        assert_eq!(Scenario::Mixed(5).spec(12).to_string(), "shadowed:2+small:10");
        assert_eq!(Scenario::Mixed(10).spec(3).to_string(), "shadowed:1+small:2");
        assert_eq!(Scenario::Mixed(5).spec(1).to_string(), "shadowed:1");
        assert_eq!("mixed:5".parse::<Scenario>().unwrap(), Scenario::Mixed(5));
        assert!("mixed-1:0".parse::<Scenario>().is_err() && "huge".parse::<Scenario>().is_err());
    }
}
