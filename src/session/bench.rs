//! Benchmark measurements: warm, repeated runs of fixed sample counts, median
//! time. The CLI decides which cases to run and prints them.

use crate::abi::StageCounts;
use crate::gpu::GpuContext;
use crate::kernel::Stage;
use crate::render::{self, RenderError, RenderOptions, Renderer, StopRule};
use crate::scene::Scene;

/// One configuration measured on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    pub samples: u32,
    /// Seconds of each repetition, in the order run.
    pub seconds: Vec<f64>,
    pub median_seconds: f64,
    /// Paths (pixels x samples) per second at the median time.
    pub paths_per_second: f64,
    /// Ray segments per second, median over repetitions.
    pub segments_per_second: f64,
}

/// Builds the renderer, warms it up (`Renderer::warm_up`), then times
/// `repetitions` runs of `samples` samples per pixel each.
pub fn measure(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    samples: u32,
    repetitions: usize,
) -> Result<Measurement, RenderError> {
    let mut renderer = Renderer::new(ctx, scene, options)?;
    renderer.warm_up(samples);
    let (width, height) = renderer.size();
    let mut seconds = Vec::with_capacity(repetitions);
    let mut segment_rates = Vec::with_capacity(repetitions);
    for _ in 0..repetitions.max(1) {
        let stop = StopRule::samples(renderer.samples() + samples);
        let summary = render::run(&mut renderer, stop, |_| {})?;
        seconds.push(summary.elapsed.as_secs_f64());
        segment_rates.push(summary.segments_per_second);
    }
    let median_seconds = median(&seconds);
    Ok(Measurement {
        samples,
        paths_per_second: width as f64 * height as f64 * samples as f64 / median_seconds,
        segments_per_second: median(&segment_rates),
        median_seconds,
        seconds,
    })
}

/// A profiling kernel's counts over a run (`RenderOptions::profile`).
#[derive(Clone, Debug, PartialEq)]
pub struct StageProfile {
    /// Paths traced (pixels x samples).
    pub paths: u64,
    pub stages: Vec<(Stage, StageCounts)>,
}

/// Renders `samples` samples per pixel of `scene` with a profiling kernel and
/// returns its stage counts.
pub fn profile_stages(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    samples: u32,
) -> Result<StageProfile, RenderError> {
    let options = RenderOptions {
        profile: true,
        ..options.clone()
    };
    let mut renderer = Renderer::new(ctx, scene, &options)?;
    render::run(&mut renderer, StopRule::samples(samples), |_| {})?;
    let (width, height) = renderer.size();
    Ok(StageProfile {
        paths: width as u64 * height as u64 * samples as u64,
        stages: renderer
            .stage_counts()
            .expect("a profiling renderer has stage counts"),
    })
}

pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        (sorted[mid - 1] + sorted[mid]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[7.0]), 7.0);
    }
}
