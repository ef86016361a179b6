//! SSIM (Wang, Bovik, Sheikh and Simoncelli 2004) of two 8-bit RGB images,
//! on their luma: an 11x11 Gaussian window (sigma 1.5) over the whole image
//! without padding, K1 = 0.01, K2 = 0.03, L = 255, the mean of the SSIM map
//! (the paper's reference implementation, as scikit-image's
//! `gaussian_weights=True, use_sample_covariance=False` computes it).

use image::RgbaImage;

const RADIUS: usize = 5;
const SIGMA: f64 = 1.5;
const C1: f64 = (0.01 * 255.0) * (0.01 * 255.0);
const C2: f64 = (0.03 * 255.0) * (0.03 * 255.0);

/// Rec. 601 luma of every pixel, row by row.
fn luma(image: &RgbaImage) -> Vec<f64> {
    image.pixels().map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])).collect()
}

/// Normalised Gaussian weights of a window of `2 * radius + 1` taps.
fn gaussian(radius: usize) -> Vec<f64> {
    let w: Vec<f64> =
        (0..=2 * radius).map(|i| (-((i as f64 - radius as f64).powi(2)) / (2.0 * SIGMA * SIGMA)).exp()).collect();
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| v / sum).collect()
}

/// `values` (w x h) filtered with the separable window `k`, keeping only
/// the positions where the window lies inside the image ("valid").
fn filter_valid(values: &[f64], w: usize, h: usize, k: &[f64]) -> Vec<f64> {
    let n = k.len();
    let (ow, oh) = (w + 1 - n, h + 1 - n);
    let mut rows = vec![0.0; ow * h];
    for y in 0..h {
        for x in 0..ow {
            rows[y * ow + x] = k.iter().enumerate().map(|(i, c)| c * values[y * w + x + i]).sum();
        }
    }
    let mut out = vec![0.0; ow * oh];
    for y in 0..oh {
        for x in 0..ow {
            out[y * ow + x] = k.iter().enumerate().map(|(i, c)| c * rows[(y + i) * ow + x]).sum();
        }
    }
    out
}

/// Mean SSIM of `test` against `reference` (1 = identical; it can fall
/// below 0 for anti-correlated images). Images smaller than the 11x11
/// window use the largest centred window that fits.
///
/// Panics if the sizes differ or an image is empty.
pub fn ssim(reference: &RgbaImage, test: &RgbaImage) -> f64 {
    assert_eq!(reference.dimensions(), test.dimensions(), "compared images must have the same size");
    let (w, h) = (reference.width() as usize, reference.height() as usize);
    assert!(w > 0 && h > 0, "SSIM of an empty image");
    let radius = RADIUS.min((w.min(h) - 1) / 2);
    let k = gaussian(radius);
    let (x, y) = (luma(reference), luma(test));
    let product = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).collect::<Vec<f64>>();
    let filter = |v: &[f64]| filter_valid(v, w, h, &k);
    let (mx, my) = (filter(&x), filter(&y));
    let (xx, yy, xy) = (filter(&product(&x, &x)), filter(&product(&y, &y)), filter(&product(&x, &y)));
    let mut sum = 0.0;
    for i in 0..mx.len() {
        let (a, b) = (mx[i], my[i]);
        let (vx, vy, cov) = (xx[i] - a * a, yy[i] - b * b, xy[i] - a * b);
        sum += ((2.0 * a * b + C1) * (2.0 * cov + C2)) / ((a * a + b * b + C1) * (vx + vy + C2));
    }
    sum / mx.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(w: u32, h: u32, f: impl Fn(u32, u32) -> u8) -> RgbaImage {
        RgbaImage::from_fn(w, h, |x, y| {
            let v = f(x, y);
            image::Rgba([v, v, v, 255])
        })
    }

    #[test]
    fn identical_images_score_one() {
        let a = grey(32, 24, |x, y| ((x * 7 + y * 13) % 256) as u8);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
    }

    /// Flat images have no variance: SSIM is the luminance term alone,
    /// (2ab + C1) / (a² + b² + C1).
    #[test]
    fn flat_images_score_their_luminance_term() {
        let (a, b) = (100.0f64, 150.0f64);
        let expected = (2.0 * a * b + C1) / (a * a + b * b + C1);
        let s = ssim(&grey(20, 20, |_, _| 100), &grey(20, 20, |_, _| 150));
        assert!((s - expected).abs() < 1e-9, "{s} != {expected}");
        // By hand: (30000 + 6.5025) / (32500 + 6.5025) = 0.9230923.
        assert!((s - 0.923_092_3).abs() < 1e-7, "{s}");
    }

    /// A 2-level stripe pattern against its negative: the means agree (127.5)
    /// and the covariance is minus the variance (127.5²), so SSIM is
    /// (-2σ² + C2) / (2σ² + C2) in every window, whatever its weights.
    #[test]
    fn an_inverted_pattern_scores_below_zero() {
        let a = grey(16, 16, |x, _| if x % 2 == 0 { 0 } else { 255 });
        let b = grey(16, 16, |x, _| if x % 2 == 0 { 255 } else { 0 });
        let s = ssim(&a, &b);
        // Each window's weights over the odd columns sum to p (not exactly
        // 1/2), so σ² = 255² p (1 - p): compute it from the window.
        let k = gaussian(RADIUS);
        let p: f64 = k.iter().skip(1).step_by(2).sum();
        let var = 255.0 * 255.0 * p * (1.0 - p);
        let mean = 255.0 * p;
        let l = (2.0 * mean * (255.0 - mean) + C1) / (mean * mean + (255.0 - mean).powi(2) + C1);
        let expected_even = l * (-2.0 * var + C2) / (2.0 * var + C2);
        // Windows starting on odd columns see the complementary weights:
        // the same variance, the means swapped, the same score.
        assert!((s - expected_even).abs() < 1e-9, "{s} != {expected_even}");
        assert!(s < -0.9);
    }

    #[test]
    fn small_images_use_a_smaller_window() {
        let a = grey(5, 4, |x, y| (x * 40 + y * 10) as u8);
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        assert!(ssim(&a, &grey(5, 4, |_, _| 0)) < 0.1);
    }
}
