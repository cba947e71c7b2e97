//! Adaptive sampling's rule: after a pilot, which pixels the next round samples
//! and how many samples each gets. Plain data in, plain data out: the renderer
//! reads the sums back at each round's start and hands them here.
//!
//! The image's error is the sum of the pixels' `c_p σ_p² / n_p`, with `c_p` what
//! the metric makes of a pixel's squared error ([`AdaptiveMetric`]): by default
//! relative to its brightness, `c_p = 1 / (μ_p² + (RELATIVE_FLOOR · μ̄)²)`, the
//! error a person sees (an error of 0.1 on a pixel of 10 is not one on a pixel of
//! 0.1); `c_p = 1` for the absolute squared error. For a given total of samples it
//! is least with `n_p ∝ sqrt(c_p) σ_p`, the pixel's *spread* (each sample goes
//! where it lowers the error most: the pixel's priority `c_p σ_p² / n_p²`, the
//! error one more sample removes). Each round samples the pixels whose priority
//! is at least the image's mean priority, all by the same number of samples, so
//! that every pixel of a round continues from where it is and one dispatch covers
//! them all. Uniform sampling (`n_p` equal) is the special case of equal spreads.
//!
//! The rounds read only replicate 0 (sample indices `0 mod 4`, an independently
//! scrambled sequence: its sums and, in an adaptive kernel, the squares), and the
//! image is the mean of replicates 1 to 3, which are independent of replicate 0:
//! each pixel's count is independent of the samples averaged, and the mean of a
//! fixed number of them is unbiased. (Deciding from all samples instead, the
//! Cornell boxes' image came out 2.6% dark, 13 standard errors: pixels whose early
//! samples missed the light stop early.) The price: a quarter of the samples only
//! decides. So after the pilot, `choose` predicts whether the rounds gain that
//! back; where not (evenly spread error), the run goes on uniformly and its image
//! is the mean of every sample.

use crate::abi::REPLICATES;
pub use crate::scene::AdaptiveMetric;
use crate::stats::{Accumulation, luminance_f64};

/// Samples per pixel of the first round (every pixel), before anything is decided.
pub const PILOT_SAMPLES: u32 = 16;

/// A pixel's count is capped at this many times the run's samples per pixel.
pub const MAX_SAMPLES_FACTOR: u32 = 16;

/// A pixel's standard deviation counts as at least this fraction of the image's
/// mean luminance: a pixel whose pilot missed a rare bright path (zero spread)
/// still gets samples, in proportion to the floor.
pub const SPREAD_FLOOR: f64 = 0.1;

/// Under the relative metric, a pixel's brightness counts as at least about this
/// fraction of the image's mean luminance: the error of black pixels (a shadow,
/// the background) matters, but not infinitely.
pub const RELATIVE_FLOOR: f64 = 0.1;

/// The next round: the pixels it samples (indices, ascending) and the samples
/// each gets, a multiple of `REPLICATES` so every replicate keeps its share.
#[derive(Clone, Debug, PartialEq)]
pub struct Round {
    pub pixels: Vec<u32>,
    pub samples: u32,
}

/// The most samples a pixel may take in a run of `samples_per_pixel` (the
/// uniform run's count): `MAX_SAMPLES_FACTOR` times it, in whole replicate sets.
pub fn pixel_cap(samples_per_pixel: u32) -> u32 {
    let cap = samples_per_pixel.saturating_mul(MAX_SAMPLES_FACTOR);
    (cap - cap % REPLICATES).max(REPLICATES)
}

/// Rounds a count up to whole replicate sets.
fn whole_sets(n: u64) -> u64 {
    n.div_ceil(REPLICATES as u64) * REPLICATES as u64
}

