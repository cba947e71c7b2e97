//! The AOVs (`kinds::aov`) against what the geometry says: a plane seen
//! head-on, whose albedo, normals and position are exact and whose depth is
//! the mean of the distance over each pixel; the image beside them unchanged;
//! the list taken from the command line over the file's and kept by a
//! checkpoint; and refusals with exit code 2 and nothing written. Their
//! agreement with Mitsuba's `aov` integrator is in `tests/mitsuba.rs`.

mod common;

use common::pathmix;

use std::path::Path;
use std::process::Output;

/// Image side in pixels, and the view's half angle.
const SIDE: usize = 16;
const HALF_FOV_DEGREES: f64 = 20.0;

/// A camera at the origin looking down -z at a wide diffuse plane at z = -2
/// facing it, lit by a small light behind the camera; `aovs` is the
/// `[render]` line that asks for AOVs, if any.
fn plane_scene(dir: &Path, aovs: &str) -> String {
    let path = dir.join("plane.toml");
    std::fs::write(
        &path,
        format!(
            r#"
            [camera]
            lookfrom = [0, 0, 0]
            lookat = [0, 0, -1]
            vfov = {vfov}
            width = {SIDE}
            height = {SIDE}
            [render]
            spp = 16
            {aovs}
            [materials.wall]
            type = "lambertian"
            albedo = [0.2, 0.4, 0.6]
            [materials.glow]
            type = "light"
            emit = [4, 4, 4]
            [[objects]]
            type = "quad"
            q = [-50, -50, -2]
            u = [100, 0, 0]
            v = [0, 100, 0]
            material = "wall"
            [[objects]]
            type = "sphere"
            center = [0, 0, 1]
            radius = 0.2
            material = "glow"
            "#,
            vfov = 2.0 * HALF_FOV_DEGREES
        ),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

fn render(args: &[&str]) -> Output {
    let output = pathmix(args);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// The distance from the eye to the plane z = -2 averaged over pixel (x, y)
/// (the box filter: uniform over the pixel's square of the image plane).
fn mean_depth(x: usize, y: usize) -> f64 {
    let half = HALF_FOV_DEGREES.to_radians().tan();
    let pixel = 2.0 * half / SIDE as f64;
    let steps = 64;
    let mut sum = 0.0;
    for j in 0..steps {
        for i in 0..steps {
            let u = -half + (x as f64 + (i as f64 + 0.5) / steps as f64) * pixel;
            let v = half - (y as f64 + (j as f64 + 0.5) / steps as f64) * pixel;
            sum += 2.0 * (1.0 + u * u + v * v).sqrt();
        }
    }
    sum / (steps * steps) as f64
}

#[test]
fn a_plane_seen_head_on_has_its_exact_aovs() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("aovs", "plane");
    let scene = plane_scene(
        &dir,
        r#"aovs = ["albedo", "dd:depth", "position", "geo_normal", "nn:sh_normal"]"#,
    );
    let exr = dir.join("plane.exr");
    let png = dir.join("plane.png");
    let (exr_path, png) = (exr.to_str().unwrap(), png.to_str().unwrap());
    render(&[
        "render", &scene, "--spp", "256", "--exr", exr_path, "-o", png,
    ]);
    let channels = common::exr_channels(&exr);
    let names: Vec<&str> = channels.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "albedo.B",
            "albedo.G",
            "albedo.R",
            "dd.T",
            "geo_normal.X",
            "geo_normal.Y",
            "geo_normal.Z",
            "nn.X",
            "nn.Y",
            "nn.Z",
            "position.X",
            "position.Y",
            "position.Z"
        ]
    );
    for (name, value) in [
        ("albedo.R", 0.2),
        ("albedo.G", 0.4),
        ("albedo.B", 0.6),
        ("geo_normal.X", 0.0),
        ("geo_normal.Y", 0.0),
        ("geo_normal.Z", 1.0),
        ("nn.Z", 1.0),
        ("position.Z", -2.0),
    ] {
        for (i, &v) in channels[name].iter().enumerate() {
            assert!((v - value).abs() < 1e-5, "{name} pixel {i}: {v}");
        }
    }
    // Right and down in the image are +x and -y on the plane.
    let at = |name: &str, x: usize, y: usize| channels[name][y * SIDE + x];
    assert!(at("position.X", SIDE - 1, 0) > 0.0 && at("position.Y", SIDE - 1, 0) > 0.0);
    for (x, y) in [(0, 0), (3, 11), (8, 8), (15, 2)] {
        let (depth, expected) = (f64::from(at("dd.T", x, y)), mean_depth(x, y));
        // 256 samples of a distance that varies by up to 1.3% across a pixel.
        assert!(
            (depth / expected - 1.0).abs() < 1e-4,
            "({x}, {y}): {depth} against {expected}"
        );
    }
}

