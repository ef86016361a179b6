//! Error and flicker split by pixel class: each frame's pixels are
//! labelled with one class of a partition (for example MSAA edge or
//! interior), and the per-pixel FLIP, squared error and flicker
//! ([`super::temporal`]) are summed per class, so that the classes' sums
//! add up to the image's (a class's share of the error says where the error
//! is).

use image::RgbaImage;
use serde::{Deserialize, Serialize};

/// One class's sums over a path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ClassSums {
    /// Pixels in the class, summed over the frames.
    pub pixels: u64,
    /// Sum of their FLIP values (the frame's mean FLIP is the sum over the
    /// classes over the frame's pixels).
    pub flip: f64,
    /// Sum over their RGB channels of the squared 8-bit difference from the
    /// reference.
    pub squared: f64,
    /// Pixels in the class in the later frame of a frame pair, summed over the pairs.
    pub pair_pixels: u64,
    /// Sum over them and their RGB channels of |change - reference change|
    /// (8-bit steps), as [`super::temporal::pair_flicker`] sums it.
    pub flicker: f64,
}

impl ClassSums {
    fn add(&mut self, o: &ClassSums) {
        self.pixels += o.pixels;
        self.flip += o.flip;
        self.squared += o.squared;
        self.pair_pixels += o.pair_pixels;
        self.flicker += o.flicker;
    }
}

/// Why pixel labels cannot be summed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LabelError {
    #[error("{labels} labels for an image of {pixels} pixels")]
    Count { labels: usize, pixels: usize },
    #[error("pixel {pixel} has class {class}; the partition has {classes}")]
    OutOfRange { pixel: usize, class: u8, classes: usize },
}

/// Checks that `labels` gives each of `pixels` pixels one of `classes` classes.
pub fn check_labels(labels: &[u8], pixels: usize, classes: usize) -> Result<(), LabelError> {
    if labels.len() != pixels {
        return Err(LabelError::Count { labels: labels.len(), pixels });
    }
    match labels.iter().position(|&c| usize::from(c) >= classes) {
        Some(pixel) => Err(LabelError::OutOfRange { pixel, class: labels[pixel], classes }),
        None => Ok(()),
    }
}

/// Per class of `labels` (one per pixel, row-major): pixels, FLIP (`flip`,
/// the frame's per-pixel FLIP map) and squared error of `test` against `reference`.
pub fn frame_sums(
    labels: &[u8],
    classes: usize,
    reference: &RgbaImage,
    test: &RgbaImage,
    flip: &[f32],
) -> Result<Vec<ClassSums>, LabelError> {
    let pixels = (reference.width() * reference.height()) as usize;
    check_labels(labels, pixels, classes)?;
    assert_eq!(reference.dimensions(), test.dimensions(), "compared images must have the same size");
    assert_eq!(flip.len(), pixels, "one FLIP value per pixel");
    let mut sums = vec![ClassSums::default(); classes];
    for (i, (r, t)) in reference.pixels().zip(test.pixels()).enumerate() {
        let s = &mut sums[usize::from(labels[i])];
        s.pixels += 1;
        s.flip += f64::from(flip[i]);
        s.squared += (0..3).map(|c| f64::from(r[c].abs_diff(t[c])).powi(2)).sum::<f64>();
    }
    Ok(sums)
}

/// Per class of `labels` (the later frame's): the flicker of the frame
/// pair (`p_prev`, `p`) against the reference's (`r_prev`, `r`).
pub fn pair_sums(
    labels: &[u8],
    classes: usize,
    (p_prev, p): (&RgbaImage, &RgbaImage),
    (r_prev, r): (&RgbaImage, &RgbaImage),
) -> Result<Vec<ClassSums>, LabelError> {
    let pixels = (p.width() * p.height()) as usize;
    check_labels(labels, pixels, classes)?;
    for other in [p_prev, r_prev, r] {
        assert_eq!(other.dimensions(), p.dimensions(), "flicker compares frames of one size");
    }
    let mut sums = vec![ClassSums::default(); classes];
    let frames = p_prev.pixels().zip(p.pixels()).zip(r_prev.pixels().zip(r.pixels()));
    for (i, ((a0, a1), (b0, b1))) in frames.enumerate() {
        let s = &mut sums[usize::from(labels[i])];
        s.pair_pixels += 1;
        s.flicker += (0..3)
            .map(|c| {
                let change = i32::from(a1[c]) - i32::from(a0[c]);
                let reference_change = i32::from(b1[c]) - i32::from(b0[c]);
                f64::from((change - reference_change).abs())
            })
            .sum::<f64>();
    }
    Ok(sums)
}

