//! Progressive runs that lose nothing: checkpoints and resume, interruption,
//! shards and merging, through the library and the binary.

mod common;

use pathmix::kernel::AccumulatorKind;
use pathmix::render::{AccumulatorState, RenderOptions, Renderer};
use pathmix::scene::{Scene, SceneOverrides};
use pathmix::session::checkpoint::{self, Checkpoint, SceneIdentity};
use pathmix::session::shard::{self, Partial};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn small_scene(spp: u32) -> Scene {
    let mut scene = common::scene_file("cornell-boxes.toml");
    scene
        .apply_overrides(&SceneOverrides {
            width: Some(16),
            height: Some(12),
            spp: Some(spp),
            ..Default::default()
        })
        .unwrap();
    scene
}

fn render_until(renderer: &mut Renderer, samples: u32) {
    while renderer.samples() < samples {
        renderer.advance(samples - renderer.samples());
    }
}

fn bits(state: &AccumulatorState) -> Vec<[u32; 4]> {
    state.texels.iter().map(|t| t.map(f32::to_bits)).collect()
}

#[test]
fn resumed_renderer_continues_bit_exactly() {
    let ctx = gpu_or_skip!();
    let scene = small_scene(9);
    let options = common::with_variance();
    let mut whole = Renderer::new(ctx, &scene, &options).unwrap();
    render_until(&mut whole, 9);
    let expected = whole.export_state();

    let mut first = Renderer::new(ctx, &scene, &options).unwrap();
    render_until(&mut first, 4);
    // Through the checkpoint format, into the other accumulator kind where there is one.
    let saved = Checkpoint {
        pathmix_version: env!("CARGO_PKG_VERSION").into(),
        scene_path: "scene.toml".into(),
        overrides: SceneOverrides::default(),
        identity: SceneIdentity::of(&scene),
        discarded: 0,
        run: Default::default(),
        state: first.export_state(),
    };
    let restored = checkpoint::from_bytes(&checkpoint::to_bytes(&saved)).unwrap();
    assert_eq!(restored, saved);
    let kinds = if ctx.storage_texture_accumulator {
        vec![AccumulatorKind::Buffer, AccumulatorKind::Texture]
    } else {
        vec![AccumulatorKind::Buffer]
    };
    for kind in kinds {
        let options = RenderOptions {
            accumulator: Some(kind),
            ..common::with_variance()
        };
        let mut second = Renderer::new(ctx, &scene, &options).unwrap();
        second.import_state(&restored.state).unwrap();
        assert_eq!(second.samples(), 4);
        render_until(&mut second, 9);
        let resumed = second.export_state();
        assert_eq!(resumed.samples, 9);
        assert!(bits(&resumed) == bits(&expected), "{kind:?}: sums differ");
        assert_eq!(second.accumulation(), whole.accumulation());
    }
    // A state of the wrong shape is refused.
    let mut plain = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    assert!(plain.import_state(&expected).is_err());
}

#[test]
fn sample_offset_shards_merge_to_one_run() {
    let ctx = gpu_or_skip!();
    let scene = small_scene(10);
    let identity = SceneIdentity::of(&scene);
    let options = common::with_variance();
    let mut parts = Vec::new();
    for range in [0..3, 7..10, 3..7] {
        let mut renderer = Renderer::new(ctx, &scene, &options).unwrap();
        renderer.set_first_sample(range.start).unwrap();
        render_until(&mut renderer, range.len() as u32);
        assert!(renderer.set_first_sample(0).is_err());
        let partial =
            Partial::from_state(identity.clone(), "scene".into(), 0, renderer.export_state());
        assert_eq!(partial.range, range);
        parts.push((format!("{range:?}"), partial));
    }
    let merged = shard::merge(&parts).unwrap();
    assert!(merged.gaps.is_empty());
    let one = common::render(ctx, &scene, &options);
    assert_eq!(merged.accumulation.samples, one.samples);
    assert_close(&merged.accumulation.mean(), &one.mean(), 1e-6);
    assert_close(
        &merged.accumulation.standard_error().unwrap(),
        &one.standard_error().unwrap(),
        1e-4,
    );
}

