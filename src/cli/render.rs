//! `pathmix render`.

use super::Failure;
use super::progress::ProgressDisplay;
use clap::{Args, ValueEnum};
use pathmix::gpu::GpuContext;
use pathmix::kernel::{AccumulatorKind, SceneStorage};
use pathmix::output::{self, ImageFormat};
use pathmix::render::{self, RenderOptions, Renderer, StopRule};
use pathmix::scene::{Scene, SceneOverrides, Strategy};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (TOML; see docs/scene-format.md).
    pub scene: PathBuf,
    /// Output image: 8-bit sRGB PNG (linear radiance clamped to [0, 1], then the sRGB curve).
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Also write the mean radiance as linear float RGB OpenEXR.
    #[arg(long, value_name = "FILE")]
    pub exr: Option<PathBuf>,
    /// Samples per pixel [scene: render.spp].
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,
    /// Image width in pixels [scene: camera.width].
    #[arg(long, value_name = "W")]
    pub width: Option<u32>,
    /// Image height in pixels [scene: camera.height].
    #[arg(long, value_name = "H")]
    pub height: Option<u32>,
    /// Most scattering events on a path; 0 shows emitters only [scene: render.max_depth].
    #[arg(long, value_name = "D")]
    pub max_depth: Option<u32>,
    /// Direction sampling at diffuse surfaces [scene: render.strategy].
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// Mixture weight of the light density, in [0, 1] (default 0.5) [scene: render.light_weight].
    #[arg(long, value_name = "W")]
    pub light_weight: Option<f32>,
    /// Random seed: the same seed gives the same image [scene: render.seed].
    #[arg(long, value_name = "S")]
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
    /// on CPU drivers, slower to compile) or from storage buffers. Default: baked
    /// for scenes of up to 32 objects.
    #[arg(long, value_enum)]
    pub scene_storage: Option<SceneStorageArg>,
    /// No progress output.
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum StrategyArg {
    /// Mixture of the light density and cosine (unbiased; the default).
    Mixture,
    /// Cosine-weighted hemisphere only.
    Cosine,
    /// Light density only: biased, misses indirect light (diagnostic).
    Light,
}

impl From<StrategyArg> for Strategy {
    fn from(arg: StrategyArg) -> Strategy {
        match arg {
            StrategyArg::Mixture => Strategy::Mixture,
            StrategyArg::Cosine => Strategy::Cosine,
            StrategyArg::Light => Strategy::Light,
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
}

impl From<SceneStorageArg> for SceneStorage {
    fn from(arg: SceneStorageArg) -> SceneStorage {
        match arg {
            SceneStorageArg::Baked => SceneStorage::Baked,
            SceneStorageArg::Buffers => SceneStorage::Buffers,
        }
    }
}

pub fn render(args: RenderArgs) -> Result<(), Failure> {
    let mut scene = Scene::load(&args.scene).map_err(Failure::input)?;
    scene
        .apply_overrides(&SceneOverrides {
            spp: args.spp,
            width: args.width,
            height: args.height,
            max_depth: args.max_depth,
            strategy: args.strategy.map(Strategy::from),
            light_weight: args.light_weight,
            seed: args.seed,
        })
        .map_err(Failure::input)?;
    // Refuse unwritable outputs before spending the render time.
    output::check_output_path(&args.output, ImageFormat::Png).map_err(Failure::input)?;
    if let Some(exr) = &args.exr {
        output::check_output_path(exr, ImageFormat::Exr).map_err(Failure::input)?;
    }

    let ctx = GpuContext::new(args.adapter.as_deref()).map_err(Failure::runtime)?;
    let options = RenderOptions {
        accumulator: args.accumulator.map(AccumulatorKind::from),
        scene_storage: args.scene_storage.map(SceneStorage::from),
        ..Default::default()
    };
    let mut renderer = Renderer::new(&ctx, &scene, &options).map_err(Failure::input)?;
    for warning in &renderer.warnings {
        eprintln!("pathmix: warning: {warning}");
    }
    let (width, height) = renderer.size();
    eprintln!("adapter: {}", ctx.describe());
    eprintln!(
        "scene: {}  {width}x{height}  {} spp  strategy {}  max depth {}",
        scene.source,
        scene.render.spp,
        renderer.config().strategy,
        scene.render.max_depth
    );
    let mut display = ProgressDisplay::new(args.quiet);
    let summary = render::run(
        &mut renderer,
        StopRule {
            samples: scene.render.spp,
        },
        |p| display.update(p),
    );
    display.finish();
    let summary = summary.map_err(Failure::runtime)?;

    let mean = renderer.accumulation().mean();
    output::write_png(&args.output, &mean, 0.0).map_err(Failure::runtime)?;
    if let Some(exr) = &args.exr {
        output::write_exr(exr, &mean, &[]).map_err(Failure::runtime)?;
    }
    println!(
        "rendered {}x{} at {} spp in {:.2} s: {:.2} M paths/s",
        width,
        height,
        summary.samples,
        summary.elapsed.as_secs_f64(),
        summary.paths_per_second / 1e6
    );
    if summary.discarded > 0 {
        eprintln!(
            "pathmix: warning: {} samples were NaN or infinite and counted as zero",
            summary.discarded
        );
    }
    println!("wrote {}", args.output.display());
    if let Some(exr) = &args.exr {
        println!("wrote {}", exr.display());
    }
    Ok(())
}
