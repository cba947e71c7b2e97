//! The render session as a library caller uses it (`pathmix::session`): a
//! `Request` planned, rendered and written with no command line, refusals as
//! typed errors naming settings, a run cut in two through its checkpoint (or
//! rendered in steps) giving the same sums as one uninterrupted run, and a
//! device that keeps its kernels building each config once.

mod common;

use pathmix::session::checkpoint;
use pathmix::session::{Outputs, Request, Session, SessionError, Setting};
use pathmix::stats::Accumulation;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml")
}

/// A small render of the Cornell box with `spp` samples.
fn request(spp: u32) -> Request {
    let mut request = Request {
        scene: Some(cornell()),
        spp: Some(spp),
        ..Request::default()
    };
    request.overrides.width = Some(16);
    request.overrides.height = Some(12);
    request
}

/// Plans, renders and writes `request`, returning the run's sums.
fn render(ctx: &pathmix::gpu::GpuContext, request: &Request) -> (Accumulation, Vec<PathBuf>) {
    let session = Session::plan(request).unwrap();
    let mut run = session.start(ctx, None).unwrap();
    let summary = run.render(&AtomicBool::new(false), |_| {}).unwrap();
    let outcome = run.finish(summary).unwrap();
    (run.renderer.accumulation(), outcome.written)
}

#[test]
fn refusals_name_settings() {
    let dir = common::TempDir::new("session", "refusals");
    let every = Request {
        checkpoint_every: Some(std::time::Duration::from_secs(5)),
        ..request(4)
    };
    assert!(matches!(
        Session::plan(&every),
        Err(SessionError::CheckpointEveryWithoutCheckpoint)
    ));
    let same = dir.join("same.exr");
    let collision = Request {
        outputs: Outputs {
            exr: Some(same.clone()),
            variance: Some(same),
            ..Outputs::default()
        },
        ..request(4)
    };
    match Session::plan(&collision) {
        Err(SessionError::SameFile(c)) => {
            assert_eq!(
                (c.first.label.setting, c.second.label.setting),
                (Setting::Exr, Setting::Variance)
            );
            let message = SessionError::SameFile(c).to_string();
            assert!(
                message.contains("exr") && message.contains("variance"),
                "{message}"
            );
        }
        other => panic!("expected a collision, got {:?}", other.err()),
    }
    let counts = Request {
        outputs: Outputs {
            sample_counts: Some(dir.join("counts.exr")),
            ..Outputs::default()
        },
        ..request(4)
    };
    assert!(matches!(
        Session::plan(&counts),
        Err(SessionError::SampleCountsWithoutAdaptive)
    ));
    let missing = Request {
        scene: Some(dir.join("missing.toml")),
        ..request(4)
    };
    let error = Session::plan(&missing).err().unwrap();
    assert!(error.is_input() && error.to_string().contains("missing.toml"));
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "nothing written"
    );
}

#[test]
fn a_run_resumed_from_its_checkpoint_gives_the_uninterrupted_sums() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("session", "resume");
    let (whole, _) = render(ctx, &request(8));

    let checkpoint = dir.join("run.ckpt");
    let png = dir.join("first.png");
    let first = Request {
        checkpoint: Some(checkpoint.clone()),
        outputs: Outputs {
            png: Some(png.clone()),
            ..Outputs::default()
        },
        ..request(3)
    };
    let (_, written) = render(ctx, &first);
    assert_eq!(written, [checkpoint.clone(), png], "the checkpoint first");
    assert_eq!(checkpoint::read(&checkpoint).unwrap().state.samples, 3);

    let resumed = Request {
        resume: Some(checkpoint.clone()),
        spp: Some(8),
        ..Request::default()
    };
    let session = Session::plan(&resumed).unwrap();
    let recorded = std::fs::canonicalize(cornell()).unwrap();
    assert_eq!(session.scene_path, recorded, "the recorded scene");
    let (sums, _) = render(ctx, &resumed);
    assert_eq!(sums.samples, 8);
    assert_eq!(sums, whole, "bit-identical to one run of 8 samples");
}

