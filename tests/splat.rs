//! Splatting (`render.reconstruction = "splat"`, `shaders/splat.wgsl`): the
//! sums do not depend on how samples are split into submissions, the error
//! estimate stays honest although neighbouring pixels share samples, and it
//! lowers the error of drawing offsets from the filter. What each filter's
//! splatted image converges to (light edges, constant scenes) is tested with
//! the filters (tests/filters.rs).

mod common;

use pathmix::render::Renderer;
use pathmix::scene::{Filter, Reconstruction, Sampler, Scene, SceneOverrides};
use pathmix::stats::Accumulation;

/// The Cornell boxes at 24×24 through Mitsuba's default Gaussian filter.
fn boxes(seed: u32, reconstruction: Reconstruction) -> Scene {
    let mut scene = common::small_cornell_boxes(24, Sampler::Sobol);
    scene.camera.filter = Filter::Gaussian { stddev: 0.5 };
    scene
        .apply_overrides(&SceneOverrides {
            seed: Some(seed),
            ..Default::default()
        })
        .unwrap();
    scene.render.reconstruction = Some(reconstruction);
    scene
}

/// Samples taken one submission at a time, or eight at once, give the same
/// sums bit for bit: each pixel adds its samples in sample-index order.
#[test]
fn submissions_do_not_change_the_sums() {
    let ctx = gpu_or_skip!();
    let scene = boxes(3, Reconstruction::Splat);
    let options = common::with_variance();
    let mut whole = Renderer::new(ctx, &scene, &options).unwrap();
    assert!(whole.config().splat, "the run splats");
    assert_eq!(whole.advance(8), 8);
    let mut steps = Renderer::new(ctx, &scene, &options).unwrap();
    for _ in 0..8 {
        assert_eq!(steps.advance(1), 1);
    }
    let (whole, steps) = (whole.accumulation(), steps.accumulation());
    assert_eq!(whole.sum, steps.sum);
    assert_eq!(whole.sum_sq, steps.sum_sq);
    assert_eq!(whole.replicates, steps.replicates);
}

/// A light's straight edge at 30° across a 48×48 image through Mitsuba's
/// default Gaussian filter: every sample is 0 or 1, so the error has no heavy
/// tail to hide in, and it lies where neighbouring pixels share the most.
fn edge(sampler: Sampler, seed: u32, reconstruction: Reconstruction) -> Scene {
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, 1]
        vfov = 40
        width = 48
        height = 48
        filter = "gaussian"
        [render]
        spp = 256
        max_depth = 0
        seed = {seed}
        sampler = "{}"
        reconstruction = "{}"
        [materials.glow]
        type = "light"
        emit = [1, 1, 1]
        [[objects]]
        type = "quad"
        q = [-8.660254, -5, 1]
        u = [-5, 8.660254, 0]
        v = [17.320508, 10, 0]
        material = "glow"
        "#,
        sampler.name(),
        reconstruction.name(),
    ))
}

/// The error the run estimates against the error it has, over three pairs of
/// seeds: half the mean squared difference of a pair's images is the mean
/// squared error of one.
fn estimated_and_actual(sampler: Sampler, reconstruction: Reconstruction) -> (f64, f64) {
    let ctx = common::gpu().expect("a device");
    let options = common::with_variance();
    let flat = |image: &pathmix::output::Image| -> Vec<f64> {
        image
            .pixels
            .iter()
            .flatten()
            .map(|&v| f64::from(v))
            .collect()
    };
    let (mut estimated, mut actual, mut values) = (0.0, 0.0, 0.0);
    for pair in 0..3 {
        let render = |seed| common::render(ctx, &edge(sampler, seed, reconstruction), &options);
        let (a, b): (Accumulation, Accumulation) = (render(2 * pair), render(2 * pair + 1));
        let (x, y) = (flat(&a.mean()), flat(&b.mean()));
        let e = flat(&a.standard_error().unwrap());
        actual += x.iter().zip(&y).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / 2.0;
        estimated += e.iter().map(|e| e * e).sum::<f64>();
        values += x.len() as f64;
    }
    (estimated / values, actual / values)
}

/// With both samplers and both reconstructions the estimated squared error is
/// within 25% of the actual one (the edge's pixels, about 150 independent
/// values a render, leave the actual error a spread of about 7% over the
/// three pairs).
#[test]
fn the_error_estimate_stays_honest() {
    let _ = gpu_or_skip!();
    for sampler in [Sampler::Independent, Sampler::Sobol] {
        for reconstruction in Reconstruction::ALL {
            let (estimated, actual) = estimated_and_actual(sampler, reconstruction);
            let what = format!("{sampler:?}, {reconstruction:?}");
            println!("{what}: estimated {estimated:.4e}, actual {actual:.4e}");
            assert!(
                (estimated / actual - 1.0).abs() < 0.25,
                "{what}: estimated {estimated:.4e} against {actual:.4e}"
            );
        }
    }
}

/// At the edge, splatting's image has less than 0.7 times the error of
/// drawing offsets from the same filter at equal samples.
#[test]
fn splatting_lowers_the_error() {
    let _ = gpu_or_skip!();
    let (_, splat) = estimated_and_actual(Sampler::Sobol, Reconstruction::Splat);
    let (_, importance) = estimated_and_actual(Sampler::Sobol, Reconstruction::Importance);
    println!("splat {splat:.4e}, importance {importance:.4e}");
    assert!(
        splat < 0.7 * importance,
        "{splat:.4e} against {importance:.4e}"
    );
}
