//! Colour encoding shared by texture loading, generated textures and debug
//! read-backs (the GPU tone mapper has its WGSL twin in `tonemap.wgsl`).

/// A linear value in [0, 1] as an sRGB-encoded byte (values outside are
/// clamped; NaN and infinities give 0).
pub fn linear_to_srgb8(linear: f32) -> u8 {
    let l = if linear.is_finite() { linear.clamp(0.0, 1.0) } else { 0.0 };
    let s = if l <= 0.003_130_8 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// An sRGB-encoded byte as a linear value in [0, 1].
pub fn srgb8_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Reinhard tone mapping of a linear HDR value, then sRGB: what the tone
/// mapping pass does at exposure 1.
pub fn reinhard_srgb8(hdr: f32) -> u8 {
    let v = if hdr.is_finite() { hdr.max(0.0) } else { 0.0 };
    linear_to_srgb8(v / (1.0 + v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_reference_points() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        // 18 % grey encodes to 46 % (117.96 -> 118 of 255).
        assert_eq!(linear_to_srgb8(0.18), 118);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(7.0), 255);
        for c in [0u8, 10, 118, 200, 255] {
            assert_eq!(linear_to_srgb8(srgb8_to_linear(c)), c, "round trip of {c}");
        }
        assert_eq!(reinhard_srgb8(1.0), linear_to_srgb8(0.5));
    }
}
