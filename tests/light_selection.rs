//! Next-event estimation's spatial light selection (`render.light_selection`):
//! under `nee-mis`, lights picked in proportion to a bound on what each sends
//! toward the shading point. Its estimate is the analytic irradiance of spheres
//! and a disk (with a rectangle facing away, which the bound gives no share),
//! and where one bright far light and dim near ones light a floor, it has far
//! less noise than the uniform pick, with the same mean. A checkpoint keeps the
//! pick for its resume.

mod common;

use common::pathmix;

use pathmix::render::{RenderOptions, plan_kernel};
use pathmix::scene::{LightSelection, Scene};

/// `(albedo, emit)` of the floor and the lamps; the floor patch is at the origin.
const FLOOR: (f64, f64) = (0.5, 10.0);

/// Irradiance over `emit` at the origin (normal +y) from a sphere of radius `r`
/// about `center`, wholly above the floor: pi (r/d)^2 cos(theta).
fn sphere_irradiance(center: [f64; 3], r: f64) -> f64 {
    let d2: f64 = center.iter().map(|c| c * c).sum();
    std::f64::consts::PI * r * r / d2 * center[1] / d2.sqrt()
}

#[test]
fn spatial_selection_gives_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let (albedo, emit) = FLOOR;
    let lights = r#"
        [[objects]]
        type = "sphere"
        center = [1, 1, 0]
        radius = 0.1
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [-3, 2, 1]
        radius = 0.5
        material = "lamp"
        # Facing down from above the camera, centred over the patch.
        [[objects]]
        type = "disk"
        center = [0, 3, 0]
        u = [0.5, 0, 0]
        v = [0, 0, 0.5]
        material = "lamp"
        # Facing up, beside: it cannot light the floor below it.
        [[objects]]
        type = "quad"
        q = [5, 0.5, 0]
        u = [0, 0, 0.5]
        v = [0.5, 0, 0]
        material = "lamp"
    "#;
    // A disk of radius R at height H over the point: pi R^2 / (R^2 + H^2).
    let disk = std::f64::consts::PI * 0.25 / (0.25 + 9.0);
    let irradiance =
        sphere_irradiance([1.0, 1.0, 0.0], 0.1) + sphere_irradiance([-3.0, 2.0, 1.0], 0.5) + disk;
    let expected = albedo / std::f64::consts::PI * emit * irradiance;
    common::assert_lit_floor(
        ctx,
        (albedo, emit, 1.0),
        lights,
        expected,
        "spatial selection",
    );
}

/// The floor patch of `common::assert_lit_floor` under `nee-mis`, 1024 independent
/// samples, lit by one bright far sphere (200x the power of each other) and four
/// dim near ones: Veach's lights.
fn veach_like_floor(selection: LightSelection) -> Scene {
    let (albedo, emit) = FLOOR;
    let lights = format!(
        r#"
        [materials.bright]
        type = "light"
        emit = [{bright}, {bright}, {bright}]
        [materials.lamp]
        type = "light"
        emit = [{emit}, {emit}, {emit}]
        [[objects]]
        type = "sphere"
        center = [10, 10, 4]
        radius = 0.5
        material = "bright"
        [[objects]]
        type = "sphere"
        center = [-1, 1, 0]
        radius = 0.1
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [1, 1.5, 0]
        radius = 0.1
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [0, 1.5, 1]
        radius = 0.1
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [0, 2, -1.5]
        radius = 0.1
        material = "lamp"
        "#,
        // 200x the power of a dim sphere: (0.1 / 0.5)^2 200 = 8 times the radiance.
        bright = 8.0 * emit,
    );
    let mut scene = common::floor_patch_scene((albedo, 1.0), "nee-mis", 1024, &lights);
    scene.render.light_selection = selection;
    scene
}

