//! Progressive accumulation: dispatching samples in short submissions, reading
//! the running sums back, and the rules that stop a run.

pub mod adaptive;
pub mod aov;

use crate::abi::{
    BINDING_ACCUMULATOR, BINDING_ACTIVE_PIXELS, BINDING_COUNTERS, BINDING_PARAMS, BINDING_PROFILE,
    BINDING_SPLAT_SAMPLES, Counters, LAYER_SQUARES, LAYER_SUM, Params, RAY_OFFSET_RELATIVE,
    REPLICATES, SPLAT_SAMPLE_BYTES, SPLAT_STRIP_ROWS, StageCounts, replicate_layer,
};
use crate::accel::{self, WideBvh};
use crate::gpu::accumulator::{Accumulator, compensated_sums, read_back};
use crate::gpu::error_estimate::{ErrorEstimator, ErrorSums};
use crate::gpu::pipeline::Kernel;
use crate::gpu::texture_array::{self, TextureArray};
use crate::gpu::{GpuContext, GpuError};
use crate::kernel::{
    AccumulatorKind, ArrayMemory, ArraySource, KernelConfig, SceneStorage, Stage, WORKGROUP_SIZE,
};
use crate::kinds::{MASK_RAY_HITS, MATERIAL_NESTING, PRIMITIVE_KINDS};
use crate::pack::{CameraFrame, SceneData};
use crate::scene::{Filter, Reconstruction, Sampler, Scene, Strategy};
use crate::shader::ComposeError;
use crate::stats::{Accumulation, Replicates};
use std::cell::OnceCell;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// `None`: the storage texture where the adapter has it, else the buffer.
    pub accumulator: Option<AccumulatorKind>,
    /// Also accumulate squared samples (per-pixel error estimates).
    pub variance: bool,
    /// `None`: baked into the kernel for small scenes (`SceneStorage::auto`).
    pub scene_storage: Option<SceneStorage>,
    /// `None`: textures where they read faster and the adapter can bind the
    /// kernel's (`choose_array_memory`).
    pub array_memory: Option<ArrayMemory>,
    /// Wall time one submission should take: short enough to report progress
    /// and stop promptly, long enough to keep the device busy. Each dispatch waits
    /// for its slowest invocation, so more samples per invocation even out long
    /// paths: on the book's Cornell box (glass, 600x600) 1 s gave 1.40x the paths/s
    /// of 0.25 s, and 2.5x with the variance sums (docs/benchmarks.md).
    pub submission_seconds: f64,
    /// Compile every primitive and material kind in, not only the scene's
    /// (`KernelConfig::generalized`): for benchmarks.
    pub general_kernel: bool,
    /// Adaptive sampling (`crate::render::adaptive`): rounds over the pixels whose
    /// samples lower the error most. Accumulates the variance sums too.
    pub adaptive: bool,
    /// Under Sobol, interleave independent replicates (`KernelConfig::replicates`)
    /// even without `variance`: where samples are to be merged with a run that
    /// estimates errors (a resumed checkpoint's, the strategy pilot's).
    pub sampler_replicates: bool,
    /// Adaptive: the rounds whatever the pilot predicts (`adaptive::choose`), to
    /// study or test them where the choice would go on uniformly.
    pub adaptive_rounds_always: bool,
    /// Count each stage's SIMD lanes (`KernelConfig::profile`,
    /// `Renderer::stage_counts`): slower, for `pathmix bench --stages`.
    pub profile: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            accumulator: None,
            variance: false,
            scene_storage: None,
            array_memory: None,
            submission_seconds: 1.0,
            general_kernel: false,
            sampler_replicates: true,
            adaptive: false,
            adaptive_rounds_always: false,
            profile: false,
        }
    }
}

/// Why a run cannot start, or why its result cannot be trusted. The messages
/// name settings; a front end adds how to change them.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(
        "{scene}: a scene with non-finite numbers cannot be baked into the kernel; \
         it needs scene storage `buffers`"
    )]
    NonFiniteBakedScene { scene: String },
    #[error(
        "{scene}: strategy `light` needs an emitting or `importance = true` object to aim at, \
         and the scene has none"
    )]
    LightStrategyWithoutTargets { scene: String },
    #[error(
        "{scene}: strategy `auto` must be resolved by the pilot (`pathmix::session::pilot::run`) \
         before a renderer is built"
    )]
    StrategyNotChosen { scene: String },
    #[error(
        "AOV `{aov}`: the scene has no textures, and pathmix keeps the texture coordinates \
         of meshes only for scenes with textures"
    )]
    UvAovWithoutTextures { aov: String },
    #[error(
        "adapter {adapter} has no read-write rgba32float storage textures; \
         use the buffer accumulator"
    )]
    NoStorageTextures { adapter: String },
    #[error("adapter {adapter} has no subgroup operations, which profiling counts SIMD lanes with")]
    NoSubgroups { adapter: String },
    #[error(
        "adapter {adapter} cannot bind this scene's arrays as textures (too many, \
         or one taller than its largest texture); read them from storage buffers"
    )]
    ArrayTexturesTooLarge { adapter: String },
    #[error(
        "{width}x{height} exceeds this adapter's largest texture ({max}x{max}); \
         render a smaller image or use the buffer accumulator"
    )]
    TextureTooLarge { width: u32, height: u32, max: u32 },
    #[error(
        "{width}x{height} needs a {bytes}-byte accumulator, over this adapter's \
         storage buffer limit of {max} bytes; render a smaller image"
    )]
    AccumulatorTooLarge {
        width: u32,
        height: u32,
        bytes: u64,
        max: u64,
    },
    #[error("internal shader composition error: {0}")]
    ShaderComposition(#[from] ComposeError),
    #[error("the first sample index can only be set before rendering")]
    FirstSampleAfterRendering,
    #[error("saved sums are {saved_width}x{saved_height}, this render is {width}x{height}")]
    StateSizeMismatch {
        saved_width: u32,
        saved_height: u32,
        width: u32,
        height: u32,
    },
    #[error(
        "saved sums have {saved} layers, this render has {layers} (variance {})",
        if *.layers > LAYER_SQUARES { "on" } else { "off" }
    )]
    StateLayersMismatch { saved: u32, layers: u32 },
    #[error("saved sums hold {count} texels, expected {expected}")]
    StateTexelCountMismatch { count: usize, expected: u64 },
    #[error(
        "saved sums are of {}, this render is {}",
        if *.saved { "an adaptive run" } else { "a uniform run" },
        if *.saved { "uniform" } else { "adaptive" }
    )]
    StateAdaptiveMismatch { saved: bool },
    #[error("saved adaptive state does not fit the image (counts or round entries are wrong)")]
    StateAdaptiveInvalid,
    #[error(
        "adaptive sampling needs the sobol sampler: it decides from one of its independent \
         replicates and estimates from the others"
    )]
    AdaptiveNeedsSobol,
    #[error(
        "an adaptive run cannot be split into sample ranges: each pixel continues its own \
         sequence as far as its error asks, so shards would not add up to one run"
    )]
    AdaptiveShard,
    #[error("a target error needs the variance sums: render with variance on")]
    TargetErrorWithoutVariance,
    #[error(
        "{count} pixel invocations were cut short by the driver (a loop limit): the sums \
         would be wrong; render with a smaller maximum depth or a simpler scene on this adapter"
    )]
    TruncatedInvocations { count: u32 },
    #[error(
        "internal error: the kernel for this scene did not build (a pathmix bug: please \
         report it with the scene file): {message}"
    )]
    KernelBuild { message: String },
    #[error("{scene}: {what} needs {figure}, over {limit}")]
    ResourceLimit {
        scene: String,
        what: String,
        figure: String,
        limit: String,
    },
    #[error(
        "{scene}: {emitter} up to {radiance:e} could make the f32 sums \
         overflow in {samples} samples per pixel (a path can meet an emitter {hits} times; \
         the largest f32 is {max:e}){squares}: scale the emission down (the image scales \
         with it), or render fewer samples per pixel",
        max = f32::MAX,
        squares = if *.variance { ", counting the sums of squares of the variance" } else { "" }
    )]
    EmissionTooBright {
        scene: String,
        /// The brightest emitter, as the scene names it.
        emitter: String,
        /// Its field (`materials.light.emit`), which a caller may place in the file.
        field: String,
        radiance: f32,
        samples: u32,
        hits: u32,
        variance: bool,
    },
    #[error(
        "{count} of the image's sums overflowed to infinity or NaN: the scene's emission is \
         too bright for f32 sums over this many samples; scale it down (the image scales \
         with it). Nothing was written"
    )]
    SumsOverflowed { count: usize },
}

/// A scene array on the device: a storage buffer, or a texture
/// (`kernel::ArrayMemory::Textures`).
enum SceneResource {
    Buffer(wgpu::Buffer),
    Texture(wgpu::TextureView),
}

/// One scene on one device: the specialised kernel, its buffers and the sums so far.
pub struct Renderer<'a> {
    ctx: &'a GpuContext,
    kernel: Kernel,
    accumulator: Accumulator,
    params: Params,
    params_buffer: wgpu::Buffer,
    counters_buffer: wgpu::Buffer,
    /// A profiling kernel's `StageCounts`, one per `Stage`.
    profile_buffer: Option<wgpu::Buffer>,
    frame_group: wgpu::BindGroup,
    scene_group: wgpu::BindGroup,
    /// Samples per pixel accumulated so far (adaptive: the floor of their mean).
    samples: u32,
    /// Adaptive sampling's per-pixel counts and round.
    adaptive: Option<AdaptiveRun>,
    /// Paths traced since the renderer was made (for timing).
    paths_traced: u64,
    /// Sample index of the first sample accumulated (see `set_first_sample`).
    first_sample: u32,
    /// Paths one submission should trace, adapted to the measured speed.
    paths_per_submission: u64,
    /// Most samples one dispatch may trace per pixel (see `LOOP_ITERATION_BUDGET`).
    max_samples_per_dispatch: u32,
    /// A splatting kernel's samples of a submission, and how many per pixel it holds.
    splat_samples: Option<(wgpu::Buffer, u32)>,
    submission_seconds: f64,
    /// The error estimate's pipeline, built at the first `error_sums`.
    error_estimator: OnceCell<ErrorEstimator>,
    /// Things the user should know about this run (strategy fallbacks and the like).
    pub warnings: Vec<String>,
}

