//! `pathmix render`.

use super::Failure;
use super::progress::ProgressDisplay;
use super::signals::Signals;
use clap::{Args, ValueEnum};
use pathmix::abi::LAYER_SQUARES_COMPENSATION;
use pathmix::gpu::GpuContext;
use pathmix::kernel::{AccumulatorKind, ArrayMemory, SceneStorage};
use pathmix::output::{self, ImageFormat};
use pathmix::paths::{self, PathUse};
use pathmix::render::adaptive;
use pathmix::render::{self, RenderError, RenderOptions, Renderer, StopReason, StopRule};
use pathmix::scene::mitsuba::Define;
use pathmix::scene::{Sampler, Scene, SceneOverrides, Strategy};
use pathmix::session::checkpoint::{self, Checkpoint, CheckpointLock, SceneIdentity};
use pathmix::session::pilot::{self, Pilot};
use pathmix::session::shard::{self, Partial};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How often `--checkpoint` saves when `--checkpoint-every` is not given.
const DEFAULT_CHECKPOINT_EVERY: Duration = Duration::from_secs(60);

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML, see docs/scene-format.md, or Mitsuba 3 XML). With --resume it may be left
    /// out: the checkpoint's recorded scene file is read (give it when the file moved).
    #[arg(required_unless_present = "resume")]
    pub scene: Option<PathBuf>,
    /// Set the Mitsuba scene's `$NAME` parameter, as `mitsuba -D` (repeatable; a
    /// checkpoint records them, and --resume without -D uses those).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<pathmix::scene::mitsuba::Define>,
    /// Output image: 8-bit sRGB PNG (linear radiance clamped to [0, 1], then the sRGB
    /// curve). Default: out.png, except with --partial (no PNG unless asked) and
    /// with --resume (the checkpoint's recorded outputs).
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
    /// Also write the per-pixel standard error of the mean (linear RGB OpenEXR).
    #[arg(long, value_name = "FILE")]
    pub variance: Option<PathBuf>,
    /// Adaptive sampling [scene: render.adaptive]: after a 16-spp pilot, rounds
    /// sample the pixels whose samples lower the image's error most (each pixel's
    /// count in proportion to its noise), where the pilot predicts they beat uniform
    /// sampling; elsewhere the run goes on uniformly. --spp is then the budget (the uniform
    /// run's total samples: N per pixel on average), a pixel takes at most 16 N;
    /// --time and --target-error stop as without it. Not with shards.
    #[arg(long)]
    pub adaptive: bool,
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
        "width", "height", "max_depth", "strategy", "light_weight", "seed", "rr_depth", "sampler", "sample_range", "shard",
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

/// Where the results go.
struct Outputs {
    png: Option<PathBuf>,
    exr: Option<PathBuf>,
    variance: Option<PathBuf>,
    sample_counts: Option<PathBuf>,
    partial: Option<PathBuf>,
}

/// What this invocation does: the flags, and with --resume the checkpoint.
struct Plan {
    scene: Scene,
    scene_path: PathBuf,
    /// The Mitsuba scene's `-D` parameters.
    defines: Vec<Define>,
    /// Command-line settings over the scene file (without spp).
    overrides: SceneOverrides,
    /// The scene's identity, made when first asked for (`Plan::identity`): it
    /// formats every triangle, and a render that writes no checkpoint or
    /// partial result needs none (a 16² render of Mitsuba's box with the
    /// bunny: 0.62 s of process time against 0.90 s made up front).
    identity: OnceLock<SceneIdentity>,
    outputs: Outputs,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Duration,
    preview_every: Option<Duration>,
    /// `max_samples` counts the renderer's samples (saved ones included).
    stop: StopRule,
    variance: bool,
    adaptive: bool,
    first_sample: u32,
    resume: Option<Checkpoint>,
}

impl Plan {
    /// What checkpoints and partial results record of the scene.
    fn identity(&self) -> &SceneIdentity {
        self.identity.get_or_init(|| SceneIdentity::of(&self.scene))
    }

    /// The sample indices this run was asked for (a partial result records them):
    /// `None` when a time budget or error target decides the end.
    fn requested_range(&self) -> Option<Range<u32>> {
        let open = self.stop.time_budget.is_some() || self.stop.target_error.is_some();
        (self.stop.max_samples != u32::MAX && !open)
            .then(|| self.first_sample..self.first_sample.saturating_add(self.stop.max_samples))
    }
}

