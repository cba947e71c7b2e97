//! Numerical stability at the extremes: scale, light densities at their limits,
//! depth and image size, index-matched dielectrics, and the NaN/Inf guard on
//! every shipped scene. Small images on lavapipe; each tolerance is stated where
//! it is checked.

mod common;

use glam::Vec3;
use pathmix::gpu::GpuContext;
use pathmix::kernel::AccumulatorKind;
use pathmix::render::{RenderError, RenderOptions, Renderer};
use pathmix::scene::{MaterialKind, Scene, SceneOverrides, Strategy};
use pathmix::stats::{self, Accumulation};

/// Agreement of two independent estimates: |a - b| within this many standard
/// errors of their difference.
const K_SIGMA: f64 = 4.0;

fn overridden(mut scene: Scene, o: SceneOverrides) -> Scene {
    scene.apply_overrides(&o).unwrap();
    scene
}

fn cornell_boxes(size: u32, spp: u32) -> Scene {
    overridden(
        common::scene_file("cornell-boxes.toml"),
        SceneOverrides {
            width: Some(size),
            height: Some(size),
            spp: Some(spp),
            ..Default::default()
        },
    )
}

fn with_strategy(scene: &Scene, strategy: Strategy, seed: u32) -> Scene {
    overridden(
        scene.clone(),
        SceneOverrides {
            strategy: Some(strategy),
            seed: Some(seed),
            ..Default::default()
        },
    )
}

fn material(scene: &Scene, name: &str) -> u32 {
    scene
        .materials
        .iter()
        .position(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material `{name}`")) as u32
}

/// Index of the (only) quad made of the `light` material.
fn light_quad(scene: &Scene) -> usize {
    let light = material(scene, "light");
    let found: Vec<usize> = (0..scene.shapes.quads.len())
        .filter(|&i| scene.shapes.quads[i].material == light)
        .collect();
    assert_eq!(found.len(), 1);
    found[0]
}

fn mean_and_error(ctx: &GpuContext, scene: &Scene) -> (f64, f64) {
    common::image_mean_and_error(&common::render(ctx, scene, &common::with_variance()))
}

/// `a` and `b` (mean, standard error) agree within `K_SIGMA` standard errors of
/// their difference, and both errors are under `max_relative_error` of the mean,
/// so that the agreement means something.
fn assert_agree(what: &str, a: (f64, f64), b: (f64, f64), max_relative_error: f64) {
    let sigma = a.1.hypot(b.1);
    let z = (a.0 - b.0) / sigma;
    eprintln!(
        "{what}: {:.5} ± {:.5} vs {:.5} ± {:.5}: z = {z:+.2}",
        a.0, a.1, b.0, b.1
    );
    assert!(
        z.abs() <= K_SIGMA,
        "{what}: {} ± {} vs {} ± {} differ by {z:.2} standard errors",
        a.0,
        a.1,
        b.0,
        b.1
    );
    assert!(
        a.1 < max_relative_error * a.0.abs() && b.1 < max_relative_error * b.0.abs(),
        "{what}: standard errors too large to test anything (more samples)"
    );
}

// ---------------------------------------------------------------------------------
// 1. Scale-free

/// The Cornell boxes at 1e-3, 1e4 and 1e5 times the size render the same image, with
/// the same seed, as at scale 1. Tolerance: the RMSE to the scale-1 image is under
/// a hundredth of the noise (the RMSE between two seeds at scale 1); at power-of-two
/// scales every operation scales exactly, so the image is bit-identical.
#[test]
fn cornell_boxes_render_the_same_at_any_scale() {
    let ctx = gpu_or_skip!();
    let scene = cornell_boxes(32, 16);
    let image = |scene: &Scene| common::render(ctx, scene, &RenderOptions::default());
    let reference = image(&scene);
    let noise = stats::rmse(
        &image(&with_strategy(&scene, Strategy::Mixture, 1)).mean(),
        &reference.mean(),
    );
    for factor in [1e-3, 1e4, 1e5] {
        let rmse = stats::rmse(&image(&scene.scaled(factor)).mean(), &reference.mean());
        eprintln!("scale {factor:e}: RMSE {rmse:.3e} vs noise (seed 0 vs 1) {noise:.3e}");
        assert!(
            rmse < 0.01 * noise,
            "scale {factor:e}: RMSE {rmse} against noise {noise}"
        );
    }
    for factor in [2f32.powi(-10), 2f32.powi(13)] {
        assert!(
            image(&scene.scaled(factor)) == reference,
            "scale {factor:e} (a power of two) changed the image"
        );
    }
}

// ---------------------------------------------------------------------------------
// 2. Light densities at their limits

/// A floor of albedo `ALBEDO` seen by a camera with a 1 degree field of view,
/// looking straight down at the point under `light` (TOML objects) at height
/// `h`; depth 1, so each pixel is `ALBEDO * L * F`, F the view factor from that
/// point to the light (the pixels' footprint changes it by under 1e-4).
const ALBEDO: f64 = 0.73;

fn direct_light_scene(h: f64, emit: f64, light: &str) -> Scene {
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, {half}, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, 1]
        vfov = 1
        width = 16
        height = 16
        [render]
        spp = 256
        max_depth = 1
        [materials.white]
        type = "lambertian"
        albedo = [{ALBEDO}, {ALBEDO}, {ALBEDO}]
        [materials.light]
        type = "light"
        emit = [{emit}, {emit}, {emit}]
        [[objects]]
        type = "quad"
        q = [-1000, 0, -1000]
        u = [0, 0, 2000]
        v = [2000, 0, 0]
        material = "white"
        {light}
        "#,
        half = h / 2.0,
    ))
}

