//! Lose nothing, ever: one test per class of defect that could destroy or
//! silently corrupt a user's files or image (paths that collide, read-only
//! outputs, scenes at the edges, emission at the top of f32, parts cut short).

mod common;

use pathmix::render::{self, RenderOptions, StopRule};
use pathmix::scene::{Scene, Strategy};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_pathmix")
}

fn pathmix_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Every file under `dir` (links as their targets' text), by name.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| !e.path().is_dir() || e.path().is_symlink())
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let content = match std::fs::read_link(e.path()) {
                Ok(target) => target.to_string_lossy().into_owned().into_bytes(),
                Err(_) => std::fs::read(e.path()).unwrap(),
            };
            (name, content)
        })
        .collect()
}

const SMALL: [&str; 6] = ["--width", "8", "--height", "8", "--spp", "2"];

fn cornell() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/cornell-boxes.toml")
        .display()
        .to_string()
}

/// The scene file, a checkpoint and a partial result to collide with.
fn inputs(dir: &Path) {
    std::fs::copy(cornell(), dir.join("scene.toml")).unwrap();
    let made = pathmix_in(
        dir,
        &[
            &["render", "scene.toml", "-q", "-o", "ck.png"][..],
            &SMALL,
            &["--checkpoint", "run.ckpt", "--partial", "part.exr"],
        ]
        .concat(),
    );
    assert!(made.status.success(), "{}", text(&made.stderr));
}

/// A second name for `target` with extension `ext`: the same name through `./`
/// and a folder and back, a symbolic link or a hard link, in turn.
fn alias(dir: &Path, target: &str, ext: &str, form: usize) -> String {
    let name = format!("alias{form}-{}.{ext}", target.replace('.', "-"));
    match form % 4 {
        0 if Path::new(target).extension().is_some_and(|e| e == ext) => {
            format!("./sub/../{target}")
        }
        1 | 0 => {
            #[cfg(unix)]
            std::os::unix::fs::symlink(target, dir.join(&name)).unwrap();
            #[cfg(not(unix))]
            std::fs::hard_link(dir.join(target), dir.join(&name)).unwrap();
            name
        }
        2 => {
            std::fs::hard_link(dir.join(target), dir.join(&name)).unwrap();
            name
        }
        _ => format!("./{target}"),
    }
}

/// Each flag's own file, which already exists (an old result, say).
fn own_file(flag: &str) -> &'static str {
    match flag {
        "SCENE" => "scene.toml",
        "--resume" => "run.ckpt",
        "-o" => "old.png",
        "--exr" => "old.exr",
        "--variance" => "old-se.exr",
        "--partial" => "old-part.exr",
        "--checkpoint" => "other.ckpt",
        "PART" => "part.exr",
        _ => unreachable!("{flag}"),
    }
}

fn extension(flag: &str) -> &'static str {
    match flag {
        "SCENE" => "toml",
        "--resume" | "--checkpoint" => "ckpt",
        "-o" => "png",
        _ => "exr",
    }
}

