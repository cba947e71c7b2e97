//! A render session: what a request for an image decides beyond the samples,
//! behind one API that the command line and a library caller share. A
//! `Request` says what is wanted; `Session::plan` reads the scene (or the
//! checkpoint to resume), checks every path and setting before any work and
//! fixes the stopping rule; `choose_strategy` runs the pilot of `strategy =
//! "auto"`; `start` makes the renderer (from the checkpoint's state or the
//! pilot's samples); `Run::render` accumulates, saving checkpoints and
//! previews as it goes; `Run::finish` writes the results, the checkpoint
//! first, so that no finished work is lost.
//!
//! Errors name settings (`Setting`), never a front end's spelling of them:
//! the command line adds its flags.

use crate::abi::LAYER_SQUARES_COMPENSATION;
use crate::gpu::GpuContext;
use crate::output::{self, Image, ImageFormat, OutputError};
use crate::paths::{self, PathUse};
use crate::render::adaptive::{self, Choice};
use crate::render::{
    self, Progress, RenderError, RenderOptions, Renderer, RunSummary, StopReason, StopRule,
};
use crate::scene::mitsuba::Define;
use crate::scene::{
    AdaptiveMetric, LightSelection, LoadedScene, OverrideError, Sampler, Scene, SceneError,
    SceneOverrides,
};
use crate::session::checkpoint::{
    self, Checkpoint, CheckpointError, CheckpointLock, LockError, SceneIdentity,
};
use crate::session::pilot::{self, Pilot};
use crate::session::shard::{self, Partial};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// How often a session with a checkpoint saves it when the request does not say.
pub const DEFAULT_CHECKPOINT_EVERY: Duration = Duration::from_secs(60);

/// A setting of a request, for messages: `name` is the library's own (and a
/// checkpoint's `[run]` key); the command line names each by its flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Setting {
    Scene,
    Output,
    Exr,
    Variance,
    SampleCounts,
    Partial,
    Checkpoint,
    Resume,
    SampleRange,
    Shard,
}

impl Setting {
    pub fn name(self) -> &'static str {
        match self {
            Setting::Scene => "scene",
            Setting::Output => "output",
            Setting::Exr => "exr",
            Setting::Variance => "variance",
            Setting::SampleCounts => "sample_counts",
            Setting::Partial => "partial",
            Setting::Checkpoint => "checkpoint",
            Setting::Resume => "resume",
            Setting::SampleRange => "sample_range",
            Setting::Shard => "shard",
        }
    }
}

/// Where a path of a session came from: the request, or the checkpoint it resumes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathSource {
    pub setting: Setting,
    pub recorded: bool,
}

/// Where the results go.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outputs {
    /// 8-bit sRGB PNG of the mean.
    pub png: Option<PathBuf>,
    /// Linear float OpenEXR of the mean.
    pub exr: Option<PathBuf>,
    /// The per-pixel standard error of the mean (OpenEXR).
    pub variance: Option<PathBuf>,
    /// An adaptive run's per-pixel sample counts (OpenEXR).
    pub sample_counts: Option<PathBuf>,
    /// The raw sums with their sample range, for `shard::merge`.
    pub partial: Option<PathBuf>,
}

impl Outputs {
    fn each(&self) -> [(Setting, &Option<PathBuf>); 5] {
        [
            (Setting::Output, &self.png),
            (Setting::Exr, &self.exr),
            (Setting::Variance, &self.variance),
            (Setting::SampleCounts, &self.sample_counts),
            (Setting::Partial, &self.partial),
        ]
    }
}

/// What a caller asks of a render. Unset outputs of a resume default to those
/// the checkpoint recorded.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// The scene file; a resume may leave it out (the checkpoint records it).
    pub scene: Option<PathBuf>,
    /// A Mitsuba scene's `$name` parameters.
    pub defines: Vec<Define>,
    /// Settings over the scene file's (its `spp` is `spp` below).
    pub overrides: SceneOverrides,
    /// Samples per pixel; with a time budget or error target, an upper bound.
    pub spp: Option<u32>,
    /// The strategy is chosen by a pilot (`strategy = "auto"`), asked for here
    /// rather than by the scene file.
    pub auto_strategy: bool,
    pub time_budget: Option<Duration>,
    pub target_error: Option<f64>,
    pub adaptive: bool,
    pub outputs: Outputs,
    /// Where the state is saved, every `checkpoint_every` and at the end.
    pub checkpoint: Option<PathBuf>,
    pub checkpoint_every: Option<Duration>,
    /// Rewrite the PNG output this often while rendering.
    pub preview_every: Option<Duration>,
    /// The checkpoint to continue.
    pub resume: Option<PathBuf>,
    /// Only these sample indices: a shard of a larger run.
    pub sample_range: Option<Range<u32>>,
    /// Shard `index` of `count` of the `spp` samples.
    pub shard: Option<(u32, u32)>,
    /// How the kernel is built (accumulator, scene storage, array memory);
    /// `variance` and `adaptive` are the session's to decide, `variance` set
    /// here keeps the sums of squares too (a caller reading the error in memory).
    pub render: RenderOptions,
}

