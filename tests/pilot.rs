//! `strategy = "auto"`: the pilot's choice where the answer is known, its error
//! estimate against a reference, and the command line's use of it.

mod common;

use common::pathmix;

use pathmix::kernel::AccumulatorKind;
use pathmix::render::{self, RenderError, RenderOptions, Renderer, StopRule};
use pathmix::scene::{Sampler, Scene, Strategy};
use pathmix::session::converge::{self, Variant};
use pathmix::session::pilot::{self, Pilot};
use pathmix::stats;
use std::path::Path;

use std::sync::{Mutex, MutexGuard};

/// The pilot's choices rest on timings of a few milliseconds, which another test's
/// renders beside them would distort: this file's GPU tests run one at a time.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A diffuse floor and a diffuse ball seen from above, lit by `light` (objects and
/// their materials, TOML), which the camera does not see: every pixel's noise is
/// that of the lighting, which the strategies differ in.
fn lit_floor(light: &str) -> Scene {
    let text = format!(
        "[camera]\nlookfrom = [0, 3, 6]\nlookat = [0, 0, 0]\nvfov = 40\nwidth = 64\nheight = 64\n\
         [render]\nspp = 64\nmax_depth = 3\n\
         [materials.floor]\ntype = \"lambertian\"\nalbedo = [0.7, 0.7, 0.7]\n\
         [materials.ball]\ntype = \"lambertian\"\nalbedo = [0.6, 0.3, 0.2]\n\
         [[objects]]\ntype = \"quad\"\nq = [-5, 0, 5]\nu = [10, 0, 0]\nv = [0, 0, -10]\nmaterial = \"floor\"\n\
         [[objects]]\ntype = \"sphere\"\ncenter = [0, 0.5, 0]\nradius = 0.5\nmaterial = \"ball\"\n\
         {light}"
    );
    Scene::parse(&text, "lit-floor.toml").unwrap()
}

/// A sphere light of radius 0.02 at height 4, bright enough to light the floor at
/// about 1: a cosine-sampled direction finds it about once in 10^5.
const TINY_BRIGHT_LIGHT: &str = "[materials.lamp]\ntype = \"light\"\nemit = [12000, 12000, 12000]\n\
     [[objects]]\ntype = \"sphere\"\ncenter = [0, 4, 0]\nradius = 0.02\nmaterial = \"lamp\"\n";

/// A 200×200 emitter of radiance 0.5 facing down at height 5: nearly the whole
/// upper hemisphere of every floor point. Cosine sampling meets it almost
/// everywhere; light sampling spreads its points over far-away parts seen edge-on.
const LARGE_DIM_EMITTER: &str = "[materials.sky]\ntype = \"light\"\nemit = [0.5, 0.5, 0.5]\n\
     [[objects]]\ntype = \"quad\"\nq = [-100, 5, -100]\nu = [200, 0, 0]\nv = [0, 0, 200]\nmaterial = \"sky\"\n";

/// The pilot of an open-ended run (no budget: every candidate is measured).
fn run_pilot(scene: &Scene) -> Pilot<'static> {
    let ctx = common::gpu().unwrap();
    let pilot = pilot::run(ctx, scene, &RenderOptions::default(), u32::MAX).unwrap();
    eprintln!("{}chose {}", pilot::table(&pilot), pilot.choice);
    pilot
}

fn efficiency(pilot: &Pilot, variant: Variant) -> f64 {
    let row = pilot.rows.iter().find(|r| r.variant == variant).unwrap();
    // A black pilot image (no sample found the light) has no efficiency: the worst.
    row.efficiency.unwrap_or(0.0)
}

/// A tiny bright light: aiming at it is the only way to find it. `nee-mis` or a
/// mixture weighted toward the light must win, and `bsdf` must be at least 20 times
/// less efficient than the winner (measured: 10^6 times and more, `nee-mis` winning
/// with the mixture at 0.01–0.15 of it; the margin covers the timing noise of a
/// shared machine, within 2x, many times over).
#[test]
fn a_tiny_bright_light_is_won_by_aiming_at_it() {
    let _ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    for sampler in [Sampler::Sobol, Sampler::Independent] {
        let mut scene = lit_floor(TINY_BRIGHT_LIGHT);
        scene.render.sampler = sampler;
        let pilot = run_pilot(&scene);
        let choice = pilot.choice;
        assert!(
            choice == Variant::NEE_MIS
                || (choice.strategy == Strategy::Mixture && choice.light_weight >= Some(0.5)),
            "{sampler}: chose {choice}"
        );
        let best = efficiency(&pilot, choice);
        let bsdf = efficiency(&pilot, Variant::BSDF);
        assert!(bsdf * 20.0 < best, "{sampler}: bsdf {bsdf}, best {best}");
    }
}