fn plan(args: &RenderArgs) -> Result<Plan, Failure> {
    refuse_unrecordable_paths(args)?;
    let resume = match &args.resume {
        Some(path) => Some(
            checkpoint::read(path).map_err(|e| Failure::input(format!("cannot resume: {e}")))?,
        ),
        None => None,
    };
    let overrides = match &resume {
        Some(c) => c.overrides.clone(),
        None => SceneOverrides {
            spp: None,
            width: args.width,
            height: args.height,
            max_depth: args.max_depth,
            strategy: args.strategy.and_then(StrategyArg::strategy),
            light_weight: args.light_weight,
            seed: args.seed,
            rr_depth: args.rr_depth.map(|RrDepth(depth)| depth),
            sampler: args.sampler.map(Sampler::from),
        },
    };
    let scene_path = match (&args.scene, &resume) {
        (Some(path), _) => path.clone(),
        (None, Some(c)) => c.scene_path.clone(),
        (None, None) => return Err(Failure::input("no scene file given")),
    };
    let recorded = |key: &str| resume.as_ref().and_then(|c| c.run.get(key));
    let recorded_path = |key: &str| recorded(key).and_then(|v| v.as_str()).map(PathBuf::from);
    let recorded_seconds = |key: &str| {
        recorded(key)
            .and_then(|v| v.as_float())
            .map(|s| Duration::from_secs_f64(s.max(0.0)))
    };

    let outputs = Outputs {
        png: args.output.clone().or_else(|| match &resume {
            Some(_) => recorded_path("output"),
            None if args.partial.is_some() => None,
            None => Some(PathBuf::from("out.png")),
        }),
        exr: args.exr.clone().or_else(|| recorded_path("exr")),
        variance: args.variance.clone().or_else(|| recorded_path("variance")),
        sample_counts: args
            .sample_counts
            .clone()
            .or_else(|| recorded_path("sample_counts")),
        partial: args.partial.clone().or_else(|| recorded_path("partial")),
    };
    let checkpoint = args.checkpoint.clone().or_else(|| args.resume.clone());
    if checkpoint.is_none() && args.checkpoint_every.is_some() {
        return Err(Failure::input(
            "--checkpoint-every: give --checkpoint FILE to say where",
        ));
    }
    check_collisions(args, &scene_path, &outputs, checkpoint.as_deref())?;
    // A resume without -D reads the scene with the parameters it was rendered with.
    let defines = match (&resume, args.define.is_empty()) {
        (Some(c), true) => recorded_defines(c)?,
        _ => args.define.clone(),
    };
    let mut scene = super::load_scene(&scene_path, &defines)?;
    scene
        .apply_overrides(&SceneOverrides {
            spp: args.spp,
            ..overrides.clone()
        })
        .map_err(Failure::input)?;
    if let Some(StrategyArg::Auto) = args.strategy {
        scene.render.auto_strategy = true;
    }
    match &resume {
        // A resumed run keeps the strategy it was rendered with: the checkpoint's own
        // (its overrides set it after the pilot; this covers a scene file changed to auto).
        Some(c) if scene.render.auto_strategy => {
            scene.render.strategy = c.identity.strategy;
            scene.render.light_weight = c.identity.light_weight;
            scene.render.auto_strategy = false;
        }
        _ => refuse_auto_conflicts(args, &scene)?,
    }
    let identity = OnceLock::new();
    let open_ended = args.time.is_some() || args.target_error.is_some();
    let adaptive = match &resume {
        Some(c) => {
            let saved = c.state.adaptive.is_some();
            if args.adaptive && !saved {
                return Err(Failure::input(format!(
                    "cannot resume from `{}` with --adaptive: it was a uniform run",
                    args.resume.as_ref().unwrap().display()
                )));
            }
            saved
        }
        None => args.adaptive || scene.render.adaptive,
    };
    if adaptive {
        for (flag, given) in [
            ("--sample-range", args.sample_range.is_some()),
            ("--shard", args.shard.is_some()),
            ("--partial", outputs.partial.is_some()),
        ] {
            if given {
                return Err(Failure::input(format!(
                    "{flag} with adaptive sampling: {}",
                    RenderError::AdaptiveShard
                )));
            }
        }
    } else if outputs.sample_counts.is_some() {
        return Err(Failure::input(
            "--sample-counts: only an adaptive run (--adaptive) has per-pixel counts",
        ));
    }
    let (first_sample, stop, variance) = match &resume {
        Some(c) => {
            let differences = SceneIdentity::differences(
                (&c.identity, "in the checkpoint"),
                (
                    identity.get_or_init(|| SceneIdentity::of(&scene)),
                    "in the scene now",
                ),
            );
            if !differences.is_empty() {
                return Err(Failure::input(format!(
                    "cannot resume from `{}`: the scene `{}` is not the one the checkpoint was \
                     rendered from: {}",
                    args.resume.as_ref().unwrap().display(),
                    scene_path.display(),
                    differences.join("; ")
                )));
            }
            if c.pathmix_version != env!("CARGO_PKG_VERSION") {
                eprintln!(
                    "pathmix: warning: the checkpoint was written by pathmix {}, this is {}: \
                     if the kernel changed, the result is not the same as one uninterrupted run",
                    c.pathmix_version,
                    env!("CARGO_PKG_VERSION")
                );
            }
            let stop = if args.spp.is_some() || open_ended {
                StopRule {
                    max_samples: args.spp.unwrap_or(u32::MAX),
                    time_budget: args.time,
                    target_error: args.target_error,
                }
            } else {
                StopRule {
                    max_samples: recorded("spp")
                        .and_then(|v| v.as_integer())
                        .and_then(|v| u32::try_from(v).ok())
                        .unwrap_or(u32::MAX),
                    time_budget: recorded_seconds("time_left_s"),
                    target_error: recorded("target_error").and_then(|v| v.as_float()),
                }
            };
            let variance = c.state.layers > LAYER_SQUARES_COMPENSATION;
            if !variance && (args.variance.is_some() || stop.target_error.is_some()) {
                return Err(Failure::input(format!(
                    "cannot resume from `{}` with --variance or --target-error: it holds no sums \
                     of squares (the run had neither)",
                    args.resume.as_ref().unwrap().display()
                )));
            }
            (c.state.first_sample, stop, variance)
        }
        None => {
            // A shard may be empty (fewer samples than shards): a valid, empty part.
            let range = match (&args.sample_range, args.shard) {
                (Some(range), _) => Some(range.clone()),
                (None, Some((index, count))) => {
                    Some(shard::shard_range(index, count, scene.render.spp))
                }
                (None, None) => None,
            };
            let max_samples = match &range {
                Some(range) => range.len() as u32,
                None if args.spp.is_none() && open_ended => u32::MAX,
                None => scene.render.spp,
            };
            let stop = StopRule {
                max_samples,
                time_budget: args.time,
                target_error: args.target_error,
            };
            // Partial results carry the sums of squares, so a merge can estimate errors.
            let variance =
                args.variance.is_some() || args.target_error.is_some() || args.partial.is_some();
            (range.map_or(0, |r| r.start), stop, variance)
        }
    };

    let checkpoint_every = args
        .checkpoint_every
        .or_else(|| recorded_seconds("checkpoint_every_s"))
        .unwrap_or(DEFAULT_CHECKPOINT_EVERY);
    let preview_every = args
        .preview_every
        .or_else(|| recorded_seconds("preview_every_s"));
    if preview_every.is_some() && outputs.png.is_none() {
        return Err(Failure::input(
            "--preview-every rewrites the PNG output: give -o FILE.png",
        ));
    }

    check_collisions(args, &scene_path, &outputs, checkpoint.as_deref())?;
    // Refuse unwritable outputs before spending the render time.
    if let Some(png) = &outputs.png {
        output::check_output_path(png, ImageFormat::Png).map_err(Failure::input)?;
    }
    for exr in [
        &outputs.exr,
        &outputs.variance,
        &outputs.sample_counts,
        &outputs.partial,
    ]
    .into_iter()
    .flatten()
    {
        output::check_output_path(exr, ImageFormat::Exr).map_err(Failure::input)?;
    }
    if let Some(path) = &checkpoint {
        output::check_writable(path).map_err(|e| Failure::input(format!("--checkpoint: {e}")))?;
        checkpoint::check_replaceable(path)
            .map_err(|e| Failure::input(format!("--checkpoint: {e}")))?;
    }
    // An adaptive pixel may take up to its cap; adaptive runs sum squares.
    let most = match adaptive {
        true => adaptive::pixel_cap(stop.max_samples),
        false => stop.max_samples,
    };
    render::check_emission(&scene, most, variance || adaptive)
        .map_err(|e| Failure::input(with_flag(&e)))?;
    Ok(Plan {
        scene,
        scene_path,
        defines,
        overrides,
        identity,
        outputs,
        checkpoint,
        checkpoint_every,
        preview_every,
        stop,
        variance,
        adaptive,
        first_sample,
        resume,
    })
}

