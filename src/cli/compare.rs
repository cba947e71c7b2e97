//! `pathmix compare`.

use super::Failure;
use clap::Args;
use pathmix::output;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image to check: linear OpenEXR (R, G, B), e.g. a merge's `--exr`.
    #[arg(value_name = "A.exr")]
    pub image: PathBuf,
    /// The image to check it against, e.g. one uninterrupted run's `--exr`.
    #[arg(value_name = "B.exr")]
    pub reference: PathBuf,
    /// Largest relative difference allowed for every channel of every pixel:
    /// |a − b| ≤ T·max(|a|, |b|). 1e-6 is what merged shards promise against one run.
    #[arg(long, value_name = "T", default_value_t = 1e-6)]
    pub tolerance: f64,
}

/// Exit code 0 when every value is within the tolerance, 1 when any is not (or the
/// sizes differ), 2 when a file cannot be read or the tolerance is not a number ≥ 0.
pub fn compare(args: CompareArgs) -> Result<(), Failure> {
    if args.tolerance.is_nan() || args.tolerance < 0.0 {
        return Err(Failure::input(format!(
            "--tolerance {}: must be a number ≥ 0",
            args.tolerance
        )));
    }
    let a = output::read_exr(&args.image).map_err(Failure::input)?;
    let b = output::read_exr(&args.reference).map_err(Failure::input)?;
    let names = format!("{} and {}", args.image.display(), args.reference.display());
    let Some(comparison) = output::compare(&a, &b, args.tolerance) else {
        return Err(Failure::runtime(format!(
            "{names} differ in size: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        )));
    };
    let largest = match &comparison.largest {
        None => "identical".to_string(),
        Some(d) => format!(
            "largest relative difference {:.3e} at pixel ({}, {}) {}: {} and {}",
            d.relative,
            d.x,
            d.y,
            ["R", "G", "B"][d.channel],
            d.a,
            d.b
        ),
    };
    if comparison.beyond > 0 {
        return Err(Failure::runtime(format!(
            "{names} differ: {} of {} values beyond relative {:e}; {largest}",
            comparison.beyond, comparison.values, args.tolerance
        )));
    }
    println!(
        "{names} agree within relative {:e} ({} values): {largest}",
        args.tolerance, comparison.values
    );
    Ok(())
}