/// Every pair of path-taking flags of `render` and `merge` made to name one
/// file (the same path, `./`, a symlink, a hard link) is refused with exit 2
/// naming both flags, before anything is written: every file stays as it was.
#[test]
fn every_pair_of_path_flags_naming_one_file_is_refused_and_every_file_is_kept() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("robust", "collide");
    inputs(&dir);
    let own_file = |flag: &str, other: &str| match (flag, other) {
        // SCENE and --resume collide where both name the checkpoint.
        ("SCENE", "--resume") => "run.ckpt",
        _ => own_file(flag),
    };
    std::fs::create_dir(dir.join("sub")).unwrap();
    for flag in ["-o", "--exr", "--variance", "--partial"] {
        std::fs::write(
            dir.join(own_file(flag, "")),
            format!("old result of {flag}"),
        )
        .unwrap();
    }
    std::fs::copy(dir.join("run.ckpt"), dir.join("other.ckpt")).unwrap();

    let render_flags = [
        "SCENE",
        "--resume",
        "-o",
        "--exr",
        "--variance",
        "--partial",
        "--checkpoint",
    ];
    let merge_flags = ["PART", "-o", "--exr", "--variance"];
    let mut form = 0;
    let mut cases = Vec::new();
    for (command, flags) in [("render", &render_flags[..]), ("merge", &merge_flags[..])] {
        for (i, a) in flags.iter().enumerate() {
            for b in &flags[i + 1..] {
                // Resuming saves to the checkpoint it read: that pair is the design.
                if (*a, *b) == ("--resume", "--checkpoint") {
                    continue;
                }
                cases.push((command, *a, *b, form));
                form += 1;
            }
        }
    }
    for (command, a, b, form) in cases {
        let target = own_file(a, b);
        let second = alias(&dir, target, extension(b), form);
        let before = snapshot(&dir);
        let path_of = |flag: &str| -> String {
            match flag {
                f if f == b => second.clone(),
                f if f == a => target.to_string(),
                f => own_file(f, "").to_string(),
            }
        };
        let mut args: Vec<String> = vec![command.into()];
        let resuming = command == "render" && (a == "--resume" || b == "--resume");
        if command == "merge" {
            args.push(path_of("PART"));
            for flag in [a, b] {
                if flag != "PART" {
                    args.extend([flag.to_string(), path_of(flag)]);
                }
            }
        } else {
            if !resuming || a == "SCENE" {
                args.push(path_of("SCENE"));
            }
            if !resuming {
                args.extend(SMALL.iter().map(|s| s.to_string()));
            }
            for flag in [a, b] {
                if flag != "SCENE" {
                    args.extend([flag.to_string(), path_of(flag)]);
                }
            }
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let output = pathmix_in(&dir, &args);
        let stderr = text(&output.stderr);
        let case = format!("{command} {a} {b}: {}", args.join(" "));
        assert_eq!(output.status.code(), Some(2), "{case}\n{stderr}");
        assert!(
            stderr.contains("same file") && stderr.contains(a) && stderr.contains(b),
            "{case}\n{stderr}"
        );
        assert!(snapshot(&dir) == before, "{case}: a file changed");
    }
}

/// `--checkpoint` replaces only a checkpoint; any other file is kept.
#[test]
fn a_checkpoint_never_replaces_a_file_that_is_not_one() {
    let dir = common::TempDir::new("robust", "not-ckpt");
    std::fs::copy(cornell(), dir.join("scene.toml")).unwrap();
    std::fs::write(dir.join("notes.txt"), "my notes").unwrap();
    let before = snapshot(&dir);
    let output = pathmix_in(
        &dir,
        &[
            &["render", "scene.toml", "-o", "a.png"][..],
            &SMALL,
            &["--checkpoint", "notes.txt"],
        ]
        .concat(),
    );
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("not a pathmix checkpoint"), "{stderr}");
    assert!(snapshot(&dir) == before);
}

/// A read-only output (mode 0444) is refused before rendering, even for root,
/// for images and checkpoints alike; the file is kept.
#[cfg(unix)]
#[test]
fn read_only_outputs_are_refused_before_rendering() {
    use std::os::unix::fs::PermissionsExt;
    let dir = common::TempDir::new("robust", "read-only");
    std::fs::copy(cornell(), dir.join("scene.toml")).unwrap();
    for (flag, name) in [
        ("-o", "kept.png"),
        ("--exr", "kept.exr"),
        ("--checkpoint", "kept.ckpt"),
    ] {
        let file = dir.join(name);
        let content = if flag == "--checkpoint" {
            pathmix::session::checkpoint::MAGIC.to_vec()
        } else {
            b"an image".to_vec()
        };
        std::fs::write(&file, content).unwrap();
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o444)).unwrap();
    }
    for (flag, name) in [
        ("-o", "kept.png"),
        ("--exr", "kept.exr"),
        ("--checkpoint", "kept.ckpt"),
    ] {
        let before = snapshot(&dir);
        let output = pathmix_in(
            &dir,
            &[&["render", "scene.toml", flag, name][..], &SMALL].concat(),
        );
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{flag}: {stderr}");
        assert!(
            stderr.contains("read-only") && !stderr.contains("adapter:"),
            "{flag}: {stderr}"
        );
        assert!(snapshot(&dir) == before, "{flag}");
    }
}

