//! `--materials FILE`: layers for a scene's materials from a JSON file
//! (schema in `docs/materials.md`). The file is read with `serde_json` and
//! every field is checked as it is taken, so that any error names the file
//! and the field's path (`materials[0].layers[1].mask.softness: ...`):
//! unknown fields, wrong types, values out of range, names of materials the
//! scene lacks, masks of textures a material lacks.

use std::path::Path;

use glam::Vec3;
use serde_json::{Map, Value};

use super::{Channel, Layer, LayerKind, MAX_LAYERS, Mask, MaskTexture};
use crate::scene::{Material, Scene};

/// A material file that cannot be applied: the file and what is wrong, the
/// field named by its path.
#[derive(Debug, thiserror::Error)]
#[error("--materials {file}: {message}")]
pub struct MaterialsError {
    pub file: String,
    pub message: String,
}

/// Reads the material file at `path` and gives the scene's materials its layers.
pub fn apply_file(scene: &mut Scene, path: &Path) -> Result<(), MaterialsError> {
    let error = |message: String| MaterialsError { file: path.display().to_string(), message };
    let text = std::fs::read_to_string(path).map_err(|e| error(format!("cannot read it: {e}")))?;
    apply_json(scene, &text).map_err(error)
}

/// [`apply_file`] on the file's text; errors name the field.
pub fn apply_json(scene: &mut Scene, text: &str) -> Result<(), String> {
    let root: Value = serde_json::from_str(text).map_err(|e| format!("not JSON: {e}"))?;
    let mut root = Fields::new(root, "the file")?;
    let entries = root.take("materials").ok_or("materials: missing (a list of {\"name\", \"layers\"})")?;
    root.finish()?;
    let Value::Array(entries) = entries else {
        return Err("materials: expected a list of {\"name\", \"layers\"}".into());
    };
    let mut assigned: Vec<Option<Vec<Layer>>> = vec![None; scene.materials.len()];
    let mut named = vec![false; scene.materials.len()];
    let mut default: Option<(String, Vec<Value>)> = None;
    for (i, entry) in entries.into_iter().enumerate() {
        let path = format!("materials[{i}]");
        let mut e = Fields::new(entry, &path)?;
        let name = e.string("name")?;
        let layers = match e.take("layers") {
            Some(Value::Array(l)) => l,
            _ => return Err(format!("{path}.layers: expected a list of layers")),
        };
        e.finish()?;
        if layers.is_empty() || layers.len() > MAX_LAYERS {
            return Err(format!("{path}.layers: {} layers, expected 1 to {MAX_LAYERS}", layers.len()));
        }
        if name == "*" {
            if default.is_some() {
                return Err(format!("{path}.name: a second \"*\""));
            }
            default = Some((path, layers));
            continue;
        }
        let Some(m) = scene.materials.iter().position(|m| m.name == name) else {
            let known: Vec<_> = scene.materials.iter().map(|m| m.name.as_str()).collect();
            return Err(format!("{path}.name: no material '{name}' in the scene (materials: {})", known.join(", ")));
        };
        if named[m] {
            return Err(format!("{path}.name: material '{name}' is named twice"));
        }
        named[m] = true;
        assigned[m] = Some(parse_layers(&layers, &path, &scene.materials[m])?);
    }
    if let Some((path, layers)) = default {
        for (m, slot) in assigned.iter_mut().enumerate() {
            if slot.is_none() {
                *slot = Some(parse_layers(&layers, &path, &scene.materials[m])?);
            }
        }
    }
    for (m, layers) in scene.materials.iter_mut().zip(assigned) {
        m.layers = layers.unwrap_or_default();
    }
    Ok(())
}

fn parse_layers(layers: &[Value], path: &str, material: &Material) -> Result<Vec<Layer>, String> {
    layers.iter().enumerate().map(|(j, l)| parse_layer(l.clone(), &format!("{path}.layers[{j}]"), material)).collect()
}

