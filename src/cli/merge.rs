//! `pathmix merge`.

use super::Failure;
use clap::Args;
use pathmix::output::{self, ImageFormat};
use pathmix::paths::{self, PathUse};
use pathmix::session::shard::{self, PartialError, describe_ranges};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Partial results written by `pathmix render --partial` (any order). They
    /// must come from the same scene (hash), seed and image size, with disjoint
    /// sample ranges; gaps between ranges are listed, not refused.
    #[arg(required = true, value_name = "PART.exr")]
    pub parts: Vec<PathBuf>,
    /// Output image: 8-bit sRGB PNG of the merged mean, or with a `.exr` name the
    /// linear float RGB OpenEXR instead (as --exr).
    #[arg(short, long, default_value = "out.png")]
    pub output: PathBuf,
    /// Also write the merged mean radiance as linear float RGB OpenEXR.
    #[arg(long, value_name = "FILE")]
    pub exr: Option<PathBuf>,
    /// Also write the per-pixel standard error of the mean (needs parts rendered
    /// with variance).
    #[arg(long, value_name = "FILE")]
    pub variance: Option<PathBuf>,
    /// Merge parts whose run was interrupted before it rendered the samples it was
    /// asked for (they are refused otherwise), with a warning naming each.
    #[arg(long)]
    pub allow_incomplete: bool,
}

pub fn merge(args: MergeArgs) -> Result<(), Failure> {
    // No output may replace a part (or another output) before the parts are read.
    let mut uses: Vec<PathUse<&str>> = args
        .parts
        .iter()
        .map(|part| PathUse::input("PART", part))
        .collect();
    uses.push(PathUse::output("-o", &args.output));
    uses.extend(args.exr.as_deref().map(|p| PathUse::output("--exr", p)));
    uses.extend(
        args.variance
            .as_deref()
            .map(|p| PathUse::output("--variance", p)),
    );
    if let Some(collision) = paths::collision(&uses) {
        return Err(Failure::input(collision));
    }
    let (png, exr) = super::image_outputs(Some(args.output.clone()), args.exr.clone())?;
    if let Some(png) = &png {
        output::check_output_path(png, ImageFormat::Png).map_err(Failure::input)?;
    }
    for exr in [&exr, &args.variance].into_iter().flatten() {
        output::check_output_path(exr, ImageFormat::Exr).map_err(Failure::input)?;
    }
    let mut parts = Vec::new();
    for path in &args.parts {
        let part = shard::read_partial(path).map_err(|e| match e {
            PartialError::NotPartial { .. } => {
                Failure::input(format!("{e} (made by `pathmix render --partial`)"))
            }
            e => Failure::input(e),
        })?;
        parts.push((path.display().to_string(), part));
    }
    let merged = shard::merge_with(&parts, args.allow_incomplete)
        .map_err(|e| Failure::input(format!("cannot merge: {e}")))?;
    for warning in &merged.warnings {
        eprintln!("pathmix: warning: {warning}");
    }
    let acc = &merged.accumulation;
    if acc.samples == 0 {
        return Err(Failure::input("cannot merge: the parts hold no samples"));
    }
    let error = match &args.variance {
        None => None,
        Some(_) => Some(acc.standard_error().ok_or_else(|| {
            Failure::input(
                "--variance: the parts have no sums of squares (render them with --variance) \
                 or hold fewer than 2 samples",
            )
        })?),
    };
    let mean = acc.mean();
    if let Some(png) = &png {
        output::write_png(png, &mean, 0.0).map_err(Failure::runtime)?;
    }
    if let Some(exr) = &exr {
        output::write_exr(exr, &mean, &[]).map_err(Failure::runtime)?;
    }
    if let (Some(path), Some(error)) = (&args.variance, &error) {
        output::write_exr(path, error, &[]).map_err(Failure::runtime)?;
    }
    println!(
        "merged {} parts: {}x{}, samples {} ({} spp)",
        parts.len(),
        acc.width,
        acc.height,
        describe_ranges(&merged.ranges),
        acc.samples
    );
    if merged.discarded > 0 {
        eprintln!(
            "pathmix: warning: {} samples were NaN or infinite and counted as zero",
            merged.discarded
        );
    }
    for path in [png.as_ref(), exr.as_ref(), args.variance.as_ref()]
        .into_iter()
        .flatten()
    {
        println!("wrote {}", path.display());
    }
    Ok(())
}
