//! Layered materials, as Oxide's object space lighting has them: a material
//! is its own surface under an ordered list of [`Layer`]s, each a kind with
//! its own parameters (hence its own BRDF inputs) and a [`Mask`]. Every
//! pipeline lights each layer's surface with every light it gives the point
//! and blends the lit results by mask, bottom to top (`layers.wgsl`, one
//! WGSL function per layer kind and per mask kind), so the shading cost
//! grows with the number of layers that show at a point.
//!
//! Layers come from a JSON file ([`mod@file`], `--materials FILE`, schema in
//! `docs/materials.md`) or the preset `layered:K` ([`preset`]), applied to
//! the scene's materials before any pipeline sees them ([`apply`]); without
//! either, materials have no layers and every pipeline renders as before.
//!
//! On the GPU the layers of every material are one table, a storage buffer
//! of [`GpuLayer`] (112 bytes each, scene binding 13): material after
//! material, in order, and each object's table entry holds its material's
//! range (`Object.layer_first`, `Object.layer_count`), so the shaders find a
//! point's layers from the object id every pass already has.

pub mod file;
pub mod preset;

use std::path::PathBuf;

use glam::{Mat4, Vec3, Vec4};

use crate::scene::{Material, Scene};
use crate::shaders::gpu_struct;

/// Most layers a material may have (a bound on the shading cost of a point).
pub const MAX_LAYERS: usize = 16;

/// What a layer is made of: each kind is one WGSL function that gives the
/// layer's surface from the material's (`layer_*` in `layers.wgsl`).
/// Colours are linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub enum LayerKind {
    /// The material's own surface (textures, normal map, emission), its
    /// albedo tinted, and its metallic and roughness replaced where given.
    Base { tint: Vec3, metallic: Option<f32>, roughness: Option<f32> },
    /// Paint over metal, chipped where noise (of `chip_scale` metres) passes
    /// the `chips` share, showing the metal with soft chip edges.
    PaintedMetal { paint: Vec3, paint_roughness: f32, metal: Vec3, metal_roughness: f32, chips: f32, chip_scale: f32 },
    /// Bare metal, its roughness varied by brushed streaks `scale` metres long.
    BareMetal { color: Vec3, roughness: f32, scale: f32 },
    /// Dirt or grime, its albedo and ambient occlusion varied by noise of
    /// `scale` metres.
    Dirt { color: Vec3, roughness: f32, scale: f32 },
    /// Snow turning to ice by `ice` (0 to 1), its normal bent upwards by
    /// `bend` (0 to 1).
    Snow { snow: Vec3, snow_roughness: f32, ice_color: Vec3, ice_roughness: f32, ice: f32, bend: f32 },
    /// The material's surface, its albedo scaled by `albedo_scale`, emitting
    /// `emission` (linear radiance) more.
    Emissive { emission: Vec3, albedo_scale: f32 },
    /// A printed surface (a decal's colour, roughness and metallic).
    Decal { color: Vec3, roughness: f32, metallic: f32 },
}

impl LayerKind {
    /// The material's own surface, unchanged.
    pub const OWN: LayerKind = LayerKind::Base { tint: Vec3::ONE, metallic: None, roughness: None };
}

/// A texture channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    R = 0,
    G = 1,
    B = 2,
    A = 3,
}

/// Which of the material's own textures a texture mask reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaskTexture {
    BaseColor,
    Normal,
    MetallicRoughness,
    Emissive,
    Occlusion,
}