/// Defaults by measurement (issue 48): the sampler only changes the noise, so a
/// Mitsuba file's `independent` (Mitsuba's default) renders with Sobol, and
/// adaptive sampling takes Sobol over a scene's independent sampler, each with a
/// note; a run that asks for the independent sampler itself gets it (and is
/// refused with adaptive sampling). The rounds lower the error a target-error
/// run stops on (absolute), else the relative error.
#[test]
fn the_run_picks_its_defaults_and_says_so() {
    use pathmix::scene::{AdaptiveMetric, Sampler};
    let dir = common::TempDir::new("session", "defaults");
    let xml = dir.join("scene.xml");
    std::fs::write(
        &xml,
        r#"<scene version="3.0.0">
             <sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><integer name="width" value="8"/>
               <integer name="height" value="6"/></film></sensor>
             <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
           </scene>"#,
    )
    .unwrap();
    let plan = |request: &Request| Session::plan(request).unwrap();
    let mitsuba = Request {
        scene: Some(xml.clone()),
        ..Request::default()
    };
    let session = plan(&mitsuba);
    assert_eq!(session.scene.render.sampler, Sampler::Sobol);
    assert!(
        session
            .warnings
            .iter()
            .any(|w| w.contains("independent sampler (Mitsuba's default)")),
        "{:?}",
        session.warnings
    );
    let mut asked = mitsuba.clone();
    asked.overrides.sampler = Some(Sampler::Independent);
    let session = plan(&asked);
    assert_eq!(session.scene.render.sampler, Sampler::Independent);
    assert!(session.warnings.is_empty(), "{:?}", session.warnings);
    asked.adaptive = true;
    assert!(Session::plan(&asked).is_err());

    let toml = dir.join("independent.toml");
    let text = std::fs::read_to_string(cornell()).unwrap();
    std::fs::write(
        &toml,
        text.replace("[render]", "[render]\nsampler = \"independent\""),
    )
    .unwrap();
    let mut adaptive = Request {
        scene: Some(toml),
        adaptive: true,
        ..request(16)
    };
    let session = plan(&adaptive);
    assert_eq!(session.scene.render.sampler, Sampler::Sobol);
    assert!(
        session
            .warnings
            .iter()
            .any(|w| w.contains("adaptive sampling decides")),
        "{:?}",
        session.warnings
    );
    assert_eq!(
        session.scene.render.adaptive_metric, None,
        "relative, the renderer's default"
    );
    adaptive.target_error = Some(0.1);
    let session = plan(&adaptive);
    assert_eq!(
        session.scene.render.adaptive_metric,
        Some(AdaptiveMetric::Absolute)
    );
    adaptive.overrides.adaptive_metric = Some(AdaptiveMetric::Relative);
    let session = plan(&adaptive);
    assert_eq!(
        session.scene.render.adaptive_metric,
        Some(AdaptiveMetric::Relative)
    );
}

/// A caller that looks at the image between steps (the Python package's
/// sessions): `render_until` stops at each step's samples, and the steps, from
/// a scene read once (`plan_loaded`), add up to one run bit for bit.
#[test]
fn steps_of_a_run_from_a_scene_read_once_give_the_one_runs_sums() {
    let ctx = gpu_or_skip!();
    let (whole, _) = render(ctx, &request(8));
    let loaded = pathmix::scene::Scene::load_with(&cornell(), &[]).unwrap();
    let session = Session::plan_loaded(&request(8), loaded).unwrap();
    let mut run = session.start(ctx, None).unwrap();
    let stop = AtomicBool::new(false);
    let mut steps = Vec::new();
    for until in [3, 6, u32::MAX] {
        let summary = run.render_until(until, &stop, |_| {}).unwrap();
        steps.push(summary.samples);
    }
    assert_eq!(
        steps,
        [3, 6, 8],
        "each step stops at its samples, the last at the run's"
    );
    assert!(run.rendered_for() > std::time::Duration::ZERO);
    assert_eq!(run.renderer.accumulation(), whole);
}

/// A device that keeps its kernels (as the Python package's does) hands a
/// renderer of an equal config the pipelines built before, and builds one for
/// another config; a device that keeps none builds each time.
#[test]
fn a_device_keeping_kernels_builds_each_config_once() {
    let ctx = gpu_or_skip!();
    let keeping = pathmix::gpu::GpuContext::new(None).unwrap().keep_kernels();
    let scene = pathmix::scene::Scene::load_with(&cornell(), &[])
        .unwrap()
        .scene;
    let options = pathmix::render::RenderOptions::default();
    let config = pathmix::render::plan_kernel(&keeping, &scene, &options)
        .unwrap()
        .config;
    let first = keeping.kernel(config.clone()).unwrap();
    assert!(keeping.kernel(config.clone()).unwrap().pipeline == first.pipeline);
    let deeper = pathmix::kernel::KernelConfig {
        max_depth: config.max_depth + 1,
        ..config.clone()
    };
    assert!(keeping.kernel(deeper).unwrap().pipeline != first.pipeline);
    let built = ctx.kernel(config.clone()).unwrap();
    assert!(ctx.kernel(config).unwrap().pipeline != built.pipeline);
}
