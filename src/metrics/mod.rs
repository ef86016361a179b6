//! Image error between two renders: FLIP (NVIDIA's perceptual metric, through
//! `nv-flip`), PSNR and SSIM. Used by golden-image tests and pipeline comparisons.

pub mod breakdown;
pub mod ssim;
pub mod temporal;

use image::{RgbImage, RgbaImage};
use serde::Serialize;

/// How far a test image is from a reference image.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ImageError {
    /// Mean FLIP error in [0, 1] (0 = identical).
    pub flip_mean: f32,
    /// PSNR of the 8-bit RGB values in dB (infinite when identical).
    pub psnr_db: f64,
    /// Largest absolute difference of an 8-bit channel.
    pub max_abs: u8,
    /// Mean SSIM of the luma ([`ssim::ssim`]; 1 = identical).
    pub ssim: f64,
}

/// FLIP, PSNR and SSIM of `test` against `reference`, plus the FLIP error map as a
/// colour image (magma), for writing next to a failing test's output.
///
/// Panics if the sizes differ (callers compare renders of one size).
pub fn compare(reference: &RgbaImage, test: &RgbaImage) -> (ImageError, RgbImage) {
    let (error, values) = compare_values(reference, test);
    let (w, h) = reference.dimensions();
    let error_map = nv_flip::FlipImageFloat::with_data(w, h, &values);
    let visual = error_map.apply_color_lut(&nv_flip::magma_lut());
    let map = RgbImage::from_raw(w, h, visual.to_vec()).expect("FLIP map has w*h*3 bytes");
    (error, map)
}

/// [`compare`]'s errors and the FLIP value of each pixel, row-major (their
/// mean is `flip_mean`).
pub fn compare_values(reference: &RgbaImage, test: &RgbaImage) -> (ImageError, Vec<f32>) {
    assert_eq!(reference.dimensions(), test.dimensions(), "compared images must have the same size");
    let (w, h) = reference.dimensions();
    let rgb = |img: &RgbaImage| img.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect::<Vec<u8>>();
    let (a, b) = (rgb(reference), rgb(test));
    let error_map = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &a),
        nv_flip::FlipImageRgb8::with_data(w, h, &b),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let flip_mean = nv_flip::FlipPool::from_image(&error_map).mean();
    let mut sq = 0.0f64;
    let mut max_abs = 0u8;
    for (x, y) in a.iter().zip(&b) {
        let d = x.abs_diff(*y);
        max_abs = max_abs.max(d);
        sq += f64::from(d) * f64::from(d);
    }
    let mse = sq / a.len().max(1) as f64;
    let psnr_db = if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64 * 255.0 / mse).log10() };
    let error = ImageError { flip_mean, psnr_db, max_abs, ssim: ssim::ssim(reference, test) };
    (error, error_map.to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_no_error_and_different_ones_do() {
        let a = RgbaImage::from_fn(32, 32, |x, y| image::Rgba([(x * 8) as u8, (y * 8) as u8, 128, 255]));
        let (e, _) = compare(&a, &a);
        assert_eq!(e.flip_mean, 0.0);
        assert!(e.psnr_db.is_infinite());
        assert!((e.ssim - 1.0).abs() < 1e-12);
        let b = RgbaImage::from_fn(32, 32, |x, y| image::Rgba([(y * 8) as u8, (x * 8) as u8, 0, 255]));
        let (e, map) = compare(&a, &b);
        assert!(e.flip_mean > 0.1, "flip {}", e.flip_mean);
        assert!(e.psnr_db < 20.0);
        assert!(e.ssim < 0.9, "ssim {}", e.ssim);
        assert_eq!(map.dimensions(), (32, 32));
    }
}
