//! `--materials layered:K`: every material of any scene gets K layers, so
//! that experiments can vary the shading cost. Layer 0 is the material
//! itself (a base layer everywhere, so `layered:1` renders as the plain
//! material, through the layered code); the layers above cycle through
//! painted metal, dirt, bare metal, snow on upward faces, emissive spots and
//! grime, each under a world-space noise mask (or the slope rule) with a
//! soft edge and an opacity below 1, so that most points show several
//! layers and each of them is lit: the cost grows with K. Scales are in
//! metres, from the scene's size, so a 5 cm model and Sponza look alike.
//!
//! `--materials bands`: the ground's bands as shaded layers ([`bands`]).

use glam::Vec3;

use super::{Channel, Layer, LayerKind, Mask, MaskTexture};
use crate::scene::Scene;
use crate::scene::generate::terrain::bands::*;

/// Gives every material of `scene` `k` layers (1 to [`super::MAX_LAYERS`]).
pub fn layered(scene: &mut Scene, k: usize) {
    let bounds = scene.bounds();
    let size = (bounds.max - bounds.min).max_element();
    // Features about 1/40 of the scene across (Sponza: about 1 m).
    let unit = if size.is_finite() && size > 0.0 { size / 40.0 } else { 1.0 };
    for (m, material) in scene.materials.iter_mut().enumerate() {
        material.layers = (0..k).map(|i| layer(i, m, unit)).collect();
    }
}

/// Layer `i` of material `m`, features `unit` metres across.
fn layer(i: usize, m: usize, unit: f32) -> Layer {
    if i == 0 {
        return Layer::full(LayerKind::OWN);
    }
    // A hue per material and layer, so that layers are told apart.
    let hue = ((m * 7 + i * 3) % 12) as f32 / 12.0;
    let tint = hue_rgb(hue);
    let kind = match (i - 1) % 6 {
        0 => LayerKind::PaintedMetal {
            paint: tint * 0.6,
            paint_roughness: 0.45,
            metal: Vec3::new(0.56, 0.57, 0.58),
            metal_roughness: 0.3,
            chips: 0.35,
            chip_scale: 0.3 * unit,
        },
        1 => LayerKind::Dirt { color: Vec3::new(0.25, 0.18, 0.12), roughness: 0.9, scale: 0.5 * unit },
        2 => LayerKind::BareMetal { color: Vec3::new(0.91, 0.78, 0.42), roughness: 0.35, scale: unit },
        3 => LayerKind::Snow {
            snow: Vec3::new(0.9, 0.92, 0.95),
            snow_roughness: 0.7,
            ice_color: Vec3::new(0.6, 0.75, 0.85),
            ice_roughness: 0.15,
            ice: 0.3,
            bend: 0.3,
        },
        4 => LayerKind::Emissive { emission: tint * 0.5, albedo_scale: 0.8 },
        _ => LayerKind::Dirt { color: tint * 0.3, roughness: 0.7, scale: 0.25 * unit },
    };
    let mask = if (i - 1) % 6 == 3 {
        // Snow on faces turned up.
        Mask::SlopeHeight { axis: Vec3::Y, height: [-1e30, 1e30], height_fade: 0.0, slope: [0.6, 1.0], slope_fade: 0.3 }
    } else {
        Mask::Noise {
            scale: unit * (1.0 + 0.37 * i as f32),
            octaves: 3,
            seed: (m * 16 + i) as u32,
            threshold: 0.5,
            softness: 0.5,
        }
    };
    Layer { kind, mask, invert: false, opacity: 0.7 }
}

