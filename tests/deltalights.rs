//! Point, spot and directional lights (delta lights, estimated by shadow rays
//! under every strategy) and the `thindielectric` and `smoothdielectric` materials, against
//! analytic answers.

mod common;

use pathmix::render::RenderOptions;
use pathmix::stats::Accumulation;
use std::f64::consts::PI;

/// Per channel: the image's mean and its standard error from the per-pixel
/// sample variances (pixels are independent).
fn channel_means_and_errors(acc: &Accumulation) -> [(f64, f64); 3] {
    let n = acc.samples as f64;
    let sum_sq = acc.sum_sq.as_ref().expect("render with variance");
    let pixels = acc.sum.len() as f64;
    let mut out = [(0.0, 0.0); 3];
    for (sum, sq) in acc.sum.iter().zip(sum_sq) {
        for (c, (mean, variance)) in out.iter_mut().enumerate() {
            let m = sum[c] / n;
            *mean += m / pixels;
            *variance += (sq[c] - n * m * m).max(0.0) / (n - 1.0) / n / (pixels * pixels);
        }
    }
    out.map(|(mean, variance)| (mean, variance.sqrt()))
}

/// A diffuse floor of albedo a lit by two point lights and a disk light: straight
/// below the camera it reflects a/pi times the irradiance, sum over the point lights
/// of I cos / d^2, plus the disk's a L r^2 / (r^2 + h^2). Under every strategy:
/// the point lights by their shadow rays (picked by power), the disk by the strategy.
#[test]
fn point_lights_give_the_analytic_irradiance_under_every_strategy() {
    let ctx = gpu_or_skip!();
    let (r, h, emit, albedo) = (0.5f64, 2.0f64, 4.0f64, 0.6f64);
    let points = [([1.5f64, 1.0, 0.0], 3.0f64), ([-1.0, 2.0, 0.5], 1.0)];
    let irradiance: f64 = points
        .iter()
        .map(|&(p, i)| {
            let d2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
            i * (p[1] / d2.sqrt()) / d2
        })
        .sum();
    let expected = albedo / PI * irradiance + albedo * emit * r * r / (r * r + h * h);
    let lights = format!(
        "[[objects]]\ntype = \"disk\"\ncenter = [0, {h}, 0]\nu = [{r}, 0, 0]\nv = [0, 0, {r}]\n\
         material = \"lamp\"\n\
         [[lights]]\ntype = \"point\"\nposition = {:?}\nintensity = {}\n\
         [[lights]]\ntype = \"point\"\nposition = {:?}\nintensity = [{i}, {i}, {i}]\n",
        points[0].0,
        points[0].1,
        points[1].0,
        i = points[1].1,
    );
    common::assert_lit_floor(ctx, (albedo, emit, 1.0), &lights, expected, "points");
}

/// Mitsuba's `falloff_curve` (spot.cpp), written out: 1 within the beam width, 0
/// at and past the cutoff, (cutoff - theta) / (cutoff - beam width) between.
fn mitsuba_falloff(theta_degrees: f64, cutoff_degrees: f64, beam_degrees: f64) -> f64 {
    let (theta, cutoff, beam) = (
        theta_degrees.to_radians(),
        cutoff_degrees.to_radians(),
        beam_degrees.to_radians(),
    );
    if theta.cos() <= cutoff.cos() {
        0.0
    } else if theta.cos() >= beam.cos() {
        1.0
    } else {
        (cutoff - theta) / (cutoff - beam)
    }
}