/// Every channel of every pixel within `relative` of the reference.
fn assert_close(a: &pathmix::output::Image, b: &pathmix::output::Image, relative: f64) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (x, y)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let (x, y) = (x[c] as f64, y[c] as f64);
            assert!(
                (x - y).abs() <= relative * y.abs().max(1e-30),
                "pixel {i} channel {c}: {x} vs {y}"
            );
        }
    }
}

// ---- the binary ----

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_pathmix")
}

fn pathmix(args: &[&str]) -> Output {
    Command::new(bin()).args(args).output().unwrap()
}

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .display()
        .to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn wait_for(path: &Path, child: &mut std::process::Child) {
    let started = Instant::now();
    while !path.exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before its first checkpoint"
        );
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no checkpoint"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(unix)]
fn signal(child: &std::process::Child, signal: i32) {
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
}

/// Ctrl-C mid-run saves a checkpoint; resuming it gives the same bits as one
/// uninterrupted run of the same samples.
#[cfg(unix)]
#[test]
fn interrupt_and_resume_equals_uninterrupted_bit_for_bit() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "interrupt");
    let scene = repo("scenes/cornell-boxes.toml");
    let (ckpt, exr, png) = (
        dir.join("run.ckpt"),
        dir.join("run.exr"),
        dir.join("run.png"),
    );
    // Enough work (about 2 s on lavapipe) that the interrupt comes mid-run.
    let spp = "50000";
    let size = ["--width", "32", "--height", "32"];
    let mut child = Command::new(bin())
        .args([
            "render",
            &scene,
            "--spp",
            spp,
            "--variance",
            p(&dir.join("se.exr")),
        ])
        .args(size)
        .args(["--checkpoint", p(&ckpt), "--checkpoint-every", "300ms"])
        .args(["-o", p(&png), "--exr", p(&exr), "--quiet"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for(&ckpt, &mut child);
    signal(&child, libc::SIGINT);
    let output = child.wait_with_output().unwrap();
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    let saved: u32 = stderr
        .split("saved ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no saved-samples message: {stderr}"));
    assert!(saved > 0 && saved < 50000, "{stderr}");
    assert!(stderr.contains("SIGINT"), "{stderr}");
    assert_eq!(checkpoint::read(&ckpt).unwrap().state.samples, saved);
    assert!(
        png.exists() && exr.exists(),
        "the images so far are written"
    );
    let resume_line = stderr
        .lines()
        .find_map(|l| l.strip_prefix("resume with: "))
        .unwrap_or_else(|| panic!("no resume command: {stderr}"));
    assert!(
        resume_line.ends_with(&format!("render --resume {}", p(&ckpt))),
        "{resume_line}"
    );

    // The printed command: the checkpoint knows the scene, settings, spp and outputs.
    let resumed = pathmix(&["render", "--resume", p(&ckpt), "--quiet"]);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    assert!(
        text(&resumed.stdout).contains("at 50000 spp"),
        "{}",
        text(&resumed.stdout)
    );

    let (ref_ckpt, ref_exr) = (dir.join("ref.ckpt"), dir.join("ref.exr"));
    let reference = Command::new(bin())
        .args([
            "render",
            &scene,
            "--spp",
            spp,
            "--variance",
            p(&dir.join("ref-se.exr")),
        ])
        .args(size)
        .args(["--checkpoint", p(&ref_ckpt), "-o", p(&dir.join("ref.png"))])
        .args(["--exr", p(&ref_exr), "--quiet"])
        .output()
        .unwrap();
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let (a, b) = (
        checkpoint::read(&ckpt).unwrap(),
        checkpoint::read(&ref_ckpt).unwrap(),
    );
    assert_eq!(a.state.samples, 50000);
    assert!(bits(&a.state) == bits(&b.state), "resumed sums differ");
    assert_eq!(a.identity, b.identity);
    assert_eq!(
        std::fs::read(&exr).unwrap(),
        std::fs::read(&ref_exr).unwrap()
    );
    assert_eq!(
        std::fs::read(dir.join("se.exr")).unwrap(),
        std::fs::read(dir.join("ref-se.exr")).unwrap()
    );
}

