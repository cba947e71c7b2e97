//! Benchmark measurements: warm, repeated runs of fixed sample counts, median
//! time. The CLI decides which cases to run and prints them.

use crate::gpu::GpuContext;
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

/// `n` small diffuse spheres in a grid on a ground sphere, under a sky colour
/// and a sphere light: how the cost grows with the scene (256x256, max depth 8).
pub fn sphere_field(n: usize) -> Scene {
    Scene::parse(&sphere_field_toml(n), "sphere-field.toml")
        .expect("the sphere field is a valid scene")
}

/// The scene file of `sphere_field(n)`, as `pathmix bench --write-sphere-field`
/// prints it for other renderers (`scripts/compare-mitsuba.py`).
pub fn sphere_field_toml(n: usize) -> String {
    let mut text = format!(
        "# A field of {n} diffuse spheres on a ground sphere under a sky colour and a sphere\n\
         # light: `pathmix bench --write-sphere-field {n}`, the scale curve's scene.\n\
         [camera]\nlookfrom = [0, 6, 14]\nlookat = [0, 0, 0]\nwidth = 256\nheight = 256\n\
         [render]\nmax_depth = 8\nbackground = [0.5, 0.7, 1.0]\n\
         [materials.ground]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [materials.ball]\ntype = \"lambertian\"\nalbedo = [0.7, 0.3, 0.2]\n\
         [materials.lamp]\ntype = \"light\"\nemit = [10, 10, 10]\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, -1000, 0]\nradius = 1000\nmaterial = \"ground\"\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 12, 0]\nradius = 2\nmaterial = \"lamp\"\n",
    );
    let side = (n as f64).sqrt().ceil() as usize;
    let radius = 0.35 * 10.0 / side as f64;
    for i in 0..n {
        let x = (i % side) as f64 / side as f64 * 20.0 - 10.0;
        let z = (i / side) as f64 / side as f64 * 20.0 - 10.0;
        text.push_str(&format!(
            "[[objects]]\ntype = \"sphere\"\ncenter = [{x}, {radius}, {z}]\nradius = {radius}\nmaterial = \"ball\"\n"
        ));
    }
    text
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