/// What a session refuses, naming the settings and files concerned.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Override(#[from] OverrideError),
    #[error("cannot resume: {0}")]
    Resume(Box<CheckpointError>),
    #[error("no scene file given")]
    NoScene,
    #[error(
        "`{}`: the path is not UTF-8, and a checkpoint records its paths as text; rename it \
         (or render without a checkpoint)",
        .path.display()
    )]
    PathNotUtf8 { setting: Setting, path: PathBuf },
    #[error("a checkpoint interval needs a checkpoint file to say where")]
    CheckpointEveryWithoutCheckpoint,
    #[error("cannot resume: the checkpoint's `run.define` is not a list of NAME=VALUE")]
    RecordedDefines,
    #[error("{0}")]
    SameFile(paths::Collision<PathSource>),
    #[error(
        "{} with strategy auto{}: each part would run its own pilot and could choose \
         another strategy than the others; give the strategy (a render with strategy auto \
         prints its choice)",
        .setting.name(), if *.requested { "" } else { " (the scene's)" }
    )]
    AutoWithParts { setting: Setting, requested: bool },
    #[error("with strategy auto{} the pilot chooses the light weight; give the strategy mixture to set it",
        if *.requested { "" } else { " (the scene's)" })]
    AutoWithLightWeight { requested: bool },
    #[error("cannot resume from `{}` adaptively: it was a uniform run", .checkpoint.display())]
    ResumeUniformAdaptively { checkpoint: PathBuf },
    #[error("{} with adaptive sampling: {}", .setting.name(), RenderError::AdaptiveShard)]
    AdaptiveWithParts { setting: Setting },
    #[error("per-pixel sample counts: only an adaptive run has them")]
    SampleCountsWithoutAdaptive,
    #[error(
        "cannot resume from `{}`: the scene `{}` is not the one the checkpoint was rendered \
         from: {}",
        .checkpoint.display(), .scene.display(), .differences.join("; ")
    )]
    ResumeOtherScene {
        checkpoint: PathBuf,
        scene: PathBuf,
        differences: Vec<String>,
    },
    #[error(
        "cannot resume from `{}` with a variance output or an error target: it holds no sums \
         of squares (the run had neither)",
        .checkpoint.display()
    )]
    ResumeWithoutSquares { checkpoint: PathBuf },
    #[error("a preview rewrites the PNG output: give one")]
    PreviewWithoutPng,
    #[error("--aov: AOVs are written as channels of the EXR image: give --exr")]
    AovsWithoutExr,
    #[error("{}: {source}", .setting.name())]
    Output {
        setting: Setting,
        source: OutputError,
    },
    #[error("checkpoint: {0}")]
    Replace(String),
    #[error(transparent)]
    Lock(#[from] LockError),
    #[error("cannot resume from `{}`: {source}", .checkpoint.display())]
    ResumeState {
        checkpoint: PathBuf,
        source: RenderError,
    },
    /// The renderer refused the scene or a setting (before any sample).
    #[error(transparent)]
    Refused(RenderError),
    /// The run failed (the device, or sums that overflowed).
    #[error(transparent)]
    Failed(RenderError),
    #[error("a standard error needs at least 2 samples per pixel")]
    VarianceOfOneSample,
    /// Writing a result or a checkpoint failed.
    #[error(transparent)]
    Write(OutputError),
}

/// A renderer's error during the run: the run failed.
impl From<RenderError> for SessionError {
    fn from(e: RenderError) -> SessionError {
        SessionError::Failed(e)
    }
}

impl SessionError {
    /// Whether the request or its files are at fault (else the run or the machine).
    pub fn is_input(&self) -> bool {
        !matches!(
            self,
            SessionError::Failed(_) | SessionError::Write(_) | SessionError::VarianceOfOneSample
        )
    }
}

impl fmt::Display for PathSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.setting.name())
    }
}