/// `strategy = "auto"` chooses per run: shards merged into one image must share a
/// strategy, and the pilot chooses the light weight.
fn refuse_auto_conflicts(args: &RenderArgs, scene: &Scene) -> Result<(), Failure> {
    if !scene.render.auto_strategy {
        return Ok(());
    }
    let how = if args.strategy.is_some() {
        "--strategy auto"
    } else {
        "the scene's `strategy = \"auto\"`"
    };
    let flag = [
        ("--shard", args.shard.is_some()),
        ("--sample-range", args.sample_range.is_some()),
        ("--partial", args.partial.is_some()),
    ]
    .into_iter()
    .find_map(|(flag, given)| given.then_some(flag));
    if let Some(flag) = flag {
        return Err(Failure::input(format!(
            "{flag}: with {how} each part would run its own pilot and could choose another \
             strategy than the others; give the strategy with --strategy (a render with \
             --strategy auto prints its choice)"
        )));
    }
    if args.light_weight.is_some() {
        return Err(Failure::input(format!(
            "--light-weight: with {how} the pilot chooses the light weight; give --strategy \
             mixture to set it"
        )));
    }
    Ok(())
}

/// A checkpoint records its scene and output paths as text (TOML): a path that is
/// not UTF-8 could not be found again on resume, so it is refused at the start.
fn refuse_unrecordable_paths(args: &RenderArgs) -> Result<(), Failure> {
    if args.checkpoint.is_none() && args.resume.is_none() {
        return Ok(());
    }
    let paths = [
        ("SCENE", &args.scene),
        ("-o", &args.output),
        ("--exr", &args.exr),
        ("--variance", &args.variance),
        ("--sample-counts", &args.sample_counts),
        ("--partial", &args.partial),
        ("--checkpoint", &args.checkpoint),
        ("--resume", &args.resume),
    ];
    for (flag, path) in paths {
        if let Some(path) = path {
            let absolute = absolute(path);
            if absolute.to_str().is_none() {
                return Err(Failure::input(format!(
                    "{flag} `{}`: the path is not UTF-8, and a checkpoint records its paths as \
                     text; rename it (or render without --checkpoint)",
                    path.display()
                )));
            }
        }
    }
    Ok(())
}

