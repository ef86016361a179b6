//! Procedural detailed textures (`--textures detailed`): a high-frequency
//! albedo and a matching tangent-space normal map for every material, so
//! that what object-space shading does to texture detail (blur where a
//! shading texel covers more than a pixel, normal-map detail lost between
//! texels) can be seen and measured on the generated scenes, whose own
//! checker textures are too smooth to show it.
//!
//! Both textures tile (every noise lattice wraps at the texture's edge), as
//! the scenes' world-scaled `uv0` repeats them.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::{Scene, Texture};
use crate::color::{linear_to_srgb8, srgb8_to_linear};
use crate::hash::fnv1a;
use crate::memo::Memo;

/// Side of the generated textures.
pub const DETAIL_SIZE: u32 = 512;

/// Bricks per texture repeat (columns, rows): a strong pattern at the scale
/// object space shades, with mortar lines two texels wide.
const BRICKS: (u32, u32) = (4, 8);

/// Gives every material of `scene` a detailed albedo (its old base colour
/// texture's mean colour, modulated by stone-like grain and bricks) and the
/// normal map of the same relief. Alpha-masked and alpha-blended materials
/// keep their base colour texture, whose alpha is their shape or opacity,
/// and get the normal map only.
/// Textures the materials no longer use stay in the list (their indices are
/// unchanged).
pub fn add_detailed_textures(scene: &mut Scene) {
    let relief = Relief::remembered(DETAIL_SIZE);
    let normal = scene.textures.len();
    scene.textures.push(relief.normal_map("detail normal map"));
    let mut albedos: Vec<(Option<usize>, usize)> = Vec::new();
    for m in &mut scene.materials {
        m.normal_texture = Some(normal);
        if m.alpha_cutoff.is_some() || m.blend {
            continue;
        }
        let source = m.base_color_texture;
        let index = match albedos.iter().find(|(s, _)| *s == source) {
            Some(&(_, index)) => index,
            None => {
                let tint = source.map_or(Vec3::ONE, |t| mean_linear(&scene.textures[t]));
                let index = scene.textures.len();
                scene.textures.push(relief.albedo(&format!("detail albedo {index}"), tint));
                albedos.push((source, index));
                index
            }
        };
        m.base_color_texture = Some(index);
    }
}

/// The relief of [`add_detailed_textures`] at `size` texels: one albedo per
/// `(name, linear tint)` and its normal map (named `normal_name`), for
/// generated scenes that want brick facades and paving of their own.
pub(crate) fn brick_textures(size: u32, tints: &[(&str, Vec3)], normal_name: &str) -> (Vec<Texture>, Texture) {
    let relief = Relief::remembered(size);
    let albedos = tints.iter().map(|(name, tint)| relief.albedo(name, *tint)).collect();
    (albedos, relief.normal_map(normal_name))
}

/// The mean linear colour of an sRGB texture.
fn mean_linear(t: &Texture) -> Vec3 {
    let decode = srgb8_to_linear;
    let n = (t.rgba8.len() / 4).max(1) as f32;
    let sum =
        t.rgba8.chunks_exact(4).fold(Vec3::ZERO, |acc, p| acc + Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])));
    sum / n
}

/// A tileable height field (bricks with bevelled mortar, plus grain) and
/// the brightness variation that goes with it.
struct Relief {
    size: u32,
    height: Vec<f32>,
    shade: Vec<f32>,
}

/// Reliefs remembered at most: one per size the scenes use.
static RELIEFS: Memo<Relief> = Memo::new(8, |_| 1);

impl Relief {
    /// The relief of `size` texels, made once a process ([`crate::memo`]):
    /// every load of a scene with detailed textures asks for it.
    fn remembered(size: u32) -> Arc<Self> {
        RELIEFS.get(size.into(), || Self::new(size))
    }

    fn new(size: u32) -> Self {
        let n = (size * size) as usize;
        let (mut height, mut shade) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for y in 0..size {
            for x in 0..size {
                let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / size as f32;
                let (mortar, brick) = bricks(p, size);
                // Grain down to 4 texels (128 cells over 512 texels).
                let grain = fbm(p, &[8, 16, 32, 64, 128], 7);
                let stain = fbm(p, &[4, 8], 11);
                height.push(0.6 * mortar + 0.25 * grain);
                let brick_tone = 0.8 + 0.2 * unit_hash(brick);
                shade.push((0.35 + 0.65 * mortar) * brick_tone * (0.55 + 0.45 * grain) * (0.8 + 0.2 * stain));
            }
        }
        Self { size, height, shade }
    }

    fn albedo(&self, name: &str, tint: Vec3) -> Texture {
        let rgba8 = self
            .shade
            .iter()
            .flat_map(|&s| {
                let c = (tint * s).clamp(Vec3::ZERO, Vec3::ONE);
                [linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255]
            })
            .collect();
        Texture { name: name.to_string(), width: self.size, height: self.size, rgba8 }
    }