/// A planned session: the scene after the request's settings, and the rules
/// of the run.
pub struct Session {
    pub scene: Scene,
    pub scene_path: PathBuf,
    /// What was approximated reading the scene (Mitsuba files).
    pub approximations: Vec<String>,
    /// Where a Mitsuba file gives each field (`LoadedScene::places`).
    places: Vec<(String, String)>,
    defines: Vec<Define>,
    /// Settings over the scene file (without spp), as a checkpoint records them.
    overrides: SceneOverrides,
    /// Made when first asked for (`identity`): it formats every triangle, and
    /// a render that writes no checkpoint or partial result needs none.
    identity: OnceLock<SceneIdentity>,
    pub outputs: Outputs,
    pub checkpoint: Option<PathBuf>,
    checkpoint_every: Duration,
    preview_every: Option<Duration>,
    /// `max_samples` counts the renderer's samples (saved ones included).
    pub stop: StopRule,
    pub variance: bool,
    pub adaptive: bool,
    /// The first sample index (a shard's, or a resumed run's).
    pub first_sample: u32,
    /// Whether the run renders a part of a larger one (a range or shard).
    pub is_part: bool,
    pub resume: Option<(PathBuf, Checkpoint)>,
    /// What the caller should be told before the run (a checkpoint written by
    /// another pathmix).
    pub warnings: Vec<String>,
    render: RenderOptions,
    /// Held from `lock_checkpoint` to the run's end.
    lock: Option<CheckpointLock>,
}

impl Session {
    /// Reads the scene (or the checkpoint to resume and its scene) and checks
    /// the request, with no device: every refusal comes before any work.
    pub fn plan(request: &Request) -> Result<Session, SessionError> {
        Session::plan_with(request, None)
    }

    /// As `plan`, with the scene already read: `loaded` is what
    /// `Scene::load_with` gave for `request.scene` and `request.defines`, so a
    /// caller rendering one scene many times reads its files once.
    pub fn plan_loaded(request: &Request, loaded: LoadedScene) -> Result<Session, SessionError> {
        Session::plan_with(request, Some(loaded))
    }