/// Every path this render reads or writes, compared with every other before any
/// work: no output may replace an input or another output.
fn check_collisions(
    args: &RenderArgs,
    scene_path: &Path,
    outputs: &Outputs,
    checkpoint: Option<&Path>,
) -> Result<(), Failure> {
    let recorded = |flag: &str, given: &Option<PathBuf>| match given {
        Some(_) => flag.to_string(),
        None => format!("{flag} (recorded in the checkpoint)"),
    };
    let scene_flag = if args.scene.is_some() {
        "SCENE"
    } else {
        "SCENE (recorded in the checkpoint)"
    };
    let mut uses = vec![PathUse::input(scene_flag, scene_path)];
    match (&args.resume, checkpoint) {
        // Resuming saves to the checkpoint it read, as it was meant to.
        (Some(resume), Some(to))
            if paths::collision(&[
                PathUse::input("--resume", resume),
                PathUse::output("--checkpoint", to),
            ])
            .is_some() =>
        {
            uses.push(PathUse::output("--resume", resume));
        }
        (resume, to) => {
            uses.extend(resume.as_deref().map(|r| PathUse::input("--resume", r)));
            uses.extend(to.map(|c| PathUse::output("--checkpoint", c)));
        }
    }
    for (flag, path, given) in [
        ("-o", &outputs.png, &args.output),
        ("--exr", &outputs.exr, &args.exr),
        ("--variance", &outputs.variance, &args.variance),
        (
            "--sample-counts",
            &outputs.sample_counts,
            &args.sample_counts,
        ),
        ("--partial", &outputs.partial, &args.partial),
    ] {
        if let Some(path) = path {
            uses.push(PathUse::output(recorded(flag, given), path));
        }
    }
    match paths::collision(&uses) {
        Some(message) => Err(Failure::input(message)),
        None => Ok(()),
    }
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_owned())
}