impl<'a> Renderer<'a> {
    /// Builds the kernel for `scene` and its buffers. `scene.render` says the strategy,
    /// depth, weight and seed; `scene.camera` the image size.
    pub fn new(
        ctx: &'a GpuContext,
        scene: &Scene,
        options: &RenderOptions,
    ) -> Result<Renderer<'a>, RenderError> {
        let settings = &scene.render;
        let (width, height) = (scene.camera.width, scene.camera.height);
        let KernelPlan {
            data,
            config,
            warnings,
            dropped_materials: _,
        } = plan_kernel(ctx, scene, options)?;
        let max_samples_per_dispatch = max_samples_per_dispatch(&data, &config);
        // A kernel or buffer the device refuses is a bug (the limits were checked):
        // reported as an error, not wgpu's default panic.
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let kernel = ctx.kernel(config)?;
        let accumulator = Accumulator::new(
            ctx,
            kernel.config.accumulator,
            width,
            height,
            kernel.config.accumulator_layers(),
        );

        let frame = CameraFrame::new(&scene.camera);
        let params = Params {
            origin: frame.origin.to_array(),
            width,
            to_pixel00: frame.to_pixel00.to_array(),
            height,
            delta_u: frame.delta_u.to_array(),
            delta_v: frame.delta_v.to_array(),
            lens_radius: frame.lens_radius,
            focus_distance: frame.focus_distance,
            background: settings.background.to_array(),
            seed: settings.seed,
            ray_offset: scene.extent() * RAY_OFFSET_RELATIVE,
            ..Params::default()
        };
        let device = &ctx.device;
        let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let counters_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("counters"),
            contents: bytemuck::bytes_of(&Counters::default()),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        });
        let profile_buffer = kernel.config.profile.then(|| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("stage counts"),
                contents: bytemuck::cast_slice(&[StageCounts::default(); Stage::ALL.len()]),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            })
        });
        let pixels = width as usize * height as usize;
        let splat_samples = kernel.config.splat.then(|| {
            let samples = splat_samples_per_submission(ctx, kernel.config.filter, width, height)
                .expect("`plan_kernel` splats only what fits");
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("splat samples"),
                size: pixels as u64 * samples as u64 * SPLAT_SAMPLE_BYTES,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            });
            (buffer, samples)
        });
        let adaptive = kernel.config.adaptive.then(|| AdaptiveRun {
            counts: vec![0; pixels],
            round: Vec::new(),
            round_samples: 0,
            round_done: 0,
            choice: None,
            rounds_always: options.adaptive_rounds_always,
            metric: (settings.adaptive_metric).unwrap_or(adaptive::AdaptiveMetric::Relative),
            list: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("active pixels"),
                size: (pixels * size_of::<[u32; 2]>()) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        });
        let mut frame_entries = vec![
            wgpu::BindGroupEntry {
                binding: BINDING_PARAMS,
                resource: params_buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: BINDING_ACCUMULATOR,
                resource: accumulator.binding(),
            },
            wgpu::BindGroupEntry {
                binding: BINDING_COUNTERS,
                resource: counters_buffer.as_entire_binding(),
            },
        ];
        if let Some(adaptive) = &adaptive {
            frame_entries.push(wgpu::BindGroupEntry {
                binding: BINDING_ACTIVE_PIXELS,
                resource: adaptive.list.as_entire_binding(),
            });
        }
        if let Some((buffer, _)) = &splat_samples {
            frame_entries.push(wgpu::BindGroupEntry {
                binding: BINDING_SPLAT_SAMPLES,
                resource: buffer.as_entire_binding(),
            });
        }
        if let Some(buffer) = &profile_buffer {
            frame_entries.push(wgpu::BindGroupEntry {
                binding: BINDING_PROFILE,
                resource: buffer.as_entire_binding(),
            });
        }
        let frame_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &kernel.frame_layout,
            entries: &frame_entries,
        });
        let scene_resources: Vec<(u32, SceneResource)> = kernel
            .config
            .scene_bindings()
            .into_iter()
            .map(|binding| {
                // A general kernel may declare kinds the scene lacks; bindings cannot be empty.
                let never_hit;
                let contents = match binding.source {
                    ArraySource::Primitives(k) if data.geometry.primitives[k].is_empty() => {
                        never_hit = (PRIMITIVE_KINDS[k].never_hit)();
                        &never_hit[..]
                    }
                    // A scene without objects has no materials, and nothing reads one.
                    ArraySource::Materials if data.materials.is_empty() => {
                        never_hit = vec![0; size_of::<crate::abi::PackedMaterial>()];
                        &never_hit[..]
                    }
                    // A light of no intensity: a general kernel's shadow rays find nothing.
                    ArraySource::DeltaLights if data.delta_lights.is_empty() => {
                        never_hit = bytemuck::bytes_of(&crate::lights::DeltaLight {
                            pmf: 1.0,
                            cdf: 1.0,
                            ..Default::default()
                        })
                        .to_vec();
                        &never_hit[..]
                    }
                    // Nor does a general kernel read tables of materials the scene lacks.
                    ArraySource::MaterialTables if data.material_tables.is_empty() => {
                        never_hit = vec![0; size_of::<f32>()];
                        &never_hit[..]
                    }
                    // Nor textures, or texture coordinates, of a scene without textures.
                    ArraySource::Textures if data.textures.is_empty() => {
                        never_hit = vec![0; size_of::<crate::kinds::TextureInfo>()];
                        &never_hit[..]
                    }
                    ArraySource::TextureTexels if data.texture_texels.is_empty() => {
                        never_hit = vec![0; size_of::<f32>()];
                        &never_hit[..]
                    }
                    ArraySource::Uvs(k) if data.geometry.uvs[k].is_empty() => {
                        never_hit = vec![0; binding.element_size()];
                        &never_hit[..]
                    }
                    source => data.array_bytes(source),
                };
                let resource = match kernel.config.in_texture(binding.source) {
                    true => {
                        let count = contents.len() / binding.element_size();
                        let word = binding
                            .source
                            .word_size()
                            .expect("texture arrays are words");
                        let texels = TextureArray::new(contents, count, word);
                        let texture = texels.upload(device, &ctx.queue);
                        SceneResource::Texture(texture.create_view(&Default::default()))
                    }
                    false => SceneResource::Buffer(device.create_buffer_init(
                        &wgpu::util::BufferInitDescriptor {
                            label: Some("scene"),
                            contents,
                            usage: wgpu::BufferUsages::STORAGE,
                        },
                    )),
                };
                (binding.binding, resource)
            })
            .collect();
        let scene_entries: Vec<_> = scene_resources
            .iter()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: *binding,
                resource: match resource {
                    SceneResource::Buffer(buffer) => buffer.as_entire_binding(),
                    SceneResource::Texture(view) => wgpu::BindingResource::TextureView(view),
                },
            })
            .collect();
        let scene_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &kernel.scene_layout,
            entries: &scene_entries,
        });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(RenderError::KernelBuild {
                message: error.to_string(),
            });
        }

        Ok(Renderer {
            ctx,
            kernel,
            accumulator,
            params,
            params_buffer,
            counters_buffer,
            profile_buffer,
            frame_group,
            scene_group,
            samples: 0,
            adaptive,
            paths_traced: 0,
            first_sample: 0,
            paths_per_submission: 1 << 18,
            max_samples_per_dispatch,
            splat_samples,
            submission_seconds: options.submission_seconds,
            error_estimator: OnceCell::new(),
            warnings,
        })
    }

    pub fn config(&self) -> &KernelConfig {
        &self.kernel.config
    }

    pub fn samples(&self) -> u32 {
        self.samples
    }

    pub fn size(&self) -> (u32, u32) {
        (self.params.width, self.params.height)
    }

    /// Starts the accumulation over at zero samples, keeping the kernel and the tuned
    /// submission size: after a warm-up run, the next samples are timed without the
    /// pipeline's first-use cost. The next dispatch overwrites the sums, and the run
    /// then matches a fresh renderer's sample for sample.
    pub fn reset(&mut self) {
        self.samples = 0;
        if let Some(adaptive) = &mut self.adaptive {
            adaptive.counts.fill(0);
            adaptive.round.clear();
            adaptive.round_samples = 0;
            adaptive.round_done = 0;
            adaptive.choice = None;
        }
    }

    /// Adaptive sampling: each pixel's sample count so far.
    pub fn sample_counts(&self) -> Option<&[u32]> {
        self.adaptive.as_ref().map(|a| &a.counts[..])
    }

    /// Adaptive sampling: the pilot's choice, once made.
    pub fn adaptive_choice(&self) -> Option<adaptive::Choice> {
        self.adaptive.as_ref().and_then(|a| a.choice)
    }

    /// Traces up to `max_samples` more samples per pixel in about one submission's
    /// time, waits for them, and returns how many were added. A very large image
    /// takes one sample over several submissions.
    ///
    /// Adaptive: `max_samples` more samples per pixel on average (the run's total);
    /// the submission continues the current round, or starts the next one
    /// (`adaptive::next_round`), and the return is the samples each of the round's
    /// pixels got, 0 when no pixel can take more.
    pub fn advance(&mut self, max_samples: u32) -> u32 {
        self.advance_toward(max_samples, u32::MAX)
    }

    /// As `advance`, with the submission also held to about `submission_samples`
    /// more samples per pixel on average (so a caller can look at the error soon).
    /// Adaptive: the rounds are still decided from `max_samples` alone, so that a
    /// resumed run makes the same rounds; a round cut short goes on in the next
    /// submission, and the sums are the same however a round is cut.
    pub fn advance_toward(&mut self, max_samples: u32, submission_samples: u32) -> u32 {
        if self.adaptive.is_some() {
            return self.advance_adaptive(max_samples, submission_samples);
        }
        let max_samples = max_samples.min(submission_samples);
        let (width, height) = self.size();
        let splat_limit = self.splat_samples.as_ref().map_or(u32::MAX, |(_, n)| *n);
        let (samples, rows) = submission_shape(
            self.paths_per_submission,
            width,
            height,
            max_samples
                .min(self.max_samples_per_dispatch)
                .min(splat_limit),
        );
        let started = Instant::now();
        let mut row = 0;
        while row < height {
            let tile_rows = rows.min(height - row);
            self.dispatch([0, row], [width, tile_rows], samples);
            row += tile_rows;
        }
        self.splat(samples);
        self.wait();
        self.samples += samples;
        let paths = width as u64 * height as u64 * samples as u64;
        self.paths_traced += paths;
        self.paths_per_submission =
            next_paths_per_submission(paths, started.elapsed(), self.submission_seconds);
        samples
    }

    /// As `advance`, in one submission of all `max_samples` where the loop budget
    /// of a dispatch allows, however fast the last ones were: for a caller timing a
    /// few short runs (`pilot::measure`). From the first size (2^18 paths) the size
    /// takes several submissions to adapt, and each costs a pass over every
    /// accumulator layer: 8 samples of the Cornell boxes at 600×600 with the variance
    /// sums ran at 6 M paths/s that way, 14–16 M paths/s in one submission.
    pub fn advance_in_one(&mut self, max_samples: u32) -> u32 {
        let (width, height) = self.size();
        let paths = width as u64 * height as u64 * max_samples as u64;
        self.paths_per_submission = self.paths_per_submission.max(paths);
        self.advance(max_samples)
    }

    /// Renders until the pipeline is compiled and the submission size has adapted,
    /// then starts the accumulation over, so that timed samples pay for neither:
    /// lavapipe compiles the kernel at its first dispatch, sometimes again at the
    /// second (the shader cache is written in the background), and each submission
    /// moves the size at most 4x toward its target. Submissions trace up to
    /// `max_samples` samples, as the timed ones will. Settled: at least 3
    /// submissions, the time per path of the last two within 1.5 times the fastest
    /// (then neither compilation nor per-submission overhead dominates).
    pub fn warm_up(&mut self, max_samples: u32) {
        let mut per_path = Vec::new();
        while per_path.len() < WARM_UP_MAX_SUBMISSIONS {
            let started = Instant::now();
            let traced = self.paths_traced;
            if self.advance(max_samples) == 0 {
                break;
            }
            let paths = (self.paths_traced - traced) as f64;
            per_path.push(started.elapsed().as_secs_f64() / paths);
            let fastest = per_path.iter().copied().fold(f64::INFINITY, f64::min);
            if per_path.len() >= 3
                && per_path[per_path.len() - 2..]
                    .iter()
                    .all(|&t| t <= 1.5 * fastest)
            {
                break;
            }
        }
        self.reset();
    }

    /// Compiles the pipeline at the cost of two samples of one row (lavapipe compiles
    /// at the first dispatch, sometimes again at the second), then starts the
    /// accumulation over: for a caller that times its first samples without the
    /// size of its submissions settled (`pilot::measure`). A uniform renderer's.
    pub fn compile(&mut self) {
        assert!(
            self.adaptive.is_none(),
            "an adaptive renderer's rounds are its own"
        );
        let width = self.size().0;
        for _ in 0..2 {
            self.dispatch([0, 0], [width, 1], 1);
            self.splat(1);
            self.wait();
        }
        self.reset();
    }

    fn dispatch(&mut self, tile_origin: [u32; 2], tile_size: [u32; 2], samples: u32) {
        let params = Params {
            sample_start: self.first_sample.saturating_add(self.samples),
            sample_count: samples,
            tile_origin,
            tile_size,
            reset: (self.samples == 0) as u32,
            ..self.params
        };
        self.submit(params);
    }

    /// A splatting kernel's pass over the `samples` per pixel just traced
    /// (`shaders/splat.wgsl`); nothing for other kernels.
    fn splat(&self, samples: u32) {
        let start = self.first_sample.saturating_add(self.samples);
        self.splat_from(start, samples, self.samples == 0);
    }

    /// The splatting pass over the samples of indices `sample_start..` just
    /// traced into the splatting buffer (from its start), `reset` where they
    /// are the first of the sums.
    fn splat_from(&self, sample_start: u32, samples: u32, reset: bool) {
        let Some(pipeline) = &self.kernel.splat_pipeline else {
            return;
        };
        let (width, height) = self.size();
        let params = Params {
            sample_start,
            sample_count: samples,
            // One invocation per column of `SPLAT_STRIP_ROWS` pixels.
            tile_size: [width, height.div_ceil(SPLAT_STRIP_ROWS)],
            reset: reset as u32,
            ..self.params
        };
        self.submit_pass(pipeline, params);
    }

    /// The adaptive kernel's submission: `samples` samples from the round's
    /// `round_done`, for its list entries `origin_row * width..` in `rows` rows.
    fn advance_adaptive(&mut self, max_samples: u32, submission_samples: u32) -> u32 {
        let (width, height) = self.size();
        let pixels = width as u64 * height as u64;
        let adaptive = self.adaptive.as_ref().expect("an adaptive renderer");
        if adaptive.round_done == adaptive.round_samples {
            let total: u64 = adaptive.counts.iter().map(|&n| n as u64).sum();
            let run_samples = self.samples.saturating_add(max_samples);
            let budget = (run_samples as u64 * pixels).saturating_sub(total);
            let cap = adaptive::pixel_cap(run_samples);
            // The pilot's rounds and a uniform continuation's need no sums.
            let pilot_done = adaptive.pilot_done();
            let accumulation = adaptive.rounds_next().then(|| self.accumulation());
            let adaptive = self.adaptive.as_mut().expect("an adaptive renderer");
            let round = match &accumulation {
                None if !pilot_done => {
                    let pilot_cap = cap.min(adaptive::PILOT_SAMPLES);
                    adaptive::uniform_round(&adaptive.counts, pilot_cap, budget)
                }
                None => adaptive::uniform_round(&adaptive.counts, cap, budget),
                Some(accumulation) => {
                    let choice = *adaptive.choice.get_or_insert_with(|| {
                        let choice =
                            adaptive::choose(accumulation, &adaptive.counts, adaptive.metric);
                        adaptive::Choice {
                            uniform: choice.uniform && !adaptive.rounds_always,
                            ..choice
                        }
                    });
                    match choice.uniform {
                        true => adaptive::uniform_round(&adaptive.counts, cap, budget),
                        false => adaptive::next_round(
                            accumulation,
                            &adaptive.counts,
                            adaptive.metric,
                            cap,
                            budget,
                        ),
                    }
                }
            };
            let Some(round) = round else {
                return 0;
            };
            adaptive.round = (round.pixels.iter())
                .map(|&p| [p, adaptive.counts[p as usize]])
                .collect();
            adaptive.round_samples = round.samples;
            adaptive.round_done = 0;
            self.ctx
                .queue
                .write_buffer(&adaptive.list, 0, bytemuck::cast_slice(&adaptive.round));
        }
        let adaptive = self.adaptive.as_ref().expect("an adaptive renderer");
        let entries = adaptive.round.len() as u32;
        let list_rows = entries.div_ceil(width);
        let left = adaptive.round_samples - adaptive.round_done;
        let round_done = adaptive.round_done;
        // Whole replicate sets per submission, so an interrupted round leaves every
        // pixel's count a multiple of them; dispatches within the loop budget.
        let (shape_samples, rows) =
            submission_shape(self.paths_per_submission, width, list_rows, left);
        // `submission_samples` per pixel on average, over the round's entries.
        let by_limit = (submission_samples as u64 * pixels / entries.max(1) as u64)
            .min(u32::MAX as u64) as u32;
        let samples = (shape_samples.min(by_limit))
            .saturating_sub(shape_samples.min(by_limit) % REPLICATES)
            .max(REPLICATES)
            .min(left);
        // A round of every pixel at one count splats as a uniform run does
        // (the pilot, and a uniform continuation): each dispatch's samples fill
        // the splatting buffer from its start, and its pass follows.
        let splat_limit = (self.splat_samples.as_ref())
            .filter(|_| adaptive.round_is_uniform())
            .map(|&(_, limit)| limit);
        let submission_start = adaptive.round.first().map_or(0, |&[_, count]| count) + round_done;
        let chunk = self
            .max_samples_per_dispatch
            .min(splat_limit.unwrap_or(u32::MAX));
        let started = Instant::now();
        let mut done = 0;
        while done < samples {
            let count = (samples - done).min(chunk);
            let mut row = 0;
            while row < list_rows {
                let tile_rows = rows.min(list_rows - row);
                let params = Params {
                    sample_start: round_done + done,
                    sample_count: count,
                    tile_origin: [0, row],
                    tile_size: [width, tile_rows],
                    active_count: entries,
                    splatting: splat_limit.is_some() as u32,
                    ..self.params
                };
                self.submit(params);
                row += tile_rows;
            }
            if splat_limit.is_some() {
                let start = submission_start + done;
                self.splat_from(start, count, start == 0);
            }
            done += count;
        }
        self.wait();
        let adaptive = self.adaptive.as_mut().expect("an adaptive renderer");
        adaptive.round_done += samples;
        for &[p, _] in &adaptive.round {
            adaptive.counts[p as usize] += samples;
        }
        let total: u64 = adaptive.counts.iter().map(|&n| n as u64).sum();
        self.samples = (total / pixels) as u32;
        let paths = entries as u64 * samples as u64;
        self.paths_traced += paths;
        self.paths_per_submission =
            next_paths_per_submission(paths, started.elapsed(), self.submission_seconds);
        samples
    }

    fn submit(&self, params: Params) {
        let rows = params.tile_size[1].div_ceil(WORKGROUP_SIZE.1);
        let params = Params {
            workgroup_row_step: workgroup_row_step(rows),
            ..params
        };
        self.submit_pass(&self.kernel.pipeline, params);
    }

    /// One dispatch of `pipeline` over `params.tile_size`, with the frame's and
    /// the scene's bind groups.
    fn submit_pass(&self, pipeline: &wgpu::ComputePipeline, params: Params) {
        self.submit_pass_with(pipeline, &self.frame_group, params);
    }

    /// As `submit_pass`, with another frame bind group (the AOV pass's).
    fn submit_pass_with(
        &self,
        pipeline: &wgpu::ComputePipeline,
        frame_group: &wgpu::BindGroup,
        params: Params,
    ) {
        let tile_size = params.tile_size;
        self.ctx
            .queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&params));
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, frame_group, &[]);
            pass.set_bind_group(1, &self.scene_group, &[]);
            pass.dispatch_workgroups(
                tile_size[0].div_ceil(WORKGROUP_SIZE.0),
                tile_size[1].div_ceil(WORKGROUP_SIZE.1),
                1,
            );
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    fn wait(&self) {
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .expect("device lost while rendering");
    }

    /// The sums so far, in f64 (each running sum minus its compensation).
    pub fn accumulation(&self) -> Accumulation {
        let texels = self.accumulator.read(self.ctx);
        let (width, height) = self.size();
        let pixels = width as usize * height as usize;
        let layer = |sum| compensated_sums(&texels, pixels, sum, sum + 1).collect::<Vec<_>>();
        let config = &self.kernel.config;
        let sum = layer(LAYER_SUM);
        // Adaptive: each pixel's own count decides its replicates' (`counts`).
        let range = self.first_sample as u64..(self.first_sample + self.samples) as u64;
        let replicates = (config.variance && config.sampler == Sampler::Sobol).then(|| {
            let others = (1..REPLICATES).map(|r| layer(replicate_layer(r))).collect();
            Replicates::from_others(range, &sum, others)
        });
        // Before the pilot's choice, and in a uniform continuation, the pixels all
        // have `samples` and the image is the mean of all of them (`adaptive::choose`).
        let counts = match self.adaptive_choice() {
            Some(choice) if !choice.uniform => self.sample_counts().map(<[u32]>::to_vec),
            _ => None,
        };
        Accumulation {
            width,
            height,
            samples: self.samples as u64,
            counts,
            sum,
            sum_sq: config.variance.then(|| layer(LAYER_SQUARES)),
            replicates,
        }
    }

    /// Index of the first sample this renderer accumulates: sample indices
    /// `first_sample()..first_sample() + samples()` are in the sums.
    pub fn first_sample(&self) -> u32 {
        self.first_sample
    }

    /// Makes the accumulation start at sample index `first` instead of 0, so that
    /// separate runs can render disjoint sample ranges of one image (shards).
    /// Only before the first sample is traced, and not in an adaptive run.
    pub fn set_first_sample(&mut self, first: u32) -> Result<(), RenderError> {
        if self.adaptive.is_some() && first > 0 {
            return Err(RenderError::AdaptiveShard);
        }
        if self.samples > 0 {
            return Err(RenderError::FirstSampleAfterRendering);
        }
        self.first_sample = first;
        Ok(())
    }

    /// The raw device sums (each running sum and its compensation, every layer)
    /// and the samples they hold: with `import_state`, a run continues bit-exactly.
    pub fn export_state(&self) -> AccumulatorState {
        let (width, height) = self.size();
        AccumulatorState {
            width,
            height,
            layers: self.accumulator.layers,
            first_sample: self.first_sample,
            samples: self.samples,
            texels: self.accumulator.read(self.ctx),
            adaptive: self.adaptive.as_ref().map(|a| AdaptiveState {
                counts: a.counts.clone(),
                round: a.round.clone(),
                round_samples: a.round_samples,
                round_done: a.round_done,
                choice: a.choice,
            }),
        }
    }

    /// Replaces the sums with `state` (from `export_state`, maybe of another
    /// process): the next sample traced is `state.first_sample + state.samples`,
    /// added to the saved sums and compensations.
    pub fn import_state(&mut self, state: &AccumulatorState) -> Result<(), RenderError> {
        let (width, height) = self.size();
        check_state(state, width, height, self.accumulator.layers)?;
        match (&mut self.adaptive, &state.adaptive) {
            (None, None) => {}
            (Some(adaptive), Some(saved)) => {
                if !saved.fits(width, height) {
                    return Err(RenderError::StateAdaptiveInvalid);
                }
                adaptive.counts.clone_from(&saved.counts);
                adaptive.round.clone_from(&saved.round);
                adaptive.round_samples = saved.round_samples;
                adaptive.round_done = saved.round_done;
                adaptive.choice = saved.choice;
                self.ctx.queue.write_buffer(
                    &adaptive.list,
                    0,
                    bytemuck::cast_slice(&adaptive.round),
                );
            }
            (adaptive, _) => {
                return Err(RenderError::StateAdaptiveMismatch {
                    saved: adaptive.is_none(),
                });
            }
        }
        self.accumulator.write(self.ctx, &state.texels);
        self.first_sample = state.first_sample;
        self.samples = state.samples;
        Ok(())
    }

    /// Starts the run from the samples of `pilot`, a renderer of the same image,
    /// sample indices, settings and accumulator kind but maybe more accumulator
    /// layers (the pilot's with the variance sums, `pilot::Pilot::samples`): the
    /// layers come in one order whatever follows them, so this renderer's are a
    /// prefix of those, copied on the device. Both lay out Sobol's samples alike
    /// (`KernelConfig::sobol_replicates`). An adaptive renderer takes them as
    /// the start of its pilot, every pixel at `pilot.samples()` and no round
    /// begun. Only before the first sample, from a uniform renderer's samples
    /// from sample index 0.
    pub fn start_from(&mut self, pilot: &Renderer) -> Result<(), RenderError> {
        assert!(
            pilot.adaptive.is_none() && pilot.first_sample == 0,
            "a uniform run's first samples"
        );
        assert_eq!(pilot.size(), self.size(), "a pilot of the run's own image");
        assert_eq!(
            pilot.kernel.config.sobol_replicates(),
            self.kernel.config.sobol_replicates(),
            "the run's sample layout"
        );
        assert!(
            self.accumulator.layers <= pilot.accumulator.layers,
            "the pilot's layers hold the run's"
        );
        if self.samples > 0 {
            return Err(RenderError::FirstSampleAfterRendering);
        }
        let layers = self.accumulator.layers;
        self.accumulator
            .copy_layers_from(self.ctx, &pilot.accumulator, layers);
        if let Some(adaptive) = &mut self.adaptive {
            let (width, height) = pilot.size();
            adaptive.counts = vec![pilot.samples; width as usize * height as usize];
        }
        self.samples = pilot.samples;
        Ok(())
    }

    /// The error estimate's sums over the image (`gpu::error_estimate`), reduced
    /// on the device: None without variance sums. A uniform renderer's.
    pub fn error_sums(&self) -> Result<Option<ErrorSums>, RenderError> {
        let config = &self.kernel.config;
        assert!(self.adaptive.is_none(), "a uniform renderer's error");
        if !config.variance {
            return Ok(None);
        }
        let estimator = match self.error_estimator.get() {
            Some(estimator) => estimator,
            None => {
                let estimator = ErrorEstimator::new(self.ctx, config)?;
                self.error_estimator.get_or_init(|| estimator)
            }
        };
        let sums = estimator.sums(self.ctx, &self.accumulator, self.first_sample, self.samples);
        Ok(Some(sums))
    }

    /// The counters, refused when the driver cut invocations short: the sums are
    /// then wrong. The one check every run makes before trusting its result.
    pub fn check_counters(&self) -> Result<Counters, RenderError> {
        let counters = self.counters();
        if counters.truncated > 0 {
            return Err(RenderError::TruncatedInvocations {
                count: counters.truncated,
            });
        }
        Ok(counters)
    }

    /// The kernel's counters: samples discarded as NaN or infinite (added as
    /// zero), and invocations cut short by the driver (must be zero).
    pub fn counters(&self) -> Counters {
        read_back(
            self.ctx,
            &self.counters_buffer,
            bytemuck::pod_read_unaligned::<Counters>,
        )
    }

    /// A profiling kernel's counts per stage since the renderer was made
    /// (`RenderOptions::profile`); `None` for other kernels.
    pub fn stage_counts(&self) -> Option<Vec<(Stage, StageCounts)>> {
        let buffer = self.profile_buffer.as_ref()?;
        let counts = read_back(self.ctx, buffer, |bytes| {
            bytemuck::pod_collect_to_vec::<u8, StageCounts>(bytes)
        });
        Some(Stage::ALL.into_iter().zip(counts).collect())
    }
}