/// A large dim emitter over the whole sky: the material's own sampling must win,
/// or lose by at most 20% (a winner that close is within the timing noise).
/// Measured: `bsdf` wins, `nee-mis` at 0.31–0.44 of it, the mixture at 0.02–0.08.
#[test]
fn a_large_dim_emitter_is_won_by_bsdf_sampling() {
    let _ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    for sampler in [Sampler::Sobol, Sampler::Independent] {
        let mut scene = lit_floor(LARGE_DIM_EMITTER);
        scene.render.sampler = sampler;
        let pilot = run_pilot(&scene);
        let best = efficiency(&pilot, pilot.choice);
        let bsdf = efficiency(&pilot, Variant::BSDF);
        assert!(
            bsdf >= 0.8 * best,
            "{sampler}: chose {} at {best}, bsdf {bsdf}",
            pilot.choice
        );
    }
}

/// With nothing to aim at, `bsdf` is the only candidate: nothing is measured.
#[test]
fn without_lights_bsdf_is_chosen_without_a_pilot() {
    let _ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let mut scene = lit_floor("");
    scene.render.background = glam::Vec3::ONE;
    let pilot = run_pilot(&scene);
    assert_eq!((pilot.choice, pilot.rows.len()), (Variant::BSDF, 0));
}

/// On a run far shorter than building a kernel (8×8 pixels, 1 spp), the pilot stops
/// after its first candidate, the mixture at the first weight, and keeps it.
#[test]
fn the_pilot_of_a_tiny_run_stops_at_its_budget() {
    let ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let mut scene = lit_floor(TINY_BRIGHT_LIGHT);
    (scene.camera.width, scene.camera.height) = (8, 8);
    let pilot = pilot::run(ctx, &scene, &RenderOptions::default(), 1).unwrap();
    assert_eq!(pilot.rows.len(), 1, "{}", pilot::table(&pilot));
    assert_eq!(pilot.choice, Variant::mixture(pilot::FIRST_WEIGHT));
    assert_eq!(pilot.skipped, [Variant::NEE_MIS, Variant::BSDF]);
}

/// The pilot's estimated relative error against the relative RMSE measured against a
/// reference (`nee-mis`, Sobol, 2048 spp: two such references differ by 0.7%), on the
/// Cornell boxes at the pilot's size and samples, per candidate and sampler, summed
/// over three seeds: the estimated and measured relative MSE (so the efficiencies, the
/// same seconds over each) agree within a factor 1.5. A single seed scatters more:
/// small lights give rare bright paths, and one seed's `nee-mis` under Sobol measured
/// 0.49 of its error (seeds 11, 21, 31 gave 0.49, 1.43, 1.24; summed 0.94).
#[test]
fn estimated_efficiencies_agree_with_ones_measured_against_a_reference() {
    let ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let mut reference_scene = common::small_cornell_boxes(64, Sampler::Sobol);
    reference_scene.render.seed = 12;
    reference_scene.render.strategy = Strategy::NeeMis;
    let mut renderer = Renderer::new(ctx, &reference_scene, &Default::default()).unwrap();
    render::run(&mut renderer, StopRule::samples(2048), |_| {}).unwrap();
    let reference = renderer.accumulation().mean();
    for sampler in [Sampler::Sobol, Sampler::Independent] {
        for variant in [Variant::BSDF, Variant::NEE_MIS, Variant::mixture(0.5)] {
            let (mut estimated, mut measured) = (0.0, 0.0);
            for seed in [11, 21, 31] {
                let mut scene = common::small_cornell_boxes(64, sampler);
                scene.render.seed = seed;
                let options = RenderOptions::default();
                let (row, samples) =
                    pilot::measure(ctx, &scene, &options, variant, (64, 64), 64).unwrap();
                let image = samples.renderer.accumulation().mean();
                let error = stats::relative_rmse(&image, &reference).unwrap();
                let estimate = row.relative_error.unwrap();
                eprintln!(
                    "{sampler} {variant} seed {seed}: estimated {estimate:.4}, measured {error:.4}"
                );
                estimated += estimate.powi(2);
                measured += error.powi(2);
            }
            let ratio = estimated / measured;
            assert!(
                (1.0 / 1.5..=1.5).contains(&ratio),
                "{sampler} {variant}: estimated relative MSE / measured {ratio:.3}"
            );
        }
    }
}