/// The flags a resume needs besides the state: stopping rule and outputs.
fn run_table(plan: &Plan, elapsed: Duration) -> toml::Table {
    let mut run = toml::Table::new();
    if plan.stop.max_samples != u32::MAX {
        run.insert(
            "spp".into(),
            toml::Value::Integer(plan.stop.max_samples.into()),
        );
    }
    if let Some(budget) = plan.stop.time_budget {
        let left = budget.saturating_sub(elapsed).as_secs_f64();
        run.insert("time_left_s".into(), left.into());
    }
    if let Some(target) = plan.stop.target_error {
        run.insert("target_error".into(), target.into());
    }
    let outputs = &plan.outputs;
    for (key, path) in [
        ("output", &outputs.png),
        ("exr", &outputs.exr),
        ("variance", &outputs.variance),
        ("sample_counts", &outputs.sample_counts),
        ("partial", &outputs.partial),
    ] {
        if let Some(path) = path {
            let path = absolute(path).to_string_lossy().into_owned();
            run.insert(key.into(), path.into());
        }
    }
    run.insert(
        "checkpoint_every_s".into(),
        plan.checkpoint_every.as_secs_f64().into(),
    );
    if let Some(every) = plan.preview_every {
        run.insert("preview_every_s".into(), every.as_secs_f64().into());
    }
    if !plan.defines.is_empty() {
        let defines = plan
            .defines
            .iter()
            .map(|d| format!("{}={}", d.name, d.value));
        run.insert("define".into(), defines.collect::<Vec<_>>().into());
    }
    run
}

/// The `-D` parameters a checkpoint's run was given.
fn recorded_defines(c: &Checkpoint) -> Result<Vec<Define>, Failure> {
    let Some(recorded) = c.run.get("define") else {
        return Ok(Vec::new());
    };
    let bad = || {
        Failure::input("cannot resume: the checkpoint's `run.define` is not a list of NAME=VALUE")
    };
    recorded
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|v| v.as_str().and_then(|s| s.parse().ok()).ok_or_else(bad))
        .collect()
}

fn save_checkpoint(
    plan: &Plan,
    path: &Path,
    renderer: &Renderer,
    discarded: u64,
    elapsed: Duration,
) -> Result<(), Failure> {
    let scene_path =
        std::fs::canonicalize(&plan.scene_path).unwrap_or_else(|_| absolute(&plan.scene_path));
    let checkpoint = Checkpoint {
        pathmix_version: env!("CARGO_PKG_VERSION").to_string(),
        scene_path,
        overrides: plan.overrides.clone(),
        identity: plan.identity().clone(),
        discarded,
        run: run_table(plan, elapsed),
        state: renderer.export_state(),
    };
    checkpoint::write(path, &checkpoint).map_err(Failure::runtime)
}