/// The Cornell light shrunk to 1e-4 of its area about its centre, 15e4 emission
/// (the same power): at its height above a floor point under its centre, the
/// mixture's mean is the analytic `ALBEDO * L * F`, F the view factor of a
/// parallel rectangle (Howell B-3). Cosine sampling almost never finds a light this
/// small, so the reference is analytic. The same light in the Cornell box renders
/// without a NaN or Inf sample.
#[test]
fn tiny_quad_light_with_the_same_power_is_unbiased() {
    let ctx = gpu_or_skip!();
    let (a, b, h, emit) = (1.3, 1.05, 554.0, 15e4);
    let scene = direct_light_scene(
        h,
        emit,
        &format!(
            r#"
            [[objects]]
            type = "quad"
            q = [{}, {h}, {}]
            u = [{a}, 0, 0]
            v = [0, 0, {b}]
            material = "light"
            "#,
            -a / 2.0,
            -b / 2.0
        ),
    );
    // Four corner rectangles of half the sides.
    let (x, y) = (a / (2.0 * h), b / (2.0 * h));
    let corner = |x: f64, y: f64| {
        let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
        (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
    };
    let expected = ALBEDO * emit * 4.0 * corner(x, y);
    let measured = mean_and_error(ctx, &scene);
    assert_agree(
        "tiny quad light (mixture vs analytic)",
        measured,
        (expected, 0.0),
        0.01,
    );

    let mut cornell = cornell_boxes(16, 16);
    let i = light_quad(&cornell);
    let light = &mut cornell.shapes.quads[i];
    let centre = light.q + 0.5 * (light.u + light.v);
    light.u *= 0.01;
    light.v *= 0.01;
    light.q = centre - 0.5 * (light.u + light.v);
    let m = material(&cornell, "light") as usize;
    cornell.materials[m].emit *= 1e4;
    for strategy in Strategy::ALL {
        common::render(
            ctx,
            &with_strategy(&cornell, strategy, 0),
            &RenderOptions::default(),
        );
    }
}

/// A sphere light of radius 1e-4 of its distance (sin^2 of its cone 1e-8, where a
/// naive `1 - sqrt(1 - sin^2)` is 0 in f32) and emission 5e7: the point under it
/// receives exactly `pi L sin^2`, so the pixel is `ALBEDO * L * 1e-8`.
#[test]
fn pin_point_sphere_light_is_unbiased() {
    let ctx = gpu_or_skip!();
    let (h, emit) = (554.0, 5e7);
    let radius = h * 1e-4;
    let scene = direct_light_scene(
        h,
        emit,
        &format!(
            r#"
            [[objects]]
            type = "sphere"
            center = [0, {h}, 0]
            radius = {radius}
            material = "light"
            "#
        ),
    );
    let r = scene.shapes.spheres[0].radius as f64;
    let expected = ALBEDO * emit * (r / h).powi(2);
    let measured = mean_and_error(ctx, &scene);
    assert_agree(
        "pin-point sphere light (mixture vs analytic)",
        measured,
        (expected, 0.0),
        0.01,
    );
}

/// Mixture and cosine sampling of the same Cornell-box variant agree: cosine does
/// not use the light density, so a wrong density shows as a difference.
fn mixture_agrees_with_cosine(ctx: &GpuContext, what: &str, scene: &Scene, spp: (u32, u32)) {
    // Different seeds: the two estimates are independent.
    let run = |strategy, spp| {
        let seed = if strategy == Strategy::Mixture { 1 } else { 2 };
        let scene = overridden(
            with_strategy(scene, strategy, seed),
            SceneOverrides {
                spp: Some(spp),
                ..Default::default()
            },
        );
        let acc = common::render(ctx, &scene, &common::with_variance());
        common::image_mean_and_error(&acc)
    };
    assert_agree(
        &format!("{what} (mixture vs cosine)"),
        run(Strategy::Mixture, spp.0),
        run(Strategy::Bsdf, spp.1),
        0.01,
    );
}

/// The Cornell light grown to fill the whole ceiling, emission scaled down to keep
/// its power.
#[test]
fn ceiling_filling_light_mixture_agrees_with_cosine() {
    let ctx = gpu_or_skip!();
    let mut scene = cornell_boxes(16, 1);
    let i = light_quad(&scene);
    let area = scene.shapes.quads[i]
        .u
        .cross(scene.shapes.quads[i].v)
        .length();
    scene.shapes.quads[i].q = Vec3::new(0.0, 554.0, 0.0);
    scene.shapes.quads[i].u = Vec3::new(555.0, 0.0, 0.0);
    scene.shapes.quads[i].v = Vec3::new(0.0, 0.0, 555.0);
    let m = material(&scene, "light") as usize;
    scene.materials[m].emit *= area / (555.0 * 555.0);
    mixture_agrees_with_cosine(ctx, "ceiling-filling light", &scene, (256, 256));
}

/// The light hangs from the ceiling almost vertically (0.01 degree off), facing the
/// camera and slightly down: the floor below it and the ceiling beside it see it
/// nearly edge-on, where its solid-angle density `d^2 / (|cos| A)` is huge.
#[test]
fn grazing_light_mixture_agrees_with_cosine() {
    let ctx = gpu_or_skip!();
    let mut scene = cornell_boxes(16, 1);
    let i = light_quad(&scene);
    let tilt = 0.01f32.to_radians();
    let (length, hinge_z) = (200.0, 280.0);
    scene.shapes.quads[i].q = Vec3::new(213.0, 554.0, hinge_z);
    scene.shapes.quads[i].u = Vec3::new(130.0, 0.0, 0.0);
    scene.shapes.quads[i].v = length * Vec3::new(0.0, -tilt.cos(), tilt.sin());
    let normal = scene.shapes.quads[i]
        .u
        .cross(scene.shapes.quads[i].v)
        .normalize();
    assert!(normal.z < -0.99 && normal.y < 0.0, "{normal}");
    mixture_agrees_with_cosine(ctx, "grazing light", &scene, (256, 256));
}

/// The light in mid-air facing up: the floor and the box tops below see only its
/// back, and the faces turned away from it have it behind them.
#[test]
fn light_facing_away_mixture_agrees_with_cosine() {
    let ctx = gpu_or_skip!();
    let mut scene = cornell_boxes(16, 1);
    let i = light_quad(&scene);
    let quad = &mut scene.shapes.quads[i];
    quad.q.y = 400.0;
    std::mem::swap(&mut quad.u, &mut quad.v);
    assert!(quad.u.cross(quad.v).y > 0.0);
    mixture_agrees_with_cosine(ctx, "light facing away", &scene, (1024, 4096));
}

// ---------------------------------------------------------------------------------
// 3. Depth and size extremes

/// Projected area of the Cornell light as a fraction of the image (perspective
/// maps the quad to a quadrilateral; shoelace formula).
fn projected_fraction(scene: &Scene, corners: [Vec3; 4]) -> f64 {
    let c = &scene.camera;
    let w = (c.lookfrom - c.lookat).normalize();
    let u = c.vup.cross(w).normalize();
    let v = w.cross(u);
    let half_height = (c.vfov_degrees.to_radians() / 2.0).tan() as f64;
    let half_width = half_height * c.width as f64 / c.height as f64;
    let points: Vec<(f64, f64)> = corners
        .iter()
        .map(|&p| {
            let d = p - c.lookfrom;
            let depth = -d.dot(w) as f64;
            (d.dot(u) as f64 / depth, d.dot(v) as f64 / depth)
        })
        .collect();
    let mut twice_area = 0.0;
    for k in 0..4 {
        let (p, q) = (points[k], points[(k + 1) % 4]);
        twice_area += p.0 * q.1 - q.0 * p.1;
    }
    (twice_area / 2.0).abs() / (4.0 * half_width * half_height)
}

/// Depth 0 shows emission only: the Cornell box is black but for its light, whose
/// pixels are grey (15, 15, 15 times the covered fraction), and the image mean is
/// 15 times the light's projected area within `K_SIGMA` standard errors.
#[test]
fn depth_zero_shows_only_the_light() {
    let ctx = gpu_or_skip!();
    let scene = overridden(
        cornell_boxes(64, 32),
        SceneOverrides {
            max_depth: Some(0),
            ..Default::default()
        },
    );
    let acc = common::render(ctx, &scene, &common::with_variance());
    let mean = acc.mean();
    let lit = mean.pixels.iter().filter(|p| p[0] > 0.0).count();
    assert!(
        mean.pixels
            .iter()
            .all(|p| p[0] == p[1] && p[1] == p[2] && p[0] <= 15.0),
        "a pixel that is not the light's grey"
    );
    assert!(mean.pixels.iter().any(|p| p[0] == 15.0));
    let q = scene.shapes.quads[light_quad(&scene)];
    let expected = 15.0 * projected_fraction(&scene, [q.q, q.q + q.u, q.q + q.u + q.v, q.q + q.v]);
    eprintln!("depth 0: {lit} of {} pixels lit", mean.pixels.len());
    assert_agree(
        "depth 0 (image vs projected light)",
        common::image_mean_and_error(&acc),
        (expected, 0.0),
        0.05,
    );
}

/// Depth 1 lies strictly between depth 0 and depth 50; depth 1000 is finite and
/// equals depth 50 within `K_SIGMA` standard errors (paths this long carry
/// 0.73^50 of the light), and with the same seed at least 99% of the pixels are
/// bit-identical.
#[test]
fn depths_one_and_one_thousand_are_finite_and_consistent() {
    let ctx = gpu_or_skip!();
    let depth = |d: u32| {
        let scene = overridden(
            cornell_boxes(16, 64),
            SceneOverrides {
                max_depth: Some(d),
                ..Default::default()
            },
        );

        common::render(ctx, &scene, &common::with_variance())
    };
    let (zero, one, fifty, thousand) = (depth(0), depth(1), depth(50), depth(1000));
    let m = |acc: &Accumulation| common::image_mean_and_error(acc);
    eprintln!(
        "image means: depth 0 {:.4}, 1 {:.4}, 50 {:.4}, 1000 {:.4}",
        m(&zero).0,
        m(&one).0,
        m(&fifty).0,
        m(&thousand).0
    );
    assert!(m(&zero).0 < m(&one).0 && m(&one).0 < m(&fifty).0);
    let fifty_mean = m(&fifty);
    assert!(
        (m(&thousand).0 - fifty_mean.0).abs() <= K_SIGMA * fifty_mean.1,
        "depth 1000 {:?} vs depth 50 {fifty_mean:?}",
        m(&thousand)
    );
    // Same seed: a pixel changes only if one of its paths survived 50 bounces.
    let identical = (fifty.sum.iter().zip(&thousand.sum))
        .filter(|(a, b)| a == b)
        .count();
    eprintln!(
        "depth 50 vs 1000, same seed: {identical} of {} pixels identical",
        fifty.sum.len()
    );
    assert!(identical as f64 >= 0.99 * fifty.sum.len() as f64);
}

/// One sample per pixel renders finite values (and has no variance estimate).
#[test]
fn one_sample_per_pixel_renders() {
    let ctx = gpu_or_skip!();
    let acc = common::render(ctx, &cornell_boxes(32, 1), &common::with_variance());
    assert_eq!(acc.samples, 1);
    assert!(acc.sum.iter().any(|p| p[0] > 0.0), "the image is black");
    assert!(acc.standard_error().is_none());
}

/// Images of 1x1, 1x4096 and 4096x1 pixels render finite values. The 4096x1
/// image spans nearly 180 degrees across: only its two middle pixels (36 degrees
/// each) look into the box (19 degrees either side of the view axis); every other
/// ray escapes to the black background.
#[test]
fn extreme_image_shapes_render() {
    let ctx = gpu_or_skip!();
    for (width, height) in [(1, 1), (1, 4096), (4096, 1)] {
        let scene = overridden(
            cornell_boxes(1, 8),
            SceneOverrides {
                width: Some(width),
                height: Some(height),
                ..Default::default()
            },
        );
        let acc = common::render(ctx, &scene, &RenderOptions::default());
        assert_eq!((acc.width, acc.height, acc.samples), (width, height, 8));
        assert_eq!(acc.sum.len(), (width * height) as usize);
        let lit: Vec<usize> = (0..acc.sum.len())
            .filter(|&i| acc.sum[i][0] > 0.0)
            .collect();
        eprintln!("{width}x{height}: {} pixels lit", lit.len());
        match (width, height) {
            (4096, 1) => assert_eq!(lit, [2047, 2048]),
            _ => assert!(!lit.is_empty(), "{width}x{height} is black"),
        }
    }
}

/// An image one pixel taller than the adapter's largest texture renders with the
/// buffer accumulator (and the texture accumulator refuses it).
#[test]
fn image_taller_than_the_largest_texture_uses_the_buffer() {
    let ctx = gpu_or_skip!();
    let height = ctx.limits().max_texture_dimension_2d + 1;
    if height > 65536 {
        eprintln!(
            "largest texture side {} > the scene limit: skipped",
            height - 1
        );
        return;
    }
    let scene = overridden(
        cornell_boxes(1, 1),
        SceneOverrides {
            height: Some(height),
            max_depth: Some(4),
            ..Default::default()
        },
    );
    let renderer = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    assert_eq!(renderer.config().accumulator, AccumulatorKind::Buffer);
    drop(renderer);
    let acc = common::render(ctx, &scene, &RenderOptions::default());
    assert_eq!((acc.width, acc.height), (1, height));
    assert!(acc.sum.iter().any(|p| p[0] > 0.0), "the image is black");
    if ctx.storage_texture_accumulator {
        let texture = RenderOptions {
            accumulator: Some(AccumulatorKind::Texture),
            ..Default::default()
        };
        match Renderer::new(ctx, &scene, &texture) {
            Err(e @ RenderError::TextureTooLarge { .. }) => {
                let message = e.to_string();
                assert!(message.contains("largest texture"), "{message}")
            }
            _ => panic!("the texture accumulator accepted 1x{height}"),
        }
    }
}

/// A white floor under a sky: nothing emits, nothing is marked for importance.
fn scene_without_emitters(strategy: &str) -> Scene {
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 1, -3]
        lookat = [0, 0, 0]
        width = 16
        height = 16
        [render]
        spp = 8
        strategy = "{strategy}"
        background = [0.5, 0.7, 1.0]
        [materials.white]
        type = "lambertian"
        albedo = [0.73, 0.73, 0.73]
        [[objects]]
        type = "quad"
        q = [-5, 0, -5]
        u = [0, 0, 10]
        v = [10, 0, 0]
        material = "white"
        "#
    ))
}