/// The accumulator's raw contents and the sample range they cover.
#[derive(Clone, Debug, PartialEq)]
pub struct AccumulatorState {
    pub width: u32,
    pub height: u32,
    /// 2 (sum, compensation) or 4 (and squares, compensation): `abi::LAYER_*`.
    pub layers: u32,
    pub first_sample: u32,
    pub samples: u32,
    /// `layers * width * height` texels, layer-major, rows top first; rgb are the
    /// channels, w is unused (0).
    pub texels: Vec<[f32; 4]>,
    /// Adaptive sampling's counts and round; `None` for a uniform run.
    pub adaptive: Option<AdaptiveState>,
}

/// An adaptive run's state besides the sums: with them, a resumed run makes the
/// same decisions as the uninterrupted one.
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptiveState {
    /// Each pixel's sample count, row-major.
    pub counts: Vec<u32>,
    /// The current round's pixels, each with its count when the round began.
    pub round: Vec<[u32; 2]>,
    /// Samples the round gives each of its pixels, and how many it has given.
    pub round_samples: u32,
    pub round_done: u32,
    /// The pilot's choice, once made (`adaptive::choose`).
    pub choice: Option<adaptive::Choice>,
}

impl AdaptiveState {
    /// Whether the state is one a `width` x `height` run could have reached.
    pub fn fits(&self, width: u32, height: u32) -> bool {
        let pixels = width as usize * height as usize;
        self.counts.len() == pixels
            && self.round_done <= self.round_samples
            && self.round.len() <= pixels
            && self.round.iter().all(|&[p, start]| {
                (p as usize) < pixels && self.counts[p as usize] == start + self.round_done
            })
    }
}

