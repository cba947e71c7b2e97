//! Stopping rules and the error estimate they rely on.

mod common;

use pathmix::render::{self, RenderOptions, Renderer, StopReason, StopRule};
use pathmix::scene::SceneOverrides;
use std::time::Duration;

fn small_cornell() -> pathmix::scene::Scene {
    common::scene_with(
        "cornell-boxes.toml",
        SceneOverrides {
            width: Some(16),
            height: Some(16),
            max_depth: Some(8),
            ..Default::default()
        },
    )
}

#[test]
fn time_budget_stops_near_its_budget() {
    let ctx = gpu_or_skip!();
    let mut renderer = Renderer::new(ctx, &small_cornell(), &RenderOptions::default()).unwrap();
    let budget = Duration::from_millis(1500);
    let stop = StopRule {
        max_samples: u32::MAX,
        time_budget: Some(budget),
        target_error: None,
    };
    let summary = render::run(&mut renderer, stop, |_| {}).unwrap();
    assert_eq!(summary.reason, StopReason::TimeBudget);
    // One submission is aimed at 0.25 s, so the overshoot is small; generous bound for busy machines.
    assert!(
        summary.elapsed >= budget && summary.elapsed < budget + Duration::from_secs(3),
        "{:?}",
        summary.elapsed
    );
    assert!(summary.samples > 0);
}

#[test]
fn sample_cap_still_bounds_an_open_ended_rule() {
    let ctx = gpu_or_skip!();
    let mut renderer = Renderer::new(ctx, &small_cornell(), &common::with_variance()).unwrap();
    let stop = StopRule {
        max_samples: 12,
        time_budget: Some(Duration::from_secs(600)),
        target_error: Some(1e-9),
    };
    let summary = render::run(&mut renderer, stop, |_| {}).unwrap();
    assert_eq!((summary.reason, summary.samples), (StopReason::Samples, 12));
}

#[test]
fn noise_target_stops_with_the_estimate_below_the_target() {
    let ctx = gpu_or_skip!();
    let mut renderer = Renderer::new(ctx, &small_cornell(), &common::with_variance()).unwrap();
    let target = 0.08;
    let stop = StopRule {
        max_samples: 1 << 20,
        time_budget: None,
        target_error: Some(target),
    };
    let mut errors = Vec::new();
    let summary = render::run(&mut renderer, stop, |p| errors.extend(p.relative_error)).unwrap();
    assert_eq!(summary.reason, StopReason::TargetError);
    let error = summary.relative_error.unwrap();
    assert!(error <= target, "{error}");
    // And the run stopped because of it, not long after: the estimate was above the target before.
    assert!(errors.iter().any(|&e| e > target), "{errors:?}");
    assert_eq!(renderer.accumulation().relative_error(), Some(error));
}

#[test]
fn target_error_without_variance_is_refused() {
    let ctx = gpu_or_skip!();
    let mut renderer = Renderer::new(ctx, &small_cornell(), &RenderOptions::default()).unwrap();
    let stop = StopRule {
        max_samples: 4,
        time_budget: None,
        target_error: Some(0.1),
    };
    assert!(render::run(&mut renderer, stop, |_| {}).is_err());
}

/// A one-pixel camera whose view is exactly half covered by an emitter of
/// radiance 2: each sample is 2 or 0 with probability 1/2, so the standard error
/// of the mean is exactly 2 * 0.5 / sqrt(n).
#[test]
fn standard_error_matches_a_known_variance() {
    let ctx = gpu_or_skip!();
    let scene = common::camera_facing_emitter(
        20.0,
        16384,
        2.0,
        [0.0, -1.0, 1.0],
        [0.0, 2.0, 0.0],
        [1.0, 0.0, 0.0],
    );
    let acc = common::render(ctx, &scene, &common::with_variance());
    let n = acc.samples as f64;
    let mean = acc.mean().pixels[0][0] as f64;
    let error = acc.standard_error().unwrap().pixels[0][0] as f64;
    let expected_error = 2.0 * 0.5 / n.sqrt();
    // The mean is within 4 standard errors of 1, and the estimated standard error
    // within 2% of the exact one (its own sampling error here is ~0.8%).
    assert!((mean - 1.0).abs() < 4.0 * expected_error, "mean {mean}");
    assert!(
        (error / expected_error - 1.0).abs() < 0.02,
        "error {error} vs {expected_error}"
    );
}