/// The round after the sums of `accumulation` (with its per-pixel `counts`,
/// `sum_sq` needed), lowering the error `metric` measures, for pixels of at most `cap` samples, tracing at most about
/// `budget` samples in all (over by less than `REPLICATES`). `None` when no pixel
/// can take more (all at the cap, or no budget left).
pub fn next_round(
    accumulation: &Accumulation,
    counts: &[u32],
    metric: AdaptiveMetric,
    cap: u32,
    budget: u64,
) -> Option<Round> {
    let sets = REPLICATES as u64;
    if budget == 0 {
        return None;
    }
    let pixels = counts.len() as u64;
    let priorities = priorities(accumulation, counts, metric);
    // The mean over the pixels that can take samples: one capped pixel of huge
    // priority (an emitter's edge) would otherwise leave every other one below it.
    let open: Vec<usize> = (0..pixels as usize).filter(|&p| counts[p] < cap).collect();
    let mean = open.iter().map(|&p| priorities[p]).sum::<f64>() / open.len().max(1) as f64;
    // Equal priorities must not all fall below their mean by its rounding.
    let threshold = mean * (1.0 - 1e-9);
    let mut active: Vec<u32> = (open.into_iter())
        .filter(|&p| priorities[p] >= threshold)
        .map(|p| p as u32)
        .collect();
    if active.is_empty() {
        return None;
    }
    // Half again the least sampled active pixel's count, and at least a quarter
    // of the samples traced so far in all (each round's readback and decision
    // then cost little beside its work; rounds of a few pixels were mostly
    // overhead), at most what lifts one to the cap.
    let least = active.iter().map(|&p| counts[p as usize]).min().unwrap() as u64;
    let headroom = active
        .iter()
        .map(|&p| cap - counts[p as usize])
        .min()
        .unwrap() as u64;
    let traced: u64 = counts.iter().map(|&n| n as u64).sum();
    let by_work = (traced / 4).div_ceil(active.len() as u64);
    let mut samples = whole_sets((least / 2).max(by_work).max(sets)).min(whole_sets(headroom));
    let affordable = budget / samples;
    if (active.len() as u64) > affordable {
        // The budget's last round: the highest priorities first, one set each.
        samples = sets;
        let keep = budget.div_ceil(sets).clamp(1, active.len() as u64) as usize;
        active.sort_by(|&a, &b| {
            let (qa, qb) = (priorities[a as usize], priorities[b as usize]);
            qb.total_cmp(&qa).then(a.cmp(&b))
        });
        active.truncate(keep);
        active.sort_unstable();
    }
    Some(Round {
        pixels: active,
        samples: samples as u32,
    })
}

/// The round of a run that goes on uniformly (`Choice::uniform`), or of the pilot
/// (`cap` at most `PILOT_SAMPLES`), `counts` all equal: every pixel, to the budget
/// in whole replicate sets (over by less than `REPLICATES` per pixel) or to the
/// cap. `None` when neither leaves room.
pub fn uniform_round(counts: &[u32], cap: u32, budget: u64) -> Option<Round> {
    let pixels = counts.len() as u64;
    let headroom = cap.saturating_sub(counts.iter().copied().max()?) as u64;
    let samples =
        whole_sets(budget.div_ceil(pixels.max(1))).min(headroom - headroom % REPLICATES as u64);
    (samples > 0).then(|| Round {
        pixels: (0..pixels as u32).collect(),
        samples: samples as u32,
    })
}

/// Each pixel's priority `(spread / n_p)²`, with its spread from `spreads` and
/// `n_p` its count.
fn priorities(accumulation: &Accumulation, counts: &[u32], metric: AdaptiveMetric) -> Vec<f64> {
    (spreads(accumulation, counts, metric).iter().zip(counts))
        .map(|(&spread, &n)| spread * spread / (n as f64 * n as f64))
        .collect()
}

/// Each pixel's mean from replicate 0 alone (its samples decide).
fn deciding_means(accumulation: &Accumulation, counts: &[u32]) -> Vec<[f64; 3]> {
    let replicates = (accumulation.replicates.as_ref()).expect("adaptive sampling has replicates");
    let k = replicates.sums.len() as u32;
    (replicates.sums[0].iter().zip(counts))
        .map(|(s, &n)| s.map(|c| c / (n / k).max(1) as f64))
        .collect()
}