/// The adaptive renderer's counts and round, and the device list of the round's pixels.
struct AdaptiveRun {
    /// The error the rounds lower.
    metric: adaptive::AdaptiveMetric,
    counts: Vec<u32>,
    round: Vec<[u32; 2]>,
    round_samples: u32,
    round_done: u32,
    choice: Option<adaptive::Choice>,
    /// `RenderOptions::adaptive_rounds_always`.
    rounds_always: bool,
    /// Room for every pixel, as `[pixel, count when the round began]`.
    list: wgpu::Buffer,
}

impl AdaptiveRun {
    fn pilot_done(&self) -> bool {
        self.counts.iter().all(|&n| n >= adaptive::PILOT_SAMPLES)
    }

    /// Whether the next round is decided by the sums (and the budget): the
    /// pilot's choice, or the rounds it chose.
    fn rounds_next(&self) -> bool {
        self.choice.map_or(self.pilot_done(), |c| !c.uniform)
    }

    /// Whether the round samples every pixel from one count, as a uniform run
    /// does: then it can splat (the pilot, and a uniform continuation).
    fn round_is_uniform(&self) -> bool {
        let start = self.round.first().map(|&[_, count]| count);
        self.round.len() == self.counts.len()
            && self.round.iter().all(|&[_, count]| Some(count) == start)
    }
}

/// What a run's kernel is: the packed scene, the kernel configuration, and what
/// the user should be told. Decided once, here, for `Renderer::new` and `info`.
pub struct KernelPlan {
    pub data: SceneData,
    pub config: KernelConfig,
    pub warnings: Vec<String>,
    /// Materials of the scene file that no object uses, left out of the kernel.
    pub dropped_materials: usize,
}

