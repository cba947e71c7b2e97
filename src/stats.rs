//! Statistics over accumulated sample sums, for noise estimates and convergence studies.

use crate::abi::LUMINANCE;
use crate::output::Image;
use std::ops::Range;

/// Per-pixel sums of samples and of squared samples (f64), over `samples` samples per pixel
/// (or each pixel's own count, `counts`). `sum` and `sum_sq` hold `width * height` pixels,
/// row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulation {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel; with `counts`, the floor of their mean.
    pub samples: u64,
    /// Adaptive sampling, once the pilot chose the rounds (before, and in a
    /// uniform continuation, `None`: every pixel has `samples`): each pixel's own
    /// sample count, a multiple of the replicate count (each replicate holds a
    /// quarter), from sample index 0. Replicate 0
    /// decided the counts (`crate::render::adaptive`; `sum_sq` holds its squares alone), so
    /// the mean and its error come from the other replicates: unbiased.
    pub counts: Option<Vec<u32>>,
    pub sum: Vec<[f64; 3]>,
    pub sum_sq: Option<Vec<[f64; 3]>>,
    /// Under the Sobol sampler with variance on: the independent replicates' sums.
    pub replicates: Option<Replicates>,
}

/// The sums of a pixel's randomised-QMC replicates: replicate `r` holds the sample
/// indices `i` with `i mod K == r` (`K = samples.len()`), each replicate an
/// independently scrambled Sobol sequence, so the replicates' means are independent
/// estimates of the pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Replicates {
    /// Samples per pixel in each replicate.
    pub samples: Vec<u64>,
    /// Per replicate, per pixel (as `Accumulation::sum`).
    pub sums: Vec<Vec<[f64; 3]>>,
}

impl Replicates {
    /// How many of the sample indices `range` fall in each of `count` replicates.
    pub fn samples_in(range: Range<u64>, count: u32) -> Vec<u64> {
        let k = count as u64;
        // Indices below `end` that are `r` mod k.
        let below = |end: u64, r: u64| if end > r { (end - r - 1) / k + 1 } else { 0 };
        (0..k)
            .map(|r| below(range.end, r) - below(range.start, r))
            .collect()
    }

    /// Replicate 0's sums from the total's and the others' (the device keeps
    /// only replicates 1.., as replicate 0 is the rest of the total).
    pub fn from_others(
        range: Range<u64>,
        total: &[[f64; 3]],
        mut others: Vec<Vec<[f64; 3]>>,
    ) -> Replicates {
        let first = total
            .iter()
            .enumerate()
            .map(|(p, t)| {
                std::array::from_fn(|c| t[c] - others.iter().map(|o| o[p][c]).sum::<f64>())
            })
            .collect();
        others.insert(0, first);
        Replicates {
            samples: Replicates::samples_in(range, others.len() as u32),
            sums: others,
        }
    }

    /// Pixel `p`'s standard error of the mean, per channel, from the spread of the
    /// K replicate means: `SE² = Σ_r (m_r − m̄)² / (K (K − 1))`, with `m̄` their
    /// plain average (K − 1 degrees of freedom). Replicates that differ by one
    /// sample (a count that is not a multiple of K) are treated as equal. None
    /// unless every replicate has a sample. `per_replicate`: the pixel's own count in
    /// each replicate (adaptive sampling), instead of `samples`, and then replicate 0
    /// (the deciding one) is left out.
    fn standard_error(&self, p: usize, per_replicate: Option<u64>) -> Option<[f64; 3]> {
        let first = per_replicate.is_some() as usize;
        let k = (self.samples.len() - first) as f64;
        let count = |r: usize| per_replicate.unwrap_or(self.samples[r]);
        if k < 2.0 || (first..self.samples.len()).any(|r| count(r) == 0) {
            return None;
        }
        Some(std::array::from_fn(|c| {
            let means = || {
                (self.sums.iter().enumerate())
                    .skip(first)
                    .map(|(r, s)| s[p][c] / count(r) as f64)
            };
            let average = means().sum::<f64>() / k;
            let squares: f64 = means().map(|m| (m - average).powi(2)).sum();
            (squares / (k * (k - 1.0))).sqrt()
        }))
    }
}

