//! Command definitions and dispatch.

mod bench;
mod compare;
mod converge;
mod convert;
mod info;
mod merge;
mod progress;
mod render;
mod signals;

use clap::{Parser, Subcommand};
use pathmix::gpu::{GpuContext, GpuError};
use pathmix::output::ImageFormat;
use pathmix::scene::mitsuba::Define;
use pathmix::scene::{OverrideError, Scene};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "pathmix",
    version,
    about = "Headless GPU path tracer with mixture-PDF importance sampling",
    long_about = "Headless GPU path tracer (wgpu compute) with mixture-PDF importance sampling: \
                  cosine-weighted hemisphere plus sampling toward lights, as in Shirley's \
                  'Ray Tracing: The Rest of Your Life'. Runs on any Vulkan, Metal or DX12 \
                  device, including Mesa's software Vulkan driver (lavapipe)."
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene file to an image.
    Render(Box<render::RenderArgs>),
    /// Print what a scene uses, what its kernel contains, buffer sizes and adapter limits.
    Info(info::InfoArgs),
    /// Merge partial results of shards (`render --partial`) into one image.
    Merge(merge::MergeArgs),
    /// Measure rendering speed on the shipped scenes (paths/s, segments/s, start-up time).
    Bench(bench::BenchArgs),
    /// Measure each strategy's error against time and samples (table, CSV, plot).
    Converge(converge::ConvergeArgs),
    /// Check that two linear EXR images agree within a relative tolerance (exit 1 if not).
    Compare(compare::CompareArgs),
    /// Write a Mitsuba 3 XML scene as the pathmix TOML scene it renders as.
    Convert(convert::ConvertArgs),
}

/// The PNG and EXR outputs that `-o FILE` and `--exr FILE` ask for: `-o NAME.exr`
/// writes the linear EXR instead of the PNG, as Mitsuba's and pbrt's outputs
/// follow their extension. Refused where `--exr` names a second EXR.
fn image_outputs(
    output: Option<PathBuf>,
    exr: Option<PathBuf>,
) -> Result<(Option<PathBuf>, Option<PathBuf>), Failure> {
    let names_exr =
        |path: &PathBuf| ImageFormat::from_path(path).is_ok_and(|f| f == ImageFormat::Exr);
    match (output, exr) {
        (Some(output), Some(exr)) if names_exr(&output) => Err(Failure::input(format!(
            "-o {} and --exr {} both ask for the linear EXR image: give one of them \
             (-o FILE.png for the 8-bit PNG)",
            output.display(),
            exr.display()
        ))),
        (Some(output), None) if names_exr(&output) => Ok((None, Some(output))),
        (output, exr) => Ok((output, exr)),
    }
}

/// A failed command: what to tell the user, and the exit code.
pub struct Failure {
    pub message: String,
    pub code: u8,
}

impl Failure {
    /// Bad input (scene file, flags, output path): exit code 2.
    pub fn input(message: impl ToString) -> Failure {
        Failure {
            message: message.to_string(),
            code: 2,
        }
    }

    /// The run itself failed (no adapter, device error, write error): exit code 1.
    pub fn runtime(message: impl ToString) -> Failure {
        Failure {
            message: message.to_string(),
            code: 1,
        }
    }
}

pub fn run(cli: Cli, process_start: Instant) -> Result<(), Failure> {
    match cli.command {
        Command::Render(args) => render::render(*args, process_start),
        Command::Info(args) => info::info(args),
        Command::Merge(args) => merge::merge(args),
        Command::Bench(args) => bench::bench(args),
        Command::Converge(args) => converge::converge(args),
        Command::Compare(args) => compare::compare(args),
        Command::Convert(args) => convert::convert(args),
    }
}

/// The device: the adapter `--adapter` names, or the best one.
pub fn open_gpu(adapter: Option<&str>) -> Result<GpuContext, Failure> {
    GpuContext::new(adapter).map_err(|e| match e {
        GpuError::NoMatchingAdapter { wanted, available } => Failure::runtime(format!(
            "no adapter's name contains `{wanted}` (from --adapter or PATHMIX_ADAPTER); \
             available: {}",
            available.join("; ")
        )),
        e => Failure::runtime(e),
    })
}

/// An override refused, in this command line's words: the flag that gave it.
pub fn override_failure(e: &OverrideError) -> Failure {
    let flag = match e.field {
        "render.spp" => "--spp",
        "camera.width" => "--width",
        "camera.height" => "--height",
        "render.max_depth" => "--max-depth",
        "render.seed" => "--seed",
        "render.rr_depth" => "--rr-depth",
        "render.light_weight" => "--light-weight",
        field => field,
    };
    Failure::input(format!("command line: {flag}: {}", e.message))
}

/// Reads a scene file (TOML or Mitsuba XML with its `-D` parameters), warning once
/// about what was approximated.
pub fn load_scene(path: &Path, defines: &[Define]) -> Result<Scene, Failure> {
    let loaded = Scene::load_with(path, defines).map_err(Failure::input)?;
    print_approximations(path, &loaded.warnings);
    Ok(loaded.scene)
}

fn print_approximations(path: &Path, warnings: &[String]) {
    if !warnings.is_empty() {
        eprintln!(
            "pathmix: warning: {}: approximated: {}",
            path.display(),
            warnings.join("; ")
        );
    }
}