/// A spot light 1 above a diffuse floor, its axis tilted by theta from the
/// floor point below it: that point reflects a/pi I falloff(theta), with theta
/// inside the beam, in the falloff and past the cutoff (default and given widths).
#[test]
fn spot_light_falls_off_as_mitsuba_s() {
    let ctx = gpu_or_skip!();
    let (albedo, intensity) = (0.5f64, 2.0f64);
    for (theta, cutoff, beam) in [
        (5.0f64, None, None),
        (17.0, None, None),
        (19.0, None, None),
        (25.0, None, None),
        (40.0, Some(60.0), Some(10.0)),
        (59.0, Some(60.0), Some(10.0)),
    ] {
        let (sin, cos) = theta.to_radians().sin_cos();
        let mut cone = String::new();
        if let Some(c) = cutoff {
            cone += &format!("cutoff_angle = {c}\n");
        }
        if let Some(b) = beam {
            cone += &format!("beam_width = {b}\n");
        }
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 1, 0]
            lookat = [0, 0, 0]
            vup = [0, 0, -1]
            vfov = 0.001
            width = 2
            height = 2
            [render]
            spp = 16
            max_depth = 1
            strategy = "bsdf"
            [materials.floor]
            type = "lambertian"
            albedo = [{albedo}, {albedo}, {albedo}]
            [[objects]]
            type = "quad"
            q = [-10, 0, -10]
            u = [0, 0, 20]
            v = [20, 0, 0]
            material = "floor"
            [[lights]]
            type = "spot"
            position = [0, 1, 0]
            intensity = {intensity}
            direction = [{sin}, {}, 0]
            {cone}
            "#,
            -cos
        ));
        let expected = albedo / PI
            * intensity
            * mitsuba_falloff(
                theta,
                cutoff.unwrap_or(20.0),
                beam.unwrap_or(cutoff.unwrap_or(20.0) * 0.75),
            );
        let acc = common::render(ctx, &scene, &RenderOptions::default());
        // The estimate is exact but for f32 rounding and the device's acos in the
        // falloff (measured: 3e-5 rad off on lavapipe, 3e-4 of the full value);
        // a wrong cone edge, width or slope is off by far more.
        for pixel in acc.mean().pixels {
            for channel in pixel {
                let channel = channel as f64;
                assert!(
                    (channel - expected).abs() <= 1e-3 * albedo / PI * intensity,
                    "theta {theta}: {channel} against {expected}"
                );
            }
        }
    }
}

/// The unpolarised Fresnel reflectance of a dielectric interface of relative
/// index eta at incidence cosine c (no total internal reflection here).
fn fresnel(c: f64, eta: f64) -> f64 {
    let t = (1.0 - (1.0 - c * c) / (eta * eta)).sqrt();
    let rs = (c - eta * t) / (c + eta * t);
    let rp = (t - eta * c) / (t + eta * c);
    0.5 * (rs * rs + rp * rp)
}

/// A quad of `material` (a `[materials.*]` table's body) at 60 degrees to a
/// narrow view, centred 5 down it: its normal (sin 60, 0, cos 60), edges 2
/// long. A red emitter of `emit` lies behind it (the square of side `red_side`
/// about the view at z = -20, to catch what passes straight or bent), a green
/// one where the quad mirrors the view; one scattering event, 8192 independent
/// samples.
fn interface_at_60_degrees(material: &str, emit: f64, red_side: f64) -> pathmix::scene::Scene {
    let (sin60, cos60) = (3f64.sqrt() / 2.0, 0.5);
    let u = [0.0, 2.0, 0.0];
    let v = [-2.0 * cos60, 0.0, 2.0 * sin60];
    let q = [
        -(u[0] + v[0]) / 2.0,
        -(u[1] + v[1]) / 2.0,
        -5.0 - (u[2] + v[2]) / 2.0,
    ];
    let half = red_side / 2.0;
    common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, -1]
        vfov = 0.5
        width = 4
        height = 4
        [render]
        spp = 8192
        max_depth = 1
        sampler = "independent"
        [materials.interface]
        {material}
        [materials.red]
        type = "light"
        emit = [{emit}, 0, 0]
        [materials.green]
        type = "light"
        emit = [0, {emit}, 0]
        [[objects]]
        type = "quad"
        q = {q:?}
        u = {u:?}
        v = {v:?}
        material = "interface"
        [[objects]]
        type = "quad"
        q = [-{half}, -{half}, -20]
        u = [{red_side}, 0, 0]
        v = [0, {red_side}, 0]
        material = "red"
        [[objects]]
        type = "quad"
        q = [10, -20, -30]
        u = [0, 0, 40]
        v = [0, 40, 0]
        material = "green"
        "#
    ))
}