impl MaskTexture {
    /// The JSON names.
    pub const NAMES: [&'static str; 5] = ["base_color", "normal", "metallic_roughness", "emissive", "occlusion"];

    /// The material's texture of this slot.
    pub fn of(self, m: &Material) -> Option<usize> {
        match self {
            Self::BaseColor => m.base_color_texture,
            Self::Normal => m.normal_texture,
            Self::MetallicRoughness => m.metallic_roughness_texture,
            Self::Emissive => m.emissive_texture,
            Self::Occlusion => m.occlusion_texture,
        }
    }

    /// Whether the texture is in the colour (sRGB) array, else the linear one.
    pub fn is_color(self) -> bool {
        matches!(self, Self::BaseColor | Self::Emissive)
    }
}

/// Where a layer shows: the mask's value, remapped by the shape, times the
/// layer's opacity.
#[derive(Clone, Debug, PartialEq)]
pub enum Mask {
    /// Everywhere.
    Full,
    /// A channel of one of the material's textures, repeated `scale` times
    /// over its UV0; 1 above `threshold` (soft over `softness`).
    Texture { texture: MaskTexture, channel: Channel, scale: f32, threshold: f32, softness: f32 },
    /// Fractal value noise of world position, `scale` metres per cell,
    /// `octaves` octaves, seeded; 1 above `threshold` (soft over `softness`).
    Noise { scale: f32, octaves: u32, seed: u32, threshold: f32, softness: f32 },
    /// Where the height along the unit `axis` is within `height` (low, high)
    /// and the normal's cosine to the axis within `slope` (low, high), each
    /// fading over its `fade`.
    SlopeHeight { axis: Vec3, height: [f32; 2], height_fade: f32, slope: [f32; 2], slope_fade: f32 },
    /// A box projector: centred at `center`, projecting along `direction`
    /// over `depth` metres each way, its footprint `size` metres (width,
    /// height; `up` orients it), square or `round`, fading over `softness`
    /// (share of the half-size) at its edge, on surfaces facing it.
    Decal { center: Vec3, direction: Vec3, up: Vec3, size: [f32; 2], depth: f32, round: bool, softness: f32 },
}

/// One layer of a material.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    pub kind: LayerKind,
    pub mask: Mask,
    /// Inverts the mask.
    pub invert: bool,
    /// Multiplies the mask (0 to 1).
    pub opacity: f32,
}

impl Layer {
    /// A layer of `kind` shown everywhere.
    pub fn full(kind: LayerKind) -> Self {
        Self { kind, mask: Mask::Full, invert: false, opacity: 1.0 }
    }
}

/// `Layer.kind` and `Layer.mask` in WGSL (exported as `LAYER_*`, `MASK_*`).
pub fn wgsl_constants() -> Vec<(&'static str, u32)> {
    let kinds = ["LAYER_BASE", "LAYER_PAINTED_METAL", "LAYER_BARE_METAL", "LAYER_DIRT", "LAYER_SNOW"];
    let mut c: Vec<_> = kinds.iter().enumerate().map(|(i, n)| (*n, i as u32)).collect();
    c.extend([("LAYER_EMISSIVE", 5), ("LAYER_DECAL", 6)]);
    c.extend([("MASK_FULL", 0), ("MASK_TEXTURE", 1), ("MASK_NOISE", 2), ("MASK_SLOPE_HEIGHT", 3), ("MASK_DECAL", 4)]);
    c
}

gpu_struct! {
    /// One layer on the GPU (`Layer` in `layers.wgsl`, which says what each
    /// field holds for each kind and mask).
    pub struct GpuLayer as "Layer" {
        pub kind: u32,
        pub mask: u32,
        pub mask_index: u32,
        pub mask_mode: u32,
        pub color_a: Vec4,
        pub color_b: Vec4,
        pub params: Vec4,
        pub mask_a: Vec4,
        pub mask_b: Vec4,
        pub mask_c: Vec4,
        /// Threshold, softness, invert (0 or 1), opacity.
        pub mask_shape: Vec4,
    }
}

