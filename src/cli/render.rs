//! `pathmix render`.

use super::Failure;
use super::progress::ProgressDisplay;
use super::signals::Signals;
use clap::{Args, ValueEnum};
use pathmix::kernel::{AccumulatorKind, ArrayMemory, SceneStorage};
use pathmix::render::{RenderError, RenderOptions, RunSummary, StopReason, StopRule};
use pathmix::scene::mitsuba::Define;
use pathmix::scene::{
    AdaptiveMetric, Aov, LightSelection, Reconstruction, Sampler, SceneOverrides, Strategy,
    parse_aovs,
};
use pathmix::session::checkpoint;
use pathmix::session::pilot::{self, Pilot};
use pathmix::session::shard;
use pathmix::session::{Outcome, Outputs, Request, Session, SessionError, Setting};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/scene-format.md, or Mitsuba 3 XML). With --resume it may be left
    /// out: the checkpoint's recorded scene file is read (give it when the file moved).
    #[arg(required_unless_present = "resume")]
    pub scene: Option<PathBuf>,
    /// Set the Mitsuba scene's `$NAME` parameter, as `mitsuba -D` (repeatable; a
    /// checkpoint records them, and --resume without -D uses those).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<Define>,
    /// Output image: 8-bit sRGB PNG (linear radiance clamped to [0, 1], then the sRGB
    /// curve), or with a `.exr` name the linear float RGB OpenEXR instead (as --exr).
    /// Default: out.png, except with --partial (no PNG unless asked) and with
    /// --resume (the checkpoint's recorded outputs).
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Also write the mean radiance as linear float RGB OpenEXR.
    #[arg(long, value_name = "FILE")]
    pub exr: Option<PathBuf>,
    /// Samples per pixel [scene: render.spp]. With --time or --target-error, an
    /// upper bound (without it those run until their own rule stops them).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Stop when this much render time is spent: 90s, 2m, 1.5h or plain seconds.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Stop when the image's estimated relative standard error falls to this
    /// (e.g. 0.01): the RMS over pixels of the per-pixel standard error of the mean
    /// luminance, divided by the image's mean luminance (docs/statistics.md).
    #[arg(long, value_name = "E")]
    pub target_error: Option<f64>,
    /// Also compute these AOVs (arbitrary output variables) of the surfaces the
    /// camera sees and write them as channels NAME.R, NAME.T, ... of the --exr
    /// image: Mitsuba's `aovs` list, NAME:TYPE or TYPE items separated by
    /// commas, of the types albedo, depth, position, uv, geo_normal, sh_normal
    /// (e.g. `albedo,nn:sh_normal`) [scene: render.aovs].
    #[arg(long, value_name = "LIST", value_parser = parse_aov_list)]
    pub aov: Option<AovList>,
    /// Also write the per-pixel standard error of the mean (linear RGB OpenEXR).
    #[arg(long, value_name = "FILE")]
    pub variance: Option<PathBuf>,
    /// Adaptive sampling [scene: render.adaptive]: after a 16-spp pilot, rounds
    /// sample the pixels whose samples lower the image's error most (see
    /// --adaptive-metric), where the pilot predicts they beat uniform sampling;
    /// elsewhere the run goes on uniformly. --spp is then the budget (the uniform
    /// run's total samples: N per pixel on average), a pixel takes at most 16 N;
    /// --time and --target-error stop as without it. Samples with the sobol
    /// sampler. Not with shards.
    #[arg(long)]
    pub adaptive: bool,
    /// The error adaptive sampling lowers: each pixel's relative to its
    /// brightness (what a person sees; default), or the absolute squared error
    /// (bright pixels take most samples) [scene: render.adaptive_metric].
    #[arg(long, value_enum)]
    pub adaptive_metric: Option<AdaptiveMetricArg>,
    /// How nee-mis picks the light each next-event estimate samples: spatial
    /// (default: in proportion to a bound on what each light sends toward the
    /// point, where every light is a sphere, rectangle or disk) or uniform (each
    /// light alike, as Mitsuba does) [scene: render.light_selection].
    #[arg(long, value_enum)]
    pub light_selection: Option<LightSelectionArg>,
    /// How a filter wider than a pixel makes each pixel of the samples around
    /// it: splat (default: each sample weighted into every pixel the filter
    /// reaches, as Mitsuba does) or importance (each sample's offset drawn from
    /// the filter, kept by its own pixel) [scene: render.reconstruction].
    #[arg(long, value_enum)]
    pub reconstruction: Option<ReconstructionArg>,
    /// With adaptive sampling: also write each pixel's sample count (OpenEXR, in
    /// every channel).
    #[arg(long, value_name = "FILE")]
    pub sample_counts: Option<PathBuf>,
    /// Image width in pixels [scene: camera.width].
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels [scene: camera.height].
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Most scattering events on a path; 0 shows emitters only [scene: render.max_depth].
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    pub max_depth: Option<u32>,
    /// Direction sampling at diffuse surfaces; `auto` lets a short pilot choose
    /// [scene: render.strategy].
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// Mixture weight of the light density, in [0, 1] (default 0.5) [scene: render.light_weight].
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    pub light_weight: Option<f32>,
    /// Russian roulette from this many bounces on, or `off` (paths end only at
    /// --max-depth) [scene: render.rr_depth; default: 5 for nee-mis and bsdf, off for
    /// mixture and light].
    #[arg(long, value_name = "N|off", value_parser = parse_rr_depth)]
    pub rr_depth: Option<RrDepth>,
    /// Where the random numbers come from [scene: render.sampler].
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerArg>,
    /// Random seed: the same seed gives the same image [scene: render.seed].
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    pub seed: Option<u32>,
    /// Use the first adapter whose name contains NAME (case-insensitive) [env: PATHMIX_ADAPTER].
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Where running sums live: a read-write storage texture (where the adapter
    /// supports it) or a storage buffer (works everywhere). Default: the texture
    /// when available.
    #[arg(long, value_enum)]
    pub accumulator: Option<AccumulatorArg>,
    /// Where the kernel reads the scene: compiled into it as constants (fastest
    /// on CPU drivers, slower to compile), from storage buffers with every ray
    /// testing every primitive, or from storage buffers through a BVH. Default:
    /// baked for scenes of up to 128 objects, the BVH above.
    #[arg(long, value_enum)]
    pub scene_storage: Option<SceneStorageArg>,
    /// How the kernel reads the scene's arrays of whole 16- and 8-byte words
    /// (primitives, materials, BVH nodes, an environment map's texels) that
    /// are not compiled in: from textures, or from storage buffers. The images
    /// are the same; Mesa's lavapipe reads textures faster on CPUs without
    /// AVX-512. Default: textures on such a CPU driver where the adapter can
    /// bind them all, else buffers.
    #[arg(long, value_enum)]
    pub array_memory: Option<ArrayMemoryArg>,
    /// Save the accumulated state (raw sums and compensations, sample count,
    /// scene hash, settings, outputs) to FILE every --checkpoint-every and at the
    /// end, atomically. `--resume FILE` continues it bit-exactly.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// How often to save the checkpoint: 30s, 5m, ... [default: 60s].
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
    pub checkpoint_every: Option<Duration>,
    /// Continue the run saved in FILE. The scene file is re-read (the recorded
    /// path, or SCENE when given) and must be unchanged. Without --spp, --time or
    /// --target-error the recorded stopping rule applies (--spp counts all samples,
    /// saved ones included); outputs default to the recorded ones; checkpoints go
    /// on being saved to FILE.
    #[arg(long, value_name = "FILE", conflicts_with_all = [
        "width", "height", "max_depth", "strategy", "light_weight", "seed", "rr_depth", "sampler",
        "light_selection", "sample_range", "shard",
    ])]
    pub resume: Option<PathBuf>,
    /// Rewrite the PNG output this often while rendering (atomically), e.g. 10s.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
    pub preview_every: Option<Duration>,
    /// Render only sample indices A..B (A included, B excluded): a shard of a
    /// larger run, to combine with `pathmix merge`.
    #[arg(long, value_name = "A..B", value_parser = shard::parse_range, conflicts_with_all = ["spp", "shard"])]
    pub sample_range: Option<Range<u32>>,
    /// Render shard INDEX (from 0) of COUNT of the --spp samples: sample indices
    /// spp*INDEX/COUNT .. spp*(INDEX+1)/COUNT.
    #[arg(long, value_name = "INDEX/COUNT", value_parser = shard::parse_shard)]
    pub shard: Option<(u32, u32)>,
    /// Write the raw sums and sums of squares with their sample range as a
    /// partial result (OpenEXR), for `pathmix merge`.
    #[arg(long, value_name = "FILE")]
    pub partial: Option<PathBuf>,
    /// Nothing on stderr but warnings and errors (no progress, adapter or scene
    /// lines); the summary on stdout stays, for scripts.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum StrategyArg {
    /// Mixture of the light density and the material's own sampling (unbiased; the default).
    Mixture,
    /// The material's own sampling only (cosine-weighted for Lambertian).
    #[value(alias = "cosine")]
    Bsdf,
    /// Light density only: biased, misses indirect light (diagnostic).
    Light,
    /// Next-event estimation (shadow rays to emitters) with multiple importance sampling.
    NeeMis,
    /// Chosen by a short pilot: bsdf, nee-mis and mixture (light weights 0.25, 0.5,
    /// 0.75) rendered with a few samples, at the run's resolution where its budget
    /// allows, the most efficient kept.
    Auto,
}