#[test]
fn spatial_selection_lowers_the_noise_of_lights_unlike_in_power() {
    let ctx = gpu_or_skip!();
    let options = common::with_variance();
    let mut estimates = Vec::new();
    for selection in [LightSelection::Spatial, LightSelection::Uniform] {
        let scene = veach_like_floor(selection);
        let plan = plan_kernel(ctx, &scene, &RenderOptions::default()).unwrap();
        assert_eq!(
            plan.config.spatial_light_selection,
            selection == LightSelection::Spatial
        );
        let (mean, error) = common::image_mean_and_error(&common::render(ctx, &scene, &options));
        println!("{}: {mean:.6} ± {error:.6}", selection.name());
        estimates.push((mean, error));
    }
    let [(spatial, spatial_error), (uniform, uniform_error)] = estimates[..] else {
        unreachable!()
    };
    let combined = spatial_error.hypot(uniform_error);
    assert!(
        (spatial - uniform).abs() < 4.0 * combined,
        "spatial {spatial} ± {spatial_error} against uniform {uniform} ± {uniform_error}"
    );
    assert!(
        spatial_error < 0.5 * uniform_error,
        "spatial ± {spatial_error} against uniform ± {uniform_error}"
    );
}

/// A checkpoint records the pick its run made, and a resume keeps it: the furnace's
/// six emitting walls under `nee-mis`, interrupted at 4 spp and resumed to 8, equal
/// a run of 8, bit for bit, with either pick (the two differing from each other);
/// a resume that names a pick is refused.
#[test]
fn a_resume_keeps_the_runs_light_selection() {
    let _ctx = gpu_or_skip!();
    let dir = common::TempDir::new("light-selection", "resume");
    let furnace = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/furnace.toml");
    let small = ["--strategy", "nee-mis", "--width", "16", "--height", "16"];
    let mut images = Vec::new();
    for selection in ["spatial", "uniform"] {
        let path = |name: &str| dir.join(format!("{selection}-{name}"));
        let (ckpt, resumed, direct) = (path("run.ckpt"), path("resumed.exr"), path("direct.exr"));
        let png = path("x.png");
        let p = |p: &std::path::Path| p.to_str().unwrap().to_owned();
        let mut first = vec![
            "render",
            furnace,
            "--spp",
            "4",
            "--light-selection",
            selection,
        ];
        let (ckpt_arg, png_arg) = (p(&ckpt), p(&png));
        first.extend(["--checkpoint", &ckpt_arg, "-o", &png_arg]);
        first.extend(small);
        let output = pathmix(&first);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let header = String::from_utf8_lossy(&std::fs::read(&ckpt).unwrap()).into_owned();
        assert!(header.contains(&format!("light_selection = \"{selection}\"")));
        let resumed_arg = p(&resumed);
        let output = pathmix(&[
            "render",
            "--resume",
            &ckpt_arg,
            "--spp",
            "8",
            "--exr",
            &resumed_arg,
            "-o",
            &png_arg,
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        assert_eq!(
            stderr.contains("spatial light selection"),
            selection == "spatial",
            "{stderr}"
        );
        // The pick is the checkpoint's: a resume that names one is refused, as one
        // naming a seed or a sampler is.
        let output = pathmix(&[
            "render",
            "--resume",
            &ckpt_arg,
            "--light-selection",
            "uniform",
        ]);
        assert_eq!(output.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&output.stderr).contains("--light-selection"));
        let direct_arg = p(&direct);
        let mut whole = vec![
            "render",
            furnace,
            "--spp",
            "8",
            "--light-selection",
            selection,
        ];
        whole.extend(["--exr", &direct_arg, "-o", &png_arg]);
        whole.extend(small);
        let output = pathmix(&whole);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let resumed = pathmix::output::read_exr(&resumed).unwrap();
        let direct = pathmix::output::read_exr(&direct).unwrap();
        assert!(
            resumed.pixels == direct.pixels,
            "{selection}: the resume differs"
        );
        images.push(direct.pixels);
    }
    assert!(images[0] != images[1], "the two picks gave the same image");
}