impl GpuLayer {
    /// The GPU form of `layer` on `material`, whose textures are at
    /// `color_layer` (base colour and emissive: the colour array) and
    /// `linear_layer` (the others: the linear array) of the texture arrays.
    pub fn new(
        layer: &Layer,
        material: &Material,
        color_layer: impl Fn(usize) -> u32,
        linear_layer: impl Fn(usize) -> u32,
    ) -> Self {
        let mut g = GpuLayer {
            mask_shape: Vec4::new(0.5, 0.0, layer.invert as u32 as f32, layer.opacity),
            ..Default::default()
        };
        let c = |rgb: Vec3, a: f32| rgb.extend(a);
        match &layer.kind {
            LayerKind::Base { tint, metallic, roughness } => {
                g.kind = 0;
                g.color_a = c(*tint, 0.0);
                g.params = Vec4::new(metallic.unwrap_or(-1.0), roughness.unwrap_or(-1.0), 0.0, 0.0);
            }
            LayerKind::PaintedMetal { paint, paint_roughness, metal, metal_roughness, chips, chip_scale } => {
                g.kind = 1;
                g.color_a = c(*paint, *paint_roughness);
                g.color_b = c(*metal, *metal_roughness);
                g.params = Vec4::new(*chips, 1.0 / chip_scale, 3.0, 0.0);
            }
            LayerKind::BareMetal { color, roughness, scale } => {
                g.kind = 2;
                g.color_a = c(*color, *roughness);
                g.params = Vec4::new(1.0 / scale, 0.0, 0.0, 0.0);
            }
            LayerKind::Dirt { color, roughness, scale } => {
                g.kind = 3;
                g.color_a = c(*color, *roughness);
                g.params = Vec4::new(1.0 / scale, 0.0, 0.0, 0.0);
            }
            LayerKind::Snow { snow, snow_roughness, ice_color, ice_roughness, ice, bend } => {
                g.kind = 4;
                g.color_a = c(*snow, *snow_roughness);
                g.color_b = c(*ice_color, *ice_roughness);
                g.params = Vec4::new(*ice, *bend, 0.0, 0.0);
            }
            LayerKind::Emissive { emission, albedo_scale } => {
                g.kind = 5;
                g.color_a = c(*emission, 0.0);
                g.params = Vec4::new(*albedo_scale, 0.0, 0.0, 0.0);
            }
            LayerKind::Decal { color, roughness, metallic } => {
                g.kind = 6;
                g.color_a = c(*color, *roughness);
                g.params = Vec4::new(*metallic, 0.0, 0.0, 0.0);
            }
        }
        match &layer.mask {
            Mask::Full => g.mask = 0,
            Mask::Texture { texture, channel, scale, threshold, softness } => {
                g.mask = 1;
                // Validation ([`mod@file`]) refuses a texture the material
                // lacks; a layer built in code without one reads layer 0.
                g.mask_index = match (texture.of(material), texture.is_color()) {
                    (Some(t), true) => color_layer(t),
                    (Some(t), false) => linear_layer(t),
                    (None, _) => 0,
                };
                g.mask_mode = *channel as u32 + if texture.is_color() { 0 } else { 4 };
                g.mask_a.x = *scale;
                (g.mask_shape.x, g.mask_shape.y) = (*threshold, *softness);
            }
            Mask::Noise { scale, octaves, seed, threshold, softness } => {
                g.mask = 2;
                g.mask_index = *seed;
                g.mask_mode = *octaves;
                g.mask_a.x = 1.0 / scale;
                (g.mask_shape.x, g.mask_shape.y) = (*threshold, *softness);
            }
            Mask::SlopeHeight { axis, height, height_fade, slope, slope_fade } => {
                g.mask = 3;
                g.mask_a = axis.normalize().extend(0.0);
                g.mask_b = Vec4::new(height[0], height[1], *height_fade, 0.0);
                g.mask_c = Vec4::new(slope[0], slope[1], *slope_fade, 0.0);
            }
            Mask::Decal { center, direction, up, size, depth, round, softness } => {
                g.mask = 4;
                g.mask_mode = *round as u32;
                let rows = decal_rows(*center, *direction, *up, *size, *depth);
                (g.mask_a, g.mask_b, g.mask_c) = (rows[0], rows[1], rows[2]);
                g.mask_shape.y = *softness;
            }
        }
        g
    }
}

