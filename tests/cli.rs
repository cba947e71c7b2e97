//! The `pathmix` binary as a user runs it.

mod common;

use common::pathmix;

use std::path::Path;
use std::process::{Command, Output};

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
        .display()
        .to_string()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn help_explains_every_render_flag() {
    let output = pathmix(&["render", "--help"]);
    assert!(output.status.success());
    let help = String::from_utf8_lossy(&output.stdout);
    for flag in [
        "--spp",
        "--width",
        "--height",
        "--max-depth",
        "--strategy",
        "--light-weight",
        "--seed",
        "--exr",
        "--adapter",
        "--output",
        "--accumulator",
        "--scene-storage",
        "PATHMIX_ADAPTER",
    ] {
        assert!(help.contains(flag), "render --help lacks {flag}");
    }
    assert!(pathmix(&["--help"]).status.success());
}

#[test]
fn bad_scene_is_refused_naming_file_and_field_and_writes_nothing() {
    let dir = common::TempDir::new("cli", "bad-scene");
    let scene_path = dir.join("broken.toml");
    let text = std::fs::read_to_string(scene("cornell.toml"))
        .unwrap()
        .replace("\"white\"", "\"whit\"");
    std::fs::write(&scene_path, text).unwrap();
    let png = dir.join("out.png");
    let output = pathmix(&[
        "render",
        scene_path.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    let message = stderr(&output);
    assert!(
        message.contains("broken.toml") && message.contains("objects[") && message.contains("whit"),
        "{message}"
    );
    assert!(!png.exists());
}

#[test]
fn unwritable_outputs_are_refused_before_rendering() {
    let dir = common::TempDir::new("cli", "outputs");
    let missing = dir.join("no-such-folder").join("out.png");
    let output = pathmix(&[
        "render",
        &scene("furnace.toml"),
        "-o",
        missing.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no-such-folder"),
        "{}",
        stderr(&output)
    );

    let jpg = dir.join("out.jpg");
    let output = pathmix(&[
        "render",
        &scene("furnace.toml"),
        "-o",
        jpg.to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains(".jpg"), "{}", stderr(&output));
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "something was written"
    );
}

#[test]
fn bad_flag_values_are_refused() {
    let output = pathmix(&["render", &scene("furnace.toml"), "--width", "0"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("--width"), "{}", stderr(&output));
}

#[test]
fn renders_png_and_exr_and_reports_speed() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("cli", "render");
    let (png, exr) = (dir.join("box.png"), dir.join("box.exr"));
    let output = pathmix(&[
        "render",
        &scene("cornell-boxes.toml"),
        "--spp",
        "2",
        "--width",
        "24",
        "--height",
        "16",
        "-o",
        png.to_str().unwrap(),
        "--exr",
        exr.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("paths/s") && stdout.contains("24x16") && stdout.contains("2 spp"),
        "{stdout}"
    );
    // --quiet leaves stderr to warnings and errors.
    assert_eq!(stderr(&output), "");
    let decoded = image::open(&png).unwrap();
    assert_eq!((decoded.width(), decoded.height()), (24, 16));
    let linear = pathmix::output::read_exr(&exr).unwrap();
    assert_eq!((linear.width, linear.height), (24, 16));
}

#[test]
fn output_named_exr_is_the_linear_image() {
    // Two EXRs asked for are refused before anything runs.
    let output = pathmix(&[
        "render",
        &scene("cornell-boxes.toml"),
        "-o",
        "a.exr",
        "--exr",
        "b.exr",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("-o a.exr and --exr b.exr"),
        "{}",
        stderr(&output)
    );
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("cli", "output-exr");
    let exr = dir.join("box.exr");
    let output = Command::new(env!("CARGO_BIN_EXE_pathmix"))
        .current_dir(&*dir)
        .args(["render", &scene("cornell-boxes.toml"), "--spp", "2"])
        .args([
            "--width", "24", "--height", "16", "--quiet", "-o", "box.exr",
        ])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let linear = pathmix::output::read_exr(&exr).unwrap();
    assert_eq!((linear.width, linear.height), (24, 16));
    // Not also the default out.png.
    assert!(!dir.join("out.png").exists());
}

#[test]
fn light_strategy_warns_that_it_is_biased() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("cli", "light");
    let png = dir.join("light.png");
    let output = pathmix(&[
        "render",
        &scene("cornell-boxes.toml"),
        "--strategy",
        "light",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("biased"), "{}", stderr(&output));
}

#[test]
fn info_shows_what_the_kernel_contains() {
    if common::gpu().is_none() {
        return;
    }
    let output = pathmix(&["info", &scene("cornell-boxes.toml")]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let flags = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("flags:"))
        .unwrap();
    assert!(
        flags.contains("QUADS") && flags.contains("LAMBERTIAN"),
        "{flags}"
    );
    assert!(
        !flags.contains("SPHERES") && !flags.contains("DIELECTRIC"),
        "{flags}"
    );
    assert!(
        stdout.contains("18 quads") && stdout.contains("max texture dimension"),
        "{stdout}"
    );
}

/// How the light density weighs emitting mesh faces, by their number and the
/// strategy: 2 faces (Mitsuba's light) each tested; the knot's 4 608 walked
/// through their BVH, or weighed by the points hit under `nee-mis`.
#[test]
fn info_says_how_emitting_mesh_faces_are_weighed() {
    let dir = common::TempDir::new("info", "mesh-lights");
    let Some(mitsuba_box) =
        common::fixture_reading_shared("tests/fixtures/mitsuba-cbox-bunny.toml", &dir)
    else {
        return;
    };
    if common::gpu().is_none() {
        return;
    }
    let knot = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/knot.obj");
    let glowing_knot = dir.join("knot.toml");
    std::fs::write(
        &glowing_knot,
        format!(
            "[camera]\nlookfrom = [0, 0, 8]\nlookat = [0, 0, 0]\n\
             [materials.glow]\ntype = \"light\"\nemit = [1, 1, 1]\n\
             [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[objects]]\ntype = \"sphere\"\ncenter = [0, -102, 0]\nradius = 100\nmaterial = \"floor\"\n\
             [[objects]]\ntype = \"mesh\"\nfile = {knot:?}\nmaterial = \"glow\"\n"
        ),
    )
    .unwrap();
    for (scene, strategy, expected) in [
        (mitsuba_box.as_path(), "mixture", "each tested"),
        (mitsuba_box.as_path(), "nee-mis", "each tested"),
        (glowing_knot.as_path(), "mixture", "walks their BVH"),
        (glowing_knot.as_path(), "nee-mis", "point hit"),
    ] {
        let output = pathmix(&["info", scene.to_str().unwrap(), "--strategy", strategy]);
        assert!(output.status.success(), "{}", stderr(&output));
        let stdout = String::from_utf8_lossy(&output.stdout);
        let line = stdout
            .lines()
            .find(|l| l.contains("emitting mesh faces:"))
            .unwrap_or_else(|| panic!("{stdout}"));
        assert!(line.contains(expected), "{strategy}: {line}");
    }
}

#[test]
fn bench_prints_speed_figures() {
    if common::gpu().is_none() {
        return;
    }
    let output = pathmix(&["bench", "--quick", "--no-startup"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("| cornell"))
        .collect();
    assert!(rows.len() >= 6, "{stdout}");
    assert!(
        stdout.contains("general kernel") && stdout.contains("M paths/s"),
        "{stdout}"
    );
}

/// `bench --stages` on a scene it is given prints the scene's speed and a row
/// per stage; a missing scene is an input error (exit 2).
#[test]
fn bench_stages_prints_a_row_per_stage() {
    if common::gpu().is_none_or(|ctx| !ctx.subgroups) {
        return;
    }
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml");
    let output = pathmix(&["bench", "--stages", "--quick", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(stdout.contains("M paths/s"), "{stdout}");
    for stage in pathmix::kernel::Stage::ALL {
        let row = format!("| {} | ", stage.name());
        assert!(
            stdout.lines().any(|l| l.starts_with(&row)),
            "{stage:?}: {stdout}"
        );
    }
    let missing = pathmix(&["bench", "--stages", "--quick", "no-such-scene.toml"]);
    assert_eq!(missing.status.code(), Some(2), "{}", stderr(&missing));
}

/// The scale curve's sphere field, printed as a scene file, reads back as the
/// scene `pathmix bench` renders (no device needed).
#[test]
fn bench_writes_the_sphere_field_as_a_scene_file() {
    let output = pathmix(&["bench", "--write-sphere-field", "10"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = String::from_utf8(output.stdout).unwrap();
    let scene = pathmix::scene::Scene::parse(&text, "sphere-field.toml").unwrap();
    assert_eq!(scene, pathmix::scene::sphere_field(10));
    // The ground, the lamp and the ten spheres.
    assert_eq!(text.matches("type = \"sphere\"").count(), 12, "{text}");
}

/// Each bad input exits with code 2 before rendering, with a message that names the
/// file (or flag) and the field or line, and leaves nothing behind.
#[test]
fn bad_inputs_exit_2_naming_the_problem_and_write_nothing() {
    let base = std::fs::read_to_string(scene("furnace.toml")).unwrap();
    let edit = |from: &str, to: &str| {
        assert!(base.contains(from), "furnace.toml lacks {from:?}");
        base.replacen(from, to, 1)
    };
    // (case, scene text, extra arguments, fragments the message must contain)
    let cases: Vec<(&str, String, Vec<&str>, Vec<&str>)> = vec![
        (
            "malformed TOML",
            edit("[camera]", "[camera"),
            vec![],
            vec!["case.toml", "line ", "invalid TOML"],
        ),
        (
            "wrong type",
            edit("width = 32", "width = \"wide\""),
            vec![],
            vec!["case.toml", "camera.width", "expected an integer"],
        ),
        (
            "unknown key",
            edit("albedo =", "albdo ="),
            vec![],
            vec![
                "case.toml",
                "materials.wall",
                "`albdo`",
                "did you mean `albedo`",
            ],
        ),
        (
            "NaN",
            edit("vfov = 90", "vfov = nan"),
            vec![],
            vec!["case.toml", "camera.vfov", "finite"],
        ),
        (
            "negative size in the file",
            edit("width = 32", "width = -5"),
            vec![],
            vec!["case.toml", "camera.width", "-5"],
        ),
        (
            "negative size flag",
            base.clone(),
            vec!["--width", "-5"],
            vec!["--width", "-5"],
        ),
        (
            "negative weight flag",
            base.clone(),
            vec!["--light-weight", "-0.5"],
            vec!["--light-weight", "-0.5"],
        ),
        (
            "unknown material",
            edit("material = \"wall\"", "material = \"wal\""),
            vec![],
            vec!["case.toml", "objects[0].material", "`wal`"],
        ),
        (
            "output in a missing folder",
            base.clone(),
            vec!["-o", "MISSING/out.png"],
            vec!["MISSING", "does not exist"],
        ),
        (
            "unknown output extension",
            base.clone(),
            vec!["-o", "OUT/out.bmp"],
            vec!["out.bmp", ".bmp"],
        ),
        (
            "EXR flag naming a PNG",
            base.clone(),
            vec!["--exr", "OUT/out2.png"],
            vec!["out2.png", "EXR"],
        ),
    ];
    for (case, text, extra, fragments) in cases {
        let dir = common::TempDir::new("cli", "bad-input");
        let scene_path = dir.join("case.toml");
        std::fs::write(&scene_path, text).unwrap();
        let out = dir.join("out.png");
        let missing = dir.join("no-such-folder");
        let substitute = |arg: &str| {
            arg.replace("MISSING", missing.to_str().unwrap())
                .replace("OUT", dir.to_str().unwrap())
        };
        let mut args = vec!["render".to_string(), scene_path.display().to_string()];
        if !extra.contains(&"-o") {
            args.extend(["-o".to_string(), out.display().to_string()]);
        }
        args.extend(extra.iter().map(|a| substitute(a)));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = pathmix(&args);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{case}: {message}");
        for fragment in fragments {
            let fragment = substitute(fragment);
            assert!(
                message.contains(&fragment),
                "{case}: the message lacks {fragment:?}: {message}"
            );
        }
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, ["case.toml"], "{case}: something was written");
    }
}

#[test]
fn compare_exits_0_within_the_tolerance_1_beyond_it_2_for_unreadable_files() {
    use pathmix::output::{Image, write_exr};
    let dir = common::TempDir::new("cli", "compare");
    let image = |pixels: Vec<[f32; 3]>| Image {
        width: 2,
        height: 1,
        pixels,
    };
    let write = |name: &str, image: &Image| {
        let path = dir.join(name);
        write_exr(&path, image, &[]).unwrap();
        path.display().to_string()
    };
    let a = write("a.exr", &image(vec![[0.5, 0.0, 1.0], [2.0, 3.0, 4.0]]));
    let close = write(
        "b.exr",
        &image(vec![[0.5, 0.0, 1.0], [2.0, 3.0 * (1.0 + 4e-7), 4.0]]),
    );
    let far = write(
        "c.exr",
        &image(vec![[0.5, 0.0, 1.0], [2.0, 3.0 * (1.0 + 4e-6), 4.0]]),
    );
    let other_size = write("d.exr", &Image::new(1, 2));

    let output = pathmix(&["compare", &a, &close]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("agree within relative 1e-6 (6 values)")
            && stdout.contains("at pixel (1, 0) G"),
        "{stdout}"
    );
    let output = pathmix(&["compare", &a, &a]);
    assert!(String::from_utf8_lossy(&output.stdout).contains("identical"));

    let output = pathmix(&["compare", &a, &far, "--tolerance", "1e-6"]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("differ: 1 of 6 values beyond relative 1e-6"),
        "{}",
        stderr(&output)
    );
    assert!(
        pathmix(&["compare", &a, &far, "--tolerance", "1e-5"])
            .status
            .success()
    );
    let output = pathmix(&["compare", &a, &other_size]);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        stderr(&output).contains("differ in size: 2x1 and 1x2"),
        "{}",
        stderr(&output)
    );

    let missing = dir.join("missing.exr").display().to_string();
    let output = pathmix(&["compare", &a, &missing]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("missing.exr"),
        "{}",
        stderr(&output)
    );
    let output = pathmix(&["compare", &a, &close, "--tolerance", "-1"]);
    assert_eq!(output.status.code(), Some(2));
}

/// A scene whose mesh file is missing, malformed or empty exits with code 2,
/// names the scene file, the object, the mesh file and (where the reader knows
/// it) the line, and writes nothing.
#[test]
fn bad_mesh_files_are_refused_naming_object_and_file() {
    let dir = common::TempDir::new("cli", "bad-meshes");
    let cases = [
        ("missing.obj", None, "cannot read the mesh file"),
        ("short.obj", Some("v 0 0 0\nv 1 0 0\nf 1 2\n"), "line 3"),
        (
            "range.obj",
            Some("v 0 0 0\nv 1 0 0\nf 1 2 9\n"),
            "out of range",
        ),
        (
            "nan.obj",
            Some("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
            "non-finite",
        ),
        (
            "empty.ply",
            Some(
                "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
            ),
            "no triangles",
        ),
        ("mesh.stl", Some("solid x\n"), "unknown mesh format"),
    ];
    for (file, contents, problem) in cases {
        if let Some(contents) = contents {
            std::fs::write(dir.join(file), contents).unwrap();
        }
        let scene_path = dir.join(format!("{file}.toml"));
        std::fs::write(
            &scene_path,
            format!(
                "[camera]\nlookfrom = [0, 0, -5]\nlookat = [0, 0, 0]\n\
                 [materials.white]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"white\"\n\
                 [[objects]]\ntype = \"mesh\"\nfile = \"{file}\"\nmaterial = \"white\"\n"
            ),
        )
        .unwrap();
        let out = dir.join(format!("{file}.png"));
        let output = pathmix(&[
            "render",
            scene_path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{file}: {message}");
        for part in [&format!("{file}.toml"), "objects[1].file", file, problem] {
            assert!(message.contains(part), "{file}: no {part:?} in {message}");
        }
        assert!(!message.contains("panicked"), "{message}");
        assert!(!out.exists(), "{file}: an image was written");
    }
}

/// Output piped into a reader that has gone (`pathmix info | head -1`) ends the
/// process quietly, as SIGPIPE does for Unix tools, instead of a panic.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_printing_commands_quietly() {
    use std::os::unix::process::ExitStatusExt;
    for args in [
        vec!["info", "scenes/cornell.toml"],
        vec!["render", "--help"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args(&args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Closed before the command prints its first line.
        drop(child.stdout.take());
        let output = child.wait_with_output().unwrap();
        let status = output.status;
        assert!(
            status.success() || status.signal() == Some(libc::SIGPIPE),
            "{args:?}: {status:?}\n{}",
            stderr(&output)
        );
        assert!(
            !stderr(&output).contains("panicked"),
            "{args:?}: {}",
            stderr(&output)
        );
    }
}
