//! `--gloss high`: a material override that provokes specular aliasing, as
//! Oxide's object space lighting describes it (specular powers of 1000-2000
//! that crawl and sparkle when shaded per pixel). Applied to the scene before
//! any pipeline sees it, so every pipeline and the reference render the same
//! materials. Normal maps come from the file or `--textures detailed`.

use serde::Serialize;

use super::Scene;

/// Phong exponent of `--gloss high`.
pub const HIGH_SHININESS: f32 = 1500.0;
/// GGX roughness of `--gloss high` (the metallic-roughness texture's green
/// channel, where a material has one, multiplies it).
pub const HIGH_ROUGHNESS: f32 = 0.05;
/// The least specular strength of `--gloss high`: a narrow lobe of the
/// files' usual 0-0.3 strength would hardly show.
pub const HIGH_SPECULAR: f32 = 1.0;

/// The material setting, for `--gloss`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Gloss {
    /// The materials as the scene defines them.
    #[default]
    Default,
    /// Every material: Phong exponent 1500, GGX roughness 0.05, specular at least 1.
    High,
}

impl Gloss {
    /// The name `--gloss` takes and reports carry.
    pub fn name(self) -> &'static str {
        match self {
            Gloss::Default => "default",
            Gloss::High => "high",
        }
    }
}

/// Overrides every material of `scene` as `gloss` says.
pub fn apply(scene: &mut Scene, gloss: Gloss) {
    if gloss == Gloss::High {
        for m in &mut scene.materials {
            m.shininess = HIGH_SHININESS;
            m.roughness = HIGH_ROUGHNESS;
            m.specular = m.specular.max(HIGH_SPECULAR);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    #[test]
    fn high_gloss_overrides_every_material_and_default_none() {
        let materials = vec![Material::default(), Material { specular: 2.0, roughness: 0.9, ..Material::default() }];
        let mut scene = Scene { materials, ..Scene::default() };
        let before = format!("{:?}", scene.materials);
        apply(&mut scene, Gloss::Default);
        assert_eq!(format!("{:?}", scene.materials), before);
        apply(&mut scene, Gloss::High);
        for m in &scene.materials {
            assert_eq!((m.shininess, m.roughness), (HIGH_SHININESS, HIGH_ROUGHNESS));
            assert!(m.specular >= HIGH_SPECULAR);
        }
        assert_eq!(scene.materials[1].specular, 2.0, "a stronger specular is kept");
    }
}