impl Accumulation {
    /// How many sums (and sums of squares) are infinite or NaN: f32 sums that overflowed.
    pub fn non_finite_sums(&self) -> usize {
        let squares = self.sum_sq.iter().flatten();
        self.sum
            .iter()
            .chain(squares)
            .flatten()
            .filter(|v| !v.is_finite())
            .count()
    }

    /// Pixel `p`'s sample count.
    pub fn samples_at(&self, p: usize) -> u64 {
        self.counts.as_ref().map_or(self.samples, |c| c[p] as u64)
    }

    /// Pixel `p`'s mean: `sum / samples`, or under adaptive sampling the mean of
    /// replicates 1.. over the pixel's own count (see `counts`); 0 without samples.
    fn pixel_mean(&self, p: usize) -> [f64; 3] {
        match (&self.counts, &self.replicates) {
            (Some(counts), Some(replicates)) if counts[p] > 0 => {
                let k = replicates.sums.len();
                let n = counts[p] as f64 * (k - 1) as f64 / k as f64;
                std::array::from_fn(|c| {
                    replicates.sums[1..].iter().map(|s| s[p][c]).sum::<f64>() / n
                })
            }
            _ => match self.samples_at(p) {
                0 => [0.0; 3],
                n => self.sum[p].map(|s| s / n as f64),
            },
        }
    }

    /// The mean image (`pixel_mean`) as f32; black where a pixel has no samples.
    pub fn mean(&self) -> Image {
        let pixels = (0..self.sum.len())
            .map(|p| self.pixel_mean(p).map(|c| c as f32))
            .collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }

    /// Per-pixel, per-channel standard error of the mean. With replicates (the Sobol
    /// sampler), from the spread of their means ([`Replicates`]); otherwise
    /// `SE = sqrt(s² / n)`, with the unbiased sample variance
    /// `s² = (sum_sq - n·mean²) / (n - 1)` (clamped at 0 against rounding).
    /// None without either, or with fewer than 2 samples (a sample in each replicate).
    pub fn standard_error(&self) -> Option<Image> {
        let pixels = self
            .mean_and_standard_error()?
            .into_iter()
            .map(|(_, se)| se.map(|c| c as f32))
            .collect();
        Some(Image {
            width: self.width,
            height: self.height,
            pixels,
        })
    }

    /// Whether every sample so far was zero (black in every pixel).
    pub fn is_black(&self) -> bool {
        self.sum.iter().all(|s| *s == [0.0; 3])
    }

    /// The image's relative standard error, defined as
    ///
    /// `sqrt( (1/P) Σ_p Y(SE_p)² ) / ( (1/P) Σ_p Y(mean_p) )`
    ///
    /// over the P pixels, where `SE_p` is pixel p's per-channel standard error (as in
    /// [`standard_error`](Self::standard_error)), `mean_p` its mean and `Y` is [`luminance`].
    /// So: the RMS over pixels of the luminance of the per-channel standard errors, divided by
    /// the mean luminance of the mean image.
    ///
    /// `Y(SE_p)` is not the standard error of the pixel's luminance, which needs cross-channel
    /// covariances that the sums do not hold; with positive weights it is an upper bound on it.
    /// None without `sum_sq`, with fewer than 2 samples, or when the mean luminance is not
    /// positive (an all-black image).
    pub fn relative_error(&self) -> Option<f64> {
        let (mut error_sq, mut mean_y, mut pixels) = (0.0, 0.0, 0.0);
        for (mean, se) in self.mean_and_standard_error()? {
            error_sq += luminance_f64(se).powi(2);
            mean_y += luminance_f64(mean);
            pixels += 1.0;
        }
        // `> 0` also rejects NaN and the 0/0 of an empty image.
        (mean_y > 0.0).then(|| (error_sq / pixels).sqrt() / (mean_y / pixels))
    }

