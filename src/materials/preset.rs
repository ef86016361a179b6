//! `--materials layered:K`: every material of any scene gets K layers, so
//! that experiments can vary the shading cost. Layer 0 is the material
//! itself (a base layer everywhere, so `layered:1` renders as the plain
//! material, through the layered code); the layers above cycle through
//! painted metal, dirt, bare metal, snow on upward faces, emissive spots and
//! grime, each under a world-space noise mask (or the slope rule) with a
//! soft edge and an opacity below 1, so that most points show several
//! layers and each of them is lit: the cost grows with K. Scales are in
//! metres, from the scene's size, so a 5 cm model and Sponza look alike.

use glam::Vec3;

use super::{Layer, LayerKind, Mask};
use crate::scene::Scene;

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
        return Layer::full(LayerKind::Base { tint: Vec3::ONE, metallic: None, roughness: None });
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
}