/// A second Ctrl-C exits at once; whatever is on disk is whole.
#[cfg(unix)]
#[test]
fn second_interrupt_exits_at_once_leaving_whole_files() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "twice");
    let ckpt = dir.join("run.ckpt");
    let mut child = Command::new(bin())
        .args([
            "render",
            &repo("scenes/cornell-boxes.toml"),
            "--spp",
            "100000",
        ])
        .args(["--width", "32", "--height", "32", "--quiet"])
        .args(["--checkpoint", p(&ckpt), "--checkpoint-every", "100ms"])
        .args(["-o", p(&dir.join("out.png"))])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for(&ckpt, &mut child);
    signal(&child, libc::SIGINT);
    signal(&child, libc::SIGINT);
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(checkpoint::read(&ckpt).unwrap().state.samples > 0);
    assert_eq!(
        debris(&dir),
        Vec::<String>::new(),
        "temporaries and the lock removed"
    );
}

#[cfg(unix)]
#[test]
fn sigterm_saves_and_exits_143() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "term");
    let ckpt = dir.join("run.ckpt");
    let mut child = Command::new(bin())
        .args(["render", &repo("scenes/furnace.toml"), "--spp", "100000"])
        .args(["--width", "16", "--height", "16", "--quiet"])
        .args(["--checkpoint", p(&ckpt), "--checkpoint-every", "100ms"])
        .args(["-o", p(&dir.join("out.png"))])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for(&ckpt, &mut child);
    signal(&child, libc::SIGTERM);
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(143), "{}", text(&output.stderr));
    assert!(text(&output.stderr).contains("SIGTERM"));
}

/// Makes a small checkpoint and a small partial result.
fn small_outputs(dir: &Path, scene: &str) -> (PathBuf, PathBuf) {
    let (ckpt, part) = (dir.join("run.ckpt"), dir.join("part.exr"));
    let output = pathmix(&[
        "render",
        scene,
        "--spp",
        "4",
        "--width",
        "8",
        "--height",
        "6",
        "--checkpoint",
        p(&ckpt),
        "--partial",
        p(&part),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    (ckpt, part)
}

#[test]
fn damaged_checkpoints_and_partials_are_refused() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "damaged");
    let (ckpt, part) = small_outputs(&dir, &repo("scenes/cornell-boxes.toml"));
    let bytes = std::fs::read(&ckpt).unwrap();
    let damaged = dir.join("damaged.ckpt");
    let mut flipped = bytes.clone();
    flipped[bytes.len() * 2 / 3] ^= 0x08;
    for (content, expected) in [
        (bytes[..bytes.len() - 100].to_vec(), "truncated"),
        (flipped, "corrupted"),
        (
            b"not a checkpoint at all".to_vec(),
            "not a pathmix checkpoint",
        ),
    ] {
        std::fs::write(&damaged, content).unwrap();
        let output = pathmix(&[
            "render",
            "--resume",
            p(&damaged),
            "-o",
            p(&dir.join("x.png")),
        ]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(expected) && stderr.contains("damaged.ckpt"),
            "{stderr}"
        );
    }
    assert!(!dir.join("x.png").exists());

    let bytes = std::fs::read(&part).unwrap();
    let damaged = dir.join("damaged.exr");
    let mut flipped = bytes.clone();
    flipped[bytes.len() - 40] ^= 0x01;
    for (content, expected) in [
        (bytes[..bytes.len() - 30].to_vec(), "truncated or corrupted"),
        (flipped, "corrupted"),
    ] {
        std::fs::write(&damaged, content).unwrap();
        let output = pathmix(&["merge", p(&damaged), "-o", p(&dir.join("m.png"))]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(expected) && stderr.contains("damaged.exr"),
            "{stderr}"
        );
    }
    assert!(!dir.join("m.png").exists());
}