    /// Per pixel: the mean and the standard error of the mean, per channel, in f64.
    fn mean_and_standard_error(&self) -> Option<Vec<([f64; 3], [f64; 3])>> {
        let fewest = self.counts.as_ref().map_or(self.samples, |c| {
            c.iter().copied().min().unwrap_or(0) as u64
        });
        if fewest < 2 {
            return None;
        }
        let means = (0..self.sum.len()).map(|p| self.pixel_mean(p));
        if let Some(replicates) = &self.replicates {
            let k = replicates.samples.len() as u64;
            return means
                .enumerate()
                .map(|(p, mean)| {
                    let own = self.counts.as_ref().map(|c| c[p] as u64 / k);
                    Some((mean, replicates.standard_error(p, own)?))
                })
                .collect();
        }
        let sum_sq = self.sum_sq.as_ref()?;
        Some(
            means
                .zip(sum_sq)
                .enumerate()
                .map(|(p, (mean, sum_sq))| {
                    let n = self.samples_at(p) as f64;
                    let se = std::array::from_fn(|c| {
                        let variance = ((sum_sq[c] - n * mean[c] * mean[c]) / (n - 1.0)).max(0.0);
                        (variance / n).sqrt()
                    });
                    (mean, se)
                })
                .collect(),
        )
    }
}

/// Rec. 709 luminance (`abi::LUMINANCE`): `Y = 0.212671 R + 0.715160 G + 0.072169 B`.
pub fn luminance(rgb: [f32; 3]) -> f32 {
    luminance_f64(rgb.map(f64::from)) as f32
}

pub(crate) fn luminance_f64(rgb: [f64; 3]) -> f64 {
    rgb.iter().zip(LUMINANCE).map(|(c, w)| c * w as f64).sum()
}

/// Root-mean-square difference over all pixels and channels, in f64 (NaN for empty images).
///
/// # Panics
/// If the images differ in size.
pub fn rmse(a: &Image, b: &Image) -> f64 {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "rmse of images of different sizes"
    );
    let squared: f64 = a
        .pixels
        .iter()
        .flatten()
        .zip(b.pixels.iter().flatten())
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum();
    (squared / (3 * a.pixels.len()) as f64).sqrt()
}

/// `rmse(image, reference)` divided by [`mean_value`] of `reference`; None if that mean is 0
/// (or NaN, as for an empty image).
///
/// # Panics
/// If the images differ in size.
pub fn relative_rmse(image: &Image, reference: &Image) -> Option<f64> {
    let mean = mean_value(reference);
    if mean == 0.0 || mean.is_nan() {
        return None;
    }
    Some(rmse(image, reference) / mean)
}

/// What [`relative_mse`] adds to each squared reference value: dark pixels'
/// errors count as if they were about 0.1 bright, not without bound.
pub const RELATIVE_MSE_FLOOR: f64 = 0.01;

/// The relative mean squared error, mean((x − r)² / (r² + 0.01)) over all
/// pixels and channels, in f64: each pixel's error relative to its brightness,
/// so an emitter's own pixels do not decide it (the relMSE of papers, and of
/// docs/benchmarks.md).
///
/// # Panics
/// If the images differ in size.
pub fn relative_mse(image: &Image, reference: &Image) -> f64 {
    assert_eq!(
        (image.width, image.height),
        (reference.width, reference.height),
        "relative_mse of images of different sizes"
    );
    let sum: f64 = (image.pixels.iter().flatten())
        .zip(reference.pixels.iter().flatten())
        .map(|(&x, &r)| {
            let (x, r) = (f64::from(x), f64::from(r));
            (x - r).powi(2) / (r * r + RELATIVE_MSE_FLOOR)
        })
        .sum();
    sum / (3 * image.pixels.len()) as f64
}

/// Mean over all pixels and channels, in f64 (NaN for an empty image).
pub fn mean_value(image: &Image) -> f64 {
    let sum: f64 = image.pixels.iter().flatten().map(|&v| f64::from(v)).sum();
    sum / (3 * image.pixels.len()) as f64
}