/// A thin slab at 60 degrees to the view, a red emitter straight behind it and a
/// green one where it mirrors the view: red shows the transmitted 1 - R', green
/// the reflected R' = 2R / (1 + R) (every bounce inside the slab summed), R the
/// exact Fresnel reflectance of one interface.
#[test]
fn thindielectric_slab_transmits_and_reflects_the_analytic_fractions() {
    let ctx = gpu_or_skip!();
    let (eta, emit) = (1.5f64, 2.0f64);
    let r = fresnel(0.5, eta);
    let slab = 2.0 * r / (1.0 + r);
    let scene = interface_at_60_degrees(
        &format!("type = \"thindielectric\"\nint_ior = {eta}\next_ior = 1"),
        emit,
        10.0,
    );
    let acc = common::render(ctx, &scene, &common::with_variance());
    let [(red, red_error), (green, green_error), (blue, _)] = channel_means_and_errors(&acc);
    let (expected_red, expected_green) = (emit * (1.0 - slab), emit * slab);
    println!(
        "R' = {slab:.6}: red {red:.5} ± {red_error:.5} (expected {expected_red:.5}), \
         green {green:.5} ± {green_error:.5} (expected {expected_green:.5})"
    );
    assert!((red - expected_red).abs() < 4.0 * red_error + 1e-6);
    assert!((green - expected_green).abs() < 4.0 * green_error + 1e-6);
    assert_eq!(blue, 0.0);
    // Schlick's approximation, which the book's glass uses, would be caught.
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let schlick = r0 + (1.0 - r0) * 0.5f64.powi(5);
    let schlick_slab = 2.0 * schlick / (1.0 + schlick);
    assert!((emit * schlick_slab - expected_green).abs() > 8.0 * green_error);
}

/// One smooth interface at 60 degrees to the view (into glass of index 1.5), a
/// red emitter behind it where the refracted rays go and a green one where it
/// mirrors the view: green shows the exact Fresnel reflectance R, red the rest
/// scaled by 1/eta^2 as radiance entering glass is (Mitsuba's `dielectric`).
#[test]
fn smoothdielectric_reflects_and_refracts_the_analytic_fractions() {
    let ctx = gpu_or_skip!();
    let (eta, emit) = (1.5f64, 2.0f64);
    let r = fresnel(0.5, eta);
    let scene = interface_at_60_degrees(
        &format!("type = \"smoothdielectric\"\nint_ior = {eta}\next_ior = 1"),
        emit,
        200.0,
    );
    let acc = common::render(ctx, &scene, &common::with_variance());
    let [(red, red_error), (green, green_error), (blue, _)] = channel_means_and_errors(&acc);
    let (expected_red, expected_green) = (emit * (1.0 - r) / (eta * eta), emit * r);
    println!(
        "R = {r:.6}: red {red:.5} ± {red_error:.5} (expected {expected_red:.5}), \
         green {green:.5} ± {green_error:.5} (expected {expected_green:.5})"
    );
    assert!((red - expected_red).abs() < 4.0 * red_error + 1e-6);
    assert!((green - expected_green).abs() < 4.0 * green_error + 1e-6);
    assert_eq!(blue, 0.0);
    // Schlick's approximation, which the book's glass uses, would be caught.
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let schlick = r0 + (1.0 - r0) * 0.5f64.powi(5);
    assert!((emit * schlick - expected_green).abs() > 8.0 * green_error);
}

