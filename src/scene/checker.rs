//! Generated albedo textures: a UV checker with a per-object tint, given to
//! objects that have no texture so that their UV layouts are visible.

use glam::Vec3;

use super::Texture;
use crate::color::linear_to_srgb8;

/// A distinct, deterministic tint for object `index` (hues spaced by the
/// golden angle, so neighbours in a file never get similar colours).
pub fn object_tint(index: usize) -> Vec3 {
    let hue = (index as f32 * 0.618_034).fract();
    let h = hue * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let rgb = match h as u32 {
        0 => Vec3::new(1.0, x, 0.0),
        1 => Vec3::new(x, 1.0, 0.0),
        2 => Vec3::new(0.0, 1.0, x),
        3 => Vec3::new(0.0, x, 1.0),
        4 => Vec3::new(x, 0.0, 1.0),
        _ => Vec3::new(1.0, 0.0, x),
    };
    // Desaturate so that lighting, not the tint, dominates the image.
    Vec3::splat(0.55).lerp(rgb, 0.45)
}

/// A `size` x `size` checker of `cells` x `cells` squares alternating between
/// `tint` and a darker `tint`, with thin grid lines every cell.
pub fn uv_checker(name: &str, tint: Vec3, size: u32, cells: u32) -> Texture {
    let cell = (size / cells.max(1)).max(1);
    // Three colours: encode each once, not per texel (sRGB encoding is a
    // `powf`; per texel it dominated loading an OBJ without materials).
    let [line, light, dark] = [0.35, 1.0, 0.7].map(|shade| {
        let c = tint * shade;
        [linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255]
    });
    // Three kinds of row: a grid line, and rows through cells starting
    // light or dark; the texture is rows of these.
    let row = |first: [u8; 4], second: [u8; 4]| -> Vec<u8> {
        (0..size)
            .flat_map(|x| match (x % cell == 0, (x / cell).is_multiple_of(2)) {
                (true, _) => line,
                (false, true) => first,
                (false, false) => second,
            })
            .collect()
    };
    let (line_row, even_row, odd_row) = (row(line, line), row(light, dark), row(dark, light));
    let mut rgba8 = Vec::with_capacity((size * size * 4) as usize);
    for y in 0..size {
        let r = if y % cell == 0 {
            &line_row
        } else if (y / cell).is_multiple_of(2) {
            &even_row
        } else {
            &odd_row
        };
        rgba8.extend_from_slice(r);
    }
    Texture { name: name.to_string(), width: size, height: size, rgba8 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_repeat_the_per_texel_pattern() {
        let tint = Vec3::new(0.9, 0.5, 0.2);
        let (size, cells) = (96, 6);
        let t = uv_checker("t", tint, size, cells);
        let cell = size / cells;
        for y in 0..size {
            for x in 0..size {
                let shade = if x % cell == 0 || y % cell == 0 {
                    0.35
                } else if (x / cell + y / cell) % 2 == 0 {
                    1.0
                } else {
                    0.7
                };
                let c = tint * shade;
                let want = [linear_to_srgb8(c.x), linear_to_srgb8(c.y), linear_to_srgb8(c.z), 255];
                let i = ((y * size + x) * 4) as usize;
                assert_eq!(t.rgba8[i..i + 4], want, "texel ({x}, {y})");
            }
        }
    }

    #[test]
    fn checker_alternates_and_tints_differ() {
        let t = uv_checker("t", Vec3::ONE, 64, 8);
        assert_eq!(t.rgba8.len(), 64 * 64 * 4);
        let px = |x: usize, y: usize| t.rgba8[(y * 64 + x) * 4];
        assert!(px(4, 4) > px(12, 4), "neighbouring cells must differ");
        assert_eq!(px(4, 4), px(12, 12), "diagonal cells must match");
        assert_ne!(object_tint(0), object_tint(1));
    }
}
