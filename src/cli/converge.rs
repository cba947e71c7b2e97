//! `pathmix converge`: the speed/accuracy trade of each strategy, measured.

use super::Failure;
use super::progress::ProgressDisplay;
use clap::Args;
use pathmix::scene::SceneOverrides;
use pathmix::session::converge::{
    self, ConvergeError, Event, ReferenceChoice, ReferenceSource, Study, Variant,
};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ConvergeArgs {
    /// Scene file (TOML, see docs/scene-format.md, or Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Set the Mitsuba scene's `$NAME` parameter, as `mitsuba -D` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<pathmix::scene::mitsuba::Define>,
    /// Output folder (created if missing): converge.md, converge.csv, converge.png and
    /// the cached reference.
    #[arg(long, value_name = "DIR", default_value = "converge-out")]
    pub out: PathBuf,
    /// Image width. Default: the longest side is 128 pixels, with the scene's aspect
    /// ratio (or the --reference image's size).
    #[arg(long, value_name = "W")]
    pub width: Option<u32>,
    /// Image height. Default: as for --width.
    #[arg(long, value_name = "H")]
    pub height: Option<u32>,
    /// Most scattering events on a path [scene: render.max_depth].
    #[arg(long, value_name = "D")]
    pub max_depth: Option<u32>,
    /// Russian roulette from this many bounces on, or `off`, for every variant
    /// [scene: render.rr_depth; default: each variant's strategy's own].
    #[arg(long, value_name = "N|off", value_parser = super::render::parse_rr_depth)]
    pub rr_depth: Option<super::render::RrDepth>,
    /// Where the random numbers come from, for every variant and the rendered
    /// reference [scene: render.sampler].
    #[arg(long, value_enum)]
    pub sampler: Option<super::render::SamplerArg>,
    /// Seed of the measured runs [scene: render.seed]. The rendered reference uses its
    /// own seed.
    #[arg(long, value_name = "S")]
    pub seed: Option<u32>,
    /// Last rung of the sample ladder 1, 4, 16, ... (added if not a power of 4).
    #[arg(long, value_name = "N", default_value_t = 256,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub max_spp: u32,
    /// Reference image (linear EXR of the measured size) instead of a rendered one.
    #[arg(long, value_name = "EXR")]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference (mixture strategy), cached in the
    /// output folder as reference-<hash>.exr and reused while scene file, size, depth
    /// and this count are the same.
    #[arg(long, value_name = "N", default_value_t = 4096,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub reference_spp: u32,
    /// Comma-separated strategies to measure: cosine, light, nee-mis, mixture (weight
    /// 0.5), mixture:W; each with `+adaptive` for adaptive sampling (rungs are then
    /// sample budgets: the uniform run's total) and `+importance` for offsets drawn
    /// from the pixel filter instead of splatting, nee-mis also with `+uniform-lights`
    /// for lights picked uniformly, e.g. mixture,mixture+adaptive. Default:
    /// cosine,light,nee-mis,mixture:0.25,mixture:0.5,mixture:0.75.
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = Variant::parse)]
    pub variants: Option<Vec<Variant>>,
    /// Use the first adapter whose name contains NAME (case-insensitive) [env: PATHMIX_ADAPTER].
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
}

fn failure(e: ConvergeError) -> Failure {
    match e {
        ConvergeError::Input(_) => Failure::input(e),
        ConvergeError::ReferenceSize { reference, .. } => Failure::input(format!(
            "{e} (--width {} --height {})",
            reference.0, reference.1
        )),
        ConvergeError::ReferenceSeed => Failure::input(format!("{e} (--seed S)")),
        ConvergeError::Unsupported(e) => Failure::input(super::render::with_flag(&e)),
        ConvergeError::Render(e) => Failure::runtime(super::render::with_flag(&e)),
        ConvergeError::Output(_) => Failure::runtime(e),
    }
}

pub fn converge(args: ConvergeArgs) -> Result<(), Failure> {
    let scene_bytes = converge::scene_bytes(&args.scene, &args.define).map_err(failure)?;
    let mut scene = super::load_scene(&args.scene, &args.define)?;
    let (mut width, mut height) = (args.width, args.height);
    let mut size_note = "";
    if let (Some(path), None, None) = (&args.reference, width, height) {
        let image = pathmix::output::read_exr(path).map_err(Failure::input)?;
        (width, height) = (Some(image.width), Some(image.height));
        size_note = " (the reference's size)";
    } else if width.is_none() && height.is_none() {
        size_note = " (converge's default; --width/--height to change)";
    }
    let (width, height) = converge::measured_size(&scene, width, height);
    scene
        .apply_overrides(&SceneOverrides {
            width: Some(width),
            height: Some(height),
            max_depth: args.max_depth,
            seed: args.seed,
            rr_depth: args.rr_depth.map(|rr| rr.0),
            sampler: args.sampler.map(Into::into),
            ..Default::default()
        })
        .map_err(|e| super::override_failure(&e))?;
    // Checked before the device starts.
    let reference = match &args.reference {
        Some(path) => {
            ReferenceChoice::Given(converge::given_reference(path, width, height).map_err(failure)?)
        }
        None => ReferenceChoice::Render {
            spp: args.reference_spp,
        },
    };
    let variants = args.variants.unwrap_or_else(Variant::defaults);
    if args.reference.is_none() && (args.reference_spp as u64) < 16 * args.max_spp as u64 {
        eprintln!(
            "pathmix: warning: a reference at {} spp has more than 1/16 of the variance of the \
             last rung ({} spp): its own noise will flatten the curves",
            args.reference_spp, args.max_spp
        );
    }

    let ctx = super::open_gpu(args.adapter.as_deref())?;
    eprintln!("adapter: {}", ctx.describe());
    eprintln!(
        "scene: {}  {width}x{height}{size_note}  max depth {}  seed {}  ladder {:?}",
        scene.source,
        scene.render.max_depth,
        scene.render.seed,
        converge::ladder(args.max_spp)
    );
    let study = Study {
        scene: &scene,
        scene_bytes: &scene_bytes,
        out_dir: &args.out,
        variants: &variants,
        max_spp: args.max_spp,
        reference,
    };
    let mut display = ProgressDisplay::new(false);
    let report = converge::run_study(&ctx, &study, |event| match event {
        Event::ReferenceProgress(progress) => display.update(progress),
        Event::Reference(reference) => {
            display.finish();
            let verb = match reference.source {
                ReferenceSource::Given => "using given reference",
                ReferenceSource::Rendered => "rendered reference",
                ReferenceSource::Cached => "reused cached reference",
            };
            println!("{verb} {}", reference.path.display());
        }
        Event::VariantStarted(variant) => eprintln!("measuring {variant}"),
        Event::Rung(row) => eprintln!(
            "  {:>6} spp  {:>8.3} s  {:>6.2} M paths/s  RMSE {:.5}  relMSE {:.3e}  (noise estimate {})",
            row.spp,
            row.seconds,
            row.paths_per_second / 1e6,
            row.rmse,
            row.relative_mse,
            row.estimated_error
                .map_or_else(|| "–".to_string(), |e| format!("{e:.5}"))
        ),
        Event::Warning(warning) => eprintln!("pathmix: warning: {warning}"),
    })
    .map_err(failure)?;
    let files = converge::write_report(&args.out, &report).map_err(Failure::runtime)?;

    println!();
    print!("{}", converge::summary_markdown(&report.summaries));
    println!();
    for path in [&files.markdown, &files.csv, &files.plot] {
        println!("wrote {}", path.display());
    }
    Ok(())
}