/// A render whose scene path is not UTF-8 cannot be recorded in a checkpoint:
/// refused at the start, naming the path, with nothing written.
#[cfg(target_os = "linux")]
#[test]
fn non_utf8_scene_paths_are_refused_when_a_checkpoint_records_them() {
    use std::os::unix::ffi::OsStrExt;
    let dir = common::TempDir::new("robust", "utf8");
    let name = std::ffi::OsStr::from_bytes(b"sc\xffene.toml");
    std::fs::copy(cornell(), dir.join(name)).unwrap();
    let before = snapshot(&dir);
    let output = Command::new(bin())
        .arg("render")
        .arg(name)
        .args(SMALL)
        .args(["--checkpoint", "run.ckpt", "-o", "a.png"])
        .current_dir(&dir)
        .output()
        .unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("not UTF-8"), "{stderr}");
    assert!(snapshot(&dir) == before);
}

const EMPTY_SCENE: &str = r#"
    [camera]
    lookfrom = [0, 0, 5]
    lookat = [0, 0, 0]
    width = 8
    height = 8
    [render]
    spp = 2
    max_depth = 4
    strategy = "bsdf"
    background = [0.25, 0.5, 0.75]
"#;

/// A scene without materials (and without objects) is valid: it renders its
/// background, on every scene storage.
#[test]
fn a_scene_without_materials_or_objects_renders_the_background() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let scene = common::scene_text(EMPTY_SCENE);
    assert!(scene.materials.is_empty());
    for storage in [
        pathmix::kernel::SceneStorage::Baked,
        pathmix::kernel::SceneStorage::Buffers,
        pathmix::kernel::SceneStorage::Bvh,
    ] {
        let options = RenderOptions {
            scene_storage: Some(storage),
            ..RenderOptions::default()
        };
        let image = common::render(ctx, &scene, &options).mean();
        assert!(
            image.pixels.iter().all(|&p| p == [0.25, 0.5, 0.75]),
            "{storage:?}: {:?}",
            image.pixels[0]
        );
    }
}

/// 10 000 materials no object uses never reach the kernel: the plan drops them,
/// and the image is the one of the scene without them, bit for bit.
#[test]
fn unused_materials_are_dropped_before_packing() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let mut text = std::fs::read_to_string(cornell()).unwrap();
    for i in 0..10_000 {
        text +=
            &format!("\n[materials.unused{i}]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\n");
    }
    let mut scene = common::scene_text(&text);
    let mut plain = common::scene_file("cornell-boxes.toml");
    for s in [&mut scene, &mut plain] {
        s.camera.width = 8;
        s.camera.height = 8;
        s.render.spp = 2;
    }
    let options = RenderOptions::default();
    let plan = render::plan_kernel(ctx, &scene, &options).unwrap();
    assert_eq!(plan.dropped_materials, 10_000);
    assert_eq!(plan.data.materials.len(), plain.materials.len());
    let a = common::render(ctx, &scene, &options).mean();
    let b = common::render(ctx, &plain, &options).mean();
    assert!(a == b, "dropping unused materials changed the image");
}