/// The kernel `Renderer::new` builds for `scene` under `options` on `ctx`.
pub fn plan_kernel(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<KernelPlan, RenderError> {
    let settings = &scene.render;
    if settings.auto_strategy {
        return Err(RenderError::StrategyNotChosen {
            scene: scene.source.clone(),
        });
    }
    let (used, dropped_materials) = scene.without_unused_materials();
    let (data, strategy, warnings) = prepare_scene(&used, settings.strategy)?;
    aov::check_texture_coordinates(&settings.aovs, !data.textures.is_empty())?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let accumulator_kind = choose_accumulator(ctx, options.accumulator, width, height)?;
    // The general kernel reads the scene from buffers, as a kernel not specialised
    // to any scene would (through the BVH where the scene is large).
    let scene_storage = match options.scene_storage {
        _ if options.general_kernel => match SceneStorage::auto(&data) {
            SceneStorage::Baked => SceneStorage::Buffers,
            storage => storage,
        },
        Some(storage) => storage,
        None => SceneStorage::auto(&data),
    };
    let mut data = data;
    // Instances are found through the two-level BVH alone, whatever was asked.
    let scene_storage = match data.has_instances() {
        true => SceneStorage::Bvh,
        false => scene_storage,
    };
    let scene_storage = match scene_storage {
        SceneStorage::Bvh if data.has_instances() => {
            if !options.general_kernel {
                accel::put_large_first(&mut data.geometry);
            }
            let set = std::mem::take(&mut data.instance_set);
            match WideBvh::build_instanced(&mut data.geometry, &set) {
                Some((bvh, instancing)) => {
                    data.bvh = Some(bvh);
                    data.instancing = Some(instancing);
                    SceneStorage::Bvh
                }
                None => SceneStorage::Buffers,
            }
        }
        SceneStorage::Bvh => {
            // The general kernel compiles nothing in, large primitives included.
            if !options.general_kernel {
                accel::put_large_first(&mut data.geometry);
            }
            match WideBvh::build(&mut data.geometry) {
                Some(bvh) => {
                    data.bvh = Some(bvh);
                    SceneStorage::Bvh
                }
                // Nothing to hit: the loops over empty buffers are the same.
                None => SceneStorage::Buffers,
            }
        }
        storage => storage,
    };
    if scene_storage == SceneStorage::Baked && !data.is_finite() {
        return Err(RenderError::NonFiniteBakedScene {
            scene: scene.source.clone(),
        });
    }
    let config = KernelConfig::for_scene(
        &data,
        strategy,
        settings,
        scene.camera.filter,
        scene.camera.model(),
        accumulator_kind,
        options.variance,
        scene_storage,
    );
    let config = if options.general_kernel {
        config.generalized()
    } else {
        config
    };
    if options.adaptive && config.sampler != Sampler::Sobol {
        return Err(RenderError::AdaptiveNeedsSobol);
    }
    if options.profile && !ctx.subgroups {
        return Err(RenderError::NoSubgroups {
            adapter: ctx.describe(),
        });
    }
    let mut warnings = warnings;
    let config = KernelConfig {
        variance: config.variance || options.adaptive,
        adaptive: options.adaptive,
        replicates: options.sampler_replicates || config.variance || options.adaptive,
        splat: choose_splat(ctx, scene, &mut warnings),
        profile: options.profile,
        ..config
    };
    let config = KernelConfig {
        array_memory: choose_array_memory(ctx, &data, &config, options.array_memory)?,
        ..config
    };
    check_size(ctx, &config, width, height)?;
    check_scene_limits(ctx, scene, &data, &config)?;
    Ok(KernelPlan {
        data,
        config,
        warnings,
        dropped_materials,
    })
}

/// Whether the run splats its samples (`Reconstruction::Splat`): by default
/// wherever the filter is wider than a pixel (splatting with the box filter is
/// filter importance sampling), unless the image is too large for it; a note
/// where it would and cannot (drawn offsets cost 2-3x the relMSE at equal
/// samples). An adaptive run splats its uniform rounds alone: the others'
/// pixels take different numbers of samples, so they draw offsets.
fn choose_splat(ctx: &GpuContext, scene: &Scene, warnings: &mut Vec<String>) -> bool {
    let filter = scene.camera.filter;
    if scene.render.reconstruction_with(filter) == Reconstruction::Importance {
        return false;
    }
    let (width, height) = (scene.camera.width, scene.camera.height);
    if splat_samples_per_submission(ctx, filter, width, height).is_some() {
        return true;
    }
    warnings.push(format!(
        "the {} filter is applied by importance sampling, not splatting: one sample of \
         every pixel is more than the device can hold in one buffer",
        filter.name()
    ));
    false
}

/// Refuses, before the device is asked, a scene whose buffers exceed the
/// adapter's limits or whose loops cannot fit one sample in the loop budget.
fn check_scene_limits(
    ctx: &GpuContext,
    scene: &Scene,
    data: &SceneData,
    config: &KernelConfig,
) -> Result<(), RenderError> {
    let limits = ctx.limits();
    let limit = |what: String, figure: String, limit: String| RenderError::ResourceLimit {
        scene: scene.source.clone(),
        what,
        figure,
        limit,
    };
    // Arrays in textures fit: `choose_array_memory` checked their rows.
    let buffers =
        (config.scene_bindings().into_iter()).filter(|array| !config.in_texture(array.source));
    for binding in buffers {
        let bytes = data.array_bytes(binding.source).len() as u64;
        for (max, name) in [
            (
                limits.max_storage_buffer_binding_size,
                "max_storage_buffer_binding_size",
            ),
            (limits.max_buffer_size, "max_buffer_size"),
        ] {
            if bytes > max {
                return Err(limit(
                    format!("the scene array `{}`", binding.name),
                    format!("{bytes} bytes"),
                    format!("this adapter's {name} of {max} bytes"),
                ));
            }
        }
    }
    // One path vertex past the driver's limit is cut short whatever the path does.
    let per_vertex = loop_iterations_per_vertex(data, config);
    if per_vertex > DRIVER_LOOP_LIMIT {
        let advice = match (config.scene_storage(), &data.bvh) {
            (SceneStorage::Bvh, Some(bvh)) => format!(
                "; the BVH's walk is allowed {} steps a ray, {BVH_MEAN_STEPS_MARGIN} times its \
                 mean of {:.0}: its boxes overlap much, as a soup of large crossing triangles \
                 makes them{}: simplify or split such meshes",
                bvh_walk_allowance(bvh),
                bvh.expected_steps(),
                largest_meshes(scene)
            ),
            (SceneStorage::Buffers, _) => {
                " (the BVH, scene storage `bvh`, needs far fewer)".to_string()
            }
            _ => String::new(),
        };
        return Err(limit(
            format!(
                "one path vertex over {} objects and {} lights (scene storage {:?})",
                data.geometry.primitive_count(),
                data.light_count(),
                config.scene_storage()
            ),
            format!("{per_vertex} loop iterations"),
            format!(
                "the {DRIVER_LOOP_LIMIT} loop iterations lavapipe allows an invocation{advice}"
            ),
        ));
    }
    // Read from buffers, a path's count is a bound, not an allowance: one
    // that could pass the limit is refused rather than cut short mid-run.
    let per_path = per_vertex * (u64::from(config.max_depth) + 1);
    if config.scene_storage() == SceneStorage::Buffers && per_path > DRIVER_LOOP_LIMIT {
        return Err(limit(
            format!(
                "a path of up to {} vertices over {} objects and {} lights (scene storage \
                 Buffers)",
                config.max_depth + 1,
                data.geometry.primitive_count(),
                data.light_count()
            ),
            format!("{per_path} loop iterations"),
            format!(
                "the {DRIVER_LOOP_LIMIT} loop iterations lavapipe allows an invocation (the \
                 BVH, scene storage `bvh`, needs far fewer; or lower the maximum depth)"
            ),
        ));
    }
    Ok(())
}

/// The scene's largest mesh objects by faces, for a message: `; the largest
/// meshes: objects[2] (200000 faces), ...`, or nothing without meshes.
fn largest_meshes(scene: &Scene) -> String {
    let mut faces: BTreeMap<u32, usize> = BTreeMap::new();
    for triangle in &scene.shapes.triangles {
        *faces.entry(triangle.mesh).or_default() += 1;
    }
    let mut largest: Vec<(u32, usize)> = faces.into_iter().collect();
    largest.sort_by_key(|&(object, count)| (std::cmp::Reverse(count), object));
    let named: Vec<String> = (largest.iter().take(3))
        .map(|(object, count)| format!("objects[{object}] ({count} faces)"))
        .collect();
    match named.is_empty() {
        true => String::new(),
        false => format!("; the largest meshes: {}", named.join(", ")),
    }
}

/// Whether saved sums fit a render of `width` x `height` with `layers` layers:
/// the resume rules of `Renderer::import_state`.
fn check_state(
    state: &AccumulatorState,
    width: u32,
    height: u32,
    layers: u32,
) -> Result<(), RenderError> {
    if (state.width, state.height) != (width, height) {
        return Err(RenderError::StateSizeMismatch {
            saved_width: state.width,
            saved_height: state.height,
            width,
            height,
        });
    }
    if state.layers != layers {
        return Err(RenderError::StateLayersMismatch {
            saved: state.layers,
            layers,
        });
    }
    let expected = width as u64 * height as u64 * layers as u64;
    if state.texels.len() as u64 != expected {
        return Err(RenderError::StateTexelCountMismatch {
            count: state.texels.len(),
            expected,
        });
    }
    Ok(())
}

/// Samples per pixel and rows per dispatch for a submission of about `budget`
/// paths: as many whole samples of the image as fit, 1 to `max_samples`, over
/// all rows unless one sample of the image is over budget; a dispatch covers at
/// most the rows its workgroup count can reach.
fn submission_shape(budget: u64, width: u32, height: u32, max_samples: u32) -> (u32, u32) {
    let budget = budget.max(1);
    let pixels = width as u64 * height as u64;
    let samples = (budget / pixels).clamp(1, max_samples.max(1) as u64) as u32;
    let rows = ((budget / width as u64).clamp(1, height as u64) as u32)
        .min(u16::MAX as u32 * WORKGROUP_SIZE.1);
    (samples, rows)
}

/// The step by which a dispatch's workgroup rows go through the tile's `rows`
/// rows of workgroups: row `r` covers row `r × step mod rows`. lavapipe splits
/// a dispatch into one contiguous range of workgroups per thread, so taken in
/// order a thread can get all the sky while another traces the ground (on a
/// field of 4 000 spheres the two threads were busy 78% and 61% of the time).
/// A step coprime with `rows` visits every row once; the one nearest `rows`
/// times the golden ratio's conjugate spreads every contiguous range of the
/// sequence evenly over the tile (a Weyl sequence). The step is at most `rows`,
/// so `r × step` stays below 2^32: a dispatch has at most `u16::MAX` rows of
/// workgroups.
fn workgroup_row_step(rows: u32) -> u32 {
    let nearest = (rows as f64 * (5f64.sqrt() - 1.0) / 2.0).round() as u32;
    (0..=rows)
        .flat_map(|d| [nearest + d, nearest.saturating_sub(d)])
        .find(|&step| (1..=rows).contains(&step) && greatest_common_divisor(step, rows) == 1)
        .expect("1 is coprime with every row count")
}

fn greatest_common_divisor(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The next submission's paths after `paths` took `elapsed`: aimed at
/// `target_seconds`, changing by at most 4x at a time.
fn next_paths_per_submission(paths: u64, elapsed: Duration, target_seconds: f64) -> u64 {
    let seconds = elapsed.as_secs_f64().max(1e-4);
    let wanted = paths as f64 * (target_seconds / seconds).clamp(0.25, 4.0);
    wanted.max(1.0) as u64
}

/// The scene packed for a run with the `wanted` strategy, the strategy the run
/// really uses, and what the user should be told. Next-event estimation aims only
/// at emitters (a shadow ray toward a non-emitting importance object finds no
/// light). A strategy with nothing to aim at falls back to the materials' own (`bsdf`) sampling, except
/// `light`, which is refused there unless the scene has point or spot lights (which every
/// strategy estimates by shadow rays), and warned about everywhere (it is biased).
pub fn prepare_scene(
    scene: &Scene,
    wanted: Strategy,
) -> Result<(SceneData, Strategy, Vec<String>), RenderError> {
    let mut data = SceneData::pack(scene);
    if wanted == Strategy::NeeMis {
        data.keep_emitting_lights();
    }
    let mut warnings = scene.warnings.clone();
    let mut strategy = wanted;
    if data.light_count() == 0 && data.environment.is_none() && strategy != Strategy::Bsdf {
        // Point and spot lights are estimated by shadow rays whatever the strategy.
        let delta_lights = !data.delta_lights.is_empty();
        if strategy == Strategy::Light && !delta_lights {
            return Err(RenderError::LightStrategyWithoutTargets {
                scene: scene.source.clone(),
            });
        }
        let also = if delta_lights {
            " (point and spot lights are estimated by shadow rays under every strategy)"
        } else {
            ""
        };
        warnings.push(format!(
            "{}: no emitting or `importance = true` object to aim at: {wanted} falls back to bsdf sampling (the materials' own: cosine-weighted on diffuse surfaces){also}",
            scene.source
        ));
        strategy = Strategy::Bsdf;
    }
    // At weight 1 the mixture never samples the material: it is `light`, biased alike.
    let all_light = strategy == Strategy::Mixture && scene.render.light_weight >= 1.0;
    if strategy == Strategy::Light || all_light {
        let (name, fix) = if all_light {
            ("mixture` with `light_weight = 1", "a weight below 1")
        } else {
            ("light", "`mixture`")
        };
        warnings.push(format!(
            "strategy `{name}` is biased: it never samples directions that miss the lights, \
             so indirect light is lost (a diagnostic; use {fix} for correct images)"
        ));
    }
    Ok((data, strategy, warnings))
}

/// The array memory asked for, or textures where they read faster
/// (`GpuContext::textures_read_faster`) and the adapter can bind every texture
/// `config` would read; else storage buffers.
fn choose_array_memory(
    ctx: &GpuContext,
    data: &SceneData,
    config: &KernelConfig,
    wanted: Option<ArrayMemory>,
) -> Result<ArrayMemory, RenderError> {
    let limits = ctx.limits();
    let arrays: Vec<_> = (config.scene_bindings().into_iter())
        .filter(|array| config.can_be_texture(array.source))
        .collect();
    let fits = arrays.len() <= limits.max_sampled_textures_per_shader_stage as usize
        && arrays.iter().all(|array| {
            let word = array.source.word_size().expect("texture arrays are words");
            texture_array::rows(data.array_bytes(array.source).len(), word)
                <= limits.max_texture_dimension_2d
        });
    Ok(match wanted {
        Some(ArrayMemory::Textures) if !fits => {
            return Err(RenderError::ArrayTexturesTooLarge {
                adapter: ctx.describe(),
            });
        }
        Some(memory) => memory,
        None if fits && ctx.textures_read_faster => ArrayMemory::Textures,
        None => ArrayMemory::Buffers,
    })
}

/// The accumulator asked for, or the best the adapter offers for this size.
pub fn choose_accumulator(
    ctx: &GpuContext,
    wanted: Option<AccumulatorKind>,
    width: u32,
    height: u32,
) -> Result<AccumulatorKind, RenderError> {
    Ok(match wanted {
        Some(AccumulatorKind::Texture) if !ctx.storage_texture_accumulator => {
            return Err(RenderError::NoStorageTextures {
                adapter: ctx.describe(),
            });
        }
        Some(kind) => kind,
        // The buffer has no per-dimension limit, so it takes images wider or
        // taller than the adapter's largest texture.
        None if ctx.storage_texture_accumulator
            && width.max(height) <= ctx.limits().max_texture_dimension_2d =>
        {
            AccumulatorKind::Texture
        }
        None => AccumulatorKind::Buffer,
    })
}

/// Loop iterations one invocation may run per dispatch, all loops together.
/// lavapipe (gallivm) silently ends every loop of an invocation after 65535
/// iterations in all; the kernel counts invocations that end early, and this
/// budget, at half that limit, keeps them from happening.
const LOOP_ITERATION_BUDGET: u64 = 32768;

/// lavapipe's limit itself: loop iterations of one invocation, all loops together.
const DRIVER_LOOP_LIMIT: u64 = 65535;

/// Bytes a splatting kernel's buffer of samples may take: a submission traces
/// at most as many samples per pixel as fit (at least one).
const SPLAT_BUFFER_BYTES: u64 = 64 << 20;

/// Samples per pixel a splatting submission may trace (`Renderer::splat`), or
/// `None` where splatting cannot run: where one sample of every pixel exceeds
/// the device's largest storage binding, or one sample's pass over the pixels
/// around a strip (`(2 reach + 4) (2 reach + 2) + 1` loop iterations, and 4
/// loops over the replicates) the loop budget.
pub fn splat_samples_per_submission(
    ctx: &GpuContext,
    filter: Filter,
    width: u32,
    height: u32,
) -> Option<u32> {
    let one_sample = width as u64 * height as u64 * SPLAT_SAMPLE_BYTES;
    let limits = ctx.limits();
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let window = 2 * filter.splat_reach() as u64 + 1;
    let strip_rows = SPLAT_STRIP_ROWS as u64;
    let pass_iterations =
        (window + strip_rows - 1) * (window + 1) + 1 + strip_rows * REPLICATES as u64;
    let samples = (SPLAT_BUFFER_BYTES.max(one_sample).min(binding) / one_sample)
        .min(LOOP_ITERATION_BUDGET / pass_iterations);
    (samples >= 1).then(|| samples.min(u32::MAX as u64) as u32)
}

/// Loop iterations allowed for one ray's BVH traversal at least (see
/// `max_samples_per_dispatch`).
const BVH_ITERATIONS_PER_RAY: u64 = 256;

/// How many times its mean (`WideBvh::expected_steps`) a ray's walk of the
/// scene's BVH is allowed, where that is more than `BVH_ITERATIONS_PER_RAY`.
const BVH_MEAN_STEPS_MARGIN: f64 = 4.0;

/// Samples per dispatch that stay within `LOOP_ITERATION_BUDGET` even if every
/// path runs to the kernel's maximum depth: one path-loop iteration per vertex
/// and, when the scene is read from buffers, a loop over every primitive (closest
/// hit) and every light (light density) in it, twice with next-event estimation
/// (the shadow ray's closest hit and a second light density). A baked scene's
/// loops are unrolled. A BVH traversal's iterations (while-while: an inner-loop
/// step per interior node visited and per leaf reached, an outer-loop step per
/// leaf, and one per primitive tested) have no tight bound:
/// `BVH_ITERATIONS_PER_RAY` is a generous allowance for a BVH of well
/// separated boxes, raised to `BVH_MEAN_STEPS_MARGIN` times the walk's mean
/// for one whose boxes overlap much (a rotated mesh of long, thin faces: 4 000
/// such faces took over 1 000 steps a ray and failed at 256), and the
/// truncation guard reports a ray that needs more. The walk of a grouped kind's light BVH visits
/// each node, reaches each leaf and tests each light at most once, so its
/// nodes and lights bound it (`kernel::light_density_iterations`), capped at
/// its own such allowance.
pub fn max_samples_per_dispatch(data: &SceneData, config: &KernelConfig) -> u32 {
    let per_sample = loop_iterations_per_vertex(data, config) * (config.max_depth as u64 + 1);
    (LOOP_ITERATION_BUDGET / per_sample).clamp(1, u32::MAX as u64) as u32
}

/// Loop iterations allowed for one ray's walk of `bvh`: `BVH_ITERATIONS_PER_RAY`,
/// or `BVH_MEAN_STEPS_MARGIN` times its mean where that is more.
fn bvh_walk_allowance(bvh: &WideBvh) -> u64 {
    BVH_ITERATIONS_PER_RAY.max((BVH_MEAN_STEPS_MARGIN * bvh.expected_steps()).ceil() as u64)
}

/// The most loop iterations one path vertex can take (see `max_samples_per_dispatch`).
fn loop_iterations_per_vertex(data: &SceneData, config: &KernelConfig) -> u64 {
    let closest_hit = match config.scene_storage() {
        SceneStorage::Baked => 0,
        SceneStorage::Buffers => data.geometry.primitive_count() as u64,
        SceneStorage::Bvh => data.bvh.as_ref().map_or(0, bvh_walk_allowance),
    };
    let baked = config.scene_storage() == SceneStorage::Baked;
    let mut inner_loops = closest_hit
        + crate::kernel::light_density_iterations(
            data,
            bvh_walk_allowance,
            baked,
            config.grouped_density,
        );
    // The environment's sampling descends its pyramid.
    if let Some(tables) = data
        .environment
        .as_ref()
        .filter(|_| config.light_environment)
    {
        inner_loops += u64::from(tables.info.levels);
    }
    if config.strategy == Strategy::NeeMis {
        inner_loops *= 2;
        // Through masked surfaces, a shadow ray takes up to MASK_RAY_HITS
        // closest hits, each a step of its own loop.
        if config.masked {
            inner_loops += (u64::from(MASK_RAY_HITS) - 1) * closest_hit + u64::from(MASK_RAY_HITS);
        }
    }
    // The delta lights' shadow rays: a linear pick and one closest hit, or one
    // closest hit per light.
    if config.delta_lights {
        let lights = data.delta_lights.len() as u64;
        // Through masked surfaces, each shadow ray takes up to MASK_RAY_HITS
        // closest hits, each a step of its own loop.
        let shadow_ray = match config.masked {
            true => u64::from(MASK_RAY_HITS) * (closest_hit + 1),
            false => closest_hit,
        };
        inner_loops += match config.delta_light_pick {
            true => lights + shadow_ray,
            false => lights * (shadow_ray + 1),
        };
    }
    // Null events through masked surfaces: up to MASK_RAY_HITS - 1 more
    // path-loop iterations after each bounce, each a closest hit.
    if config.masked {
        inner_loops += (u64::from(MASK_RAY_HITS) - 1) * (closest_hit + 1);
    }
    // Resolving a material made of others: up to MATERIAL_NESTING steps.
    if config.nested_materials() {
        inner_loops += u64::from(MATERIAL_NESTING);
    }
    // One spare iteration per vertex, for safety.
    inner_loops + 2
}

fn check_size(
    ctx: &GpuContext,
    config: &KernelConfig,
    width: u32,
    height: u32,
) -> Result<(), RenderError> {
    let limits = ctx.limits();
    let layers = config.accumulator_layers() as u64;
    match config.accumulator {
        AccumulatorKind::Texture => {
            let max = limits.max_texture_dimension_2d;
            if width > max || height > max {
                return Err(RenderError::TextureTooLarge { width, height, max });
            }
        }
        AccumulatorKind::Buffer => {
            let bytes = width as u64 * height as u64 * 16 * layers;
            let max = limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size);
            if bytes > max {
                return Err(RenderError::AccumulatorTooLarge {
                    width,
                    height,
                    bytes,
                    max,
                });
            }
        }
    }
    Ok(())
}

/// Refuses a scene whose brightest emission (or background) could overflow the
/// f32 running sums within `max_samples` samples per pixel: a path meets an
/// emitter at most once per vertex, and `max_depth + 1` vertices (twice that with
/// next-event estimation's shadow rays), each adding at most the brightest
/// radiance times a throughput of about 1; with `variance` the squares must fit
/// too. Paths whose throughput grows past 1 are caught after the run by
/// [`check_sums_finite`].
pub fn check_emission(scene: &Scene, max_samples: u32, variance: bool) -> Result<(), RenderError> {
    let (radiance, emitter, field) = brightest_emission(scene);
    let depth = scene.render.max_depth.saturating_add(1);
    let hits = match scene.render.strategy {
        Strategy::NeeMis => depth.saturating_mul(2),
        _ => depth,
    };
    let per_sample = radiance as f64 * hits as f64;
    let samples = max_samples as f64;
    let largest = f32::MAX as f64;
    let overflows =
        per_sample * samples > largest || (variance && per_sample * per_sample * samples > largest);
    if overflows {
        return Err(RenderError::EmissionTooBright {
            scene: scene.source.clone(),
            emitter,
            field,
            radiance,
            samples: max_samples,
            hits,
            variance,
        });
    }
    Ok(())
}

/// The scene's brightest radiance and, for a message, what gives it (a
/// material's `emit`, `render.background` or an environment map's texel) and
/// its field.
fn brightest_emission(scene: &Scene) -> (f32, String, String) {
    // Only the materials objects use: an unused one is dropped before packing.
    let used = scene.used_materials();
    let materials = (scene.materials.iter().zip(used))
        .filter(|&(_, used)| used)
        .map(|(m, _)| {
            let what = format!("material `{}` (its `emit`)", m.name);
            (
                m.emit.max_element(),
                what,
                format!("materials.{}.emit", m.name),
            )
        });
    let background = (
        scene.render.background.max_element(),
        "`render.background`".to_string(),
        "render.background".to_string(),
    );
    let environment = scene.environment.as_ref().map(|map| {
        let (x, y, value) = map.brightest_texel();
        let texel = format!(
            "environment map `{}` (texel ({x}, {y}), times `scale` {})",
            map.file, map.scale
        );
        (value * map.scale, texel, "environment".to_string())
    });
    (materials.chain([background]).chain(environment)).fold(
        (0.0, "emission".to_string(), String::new()),
        |brightest, candidate| match candidate.0 > brightest.0 {
            true => candidate,
            false => brightest,
        },
    )
}

/// Refuses sums that overflowed (infinite or NaN): whatever the emission, an
/// image is never written from them.
pub fn check_sums_finite(accumulation: &Accumulation) -> Result<(), RenderError> {
    match accumulation.non_finite_sums() {
        0 => Ok(()),
        count => Err(RenderError::SumsOverflowed { count }),
    }
}

/// When a progressive run stops: at `max_samples` per pixel, or earlier when the
/// time budget is spent or the estimated relative error reaches the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StopRule {
    pub max_samples: u32,
    pub time_budget: Option<Duration>,
    /// Target for `Accumulation::relative_error` (needs `RenderOptions::variance`).
    pub target_error: Option<f64>,
}