/// A white furnace: a smoothdielectric sphere under a uniform sky of 1: what
/// enters is scaled by 1/eta^2 and what leaves by eta^2, and the sphere traps
/// nothing (a ray inside meets its surface at the angle it entered by, below
/// the critical one), so every pixel is 1.
#[test]
fn smoothdielectric_conserves_energy_in_a_furnace() {
    let ctx = gpu_or_skip!();
    let scene = common::scene_text(
        r#"
        [camera]
        lookfrom = [0, 0, 3]
        lookat = [0, 0, 0]
        vfov = 40
        width = 8
        height = 8
        [render]
        spp = 64
        max_depth = 100
        background = [1, 1, 1]
        [materials.glass]
        type = "smoothdielectric"
        int_ior = 1.7
        [[objects]]
        type = "sphere"
        center = [0, 0, 0]
        radius = 1
        material = "glass"
        "#,
    );
    let acc = common::render(ctx, &scene, &RenderOptions::default());
    common::assert_every_pixel_is(&acc, 1.0, 1e-5, "smoothdielectric furnace");
}

/// A white furnace: a thindielectric sphere (reflectance and transmittance 1)
/// under a uniform sky of 1 loses and adds nothing, so every pixel is exactly 1.
#[test]
fn thindielectric_conserves_energy_in_a_furnace() {
    let ctx = gpu_or_skip!();
    let scene = common::scene_text(
        r#"
        [camera]
        lookfrom = [0, 0, 3]
        lookat = [0, 0, 0]
        vfov = 40
        width = 8
        height = 8
        [render]
        spp = 64
        max_depth = 100
        background = [1, 1, 1]
        [materials.slab]
        type = "thindielectric"
        int_ior = 1.7
        [[objects]]
        type = "sphere"
        center = [0, 0, 0]
        radius = 1
        material = "slab"
        "#,
    );
    let acc = common::render(ctx, &scene, &RenderOptions::default());
    common::assert_every_pixel_is(&acc, 1.0, 1e-6, "thindielectric furnace");
}

/// Beyond `KernelConfig::MAX_DELTA_SHADOW_RAYS` lights each vertex picks one by
/// power: 72 point lights of unequal intensities over a diffuse floor still give
/// a/pi sum I cos / d^2 (within 4 standard errors).
#[test]
fn many_point_lights_picked_by_power_give_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let albedo = 0.5f64;
    let count = pathmix::kernel::KernelConfig::MAX_DELTA_SHADOW_RAYS + 8;
    let mut lights = String::new();
    let mut irradiance = 0.0;
    for i in 0..count {
        let angle = i as f64 * 2.399963;
        let radius = 0.5 + 0.05 * i as f64;
        let p = [
            radius * angle.cos(),
            1.0 + 0.02 * i as f64,
            radius * angle.sin(),
        ];
        let intensity = 0.2 + (i % 7) as f64 * 0.3;
        let d2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        irradiance += intensity * (p[1] / d2.sqrt()) / d2;
        lights +=
            &format!("[[lights]]\ntype = \"point\"\nposition = {p:?}\nintensity = {intensity}\n");
    }
    let expected = albedo / PI * irradiance;
    let scene = common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0.5, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 0.01
        width = 4
        height = 4
        [render]
        spp = 4096
        max_depth = 1
        sampler = "independent"
        [materials.floor]
        type = "lambertian"
        albedo = [{albedo}, {albedo}, {albedo}]
        [[objects]]
        type = "quad"
        q = [-10, 0, -10]
        u = [0, 0, 20]
        v = [20, 0, 0]
        material = "floor"
        {lights}
        "#
    ));
    let acc = common::render(ctx, &scene, &common::with_variance());
    let (mean, error) = common::image_mean_and_error(&acc);
    println!("{count} lights: {mean:.5} ± {error:.5}, expected {expected:.5}");
    assert!(error > 0.0, "picking one light per vertex is noisy");
    assert!(
        (mean - expected).abs() < 4.0 * error,
        "{mean} ± {error} against {expected}"
    );
}