/// Each pixel's `sqrt(c_p)` (the module's doc), from the deciding means. A
/// pixel's brightness `μ_p` is the mean luminance of it and its 8 neighbours: its
/// own few samples make a noisy brightness, and dividing by that sent the samples
/// to pixels whose samples happened to be dark (on the book's Cornell box the
/// rounds then lost 1.3x in relMSE where the pilot predicted a 2x gain).
fn metric_scales(means: &[[f64; 3]], width: usize, metric: AdaptiveMetric) -> Vec<f64> {
    match metric {
        AdaptiveMetric::Absolute => vec![1.0; means.len()],
        AdaptiveMetric::Relative => {
            let floor_sq = (RELATIVE_FLOOR * image_mean(means)).powi(2);
            let luminance: Vec<f64> = means.iter().map(|&m| luminance_f64(m)).collect();
            let height = means.len() / width;
            (0..means.len())
                .map(|p| {
                    let (sum, count) = neighbourhood(p, width, height)
                        .fold((0.0, 0.0), |(sum, count), q| {
                            (sum + luminance[q], count + 1.0)
                        });
                    let brightness = sum / count;
                    let scale = 1.0 / (brightness.powi(2) + floor_sq).sqrt();
                    // A black image (no floor): every pixel alike.
                    if scale.is_finite() { scale } else { 1.0 }
                })
                .collect()
        }
    }
}

/// Pixel `p` and its (up to 8) neighbours in an image `width` by `height`.
fn neighbourhood(p: usize, width: usize, height: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (p % width, p / width);
    (y.saturating_sub(1)..(y + 2).min(height)).flat_map(move |ny| {
        (x.saturating_sub(1)..(x + 2).min(width)).map(move |nx| ny * width + nx)
    })
}

fn image_mean(means: &[[f64; 3]]) -> f64 {
    let sum = means.iter().map(|&m| luminance_f64(m)).sum::<f64>();
    (sum / means.len() as f64).max(0.0)
}