impl StopRule {
    pub fn samples(max_samples: u32) -> StopRule {
        StopRule {
            max_samples,
            time_budget: None,
            target_error: None,
        }
    }
}

/// Which rule ended a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopReason {
    Samples,
    TimeBudget,
    /// The estimated relative error fell to or below the target.
    TargetError,
    /// The caller asked the run to stop (`run_with`'s flag).
    Interrupted,
    /// Toward an error target, the image was still black after
    /// [`BLACK_IMAGE_SAMPLES`]: its relative error is 0/0, so no target can
    /// be reached, and without a sample count or time budget the run would
    /// never end.
    BlackImage,
}

/// Samples per pixel after which a run toward an error target whose image is
/// black everywhere stops (`StopReason::BlackImage`): far beyond where a
/// scene with any light reachable by the camera shows some.
pub const BLACK_IMAGE_SAMPLES: u32 = 256;

/// Most submissions `Renderer::warm_up` runs.
const WARM_UP_MAX_SUBMISSIONS: usize = 10;

/// The error estimate is not trusted before this many samples per pixel.
pub const MIN_SAMPLES_FOR_ERROR: u32 = 8;

/// How often the error estimate is read back while running toward a target
/// (a readback copies the whole accumulator).
const ERROR_CHECK_INTERVAL: Duration = Duration::from_secs(1);