    fn plan_with(request: &Request, loaded: Option<LoadedScene>) -> Result<Session, SessionError> {
        refuse_unrecordable_paths(request)?;
        let resume = match &request.resume {
            Some(path) => Some((
                path.clone(),
                checkpoint::read(path).map_err(|e| SessionError::Resume(Box::new(e)))?,
            )),
            None => None,
        };
        let saved = resume.as_ref().map(|(_, c)| c);
        let overrides = match saved {
            // AOVs are written at the end, as outputs are: a resume may ask for others.
            Some(c) => SceneOverrides {
                aovs: (request.overrides.aovs.clone()).or_else(|| c.overrides.aovs.clone()),
                ..c.overrides.clone()
            },
            None => SceneOverrides {
                spp: None,
                ..request.overrides.clone()
            },
        };
        let scene_path = match (&request.scene, saved) {
            (Some(path), _) => path.clone(),
            (None, Some(c)) => c.scene_path.clone(),
            (None, None) => return Err(SessionError::NoScene),
        };
        let recorded = |key: &str| saved.and_then(|c| c.run.get(key));
        let recorded_path = |key: &str| recorded(key).and_then(|v| v.as_str()).map(PathBuf::from);
        let recorded_seconds = |key: &str| {
            recorded(key)
                .and_then(|v| v.as_float())
                .map(|s| Duration::from_secs_f64(s.max(0.0)))
        };
        let given = &request.outputs;
        let outputs = Outputs {
            png: given.png.clone().or_else(|| recorded_path("output")),
            exr: given.exr.clone().or_else(|| recorded_path("exr")),
            variance: given.variance.clone().or_else(|| recorded_path("variance")),
            sample_counts: (given.sample_counts.clone()).or_else(|| recorded_path("sample_counts")),
            partial: given.partial.clone().or_else(|| recorded_path("partial")),
        };
        let checkpoint = request
            .checkpoint
            .clone()
            .or_else(|| request.resume.clone());
        if checkpoint.is_none() && request.checkpoint_every.is_some() {
            return Err(SessionError::CheckpointEveryWithoutCheckpoint);
        }
        // Before the scene is read (an output may name it), and again with the
        // files it reads.
        check_collisions(request, &scene_path, &[], &outputs, checkpoint.as_deref())?;
        // A resume without parameters reads the scene with those it was rendered with.
        let defines = match (saved, request.defines.is_empty()) {
            (Some(c), true) => recorded_defines(c)?,
            _ => request.defines.clone(),
        };
        let LoadedScene {
            mut scene,
            warnings: approximations,
            places,
            file_sampler,
        } = match loaded {
            Some(loaded) => loaded,
            None => Scene::load_with(&scene_path, &defines)?,
        };
        check_collisions(
            request,
            &scene_path,
            &scene.inputs,
            &outputs,
            checkpoint.as_deref(),
        )?;
        scene.apply_overrides(&SceneOverrides {
            spp: request.spp,
            ..overrides.clone()
        })?;
        if request.auto_strategy {
            scene.render.auto_strategy = true;
        }
        match saved {
            // A resumed run keeps the strategy it was rendered with: the checkpoint's own
            // (its overrides set it after the pilot; this covers a scene file changed to auto).
            Some(c) if scene.render.auto_strategy => {
                scene.render.strategy = c.identity.strategy;
                scene.render.light_weight = c.identity.light_weight;
                scene.render.auto_strategy = false;
            }
            _ => refuse_auto_conflicts(request, &scene)?,
        }
        // A resume picks lights as its run did; checkpoints from before the
        // choice all picked uniformly.
        if saved.is_some() {
            scene.render.light_selection = recorded(LIGHT_SELECTION_KEY)
                .and_then(|v| v.as_str())
                .and_then(LightSelection::from_name)
                .unwrap_or(LightSelection::Uniform);
        }
        let identity = OnceLock::new();
        let mut warnings = Vec::new();
        let open_ended = request.time_budget.is_some() || request.target_error.is_some();
        let adaptive = match &resume {
            Some((path, c)) => {
                let saved = c.state.adaptive.is_some();
                if request.adaptive && !saved {
                    return Err(SessionError::ResumeUniformAdaptively {
                        checkpoint: path.clone(),
                    });
                }
                saved
            }
            None => request.adaptive || scene.render.adaptive,
        };
        // Defaults by measurement (docs/rendering.md): the sampler only changes the
        // noise, so where this run does not name one it gets the best one, and is told.
        if overrides.sampler.is_none() {
            if let Some(named) = file_sampler {
                warnings.push(format!(
                    "the scene file names the {named} sampler (Mitsuba's default): rendering \
                     with the {} sampler, the same expected image with less noise; ask for the \
                     {named} sampler to render with it",
                    scene.render.sampler
                ));
            } else if adaptive && scene.render.sampler == Sampler::Independent {
                scene.render.sampler = Sampler::Sobol;
                warnings.push(
                    "adaptive sampling decides from one of the sobol sampler's replicates: \
                     rendering with it, not the scene's independent sampler (the same expected \
                     image)"
                        .into(),
                );
            }
        }
        if adaptive && scene.render.sampler != Sampler::Sobol {
            return Err(SessionError::Refused(RenderError::AdaptiveNeedsSobol));
        }
        if adaptive {
            for (setting, given) in [
                (Setting::SampleRange, request.sample_range.is_some()),
                (Setting::Shard, request.shard.is_some()),
                (Setting::Partial, outputs.partial.is_some()),
            ] {
                if given {
                    return Err(SessionError::AdaptiveWithParts { setting });
                }
            }
        } else if outputs.sample_counts.is_some() {
            return Err(SessionError::SampleCountsWithoutAdaptive);
        }
        if !scene.render.aovs.is_empty() && outputs.exr.is_none() {
            match overrides.aovs.is_some() {
                true => return Err(SessionError::AovsWithoutExr),
                false => warnings.push(
                    "the scene's AOVs (render.aovs) are channels of the EXR image: give --exr \
                     to have them"
                        .into(),
                ),
            }
        }
        let (first_sample, stop, variance) = match &resume {
            Some((path, c)) => {
                let differences = SceneIdentity::differences(
                    (&c.identity, "in the checkpoint"),
                    (
                        identity.get_or_init(|| SceneIdentity::of(&scene)),
                        "in the scene now",
                    ),
                );
                if !differences.is_empty() {
                    return Err(SessionError::ResumeOtherScene {
                        checkpoint: path.clone(),
                        scene: scene_path,
                        differences,
                    });
                }
                if c.pathmix_version != env!("CARGO_PKG_VERSION") {
                    warnings.push(format!(
                        "the checkpoint was written by pathmix {}, this is {}: if the kernel \
                         changed, the result is not the same as one uninterrupted run",
                        c.pathmix_version,
                        env!("CARGO_PKG_VERSION")
                    ));
                }
                let stop = if request.spp.is_some() || open_ended {
                    StopRule {
                        max_samples: request.spp.unwrap_or(u32::MAX),
                        time_budget: request.time_budget,
                        target_error: request.target_error,
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
                let wants_squares = given.variance.is_some()
                    || stop.target_error.is_some()
                    || request.render.variance;
                if !variance && wants_squares {
                    return Err(SessionError::ResumeWithoutSquares {
                        checkpoint: path.clone(),
                    });
                }
                (c.state.first_sample, stop, variance)
            }
            None => {
                // A shard may be empty (fewer samples than shards): a valid, empty part.
                let range = match (&request.sample_range, request.shard) {
                    (Some(range), _) => Some(range.clone()),
                    (None, Some((index, count))) => {
                        Some(shard::shard_range(index, count, scene.render.spp))
                    }
                    (None, None) => None,
                };
                let max_samples = match &range {
                    Some(range) => range.len() as u32,
                    None if request.spp.is_none() && open_ended => u32::MAX,
                    None => scene.render.spp,
                };
                let stop = StopRule {
                    max_samples,
                    time_budget: request.time_budget,
                    target_error: request.target_error,
                };
                // Partial results carry the sums of squares, so a merge can estimate errors.
                let variance = given.variance.is_some()
                    || request.target_error.is_some()
                    || given.partial.is_some()
                    || request.render.variance;
                (range.map_or(0, |r| r.start), stop, variance)
            }
        };

        let checkpoint_every = request
            .checkpoint_every
            .or_else(|| recorded_seconds("checkpoint_every_s"))
            .unwrap_or(DEFAULT_CHECKPOINT_EVERY);
        let preview_every = request
            .preview_every
            .or_else(|| recorded_seconds("preview_every_s"));
        if preview_every.is_some() && outputs.png.is_none() {
            return Err(SessionError::PreviewWithoutPng);
        }
        // Refuse unwritable outputs before spending the render time.
        for (setting, path) in outputs.each() {
            if let Some(path) = path {
                let format = match setting {
                    Setting::Output => ImageFormat::Png,
                    _ => ImageFormat::Exr,
                };
                output::check_output_path(path, format)
                    .map_err(|source| SessionError::Output { setting, source })?;
            }
        }
        if let Some(path) = &checkpoint {
            output::check_writable(path).map_err(|source| SessionError::Output {
                setting: Setting::Checkpoint,
                source,
            })?;
            checkpoint::check_replaceable(path).map_err(SessionError::Replace)?;
        }
        // An adaptive pixel may take up to its cap; adaptive runs sum squares.
        let most = match adaptive {
            true => adaptive::pixel_cap(stop.max_samples),
            false => stop.max_samples,
        };
        // Unless told otherwise, the rounds lower the error the run stops on.
        if adaptive && stop.target_error.is_some() && scene.render.adaptive_metric.is_none() {
            scene.render.adaptive_metric = Some(AdaptiveMetric::Absolute);
        }
        render::check_emission(&scene, most, variance || adaptive)
            .map_err(|e| SessionError::Refused(placed(e, &places)))?;
        // Sobol's independent replicates where the run estimates an error (the
        // variance sums, the adaptive rounds); elsewhere one finer net per pixel,
        // the strategy pilot's replicated samples then left out of the run. A
        // resume keeps its checkpoint's (checkpoints before the key were all
        // written with them).
        let sampler_replicates = match &resume {
            Some(_) => recorded(SAMPLER_REPLICATES_KEY)
                .and_then(|v| v.as_bool())
                .unwrap_or(true),
            None => variance || adaptive,
        };
        Ok(Session {
            scene,
            scene_path,
            approximations,
            places,
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
            is_part: request.sample_range.is_some() || request.shard.is_some(),
            resume,
            warnings,
            render: RenderOptions {
                variance,
                adaptive,
                sampler_replicates,
                ..request.render.clone()
            },
            lock: None,
        })
    }

    /// What checkpoints and partial results record of the scene.
    pub fn identity(&self) -> &SceneIdentity {
        self.identity.get_or_init(|| SceneIdentity::of(&self.scene))
    }

    /// The sample indices this run was asked for (a partial result records them):
    /// `None` when a time budget or error target decides the end.
    fn requested_range(&self) -> Option<Range<u32>> {
        let open = self.stop.time_budget.is_some() || self.stop.target_error.is_some();
        (self.stop.max_samples != u32::MAX && !open)
            .then(|| self.first_sample..self.first_sample.saturating_add(self.stop.max_samples))
    }

    /// For `strategy = "auto"`: runs the pilot and makes its choice the run's:
    /// the scene's strategy and light weight, the overrides a checkpoint
    /// records (so that a resume renders with it, without a pilot) and the
    /// scene identity. `None` where the strategy is set.
    pub fn choose_strategy<'a>(
        &mut self,
        ctx: &'a GpuContext,
    ) -> Result<Option<Pilot<'a>>, SessionError> {
        if !self.scene.render.auto_strategy {
            return Ok(None);
        }
        let pilot = pilot::run(ctx, &self.scene, &self.render, self.stop.max_samples)
            .map_err(SessionError::Refused)?;
        let choice = pilot.choice;
        let (render, overrides) = (&mut self.scene.render, &mut self.overrides);
        render.strategy = choice.strategy;
        render.auto_strategy = false;
        overrides.strategy = Some(choice.strategy);
        if let Some(weight) = choice.light_weight {
            render.light_weight = weight;
            overrides.light_weight = Some(weight);
        }
        self.identity = OnceLock::new();
        render::check_emission(&self.scene, self.stop.max_samples, self.variance)
            .map_err(|e| SessionError::Refused(placed(e, &self.places)))?;
        Ok(Some(pilot))
    }