/// Emission at the top of f32 never gives a silent NaN: a run whose sums could
/// overflow is refused before it starts (exit 2, nothing written), and sums
/// that overflow anyway are counted and refused after it.
#[test]
fn emission_at_the_top_of_f32_is_refused_or_counted_never_silent() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = common::TempDir::new("robust", "bright");
    let cornell_text = std::fs::read_to_string(cornell()).unwrap();
    assert!(cornell_text.contains("emit = [15, 15, 15]"));
    for emit in [f32::MAX, 1e38] {
        let bright = cornell_text.replace(
            "emit = [15, 15, 15]",
            &format!("emit = [{emit:e}, {emit:e}, {emit:e}]"),
        );
        std::fs::write(dir.join("bright.toml"), &bright).unwrap();
        let before = snapshot(&dir);
        let output = pathmix_in(
            &dir,
            &[
                &["render", "bright.toml", "--exr", "b.exr", "-o", "b.png"][..],
                &[
                    "--width",
                    "8",
                    "--height",
                    "8",
                    "--spp",
                    "4",
                    "--variance",
                    "se.exr",
                ],
            ]
            .concat(),
        );
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{emit:e}: {stderr}");
        assert!(stderr.contains("overflow"), "{stderr}");
        assert!(snapshot(&dir) == before);

        // Past the check (as a throughput above 1 could take it): every sample sees
        // the emitter, so the sums overflow, and are refused.
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 0, 0]
            lookat = [0, 0, 1]
            vfov = 30
            width = 2
            height = 2
            [render]
            max_depth = 0
            [materials.glow]
            type = "light"
            emit = [{emit:e}, {emit:e}, {emit:e}]
            [[objects]]
            type = "quad"
            q = [-1, -1, 1]
            u = [0, 2, 0]
            v = [2, 0, 0]
            material = "glow"
            "#
        ));
        assert!(render::check_emission(&scene, 4, false).is_err());
        let mut renderer = render::Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
        render::run(&mut renderer, StopRule::samples(4), |_| {}).unwrap();
        let accumulation = renderer.accumulation();
        assert!(accumulation.non_finite_sums() > 0);
        assert!(render::check_sums_finite(&accumulation).is_err());
    }
    // Bright but within range: rendered, and every sum finite.
    let mut scene = common::scene_text(
        &cornell_text.replace("emit = [15, 15, 15]", "emit = [1e15, 1e15, 1e15]"),
    );
    scene.camera.width = 8;
    scene.camera.height = 8;
    render::check_emission(&scene, 4, true).unwrap();
    let accumulation = common::render(ctx, &scene, &common::with_variance());
    render::check_sums_finite(&accumulation).unwrap();
}

/// The mixture at light weight 1 is the `light` strategy, biased alike: warned.
#[test]
fn mixture_at_light_weight_one_warns_as_light_does() {
    let mut scene = common::scene_file("cornell-boxes.toml");
    scene.render.light_weight = 1.0;
    let (_, _, warnings) = render::prepare_scene(&scene, Strategy::Mixture).unwrap();
    assert!(
        warnings.iter().any(|w| w.contains("is biased")),
        "{warnings:?}"
    );
    scene.render.light_weight = 0.999;
    let (_, _, warnings) = render::prepare_scene(&scene, Strategy::Mixture).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
}

/// However small the time budget, every pixel gets a sample.
#[test]
fn a_tiny_time_budget_still_renders_a_sample_per_pixel() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let mut scene: Scene = common::scene_file("cornell-boxes.toml");
    scene.camera.width = 8;
    scene.camera.height = 8;
    let mut renderer = render::Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    let stop = StopRule {
        max_samples: u32::MAX,
        time_budget: Some(Duration::from_nanos(1)),
        target_error: None,
    };
    let summary = render::run(&mut renderer, stop, |_| {}).unwrap();
    assert!(summary.samples >= 1, "{summary:?}");
}

/// A shard with no samples (fewer samples than shards) is a valid, empty part,
/// and the merge takes it.
#[test]
fn an_empty_shard_is_a_valid_empty_part() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("robust", "empty-shard");
    std::fs::copy(cornell(), dir.join("scene.toml")).unwrap();
    let size = ["--width", "8", "--height", "8", "--spp", "1", "-q"];
    for (shard, part) in [("0/2", "e0.exr"), ("1/2", "e1.exr")] {
        let output = pathmix_in(
            &dir,
            &[
                &["render", "scene.toml", "--shard", shard, "--partial", part][..],
                &size,
            ]
            .concat(),
        );
        assert!(output.status.success(), "{shard}: {}", text(&output.stderr));
    }
    let empty = pathmix::session::shard::read_partial(&dir.join("e0.exr")).unwrap();
    assert_eq!(empty.range, 0..0);
    let merged = pathmix_in(&dir, &["merge", "e0.exr", "e1.exr", "-o", "m.png"]);
    assert!(merged.status.success(), "{}", text(&merged.stderr));
    assert!(
        text(&merged.stdout).contains("(1 spp)"),
        "{}",
        text(&merged.stdout)
    );
}

/// `compare` on a cut-off EXR says it is truncated.
#[test]
fn compare_names_a_truncated_file_as_truncated() {
    let dir = common::TempDir::new("robust", "truncated");
    let image = pathmix::output::Image {
        width: 32,
        height: 32,
        pixels: (0..1024).map(|i| [i as f32, 0.5, 0.25]).collect(),
    };
    let whole = dir.join("whole.exr");
    pathmix::output::write_exr(&whole, &image, &[]).unwrap();
    let bytes = std::fs::read(&whole).unwrap();
    for cut in [bytes.len() / 3, bytes.len() - 10] {
        std::fs::write(dir.join("cut.exr"), &bytes[..cut]).unwrap();
        let output = pathmix_in(&dir, &["compare", "cut.exr", "whole.exr"]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("truncated"), "{cut}: {stderr}");
    }
}