/// Progress after each submission, for the caller to display.
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    pub samples: u32,
    pub max_samples: u32,
    pub elapsed: Duration,
    pub paths_per_second: f64,
    /// The latest relative error estimate, when variance is accumulated.
    pub relative_error: Option<f64>,
    /// Estimated time left under the rule most likely to stop the run.
    pub eta: Option<Duration>,
}

/// How a run went.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub samples: u32,
    pub elapsed: Duration,
    pub paths_per_second: f64,
    /// Ray segments (closest-hit queries) per second.
    pub segments_per_second: f64,
    /// Samples whose radiance was NaN or infinite, counted as zero.
    pub discarded: u64,
    pub reason: StopReason,
    pub relative_error: Option<f64>,
}

/// Accumulates until `stop` holds, calling `on_progress` after each submission.
pub fn run(
    renderer: &mut Renderer,
    stop: StopRule,
    mut on_progress: impl FnMut(&Progress),
) -> Result<RunSummary, RenderError> {
    run_with(renderer, stop, &AtomicBool::new(false), |progress, _| {
        on_progress(progress);
        Ok::<(), RenderError>(())
    })
}

/// Like `run`, and also stops with `StopReason::Interrupted` once
/// `stop_requested` is set (checked between submissions, so the submission in
/// flight completes). After each submission `between` gets the progress and the
/// renderer, to save state or previews; an error from it ends the run.
pub fn run_with<E: From<RenderError>>(
    renderer: &mut Renderer,
    stop: StopRule,
    stop_requested: &AtomicBool,
    mut between: impl FnMut(&Progress, &Renderer) -> Result<(), E>,
) -> Result<RunSummary, E> {
    if stop.target_error.is_some() && !renderer.config().variance {
        return Err(RenderError::TargetErrorWithoutVariance.into());
    }
    let start_segments = renderer.counters().segments();
    let started = Instant::now();
    let start_samples = renderer.samples();
    let (width, height) = renderer.size();
    let pixels = width as f64 * height as f64;
    let rate = |samples: u32, elapsed: Duration| {
        (samples - start_samples) as f64 * pixels / elapsed.as_secs_f64().max(1e-9)
    };
    let mut relative_error = None;
    let mut last_error_check: Option<Instant> = None;
    let mut last_counter_check: Option<Instant> = None;
    // Samples at the last error check. Toward a target the error is also checked
    // when the samples have doubled since, and submissions stop there, so a run
    // overshoots by at most twice the samples (checks once a second alone let a
    // fast Sobol run stop at 3x the samples it needed).
    let mut checked_at = 0u32;
    // At the last error check, toward a target: every sum was zero.
    let mut black = false;
    let reason = loop {
        if stop_requested.load(Ordering::SeqCst) {
            break StopReason::Interrupted;
        }
        if renderer.samples() >= stop.max_samples {
            break StopReason::Samples;
        }
        // However small the budget, the image gets a sample per pixel.
        if renderer.samples() > 0
            && stop
                .time_budget
                .is_some_and(|budget| started.elapsed() >= budget)
        {
            break StopReason::TimeBudget;
        }
        if let (Some(target), Some(error)) = (stop.target_error, relative_error) {
            if error <= target {
                break StopReason::TargetError;
            }
        }
        if black && renderer.samples() >= BLACK_IMAGE_SAMPLES {
            break StopReason::BlackImage;
        }
        let samples = renderer.samples();
        let next_check = MIN_SAMPLES_FOR_ERROR.max(checked_at.saturating_mul(2));
        let to_next_check = match stop.target_error {
            Some(_) if next_check > samples => next_check - samples,
            _ => u32::MAX,
        };
        if renderer.advance_toward(stop.max_samples - samples, to_next_check) == 0 {
            // Adaptive: every pixel is at its cap.
            break StopReason::Samples;
        }
        // An invocation cut short makes the sums wrong: fail within a second,
        // not after the whole run.
        if last_counter_check.is_none_or(|t| t.elapsed() >= ERROR_CHECK_INTERVAL) {
            renderer.check_counters()?;
            last_counter_check = Some(Instant::now());
        }
        let elapsed = started.elapsed();
        let wants_error = renderer.config().variance && renderer.samples() >= MIN_SAMPLES_FOR_ERROR;
        let due = last_error_check.is_none_or(|t| t.elapsed() >= ERROR_CHECK_INTERVAL)
            || (stop.target_error.is_some() && renderer.samples() >= next_check);
        if wants_error && due {
            let accumulation = renderer.accumulation();
            relative_error = accumulation.relative_error();
            black = stop.target_error.is_some() && accumulation.is_black();
            last_error_check = Some(Instant::now());
            checked_at = renderer.samples();
        }
        between(
            &Progress {
                samples: renderer.samples(),
                max_samples: stop.max_samples,
                elapsed,
                paths_per_second: rate(renderer.samples(), elapsed),
                relative_error,
                eta: eta(
                    &stop,
                    renderer.samples() - start_samples,
                    elapsed,
                    renderer.samples(),
                    relative_error,
                ),
            },
            renderer,
        )?;
    };
    let elapsed = started.elapsed();
    let counters = renderer.check_counters()?;
    if renderer.config().variance && reason != StopReason::TargetError {
        relative_error = renderer.accumulation().relative_error();
    }
    Ok(RunSummary {
        samples: renderer.samples(),
        elapsed,
        paths_per_second: rate(renderer.samples(), elapsed),
        segments_per_second: (counters.segments() - start_segments) as f64
            / elapsed.as_secs_f64().max(1e-9),
        discarded: counters.discarded as u64,
        reason,
        relative_error,
    })
}