impl StrategyArg {
    /// The strategy named; `None` for `auto`.
    pub fn strategy(self) -> Option<Strategy> {
        match self {
            StrategyArg::Mixture => Some(Strategy::Mixture),
            StrategyArg::Bsdf => Some(Strategy::Bsdf),
            StrategyArg::Light => Some(Strategy::Light),
            StrategyArg::NeeMis => Some(Strategy::NeeMis),
            StrategyArg::Auto => None,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SamplerArg {
    /// Owen-scrambled Sobol points, stratified per pixel (the default), in 4
    /// independently scrambled replicates whose spread gives the standard error.
    Sobol,
    /// Independent random numbers; the per-pixel standard error is unbiased.
    Independent,
}

impl From<SamplerArg> for Sampler {
    fn from(arg: SamplerArg) -> Sampler {
        match arg {
            SamplerArg::Sobol => Sampler::Sobol,
            SamplerArg::Independent => Sampler::Independent,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum AdaptiveMetricArg {
    /// Each pixel's error relative to its brightness (the default).
    Relative,
    /// The absolute squared error of the linear image.
    Absolute,
}

impl From<AdaptiveMetricArg> for AdaptiveMetric {
    fn from(arg: AdaptiveMetricArg) -> AdaptiveMetric {
        match arg {
            AdaptiveMetricArg::Relative => AdaptiveMetric::Relative,
            AdaptiveMetricArg::Absolute => AdaptiveMetric::Absolute,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LightSelectionArg {
    /// In proportion to a bound on what each light sends toward the point (the default).
    Spatial,
    /// Each light alike.
    Uniform,
}

impl From<LightSelectionArg> for LightSelection {
    fn from(arg: LightSelectionArg) -> LightSelection {
        match arg {
            LightSelectionArg::Spatial => LightSelection::Spatial,
            LightSelectionArg::Uniform => LightSelection::Uniform,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ReconstructionArg {
    /// Each sample weighted into every pixel its filter reaches (the default).
    Splat,
    /// Each sample's offset drawn from the filter, the sample kept by its pixel.
    Importance,
}

impl From<ReconstructionArg> for Reconstruction {
    fn from(arg: ReconstructionArg) -> Reconstruction {
        match arg {
            ReconstructionArg::Splat => Reconstruction::Splat,
            ReconstructionArg::Importance => Reconstruction::Importance,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum AccumulatorArg {
    Texture,
    Buffer,
}

impl From<AccumulatorArg> for AccumulatorKind {
    fn from(arg: AccumulatorArg) -> AccumulatorKind {
        match arg {
            AccumulatorArg::Texture => AccumulatorKind::Texture,
            AccumulatorArg::Buffer => AccumulatorKind::Buffer,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SceneStorageArg {
    Baked,
    Buffers,
    Bvh,
}

impl From<SceneStorageArg> for SceneStorage {
    fn from(arg: SceneStorageArg) -> SceneStorage {
        match arg {
            SceneStorageArg::Baked => SceneStorage::Baked,
            SceneStorageArg::Buffers => SceneStorage::Buffers,
            SceneStorageArg::Bvh => SceneStorage::Bvh,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ArrayMemoryArg {
    Textures,
    Buffers,
}

impl From<ArrayMemoryArg> for ArrayMemory {
    fn from(arg: ArrayMemoryArg) -> ArrayMemory {
        match arg {
            ArrayMemoryArg::Textures => ArrayMemory::Textures,
            ArrayMemoryArg::Buffers => ArrayMemory::Buffers,
        }
    }
}

impl From<RenderError> for Failure {
    fn from(e: RenderError) -> Failure {
        Failure::runtime(with_flag(&e))
    }
}

/// The library's message, and the flag that changes the setting it names.
pub fn with_flag(e: &RenderError) -> String {
    let flag = match e {
        RenderError::NonFiniteBakedScene { .. } => "--scene-storage buffers",
        RenderError::NoStorageTextures { .. } | RenderError::TextureTooLarge { .. } => {
            "--accumulator buffer"
        }
        RenderError::ArrayTexturesTooLarge { .. } => "--array-memory buffers",
        RenderError::TruncatedInvocations { .. } => "--max-depth D",
        RenderError::AdaptiveNeedsSobol => "--sampler sobol",
        _ => return e.to_string(),
    };
    format!("{e} ({flag})")
}

/// A setting as this command line gives it: its flag.
fn flag(setting: Setting) -> &'static str {
    match setting {
        Setting::Scene => "SCENE",
        Setting::Output => "-o",
        Setting::Exr => "--exr",
        Setting::Variance => "--variance",
        Setting::SampleCounts => "--sample-counts",
        Setting::Partial => "--partial",
        Setting::Checkpoint => "--checkpoint",
        Setting::Resume => "--resume",
        Setting::SampleRange => "--sample-range",
        Setting::Shard => "--shard",
    }
}

/// The session's refusal in this command line's words: the flags that set
/// what it names, and its exit code.
fn failure(e: SessionError) -> Failure {
    let auto = |requested: bool| match requested {
        true => "--strategy auto",
        false => "the scene's `strategy = \"auto\"`",
    };
    let message = match &e {
        SessionError::PathNotUtf8 { setting, path } => format!(
            "{} `{}`: the path is not UTF-8, and a checkpoint records its paths as text; rename \
             it (or render without --checkpoint)",
            flag(*setting),
            path.display()
        ),
        SessionError::CheckpointEveryWithoutCheckpoint => {
            "--checkpoint-every: give --checkpoint FILE to say where".into()
        }
        SessionError::SameFile(collision) => collision
            .clone()
            .relabel(|source| match source.recorded {
                true => format!("{} (recorded in the checkpoint)", flag(source.setting)),
                false => flag(source.setting).to_string(),
            })
            .to_string(),
        SessionError::AutoWithParts { setting, requested } => format!(
            "{}: with {} each part would run its own pilot and could choose another strategy \
             than the others; give the strategy with --strategy (a render with --strategy auto \
             prints its choice)",
            flag(*setting),
            auto(*requested)
        ),
        SessionError::AutoWithLightWeight { requested } => format!(
            "--light-weight: with {} the pilot chooses the light weight; give --strategy \
             mixture to set it",
            auto(*requested)
        ),
        SessionError::ResumeUniformAdaptively { checkpoint } => format!(
            "cannot resume from `{}` with --adaptive: it was a uniform run",
            checkpoint.display()
        ),
        SessionError::AdaptiveWithParts { setting } => format!(
            "{} with adaptive sampling: {}",
            flag(*setting),
            RenderError::AdaptiveShard
        ),
        SessionError::SampleCountsWithoutAdaptive => {
            "--sample-counts: only an adaptive run (--adaptive) has per-pixel counts".into()
        }
        SessionError::ResumeWithoutSquares { checkpoint } => format!(
            "cannot resume from `{}` with --variance or --target-error: it holds no sums of \
             squares (the run had neither)",
            checkpoint.display()
        ),
        SessionError::PreviewWithoutPng => {
            "--preview-every rewrites the PNG output: give -o FILE.png".into()
        }
        SessionError::Output {
            setting: Setting::Checkpoint,
            source,
        } => format!("--checkpoint: {source}"),
        SessionError::Output { source, .. } => source.to_string(),
        SessionError::Replace(message) => format!("--checkpoint: {message}"),
        SessionError::ResumeState { checkpoint, source } => format!(
            "cannot resume from `{}`: {}",
            checkpoint.display(),
            with_flag(source)
        ),
        SessionError::Refused(e) | SessionError::Failed(e) => with_flag(e),
        SessionError::Override(e) => return super::override_failure(e),
        SessionError::VarianceOfOneSample => {
            "--variance: a standard error needs at least 2 samples per pixel".into()
        }
        _ => e.to_string(),
    };
    match e.is_input() {
        true => Failure::input(message),
        false => Failure::runtime(message),
    }
}

/// What the flags ask for.
fn request(args: &RenderArgs) -> Result<Request, Failure> {
    let (png, exr) = super::image_outputs(args.output.clone(), args.exr.clone())?;
    Ok(Request {
        scene: args.scene.clone(),
        defines: args.define.clone(),
        overrides: SceneOverrides {
            spp: None,
            width: args.width,
            height: args.height,
            max_depth: args.max_depth,
            strategy: args.strategy.and_then(StrategyArg::strategy),
            light_weight: args.light_weight,
            seed: args.seed,
            rr_depth: args.rr_depth.map(|RrDepth(depth)| depth),
            sampler: args.sampler.map(Sampler::from),
            light_selection: args.light_selection.map(LightSelection::from),
            adaptive_metric: args.adaptive_metric.map(AdaptiveMetric::from),
            reconstruction: args.reconstruction.map(Reconstruction::from),
            aovs: args.aov.clone().map(|AovList(aovs)| aovs),
        },
        spp: args.spp,
        auto_strategy: matches!(args.strategy, Some(StrategyArg::Auto)),
        time_budget: args.time,
        target_error: args.target_error,
        adaptive: args.adaptive,
        outputs: Outputs {
            // A new whole render writes out.png unless told otherwise; a resume
            // writes the recorded outputs.
            png: png.or_else(|| {
                let asked =
                    args.output.is_some() || args.resume.is_some() || args.partial.is_some();
                (!asked).then(|| PathBuf::from("out.png"))
            }),
            exr,
            variance: args.variance.clone(),
            sample_counts: args.sample_counts.clone(),
            partial: args.partial.clone(),
        },
        checkpoint: args.checkpoint.clone(),
        checkpoint_every: args.checkpoint_every,
        preview_every: args.preview_every,
        resume: args.resume.clone(),
        sample_range: args.sample_range.clone(),
        shard: args.shard,
        render: RenderOptions {
            accumulator: args.accumulator.map(AccumulatorKind::from),
            scene_storage: args.scene_storage.map(SceneStorage::from),
            array_memory: args.array_memory.map(ArrayMemory::from),
            ..Default::default()
        },
    })
}

pub fn render(args: RenderArgs, process_start: Instant) -> Result<(), Failure> {
    if let Some(target) = args.target_error {
        if !(target.is_finite() && target > 0.0) {
            return Err(Failure::input(format!(
                "--target-error: must be a number > 0, got {target}"
            )));
        }
    }
    let mut session = Session::plan(&request(&args)?).map_err(failure)?;
    super::print_approximations(&session.scene_path, &session.approximations);
    for warning in &session.warnings {
        eprintln!("pathmix: warning: {warning}");
    }
    // From here on a signal stops the run cleanly (during the kernel's build too).
    let signals = Signals::install().map_err(Failure::runtime)?;
    session.lock_checkpoint().map_err(failure)?;
    let quiet = args.quiet;

    let ctx = super::open_gpu(args.adapter.as_deref())?;
    let mut pilot = session.choose_strategy(&ctx).map_err(failure)?;
    if let (Some(pilot), false) = (&pilot, quiet) {
        report_pilot(pilot);
    }
    let mut run = session.start(&ctx, pilot.as_mut()).map_err(failure)?;
    for warning in &run.renderer.warnings {
        eprintln!("pathmix: warning: {warning}");
    }
    let session = &run.session;
    let (width, height) = run.renderer.size();
    if !quiet {
        eprintln!("adapter: {}", ctx.describe());
        eprintln!(
            "scene: {}  {width}x{height}  strategy {}  {}  {}  max depth {}  stop: {}",
            session.scene.source,
            run.renderer.config().describe_strategy(),
            run.renderer.config().describe_sampler(),
            run.renderer.config().describe_filter(),
            session.scene.render.max_depth,
            describe_stop(&session.stop),
        );
    }
    if let (Some((path, c)), false) = (&session.resume, quiet) {
        eprintln!(
            "resuming from {} at {} spp",
            path.display(),
            c.state.samples
        );
    }
    if !quiet && (session.first_sample > 0 || session.is_part) {
        eprintln!(
            "sample indices from {} (scene hash {})",
            session.first_sample,
            checkpoint::hex(session.identity().hash())
        );
    }
    let mut display = ProgressDisplay::new(args.quiet);
    let mut first_sample = None;
    let summary = run.render(&signals.stop, |p| {
        first_sample.get_or_insert_with(|| process_start.elapsed());
        display.update(p);
    });
    display.finish();
    let summary = summary.map_err(failure)?;
    let (signal, signal_code) = signals.received().unwrap_or(("an interrupt", 130));
    if summary.reason == StopReason::Interrupted && summary.samples == 0 {
        // Nothing rendered: writing would only replace earlier files with black.
        return Err(Failure {
            message: format!("interrupted by {signal} before the first sample; nothing written"),
            code: signal_code,
        });
    }
    let outcome = run.finish(summary).map_err(failure)?;
    let summary = &outcome.summary;
    let session = &run.session;
    if outcome.discarded > 0 {
        eprintln!(
            "pathmix: warning: {} samples were NaN or infinite and counted as zero",
            outcome.discarded
        );
    }
    if outcome.interrupted() {
        return Err(interruption(
            session.checkpoint.as_deref(),
            summary,
            signal,
            signal_code,
        ));
    }
    let stopped = match summary.reason {
        StopReason::Samples => "sample count reached".to_string(),
        StopReason::TimeBudget => "time budget spent".to_string(),
        StopReason::TargetError => "target error reached".to_string(),
        StopReason::Interrupted => "interrupted".to_string(),
        StopReason::BlackImage => format!(
            "the image is black after {} spp: its relative error is undefined, so no \
             --target-error can be reached",
            summary.samples
        ),
    };
    println!(
        "rendered {width}x{height} at {} spp in {:.2} s: {:.2} M paths/s ({stopped})",
        summary.samples,
        summary.elapsed.as_secs_f64(),
        summary.paths_per_second / 1e6
    );
    if let Some(choice) = run.adaptive_choice() {
        let went_on = match choice.uniform {
            true => "went on uniformly, the image the mean of every sample",
            false => "went on adaptively",
        };
        println!(
            "adaptive: the pilot predicted {:.2}x uniform's RMSE at equal time; {went_on}",
            choice.predicted_ratio
        );
    }
    if let Some(pilot) = &pilot {
        println!(
            "strategy auto: {} (pilot of {} candidate{} in {:.2} s)",
            pilot.choice,
            pilot.rows.len(),
            plural(pilot.rows.len()),
            pilot.seconds
        );
    }
    if session.first_sample > 0 || session.outputs.partial.is_some() {
        println!(
            "sample indices {}..{}",
            run.renderer.first_sample(),
            run.renderer.first_sample() + run.renderer.samples()
        );
    }
    if let Some(error) = summary.relative_error {
        println!("estimated relative error: {error:.5}");
    }
    if let Some(first) = first_sample {
        println!(
            "first samples done {:.0} ms after start",
            first.as_secs_f64() * 1e3
        );
    }
    for path in written_in_report_order(session, &outcome) {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The files written, outputs first and the checkpoint last, as the report lists them.
fn written_in_report_order<'a>(session: &'a Session, outcome: &Outcome) -> Vec<&'a Path> {
    let outputs = &session.outputs;
    [
        outputs.png.as_ref(),
        outputs.exr.as_ref(),
        outputs.variance.as_ref(),
        outputs.sample_counts.as_ref(),
        outputs.partial.as_ref(),
        session.checkpoint.as_ref(),
    ]
    .into_iter()
    .flatten()
    .filter(|path| outcome.written.contains(path))
    .map(PathBuf::as_path)
    .collect()
}

/// What the pilot of `strategy = "auto"` measured and chose.
fn report_pilot(pilot: &Pilot) {
    match pilot.rows.len() {
        0 => eprintln!(
            "strategy auto: {} (the only candidate: nothing to aim at)",
            pilot.choice
        ),
        n => eprintln!(
            "strategy auto: pilot of {n} candidate{} at {}x{}, {} spp each, {} for those \
             within {} of the best, {:.2} s in all \
             (efficiency = 1 / (estimated relative MSE x seconds)):\n{}chose {}",
            plural(n),
            pilot.width,
            pilot.height,
            pilot::first_half(pilot.spp),
            pilot.spp,
            pilot::RACE,
            pilot.seconds,
            pilot::table(pilot),
            pilot.choice
        ),
    }
    if let Some(samples) = &pilot.samples {
        eprintln!(
            "the pilot's {} spp of {} are the run's first samples",
            samples.renderer.samples(),
            pilot.choice
        );
    }
    if !pilot.skipped.is_empty() {
        let names: Vec<String> = pilot.skipped.iter().map(|v| v.name()).collect();
        eprintln!(
            "not measured: {} (the pilot had spent {:.0}% of the run's estimated time)",
            names.join(", "),
            pilot::BUDGET * 100.0
        );
    }
}

fn plural(count: usize) -> &'static str {
    if count == 1 { "" } else { "s" }
}

/// What an interrupted run tells the user (what was saved, how to go on) and its
/// exit: 130 for SIGINT, 143 for SIGTERM.
fn interruption(
    checkpoint: Option<&Path>,
    summary: &RunSummary,
    signal: &str,
    code: u8,
) -> Failure {
    match checkpoint {
        Some(path) => {
            eprintln!(
                "pathmix: {signal}: saved {} samples per pixel in {}",
                summary.samples,
                path.display()
            );
            eprintln!("resume with: {}", resume_command(path));
        }
        None => eprintln!(
            "pathmix: {signal}: the images hold the {} samples per pixel done; without \
             --checkpoint FILE the run cannot be resumed",
            summary.samples
        ),
    }
    Failure {
        message: format!("interrupted by {signal} at {} spp", summary.samples),
        code,
    }
}

/// The command that continues from `checkpoint`: the checkpoint records the
/// scene, settings, stopping rule and outputs.
fn resume_command(checkpoint: &Path) -> String {
    let program = std::env::args().next().unwrap_or_else(|| "pathmix".into());
    format!(
        "{} render --resume {}",
        shell_quote(&program),
        shell_quote(&checkpoint.to_string_lossy())
    )
}

fn shell_quote(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-./:=+,@%".contains(c));
    if plain {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
}

fn describe_stop(stop: &StopRule) -> String {
    let mut rules = Vec::new();
    if stop.max_samples != u32::MAX {
        rules.push(format!("{} spp", stop.max_samples));
    }
    if let Some(budget) = stop.time_budget {
        rules.push(format!("{:.1} s", budget.as_secs_f64()));
    }
    if let Some(target) = stop.target_error {
        rules.push(format!("relative error {target}"));
    }
    rules.join(" or ")
}

/// A Russian roulette depth, or none.
#[derive(Clone, Debug)]
pub struct AovList(pub Vec<Aov>);

pub fn parse_aov_list(text: &str) -> Result<AovList, String> {
    parse_aovs(text).map(AovList)
}

#[derive(Clone, Copy, Debug)]
pub struct RrDepth(pub Option<u32>);

pub fn parse_rr_depth(text: &str) -> Result<RrDepth, String> {
    match text {
        "off" => Ok(RrDepth(None)),
        _ => text
            .parse()
            .map(|depth| RrDepth(Some(depth)))
            .map_err(|_| format!("`{text}`: give a depth or `off`")),
    }
}

/// `90s`, `2m`, `1.5h`, `500ms` or plain seconds.
pub fn parse_duration(text: &str) -> Result<Duration, String> {
    let text = text.trim();
    let split = text
        .find(|c: char| c.is_ascii_alphabetic())
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a duration (examples: 90s, 2m, 1.5h)"))?;
    let seconds = match unit.trim() {
        "" | "s" => value,
        "ms" => value / 1e3,
        "m" | "min" => value * 60.0,
        "h" => value * 3600.0,
        other => {
            return Err(format!(
                "unknown unit `{other}` in `{text}` (use ms, s, m or h)"
            ));
        }
    };
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(format!("`{text}`: a duration must be > 0"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

#[cfg(test)]
mod tests {
    use super::{parse_duration, with_flag};
    use pathmix::render::RenderError;
    use std::time::Duration;

    #[test]
    fn library_refusals_gain_the_flag_that_changes_the_setting() {
        let large = RenderError::TextureTooLarge {
            width: 1,
            height: 9000,
            max: 8192,
        };
        assert_eq!(
            with_flag(&large),
            "1x9000 exceeds this adapter's largest texture (8192x8192); render a smaller \
             image or use the buffer accumulator (--accumulator buffer)"
        );
        let baked = RenderError::NonFiniteBakedScene {
            scene: "s.toml".into(),
        };
        assert!(with_flag(&baked).ends_with("scene storage `buffers` (--scene-storage buffers)"));
        let cut = RenderError::TruncatedInvocations { count: 3 };
        assert!(with_flag(&cut).starts_with("3 pixel invocations"));
        assert!(
            with_flag(&cut).ends_with(
                "smaller maximum depth or a simpler scene on this adapter (--max-depth D)"
            )
        );
        let first = RenderError::FirstSampleAfterRendering;
        assert_eq!(with_flag(&first), first.to_string());
    }

    #[test]
    fn durations() {
        assert_eq!(parse_duration("90s"), Ok(Duration::from_secs(90)));
        assert_eq!(parse_duration("2m"), Ok(Duration::from_secs(120)));
        assert_eq!(parse_duration("1.5h"), Ok(Duration::from_secs(5400)));
        assert_eq!(parse_duration("250ms"), Ok(Duration::from_millis(250)));
        assert_eq!(parse_duration("3"), Ok(Duration::from_secs(3)));
        assert!(parse_duration("0s").is_err());
        assert!(parse_duration("5 parsecs").is_err());
        assert!(parse_duration("soon").is_err());
    }
}