/// The device's reduction of the error estimate (`Renderer::error_sums`) gives the
/// host's relative noise from the read-back sums, under both samplers and both
/// accumulators, on an image whose width is not a whole number of strips: within
/// 1e-4 (f32 sums of 64 pixels against f64).
#[test]
fn the_devices_error_estimate_is_the_hosts() {
    let ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    for sampler in [Sampler::Sobol, Sampler::Independent] {
        for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
            let mut scene = common::small_cornell_boxes(64, sampler);
            scene.camera.width = 100;
            scene.camera.height = 37;
            scene.render.strategy = Strategy::Mixture;
            let options = RenderOptions {
                variance: true,
                accumulator: Some(accumulator),
                ..Default::default()
            };
            let mut renderer = Renderer::new(ctx, &scene, &options).unwrap();
            render::run(&mut renderer, StopRule::samples(12), |_| {}).unwrap();
            let sums = renderer.error_sums().unwrap().unwrap();
            assert_eq!(sums.values, 3 * 100 * 37);
            assert_eq!(sums.non_finite, 0);
            let device = pilot::relative_noise(&sums).unwrap();
            let accumulation = renderer.accumulation();
            let error = accumulation.standard_error().unwrap();
            let host = converge::rms(&error) / stats::mean_value(&accumulation.mean());
            assert!(
                (device / host - 1.0).abs() < 1e-4,
                "{sampler} {accumulator:?}: device {device}, host {host}"
            );
        }
    }
}

/// A renderer refuses a scene whose strategy the pilot has not chosen yet.
#[test]
fn an_unresolved_auto_strategy_is_refused() {
    let ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let mut scene = lit_floor(TINY_BRIGHT_LIGHT);
    scene.render.auto_strategy = true;
    let error = Renderer::new(ctx, &scene, &Default::default())
        .err()
        .unwrap();
    assert!(
        matches!(error, RenderError::StrategyNotChosen { .. }),
        "{error}"
    );
}

// --- The command line ----------------------------------------------------------------

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// The variant on the pilot's `chose VARIANT` line of `stderr`.
fn chosen(stderr: &str) -> Variant {
    let name = stderr
        .lines()
        .find_map(|l| l.strip_prefix("chose "))
        .unwrap_or_else(|| panic!("{stderr}"));
    Variant::parse(name).unwrap()
}

/// The flags that give `variant` to a render.
fn strategy_flags(variant: Variant) -> Vec<String> {
    let mut flags = vec![
        "--strategy".to_string(),
        variant.strategy.name().to_string(),
    ];
    if let Some(w) = variant.light_weight {
        flags.extend(["--light-weight".to_string(), w.to_string()]);
    }
    flags
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `strategy = "auto"` in the scene file: the pilot's table and choice on stderr,
/// the choice on stdout; the checkpoint records it, so a resume runs no pilot and
/// continues bit-exactly as a run given the chosen strategy.
#[test]
fn auto_in_the_scene_file_prints_its_choice_and_resumes_without_a_pilot() {
    let _ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let dir = common::TempDir::new("pilot", "resume");
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml");
    let source = std::fs::read_to_string(&cornell).unwrap();
    assert!(source.contains("strategy = \"mixture\""));
    let scene = dir.join("auto.toml");
    std::fs::write(
        &scene,
        source.replace("strategy = \"mixture\"", "strategy = \"auto\""),
    )
    .unwrap();
    let ckpt = dir.join("run.ckpt");
    let small = ["--width", "24", "--height", "24", "--max-depth", "6"];
    let (first_exr, first_png) = (dir.join("first.exr"), dir.join("first.png"));
    let mut first = vec!["render", p(&scene), "--spp", "4", "--checkpoint", p(&ckpt)];
    first.extend(["-o", p(&first_png), "--exr", p(&first_exr)]);
    first.extend(small);
    let output = pathmix(&first);
    let (stdout, stderr) = (text(&output.stdout), text(&output.stderr));
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("strategy auto: pilot of "), "{stderr}");
    assert!(stderr.contains("candidate"), "{stderr}");
    let variant = chosen(&stderr);
    let chosen = variant.name();
    assert!(
        stdout.contains(&format!("strategy auto: {chosen} (pilot of ")),
        "{stdout}"
    );
    assert!(
        stderr.contains(&format!("strategy {}", variant.strategy)),
        "{stderr}"
    );

    let resumed_exr = dir.join("resumed.exr");
    let output = pathmix(&[
        "render",
        "--resume",
        p(&ckpt),
        "--spp",
        "12",
        "--exr",
        p(&resumed_exr),
        "-o",
        p(&dir.join("resumed.png")),
    ]);
    let (stdout, stderr) = (text(&output.stdout), text(&output.stderr));
    assert!(output.status.success(), "{stderr}");
    assert!(
        !stderr.contains("strategy auto") && !stdout.contains("strategy auto"),
        "{stderr}"
    );

    let (direct_exr, direct_png) = (dir.join("direct.exr"), dir.join("direct.png"));
    let flags = strategy_flags(variant);
    let mut direct = vec!["render", p(&scene), "--spp", "12"];
    direct.extend(flags.iter().map(String::as_str));
    direct.extend(small);
    direct.extend(["--exr", p(&direct_exr), "-o", p(&direct_png)]);
    let output = pathmix(&direct);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let resumed = pathmix::output::read_exr(&resumed_exr).unwrap();
    let direct = pathmix::output::read_exr(&direct_exr).unwrap();
    assert!(
        resumed.pixels == direct.pixels,
        "a resumed auto run differs from a run given its choice ({chosen})"
    );
}