fn parse_layer(value: Value, path: &str, material: &Material) -> Result<Layer, String> {
    let mut f = Fields::new(value, path)?;
    let kind = f.string("kind")?;
    let kind = match kind.as_str() {
        "base" => LayerKind::Base {
            tint: f.rgb("tint", Vec3::ONE)?,
            metallic: f.optional_unit("metallic")?,
            roughness: f.optional_unit("roughness")?,
        },
        "painted_metal" => LayerKind::PaintedMetal {
            paint: f.rgb("paint", Vec3::new(0.6, 0.1, 0.08))?,
            paint_roughness: f.unit("paint_roughness", 0.45)?,
            metal: f.rgb("metal", Vec3::new(0.56, 0.57, 0.58))?,
            metal_roughness: f.unit("metal_roughness", 0.3)?,
            chips: f.unit("chips", 0.3)?,
            chip_scale: f.positive("chip_scale", 0.25)?,
        },
        "bare_metal" => LayerKind::BareMetal {
            color: f.rgb("color", Vec3::new(0.56, 0.57, 0.58))?,
            roughness: f.unit("roughness", 0.3)?,
            scale: f.positive("scale", 0.5)?,
        },
        "dirt" => LayerKind::Dirt {
            color: f.rgb("color", Vec3::new(0.25, 0.18, 0.12))?,
            roughness: f.unit("roughness", 0.9)?,
            scale: f.positive("scale", 0.3)?,
        },
        "snow" => LayerKind::Snow {
            snow: f.rgb("snow", Vec3::new(0.9, 0.92, 0.95))?,
            snow_roughness: f.unit("snow_roughness", 0.7)?,
            ice_color: f.rgb("ice_color", Vec3::new(0.6, 0.75, 0.85))?,
            ice_roughness: f.unit("ice_roughness", 0.1)?,
            ice: f.unit("ice", 0.0)?,
            bend: f.unit("bend", 0.5)?,
        },
        "emissive" => LayerKind::Emissive {
            emission: f.rgb("emission", Vec3::new(4.0, 2.0, 0.5))?,
            albedo_scale: f.unit("albedo_scale", 1.0)?,
        },
        "decal" => LayerKind::Decal {
            color: f.rgb("color", Vec3::new(0.8, 0.8, 0.1))?,
            roughness: f.unit("roughness", 0.5)?,
            metallic: f.unit("metallic", 0.0)?,
        },
        other => {
            return Err(format!(
                "{path}.kind: unknown kind '{other}' (expected base, painted_metal, bare_metal, dirt, snow, emissive, decal)"
            ));
        }
    };
    let mask = match f.take("mask") {
        None => Mask::Full,
        Some(m) => parse_mask(m, &format!("{path}.mask"), material)?,
    };
    let invert = f.bool("invert", false)?;
    let opacity = f.unit("opacity", 1.0)?;
    f.finish()?;
    Ok(Layer { kind, mask, invert, opacity })
}

fn parse_mask(value: Value, path: &str, material: &Material) -> Result<Mask, String> {
    let mut f = Fields::new(value, path)?;
    let kind = f.string("type")?;
    let mask = match kind.as_str() {
        "full" => Mask::Full,
        "texture" => {
            let name = f.string("texture")?;
            let Some(k) = MaskTexture::NAMES.iter().position(|n| *n == name) else {
                return Err(format!(
                    "{path}.texture: unknown texture '{name}' (expected {})",
                    MaskTexture::NAMES.join(", ")
                ));
            };
            let texture = [
                MaskTexture::BaseColor,
                MaskTexture::Normal,
                MaskTexture::MetallicRoughness,
                MaskTexture::Emissive,
                MaskTexture::Occlusion,
            ][k];
            if texture.of(material).is_none() {
                return Err(format!("{path}.texture: material '{}' has no {name} texture", material.name));
            }
            let channel = match f.string("channel")?.as_str() {
                "r" => Channel::R,
                "g" => Channel::G,
                "b" => Channel::B,
                "a" => Channel::A,
                other => return Err(format!("{path}.channel: '{other}' is not r, g, b or a")),
            };
            Mask::Texture {
                texture,
                channel,
                scale: f.positive("scale", 1.0)?,
                threshold: f.finite("threshold", 0.5)?,
                softness: f.non_negative("softness", 0.1)?,
            }
        }
        "noise" => Mask::Noise {
            scale: f.positive("scale", 1.0)?,
            octaves: f.count("octaves", 3, 1..=8)?,
            seed: f.count("seed", 0, 0..=u32::MAX)?,
            threshold: f.finite("threshold", 0.5)?,
            softness: f.non_negative("softness", 0.1)?,
        },
        "slope_height" => {
            let axis = f.vec3("axis", Vec3::Y)?;
            if axis.length() < 1e-6 {
                return Err(format!("{path}.axis: the zero vector has no direction"));
            }
            let height = f.range("height", [-1e30, 1e30])?;
            let height_fade = f.non_negative("height_fade", 0.0)?;
            let slope = f.range("slope", [-1.0, 1.0])?;
            let slope_fade = f.non_negative("slope_fade", 0.0)?;
            Mask::SlopeHeight { axis, height, height_fade, slope, slope_fade }
        }
        "decal" => {
            let center = f.vec3_required("center")?;
            let direction = f.vec3("direction", Vec3::NEG_Y)?;
            let up = f.vec3("up", Vec3::Z)?;
            if direction.length() < 1e-6 {
                return Err(format!("{path}.direction: the zero vector has no direction"));
            }
            if up.cross(direction).length() < 1e-6 * up.length() * direction.length() || up.length() < 1e-6 {
                return Err(format!("{path}.up: must not be parallel to direction"));
            }
            let size = f.numbers::<2>("size")?.unwrap_or([1.0, 1.0]);
            if size[0] <= 0.0 || size[1] <= 0.0 {
                return Err(format!("{path}.size: expected two positive lengths (width, height)"));
            }
            Mask::Decal {
                center,
                direction,
                up,
                size,
                depth: f.positive("depth", 0.5)?,
                round: f.bool("round", false)?,
                softness: f.unit("softness", 0.1)?,
            }
        }
        other => {
            return Err(format!(
                "{path}.type: unknown mask '{other}' (expected full, texture, noise, slope_height, decal)"
            ));
        }
    };
    f.finish()?;
    Ok(mask)
}