/// `--materials bands`: every material gets the terrain's seven bands (sand,
/// grass, forest, dirt, rock, scree, snow: the colours and limits of
/// `terrain::bands`, which `terrain::band_albedo` bakes) and ice as
/// layers masked by height and slope (Oxide's terrain: dirt, ice, snow
/// layers by slope and height, shaded in object space), each with its own
/// roughness and BRDF (snow and ice as `snow` layers, the others as
/// grime-varied `dirt`), instead of baked into one albedo. Heights are
/// shares of the scene's height above its lowest point, as the bands'; the
/// base layer is the material itself. Where the material has a base colour
/// texture, a top layer shows it again where its alpha is below one half:
/// the terrain stamps its precals (roads, scorch marks) there, before
/// shading, so they stay on top of the bands (alpha 1 elsewhere).
pub fn bands(scene: &mut Scene) {
    let bounds = scene.bounds();
    let (low, high) = (bounds.min.y, bounds.max.y);
    let (low, h) = if low.is_finite() && high > low { (low, high - low) } else { (0.0, 1.0) };
    let at = |share: f32| low + share * h;
    // Noise features a 400th of the scene across (the terrain: 5 m).
    let size = (bounds.max - bounds.min).max_element();
    let unit = if size.is_finite() && size > 0.0 { size / 400.0 } else { 1.0 };
    // Slopes as the cosine of the normal to +y: rise over run s is 1 / sqrt(1 + s^2).
    let cos = |rise: f32| 1.0 / (1.0 + rise * rise).sqrt();
    let band = |kind: LayerKind, height: [f32; 2], slope: [f32; 2]| Layer {
        kind,
        mask: Mask::SlopeHeight {
            axis: Vec3::Y,
            height: [at(height[0]), at(height[1])],
            height_fade: 0.04 * h,
            slope,
            slope_fade: 0.05,
        },
        invert: false,
        opacity: 0.9,
    };
    let dirt = |color: Vec3, roughness: f32, scale: f32| LayerKind::Dirt { color, roughness, scale: scale * unit };
    let snow = |ice: f32, bend: f32| LayerKind::Snow {
        snow: SNOW,
        snow_roughness: 0.7,
        ice_color: Vec3::new(0.6, 0.75, 0.85),
        ice_roughness: 0.1,
        ice,
        bend,
    };
    let (snow_flat, gentle, steep) = (cos(SNOW_SCREE_SLOPE), cos(DIRT_SLOPE), cos(ROCK_SLOPE));
    let below = -1e30;
    let above = 1e30;
    let layers = [
        band(dirt(SAND, 0.85, 0.5), [below, SAND_TOP], [gentle, 1.0]),
        band(dirt(GRASS, 0.8, 1.0), [SAND_TOP, GRASS_TOP], [gentle, 1.0]),
        band(dirt(FOREST, 0.9, 2.0), [GRASS_TOP, FOREST_TOP], [gentle, 1.0]),
        band(dirt(DIRT, 0.9, 0.5), [below, above], [steep, gentle]),
        band(dirt(ROCK, 0.6, 1.0), [below, above], [-1.0, steep]),
        band(dirt(SCREE, 0.75, 0.3), [FOREST_TOP, SCREE_TOP], [steep, 1.0]),
        band(snow(0.1, 0.15), [SCREE_TOP, above], [snow_flat, 1.0]),
        // Ice on the highest, flattest ground (no baked band of its own).
        band(snow(1.0, 0.0), [0.86, above], [cos(0.15), 1.0]),
    ];
    for material in &mut scene.materials {
        let mut all = vec![Layer::full(LayerKind::OWN)];
        all.extend(layers.iter().cloned());
        if material.base_color_texture.is_some() {
            all.push(Layer {
                kind: LayerKind::OWN,
                mask: Mask::Texture {
                    texture: MaskTexture::BaseColor,
                    channel: Channel::A,
                    scale: 1.0,
                    threshold: 0.5,
                    softness: 0.1,
                },
                invert: true,
                opacity: 1.0,
            });
        }
        material.layers = all;
    }
}

/// A saturated colour of hue `h` (0 to 1).
fn hue_rgb(h: f32) -> Vec3 {
    let c = |o: f32| (((h + o).fract() * 6.0 - 3.0).abs() - 1.0).clamp(0.0, 1.0);
    Vec3::new(c(0.0), c(2.0 / 3.0), c(1.0 / 3.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    #[test]
    fn every_material_gets_k_layers_over_its_own_surface() {
        let mut s = Scene { materials: vec![Material::default(); 3], ..Scene::default() };
        layered(&mut s, 7);
        for m in &s.materials {
            assert_eq!(m.layers.len(), 7);
            assert!(matches!(m.layers[0].kind, LayerKind::Base { .. }) && m.layers[0].mask == Mask::Full);
            assert!(m.layers[1..].iter().all(|l| l.opacity < 1.0), "layers above the base let it show");
        }
        assert_ne!(s.materials[0].layers[1], s.materials[1].layers[1], "materials differ");
    }

    /// Eight bands by height and slope over the material, and the precal
    /// layer only over a material with a base colour texture.
    #[test]
    fn bands_layer_the_ground_by_height_and_slope() {
        let textured = Material { base_color_texture: Some(0), ..Material::default() };
        let mut s = Scene { materials: vec![Material::default(), textured], ..Scene::default() };
        bands(&mut s);
        let [plain, textured] = [&s.materials[0].layers, &s.materials[1].layers];
        assert!(matches!(plain[0].kind, LayerKind::Base { .. }) && plain[0].mask == Mask::Full);
        let by_rule = plain.iter().filter(|l| matches!(l.mask, Mask::SlopeHeight { .. })).count();
        assert_eq!((plain.len(), by_rule), (9, 8));
        assert_eq!(textured.len(), 10);
        assert!(matches!(textured[9].mask, Mask::Texture { channel: Channel::A, .. }) && textured[9].invert);
        // The snow is above the grass, the rock steeper than the dirt.
        let rule = |l: &Layer| match l.mask {
            Mask::SlopeHeight { height, slope, .. } => (height, slope),
            _ => unreachable!(),
        };
        assert!(rule(&plain[7]).0[0] > rule(&plain[2]).0[1]);
        assert!(rule(&plain[5]).1[1] <= rule(&plain[4]).1[0]);
    }
}