    /// Locks the checkpoint file for the session's length, so that a second
    /// run saving to it is refused; before any work, where the caller wants
    /// that refusal first (`start` locks it otherwise).
    pub fn lock_checkpoint(&mut self) -> Result<(), SessionError> {
        if let (Some(path), None) = (&self.checkpoint, &self.lock) {
            self.lock = Some(CheckpointLock::acquire(path)?);
        }
        Ok(())
    }

    /// The renderer, holding the checkpoint's state, or the pilot's samples
    /// where it has them (`choose_strategy`).
    pub fn start<'a>(
        mut self,
        ctx: &'a GpuContext,
        pilot: Option<&mut Pilot<'a>>,
    ) -> Result<Run<'a>, SessionError> {
        self.lock_checkpoint()?;
        // The chosen candidate's samples, moved into the run's sums.
        let pilot_samples = pilot.and_then(|p| p.samples.take());
        let mut renderer =
            Renderer::new(ctx, &self.scene, &self.render).map_err(SessionError::Refused)?;
        let saved_discarded = match (&self.resume, &pilot_samples) {
            (Some((_, c)), _) => c.discarded,
            (None, Some(samples)) => samples.discarded,
            (None, None) => 0,
        };
        match &self.resume {
            Some((path, c)) => {
                renderer
                    .import_state(&c.state)
                    .map_err(|source| SessionError::ResumeState {
                        checkpoint: path.clone(),
                        source,
                    })?
            }
            None => match pilot_samples {
                Some(samples) => renderer.start_from(&samples.renderer)?,
                None => renderer.set_first_sample(self.first_sample)?,
            },
        }
        Ok(Run {
            session: self,
            renderer,
            saved_discarded,
            rendered_for: Duration::ZERO,
        })
    }
}