/// `into[k] += add[k]` for every class.
pub fn accumulate(into: &mut [ClassSums], add: &[ClassSums]) {
    assert_eq!(into.len(), add.len(), "sums of one partition");
    for (a, b) in into.iter_mut().zip(add) {
        a.add(b);
    }
}

/// The sums of all classes together.
pub fn total(sums: &[ClassSums]) -> ClassSums {
    let mut t = ClassSums::default();
    for s in sums {
        t.add(s);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::temporal::{flicker, path_quality_by};

    fn image(seed: u32) -> RgbaImage {
        RgbaImage::from_fn(24, 16, |x, y| {
            let v = (x * 37 + y * 11 + seed * 53) % 251;
            image::Rgba([v as u8, (v * 3 % 256) as u8, (255 - v) as u8, 255])
        })
    }

    /// Three classes by position, a pattern no class boundary of the images follows.
    fn labels(w: u32, h: u32) -> Vec<u8> {
        (0..w * h).map(|i| ((i % w) * 3 / w + i / w % 2) as u8 % 3).collect()
    }

    /// The classes hold every pixel once, and their FLIP, squared error and
    /// flicker add up to the path's mean FLIP, PSNR and flicker.
    #[test]
    fn class_sums_add_up_to_the_path_totals() {
        let reference: Vec<RgbaImage> = (0..3).map(image).collect();
        let test: Vec<RgbaImage> = (0..3).map(|t| image(t + 7)).collect();
        let (w, h) = reference[0].dimensions();
        let n = (w * h) as usize;
        let l = labels(w, h);
        let (q, per_frame) =
            path_quality_by(&test, &reference, |t, map| frame_sums(&l, 3, &reference[t], &test[t], map).unwrap());
        let mut sums = vec![ClassSums::default(); 3];
        for f in &per_frame {
            accumulate(&mut sums, f);
        }
        for t in 1..3 {
            let pair = pair_sums(&l, 3, (&test[t - 1], &test[t]), (&reference[t - 1], &reference[t])).unwrap();
            accumulate(&mut sums, &pair);
        }
        assert!(sums.iter().all(|s| s.pixels > 0), "every class holds pixels: {sums:?}");
        let all = total(&sums);
        assert_eq!(all.pixels, 3 * n as u64);
        assert_eq!(all.pair_pixels, 2 * n as u64);
        let flip = all.flip / all.pixels as f64;
        assert!((flip - q.flip_mean).abs() < 1e-5 * q.flip_mean, "{flip} against {}", q.flip_mean);
        // PSNR per frame from each frame's squared error.
        let psnr: f64 = per_frame
            .iter()
            .map(|f| 10.0 * (255.0f64 * 255.0 / (total(f).squared / (3 * n) as f64)).log10())
            .sum::<f64>()
            / 3.0;
        assert!((psnr - q.psnr_db).abs() < 1e-9, "{psnr} against {}", q.psnr_db);
        let f = flicker(&test, &reference);
        assert!((all.flicker / (3 * all.pair_pixels) as f64 - f.mean).abs() < 1e-12);
    }

    /// A labelling that leaves a pixel out or names a class the partition
    /// lacks is refused, not summed into a wrong total.
    #[test]
    fn labels_that_do_not_partition_the_image_are_refused() {
        let (a, b) = (image(0), image(1));
        let l = labels(24, 16);
        let flip = vec![0.5; l.len()];
        assert_eq!(
            frame_sums(&l[1..], 3, &a, &b, &flip).unwrap_err(),
            LabelError::Count { labels: l.len() - 1, pixels: l.len() }
        );
        let mut bad = l.clone();
        bad[30] = 3;
        assert_eq!(
            frame_sums(&bad, 3, &a, &b, &flip).unwrap_err(),
            LabelError::OutOfRange { pixel: 30, class: 3, classes: 3 }
        );
        assert!(pair_sums(&bad, 3, (&a, &b), (&a, &b)).is_err());
        assert!(frame_sums(&bad, 4, &a, &b, &flip).is_ok());
    }
}