#[test]
fn changed_scene_on_resume_is_refused_naming_what_differs() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "changed");
    let original = std::fs::read_to_string(repo("scenes/cornell-boxes.toml")).unwrap();
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, &original).unwrap();
    let (ckpt, _) = small_outputs(&dir, p(&scene));
    for (from, to, expected) in [
        ("vfov = 40", "vfov = 35", "the camera differs"),
        (
            "[0.73, 0.73, 0.73]",
            "[0.5, 0.73, 0.73]",
            "the materials differ",
        ),
        (
            "max_depth = 50",
            "max_depth = 3",
            "max_depth 50 in the checkpoint, 3 in the scene now",
        ),
    ] {
        assert!(original.contains(from), "{from}");
        std::fs::write(&scene, original.replacen(from, to, 1)).unwrap();
        let output = pathmix(&["render", "--resume", p(&ckpt), "--spp", "8"]);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(expected) && stderr.contains("scene.toml"),
            "{stderr}"
        );
    }
    // A moved scene file can be given again; unchanged, it resumes.
    let moved = dir.join("moved.toml");
    std::fs::write(&moved, &original).unwrap();
    let output = pathmix(&[
        "render",
        "--resume",
        p(&ckpt),
        p(&moved),
        "--spp",
        "6",
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert_eq!(checkpoint::read(&ckpt).unwrap().state.samples, 6);
}

/// The deploy scripts as a scheduler would run them (here four local processes
/// standing in for the Slurm array tasks), then the merge step, against one run.
#[cfg(unix)]
#[test]
fn shards_from_the_deploy_scripts_merge_to_one_run() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "shards");
    let scene = repo("scenes/cornell-boxes.toml");
    let parts = dir.join("parts");
    let flags = "--width 24 --height 16";
    let env = |command: &mut Command| {
        command
            .env("PATHMIX", bin())
            .env("PATHMIX_DEPLOY", repo("deploy"))
            .env("SCENE", &scene)
            .env("SPP", "1000")
            .env("OUT", &parts)
            .env("PATHMIX_FLAGS", flags)
            .env("IMAGE", dir.join("final.png"))
            .env("EXR", dir.join("final.exr"));
    };
    let children: Vec<_> = (0..4)
        .map(|task| {
            let mut command = Command::new("sh");
            command
                .arg(repo("deploy/slurm/render-shard.sh"))
                .env("SLURM_ARRAY_TASK_ID", task.to_string())
                .env("SLURM_ARRAY_TASK_COUNT", "4")
                .stdout(Stdio::piped())
                .stderr(Stdio::piped());
            env(&mut command);
            command.spawn().unwrap()
        })
        .collect();
    for child in children {
        let output = child.wait_with_output().unwrap();
        assert!(output.status.success(), "{}", text(&output.stderr));
    }
    let ranges: Vec<_> = (0..4)
        .map(|i| {
            shard::read_partial(&parts.join(format!("part-{i}.exr")))
                .unwrap()
                .range
        })
        .collect();
    assert_eq!(ranges, [0..250, 250..500, 500..750, 750..1000]);

    let mut merge = Command::new("sh");
    merge.arg(repo("deploy/slurm/merge.sh")).env("SHARDS", "4");
    env(&mut merge);
    let output = merge.output().unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(
        text(&output.stdout).contains("samples 0..1000 (1000 spp)"),
        "{}",
        text(&output.stdout)
    );

    let one = dir.join("one.exr");
    let output = pathmix(&[
        "render",
        &scene,
        "--spp",
        "1000",
        "--width",
        "24",
        "--height",
        "16",
        "-o",
        p(&dir.join("one.png")),
        "--exr",
        p(&one),
        // The parts estimate errors, so Sobol's samples are in replicates there.
        "--variance",
        p(&dir.join("one-se.exr")),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let merged = pathmix::output::read_exr(&dir.join("final.exr")).unwrap();
    let single = pathmix::output::read_exr(&one).unwrap();
    assert_close(&merged, &single, 1e-6);

    let part = |i: u32| p(&parts.join(format!("part-{i}.exr"))).to_string();
    // `-o NAME.exr` writes the linear image.
    let as_exr = dir.join("merged-o.exr");
    let all: Vec<String> = (0..4).map(part).collect();
    let mut args = vec!["merge"];
    args.extend(all.iter().map(String::as_str));
    args.extend(["-o", p(&as_exr)]);
    let output = pathmix(&args);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert_eq!(pathmix::output::read_exr(&as_exr).unwrap(), merged);

    // Gaps are listed, overlaps and other scenes refused.
    let output = pathmix(&["merge", &part(0), &part(3), "-o", p(&dir.join("gap.png"))]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(
        text(&output.stderr).contains("no part holds sample indices 250..750"),
        "{}",
        text(&output.stderr)
    );
    let overlap = dir.join("overlap.exr");
    let output = pathmix(&[
        "render",
        &scene,
        "--sample-range",
        "200..300",
        "--width",
        "24",
        "--height",
        "16",
        "--partial",
        p(&overlap),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let output = pathmix(&[
        "merge",
        &part(0),
        &part(1),
        p(&overlap),
        "-o",
        p(&dir.join("o.png")),
    ]);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("part-0.exr` (samples 0..250) and `")
            && stderr.contains("overlap.exr` (samples 200..300) overlap in 200..250"),
        "{stderr}"
    );
    let other = dir.join("other.exr");
    let output = pathmix(&[
        "render",
        &scene,
        "--sample-range",
        "1000..1010",
        "--width",
        "24",
        "--height",
        "16",
        "--seed",
        "9",
        "--partial",
        p(&other),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let output = pathmix(&["merge", &part(0), p(&other), "-o", p(&dir.join("s.png"))]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        text(&output.stderr).contains("seed 9"),
        "{}",
        text(&output.stderr)
    );
}

/// Hidden files beside the outputs (temporaries, probes, locks).
fn debris(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.starts_with('.'))
        .collect()
}

/// An interrupted last shard is refused by the merge, which names what it
/// holds and what it was asked for; `--allow-incomplete` merges it with a warning.
#[cfg(unix)]
#[test]
fn an_interrupted_shard_is_refused_by_merge() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "short-shard");
    let scene = repo("scenes/furnace.toml");
    let size = ["--width", "16", "--height", "16", "--quiet"];
    let (q0, q1, ckpt) = (dir.join("q0.exr"), dir.join("q1.exr"), dir.join("q1.ckpt"));
    // Shard 0 stands in for a complete part (a few of its samples: the gap is only warned about).
    let shard0 = pathmix(
        &[
            &[
                "render",
                &scene,
                "--sample-range",
                "0..8",
                "--partial",
                p(&q0),
            ][..],
            &size,
        ]
        .concat(),
    );
    assert!(shard0.status.success(), "{}", text(&shard0.stderr));
    let mut child = Command::new(bin())
        .args(["render", &scene, "--spp", "2000000", "--shard", "1/2"])
        .args(size)
        .args(["--partial", p(&q1), "--checkpoint", p(&ckpt)])
        .args(["--checkpoint-every", "100ms"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for(&ckpt, &mut child);
    signal(&child, libc::SIGTERM);
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(143), "{}", text(&output.stderr));
    let part = shard::read_partial(&q1).unwrap();
    assert!(part.interrupted);
    assert_eq!(part.requested, Some(1000000..2000000));
    assert!(part.range.end < 2000000);

    let merge = |extra: &[&str]| {
        pathmix(
            &[
                &["merge", p(&q0), p(&q1), "-o", p(&dir.join("m.png"))][..],
                extra,
            ]
            .concat(),
        )
    };
    let refused = merge(&[]);
    let stderr = text(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("q1.exr") && stderr.contains("1000000..2000000"),
        "{stderr}"
    );
    assert!(!dir.join("m.png").exists());
    let allowed = merge(&["--allow-incomplete"]);
    let stderr = text(&allowed.stderr);
    assert!(allowed.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains("q1.exr"),
        "{stderr}"
    );
}

/// Two resumes of one checkpoint cannot both run: the second is refused, naming
/// the process that holds it, and leaves the checkpoint alone.
#[cfg(unix)]
#[test]
fn two_resumes_of_one_checkpoint_cannot_both_run() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "two-resumes");
    let ckpt = dir.join("run.ckpt");
    let started = pathmix(&[
        "render",
        &repo("scenes/furnace.toml"),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "4",
        "--quiet",
        "--checkpoint",
        p(&ckpt),
        "-o",
        p(&dir.join("out.png")),
    ]);
    assert!(started.status.success(), "{}", text(&started.stderr));
    let lock = dir.join(".run.ckpt.lock");
    let mut first = Command::new(bin())
        .args([
            "render",
            "--resume",
            p(&ckpt),
            "--spp",
            "5000000",
            "--quiet",
        ])
        .args(["--checkpoint-every", "100ms"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for(&lock, &mut first);
    let second = pathmix(&["render", "--resume", p(&ckpt), "--spp", "8", "--quiet"]);
    let stderr = text(&second.stderr);
    signal(&first, libc::SIGINT);
    let status = first.wait().unwrap();
    assert_eq!(second.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("in use") && stderr.contains(&format!("process {}", first.id())),
        "{stderr}"
    );
    assert_eq!(status.code(), Some(130));
    assert!(checkpoint::read(&ckpt).unwrap().state.samples >= 4);
    assert_eq!(
        debris(&dir),
        Vec::<String>::new(),
        "the lock is removed at the end"
    );
}

/// SIGKILL at random moments of a run that checkpoints as often as it can:
/// the checkpoint on disk is always whole (the old one or the new one), and the
/// next run removes the temporaries the killed ones left.
#[cfg(unix)]
#[test]
fn sigkill_during_checkpoint_writes_never_damages_the_checkpoint() {
    if common::gpu().is_none() {
        return;
    }
    let dir = common::TempDir::new("prog", "kill-loop");
    let ckpt = dir.join("run.ckpt");
    let png = dir.join("out.png");
    let run = || {
        Command::new(bin())
            .args(["render", &repo("scenes/furnace.toml"), "--spp", "100000000"])
            .args(["--width", "64", "--height", "64", "--quiet"])
            .args(["--checkpoint", p(&ckpt), "--checkpoint-every", "1ms"])
            .args(["--preview-every", "1ms", "-o", p(&png)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    // A fixed sequence of delays (a simple LCG): random moments, reproducible.
    let mut state = 12345u64;
    for _ in 0..20 {
        let mut child = run();
        wait_for(&ckpt, &mut child);
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        std::thread::sleep(Duration::from_millis((state >> 33) % 150));
        signal(&child, libc::SIGKILL);
        child.wait().unwrap();
        let saved = checkpoint::read(&ckpt).expect("the checkpoint on disk is whole");
        assert!(saved.state.samples > 0);
        if png.exists() {
            image::open(&png).expect("the preview on disk is whole");
        }
    }
    // The next run starts by clearing what the killed runs left.
    let cleaned = pathmix(&[
        "render",
        &repo("scenes/furnace.toml"),
        "--spp",
        "1",
        "--width",
        "64",
        "--height",
        "64",
        "--quiet",
        "--checkpoint",
        p(&ckpt),
        "-o",
        p(&png),
    ]);
    assert!(cleaned.status.success(), "{}", text(&cleaned.stderr));
    assert_eq!(debris(&dir), Vec::<String>::new());
}

/// No checkpoint or partial result ever holds sums a run found wrong: where a
/// pixel's invocation could be cut short by lavapipe's loop limit (the knot
/// read from buffers, 4 608 faces a ray, 17 vertices a path), the run is
/// refused before any work, as a checkpoint, a shard's checkpoint or its
/// partial (issue 47, items 22 to 24: they used to hold the wrong sums, and
/// resumed and merged into images 17-23% off). A run cut short all the same
/// (a BVH walk past its allowance) fails within a second, saving nothing.
#[test]
fn sums_cut_short_are_never_saved() {
    let _ = gpu_or_skip!();
    let dir = common::TempDir::new("progressive", "cut-short");
    let knot = repo("scenes/knot.toml");
    let small = [
        "--width",
        "48",
        "--height",
        "48",
        "--scene-storage",
        "buffers",
        "--quiet",
    ];
    let checkpoint = dir.join("c.ckpt");
    let png = dir.join("c.png");
    let mut whole = vec!["render", &knot, "-o", p(&png)];
    whole.extend(small);
    whole.extend(["--checkpoint", p(&checkpoint), "--checkpoint-every", "0.1s"]);
    let shard_checkpoint = dir.join("s0.ckpt");
    let partial = dir.join("p0.exr");
    let mut shard = vec!["render", &knot, "--shard", "0/2", "--partial", p(&partial)];
    shard.extend(small);
    shard.extend([
        "--checkpoint",
        p(&shard_checkpoint),
        "--checkpoint-every",
        "0.1s",
    ]);
    for args in [whole, shard] {
        let output = pathmix(&args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("loop iterations") && stderr.contains("scene storage `bvh`"),
            "{args:?}: {stderr}"
        );
    }
    assert!(debris(&dir).is_empty(), "{:?}", debris(&dir));
    for path in [&checkpoint, &shard_checkpoint, &partial, &png] {
        assert!(!path.exists(), "{} was written", path.display());
    }
}
