//! `strategy = "auto"`: a short pilot renders the scene with each candidate strategy,
//! at the run's own resolution where its budget allows, estimates each one's
//! relative error from its own per-pixel error estimate (the Sobol replicates'
//! spread, or the sample variance), and ranks them by efficiency `1 / (relative MSE
//! × seconds)`, as `converge` ranks them against a reference. Where the pilot renders
//! the run's own image and first sample indices, the chosen candidate's samples are
//! the run's first ones ([`Pilot::samples`]): only the others cost time.
//!
//! Candidates: `bsdf`; `nee-mis` where something emits; the mixture at weight 0.25
//! where anything is aimed at, and at 0.5 and 0.75 only when 0.25 beats the others
//! (each candidate is a pipeline to compile, and compilation can cost more than the
//! pilot's samples). `light` is biased and never a candidate. Like the rest of the
//! engine, this module prints nothing.

use crate::adaptive;
use crate::converge::{Variant, short_number};
use crate::gpu::GpuContext;
use crate::gpu::accumulator::REPLICATES;
use crate::gpu::error_estimate::ErrorSums;
use crate::render::{self, RenderError, RenderOptions, Renderer, prepare_scene};
use crate::scene::{Scene, Strategy};

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
/// of the run's estimated time (at the best candidate's speed so far): on a small
/// image, building the candidates' kernels alone can take longer than the run.
pub const BUDGET: f64 = 0.1;
/// The mixture's light weight tried first, and those tried when it wins. 0.25 first:
/// under `converge` at each scene's own size it is 0.82–1.23x the efficiency of 0.5
/// on the shipped scenes, Veach's and the glossy teapot's (1.01x in geometric mean),
/// and the sky's best, where 0.5 and `nee-mis` are at 0.81–0.82 of it (README).
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
    /// Time of the pilot's samples, in one submission where the loop budget allows
    /// (`Renderer::advance_in_one`): the pipeline's compilation and two one-sample
    /// dispatches of a row (where lavapipe compiles; `Renderer::compile`) are not
    /// counted.
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
    /// Samples per pixel of each candidate.
    pub spp: u32,
    /// In the order measured; empty when `bsdf` was the only candidate.
    pub rows: Vec<Row>,
    /// Candidates left unmeasured: the pilot had spent its [`BUDGET`].
    pub skipped: Vec<Variant>,
    pub choice: Variant,
    /// The chosen candidate's sums, where the run can start from them
    /// (`Renderer::start_from`): the pilot rendered the run's image at no more samples
    /// than the run's, and, for an adaptive run, no more than its own pilot's
    /// ([`adaptive::PILOT_SAMPLES`]). Its samples are those the run would trace first
    /// (same sample indices, seed and strategy; the variance sums change no other sum).
    pub samples: Option<Samples<'a>>,
    /// Wall time of the pilot's candidates: pipelines, warm-up, samples and readbacks
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
pub fn best(rows: &[Row]) -> Option<&Row> {
    rows.iter().max_by(|a, b| {
        let rank = |r: &Row| r.efficiency.unwrap_or(-1.0);
        rank(a)
            .total_cmp(&rank(b))
            .then(b.seconds.total_cmp(&a.seconds))
    })
}

/// Renders `variant` of `scene` at `width` x `height` and `spp`, with `options`
/// (variance on, for the error estimate; uniform): the row and the samples, on the
/// device.
pub fn measure<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    variant: Variant,
    (width, height): (u32, u32),
    spp: u32,
) -> Result<(Row, Samples<'a>), RenderError> {
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
        ..options.clone()
    };
    let mut renderer = Renderer::new(ctx, &scene, &options)?;
    renderer.compile();
    let build_seconds = built.elapsed().as_secs_f64();
    let started = Instant::now();
    renderer.advance_in_one(spp);
    while renderer.samples() < spp {
        renderer.advance(spp - renderer.samples());
    }
    let seconds = started.elapsed().as_secs_f64();
    let discarded = renderer.check_counters()?.discarded as u64;
    let sums = renderer.error_sums()?.expect("variance sums");
    if sums.non_finite > 0 {
        return Err(RenderError::SumsOverflowed {
            count: sums.non_finite as usize,
        });
    }
    let relative_error = relative_noise(&sums);
    let row = Row {
        variant,
        spp,
        seconds,
        build_seconds,
        relative_error,
        efficiency: efficiency(relative_error, seconds),
    };
    Ok((
        row,
        Samples {
            renderer,
            discarded,
        },
    ))
}

/// Runs the pilot for a render of `scene` (its size) at `final_spp` samples per pixel
/// (`u32::MAX`: a time or error target decides) with `options`, and chooses the
/// candidate of highest efficiency among those measured within the [`BUDGET`].
/// `on_row` sees each row as it is measured.
pub fn run<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    final_spp: u32,
    mut on_row: impl FnMut(&Row),
) -> Result<Pilot<'a>, RenderError> {
    let ((width, height), spp) = shape(scene.camera.width, scene.camera.height, final_spp);
    let reusable = (width, height) == (scene.camera.width, scene.camera.height)
        && spp <= final_spp
        && (!options.adaptive || spp <= adaptive::PILOT_SAMPLES);
    let candidates = first_candidates(scene)?;
    // Timed from here: packing the scene once (`first_candidates`; a rough coat's
    // tables, about 1.4 s for Veach's scene) is work the run reuses.
    let started = Instant::now();
    let mut rows: Vec<Row> = Vec::new();
    let mut skipped = Vec::new();
    // The best candidate's sums so far, where the run can start from them.
    let mut samples = None;
    // The run's time at the best candidate's speed (unknown for an open-ended run).
    let pixels = |w: u32, h: u32| w as f64 * h as f64;
    let scale = pixels(scene.camera.width, scene.camera.height) * final_spp as f64
        / (pixels(width, height) * spp as f64);
    let mut try_each = |variants: &[Variant], rows: &mut Vec<Row>| -> Result<(), RenderError> {
        for &variant in variants {
            let run_seconds = best(rows).map(|r| r.seconds * scale);
            let spent = started.elapsed().as_secs_f64();
            if final_spp != u32::MAX && run_seconds.is_some_and(|run| spent >= BUDGET * run) {
                skipped.push(variant);
                continue;
            }
            let (row, measured) = measure(ctx, scene, options, variant, (width, height), spp)?;
            on_row(&row);
            rows.push(row);
            if reusable && best(rows).map(|r| r.variant) == Some(variant) {
                samples = Some(measured);
            }
        }
        Ok(())
    };
    if candidates.len() > 1 {
        try_each(&candidates, &mut rows)?;
        let all_measured = rows.len() == candidates.len();
        if all_measured && best(&rows).map(|r| r.variant) == Some(Variant::mixture(FIRST_WEIGHT)) {
            try_each(&MORE_WEIGHTS.map(Variant::mixture), &mut rows)?;
        }
    }
    let choice = best(&rows).map_or(candidates[0], |r| r.variant);
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
    let best = best(&pilot.rows).and_then(|r| r.efficiency);
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
