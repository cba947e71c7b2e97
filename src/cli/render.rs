//! `pathmix render`.

use super::Failure;
use super::progress::ProgressDisplay;
use clap::{Args, ValueEnum};
use pathmix::gpu::GpuContext;
use pathmix::kernel::{AccumulatorKind, SceneStorage};
use pathmix::output::{self, ImageFormat};
use pathmix::render::{self, RenderOptions, Renderer, StopReason, StopRule};
use pathmix::scene::{Scene, SceneOverrides, Strategy};
use std::path::PathBuf;
use std::time::{Duration, Instant};

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
    /// Image width in pixels [scene: camera.width].
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels [scene: camera.height].
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Most scattering events on a path; 0 shows emitters only [scene: render.max_depth].
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    pub max_depth: Option<u32>,
    /// Direction sampling at diffuse surfaces [scene: render.strategy].
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// Mixture weight of the light density, in [0, 1] (default 0.5) [scene: render.light_weight].
    #[arg(long, value_name = "W", allow_negative_numbers = true)]
    pub light_weight: Option<f32>,
    /// Russian roulette from this many bounces on, or `off` (paths end only at
    /// --max-depth) [scene: render.rr_depth; default off].
    #[arg(long, value_name = "N|off", value_parser = parse_rr_depth)]
    pub rr_depth: Option<RrDepth>,
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
    /// Next-event estimation (shadow rays to emitters) with multiple importance sampling.
    NeeMis,
}

impl From<StrategyArg> for Strategy {
    fn from(arg: StrategyArg) -> Strategy {
        match arg {
            StrategyArg::Mixture => Strategy::Mixture,
            StrategyArg::Cosine => Strategy::Cosine,
            StrategyArg::Light => Strategy::Light,
            StrategyArg::NeeMis => Strategy::NeeMis,
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

pub fn render(args: RenderArgs, process_start: Instant) -> Result<(), Failure> {
    if let Some(target) = args.target_error {
        if !(target.is_finite() && target > 0.0) {
            return Err(Failure::input(format!(
                "--target-error: must be a number > 0, got {target}"
            )));
        }
    }
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
            rr_depth: args.rr_depth.map(|RrDepth(depth)| depth),
        })
        .map_err(Failure::input)?;
    // Refuse unwritable outputs before spending the render time.
    output::check_output_path(&args.output, ImageFormat::Png).map_err(Failure::input)?;
    for exr in [&args.exr, &args.variance].into_iter().flatten() {
        output::check_output_path(exr, ImageFormat::Exr).map_err(Failure::input)?;
    }
    let open_ended = args.time.is_some() || args.target_error.is_some();
    let stop = StopRule {
        max_samples: match args.spp {
            None if open_ended => u32::MAX,
            _ => scene.render.spp,
        },
        time_budget: args.time,
        target_error: args.target_error,
    };

    let ctx = GpuContext::new(args.adapter.as_deref()).map_err(Failure::runtime)?;
    let options = RenderOptions {
        accumulator: args.accumulator.map(AccumulatorKind::from),
        variance: args.variance.is_some() || args.target_error.is_some(),
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
        "scene: {}  {width}x{height}  strategy {}  max depth {}  stop: {}",
        scene.source,
        renderer.config().strategy,
        scene.render.max_depth,
        describe_stop(&stop),
    );
    let mut display = ProgressDisplay::new(args.quiet);
    let mut first_sample = None;
    let summary = render::run(&mut renderer, stop, |p| {
        first_sample.get_or_insert_with(|| process_start.elapsed());
        display.update(p)
    });
    display.finish();
    let summary = summary.map_err(Failure::runtime)?;

    let accumulation = renderer.accumulation();
    let mean = accumulation.mean();
    output::write_png(&args.output, &mean, 0.0).map_err(Failure::runtime)?;
    if let Some(exr) = &args.exr {
        output::write_exr(exr, &mean, &[]).map_err(Failure::runtime)?;
    }
    if let Some(path) = &args.variance {
        let error = accumulation.standard_error().ok_or_else(|| {
            Failure::runtime("--variance: a standard error needs at least 2 samples per pixel")
        })?;
        output::write_exr(path, &error, &[]).map_err(Failure::runtime)?;
    }
    let stopped = match summary.reason {
        StopReason::Samples => "sample count reached".to_string(),
        StopReason::TimeBudget => "time budget spent".to_string(),
        StopReason::TargetError => "target error reached".to_string(),
    };
    println!(
        "rendered {width}x{height} at {} spp in {:.2} s: {:.2} M paths/s ({stopped})",
        summary.samples,
        summary.elapsed.as_secs_f64(),
        summary.paths_per_second / 1e6
    );
    if let Some(error) = summary.relative_error {
        println!("estimated relative error: {error:.5}");
    }
    if let Some(first) = first_sample {
        println!(
            "first samples done {:.0} ms after start",
            first.as_secs_f64() * 1e3
        );
    }
    if summary.discarded > 0 {
        eprintln!(
            "pathmix: warning: {} samples were NaN or infinite and counted as zero",
            summary.discarded
        );
    }
    for path in [
        Some(&args.output),
        args.exr.as_ref(),
        args.variance.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        println!("wrote {}", path.display());
    }
    Ok(())
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
    use super::parse_duration;
    use std::time::Duration;

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