    /// Tangent-space normals of the height field (x along +u, y along +v,
    /// central differences with wrap-around), encoded as `n * 0.5 + 0.5`.
    fn normal_map(&self, name: &str) -> Texture {
        let s = self.size as i64;
        let h = |x: i64, y: i64| self.height[(y.rem_euclid(s) * s + x.rem_euclid(s)) as usize];
        // Relief depth in texels per unit of height: steep enough that the
        // mortar and grain read clearly under grazing lights.
        let strength = 6.0;
        let mut rgba8 = Vec::with_capacity((s * s * 4) as usize);
        for y in 0..s {
            for x in 0..s {
                let du = (h(x + 1, y) - h(x - 1, y)) * 0.5 * strength;
                let dv = (h(x, y + 1) - h(x, y - 1)) * 0.5 * strength;
                let n = Vec3::new(-du, -dv, 1.0).normalize();
                let e = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
                rgba8.extend_from_slice(&[e(n.x), e(n.y), e(n.z), 255]);
            }
        }
        Texture { name: name.to_string(), width: self.size, height: self.size, rgba8 }
    }
}

/// Mortar profile at `p` (0 in the joint, rising to 1 over a bevel) and the
/// brick's id. Rows are offset by half a brick.
fn bricks(p: Vec2, size: u32) -> (f32, u64) {
    let (cols, rows) = (BRICKS.0 as f32, BRICKS.1 as f32);
    let row = (p.y * rows).floor();
    let shift = if row as i64 % 2 == 0 { 0.0 } else { 0.5 };
    let q = Vec2::new(p.x * cols + shift, p.y * rows);
    let cell = q.floor();
    let f = q - cell;
    // Distance to the nearest joint, in texels.
    let texels = Vec2::new(size as f32 / cols, size as f32 / rows);
    let d = (f.min(Vec2::ONE - f) * texels).min_element();
    let mortar = ((d - 1.0) / 3.0).clamp(0.0, 1.0);
    let id = (cell.x.rem_euclid(cols) as u64) | ((cell.y.rem_euclid(rows) as u64) << 16);
    (mortar, id)
}

/// Fractal sum of periodic value noise at `cells` lattice cells per repeat
/// (each octave half the weight of the previous), in [0, 1].
fn fbm(p: Vec2, cells: &[u32], seed: u64) -> f32 {
    let (mut sum, mut weight, mut total) = (0.0, 1.0, 0.0);
    for &c in cells {
        sum += weight * periodic_noise(p * c as f32, c, seed);
        total += weight;
        weight *= 0.6;
    }
    sum / total
}

/// Value noise with a lattice that wraps every `period` cells.
fn periodic_noise(p: Vec2, period: u32, seed: u64) -> f32 {
    let lattice = |x: i64, y: i64| {
        let (x, y) = (x.rem_euclid(period as i64) as u64, y.rem_euclid(period as i64) as u64);
        unit_hash(x | (y << 20) | ((period as u64) << 40) | (seed << 52))
    };
    let (fx, fy) = (p.x.floor(), p.y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let smooth = |t: f32| t * t * (3.0 - 2.0 * t);
    let (tx, ty) = (smooth(p.x - fx), smooth(p.y - fy));
    let a = lattice(ix, iy) + (lattice(ix + 1, iy) - lattice(ix, iy)) * tx;
    let b = lattice(ix, iy + 1) + (lattice(ix + 1, iy + 1) - lattice(ix, iy + 1)) * tx;
    a + (b - a) * ty
}

/// A deterministic value in [0, 1) for `key`.
fn unit_hash(key: u64) -> f32 {
    (fnv1a(&key.to_le_bytes()) >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn textures_tile_and_the_normal_map_follows_the_relief() {
        let r = Relief::new(128);
        let n = r.normal_map("n");
        let px = |t: &Texture, x: u32, y: u32| {
            let i = ((y * t.width + x) * 4) as usize;
            [t.rgba8[i], t.rgba8[i + 1], t.rgba8[i + 2]]
        };
        // Flat relief points up (z near 1); a vertical joint tilts x.
        let decode = |c: [u8; 3]| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 127.5 - Vec3::ONE;
        let all: Vec<Vec3> =
            (0..128).flat_map(|y| (0..128).map(move |x| (x, y))).map(|(x, y)| decode(px(&n, x, y))).collect();
        assert!(all.iter().all(|v| (v.length() - 1.0).abs() < 0.02), "normals must be unit vectors");
        assert!(all.iter().any(|v| v.x.abs() > 0.3), "the relief must tilt some normals");
        // Tiling: the noise lattice wraps at the edge.
        let a = periodic_noise(Vec2::new(0.0, 3.25), 8, 1);
        let b = periodic_noise(Vec2::new(8.0, 3.25), 8, 1);
        assert!((a - b).abs() < 1e-6);
    }

    #[test]
    fn every_material_gets_detail_with_its_old_tint() {
        let mut scene = crate::scene::load("atrium").unwrap();
        let masked = scene.materials[1].base_color_texture;
        scene.materials[1].alpha_cutoff = Some(0.5);
        let before = scene.textures.len();
        add_detailed_textures(&mut scene);
        assert!(scene.materials.iter().all(|m| m.normal_texture == Some(before)));
        let opaque = scene.materials.iter().filter(|m| m.alpha_cutoff.is_none());
        assert!(opaque.clone().count() > 1 && opaque.clone().all(|m| m.base_color_texture.is_some_and(|t| t > before)));
        assert_eq!(scene.materials[1].base_color_texture, masked, "a masked material keeps its shape");
        let t = &scene.textures[scene.materials[0].base_color_texture.unwrap()];
        assert_eq!((t.width, t.height), (DETAIL_SIZE, DETAIL_SIZE));
    }
}
