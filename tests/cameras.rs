//! The cameras against what their geometry predicts: the thin lens's depth of
//! field (Mitsuba's `thinlens`) and the orthographic view's scale (Mitsuba's
//! `orthographic`).

mod common;

use pathmix::render::RenderOptions;
use pathmix::stats::Accumulation;
use std::f64::consts::PI;

/// Columns and rows of the edge images.
const WIDTH: u32 = 64;
const HEIGHT: u32 = 4;

/// A camera at the origin looking down -z (the image's right is +x) whose
/// pixels are `pixel` wide on the plane `depth` ahead, with `lens` (extra
/// `[camera]` keys), seeing at depth 0 an emitter of radiance 1 that covers
/// the half x > `edge` of the plane z = -`depth`.
fn edge_scene(depth: f64, pixel: f64, edge: f64, lens: &str, spp: u32) -> pathmix::scene::Scene {
    let vfov = 2.0 * (pixel * HEIGHT as f64 / (2.0 * depth)).atan().to_degrees();
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, -1]
        vfov = {vfov}
        width = {WIDTH}
        height = {HEIGHT}
        {lens}
        [render]
        spp = {spp}
        max_depth = 0
        [materials.glow]
        type = "light"
        emit = [1, 1, 1]
        [[objects]]
        type = "quad"
        q = [{edge}, -50, -{depth}]
        u = [100, 0, 0]
        v = [0, 100, 0]
        material = "glow"
        "#
    ))
}

/// Each column's mean over the rows and channels.
fn profile(acc: &Accumulation) -> Vec<f64> {
    let image = acc.mean();
    (0..WIDTH as usize)
        .map(|x| {
            let column = (0..HEIGHT as usize).map(|y| image.pixels[y * WIDTH as usize + x]);
            column.flatten().map(f64::from).sum::<f64>() / (3 * HEIGHT) as f64
        })
        .collect()
}

/// Columns strictly between dark and lit: the edge's width in pixels.
fn edge_width(profile: &[f64]) -> usize {
    profile.iter().filter(|&&p| p > 0.01 && p < 0.99).count()
}

/// The lit fraction of a disk of radius 1 whose centre is `t` radii on the lit
/// side of a straight edge.
fn lit_fraction(t: f64) -> f64 {
    let t = t.clamp(-1.0, 1.0);
    0.5 + (t * (1.0 - t * t).sqrt() + t.asin()) / PI
}

/// Aperture 0 is the pinhole, bit for bit: the same kernel, the same samples.
#[test]
fn zero_aperture_is_the_pinhole_bit_for_bit() {
    let ctx = gpu_or_skip!();
    let pinhole = common::render(
        ctx,
        &edge_scene(3.0, 0.01, 0.003, "", 16),
        &RenderOptions::default(),
    );
    let lens = "aperture_radius = 0\nfocus_distance = 2";
    let zero = common::render(
        ctx,
        &edge_scene(3.0, 0.01, 0.003, lens, 16),
        &RenderOptions::default(),
    );
    let bits = |acc: &Accumulation| -> Vec<u64> {
        acc.sum.iter().flatten().map(|v| v.to_bits()).collect()
    };
    assert_eq!(bits(&pinhole), bits(&zero));
}