/// The rows of the affine map from world space into a decal projector's box
/// (-1..1 on each axis; +z along `direction`).
pub fn decal_rows(center: Vec3, direction: Vec3, up: Vec3, size: [f32; 2], depth: f32) -> [Vec4; 3] {
    let z = direction.normalize();
    let x = up.cross(z).try_normalize().unwrap_or_else(|| z.any_orthonormal_vector());
    let y = z.cross(x);
    let half = Vec3::new(size[0] * 0.5, size[1] * 0.5, depth);
    // World -> box: scale(1 / half) * rotation^T * translate(-center).
    let to_box = Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), center.extend(1.0)).inverse();
    let m = Mat4::from_scale(half.recip()) * to_box;
    [m.row(0), m.row(1), m.row(2)]
}

/// `--materials`: which layers the scene's materials get.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum MaterialsSpec {
    /// The materials as the scene defines them (no layers).
    #[default]
    None,
    /// The preset: every material with `K` layers ([`preset::layered`]).
    Layered(usize),
    /// The ground's bands as shaded layers by height and slope
    /// ([`preset::bands`]): what `--scene terrain` bakes into its albedo.
    Bands,
    /// A material file ([`mod@file`]).
    File(PathBuf),
}

impl std::str::FromStr for MaterialsSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s == "none" {
            return Ok(Self::None);
        }
        if s == "bands" {
            return Ok(Self::Bands);
        }
        if let Some(k) = s.strip_prefix("layered:") {
            let k: usize =
                k.parse().map_err(|_| format!("layered:{k}: expected a layer count from 1 to {MAX_LAYERS}"))?;
            if !(1..=MAX_LAYERS).contains(&k) {
                return Err(format!("layered:{k}: expected a layer count from 1 to {MAX_LAYERS}"));
            }
            return Ok(Self::Layered(k));
        }
        Ok(Self::File(PathBuf::from(s)))
    }
}

impl std::fmt::Display for MaterialsSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::None => write!(f, "none"),
            Self::Layered(k) => write!(f, "layered:{k}"),
            Self::Bands => write!(f, "bands"),
            Self::File(p) => write!(f, "{}", p.display()),
        }
    }
}

/// Gives the scene's materials the layers `spec` describes. A material
/// file's errors name the file and the field.
pub fn apply(scene: &mut Scene, spec: &MaterialsSpec) -> Result<(), file::MaterialsError> {
    match spec {
        MaterialsSpec::None => Ok(()),
        MaterialsSpec::Layered(k) => {
            preset::layered(scene, *k);
            Ok(())
        }
        MaterialsSpec::Bands => {
            preset::bands(scene);
            Ok(())
        }
        MaterialsSpec::File(path) => file::apply_file(scene, path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decal_rows_map_the_box_to_the_unit_cube() {
        let rows = decal_rows(Vec3::new(1.0, 2.0, 3.0), Vec3::NEG_Y, Vec3::Z, [2.0, 4.0], 0.5);
        let apply =
            |p: Vec3| Vec3::new(rows[0].dot(p.extend(1.0)), rows[1].dot(p.extend(1.0)), rows[2].dot(p.extend(1.0)));
        assert!(apply(Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5);
        // 0.5 m down (along the projection) is the box's far face.
        assert!((apply(Vec3::new(1.0, 1.5, 3.0)) - Vec3::Z).length() < 1e-5);
        // `up` (+z) is the footprint's y, 2 m to its edge.
        assert!((apply(Vec3::new(1.0, 2.0, 5.0)) - Vec3::Y).length() < 1e-5);
    }

    #[test]
    fn spec_parses_presets_and_files_and_refuses_bad_counts() {
        assert_eq!("layered:4".parse::<MaterialsSpec>(), Ok(MaterialsSpec::Layered(4)));
        assert_eq!("none".parse::<MaterialsSpec>(), Ok(MaterialsSpec::None));
        assert_eq!("a.json".parse::<MaterialsSpec>(), Ok(MaterialsSpec::File("a.json".into())));
        for bad in ["layered:0", "layered:17", "layered:x"] {
            assert!(bad.parse::<MaterialsSpec>().unwrap_err().contains("1 to 16"), "{bad}");
        }
    }
}
