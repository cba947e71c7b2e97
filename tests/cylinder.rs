//! The `cylinder` shape on the device: what a camera sees of its sides, a white
//! furnace, and as a light, the irradiance it gives under every strategy
//! against the analytic value (its sampling and density unbiased).

mod common;

use pathmix::render::RenderOptions;

/// A camera at `lookfrom` looking at `lookat` through a 2-degree view, depth 0,
/// at a cylinder emitting 3: every pixel sees the cylinder.
fn seen(lookfrom: &str, lookat: &str, cylinder: &str) -> pathmix::scene::Scene {
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = {lookfrom}
        lookat = {lookat}
        vfov = 2
        width = 4
        height = 4
        [render]
        spp = 4
        max_depth = 0
        [materials.glow]
        type = "light"
        emit = [3, 3, 3]
        [[objects]]
        type = "cylinder"
        material = "glow"
        {cylinder}
        "#
    ))
}

/// Seen from outside its side shows its outer face, from inside its inner one: an emitter emits on its normal's side only, as Mitsuba's area
/// emitter, and `flip_normals` turns that side inward.
#[test]
fn an_emitting_cylinder_shows_its_radiance_on_its_normals_side_only() {
    let ctx = gpu_or_skip!();
    let axis_y = "p0 = [0, -1, 0]\np1 = [0, 1, 0]\nradius = 1";
    for (flip, from_side, expected) in [
        (false, true, 3.0),
        (false, false, 0.0),
        (true, true, 0.0),
        (true, false, 3.0),
    ] {
        // From inside, on the axis, looking at the wall.
        let (lookfrom, lookat) = match from_side {
            true => ("[0, 0, -5]", "[0, 0, 0]"),
            false => ("[0, 0, 0]", "[0, 0, 1]"),
        };
        let scene = seen(
            lookfrom,
            lookat,
            &format!("{axis_y}\nflip_normals = {flip}"),
        );
        let acc = common::render(ctx, &scene, &RenderOptions::default());
        let what = format!("flip_normals = {flip}, from the side: {from_side}");
        for pixel in acc.mean().pixels {
            for channel in pixel {
                assert_eq!(channel, expected, "{what}");
            }
        }
    }
}

/// A white furnace: a two-sided white cylinder, open at both ends and in the
/// light density (its sampling and density then weigh the mixture's and
/// `nee-mis`'s directions), under a uniform background of 1, deep enough that
/// every path escapes: every pixel's expected value is the background.
#[test]
fn a_white_cylinder_in_a_furnace_vanishes() {
    let ctx = gpu_or_skip!();
    for strategy in ["bsdf", "mixture", "nee-mis"] {
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0.3, 3, -4]
            lookat = [0, 0, 0]
            vfov = 40
            width = 8
            height = 8
            [render]
            spp = 1024
            max_depth = 64
            strategy = "{strategy}"
            background = [1, 1, 1]
            [materials.white]
            type = "lambertian"
            albedo = [1, 1, 1]
            [[objects]]
            type = "cylinder"
            p0 = [0, -1, 0]
            p1 = [0, 1, 0.5]
            radius = 1
            importance = true
            material = "white"
            "#
        ));
        let acc = common::render(ctx, &scene, &common::with_variance());
        let (mean, error) = common::image_mean_and_error(&acc);
        println!("furnace {strategy}: {mean:.6} ± {error:.6}");
        assert!(
            (mean - 1.0).abs() < 4.0 * error + 1e-5,
            "furnace {strategy}: {mean} ± {error}"
        );
    }
}

/// Standing on the floor around the lit patch, normals flipped inward, a
/// cylinder of radius r and height h lights the patch at the centre of its
/// base with all of the hemisphere but its open top: the irradiance pi L (1 -
/// r^2 / (r^2 + h^2)). Its outward-facing twin, seen from inside, lights
/// nothing.
#[test]
fn a_cylinder_light_around_a_point_gives_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let (r, h, emit, albedo) = (1.5f64, 2.0f64, 2.0f64, 0.6f64);
    let expected = albedo * emit * h * h / (r * r + h * h);
    let cylinder = |flip: bool| {
        format!(
            "[[objects]]\ntype = \"cylinder\"\np0 = [0, 0, 0]\np1 = [0, {h}, 0]\nradius = {r}\n\
             flip_normals = {flip}\nmaterial = \"lamp\"\n"
        )
    };
    common::assert_lit_floor(
        ctx,
        (albedo, emit, 1.0),
        &cylinder(true),
        expected,
        "cylinder",
    );
    let lamp = format!("[materials.lamp]\ntype = \"light\"\nemit = [{emit}, {emit}, {emit}]\n");
    common::assert_floor_patch(
        ctx,
        (albedo, 1.0),
        &format!("{lamp}{}", cylinder(false)),
        (0.0, 1e-30),
        "outward cylinder",
    );
}

/// A horizontal cylinder light above the floor, seen from outside: a line
/// toward it meets it twice, so its light density sums both points. The
/// expected irradiance is integrated here over the part of its side that
/// faces the patch (the rest, and the inside, are hidden).
#[test]
fn a_cylinder_light_above_a_floor_gives_the_integrated_irradiance() {
    let ctx = gpu_or_skip!();
    let (r, height, half, emit, albedo) = (0.5f64, 1.5f64, 2.0f64, 2.0f64, 0.6f64);
    // E = L ∫ cos(floor) cos(light) / d^2 dA over the side, midpoint rule.
    let (n_phi, n_x) = (2000, 2000);
    let mut irradiance = 0.0;
    for i in 0..n_phi {
        let phi = (i as f64 + 0.5) / n_phi as f64 * std::f64::consts::TAU;
        let normal = [0.0, phi.cos(), phi.sin()];
        for j in 0..n_x {
            let x = -half + (j as f64 + 0.5) / n_x as f64 * 2.0 * half;
            let p = [x, height + r * normal[1], r * normal[2]];
            let d2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
            let d = d2.sqrt();
            let cos_floor = p[1] / d;
            let cos_light = -(normal[1] * p[1] + normal[2] * p[2]) / d;
            if cos_floor > 0.0 && cos_light > 0.0 {
                irradiance += cos_floor * cos_light / d2;
            }
        }
    }
    irradiance *= emit * (std::f64::consts::TAU * r / n_phi as f64) * (2.0 * half / n_x as f64);
    let expected = albedo / std::f64::consts::PI * irradiance;
    let cylinder = format!(
        "[[objects]]\ntype = \"cylinder\"\np0 = [{}, {height}, 0]\np1 = [{half}, {height}, 0]\n\
         radius = {r}\nmaterial = \"lamp\"\n",
        -half
    );
    // The camera below the cylinder's lowest line, y = 1.
    common::assert_lit_floor(
        ctx,
        (albedo, emit, 0.5),
        &cylinder,
        expected,
        "cylinder above",
    );
}