/// A started session: its renderer, and what the run has saved.
pub struct Run<'a> {
    pub session: Session,
    pub renderer: Renderer<'a>,
    /// Samples already in the sums (a resumed run's, or the pilot's) found
    /// NaN or infinite and counted as zero.
    saved_discarded: u64,
    /// Time spent rendering so far (`render_until`'s steps add up).
    rendered_for: Duration,
}

/// What a finished or interrupted run did.
pub struct Outcome {
    pub summary: RunSummary,
    /// Samples counted as zero for being NaN or infinite, saved ones included.
    pub discarded: u64,
    /// The files written, in the order written.
    pub written: Vec<PathBuf>,
}

impl Outcome {
    pub fn interrupted(&self) -> bool {
        self.summary.reason == StopReason::Interrupted
    }
}

impl Run<'_> {
    /// Accumulates until the stopping rule holds or `stop_requested` is set,
    /// saving the checkpoint and the preview as often as asked, and calling
    /// `on_progress` after each submission.
    pub fn render(
        &mut self,
        stop_requested: &AtomicBool,
        on_progress: impl FnMut(&Progress),
    ) -> Result<RunSummary, SessionError> {
        self.render_until(u32::MAX, stop_requested, on_progress)
    }

    /// As `render`, stopping too at `samples` per pixel: one step of a run
    /// its caller looks at between steps. The time budget counts the earlier
    /// steps' time (`rendered_for`); each step's summary its own.
    pub fn render_until(
        &mut self,
        samples: u32,
        stop_requested: &AtomicBool,
        mut on_progress: impl FnMut(&Progress),
    ) -> Result<RunSummary, SessionError> {
        let session = &self.session;
        let stop = StopRule {
            max_samples: session.stop.max_samples.min(samples),
            time_budget: (session.stop.time_budget)
                .map(|budget| budget.saturating_sub(self.rendered_for)),
            ..session.stop
        };
        let (mut last_checkpoint, mut last_preview) = (Instant::now(), Instant::now());
        let (saved_discarded, rendered_for) = (self.saved_discarded, self.rendered_for);
        let summary = render::run_with(&mut self.renderer, stop, stop_requested, |p, r| {
            on_progress(p);
            if let Some(path) = &session.checkpoint {
                if last_checkpoint.elapsed() >= session.checkpoint_every {
                    // Never save sums an invocation cut short has made wrong.
                    let discarded = saved_discarded + r.check_counters()?.discarded as u64;
                    save_checkpoint(session, path, r, discarded, rendered_for + p.elapsed)?;
                    last_checkpoint = Instant::now();
                }
            }
            if let (Some(every), Some(png)) = (session.preview_every, &session.outputs.png) {
                if last_preview.elapsed() >= every {
                    output::write_png(png, &r.accumulation().mean(), 0.0)
                        .map_err(SessionError::Write)?;
                    last_preview = Instant::now();
                }
            }
            Ok::<(), SessionError>(())
        });
        if let Ok(summary) = &summary {
            self.rendered_for += summary.elapsed;
        }
        summary
    }

    /// Time spent in `render` and `render_until` so far.
    pub fn rendered_for(&self) -> Duration {
        self.rendered_for
    }

    /// Writes what the run asked for, the checkpoint first: once the state is
    /// saved, nothing of the run can be lost. An interrupted run writes too
    /// (its partial result says it was interrupted).
    pub fn finish(&self, summary: RunSummary) -> Result<Outcome, SessionError> {
        let session = &self.session;
        let renderer = &self.renderer;
        let discarded = self.saved_discarded + summary.discarded;
        let interrupted = summary.reason == StopReason::Interrupted;
        let accumulation = renderer.accumulation();
        render::check_sums_finite(&accumulation)?;
        let mut written = Vec::new();
        if let Some(path) = &session.checkpoint {
            save_checkpoint(session, path, renderer, discarded, self.rendered_for)?;
            written.push(path.clone());
        }
        let mean = accumulation.mean();
        let outputs = &session.outputs;
        if let Some(png) = &outputs.png {
            output::write_png(png, &mean, 0.0).map_err(SessionError::Write)?;
            written.push(png.clone());
        }
        if let Some(exr) = &outputs.exr {
            let aovs = &session.scene.render.aovs;
            let channels = match aovs.is_empty() {
                true => Vec::new(),
                false => renderer.render_aovs(aovs, renderer.samples())?.channels,
            };
            output::write_exr_with_channels(exr, &mean, &channels).map_err(SessionError::Write)?;
            written.push(exr.clone());
        }
        if let Some(path) = &outputs.partial {
            let partial = Partial::from_state(
                session.identity().clone(),
                session.scene_path.display().to_string(),
                discarded,
                renderer.export_state(),
            )
            .asked_for(session.requested_range(), interrupted);
            shard::write_partial(path, &partial).map_err(SessionError::Write)?;
            written.push(path.clone());
        }
        if let Some(path) = &outputs.variance {
            let error = accumulation
                .standard_error()
                .ok_or(SessionError::VarianceOfOneSample)?;
            output::write_exr(path, &error, &[]).map_err(SessionError::Write)?;
            written.push(path.clone());
        }
        // The renderer's counts: a uniform continuation's image has none of its own.
        if let (Some(path), Some(counts)) = (&outputs.sample_counts, renderer.sample_counts()) {
            let (width, height) = renderer.size();
            let image = Image {
                width,
                height,
                pixels: counts.iter().map(|&n| [n as f32; 3]).collect(),
            };
            output::write_exr(path, &image, &[]).map_err(SessionError::Write)?;
            written.push(path.clone());
        }
        Ok(Outcome {
            summary,
            discarded,
            written,
        })
    }

    /// Adaptive sampling's choice, where the run was adaptive.
    pub fn adaptive_choice(&self) -> Option<Choice> {
        self.renderer.adaptive_choice()
    }
}

