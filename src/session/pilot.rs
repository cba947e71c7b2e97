//! `strategy = "auto"`: a short pilot renders the scene with each candidate strategy,
//! at the run's own resolution where its budget allows, estimates each one's
//! relative error from its own per-pixel error estimate (the Sobol replicates'
//! spread, or the sample variance), and ranks them by efficiency `1 / (relative MSE
//! × seconds)`, as `converge` ranks them against a reference. Where the pilot renders
//! the run's own image and first sample indices, and the run estimates errors too
//! (its Sobol samples in the candidates' replicates), the chosen candidate's samples
//! are the run's first ones ([`Pilot::samples`]): only the others cost time. Those
//! far behind the best stop at half their samples ([`RACE`]).
//!
//! Candidates: `bsdf`; `nee-mis` where something emits; the mixture at weight 0.25
//! where anything is aimed at, and at 0.5 and 0.75 only when 0.25 beats the others
//! (each candidate is a pipeline to compile, and compilation can cost more than the
//! pilot's samples). `light` is biased and never a candidate. Like the rest of the
//! engine, this module prints nothing.

use crate::abi::REPLICATES;
use crate::gpu::GpuContext;
use crate::gpu::error_estimate::ErrorSums;
use crate::render::adaptive;
use crate::render::{self, RenderError, RenderOptions, Renderer, prepare_scene};
use crate::scene::{Sampler, Scene, Strategy};
use crate::session::converge::{Variant, short_number};
use std::fmt::Write as _;
use std::time::Instant;

/// Most samples per pixel a candidate renders in the pilot.
pub const MAX_SPP: u32 = 64;
/// Fewest: two per Sobol replicate.
pub const MIN_SPP: u32 = 2 * REPLICATES;
/// Fewest pixels of a pilot's image (a smaller render's whole image).
pub const MIN_PIXELS: u32 = 64 * 64;
/// Candidates the pilot's samples are sized for: those measured first.
const SIZED_FOR: u32 = 3;
/// The run's samples per pixel the pilot is sized for when a time or error target
/// ends the run (its length unknown).
pub const OPEN_ENDED_SPP: u32 = 256;
/// The pilot measures no further candidate once its wall time reaches this fraction
/// of the run's estimated time (at the best candidate's speed so far), and no
/// further mixture weight once one more candidate at the mean cost so far would: on
/// a small image, building the candidates' kernels alone can take longer than the run.
pub const BUDGET: f64 = 0.1;
/// A candidate whose first half is less efficient than this fraction of the best
/// first half stops there. Where one strategy is far ahead (the Cornell boxes:
/// the mixture 0.35–0.43 of `nee-mis`, `bsdf` 0.02), the losers cost half their
/// samples; within the factor the estimates at half the samples are too noisy to
/// decide (the sky's candidates, within 1.25x of each other, scatter 2x from seed
/// to seed at 4–16 spp).
pub const RACE: f64 = 0.75;
/// The mixture's light weight tried first, and those tried when it wins. 0.25 first:
/// under `converge` at each scene's own size it is 0.82–1.23x the efficiency of 0.5
/// on the shipped scenes, Veach's and the glossy teapot's (1.01x in geometric mean),
/// and the sky's best, where 0.5 and `nee-mis` are at 0.81–0.82 of it (docs/benchmarks.md, "The strategy pilot").
pub const FIRST_WEIGHT: f32 = 0.25;
pub const MORE_WEIGHTS: [f32; 2] = [0.5, 0.75];