/// With nothing to aim at, mixture renders as cosine (the same image, bit for
/// bit) with a warning, and `light` is refused with a message that says why.
#[test]
fn scene_without_emitters_falls_back_to_cosine_or_is_refused() {
    let ctx = gpu_or_skip!();
    let mixture = scene_without_emitters("mixture");
    let renderer = Renderer::new(ctx, &mixture, &RenderOptions::default()).unwrap();
    assert_eq!(renderer.config().strategy, Strategy::Bsdf);
    assert!(
        renderer
            .warnings
            .iter()
            .any(|w| w.contains("test.toml") && w.contains("falls back to bsdf")),
        "{:?}",
        renderer.warnings
    );
    drop(renderer);
    let acc = common::render(ctx, &mixture, &RenderOptions::default());
    assert!(acc.sum.iter().any(|p| p[0] > 0.0));
    let cosine = common::render(
        ctx,
        &scene_without_emitters("cosine"),
        &RenderOptions::default(),
    );
    assert!(acc == cosine, "mixture without lights differs from cosine");

    match Renderer::new(
        ctx,
        &scene_without_emitters("light"),
        &RenderOptions::default(),
    ) {
        Err(e @ RenderError::LightStrategyWithoutTargets { .. }) => {
            let message = e.to_string();
            assert!(
                message.contains("test.toml") && message.contains("`light`"),
                "{message}"
            )
        }
        Err(e) => panic!("unexpected error: {e}"),
        Ok(_) => panic!("strategy `light` accepted a scene without emitters"),
    }
}