/// A bad light exits with code 2 naming the file and the field, writing nothing.
#[test]
fn bad_lights_exit_2_naming_file_and_field() {
    let dir = common::TempDir::new("deltalights", "bad");
    let base = "[camera]\nlookfrom = [0, 1, -3]\nlookat = [0, 0, 0]\n[[lights]]\n";
    for (light, field, message) in [
        (
            "type = \"point\"\nposition = [0, 1, 0]\nintensity = [1, -1, 1]",
            "lights[0].intensity[1]",
            "must be >= 0",
        ),
        (
            "type = \"spot\"\nposition = [0, 1, 0]\nintensity = 1\ndirection = [0, -1, 0]\ncutoff_angle = 200",
            "lights[0].cutoff_angle",
            "must be in (0, 180) degrees",
        ),
    ] {
        let scene = dir.join("case.toml");
        std::fs::write(&scene, format!("{base}{light}\n")).unwrap();
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args(["render", scene.to_str().unwrap(), "-o"])
            .arg(dir.join("out.png"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        for part in ["case.toml", field, message] {
            assert!(stderr.contains(part), "{part:?} not in {stderr}");
        }
        assert!(!dir.join("out.png").exists());
    }
}

/// A Lambertian floor of albedo a under a directional light of irradiance E
/// at the angle theta from its normal has the radiance a E cos(theta) / pi,
/// under every strategy, whatever the scene's size (a far-off sphere widens it).
#[test]
fn directional_light_gives_its_irradiance_times_the_cosine() {
    let ctx = gpu_or_skip!();
    let (albedo, irradiance, theta) = (0.6f64, 3.0f64, 35.0f64);
    let (sin, cos) = theta.to_radians().sin_cos();
    let lights = format!(
        "[materials.dark]\ntype = \"lambertian\"\nalbedo = [0, 0, 0]\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [500, 900, 0]\nradius = 1\nmaterial = \"dark\"\n\
         [[lights]]\ntype = \"directional\"\ndirection = [{sin}, {}, 0]\nirradiance = {irradiance}\n",
        -cos
    );
    let expected = albedo * irradiance * cos / PI;
    common::assert_floor_patch(ctx, (albedo, 1.0), &lights, (expected, 0.0), "directional");
}

/// A black occluder at height 1 over the floor's half x < 0, under a
/// directional light 45 degrees off the vertical toward +x: the floor's
/// shadow ends at x = 1 with a sharp edge, the columns dark to its left and
/// lit to its right (a E cos / pi, exactly), one column between at most.
#[test]
fn directional_light_casts_sharp_shadows() {
    let ctx = gpu_or_skip!();
    let (albedo, irradiance) = (0.5f64, 2.0f64);
    let half = std::f64::consts::FRAC_1_SQRT_2;
    // 4.4 of the floor across 32 columns (the image is 8 times as wide as high).
    let vfov = 2.0 * (4.4f64 / 8.0 / 2.0 / 10.0).atan().to_degrees();
    let scene = common::scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 10, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = {vfov}
        width = 32
        height = 4
        [render]
        spp = 16
        max_depth = 1
        [materials.floor]
        type = "lambertian"
        albedo = [{albedo}, {albedo}, {albedo}]
        [materials.black]
        type = "lambertian"
        albedo = [0, 0, 0]
        [[objects]]
        type = "quad"
        q = [-10, 0, -10]
        u = [0, 0, 20]
        v = [20, 0, 0]
        material = "floor"
        [[objects]]
        type = "quad"
        q = [-10, 1, -10]
        u = [0, 0, 20]
        v = [10, 0, 0]
        material = "black"
        [[lights]]
        type = "directional"
        direction = [{half}, -{half}, 0]
        irradiance = {irradiance}
        "#
    ));
    let acc = common::render(ctx, &scene, &RenderOptions::default());
    let image = acc.mean();
    let lit = (albedo * irradiance * half / PI) as f32;
    let row: Vec<f32> = (0..32).map(|x| image.pixels[x][0]).collect();
    println!("{row:?}");
    let dark = row.iter().take_while(|&&v| v == 0.0).count();
    let bright = row
        .iter()
        .rev()
        .take_while(|&&v| (v - lit).abs() <= 1e-5 * lit)
        .count();
    assert!(
        dark + bright >= 31,
        "more than one column between dark and lit: {row:?}"
    );
    // The edge at x = 1 on the floor: 3.2 of 4.4 from the image's left, in
    // column 23 of 32.
    assert!(
        (22..=24).contains(&dark),
        "shadow edge after column {dark}: {row:?}"
    );
}