/// Each candidate's image size and samples per pixel for a `width` x `height` render
/// of `final_spp` (`u32::MAX` when a time or error target ends it: sized as for
/// [`OPEN_ENDED_SPP`]). A candidate gets a [`SIZED_FOR`]th of the pilot's
/// [`BUDGET`] of the run's paths: at the run's own resolution, with as many samples
/// as that allows within [`MIN_SPP`]–[`MAX_SPP`] (a multiple of the replicates), or
/// where even [`MIN_SPP`] would be over, at [`MIN_SPP`] on the image shrunk to fit
/// (aspect ratio kept, at least [`MIN_PIXELS`] or the whole image).
///
/// The resolution matters more than the samples: a pixel's noise mixes what every
/// strategy shares (the edges of directly seen lights, which weigh more in larger
/// pixels) with what they differ in, and the speeds differ by resolution too. At
/// 600×600 `nee-mis` is 2.4x the mixture's efficiency on the Cornell boxes; on a
/// 64×64 image it measured 0.96–1.54x (its samples 1.8–2.9x the mixture's time, 2.0x
/// at 600×600). Under `converge` at each scene's own size, the ranking at 16 spp
/// already was the ranking at 256 on the Cornell boxes, Veach's scene and the sky.
pub fn shape(width: u32, height: u32, final_spp: u32) -> ((u32, u32), u32) {
    let run_spp = if final_spp == u32::MAX {
        OPEN_ENDED_SPP
    } else {
        final_spp
    };
    let pixels = width as f64 * height as f64;
    let paths = BUDGET * pixels * run_spp as f64 / SIZED_FOR as f64;
    let spp = ((paths / pixels) as u32).clamp(MIN_SPP, MAX_SPP) / REPLICATES * REPLICATES;
    let fitting = (paths / MIN_SPP as f64).max(MIN_PIXELS as f64);
    if fitting >= pixels {
        return ((width, height), spp);
    }
    let scale = (fitting / pixels).sqrt();
    let side = |s: u32| ((s as f64 * scale).round() as u32).max(1);
    ((side(width), side(height)), MIN_SPP)
}

/// The first candidates for `scene`, in the order measured: `mixture` at
/// [`FIRST_WEIGHT`] where the scene has anything to aim at, `nee-mis` where it has an
/// emitter for its shadow rays (the fallbacks of [`prepare_scene`] decide both), and
/// `bsdf`. A pilot cut short by its budget keeps the first.
pub fn first_candidates(scene: &Scene) -> Result<Vec<Variant>, RenderError> {
    let mut candidates = Vec::new();
    if prepare_scene(scene, Strategy::Mixture)?.1 == Strategy::Mixture {
        candidates.push(Variant::mixture(FIRST_WEIGHT));
    }
    if prepare_scene(scene, Strategy::NeeMis)?.1 == Strategy::NeeMis {
        candidates.push(Variant::NEE_MIS);
    }
    candidates.push(Variant::BSDF);
    Ok(candidates)
}

/// One candidate's pilot run.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub variant: Variant,
    pub spp: u32,
    /// Time of the pilot's samples, in one submission per half of the race where the
    /// loop budget allows (`Renderer::advance_in_one`): the pipeline's compilation
    /// and two one-sample dispatches of a row (where lavapipe compiles;
    /// `Renderer::compile`) are not counted.
    pub seconds: f64,
    /// Wall time before those samples: building the renderer and the two warm-up
    /// dispatches, mostly the kernel's compilation (little with a warm shader cache).
    pub build_seconds: f64,
    /// [`relative_noise`] of the candidate's pilot image; `None` for a black image.
    pub relative_error: Option<f64>,
    /// `1 / (relative_error² × seconds)`: infinite for an image without noise.
    pub efficiency: Option<f64>,
}

/// A candidate's samples, for a run to start from (`Renderer::start_from`).
pub struct Samples<'a> {
    pub renderer: Renderer<'a>,
    /// Of them, the samples the kernel found NaN or infinite and counted as zero.
    pub discarded: u64,
}

/// The pilot's result.
pub struct Pilot<'a> {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of a candidate that runs the race to the end; those out of
    /// it have [`first_half`] of them.
    pub spp: u32,
    /// In the order measured; empty when `bsdf` was the only candidate.
    pub rows: Vec<Row>,
    /// Candidates left unmeasured: the pilot had spent its [`BUDGET`].
    pub skipped: Vec<Variant>,
    pub choice: Variant,
    /// The chosen candidate's sums, where the run can start from them
    /// (`Renderer::start_from`): the pilot rendered the run's image at no more samples
    /// than the run's, and, for an adaptive run, no more than its own pilot's
    /// ([`adaptive::PILOT_SAMPLES`]), and the run lays out Sobol's samples in
    /// replicates as the candidates do (`RenderOptions::sampler_replicates`). Its
    /// samples are those the run would trace first (same sample indices, seed,
    /// strategy and layout; the variance sums change no other sum).
    pub samples: Option<Samples<'a>>,
    /// Wall time of the pilot's candidates: pipelines, warm-up, samples and error estimates
    /// (not the scene's first packing, which the run reuses).
    pub seconds: f64,
}

