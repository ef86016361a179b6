//! Scripted runs (`view --script FILE`): camera moves and option changes
//! replayed frame by frame, for tests and by hand. A script is JSON:
//!
//! ```json
//! { "repeat": 200,
//!   "steps": [ {"pipeline": "objectspace"}, {"tile_size": 16}, {"frames": 2},
//!              {"camera": {"eye": [0, 2, 8], "target": [0, 1, 0], "fov": 60}},
//!              {"move": [0.5, 0, 1]}, {"turn": [10, -5]}, {"path_frame": 120},
//!              {"lights": "small:500"}, {"seed": 3}, {"env": "sky"}, {"exposure": 1.5},
//!              {"view": "atlas-pages"}, {"atlas_object": 3}, {"atlas_level": 1},
//!              {"variable_rate": 1.5}, {"atlas_budget": 4}, {"ui": true},
//!              {"screenshot": "shot.png"} ] }
//! ```
//!
//! `steps` run `repeat` times (default once). Changes take effect at the
//! next rendered frame; `frames` renders that many frames.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Deserialize;

/// A script file's contents.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Script {
    /// How many times the steps run (a parameter, so that the switching test
    /// runs 200 and a check by hand 1000).
    #[serde(default = "once")]
    pub repeat: u32,
    pub steps: Vec<Step>,
}

fn once() -> u32 {
    1
}

/// One step of a script.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Step {
    /// Render this many frames.
    Frames(u32),
    /// Switch the pipeline (a `--pipeline` name).
    Pipeline(String),
    /// A `--lights` set.
    Lights(String),
    /// The light placement's seed.
    Seed(u64),
    /// An `--env` (`none`, `sky` or a Radiance file).
    Env(String),
    /// A fixed exposure multiplier.
    Exposure(f32),
    /// Object space: a `--view` name.
    View(String),
    TileSize(u32),
    Reuse(u32),
    MipBias(f32),
    /// Levels coarser where triangles are flat (`--variable-rate`).
    VariableRate(f32),
    TexelDensity(f32),
    /// Millions of texels per frame; `null` for no limit.
    ShadeBudget(Option<f64>),
    /// The physical atlas in Mi texels (`--atlas-budget`); `null` for the default.
    AtlasBudget(Option<u64>),
    /// `--view atlas-pages`: the object shown.
    AtlasObject(usize),
    /// `--view atlas-pages`: the mip level shown.
    AtlasLevel(usize),
    /// A free camera (`render --eye --target --fov`).
    Camera {
        eye: [f32; 3],
        target: [f32; 3],
        fov: f32,
    },
    /// Fly right, up and forward by scene units (from the current view,
    /// entering the fly camera).
    Move([f32; 3]),
    /// Turn right and up by degrees.
    Turn([f32; 2]),
    /// The camera path's frame.
    PathFrame(u32),
    /// Show or hide the control panels.
    Ui(bool),
    /// Save the next frame as a PNG (with its JSON sidecar).
    Screenshot(PathBuf),
}

impl Script {
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
        serde_json::from_str(&text).with_context(|| format!("{}: not a viewer script", path.display()))
    }
}

/// A script being played: the steps in order, `repeat` times over.
pub struct Player {
    script: Script,
    round: u32,
    next: usize,
}

impl Player {
    pub fn new(script: Script) -> Self {
        Self { script, round: 0, next: 0 }
    }

    /// Rounds of the steps completed so far.
    pub fn rounds_done(&self) -> u32 {
        self.round
    }

    /// The next step, or `None` when the script has ended.
    pub fn next_step(&mut self) -> Option<Step> {
        if self.script.steps.is_empty() {
            return None;
        }
        if self.next == self.script.steps.len() {
            self.next = 0;
            self.round += 1;
        }
        if self.round >= self.script.repeat {
            return None;
        }
        self.next += 1;
        Some(self.script.steps[self.next - 1].clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_step_kind() {
        let text = r#"{"repeat": 2, "steps": [
            {"frames": 2}, {"pipeline": "deferred"}, {"lights": "big:3"}, {"seed": 4}, {"exposure": 1.5},
            {"view": "tile-mask"}, {"tile_size": 16}, {"reuse": 2}, {"mip_bias": 0.5}, {"texel_density": 128},
            {"shade_budget": null}, {"shade_budget": 2.5}, {"variable_rate": 1.5}, {"atlas_budget": 4},
            {"atlas_budget": null}, {"atlas_object": 2}, {"atlas_level": 1},
            {"camera": {"eye": [0, 1, 2], "target": [0, 0, 0], "fov": 60}},
            {"move": [1, 0, 0]}, {"turn": [10, -5]}, {"path_frame": 7}, {"ui": false}, {"screenshot": "a.png"}]}"#;
        let s: Script = serde_json::from_str(text).unwrap();
        assert_eq!(s.repeat, 2);
        assert_eq!(s.steps.len(), 23);
        assert_eq!(s.steps[13], Step::AtlasBudget(Some(4)));
        assert_eq!(s.steps[11], Step::ShadeBudget(Some(2.5)));
        assert!(serde_json::from_str::<Script>(r#"{"steps": [{"fly": 1}]}"#).is_err());
    }

    #[test]
    fn player_repeats_the_steps() {
        let s: Script = serde_json::from_str(r#"{"repeat": 3, "steps": [{"frames": 1}, {"seed": 2}]}"#).unwrap();
        let mut p = Player::new(s);
        let mut n = 0;
        while p.next_step().is_some() {
            n += 1;
        }
        assert_eq!(n, 6);
        assert_eq!(p.rounds_done(), 3);
        assert_eq!(Player::new(Script { repeat: 5, steps: vec![] }).next_step(), None);
    }
}