/// Asking for AOVs leaves the image as it is, bit for bit; the command line's
/// list replaces the file's.
#[test]
fn aovs_leave_the_image_alone_and_the_command_line_chooses_them() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("aovs", "image");
    let scene = plane_scene(&dir, r#"aovs = ["albedo"]"#);
    let plain_scene = dir.join("plain.toml");
    std::fs::write(
        &plain_scene,
        std::fs::read_to_string(&scene)
            .unwrap()
            .replace(r#"aovs = ["albedo"]"#, ""),
    )
    .unwrap();
    let (with, without) = (dir.join("with.exr"), dir.join("without.exr"));
    let png = dir.join("out.png");
    let png = png.to_str().unwrap();
    render(&[
        "render",
        &scene,
        "--exr",
        with.to_str().unwrap(),
        "-o",
        png,
        "--aov",
        "d:depth",
    ]);
    render(&[
        "render",
        plain_scene.to_str().unwrap(),
        "--exr",
        without.to_str().unwrap(),
        "-o",
        png,
    ]);
    let (with, without) = (common::exr_channels(&with), common::exr_channels(&without));
    assert!(with.contains_key("d.T") && !with.contains_key("albedo.R"));
    for channel in ["R", "G", "B"] {
        assert_eq!(with[channel], without[channel], "{channel}");
    }
}

/// The AOVs are the camera rays' first hits, whatever strategy renders the
/// image: the same bits under each (the `bsdf` strategy evaluates no BSDF of
/// its own, yet the albedo does).
#[test]
fn every_strategy_writes_the_same_aovs() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("aovs", "strategies");
    let scene = plane_scene(&dir, "");
    let png = dir.join("out.png");
    let png = png.to_str().unwrap();
    let aovs: Vec<_> = ["nee-mis", "mixture", "bsdf"]
        .into_iter()
        .map(|strategy| {
            let exr = dir.join(format!("{strategy}.exr"));
            render(&[
                "render",
                &scene,
                "--spp",
                "4",
                "--strategy",
                strategy,
                "--aov",
                "albedo,d:depth",
                "--exr",
                exr.to_str().unwrap(),
                "-o",
                png,
            ]);
            let mut channels = common::exr_channels(&exr);
            channels.retain(|name, _| name.contains('.'));
            channels
        })
        .collect();
    assert_eq!(aovs[0].len(), 4);
    assert_eq!(aovs[1], aovs[0]);
    assert_eq!(aovs[2], aovs[0]);
}

/// A checkpoint records the command line's AOVs: its resume writes them.
#[test]
fn a_resume_writes_the_recorded_aovs() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("aovs", "resume");
    let scene = plane_scene(&dir, "");
    let (checkpoint, exr) = (dir.join("run.ckpt"), dir.join("run.exr"));
    let png = dir.join("run.png");
    let (checkpoint, exr, png) = (
        checkpoint.to_str().unwrap(),
        exr.to_str().unwrap(),
        png.to_str().unwrap(),
    );
    render(&[
        "render",
        &scene,
        "--spp",
        "4",
        "--exr",
        exr,
        "-o",
        png,
        "--checkpoint",
        checkpoint,
        "--aov",
        "albedo",
    ]);
    std::fs::remove_file(exr).unwrap();
    render(&["render", "--resume", checkpoint, "--spp", "8"]);
    let channels = common::exr_channels(Path::new(exr));
    assert!(channels.contains_key("albedo.G"), "{:?}", channels.keys());
}

/// Bad lists, an AOV with nowhere to go and texture coordinates of a scene
/// without textures: exit code 2, a message naming the problem, nothing written.
#[test]
fn bad_aovs_are_refused_before_rendering() {
    let dir = common::TempDir::new("aovs", "refused");
    let scene = plane_scene(&dir, "");
    let png = dir.join("out.png");
    let exr = dir.join("out.exr");
    let (png, exr) = (png.to_str().unwrap(), exr.to_str().unwrap());
    for (args, message) in [
        (
            vec!["--exr", exr, "--aov", "p:prim_index"],
            "`prim_index` is Mitsuba's, not computed by pathmix",
        ),
        (
            vec!["--exr", exr, "--aov", "a:albedo,a:depth"],
            "AOV name `a` is given twice",
        ),
        (
            vec!["--aov", "depth"],
            "AOVs are written as channels of the EXR image: give --exr",
        ),
        (
            vec!["--exr", exr, "--aov", "uv"],
            "the scene has no textures",
        ),
    ] {
        let mut all = vec!["render", scene.as_str(), "-o", png];
        all.extend(args);
        let output = pathmix(&all);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{all:?}: {stderr}");
        assert!(stderr.contains(message), "{all:?}: {stderr}");
        assert!(
            !Path::new(png).exists() && !Path::new(exr).exists(),
            "{all:?}"
        );
    }
    let listed = plane_scene(&dir, r#"aovs = "depth""#);
    let output = pathmix(&["render", &listed, "-o", png, "--exr", exr]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("render.aovs") && stderr.contains("expected a list"),
        "{stderr}"
    );
    let typo = plane_scene(&dir, r#"aovs = ["depht"]"#);
    let output = pathmix(&["render", &typo, "-o", png, "--exr", exr]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("render.aovs[0]") && stderr.contains("not a type of AOV"),
        "{stderr}"
    );
}