/// Least-squares slope of `ln y` against `ln x`, e.g. the convergence rate of error against
/// sample count. Points with a non-finite or non-positive coordinate are skipped. None with
/// fewer than 2 points left, or when they all share one x.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if logs.len() < 2 {
        return None;
    }
    let count = logs.len() as f64;
    let mean_x = logs.iter().map(|p| p.0).sum::<f64>() / count;
    let mean_y = logs.iter().map(|p| p.1).sum::<f64>() / count;
    // Centred sums avoid the cancellation of the textbook Σxy - n·x̄ȳ form.
    let sxx: f64 = logs.iter().map(|(x, _)| (x - mean_x).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|(x, y)| (x - mean_x) * (y - mean_y)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Accumulates `samples[k]` (one RGB value per pixel) the way the renderer's sums do.
    fn accumulate(width: u32, height: u32, samples: &[Vec<[f64; 3]>]) -> Accumulation {
        let pixels = (width * height) as usize;
        let mut sum = vec![[0.0; 3]; pixels];
        let mut sum_sq = vec![[0.0; 3]; pixels];
        for frame in samples {
            for (p, rgb) in frame.iter().enumerate() {
                for c in 0..3 {
                    sum[p][c] += rgb[c];
                    sum_sq[p][c] += rgb[c] * rgb[c];
                }
            }
        }
        Accumulation {
            width,
            height,
            samples: samples.len() as u64,
            counts: None,
            sum,
            sum_sq: Some(sum_sq),
            replicates: None,
        }
    }

    fn assert_close(actual: f64, expected: f64) {
        assert!(
            (actual - expected).abs() <= 1e-12 * expected.abs().max(1.0),
            "{actual} != {expected}"
        );
    }

    #[test]
    fn known_variance_case() {
        // R alternates 0, 2; G is constant; B is 1, 2, 3, 4.
        let samples: Vec<Vec<[f64; 3]>> = [
            [0.0, 5.0, 1.0],
            [2.0, 5.0, 2.0],
            [0.0, 5.0, 3.0],
            [2.0, 5.0, 4.0],
        ]
        .iter()
        .map(|s| vec![*s])
        .collect();
        let accumulation = accumulate(1, 1, &samples);
        assert_eq!(accumulation.mean().pixels, vec![[1.0, 5.0, 2.5]]);
        // R: Σx² = 8, s² = (8 - 4·1²) / 3 = 4/3, SE = sqrt(4/3 / 4) = sqrt(1/3).
        // G: s² = 0.  B: Σx² = 30, s² = (30 - 4·2.5²) / 3 = 5/3, SE = sqrt(5/12).
        let se = accumulation.standard_error().unwrap();
        assert_eq!((se.width, se.height), (1, 1));
        assert_eq!(
            se.pixels,
            vec![[
                (1.0f64 / 3.0).sqrt() as f32,
                0.0,
                (5.0f64 / 12.0).sqrt() as f32
            ]]
        );
    }

    #[test]
    fn standard_error_of_two_samples() {
        // With n = 2, s² = (a - b)² / 2 and SE = |a - b| / 2; pixel 1 is (0.5, 1, 4) ± (0.5, 0, 1).
        let samples = vec![
            vec![[1.0, 2.0, 3.0], [0.0, 1.0, 3.0]],
            vec![[1.0, 2.0, 3.0], [1.0, 1.0, 5.0]],
        ];
        let accumulation = accumulate(2, 1, &samples);
        assert_eq!(
            accumulation.mean().pixels,
            vec![[1.0, 2.0, 3.0], [0.5, 1.0, 4.0]]
        );
        assert_eq!(
            accumulation.standard_error().unwrap().pixels,
            vec![[0.0; 3], [0.5, 0.0, 1.0]]
        );
    }

    #[test]
    fn standard_error_needs_squares_and_two_samples() {
        let mut accumulation = accumulate(1, 1, &[vec![[1.0; 3]]]);
        assert_eq!(accumulation.standard_error(), None);
        assert_eq!(accumulation.relative_error(), None);
        accumulation = accumulate(1, 1, &[vec![[1.0; 3]], vec![[3.0; 3]]]);
        assert!(accumulation.standard_error().is_some());
        accumulation.sum_sq = None;
        assert_eq!(accumulation.standard_error(), None);
        assert_eq!(accumulation.relative_error(), None);
    }

    #[test]
    fn mean_without_samples_is_black() {
        let accumulation = Accumulation {
            width: 2,
            height: 1,
            samples: 0,
            counts: None,
            sum: vec![[0.0; 3]; 2],
            sum_sq: None,
            replicates: None,
        };
        assert_eq!(accumulation.mean(), Image::new(2, 1));
    }

    #[test]
    fn relative_error_by_hand() {
        // n = 2. Pixel A: samples 0.75 and 1.25 in every channel → mean 1, SE 0.25 each.
        // Pixel B: R samples 2 and 4 (SE 1), G and B samples 3 and 3 (SE 0) → mean 3.
        let accumulation = Accumulation {
            width: 2,
            height: 1,
            samples: 2,
            counts: None,
            sum: vec![[2.0; 3], [6.0; 3]],
            sum_sq: Some(vec![[0.5625 + 1.5625; 3], [4.0 + 16.0, 18.0, 18.0]]),
            replicates: None,
        };
        // With the weights' sum w (1 in decimal, not quite in f32): Y(SE) of A is 0.25 w,
        // of B the red weight; the mean luminance (1 + 3) w / 2 = 2 w.
        let weights = LUMINANCE.map(f64::from);
        let w = weights.iter().sum::<f64>();
        let expected = (((0.25 * w).powi(2) + weights[0].powi(2)) / 2.0).sqrt() / (2.0 * w);
        assert_close(accumulation.relative_error().unwrap(), expected);
    }

    #[test]
    fn replicate_counts_of_sample_ranges() {
        assert_eq!(Replicates::samples_in(0..8, 4), [2, 2, 2, 2]);
        assert_eq!(Replicates::samples_in(0..6, 4), [2, 2, 1, 1]);
        assert_eq!(Replicates::samples_in(3..10, 4), [2, 2, 1, 2]);
        assert_eq!(Replicates::samples_in(5..5, 4), [0, 0, 0, 0]);
        assert_eq!(Replicates::samples_in(2..3, 4), [0, 0, 1, 0]);
    }

    #[test]
    fn replicate_standard_error_by_hand() {
        // Four replicates of 2 samples each (sample i in replicate i mod 4). Pixel A:
        // replicate means 1, 2, 3, 4 in R, all 5 in G, 0, 0, 0, 4 in B. SE² =
        // Σ (m_r − m̄)² / (4 · 3): R (2.25 + 0.25 + 0.25 + 2.25) / 12 = 5/12,
        // G 0, B (1 + 1 + 1 + 9) / 12 = 1.
        let means = [
            [1.0, 5.0, 0.0],
            [2.0, 5.0, 0.0],
            [3.0, 5.0, 0.0],
            [4.0, 5.0, 4.0],
        ];
        // Each replicate's two samples: its mean ± 0.5, so the sample variance differs.
        let samples: Vec<Vec<[f64; 3]>> = (0..8)
            .map(|i| vec![means[i % 4].map(|m| m + if i < 4 { 0.5 } else { -0.5 })])
            .collect();
        let mut accumulation = accumulate(1, 1, &samples);
        let others = (1..4).map(|r| vec![means[r].map(|m| 2.0 * m)]).collect();
        accumulation.replicates = Some(Replicates::from_others(0..8, &accumulation.sum, others));
        let replicates = accumulation.replicates.as_ref().unwrap();
        assert_eq!(replicates.samples, [2, 2, 2, 2]);
        assert_eq!(replicates.sums[0], [[2.0, 10.0, 0.0]]);
        let se = accumulation.standard_error().unwrap().pixels[0];
        let expected = [(5.0f64 / 12.0).sqrt() as f32, 0.0, 1.0];
        for c in 0..3 {
            assert!((se[c] - expected[c]).abs() < 1e-6, "{se:?}");
        }
        // A replicate without samples: no estimate.
        accumulation.replicates.as_mut().unwrap().samples[3] = 0;
        assert_eq!(accumulation.standard_error(), None);
        assert_eq!(accumulation.relative_error(), None);
    }

    #[test]
    fn relative_error_of_black_image_is_none() {
        let accumulation = accumulate(1, 1, &[vec![[0.0; 3]], vec![[0.0; 3]]]);
        assert_eq!(accumulation.relative_error(), None);
    }

    #[test]
    fn luminance_weights() {
        assert_eq!(luminance([1.0, 0.0, 0.0]), 0.212671);
        assert_eq!(luminance([0.0, 1.0, 0.0]), 0.715160);
        assert_eq!(luminance([0.0, 0.0, 1.0]), 0.072169);
        assert_eq!(luminance([2.0, 2.0, 2.0]), 2.0);
    }

    fn image(pixels: Vec<[f32; 3]>) -> Image {
        Image {
            width: pixels.len() as u32,
            height: 1,
            pixels,
        }
    }

    #[test]
    fn rmse_of_identical_and_offset_images() {
        // Binary fractions, so adding the offset in f32 is exact.
        let a = image(vec![[0.125, 0.25, 0.75], [1.0, 2.0, 3.0]]);
        assert_eq!(rmse(&a, &a), 0.0);
        let shifted = image(a.pixels.iter().map(|p| p.map(|v| v + 0.5)).collect());
        assert_close(rmse(&a, &shifted), 0.5);
        // One channel of six off by 3: sqrt(9 / 6).
        let mut one_off = a.clone();
        one_off.pixels[1][2] += 3.0;
        assert_close(rmse(&a, &one_off), 1.5f64.sqrt());
    }

    #[test]
    #[should_panic(expected = "different sizes")]
    fn rmse_panics_on_size_mismatch() {
        rmse(&Image::new(2, 1), &Image::new(1, 2));
    }

    /// `image` with `by` added to every value.
    fn offset(image: &Image, by: f32) -> Image {
        Image {
            width: image.width,
            height: image.height,
            pixels: image.pixels.iter().map(|p| p.map(|v| v + by)).collect(),
        }
    }

    #[test]
    fn relative_rmse_divides_by_reference_mean() {
        let reference = image(vec![[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]);
        let shifted = offset(&reference, 0.5);
        assert_close(mean_value(&reference), 2.0);
        assert_close(relative_rmse(&shifted, &reference).unwrap(), 0.25);
        assert_eq!(relative_rmse(&shifted, &Image::new(2, 1)), None);
    }

    #[test]
    fn relative_mse_weighs_each_value_by_its_brightness() {
        let reference = image(vec![[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]);
        let shifted = offset(&reference, 0.5);
        let lit = 0.25 / 1.01 + 0.25 / 4.01 + 0.25 / 9.01;
        // A black reference value counts the error over the floor alone: 0.25 / 0.01.
        assert_close(relative_mse(&shifted, &reference), (lit + 3.0 * 25.0) / 6.0);
        assert_eq!(relative_mse(&reference, &reference), 0.0);
    }

    #[test]
    fn log_log_slope_of_power_law() {
        let points: Vec<(f64, f64)> = (0..12)
            .map(|k| 2f64.powi(k))
            .map(|x| (x, 3.0 * x.powf(-0.5)))
            .collect();
        let slope = log_log_slope(&points).unwrap();
        assert!((slope + 0.5).abs() < 1e-12, "{slope}");
    }

    #[test]
    fn log_log_slope_skips_unusable_points() {
        let mut points = vec![
            (0.0, 1.0),
            (-1.0, 2.0),
            (4.0, 0.0),
            (f64::NAN, 1.0),
            (f64::INFINITY, 1.0),
        ];
        assert_eq!(log_log_slope(&points), None);
        points.push((1.0, 5.0));
        assert_eq!(log_log_slope(&points), None);
        points.push((100.0, 5.0 * 100f64.powi(2)));
        assert_close(log_log_slope(&points).unwrap(), 2.0);
        assert_eq!(log_log_slope(&[(2.0, 1.0), (2.0, 3.0)]), None);
    }
}