/// `strategy = "auto"` chooses per run: shards merged into one image must share a
/// strategy, and the pilot chooses the light weight.
fn refuse_auto_conflicts(request: &Request, scene: &Scene) -> Result<(), SessionError> {
    if !scene.render.auto_strategy {
        return Ok(());
    }
    let requested = request.auto_strategy;
    let part = [
        (Setting::Shard, request.shard.is_some()),
        (Setting::SampleRange, request.sample_range.is_some()),
        (Setting::Partial, request.outputs.partial.is_some()),
    ]
    .into_iter()
    .find_map(|(setting, given)| given.then_some(setting));
    if let Some(setting) = part {
        return Err(SessionError::AutoWithParts { setting, requested });
    }
    if request.overrides.light_weight.is_some() {
        return Err(SessionError::AutoWithLightWeight { requested });
    }
    Ok(())
}

/// A checkpoint records its scene and output paths as text (TOML): a path that is
/// not UTF-8 could not be found again on resume, so it is refused at the start.
fn refuse_unrecordable_paths(request: &Request) -> Result<(), SessionError> {
    if request.checkpoint.is_none() && request.resume.is_none() {
        return Ok(());
    }
    let outputs = request.outputs.each();
    let paths = [
        (Setting::Scene, &request.scene),
        (Setting::Checkpoint, &request.checkpoint),
        (Setting::Resume, &request.resume),
    ]
    .into_iter()
    .chain(outputs);
    for (setting, path) in paths {
        if let Some(path) = path {
            if absolute(path).to_str().is_none() {
                return Err(SessionError::PathNotUtf8 {
                    setting,
                    path: path.clone(),
                });
            }
        }
    }
    Ok(())
}