/// Shards and partial results would each run a pilot of their own; the pilot
/// chooses the light weight. Refused before rendering, exit 2.
#[test]
fn auto_with_shards_or_a_light_weight_is_refused() {
    let dir = common::TempDir::new("pilot", "refused");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml");
    let out = dir.join("x.png");
    for (extra, flag) in [
        (&["--shard", "0/2"][..], "--shard"),
        (&["--sample-range", "0..4"][..], "--sample-range"),
        (&["--partial", p(&dir.join("x.exr"))][..], "--partial"),
        (&["--light-weight", "0.3"][..], "--light-weight"),
    ] {
        let mut args = vec!["render", p(&scene), "--strategy", "auto", "-o", p(&out)];
        args.extend(extra);
        let output = pathmix(&args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{flag}: {stderr}");
        assert!(stderr.contains(flag) && stderr.contains("auto"), "{stderr}");
        assert!(!out.exists());
    }
}

/// Where the pilot renders the run's own image and the run estimates errors, the
/// chosen candidate's samples are the run's first ones: the run traces only the
/// rest, and its image is the image of a run given the chosen strategy, bit for
/// bit, uniform with `--variance` or adaptive (the adaptive run's own pilot goes on
/// from them), and under the independent sampler. A run that estimates no error
/// lays out Sobol's samples as one sequence per pixel, not in the candidates'
/// replicates: it starts afresh, and its image is that of a plain run given the
/// choice.
#[test]
fn the_chosen_candidates_pilot_samples_start_the_run() {
    let _ctx = gpu_or_skip!();
    let _alone = one_at_a_time();
    let dir = common::TempDir::new("pilot", "reuse");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml");
    // 24×24 at 256 spp: the pilot's 8 spp per candidate fit at the run's size.
    assert_eq!(pilot::shape(24, 24, 256), ((24, 24), 8));
    let small = [
        "--width",
        "24",
        "--height",
        "24",
        "--max-depth",
        "6",
        "--spp",
        "256",
    ];
    let png = dir.join("x.png");
    // The samples are copied on the device, from either accumulator.
    for (adaptive, variance, accumulator, sampler) in [
        (false, true, "texture", "sobol"),
        (true, false, "texture", "sobol"),
        (false, true, "buffer", "sobol"),
        (false, false, "texture", "sobol"),
        (false, false, "texture", "independent"),
    ] {
        let case = format!(
            "adaptive {adaptive}, variance {variance}, {accumulator} accumulator, {sampler} sampler"
        );
        let mut extra = vec!["--accumulator", accumulator, "--sampler", sampler];
        if adaptive {
            extra.push("--adaptive");
        }
        let name = format!("{adaptive}-{variance}-{accumulator}-{sampler}");
        let auto_exr = dir.join(format!("auto-{name}.exr"));
        let auto_se = dir.join(format!("auto-se-{name}.exr"));
        let mut args = vec!["render", p(&scene), "--strategy", "auto"];
        args.extend(["-o", p(&png), "--exr", p(&auto_exr)]);
        if variance {
            args.extend(["--variance", p(&auto_se)]);
        }
        args.extend(small);
        args.extend(&extra);
        let output = pathmix(&args);
        let stderr = text(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        let variant = chosen(&stderr);
        let chosen = variant.name();
        let reused = format!("the pilot's 8 spp of {chosen} are the run's first samples");
        let same_layout = adaptive || variance || sampler == "independent";
        assert_eq!(stderr.contains(&reused), same_layout, "{case}: {stderr}");
        let direct_exr = dir.join(format!("direct-{name}.exr"));
        let direct_se = dir.join(format!("direct-se-{name}.exr"));
        let flags = strategy_flags(variant);
        let mut direct = vec!["render", p(&scene)];
        direct.extend(flags.iter().map(String::as_str));
        direct.extend(["-o", p(&png), "--exr", p(&direct_exr)]);
        if variance {
            direct.extend(["--variance", p(&direct_se)]);
        }
        direct.extend(small);
        direct.extend(&extra);
        let output = pathmix(&direct);
        assert!(output.status.success(), "{}", text(&output.stderr));
        let auto = pathmix::output::read_exr(&auto_exr).unwrap();
        let direct = pathmix::output::read_exr(&direct_exr).unwrap();
        assert!(
            auto.pixels == direct.pixels,
            "{case}: an auto run differs from a run given its choice ({chosen})"
        );
    }
}