/// The fields of one JSON object, taken one by one and checked, each error
/// naming `path.field`; [`Fields::finish`] refuses the fields left over.
struct Fields {
    map: Map<String, Value>,
    path: String,
}

impl Fields {
    fn new(value: Value, path: &str) -> Result<Self, String> {
        match value {
            Value::Object(map) => Ok(Self { map, path: path.to_string() }),
            other => Err(format!("{path}: expected an object, found {other}")),
        }
    }

    fn at(&self, name: &str) -> String {
        format!("{}.{name}", self.path)
    }

    fn take(&mut self, name: &str) -> Option<Value> {
        self.map.remove(name)
    }

    fn string(&mut self, name: &str) -> Result<String, String> {
        match self.take(name) {
            Some(Value::String(s)) => Ok(s),
            Some(other) => Err(format!("{}: expected a string, found {other}", self.at(name))),
            None => Err(format!("{}: missing", self.at(name))),
        }
    }

    fn bool(&mut self, name: &str, default: bool) -> Result<bool, String> {
        match self.take(name) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(b),
            Some(other) => Err(format!("{}: expected true or false, found {other}", self.at(name))),
        }
    }

    /// A finite number (`default` when absent).
    fn finite(&mut self, name: &str, default: f32) -> Result<f32, String> {
        match self.take(name) {
            None => Ok(default),
            Some(v) => self.number(name, &v),
        }
    }

    fn number(&self, name: &str, v: &Value) -> Result<f32, String> {
        match v.as_f64() {
            Some(x) if (x as f32).is_finite() => Ok(x as f32),
            _ => Err(format!("{}: expected a finite number, found {v}", self.at(name))),
        }
    }

    fn checked(&mut self, name: &str, default: f32, ok: fn(f32) -> bool, what: &str) -> Result<f32, String> {
        let x = self.finite(name, default)?;
        if ok(x) { Ok(x) } else { Err(format!("{}: {x} is not {what}", self.at(name))) }
    }

    fn unit(&mut self, name: &str, default: f32) -> Result<f32, String> {
        self.checked(name, default, |x| (0.0..=1.0).contains(&x), "within 0 to 1")
    }

    fn optional_unit(&mut self, name: &str) -> Result<Option<f32>, String> {
        if self.map.contains_key(name) { self.unit(name, 0.0).map(Some) } else { Ok(None) }
    }

    fn positive(&mut self, name: &str, default: f32) -> Result<f32, String> {
        self.checked(name, default, |x| x > 0.0, "positive")
    }

    fn non_negative(&mut self, name: &str, default: f32) -> Result<f32, String> {
        self.checked(name, default, |x| x >= 0.0, "0 or more")
    }

    fn count(&mut self, name: &str, default: u32, range: std::ops::RangeInclusive<u32>) -> Result<u32, String> {
        match self.take(name) {
            None => Ok(default),
            Some(v) => match v.as_u64() {
                Some(n) if n <= u32::MAX as u64 && range.contains(&(n as u32)) => Ok(n as u32),
                _ => Err(format!(
                    "{}: expected a whole number from {} to {}, found {v}",
                    self.at(name),
                    range.start(),
                    range.end()
                )),
            },
        }
    }

    fn numbers<const N: usize>(&mut self, name: &str) -> Result<Option<[f32; N]>, String> {
        let Some(v) = self.take(name) else { return Ok(None) };
        let bad = || format!("{}: expected a list of {N} finite numbers, found {v}", self.at(name));
        let Value::Array(items) = &v else { return Err(bad()) };
        if items.len() != N {
            return Err(bad());
        }
        let mut out = [0.0; N];
        for (o, item) in out.iter_mut().zip(items) {
            *o = self.number(name, item).map_err(|_| bad())?;
        }
        Ok(Some(out))
    }

    fn vec3(&mut self, name: &str, default: Vec3) -> Result<Vec3, String> {
        Ok(self.numbers::<3>(name)?.map_or(default, Vec3::from))
    }

    fn vec3_required(&mut self, name: &str) -> Result<Vec3, String> {
        self.numbers::<3>(name)?.map(Vec3::from).ok_or_else(|| format!("{}: missing", self.at(name)))
    }

    /// A linear RGB colour, each channel 0 or more.
    fn rgb(&mut self, name: &str, default: Vec3) -> Result<Vec3, String> {
        let c = self.vec3(name, default)?;
        if c.min_element() < 0.0 {
            return Err(format!("{}: colour channels must be 0 or more", self.at(name)));
        }
        Ok(c)
    }

    /// Two numbers, low then high.
    fn range(&mut self, name: &str, default: [f32; 2]) -> Result<[f32; 2], String> {
        let r = self.numbers::<2>(name)?.unwrap_or(default);
        if r[0] > r[1] {
            return Err(format!("{}: low {} is above high {}", self.at(name), r[0], r[1]));
        }
        Ok(r)
    }

    fn finish(self) -> Result<(), String> {
        match self.map.keys().next() {
            None => Ok(()),
            Some(k) => Err(format!("{}.{k}: unknown field", self.path)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        let floor = Material { name: "floor".into(), ..Material::default() };
        let wall = Material { name: "wall".into(), base_color_texture: Some(0), ..Material::default() };
        Scene { materials: vec![floor, wall], ..Scene::default() }
    }

    #[test]
    fn layers_by_name_and_by_star() {
        let mut s = scene();
        let json = r#"{"materials": [
            {"name": "floor", "layers": [{"kind": "dirt", "mask": {"type": "noise", "scale": 2, "octaves": 4}}]},
            {"name": "*", "layers": [{"kind": "base"}, {"kind": "snow", "opacity": 0.5,
                "mask": {"type": "slope_height", "slope": [0.7, 1.0], "slope_fade": 0.1}}]}
        ]}"#;
        apply_json(&mut s, json).unwrap();
        assert_eq!(s.materials[0].layers.len(), 1);
        assert!(matches!(s.materials[0].layers[0].mask, Mask::Noise { octaves: 4, scale: 2.0, .. }));
        assert_eq!(s.materials[1].layers.len(), 2);
        assert_eq!(s.materials[1].layers[1].opacity, 0.5);
    }

    /// The example of `docs/materials.md` applies to any scene.
    #[test]
    fn the_documented_example_applies() {
        let mut s = scene();
        apply_json(&mut s, include_str!("../../docs/materials/example.json")).unwrap();
        assert!(s.materials.iter().all(|m| m.layers.len() == 5));
    }

    /// Every bad input names its field.
    #[test]
    fn bad_inputs_name_the_field() {
        let cases = [
            (
                r#"{"materials": [{"name": "flor", "layers": [{"kind": "base"}]}]}"#,
                "materials[0].name: no material 'flor'",
            ),
            (r#"{"materials": [{"name": "floor", "layers": [{"kind": "paint"}]}]}"#, "materials[0].layers[0].kind"),
            (
                r#"{"materials": [{"name": "floor", "layers": [{"kind": "dirt", "scale": -1}]}]}"#,
                "materials[0].layers[0].scale: -1 is not positive",
            ),
            (
                r#"{"materials": [{"name": "floor", "layers": [{"kind": "dirt", "colour": [1, 0, 0]}]}]}"#,
                "materials[0].layers[0].colour: unknown field",
            ),
            (
                r#"{"materials": [{"name": "floor", "layers": [{"kind": "base", "mask": {"type": "noise", "softness": "x"}}]}]}"#,
                "materials[0].layers[0].mask.softness: expected a finite number",
            ),
            (
                r#"{"materials": [{"name": "floor", "layers": [{"kind": "base", "mask": {"type": "texture", "texture": "base_color", "channel": "r"}}]}]}"#,
                "materials[0].layers[0].mask.texture: material 'floor' has no base_color texture",
            ),
            (r#"{"materials": [{"name": "floor", "layers": []}]}"#, "materials[0].layers: 0 layers"),
            (r#"{"material": []}"#, "materials: missing"),
        ];
        for (json, expected) in cases {
            let e = apply_json(&mut scene(), json).unwrap_err();
            assert!(e.contains(expected), "{json}\n-> {e}\n(expected {expected})");
        }
    }
}
