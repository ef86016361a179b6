//! Temporal stability along a moving camera: how much a pipeline's frames
//! flicker beyond what the scene's motion explains, and each frame's error
//! against its supersampled reference.
//!
//! Flicker of a frame pair (t-1, t): the mean over pixels and RGB channels
//! of |(P_t - P_{t-1}) - (R_t - R_{t-1})|, in 8-bit steps of the displayed
//! (tone-mapped, sRGB) values, where P are the pipeline's frames and R the
//! reference's. True motion changes both alike and cancels; a constant
//! error (a bias that moves with the image) cancels too; what is left is
//! change the reference does not have: crawling highlights, popping levels,
//! shimmering edges.

use image::RgbaImage;
use rayon::prelude::*;
use serde::Serialize;

use super::{ImageError, compare_values};

/// The flicker of one path.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Flicker {
    /// Per frame pair (t-1, t), t from 1: mean |change - reference change|
    /// per channel, in 8-bit steps.
    pub per_pair: Vec<f64>,
    /// Sum over the pairs.
    pub sum: f64,
    /// Mean over the pairs (0 for a path of one frame).
    pub mean: f64,
}

/// Mean over pixels and RGB channels of |(p - p_prev) - (r - r_prev)|, in
/// 8-bit steps. Panics if the sizes differ.
pub fn pair_flicker(p_prev: &RgbaImage, p: &RgbaImage, r_prev: &RgbaImage, r: &RgbaImage) -> f64 {
    let size = p.dimensions();
    for other in [p_prev, r_prev, r] {
        assert_eq!(other.dimensions(), size, "flicker compares frames of one size");
    }
    let mut sum = 0i64;
    let rgb = |img: &RgbaImage| img.pixels().flat_map(|q| [q[0], q[1], q[2]]).collect::<Vec<u8>>();
    let (a0, a1, b0, b1) = (rgb(p_prev), rgb(p), rgb(r_prev), rgb(r));
    for i in 0..a1.len() {
        let change = i64::from(a1[i]) - i64::from(a0[i]);
        let reference_change = i64::from(b1[i]) - i64::from(b0[i]);
        sum += (change - reference_change).abs();
    }
    sum as f64 / a1.len().max(1) as f64
}

/// The flicker of a pipeline's frames along a path against the reference's
/// frames of the same path. Panics if the paths differ in length.
pub fn flicker(pipeline: &[RgbaImage], reference: &[RgbaImage]) -> Flicker {
    assert_eq!(pipeline.len(), reference.len(), "one reference frame per pipeline frame");
    let per_pair: Vec<f64> = (1..pipeline.len())
        .map(|t| pair_flicker(&pipeline[t - 1], &pipeline[t], &reference[t - 1], &reference[t]))
        .collect();
    let sum: f64 = per_pair.iter().sum();
    let mean = if per_pair.is_empty() { 0.0 } else { sum / per_pair.len() as f64 };
    Flicker { per_pair, sum, mean }
}

/// A pipeline's quality along a path: each frame's error against its
/// reference, their means, and the flicker.
#[derive(Clone, Debug, Serialize)]
pub struct PathQuality {
    pub frames: Vec<ImageError>,
    pub flip_mean: f64,
    /// Mean of the frames' PSNR (dB); infinite when every frame is identical.
    pub psnr_db: f64,
    pub flicker: Flicker,
}

/// Errors and flicker of `pipeline`'s frames against `reference`'s.
pub fn path_quality(pipeline: &[RgbaImage], reference: &[RgbaImage]) -> PathQuality {
    path_quality_by(pipeline, reference, |_, _| ()).0
}

/// [`path_quality`], and `per_frame(t, FLIP map)` of each frame `t` (its
/// FLIP value per pixel, row-major), computed beside the frame's errors.
pub fn path_quality_by<T: Send>(
    pipeline: &[RgbaImage],
    reference: &[RgbaImage],
    per_frame: impl Fn(usize, &[f32]) -> T + Sync,
) -> (PathQuality, Vec<T>) {
    assert_eq!(pipeline.len(), reference.len(), "one reference frame per pipeline frame");
    // FLIP takes about a second a frame at 1920x1080 on one core: frames in parallel.
    let (frames, extra): (Vec<ImageError>, Vec<T>) = reference
        .par_iter()
        .zip(pipeline)
        .enumerate()
        .map(|(t, (r, p))| {
            let (error, map) = compare_values(r, p);
            (error, per_frame(t, &map))
        })
        .unzip();
    let n = frames.len().max(1) as f64;
    let quality = PathQuality {
        flip_mean: frames.iter().map(|e| f64::from(e.flip_mean)).sum::<f64>() / n,
        psnr_db: frames.iter().map(|e| e.psnr_db).sum::<f64>() / n,
        flicker: flicker(pipeline, reference),
        frames,
    };
    (quality, extra)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(v: u8) -> RgbaImage {
        RgbaImage::from_pixel(4, 4, image::Rgba([v, v, v, 255]))
    }

    /// A gradient that moves `shift` pixels to the right: a camera pan.
    fn moving(shift: u32, bias: u8) -> RgbaImage {
        RgbaImage::from_fn(4, 4, |x, y| {
            let v = ((x + shift) * 40 + y * 10) as u8 + bias;
            image::Rgba([v, v / 2, 255 - v, 255])
        })
    }

    #[test]
    fn a_static_pair_does_not_flicker() {
        assert_eq!(pair_flicker(&grey(80), &grey(80), &grey(100), &grey(100)), 0.0);
    }

    #[test]
    fn motion_the_reference_shares_is_not_flicker() {
        let reference: Vec<RgbaImage> = (0..4).map(|t| moving(t, 0)).collect();
        // Equal to the reference: no flicker and no error.
        let q = path_quality(&reference, &reference);
        assert_eq!(q.flicker, Flicker { per_pair: vec![0.0; 3], sum: 0.0, mean: 0.0 });
        assert_eq!(q.flip_mean, 0.0);
        assert!(q.psnr_db.is_infinite());
        // A constant error that moves with the image: wrong, but stable.
        let biased: Vec<RgbaImage> = (0..4).map(|t| moving(t, 3)).collect();
        let q = path_quality(&biased, &reference);
        assert_eq!(q.flicker.sum, 0.0);
        assert!(q.flip_mean > 0.0 && q.psnr_db.is_finite());
    }

    #[test]
    fn known_flicker_gives_its_value() {
        // The reference stands still; one channel of one of 16 pixels jumps
        // by 12 steps and back: each pair changes 12 of 48 channel steps.
        let reference = vec![grey(100); 3];
        let mut lit = grey(100);
        lit.put_pixel(0, 0, image::Rgba([112, 100, 100, 255]));
        let f = flicker(&[grey(100), lit, grey(100)], &reference);
        assert_eq!(f.per_pair, [0.25, 0.25]);
        assert_eq!((f.sum, f.mean), (0.5, 0.25));
        // A pipeline that stands still while the reference changes flickers
        // by as much (it misses the change), sign notwithstanding.
        let f = flicker(&[grey(100), grey(100)], &[grey(100), grey(104)]);
        assert_eq!(f.per_pair, [4.0]);
        assert_eq!(flicker(&[grey(7)], &[grey(9)]).mean, 0.0);
    }
}