/// The relative RMSE the noise explains: the RMS over pixels and channels of the
/// per-pixel standard error of the mean ([`crate::stats::Accumulation::standard_error`]),
/// over the mean over pixels and channels of the image, from their sums
/// ([`Renderer::error_sums`]). It estimates what `converge` measures against a
/// reference ([`crate::stats::relative_rmse`]). `None` for a black image.
pub fn relative_noise(sums: &ErrorSums) -> Option<f64> {
    let values = sums.values as f64;
    (sums.mean > 0.0).then(|| (sums.squared_error / values).sqrt() / (sums.mean / values))
}

/// `1 / (relative_error² × seconds)`.
fn efficiency(relative_error: Option<f64>, seconds: f64) -> Option<f64> {
    relative_error.map(|e| 1.0 / (e * e * seconds.max(1e-9)))
}

/// The best row: the highest efficiency, then the fastest (a black or noiseless
/// pilot ranks by time alone).
pub fn best<'r>(rows: impl IntoIterator<Item = &'r Row>) -> Option<&'r Row> {
    rows.into_iter().max_by(|a, b| {
        let rank = |r: &Row| r.efficiency.unwrap_or(-1.0);
        rank(a)
            .total_cmp(&rank(b))
            .then(b.seconds.total_cmp(&a.seconds))
    })
}

/// The best of the rows that ran the race to the end (`spp` samples per pixel),
/// which the choice is made from: under Sobol the error falls faster than
/// 1/sqrt(spp), so efficiencies at different sample counts do not compare.
pub fn best_finished(rows: &[Row], spp: u32) -> Option<&Row> {
    best(rows.iter().filter(|r| r.spp == spp))
}

/// A candidate being measured: its renderer (variance on, for the error estimate;
/// uniform) and the time of its samples so far.
pub struct Candidate<'a> {
    pub variant: Variant,
    renderer: Renderer<'a>,
    build_seconds: f64,
    seconds: f64,
}

impl<'a> Candidate<'a> {
    /// Builds `variant` of `scene` at `width` x `height` with `options`, for up to
    /// `spp` samples per pixel, and compiles its kernel.
    pub fn new(
        ctx: &'a GpuContext,
        scene: &Scene,
        options: &RenderOptions,
        variant: Variant,
        (width, height): (u32, u32),
        spp: u32,
    ) -> Result<Candidate<'a>, RenderError> {
        let mut scene = scene.clone();
        scene.camera.width = width;
        scene.camera.height = height;
        scene.render.strategy = variant.strategy;
        scene.render.auto_strategy = false;
        if let Some(weight) = variant.light_weight {
            scene.render.light_weight = weight;
        }
        render::check_emission(&scene, spp, true)?;
        let built = Instant::now();
        let options = RenderOptions {
            variance: true,
            adaptive: false,
            sampler_replicates: true,
            ..options.clone()
        };
        let mut renderer = Renderer::new(ctx, &scene, &options)?;
        renderer.compile();
        Ok(Candidate {
            variant,
            renderer,
            build_seconds: built.elapsed().as_secs_f64(),
            seconds: 0.0,
        })
    }

    /// Traces samples up to `spp` per pixel, timed, in one submission where the
    /// loop budget allows (`Renderer::advance_in_one`).
    pub fn render_to(&mut self, spp: u32) {
        let started = Instant::now();
        self.renderer
            .advance_in_one(spp.saturating_sub(self.renderer.samples()));
        while self.renderer.samples() < spp {
            self.renderer.advance(spp - self.renderer.samples());
        }
        self.seconds += started.elapsed().as_secs_f64();
    }

    /// The row of its samples so far; refused where the driver cut invocations
    /// short or a sum overflowed.
    pub fn row(&self) -> Result<Row, RenderError> {
        self.renderer.check_counters()?;
        let sums = self.renderer.error_sums()?.expect("variance sums");
        if sums.non_finite > 0 {
            return Err(RenderError::SumsOverflowed {
                count: sums.non_finite as usize,
            });
        }
        let relative_error = relative_noise(&sums);
        Ok(Row {
            variant: self.variant,
            spp: self.renderer.samples(),
            seconds: self.seconds,
            build_seconds: self.build_seconds,
            relative_error,
            efficiency: efficiency(relative_error, self.seconds),
        })
    }

    /// Its samples, for a run to start from.
    pub fn into_samples(self) -> Result<Samples<'a>, RenderError> {
        let discarded = self.renderer.check_counters()?.discarded as u64;
        Ok(Samples {
            renderer: self.renderer,
            discarded,
        })
    }
}