/// A scene past a resource limit is refused before the device is asked, naming
/// the limit and the scene's figure: here 70 000 spheres looped over by every ray.
#[test]
fn resource_limits_are_checked_before_the_device_is_asked() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let mut scene = pathmix::scene::sphere_field(70_000);
    scene.camera.width = 4;
    scene.camera.height = 4;
    let options = RenderOptions {
        scene_storage: Some(pathmix::kernel::SceneStorage::Buffers),
        ..RenderOptions::default()
    };
    let Err(e) = render::plan_kernel(ctx, &scene, &options) else {
        panic!("a scene past the loop limit was accepted");
    };
    let message = e.to_string();
    assert!(
        message.contains("65535") && message.contains("70002 objects"),
        "{message}"
    );
    // Through the BVH the same scene is within every limit.
    let bvh = RenderOptions {
        scene_storage: Some(pathmix::kernel::SceneStorage::Bvh),
        ..RenderOptions::default()
    };
    assert!(render::plan_kernel(ctx, &scene, &bvh).is_ok());
}

/// `convert` never replaces its input: a Mitsuba scene in a file named `.toml`
/// converted onto itself is refused, the file unchanged (issue 47, item 16).
#[test]
fn convert_onto_its_own_scene_is_refused() {
    let dir = common::TempDir::new("robustness", "convert-self");
    let scene = dir.join("scene.toml");
    let xml = r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor><shape type="sphere"/></scene>"#;
    std::fs::write(&scene, xml).unwrap();
    let output = pathmix_in(&dir, &["convert", "scene.toml", "-o", "./scene.toml"]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("same file"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), xml);
}

/// Every file a scene reads is an input of the path check, as the scene file
/// is: an output naming its environment map, its bitmap texture or an XML file
/// it includes is refused, and the file is left as it was (issue 47, item 15).
#[test]
fn outputs_never_replace_a_file_the_scene_reads() {
    let dir = common::TempDir::new("robustness", "scene-inputs");
    common::write_exr(&dir.join("env.exr"), 4, 2, |x, _| [x as f32 * 0.25; 3]);
    common::write_exr(&dir.join("tex.exr"), 2, 2, |x, y| {
        [0.2 + 0.1 * (x + y) as f32; 3]
    });
    std::fs::write(
        dir.join("scene.toml"),
        r#"
        [camera]
        lookfrom = [0, 1, 4]
        lookat = [0, 0, 0]
        width = 8
        height = 8
        [render]
        spp = 1
        [environment]
        file = "env.exr"
        [materials.floor]
        type = "lambertian"
        albedo = { type = "bitmap", file = "tex.exr" }
        [[objects]]
        type = "quad"
        q = [-1, 0, -1]
        u = [2, 0, 0]
        v = [0, 0, 2]
        material = "floor"
        "#,
    )
    .unwrap();
    std::fs::write(
        dir.join("part.toml"),
        r#"<scene version="3.0.0"><shape type="sphere"/></scene>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("main.xml"),
        r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor><include filename="part.toml"/></scene>"#,
    )
    .unwrap();
    let cases: [&[&str]; 5] = [
        &["render", "scene.toml", "--exr", "env.exr"],
        &["render", "scene.toml", "--variance", "./env.exr"],
        &["render", "scene.toml", "--exr", "tex.exr"],
        &["render", "main.xml", "--exr", "part.toml"],
        &["convert", "main.xml", "-o", "part.toml"],
    ];
    let before = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| {
            let path = e.unwrap().path();
            (path.clone(), std::fs::read(path).unwrap())
        })
        .collect::<BTreeMap<_, _>>();
    for args in cases {
        let output = pathmix_in(&dir, args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("same file"), "{args:?}: {stderr}");
    }
    for (path, bytes) in before {
        assert_eq!(std::fs::read(&path).unwrap(), bytes, "{}", path.display());
    }
}