pub fn render(args: RenderArgs, process_start: Instant) -> Result<(), Failure> {
    if let Some(target) = args.target_error {
        if !(target.is_finite() && target > 0.0) {
            return Err(Failure::input(format!(
                "--target-error: must be a number > 0, got {target}"
            )));
        }
    }
    let mut plan = plan(&args)?;
    // From here on a signal stops the run cleanly (during the kernel's build too).
    let signals = Signals::install().map_err(Failure::runtime)?;
    // Held to the end: a second run saving to the same checkpoint is refused.
    let _lock = match &plan.checkpoint {
        Some(path) => Some(CheckpointLock::acquire(path).map_err(Failure::input)?),
        None => None,
    };
    let quiet = args.quiet;

    let ctx = GpuContext::new(args.adapter.as_deref()).map_err(Failure::runtime)?;
    let options = RenderOptions {
        accumulator: args.accumulator.map(AccumulatorKind::from),
        variance: plan.variance,
        scene_storage: args.scene_storage.map(SceneStorage::from),
        array_memory: args.array_memory.map(ArrayMemory::from),
        adaptive: plan.adaptive,
        ..Default::default()
    };
    let mut pilot = match plan.scene.render.auto_strategy {
        true => Some(choose_strategy(&ctx, &mut plan, &options, quiet)?),
        false => None,
    };
    // The chosen candidate's samples, moved into the run's sums.
    let pilot_samples = pilot.as_mut().and_then(|p| p.samples.take());
    let pilot_discarded = pilot_samples.as_ref().map(|s| s.discarded);
    let plan = plan;
    let scene = &plan.scene;
    let stop = plan.stop;
    let mut renderer =
        Renderer::new(&ctx, scene, &options).map_err(|e| Failure::input(with_flag(&e)))?;
    match &plan.resume {
        Some(c) => renderer.import_state(&c.state).map_err(|e| {
            Failure::input(format!(
                "cannot resume from `{}`: {e}",
                args.resume.as_ref().unwrap().display()
            ))
        })?,
        None => match pilot_samples {
            Some(samples) => renderer
                .start_from(&samples.renderer)
                .map_err(Failure::runtime)?,
            None => renderer.set_first_sample(plan.first_sample)?,
        },
    }
    for warning in &renderer.warnings {
        eprintln!("pathmix: warning: {warning}");
    }
    let (width, height) = renderer.size();
    if !quiet {
        eprintln!("adapter: {}", ctx.describe());
        eprintln!(
            "scene: {}  {width}x{height}  strategy {}  {} sampler  max depth {}  stop: {}",
            scene.source,
            renderer.config().strategy,
            renderer.config().sampler,
            scene.render.max_depth,
            describe_stop(&stop),
        );
    }
    if let (Some(c), false) = (&plan.resume, quiet) {
        eprintln!(
            "resuming from {} at {} spp",
            args.resume.as_ref().unwrap().display(),
            c.state.samples
        );
    }
    if !quiet && (plan.first_sample > 0 || args.sample_range.is_some() || args.shard.is_some()) {
        eprintln!(
            "sample indices from {} (scene hash {})",
            plan.first_sample,
            checkpoint::hex(plan.identity().hash())
        );
    }
    // Samples already in the sums (a resumed run's, or the pilot's) and discarded there.
    let saved_discarded = match (&plan.resume, pilot_discarded) {
        (Some(c), _) => c.discarded,
        (None, Some(discarded)) => discarded,
        (None, None) => 0,
    };
    let mut display = ProgressDisplay::new(args.quiet);
    let mut first_sample = None;
    let (mut last_checkpoint, mut last_preview) = (Instant::now(), Instant::now());
    let summary = render::run_with(&mut renderer, stop, &signals.stop, |p, r| {
        first_sample.get_or_insert_with(|| process_start.elapsed());
        display.update(p);
        if let Some(path) = &plan.checkpoint {
            if last_checkpoint.elapsed() >= plan.checkpoint_every {
                let discarded = saved_discarded + r.counters().discarded as u64;
                save_checkpoint(&plan, path, r, discarded, p.elapsed)?;
                last_checkpoint = Instant::now();
            }
        }
        if let (Some(every), Some(png)) = (plan.preview_every, &plan.outputs.png) {
            if last_preview.elapsed() >= every {
                output::write_png(png, &r.accumulation().mean(), 0.0).map_err(Failure::runtime)?;
                last_preview = Instant::now();
            }
        }
        Ok::<(), Failure>(())
    });
    display.finish();
    let summary = summary?;
    let discarded = saved_discarded + summary.discarded;
    let interrupted = summary.reason == StopReason::Interrupted;
    let (signal, signal_code) = signals.received().unwrap_or(("an interrupt", 130));
    if interrupted && summary.samples == 0 {
        // Nothing rendered: writing would only replace earlier files with black.
        return Err(Failure {
            message: format!("interrupted by {signal} before the first sample; nothing written"),
            code: signal_code,
        });
    }
    let accumulation = renderer.accumulation();
    render::check_sums_finite(&accumulation)?;

    // The state first: once it is saved, nothing of the run can be lost.
    if let Some(path) = &plan.checkpoint {
        save_checkpoint(&plan, path, &renderer, discarded, summary.elapsed)?;
    }
    let mean = accumulation.mean();
    let outputs = &plan.outputs;
    if let Some(png) = &outputs.png {
        output::write_png(png, &mean, 0.0).map_err(Failure::runtime)?;
    }
    if let Some(exr) = &outputs.exr {
        output::write_exr(exr, &mean, &[]).map_err(Failure::runtime)?;
    }
    if let Some(path) = &outputs.partial {
        let partial = Partial::from_state(
            plan.identity().clone(),
            plan.scene_path.display().to_string(),
            discarded,
            renderer.export_state(),
        )
        .asked_for(plan.requested_range(), interrupted);
        shard::write_partial(path, &partial).map_err(Failure::runtime)?;
    }
    if let Some(path) = &outputs.variance {
        let error = accumulation.standard_error().ok_or_else(|| {
            Failure::runtime("--variance: a standard error needs at least 2 samples per pixel")
        })?;
        output::write_exr(path, &error, &[]).map_err(Failure::runtime)?;
    }
    // The renderer's counts: a uniform continuation's image has none of its own.
    if let (Some(path), Some(counts)) = (&outputs.sample_counts, renderer.sample_counts()) {
        let image = output::Image {
            width,
            height,
            pixels: counts.iter().map(|&n| [n as f32; 3]).collect(),
        };
        output::write_exr(path, &image, &[]).map_err(Failure::runtime)?;
    }
    if discarded > 0 {
        eprintln!("pathmix: warning: {discarded} samples were NaN or infinite and counted as zero");
    }
    if interrupted {
        return Err(interruption(&plan, &summary, signal, signal_code));
    }
    let stopped = match summary.reason {
        StopReason::Samples => "sample count reached".to_string(),
        StopReason::TimeBudget => "time budget spent".to_string(),
        StopReason::TargetError => "target error reached".to_string(),
        StopReason::Interrupted => "interrupted".to_string(),
    };
    println!(
        "rendered {width}x{height} at {} spp in {:.2} s: {:.2} M paths/s ({stopped})",
        summary.samples,
        summary.elapsed.as_secs_f64(),
        summary.paths_per_second / 1e6
    );
    if let Some(choice) = renderer.adaptive_choice() {
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
    if plan.first_sample > 0 || outputs.partial.is_some() {
        println!(
            "sample indices {}..{}",
            renderer.first_sample(),
            renderer.first_sample() + renderer.samples()
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
    for path in [
        outputs.png.as_ref(),
        outputs.exr.as_ref(),
        outputs.variance.as_ref(),
        outputs.sample_counts.as_ref(),
        outputs.partial.as_ref(),
        plan.checkpoint.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Runs the pilot (`strategy = "auto"`) and makes its choice the run's: the scene's
/// strategy and light weight, the overrides a checkpoint records (so that a resume
/// renders with it, without a pilot) and the scene identity.
fn choose_strategy<'a>(
    ctx: &'a GpuContext,
    plan: &mut Plan,
    options: &RenderOptions,
    quiet: bool,
) -> Result<Pilot<'a>, Failure> {
    let input = |e: RenderError| Failure::input(with_flag(&e));
    let pilot = pilot::run(ctx, &plan.scene, options, plan.stop.max_samples).map_err(input)?;
    if !quiet {
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
                pilot::table(&pilot),
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
    let choice = pilot.choice;
    let (render, overrides) = (&mut plan.scene.render, &mut plan.overrides);
    render.strategy = choice.strategy;
    render.auto_strategy = false;
    overrides.strategy = Some(choice.strategy);
    if let Some(weight) = choice.light_weight {
        render.light_weight = weight;
        overrides.light_weight = Some(weight);
    }
    plan.identity = OnceLock::new();
    render::check_emission(&plan.scene, plan.stop.max_samples, plan.variance).map_err(input)?;
    Ok(pilot)
}

fn plural(count: usize) -> &'static str {
    if count == 1 { "" } else { "s" }
}

/// What an interrupted run tells the user (what was saved, how to go on) and its
/// exit: 130 for SIGINT, 143 for SIGTERM.
fn interruption(plan: &Plan, summary: &render::RunSummary, signal: &str, code: u8) -> Failure {
    match &plan.checkpoint {
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