/// Renders `variant` of `scene` at `width` x `height` and `spp`, with `options`:
/// the row and the samples, on the device.
pub fn measure<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    variant: Variant,
    size: (u32, u32),
    spp: u32,
) -> Result<(Row, Samples<'a>), RenderError> {
    let mut candidate = Candidate::new(ctx, scene, options, variant, size, spp)?;
    candidate.render_to(spp);
    Ok((candidate.row()?, candidate.into_samples()?))
}

/// Samples per pixel of a candidate's first half: at least one per replicate.
pub fn first_half(spp: u32) -> u32 {
    (spp / 2 / REPLICATES * REPLICATES).max(REPLICATES)
}

/// Whether `row` goes on to the second half against the best first half so far:
/// an efficiency at least [`RACE`] times the best's (the best itself, where no
/// efficiency is known).
fn contends(row: &Row, best: &Row) -> bool {
    match (row.efficiency, best.efficiency) {
        (Some(e), Some(b)) => e >= RACE * b,
        _ => row.variant == best.variant,
    }
}

/// Runs the pilot for a render of `scene` (its size) at `final_spp` samples per pixel
/// (`u32::MAX`: a time or error target decides) with `options`, and chooses the
/// candidate of highest efficiency among those measured within the [`BUDGET`].
///
/// A race in two halves: each candidate renders [`first_half`] of its samples,
/// and those within [`RACE`] of the best first half go on to all of them and are
/// measured again; the choice is the best of those ([`best_finished`]).
pub fn run<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    final_spp: u32,
) -> Result<Pilot<'a>, RenderError> {
    let ((width, height), spp) = shape(scene.camera.width, scene.camera.height, final_spp);
    // The candidates estimate errors, so their Sobol samples are replicates: a
    // run of one sequence per pixel does not start from them.
    let same_layout = options.sampler_replicates || scene.render.sampler != Sampler::Sobol;
    let reusable = (width, height) == (scene.camera.width, scene.camera.height)
        && spp <= final_spp
        && same_layout
        && (!options.adaptive || spp <= adaptive::PILOT_SAMPLES);
    let candidates = first_candidates(scene)?;
    // Timed from here: packing the scene once (`first_candidates`; a rough coat's
    // tables, about 1.4 s for Veach's scene) is work the run reuses.
    let started = Instant::now();
    let mut rows: Vec<Row> = Vec::new();
    let mut skipped = Vec::new();
    // The best candidate so far, whose samples the run may start from.
    let mut kept: Option<Candidate> = None;
    // Seconds per path of the best candidate so far, and the run's paths.
    let seconds_per_path = |r: &Row| r.seconds / (width as f64 * height as f64 * r.spp as f64);
    let run_paths = scene.camera.width as f64 * scene.camera.height as f64 * final_spp as f64;
    // Whether the pilot's time, with `reserve` more, reaches its budget.
    let over_budget = |rows: &[Row], reserve: f64| {
        let run_seconds = best(rows).map(|r| seconds_per_path(r) * run_paths);
        let spent = started.elapsed().as_secs_f64();
        final_spp != u32::MAX && run_seconds.is_some_and(|run| spent + reserve >= BUDGET * run)
    };
    // Every candidate's first half, which the race compares.
    let mut halves: Vec<Row> = Vec::new();
    // `predicted`: a candidate starts only where one more at the mean cost so far
    // fits in the budget (the further weights, a refinement), not merely where the
    // budget is not spent yet (the first candidates, which the choice needs).
    let mut race = |variants: &[Variant],
                    rows: &mut Vec<Row>,
                    kept: &mut Option<Candidate<'a>>,
                    predicted: bool|
     -> Result<(), RenderError> {
        let mut racing = Vec::new();
        for &variant in variants {
            let reserve = match predicted && !rows.is_empty() {
                true => started.elapsed().as_secs_f64() / rows.len() as f64,
                false => 0.0,
            };
            if over_budget(rows, reserve) {
                skipped.push(variant);
                continue;
            }
            let mut candidate = Candidate::new(ctx, scene, options, variant, (width, height), spp)?;
            candidate.render_to(first_half(spp));
            let half = candidate.row()?;
            halves.push(half.clone());
            rows.push(half);
            racing.push((rows.len() - 1, candidate));
        }
        // The leader goes on whatever the budget: where the run starts from its
        // samples, they cost nothing.
        let Some(leader) = best(&halves).cloned() else {
            return Ok(());
        };
        for (index, candidate) in &mut racing {
            let half = &rows[*index];
            if half.variant == leader.variant
                || (contends(half, &leader) && !over_budget(rows, 0.0))
            {
                candidate.render_to(spp);
                rows[*index] = candidate.row()?;
            }
        }
        let leader = best_finished(rows, spp).map(|r| r.variant);
        if let Some((_, candidate)) = racing.into_iter().find(|(_, c)| Some(c.variant) == leader) {
            *kept = Some(candidate);
        }
        Ok(())
    };
    if candidates.len() > 1 {
        race(&candidates, &mut rows, &mut kept, false)?;
        let all_measured = rows.len() == candidates.len();
        let leader = best_finished(&rows, spp).map(|r| r.variant);
        if all_measured && leader == Some(Variant::mixture(FIRST_WEIGHT)) {
            race(
                &MORE_WEIGHTS.map(Variant::mixture),
                &mut rows,
                &mut kept,
                true,
            )?;
        }
    }
    let choice = best_finished(&rows, spp).map_or(candidates[0], |r| r.variant);
    let samples = match kept {
        Some(candidate) if reusable && candidate.variant == choice => {
            Some(candidate.into_samples()?)
        }
        _ => None,
    };
    Ok(Pilot {
        width,
        height,
        spp,
        rows,
        skipped,
        choice,
        samples,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The pilot's table, one line per candidate: samples, seconds of the samples and of
/// the build before them, estimated relative error, efficiency, and efficiency
/// relative to the best.
pub fn table(pilot: &Pilot) -> String {
    let best = best_finished(&pilot.rows, pilot.spp).and_then(|r| r.efficiency);
    let mut out = format!(
        "{:<14} {:>5} {:>9} {:>9} {:>11} {:>11} {:>8}\n",
        "candidate", "spp", "seconds", "build s", "rel. error", "efficiency", "vs best"
    );
    let dash = || "–".to_string();
    for r in &pilot.rows {
        let relative = match (r.efficiency, best) {
            (Some(e), Some(b)) if b.is_finite() && b > 0.0 => format!("{:.2}", e / b),
            _ => dash(),
        };
        let _ = writeln!(
            out,
            "{:<14} {:>5} {:>9} {:>9} {:>11} {:>11} {:>8}",
            r.variant.name(),
            r.spp,
            short_number(r.seconds),
            short_number(r.build_seconds),
            r.relative_error.map_or_else(dash, short_number),
            r.efficiency.map_or_else(dash, short_number),
            relative
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(variant: Variant, seconds: f64, relative_error: Option<f64>) -> Row {
        Row {
            variant,
            spp: 64,
            seconds,
            build_seconds: 0.25,
            relative_error,
            efficiency: efficiency(relative_error, seconds),
        }
    }

    #[test]
    fn the_pilot_renders_at_the_runs_resolution_where_its_budget_allows() {
        // A third of 10% of a 256-spp run: 8.5 spp at the run's size, whole replicates.
        assert_eq!(shape(768, 512, 256), ((768, 512), 8));
        assert_eq!(shape(600, 600, 256), ((600, 600), 8));
        assert_eq!(shape(600, 600, u32::MAX), ((600, 600), 8));
        // Longer runs: more samples, up to the most.
        assert_eq!(shape(600, 600, 1024), ((600, 600), 32));
        assert_eq!(shape(600, 600, 1 << 20), ((600, 600), MAX_SPP));
        // Shorter: the image shrunk to what 8 spp allows, its aspect ratio kept.
        assert_eq!(shape(600, 600, 64), ((310, 310), MIN_SPP));
        assert_eq!(shape(768, 512, 64), ((397, 264), MIN_SPP));
        // At least 64×64 pixels, or the whole of a smaller image.
        assert_eq!(shape(600, 600, 1), ((64, 64), MIN_SPP));
        assert_eq!(shape(4000, 10, 1), ((1280, 3), MIN_SPP));
        assert_eq!(shape(32, 32, 1), ((32, 32), MIN_SPP));
        assert_eq!(shape(32, 32, 256), ((32, 32), 8));
        assert_eq!(MIN_SPP % REPLICATES, 0);
        assert_eq!(MAX_SPP % REPLICATES, 0);
    }

    #[test]
    fn the_best_has_the_highest_efficiency_then_the_least_time() {
        // 1/(0.125² × 1) = 64 against 1/(0.0625² × 8) = 32.
        let rows = [
            row(Variant::BSDF, 1.0, Some(0.125)),
            row(Variant::NEE_MIS, 8.0, Some(0.0625)),
            row(Variant::mixture(0.5), 0.5, None),
        ];
        assert_eq!(rows[0].efficiency, Some(64.0));
        assert_eq!(rows[1].efficiency, Some(32.0));
        assert_eq!(best(&rows).unwrap().variant, Variant::BSDF);
        let black = [
            row(Variant::BSDF, 1.0, None),
            row(Variant::mixture(0.5), 0.5, None),
        ];
        assert_eq!(best(&black).unwrap().variant, Variant::mixture(0.5));
        let noiseless = [
            row(Variant::BSDF, 1.0, Some(0.0)),
            row(Variant::NEE_MIS, 2.0, Some(0.0)),
        ];
        assert_eq!(best(&noiseless).unwrap().variant, Variant::BSDF);
        assert_eq!(best(&[]), None);
    }

    #[test]
    fn the_race_decides_at_half_the_samples_and_chooses_among_those_that_finish() {
        // Halves are whole replicates, at least one sample in each.
        assert_eq!(first_half(8), 4);
        assert_eq!(first_half(32), 16);
        assert_eq!(first_half(MAX_SPP), 32);
        assert_eq!(first_half(MIN_SPP), REPLICATES);
        // 1/(0.2² × 1) = 25 against the leader's 1/(0.1² × 1) = 100: out at 0.25;
        // 1/(0.1125² × 1) = 79 is 0.79 of it: in.
        let leader = row(Variant::NEE_MIS, 1.0, Some(0.1));
        assert!(contends(&leader, &leader));
        assert!(!contends(&row(Variant::BSDF, 1.0, Some(0.2)), &leader));
        assert!(contends(
            &row(Variant::mixture(0.25), 1.0, Some(0.1125)),
            &leader
        ));
        // A black image has no efficiency: only the leader goes on.
        let black = row(Variant::BSDF, 1.0, None);
        assert!(!contends(&row(Variant::NEE_MIS, 1.0, None), &black));
        assert!(contends(&black, &black));
        // A half (here 32 of 64 spp) does not compete with the finished rows,
        // however efficient it looks.
        let mut half = row(Variant::BSDF, 0.1, Some(0.1));
        half.spp = 32;
        let rows = [half, leader.clone()];
        assert_eq!(best(&rows).unwrap().variant, Variant::BSDF);
        assert_eq!(best_finished(&rows, 64).unwrap().variant, Variant::NEE_MIS);
    }

    #[test]
    fn the_table_has_a_line_per_candidate_relative_to_the_best() {
        let pilot = Pilot {
            width: 64,
            height: 64,
            spp: 64,
            rows: vec![
                row(Variant::BSDF, 1.0, Some(0.1)),
                row(Variant::NEE_MIS, 2.0, Some(0.1)),
            ],
            skipped: Vec::new(),
            choice: Variant::BSDF,
            samples: None,
            seconds: 3.5,
        };
        let text = table(&pilot);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[0].starts_with("candidate"), "{text}");
        assert!(lines[1].starts_with("bsdf") && lines[1].ends_with("1.00"));
        assert!(lines[2].starts_with("nee-mis") && lines[2].ends_with("0.50"));
        assert!(lines[2].contains(" 50.0 "), "{text}");
    }
}