/// Every path this session reads or writes, compared with every other before
/// any work: no output may replace an input (the scene file, the files it
/// reads, the checkpoint resumed) or another output.
fn check_collisions(
    request: &Request,
    scene_path: &Path,
    scene_inputs: &[PathBuf],
    outputs: &Outputs,
    checkpoint: Option<&Path>,
) -> Result<(), SessionError> {
    let source = |setting, given: bool| PathSource {
        setting,
        recorded: !given,
    };
    let scene = source(Setting::Scene, request.scene.is_some());
    let mut uses = vec![PathUse::input(scene, scene_path)];
    uses.extend(
        scene_inputs
            .iter()
            .map(|input| PathUse::input(scene, input)),
    );
    let resume = source(Setting::Resume, true);
    match (&request.resume, checkpoint) {
        // Resuming saves to the checkpoint it read, as it was meant to.
        (Some(from), Some(to))
            if paths::collision(&[
                PathUse::input(resume, from),
                PathUse::output(source(Setting::Checkpoint, true), to),
            ])
            .is_some() =>
        {
            uses.push(PathUse::output(resume, from));
        }
        (from, to) => {
            uses.extend(from.as_deref().map(|r| PathUse::input(resume, r)));
            uses.extend(to.map(|c| PathUse::output(source(Setting::Checkpoint, true), c)));
        }
    }
    for ((setting, path), (_, given)) in outputs.each().into_iter().zip(request.outputs.each()) {
        if let Some(path) = path {
            uses.push(PathUse::output(source(setting, given.is_some()), path));
        }
    }
    match paths::collision(&uses) {
        Some(collision) => Err(SessionError::SameFile(collision)),
        None => Ok(()),
    }
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_owned())
}

/// The key under which a checkpoint records whether its Sobol samples
/// interleave replicates (`RenderOptions::sampler_replicates`).
const SAMPLER_REPLICATES_KEY: &str = "sampler_replicates";

/// The key under which a checkpoint records how its run picked lights
/// (`RenderSettings::light_selection`).
const LIGHT_SELECTION_KEY: &str = "light_selection";

/// What a resume needs besides the state: the stopping rule, outputs and sampler.
fn run_table(session: &Session, elapsed: Duration) -> toml::Table {
    let mut run = toml::Table::new();
    let stop = &session.stop;
    if stop.max_samples != u32::MAX {
        run.insert("spp".into(), toml::Value::Integer(stop.max_samples.into()));
    }
    if let Some(budget) = stop.time_budget {
        let left = budget.saturating_sub(elapsed).as_secs_f64();
        run.insert("time_left_s".into(), left.into());
    }
    if let Some(target) = stop.target_error {
        run.insert("target_error".into(), target.into());
    }
    for (setting, path) in session.outputs.each() {
        if let Some(path) = path {
            let path = absolute(path).to_string_lossy().into_owned();
            run.insert(setting.name().into(), path.into());
        }
    }
    run.insert(
        SAMPLER_REPLICATES_KEY.into(),
        session.render.sampler_replicates.into(),
    );
    run.insert(
        LIGHT_SELECTION_KEY.into(),
        session.scene.render.light_selection.name().into(),
    );
    run.insert(
        "checkpoint_every_s".into(),
        session.checkpoint_every.as_secs_f64().into(),
    );
    if let Some(every) = session.preview_every {
        run.insert("preview_every_s".into(), every.as_secs_f64().into());
    }
    if !session.defines.is_empty() {
        let defines = session
            .defines
            .iter()
            .map(|d| format!("{}={}", d.name, d.value));
        run.insert("define".into(), defines.collect::<Vec<_>>().into());
    }
    run
}

/// The `-D` parameters a checkpoint's run was given.
fn recorded_defines(c: &Checkpoint) -> Result<Vec<Define>, SessionError> {
    let Some(recorded) = c.run.get("define") else {
        return Ok(Vec::new());
    };
    let bad = || SessionError::RecordedDefines;
    recorded
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|v| v.as_str().and_then(|s| s.parse().ok()).ok_or_else(bad))
        .collect()
}

fn save_checkpoint(
    session: &Session,
    path: &Path,
    renderer: &Renderer,
    discarded: u64,
    elapsed: Duration,
) -> Result<(), SessionError> {
    let scene_path = std::fs::canonicalize(&session.scene_path)
        .unwrap_or_else(|_| absolute(&session.scene_path));
    let checkpoint = Checkpoint {
        pathmix_version: env!("CARGO_PKG_VERSION").to_string(),
        scene_path,
        overrides: session.overrides.clone(),
        identity: session.identity().clone(),
        discarded,
        run: run_table(session, elapsed),
        state: renderer.export_state(),
    };
    checkpoint::write(path, &checkpoint).map_err(SessionError::Write)
}

/// A refusal of too bright an emitter, naming where a Mitsuba file gives it.
fn placed(error: RenderError, places: &[(String, String)]) -> RenderError {
    match error {
        RenderError::EmissionTooBright {
            scene,
            emitter,
            field,
            radiance,
            samples,
            hits,
            variance,
        } => {
            let emitter = match LoadedScene::place_of(places, &field) {
                Some(place) => format!("{emitter}, given at {place},"),
                None => emitter,
            };
            RenderError::EmissionTooBright {
                scene,
                emitter,
                field,
                radiance,
                samples,
                hits,
                variance,
            }
        }
        other => other,
    }
}