// ---------------------------------------------------------------------------------
// 4. Index-matched dielectric

/// The glass sphere of cornell.toml with ior 1 bends nothing: unmarked, the image is
/// bit-identical to the box without it; marked for importance (still sampled by
/// the light density), the image mean agrees within `K_SIGMA` standard errors.
#[test]
fn dielectric_with_ior_one_is_invisible() {
    let ctx = gpu_or_skip!();
    let scene = overridden(
        common::scene_file("cornell.toml"),
        SceneOverrides {
            width: Some(16),
            height: Some(16),
            spp: Some(512),
            ..Default::default()
        },
    );
    let glass = material(&scene, "glass") as usize;
    let mut index_matched = scene.clone();
    index_matched.materials[glass].kind = MaterialKind::Dielectric { ior: 1.0 };
    assert!(index_matched.shapes.spheres[0].importance);
    let mut without_sphere = scene.clone();
    without_sphere.shapes.spheres.clear();
    let mut unmarked = index_matched.clone();
    unmarked.shapes.spheres[0].importance = false;

    let options = common::with_variance();
    let reference = common::render(ctx, &without_sphere, &options);
    let plain = common::render(ctx, &unmarked, &options);
    assert!(plain == reference, "an ior-1 sphere changed the image");

    let marked = common::render(
        ctx,
        &with_strategy(&index_matched, Strategy::Mixture, 5),
        &options,
    );
    assert_agree(
        "ior-1 sphere in the light density vs no sphere",
        common::image_mean_and_error(&marked),
        common::image_mean_and_error(&reference),
        0.02,
    );
}

// ---------------------------------------------------------------------------------
// 5. Guards on every shipped scene

/// Every scene in `scenes/`, small, under every strategy: no sample is NaN or
/// infinite and no invocation is cut short.
#[test]
fn shipped_scenes_never_trip_the_guards() {
    let ctx = gpu_or_skip!();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 3);
    for path in paths {
        for strategy in Strategy::ALL {
            let scene = overridden(
                Scene::load(&path).unwrap(),
                SceneOverrides {
                    width: Some(16),
                    height: Some(16),
                    spp: Some(8),
                    strategy: Some(strategy),
                    ..Default::default()
                },
            );
            // `common::render` asserts both guard counters are zero.
            common::render(ctx, &scene, &RenderOptions::default());
        }
    }
}