/// What the rounds allocate by, per pixel: the largest spread of the pixel and its
/// 8 neighbours, a pixel's own spread being the luminance of its per-channel
/// sample standard deviations, floored at `SPREAD_FLOOR` of the image's mean
/// luminance, times its metric's scale (`metric_scales`); all from replicate 0
/// alone (its sums and the squares). Infinite (sampled first) with fewer than 2
/// samples in replicate 0. The neighbours' maximum guards against a pixel whose
/// few replicate-0 samples all missed a rare bright path its neighbours found (a
/// caustic, a small light's glossy reflection): starved, such pixels dominated
/// the image's error.
fn spreads(accumulation: &Accumulation, counts: &[u32], metric: AdaptiveMetric) -> Vec<f64> {
    let squares = (accumulation.sum_sq.as_ref()).expect("adaptive sampling sums squares");
    let replicates = (accumulation.replicates.as_ref()).expect("adaptive sampling has replicates");
    let k = replicates.sums.len() as u32;
    let means = deciding_means(accumulation, counts);
    let floor = SPREAD_FLOOR * image_mean(&means);
    let scales = metric_scales(&means, accumulation.width as usize, metric);
    let own: Vec<f64> = (means.iter().zip(squares).zip(counts).zip(&scales))
        .map(|(((mean, squares), &n), &scale)| {
            let m = (n / k) as f64;
            if m < 2.0 {
                return f64::INFINITY;
            }
            let deviation = std::array::from_fn(|c| {
                ((squares[c] - m * mean[c] * mean[c]) / (m - 1.0))
                    .max(0.0)
                    .sqrt()
            });
            // NaN (overflowed sums) counts as most urgent; the run refuses such sums anyway.
            let spread = luminance_f64(deviation).max(floor) * scale;
            if spread.is_nan() {
                f64::INFINITY
            } else {
                spread
            }
        })
        .collect();
    let (width, height) = (accumulation.width as usize, accumulation.height as usize);
    (0..own.len())
        .map(|p| {
            neighbourhood(p, width, height)
                .map(|q| own[q])
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Adaptive sampling pays off only where the error is uneven: its image is the
/// mean of 3 of the 4 replicates, and the rounds cost readbacks and dispatches.
/// Below this predicted RMSE ratio (adaptive over uniform, at equal time,
/// `choose`) the run goes on adaptively; at or above it, uniformly. Chosen by
/// measurement (docs/benchmarks.md, "Adaptive sampling").
pub const ADAPTIVE_BELOW_RATIO: f64 = 0.5;

/// The rounds' paths/s relative to a uniform run's (readbacks, decisions, the
/// list dispatch, rounds of few pixels), measured on small images (docs/benchmarks.md).
pub const ROUNDS_THROUGHPUT: f64 = 0.8;

/// The pilot's verdict: whether the rest of the run is adaptive, or uniform over
/// every pixel with the image the mean of all replicates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// The predicted RMSE of the adaptive run over the uniform run's, at equal time.
    pub predicted_ratio: f64,
    pub uniform: bool,
}

/// The choice after the pilot (`counts` all equal). Each pixel's squared error
/// is predicted as `e_p² · pilot / samples averaged`, with `e_p` the standard
/// error of its pilot mean from the spread of all K replicates (the true error
/// under Sobol: a pixel's sample variance overstates it, by far at edges, which
/// stratification resolves) and the samples averaged: uniform `N` (all
/// replicates), adaptive `3/4 · n_p` with `n_p ∝ s_p`, the deciding spread
/// (`spreads`, as the rounds steer), `N` on average, in `1 / ROUNDS_THROUGHPUT`
/// the time. `N` and the pilot cancel:
///
/// `ratio² = (Σ e_p² / s_p) (Σ s_p) / (3/4 · P · Σ e_p²) / ROUNDS_THROUGHPUT`,
///
/// the errors scaled by the metric as the spreads are (`metric_scales`).
///
/// Uniform where the prediction fails: no error seen, or a pilot of fewer than 2
/// samples per replicate (no spreads).
///
/// One decision for the whole image, from the pilot of every replicate, so
/// neither continuation's image is unbiased by construction any more; but it is
/// one bit from sums over every pixel, in each of which a pixel's samples weigh
/// about `1 / P`: docs/rendering.md argues the bias negligible, tests/adaptive.rs measures it.
pub fn choose(accumulation: &Accumulation, counts: &[u32], metric: AdaptiveMetric) -> Choice {
    let spreads = spreads(accumulation, counts, metric);
    let scales = metric_scales(
        &deciding_means(accumulation, counts),
        accumulation.width as usize,
        metric,
    );
    let replicates = (accumulation.replicates.as_ref()).expect("adaptive sampling has replicates");
    let k = replicates.sums.len() as f64;
    let (mut weighted, mut total_spread, mut total_error) = (0.0, 0.0, 0.0);
    for (p, &spread) in spreads.iter().enumerate() {
        // The spread of the replicates' means: with `m` samples each, `sqrt(m)`
        // times it is the pixel's per-sample spread as Monte Carlo would see it,
        // at most the true one (stratification only lowers the replicates' spread).
        let per_replicate = (counts[p] as f64 / k).max(1.0);
        let replicate_spread = scales[p]
            * luminance_f64(std::array::from_fn(|c| {
                let means = || replicates.sums.iter().map(|s| s[p][c] / per_replicate);
                let average = means().sum::<f64>() / k;
                let variance = means().map(|m| (m - average).powi(2)).sum::<f64>() / (k - 1.0);
                variance.sqrt()
            }));
        // The pilot mean's squared standard error, up to a factor common to all pixels.
        let error_sq = replicate_spread.powi(2);
        // The rounds re-estimate the spreads as samples come in: a bright path that
        // replicate 0's pilot missed and the others found is found again.
        let spread = spread.max(replicate_spread * per_replicate.sqrt());
        weighted += error_sq / spread;
        total_spread += spread;
        total_error += error_sq;
    }
    let pixels = counts.len() as f64;
    let ratio_sq =
        weighted * total_spread / ((k - 1.0) / k * pixels * total_error) / ROUNDS_THROUGHPUT;
    let predicted_ratio = match ratio_sq.is_finite() {
        true => ratio_sq.sqrt(),
        false => f64::INFINITY,
    };
    Choice {
        predicted_ratio,
        // Never NaN: a failed prediction is infinite.
        uniform: predicted_ratio >= ADAPTIVE_BELOW_RATIO,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abi::LUMINANCE;
    use crate::stats::Replicates;

    /// Sums for pixels of `counts` samples each, whose samples in replicate 0 (a
    /// quarter) are `mean ± deviation` alternately (grey), so its sample standard
    /// deviation is about `deviation`. The other replicates are far off: they must
    /// not matter.
    fn accumulation(pixels: &[(u32, f64, f64)]) -> (Accumulation, Vec<u32>) {
        let counts: Vec<u32> = pixels.iter().map(|p| p.0).collect();
        let quarter = |n: u32| (n / REPLICATES) as f64;
        let deciding: Vec<[f64; 3]> = (pixels.iter())
            .map(|&(n, m, _)| [m * quarter(n); 3])
            .collect();
        let others = vec![vec![[1e6; 3]; pixels.len()]; REPLICATES as usize - 1];
        let sum: Vec<[f64; 3]> = deciding.iter().map(|d| d.map(|c| c + 3e6)).collect();
        let sum_sq = (pixels.iter())
            .map(|&(n, m, d)| [quarter(n) * (m * m + d * d); 3])
            .collect();
        let accumulation = Accumulation {
            width: pixels.len() as u32,
            height: 1,
            samples: 0,
            counts: Some(counts.clone()),
            replicates: Some(Replicates::from_others(0..0, &sum, others)),
            sum,
            sum_sq: Some(sum_sq),
        };
        (accumulation, counts)
    }

    #[test]
    fn the_pilot_and_a_uniform_continuation_sample_every_pixel_alike() {
        let counts = [0; 3];
        let round = uniform_round(&counts, PILOT_SAMPLES, u64::MAX).unwrap();
        assert_eq!(
            round,
            Round {
                pixels: vec![0, 1, 2],
                samples: PILOT_SAMPLES
            }
        );
        // A budget of 2 samples per pixel: one replicate set each.
        let round = uniform_round(&counts, PILOT_SAMPLES, 6).unwrap();
        assert_eq!(round.samples, REPLICATES);
        assert_eq!(uniform_round(&counts, PILOT_SAMPLES, 0), None);
        // On from the pilot: the budget's 30 samples per pixel in whole sets, or to the cap.
        let counts = [16; 3];
        assert_eq!(uniform_round(&counts, 1024, 90).unwrap().samples, 32);
        assert_eq!(uniform_round(&counts, 40, 90).unwrap().samples, 24);
        assert_eq!(uniform_round(&counts, 16, 90), None);
    }

    /// Pilot sums whose replicates 1..3 sit at `mean ± error` per pixel (replicate
    /// 0's samples as in `accumulation`): the replicates' spread is then about
    /// `error`.
    fn pilot(pixels: &[(f64, f64)]) -> (Accumulation, Vec<u32>) {
        let (mut acc, counts) = accumulation(
            &pixels
                .iter()
                .map(|&(_, e)| (16, 1.0, e))
                .collect::<Vec<_>>(),
        );
        let replicates = acc.replicates.as_mut().unwrap();
        for (p, &(_, error)) in pixels.iter().enumerate() {
            replicates.sums[0][p] = [4.0; 3];
            for (r, sign) in [(1, 1.0), (2, -1.0), (3, 0.0)] {
                replicates.sums[r][p] = [4.0 * (1.0 + sign * error); 3];
            }
        }
        (acc, counts)
    }

    #[test]
    fn the_pilot_goes_on_adaptively_only_where_the_error_is_uneven() {
        // Even: every pixel's error alike: 2/sqrt(3)/sqrt(0.8) = 1.29, uniform.
        let (acc, counts) = pilot(&[(1.0, 0.1); 16]);
        let even = choose(&acc, &counts, AdaptiveMetric::Absolute);
        assert!(
            (even.predicted_ratio - (1.0 / 0.75f64 / 0.8).sqrt()).abs() < 1e-9,
            "{even:?}"
        );
        assert!(even.uniform, "{even:?}");
        // One pixel of 256 holds the error, and the spreads follow it (its
        // neighbours too, and the others keep the floor): adaptive.
        let mut pixels = vec![(1.0, 0.001); 256];
        pixels[5] = (1.0, 1.0);
        let (mut acc, counts) = pilot(&pixels);
        let squares = acc.sum_sq.as_mut().unwrap();
        for (square, &(_, deviation)) in squares.iter_mut().zip(&pixels) {
            *square = [4.0 * (1.0 + deviation * deviation); 3];
        }
        let uneven = choose(&acc, &counts, AdaptiveMetric::Absolute);
        assert!(
            uneven.predicted_ratio < 0.5 && !uneven.uniform,
            "{uneven:?}"
        );
        // No error seen at all: nothing to gain.
        let (acc, counts) = pilot(&[(1.0, 0.0); 4]);
        let flat = choose(&acc, &counts, AdaptiveMetric::Absolute);
        assert!(
            flat.uniform && flat.predicted_ratio == f64::INFINITY,
            "{flat:?}"
        );
    }

    #[test]
    fn noisy_pixels_and_their_neighbours_get_the_round() {
        // One row; pixel 3 is 10x noisier than the others (means 1), and its
        // neighbours 2 and 4 share its spread.
        let quiet = (16, 1.0, 0.1);
        let (acc, counts) = accumulation(&[quiet, quiet, quiet, (16, 1.0, 1.0), quiet]);
        let round = next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, u64::MAX).unwrap();
        // Half the least count: 8 (a quarter of the 80 traced is 7 each).
        assert_eq!(
            round,
            Round {
                pixels: vec![2, 3, 4],
                samples: 8
            }
        );
        // At the cap, nothing: the run ends.
        let (acc, counts) = accumulation(&[(64, 1.0, 0.1), (64, 1.0, 1.0)]);
        assert_eq!(
            next_round(&acc, &counts, AdaptiveMetric::Absolute, 64, u64::MAX),
            None
        );
        // A capped pixel, however noisy, leaves the round to the others (here its
        // neighbour, which shares its spread, is above the others' mean).
        let far = (16, 1.0, 0.1);
        let (acc, counts) = accumulation(&[(64, 1.0, 100.0), far, far, far, (16, 1.0, 1.0)]);
        assert_eq!(
            next_round(&acc, &counts, AdaptiveMetric::Absolute, 64, u64::MAX)
                .unwrap()
                .pixels,
            [1]
        );
    }

    #[test]
    fn equal_priorities_sample_every_pixel() {
        // n ∝ σ already holds (here: all alike), as under uniform sampling; also
        // where the mean of the equal priorities rounds above them.
        for pixels in [4, 3, 7, 1000] {
            let (acc, counts) = accumulation(&vec![(16, 0.3, 0.1); pixels]);
            let round =
                next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, u64::MAX).unwrap();
            assert_eq!(round.pixels.len(), pixels);
            assert_eq!(round.samples, 8);
        }
    }

    #[test]
    fn zero_spread_pixels_keep_a_floor() {
        // Pixels 0 to 2 have no spread; 0 and 1 (no noisy neighbour) keep the floor's
        // priority, (0.1 · mean)² / n².
        let flat = (16, 1.0, 0.0);
        let (acc, counts) = accumulation(&[flat, flat, flat, (256, 1.0, 0.5)]);
        assert_eq!(
            acc.replicates.as_ref().unwrap().sums[0][..2],
            [[4.0; 3], [4.0; 3]]
        );
        let q = priorities(&acc, &counts, AdaptiveMetric::Absolute);
        // A grey's luminance is its value times the weights' sum (1 in decimal, not
        // quite in f32).
        let grey = LUMINANCE.iter().map(|&w| f64::from(w)).sum::<f64>();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
        for p in [0, 1] {
            assert!(close(q[p], (0.1 * grey).powi(2) / 256.0), "{q:?}");
        }
        // Pixel 2 takes its neighbour's spread at its own count.
        let spread = 0.5 * (64.0f64 / 63.0).sqrt() * grey;
        assert!(close(q[2], spread * spread / 256.0), "{q:?}");
        let round = next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, u64::MAX).unwrap();
        assert_eq!(round.pixels, [2]);
    }

    #[test]
    fn the_last_round_keeps_to_the_budget() {
        // Pixels 2 to 4 share pixel 3's spread and would take 8 samples each.
        let quiet = (16, 1.0, 1.0);
        let (acc, counts) = accumulation(&[quiet, quiet, quiet, (16, 1.0, 3.0), quiet]);
        assert_eq!(
            next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, u64::MAX)
                .unwrap()
                .pixels,
            [2, 3, 4]
        );
        // Room for 8 samples: two of them, one set each (equal priorities: by index).
        let round = next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, 8).unwrap();
        assert_eq!(
            round,
            Round {
                pixels: vec![2, 3],
                samples: REPLICATES
            }
        );
        // Room for 1: one set (over by 3).
        let round = next_round(&acc, &counts, AdaptiveMetric::Absolute, 1024, 1).unwrap();
        assert_eq!(
            round,
            Round {
                pixels: vec![2],
                samples: REPLICATES
            }
        );
    }

    #[test]
    fn caps_are_whole_replicate_sets() {
        assert_eq!(pixel_cap(1), 16);
        assert_eq!(pixel_cap(0), REPLICATES);
        assert_eq!(pixel_cap(u32::MAX), u32::MAX - u32::MAX % REPLICATES);
    }

    #[test]
    fn the_relative_metric_weighs_each_pixels_error_by_its_brightness() {
        // Pixels of equal noise, three dark and three ten times as bright, in one
        // row: alike under the absolute metric; under the relative one the ends'
        // (whose neighbourhoods are all dark or all bright) ten times apart.
        let (dark, bright) = ((16, 1.0, 0.5), (16, 10.0, 0.5));
        let (acc, counts) = accumulation(&[dark, dark, dark, bright, bright, bright]);
        let absolute = priorities(&acc, &counts, AdaptiveMetric::Absolute);
        assert!((absolute[0] - absolute[5]).abs() < 1e-12, "{absolute:?}");
        let relative = priorities(&acc, &counts, AdaptiveMetric::Relative);
        // Weights 1 / (μ² + (0.1 · 5.5)²): 1 / 1.3025 and 1 / 100.3025.
        let expected = 100.3025 / 1.3025;
        assert!(
            (relative[0] / relative[5] - expected).abs() < 1e-9,
            "{relative:?}"
        );
        let round = next_round(&acc, &counts, AdaptiveMetric::Relative, 1024, u64::MAX).unwrap();
        // The dark ones; pixel 3 is bright, and its neighbourhood brighter still.
        assert_eq!(round.pixels, [0, 1, 2]);
        // A black image has no brightness to weigh by: every pixel alike.
        let (acc, counts) = accumulation(&[(16, 0.0, 0.5), (16, 0.0, 0.5)]);
        let black = priorities(&acc, &counts, AdaptiveMetric::Relative);
        assert!(
            black.iter().all(|q| q.is_finite() && *q == black[0]),
            "{black:?}"
        );
    }
}