/// A thin lens of radius A focused at f: a straight edge on the plane in focus
/// stays as sharp as the pinhole sees it (one column between dark and lit, the
/// same value), while on the plane at depth z each pixel averages the disk of
/// radius A |z - f| / f (the circle of confusion on that plane) about where the
/// pinhole ray meets it: the profile across the edge is the disk's lit
/// fraction, averaged over the pixel's width.
#[test]
fn thin_lens_blurs_by_the_circle_of_confusion() {
    let ctx = gpu_or_skip!();
    let (aperture, focus) = (0.1f64, 2.0f64);
    let lens = format!("aperture_radius = {aperture}\nfocus_distance = {focus}");
    let spp = 1024;

    // In focus: the edge a quarter of a pixel into column 32 (0.75 of it lit).
    let pixel = 0.01;
    let edge = 0.25 * pixel;
    let sharp = profile(&common::render(
        ctx,
        &edge_scene(focus, pixel, edge, "", spp),
        &RenderOptions::default(),
    ));
    let focused = profile(&common::render(
        ctx,
        &edge_scene(focus, pixel, edge, &lens, spp),
        &RenderOptions::default(),
    ));
    assert_eq!(edge_width(&sharp), 1, "{sharp:?}");
    assert_eq!(edge_width(&focused), 1, "{focused:?}");
    for (x, (a, b)) in sharp.iter().zip(&focused).enumerate() {
        assert!(
            (a - b).abs() < 0.01,
            "column {x}: pinhole {a}, lens in focus {b}"
        );
    }

    // Twice as far: the circle of confusion's radius A (z - f) / f = 0.1 on
    // that plane, 8 pixels of 0.0125.
    let depth = 4.0;
    let pixel = 0.0125;
    let radius = aperture * (depth - focus) / focus;
    let blurred = profile(&common::render(
        ctx,
        &edge_scene(depth, pixel, edge, &lens, spp),
        &RenderOptions::default(),
    ));
    let expected: Vec<f64> = (0..WIDTH)
        .map(|x| {
            // The pixel's box filter: its width in 64 steps.
            let steps = 64;
            (0..steps)
                .map(|s| {
                    let at =
                        (x as f64 + (s as f64 + 0.5) / steps as f64 - WIDTH as f64 / 2.0) * pixel;
                    lit_fraction((at - edge) / radius)
                })
                .sum::<f64>()
                / steps as f64
        })
        .collect();
    // 4096 samples a column (Sobol: far less noise than the 0.008 of
    // independent ones); a circle half or 1.5 times as wide is off by 0.1 and more.
    for (x, (got, want)) in blurred.iter().zip(&expected).enumerate() {
        assert!(
            (got - want).abs() < 0.02,
            "column {x}: {got} against {want}\n{blurred:?}"
        );
    }
    let predicted = edge_width(&expected);
    let measured = edge_width(&blurred);
    println!("edge width: {measured} columns, predicted {predicted} (circle of 16 columns across)");
    assert!(
        measured.abs_diff(predicted) <= 1,
        "{measured} against {predicted}"
    );
}

/// A Lambertian plane under a uniform sky has the same radiance from every
/// point and direction, so every pixel is albedo × sky through any lens: the
/// lens sample's weight is 1 (a thin lens conserves the irradiance of a plane
/// filling the view), near the focus and far out of it (the plane is tilted).
#[test]
fn thin_lens_conserves_a_uniform_plane_s_radiance() {
    let ctx = gpu_or_skip!();
    for lens in ["", "aperture_radius = 0.5\nfocus_distance = 3"] {
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 0, 0]
            lookat = [0, 0, -1]
            vfov = 30
            width = 16
            height = 16
            {lens}
            [render]
            spp = 64
            max_depth = 1
            background = [1, 1, 1]
            [materials.floor]
            type = "lambertian"
            albedo = [0.5, 0.5, 0.5]
            [[objects]]
            type = "quad"
            q = [-100, -100, -2]
            u = [200, 0, -100]
            v = [0, 200, 0]
            material = "floor"
            "#
        ));
        let acc = common::render(ctx, &scene, &RenderOptions::default());
        common::assert_every_pixel_is(&acc, 0.5, 1e-6, lens);
    }
}

/// Seen orthographically, a sphere of radius r covers pi r^2 of the view
/// whatever its distance: the lit pixels of an emitting sphere, times the
/// pixel's area, within 1% (at 1/32 of the radius a pixel, the boundary's
/// pixels are about 6% of the disk's, each counted when more than half lit).
/// A perspective view at these distances would show it 1 and 1/10 as large.
#[test]
fn orthographic_view_shows_a_sphere_at_its_size_at_any_distance() {
    let ctx = gpu_or_skip!();
    let (radius, view_width, side) = (1.0f64, 4.0f64, 128u32);
    for distance in [2.0f64, 20.0] {
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 0, {distance}]
            lookat = [0, 0, 0]
            projection = "orthographic"
            view_width = {view_width}
            width = {side}
            height = {side}
            [render]
            spp = 16
            max_depth = 0
            [materials.glow]
            type = "light"
            emit = [1, 1, 1]
            [[objects]]
            type = "sphere"
            center = [0.3, -0.2, 0]
            radius = {radius}
            material = "glow"
            "#
        ));
        let acc = common::render(ctx, &scene, &RenderOptions::default());
        let lit = acc.mean().pixels.iter().filter(|p| p[0] > 0.5).count();
        let pixel = view_width / side as f64;
        let area = lit as f64 * pixel * pixel;
        let expected = PI * radius * radius;
        println!("distance {distance}: {lit} pixels, area {area:.4} against {expected:.4}");
        assert!(
            (area / expected - 1.0).abs() < 0.01,
            "distance {distance}: {area} against {expected}"
        );
    }
}