/// Time left: the soonest of the sample cap, the time budget, and the samples
/// the error target needs (error falls as 1/sqrt(samples)).
fn eta(
    stop: &StopRule,
    traced: u32,
    elapsed: Duration,
    samples: u32,
    error: Option<f64>,
) -> Option<Duration> {
    if traced == 0 {
        return None;
    }
    let per_sample = elapsed.as_secs_f64() / traced as f64;
    let mut left = per_sample * stop.max_samples.saturating_sub(samples) as f64;
    if let Some(budget) = stop.time_budget {
        left = left.min(budget.saturating_sub(elapsed).as_secs_f64());
    }
    if let (Some(target), Some(error)) = (stop.target_error, error) {
        let needed = samples as f64 * (error / target).powi(2);
        left = left.min(per_sample * (needed - samples as f64).max(0.0));
    }
    left.is_finite().then(|| Duration::from_secs_f64(left))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_scene_specialisation_validates() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut scenes = 0;
        let paths = std::fs::read_dir(dir)
            .unwrap()
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.extension().is_some_and(|e| e == "toml"));
        for path in paths {
            let scene = Scene::load(&path).unwrap();
            for strategy in Strategy::ALL {
                for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
                    for variance in [false, true] {
                        let (data, strategy, _) = prepare_scene(&scene, strategy).unwrap();
                        for storage in [
                            SceneStorage::Baked,
                            SceneStorage::Buffers,
                            SceneStorage::Bvh,
                        ] {
                            let config = KernelConfig::for_scene(
                                &data,
                                strategy,
                                &scene.render,
                                scene.camera.filter,
                                scene.camera.model(),
                                accumulator,
                                variance,
                                storage,
                            );
                            crate::kernel::tests::validate(&config);
                        }
                    }
                }
            }
            scenes += 1;
        }
        assert!(scenes >= 3);
    }

    #[test]
    fn submissions_take_whole_samples_of_the_image_within_the_budget() {
        let budget = 1 << 18;
        // (budget, width, height, most samples) -> (samples, rows)
        for (args, expected) in [
            ((budget, 1, 1, 1000), (1000, 1)),
            ((budget, 1, 1, 0), (1, 1)),
            ((budget, 1, 4096, 1000), (64, 4096)),
            ((budget, 4096, 1, 1000), (64, 1)),
            ((budget, 16, 16, 100), (100, 16)),
            // One sample of the image is over budget: a band of rows per dispatch.
            ((budget, 65536, 65536, 1000), (1, 4)),
            ((1000, 4096, 4096, 1000), (1, 1)),
            ((0, 4, 4, 1000), (1, 1)),
            // A dispatch reaches at most 65535 workgroups of 8 rows.
            ((1 << 30, 1, 1_000_000, 5000), (1073, 524_280)),
        ] {
            let (budget, width, height, max_samples) = args;
            assert_eq!(
                submission_shape(budget, width, height, max_samples),
                expected,
                "{args:?}"
            );
        }
    }

    /// The largest gap between the fraction of `rows` at or below a row and the
    /// fraction of `covered`'s rows there (Kolmogorov-Smirnov against uniform).
    fn discrepancy(covered: &mut [u32], rows: u32) -> f64 {
        covered.sort_unstable();
        let m = covered.len() as f64;
        let rows = rows as f64;
        let gaps = covered.iter().enumerate().map(|(i, &row)| {
            let below = i as f64 / m - row as f64 / rows;
            let at = (i + 1) as f64 / m - (row + 1) as f64 / rows;
            below.abs().max(at.abs())
        });
        gaps.fold(0.0, f64::max)
    }

    #[test]
    fn workgroup_rows_cover_the_tile_once_each_thread_spread_over_it() {
        for rows in 1..=1200u32 {
            let step = workgroup_row_step(rows);
            assert!(step <= rows, "{rows}: step {step}");
            let order: Vec<u32> = (0..rows).map(|r| r * step % rows).collect();
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(
                sorted,
                (0..rows).collect::<Vec<_>>(),
                "{rows}: not a permutation"
            );
            // Each of 2 to 16 threads' contiguous ranges of at least 32 rows.
            for threads in 2..=16 {
                let per_thread = (rows / threads) as usize;
                if per_thread < 32 {
                    continue;
                }
                for range in order.chunks_exact(per_thread) {
                    let d = discrepancy(&mut range.to_vec(), rows);
                    assert!(d <= 0.15, "{rows} rows, {threads} threads: discrepancy {d}");
                }
            }
        }
        // Taken in order, the first of two threads' ranges would be the top half.
        let mut top: Vec<u32> = (0..600).collect();
        assert!(discrepancy(&mut top, 1200) >= 0.5);
    }

    #[test]
    fn the_submission_size_follows_the_target_time_by_at_most_4x() {
        let ms = Duration::from_millis;
        assert_eq!(next_paths_per_submission(1000, ms(125), 0.25), 2000);
        assert_eq!(next_paths_per_submission(1000, ms(500), 0.25), 500);
        assert_eq!(next_paths_per_submission(1000, ms(1), 0.25), 4000);
        assert_eq!(next_paths_per_submission(1000, Duration::ZERO, 0.25), 4000);
        assert_eq!(next_paths_per_submission(1000, ms(10_000), 0.25), 250);
        assert_eq!(next_paths_per_submission(1, ms(10_000), 0.25), 1);
    }

    #[test]
    fn eta_is_the_soonest_rule() {
        let secs = Duration::from_secs;
        let stop = StopRule::samples(100);
        // 8 samples in 2 s: 0.25 s per sample.
        assert_eq!(eta(&stop, 0, secs(2), 20, None), None);
        assert_eq!(eta(&stop, 8, secs(2), 20, None), Some(secs(20)));
        assert_eq!(eta(&stop, 8, secs(2), 100, None), Some(Duration::ZERO));
        let budget = StopRule {
            time_budget: Some(secs(5)),
            ..stop
        };
        assert_eq!(eta(&budget, 8, secs(2), 20, None), Some(secs(3)));
        assert_eq!(eta(&budget, 8, secs(6), 20, None), Some(Duration::ZERO));
        // Error 0.2 at 20 samples, target 0.1: 80 samples needed, 60 more.
        let target = StopRule {
            max_samples: u32::MAX,
            time_budget: None,
            target_error: Some(0.1),
        };
        assert_eq!(eta(&target, 8, secs(2), 20, Some(0.2)), Some(secs(15)));
        assert_eq!(
            eta(&target, 8, secs(2), 20, Some(0.05)),
            Some(Duration::ZERO)
        );
        // No estimate yet: the sample cap alone.
        assert_eq!(
            eta(&target, 8, secs(2), 20, None),
            Some(Duration::from_secs_f64(0.25 * (u32::MAX - 20) as f64))
        );
    }

    fn state(width: u32, height: u32, layers: u32, texels: usize) -> AccumulatorState {
        AccumulatorState {
            width,
            height,
            layers,
            first_sample: 0,
            samples: 7,
            texels: vec![[0.0; 4]; texels],
            adaptive: None,
        }
    }

    #[test]
    fn saved_sums_must_fit_the_render() {
        assert!(check_state(&state(3, 2, 2, 12), 3, 2, 2).is_ok());
        assert!(check_state(&state(3, 2, 4, 24), 3, 2, 4).is_ok());
        let size = check_state(&state(3, 2, 2, 12), 2, 3, 2).unwrap_err();
        assert!(
            matches!(
                size,
                RenderError::StateSizeMismatch {
                    saved_width: 3,
                    saved_height: 2,
                    width: 2,
                    height: 3
                }
            ),
            "{size:?}"
        );
        assert_eq!(size.to_string(), "saved sums are 3x2, this render is 2x3");
        let layers = check_state(&state(3, 2, 2, 12), 3, 2, 4).unwrap_err();
        assert!(
            matches!(
                layers,
                RenderError::StateLayersMismatch {
                    saved: 2,
                    layers: 4
                }
            ),
            "{layers:?}"
        );
        assert_eq!(
            layers.to_string(),
            "saved sums have 2 layers, this render has 4 (variance on)"
        );
        let fewer = check_state(&state(3, 2, 4, 24), 3, 2, 2).unwrap_err();
        assert!(fewer.to_string().ends_with("(variance off)"), "{fewer}");
        let texels = check_state(&state(3, 2, 2, 11), 3, 2, 2).unwrap_err();
        assert!(
            matches!(
                texels,
                RenderError::StateTexelCountMismatch {
                    count: 11,
                    expected: 12
                }
            ),
            "{texels:?}"
        );
    }
}
