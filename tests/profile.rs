//! The profiling kernel (`RenderOptions::profile`, `pathmix bench --stages`):
//! its stage counts are what the kernel does, exactly where that is known, and
//! counting does not change the image.

mod common;

use pathmix::abi::StageCounts;
use pathmix::gpu::GpuContext;
use pathmix::kernel::Stage;
use pathmix::render::{RenderOptions, Renderer};
use pathmix::scene::{Sampler, Scene, SceneOverrides, Strategy};

/// The GPU, where it has subgroup operations; else the test is skipped.
fn profiling_gpu() -> Option<&'static GpuContext> {
    let ctx = common::gpu()?;
    if !ctx.subgroups {
        eprintln!("skipped: the adapter has no subgroup operations to count lanes with");
        return None;
    }
    Some(ctx)
}

/// Renders `samples` per pixel with the profiling kernel; its renderer (for
/// the image and counters) and its counts by stage.
fn profiled<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    samples: u32,
) -> (Renderer<'a>, impl Fn(Stage) -> StageCounts) {
    let options = RenderOptions {
        profile: true,
        ..RenderOptions::default()
    };
    let mut renderer = Renderer::new(ctx, scene, &options).unwrap();
    assert_eq!(renderer.advance(samples), samples);
    let counts = renderer.stage_counts().expect("a profiling kernel");
    let stage = move |stage: Stage| counts.iter().find(|(s, _)| *s == stage).unwrap().1;
    (renderer, stage)
}

/// Under the mixture strategy no shadow ray is traced, so every ray segment
/// the kernel counts is one path step, and the profiling kernel's image is the
/// plain kernel's bit for bit.
#[test]
fn path_steps_are_the_segments_and_the_image_is_unchanged() {
    let Some(ctx) = profiling_gpu() else { return };
    let mut scene = common::small_cornell_boxes(16, Sampler::Sobol);
    scene.render.strategy = Strategy::Mixture;
    let (renderer, stage) = profiled(ctx, &scene, 4);
    let steps = stage(Stage::PathStep);
    assert_eq!(steps.lanes(), renderer.counters().segments());
    assert!(steps.lanes() > 16 * 16 * 4, "paths bounce");
    assert!(steps.lanes() <= steps.slots());
    for shadow in [Stage::ShadowNodes, Stage::ShadowPrimitives] {
        assert_eq!(stage(shadow).lanes(), 0, "{shadow:?}");
    }
    let mut plain = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    assert_eq!(plain.advance(4), 4);
    assert_eq!(plain.accumulation().sum, renderer.accumulation().sum);
}

/// A 16×16 image of rays that all miss: one step per path, every lane of every
/// SIMD group active (the 8×8 workgroups are full), nothing shaded.
#[test]
fn rays_that_miss_keep_every_lane_busy() {
    let Some(ctx) = profiling_gpu() else { return };
    let scene = common::scene_text(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, 1]
        vfov = 40
        width = 16
        height = 16
        [render]
        background = [0.5, 0.5, 0.5]
        [materials.grey]
        type = "lambertian"
        albedo = [0.5, 0.5, 0.5]
        [[objects]]
        type = "sphere"
        center = [0, 0, -5]
        radius = 1
        material = "grey"
        "#,
    );
    let (_, stage) = profiled(ctx, &scene, 3);
    let steps = stage(Stage::PathStep);
    assert_eq!((steps.lanes(), steps.slots()), (16 * 16 * 3, 16 * 16 * 3));
    assert_eq!(stage(Stage::Shading).slots(), 0);
}

/// The knot's mesh is walked through a BVH: closest hits visit nodes and test
/// primitives; shadow rays do too under `nee-mis` and not under `mixture`.
#[test]
fn bvh_walks_count_toward_their_ray() {
    let Some(ctx) = profiling_gpu() else { return };
    for (strategy, shadow_rays) in [(Strategy::NeeMis, true), (Strategy::Mixture, false)] {
        let scene = common::scene_with(
            "knot.toml",
            SceneOverrides {
                width: Some(32),
                height: Some(24),
                strategy: Some(strategy),
                ..Default::default()
            },
        );
        let (_, stage) = profiled(ctx, &scene, 1);
        // Every path step's walk visits the root at least.
        let steps = stage(Stage::PathStep).lanes();
        assert!(stage(Stage::ClosestNodes).lanes() >= steps, "{strategy:?}");
        assert!(stage(Stage::ClosestPrimitives).lanes() > 0, "{strategy:?}");
        for shadow in [Stage::ShadowNodes, Stage::ShadowPrimitives] {
            assert_eq!(
                stage(shadow).lanes() > 0,
                shadow_rays,
                "{strategy:?} {shadow:?}"
            );
        }
        for (s, counts) in Stage::ALL.map(|s| (s, stage(s))) {
            assert!(counts.lanes() <= counts.slots(), "{s:?}");
        }
    }
}
