//! Convergence study: the speed/accuracy trade of each sampling strategy, measured.
//!
//! Each variant (a strategy, and for the mixture its light weight) is rendered
//! progressively once, and the accumulation is read back at a ladder of sample counts
//! (1, 4, 16, ...). Each rung records the render time so far (readback excluded), the
//! RMSE against a reference image, and the efficiency `1 / (MSE × seconds)`. A fitted
//! log-log slope of RMSE against samples tells whether the error keeps falling like the
//! ideal `N^-1/2`.
//!
//! The reference is a file the user gives, or a high-sample mixture render with its own
//! seed, cached in the output folder under a key that hashes what determines it.
//!
//! Like the rest of the engine this module prints nothing: progress goes through
//! [`Event`]s, and the report is returned and written as files.

mod plot;

use crate::gpu::GpuContext;
use crate::output::{self, Image, OutputError};
use crate::render::{self, Progress, RenderError, RenderOptions, Renderer, StopRule};
use crate::scene::mitsuba::{self, Converted, Define};
use crate::scene::{LightSelection, Reconstruction, Scene, SceneOverrides, Strategy};
use crate::session::checkpoint::Fnv64;
use crate::stats;
use std::fmt::{self, Write as _};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub use plot::plot_png;

/// The longest side of the measured image where the caller gives no size.
pub const DEFAULT_SIDE: u32 = 128;

/// `(width, height)` of the measured runs: what was given, the other side from
/// the scene's aspect ratio, or a longest side of `DEFAULT_SIDE`.
pub fn measured_size(scene: &Scene, width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let (w, h) = (scene.camera.width as f64, scene.camera.height as f64);
    let side = |v: f64| (v.round() as u32).max(1);
    match (width, height) {
        (Some(width), Some(height)) => (width, height),
        (Some(width), None) => (width, side(width as f64 * h / w)),
        (None, Some(height)) => (side(height as f64 * w / h), height),
        (None, None) => {
            let scale = DEFAULT_SIDE as f64 / w.max(h);
            (side(w * scale), side(h * scale))
        }
    }
}

/// The bytes a scene's rendered reference is keyed by (`Study::scene_bytes`):
/// the file's, or for a Mitsuba scene those of the TOML document it means, so
/// that its includes and `-D` parameters change the key as its own text does.
pub fn scene_bytes(path: &Path, defines: &[Define]) -> Result<Vec<u8>, ConvergeError> {
    let bytes = crate::paths::read_input(path)
        .map_err(|e| ConvergeError::Input(format!("{}: {e}", path.display())))?;
    if !mitsuba::is_mitsuba(path, &String::from_utf8_lossy(&bytes)) {
        return Ok(bytes);
    }
    let converted =
        Converted::read(path, defines).map_err(|e| ConvergeError::Input(e.to_string()))?;
    Ok(toml::to_string(&converted.document)
        .expect("a TOML table serializes")
        .into_bytes())
}

/// A strategy to measure: `cosine`, `light`, `nee-mis`, or `mixture` with its light
/// weight; uniformly or with adaptive sampling; splatting its samples (where the
/// scene's filter is wider than a pixel) or drawing offsets from the filter;
/// `nee-mis` picking lights spatially (where the scene's lights allow) or uniformly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    pub strategy: Strategy,
    /// The mixture's weight of the light density; `None` for the other strategies.
    pub light_weight: Option<f32>,
    /// Adaptive sampling (`crate::render::adaptive`); its rungs are sample budgets.
    pub adaptive: bool,
    /// Offsets drawn from the pixel filter (`Reconstruction::Importance`)
    /// instead of the scene's reconstruction.
    pub importance: bool,
    /// Lights picked uniformly (`LightSelection::Uniform`) instead of the
    /// scene's selection; `nee-mis` only.
    pub uniform_lights: bool,
}

/// The modifiers a variant's name may end with, in any order, each once.
const MODIFIERS: [&str; 3] = ["+importance", "+adaptive", "+uniform-lights"];

impl Variant {
    /// The light weight `mixture` means when none is given.
    pub const DEFAULT_LIGHT_WEIGHT: f32 = 0.5;

    pub const BSDF: Variant = Variant::of(Strategy::Bsdf);
    pub const LIGHT: Variant = Variant::of(Strategy::Light);
    pub const NEE_MIS: Variant = Variant::of(Strategy::NeeMis);

    const fn of(strategy: Strategy) -> Variant {
        Variant {
            strategy,
            light_weight: None,
            adaptive: false,
            importance: false,
            uniform_lights: false,
        }
    }

    pub fn mixture(light_weight: f32) -> Variant {
        Variant {
            light_weight: Some(light_weight),
            ..Variant::of(Strategy::Mixture)
        }
    }

    /// cosine, light, next-event estimation, and the mixture at light weights 0.25, 0.5, 0.75.
    pub fn defaults() -> Vec<Variant> {
        vec![
            Variant::BSDF,
            Variant::LIGHT,
            Variant::NEE_MIS,
            Variant::mixture(0.25),
            Variant::mixture(0.5),
            Variant::mixture(0.75),
        ]
    }

    /// `cosine`, `light`, `nee-mis`, `mixture` (weight 0.5) or `mixture:W` with W in
    /// [0, 1], each with `+adaptive` for adaptive sampling and `+importance` for
    /// offsets drawn from the filter, `nee-mis` also with `+uniform-lights`, in any
    /// order.
    pub fn parse(text: &str) -> Result<Variant, String> {
        let text = text.trim();
        let mut base = text;
        let mut found = [false; MODIFIERS.len()];
        while let Some((i, rest)) = (MODIFIERS.iter().enumerate())
            .find_map(|(i, modifier)| Some((i, base.strip_suffix(modifier)?)))
        {
            if found[i] {
                return Err(format!("variant `{text}`: `{}` once", MODIFIERS[i]));
            }
            found[i] = true;
            base = rest;
        }
        let [importance, adaptive, uniform_lights] = found;
        let variant = Variant {
            adaptive,
            importance,
            uniform_lights,
            ..Variant::parse_strategy(base)?
        };
        if uniform_lights && variant.strategy != Strategy::NeeMis {
            return Err(format!(
                "variant `{text}`: only nee-mis picks lights spatially, so `+uniform-lights` \
                 goes with nee-mis"
            ));
        }
        Ok(variant)
    }

    /// A variant's strategy and light weight, without modifiers.
    fn parse_strategy(text: &str) -> Result<Variant, String> {
        let (name, weight) = match text.split_once(':') {
            Some((name, weight)) => (name, Some(weight)),
            None => (text, None),
        };
        let strategy = Strategy::from_name(name).ok_or_else(|| {
            format!(
                "unknown variant `{text}`: expected cosine, light, nee-mis, mixture or mixture:W"
            )
        })?;
        match (strategy, weight) {
            (Strategy::Mixture, None) => Ok(Variant::mixture(Variant::DEFAULT_LIGHT_WEIGHT)),
            (Strategy::Mixture, Some(weight)) => match weight.parse::<f32>() {
                Ok(w) if (0.0..=1.0).contains(&w) => Ok(Variant::mixture(w)),
                _ => Err(format!(
                    "variant `{text}`: the light weight must be a number in [0, 1]"
                )),
            },
            (_, None) => Ok(Variant::of(strategy)),
            (_, Some(_)) => Err(format!(
                "variant `{text}`: only the mixture takes a light weight"
            )),
        }
    }

    /// As [`parse`](Self::parse) reads it: `cosine`, `light`, `mixture:0.5`.
    pub fn name(&self) -> String {
        let mut name = match self.light_weight {
            Some(w) => format!("{}:{w}", self.strategy),
            None => self.strategy.to_string(),
        };
        let flags = [self.importance, self.adaptive, self.uniform_lights];
        for (modifier, set) in MODIFIERS.iter().zip(flags) {
            if set {
                name.push_str(modifier);
            }
        }
        name
    }
}

impl fmt::Display for Variant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// Sample counts at which a run is read back: 1, 4, 16, ... up to `max_spp`, and
/// `max_spp` itself when it is not a power of 4. Empty for 0.
pub fn ladder(max_spp: u32) -> Vec<u32> {
    let mut rungs: Vec<u32> = std::iter::successors(Some(1u32), |&s| s.checked_mul(4))
        .take_while(|&s| s <= max_spp)
        .collect();
    if max_spp > 0 && rungs.last() != Some(&max_spp) {
        rungs.push(max_spp);
    }
    rungs
}

/// One rung of one variant's run.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub variant: String,
    pub spp: u32,
    /// Render time to this rung, from the first sample (warm-up and readbacks excluded).
    pub seconds: f64,
    pub paths_per_second: f64,
    /// Against the reference, over all pixels and channels.
    pub rmse: f64,
    /// RMSE divided by the reference's mean value; `None` for a black reference.
    pub relative_rmse: Option<f64>,
    /// [`stats::relative_mse`]: each pixel's error relative to its brightness.
    pub relative_mse: f64,
    /// The RMSE that noise alone explains: the RMS over pixels and channels of the run's
    /// standard error of the mean ([`Accumulation::standard_error`]), combined (root sum of
    /// squares) with the same for the reference where known. `None` below 2 spp (below
    /// one sample per replicate, 4 spp, under Sobol). Well below the RMSE, the error is
    /// not noise but bias.
    ///
    /// [`Accumulation::standard_error`]: crate::stats::Accumulation::standard_error
    pub estimated_error: Option<f64>,
    /// `1 / (MSE × seconds)`: higher is better; unchanged by more samples at the ideal rate.
    pub efficiency: f64,
}

/// `1 / (rmse² × seconds)`.
pub fn efficiency(rmse: f64, seconds: f64) -> f64 {
    1.0 / (rmse * rmse * seconds)
}

/// Upper-half slopes shallower than this (the ideal is −0.5) mean the error stops falling.
pub const UPPER_SLOPE_LIMIT: f64 = -0.25;
/// A last rung's RMSE at or above this fraction of the RMSE two rungs before (16 times
/// fewer samples on the default ladder: ideally a quarter) means the error stops falling.
pub const LAST_RATIO_LIMIT: f64 = 0.75;
/// A last rung's RMSE above this multiple of the error that noise alone explains
/// ([`Row::estimated_error`]) means a part of the error does not fall with more samples.
pub const EXCESS_LIMIT: f64 = 1.5;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The error falls with more samples.
    Converging,
    /// The error stops falling, or will: the variant converges to something else than
    /// the reference (a biased strategy), or the reference is too noisy.
    StopsFalling,
    /// Fewer than two rungs.
    TooFewRungs,
}

impl Verdict {
    pub fn text(self) -> &'static str {
        match self {
            Verdict::Converging => "converging",
            Verdict::StopsFalling => "error stops falling: biased?",
            Verdict::TooFewRungs => "too few rungs to judge",
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.text())
    }
}

/// One variant's convergence, from its rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    pub variant: String,
    /// Least-squares slope of ln RMSE against ln spp over all rungs (ideal −0.5).
    pub slope: Option<f64>,
    /// The same over the upper half of the ladder (the last `⌈(n + 1) / 2⌉` rungs, at
    /// least 2).
    pub upper_slope: Option<f64>,
    /// RMSE at the last rung over the RMSE two rungs before.
    pub last_ratio: Option<f64>,
    /// RMSE at the last rung over the error noise explains there
    /// ([`Row::estimated_error`]); about 1 without bias.
    pub excess: Option<f64>,
    /// The last rung's row.
    pub last: Option<Row>,
    pub verdict: Verdict,
}

/// Slopes and verdict of one variant's rows, in ladder order.
///
/// The verdict is [`Verdict::StopsFalling`] when
/// - the upper-half slope is shallower than [`UPPER_SLOPE_LIMIT`], or
/// - the last rung's RMSE is not below [`LAST_RATIO_LIMIT`] times the RMSE two rungs
///   before, or
/// - the last rung's RMSE is over [`EXCESS_LIMIT`] times its noise estimate: then the
///   squared error holds a part that more samples do not shrink (bias), which the first
///   two tests only see once it dominates.
pub fn summarize_variant(rows: &[Row]) -> Summary {
    let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.spp as f64, r.rmse)).collect();
    let n = points.len();
    let slope = stats::log_log_slope(&points);
    let upper_slope = stats::log_log_slope(&points[n - n.div_ceil(2).max(2).min(n)..]);
    let last_ratio = (n >= 3).then(|| points[n - 1].1 / points[n - 3].1);
    let last = rows.last();
    let excess = last.and_then(|r| Some(r.rmse / r.estimated_error.filter(|e| *e > 0.0)?));
    let verdict = if n < 2 {
        Verdict::TooFewRungs
    } else if upper_slope.is_none_or(|s| s > UPPER_SLOPE_LIMIT)
        || last_ratio.is_some_and(|r| r.is_nan() || r >= LAST_RATIO_LIMIT)
        || excess.is_some_and(|e| e > EXCESS_LIMIT)
    {
        Verdict::StopsFalling
    } else {
        Verdict::Converging
    };
    Summary {
        variant: last.map_or_else(String::new, |r| r.variant.clone()),
        slope,
        upper_slope,
        last_ratio,
        excess,
        last: last.cloned(),
        verdict,
    }
}

/// One summary per variant, in the order the variants first appear in `rows`.
pub fn summarize(rows: &[Row]) -> Vec<Summary> {
    let mut names: Vec<&str> = Vec::new();
    for row in rows {
        if !names.contains(&row.variant.as_str()) {
            names.push(&row.variant);
        }
    }
    names
        .into_iter()
        .map(|name| {
            let own: Vec<Row> = rows.iter().filter(|r| r.variant == name).cloned().collect();
            summarize_variant(&own)
        })
        .collect()
}

#[derive(Debug, thiserror::Error)]
pub enum ConvergeError {
    /// The request cannot be met (an unreadable reference, settings the scene refuses).
    #[error("{0}")]
    Input(String),
    /// `path` (when the user gave it) holds a reference of another size.
    #[error(
        "{}the reference is {}x{}, the measured image {}x{}; measure at the reference's \
         size or give a reference of the measured size",
        .path.as_ref().map_or_else(String::new, |p| format!("{}: ", p.display())),
        .reference.0, .reference.1, .measured.0, .measured.1
    )]
    ReferenceSize {
        path: Option<PathBuf>,
        reference: (u32, u32),
        measured: (u32, u32),
    },
    /// Measured runs must not share the reference's noise.
    #[error("seed {REFERENCE_SEED} is the reference's; measure with another seed")]
    ReferenceSeed,
    /// A variant the scene or adapter cannot render (`Renderer::new` refused it).
    #[error(transparent)]
    Unsupported(RenderError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// `Renderer::new`, with the requests the scene or adapter cannot meet apart from
/// device failures.
fn renderer<'a>(
    ctx: &'a GpuContext,
    scene: &Scene,
    variance: bool,
    adaptive: bool,
) -> Result<Renderer<'a>, ConvergeError> {
    let options = RenderOptions {
        variance,
        adaptive,
        ..Default::default()
    };
    Renderer::new(ctx, scene, &options).map_err(|e| match e {
        RenderError::Gpu(_) => ConvergeError::Render(e),
        e => ConvergeError::Unsupported(e),
    })
}

// --- The reference -----------------------------------------------------------------

/// The seed of rendered references. Measured runs must use another one, so that their
/// noise is independent of the reference's.
pub const REFERENCE_SEED: u32 = 0x9E37_79B9;

/// The cache key of a rendered reference: FNV-1a 64 ([`Fnv64`], the scene identity's
/// hash) of the bytes `"pathmix reference v1\0"`, the scene file's length (u64
/// little-endian) and bytes, then width, height, max depth and samples per pixel (u32
/// little-endian each). The tag changes if the way references are rendered ever does.
pub fn reference_key(scene_bytes: &[u8], width: u32, height: u32, max_depth: u32, spp: u32) -> u64 {
    let mut hash = Fnv64::default();
    hash.bytes(b"pathmix reference v1\0")
        .u64(scene_bytes.len() as u64)
        .bytes(scene_bytes);
    for value in [width, height, max_depth, spp] {
        hash.u32(value);
    }
    hash.finish()
}

/// The EXR text attribute of a rendered reference that holds its estimated error.
const ERROR_ATTRIBUTE: &str = "pathmixEstimatedError";

/// `DIR/reference-<key as 16 hex digits>.exr`.
pub fn reference_cache_path(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("reference-{key:016x}.exr"))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceSource {
    /// The user's file.
    Given,
    /// Rendered now, and cached.
    Rendered,
    /// Read from the cache.
    Cached,
}

#[derive(Clone, Debug)]
pub struct Reference {
    pub image: Image,
    pub path: PathBuf,
    pub source: ReferenceSource,
    /// Samples per pixel of a rendered or cached reference; `None` for a given file.
    pub spp: Option<u32>,
    /// RMS over pixels and channels of the reference's own standard error, where known
    /// (rendered references store it in the file).
    pub estimated_error: Option<f64>,
}

impl Reference {
    /// For reports, e.g. "reference-…exr (mixture, 4096 spp, cached)".
    pub fn describe(&self) -> String {
        let name = self.path.file_name().map_or_else(
            || self.path.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        match (self.source, self.spp) {
            (ReferenceSource::Given, _) | (_, None) => format!("{name} (given)"),
            (ReferenceSource::Rendered, Some(spp)) => {
                format!("{name} (mixture, {spp} spp, rendered)")
            }
            (ReferenceSource::Cached, Some(spp)) => {
                format!("{name} (mixture, {spp} spp, cached)")
            }
        }
    }
}

/// Reads the user's reference and checks it has the image's size.
pub fn given_reference(path: &Path, width: u32, height: u32) -> Result<Reference, ConvergeError> {
    let image = output::read_exr(path).map_err(|e| ConvergeError::Input(e.to_string()))?;
    if (image.width, image.height) != (width, height) {
        return Err(ConvergeError::ReferenceSize {
            path: Some(path.to_path_buf()),
            reference: (image.width, image.height),
            measured: (width, height),
        });
    }
    Ok(Reference {
        image,
        path: path.to_path_buf(),
        source: ReferenceSource::Given,
        spp: None,
        estimated_error: None,
    })
}

/// The reference for `scene` (its size and depth) at `spp`: read from `dir`'s cache when a
/// readable file of the right size is there, else rendered with the mixture strategy at
/// [`REFERENCE_SEED`] and written to the cache. `scene_bytes` is the scene file as read,
/// for the cache key. `on_progress` sees the render's progress.
pub fn cached_or_rendered_reference(
    ctx: &GpuContext,
    scene: &Scene,
    scene_bytes: &[u8],
    dir: &Path,
    spp: u32,
    on_progress: impl FnMut(&Progress),
) -> Result<Reference, ConvergeError> {
    let (width, height) = (scene.camera.width, scene.camera.height);
    let key = reference_key(scene_bytes, width, height, scene.render.max_depth, spp);
    let path = reference_cache_path(dir, key);
    // An unreadable or wrong-sized file is rendered over.
    if let Ok((image, attributes)) = output::read_exr_with_attributes(&path) {
        if (image.width, image.height) == (width, height) {
            let estimated_error = attributes
                .iter()
                .find(|(name, _)| name == ERROR_ATTRIBUTE)
                .and_then(|(_, value)| value.parse().ok());
            return Ok(Reference {
                image,
                path,
                source: ReferenceSource::Cached,
                spp: Some(spp),
                estimated_error,
            });
        }
    }
    let mut scene = scene.clone();
    scene
        .apply_overrides(&SceneOverrides {
            strategy: Some(Strategy::Mixture),
            seed: Some(REFERENCE_SEED),
            spp: Some(spp),
            ..Default::default()
        })
        .map_err(|e| ConvergeError::Input(e.to_string()))?;
    let mut renderer = renderer(ctx, &scene, true, false)?;
    render::run(&mut renderer, StopRule::samples(spp), on_progress)?;
    let accumulation = renderer.accumulation();
    let image = accumulation.mean();
    let estimated_error = accumulation.standard_error().map(|se| rms(&se));
    let mut attributes = vec![(
        "comments",
        format!(
            "pathmix converge reference: {} {width}x{height}, max depth {}, {spp} spp, \
             strategy {}, light weight {}, seed {REFERENCE_SEED}, key {key:016x}",
            scene.source,
            scene.render.max_depth,
            renderer.config().strategy,
            scene.render.light_weight
        ),
    )];
    if let Some(error) = estimated_error {
        attributes.push((ERROR_ATTRIBUTE, format!("{error:e}")));
    }
    output::write_exr(&path, &image, &attributes)?;
    Ok(Reference {
        image,
        path,
        source: ReferenceSource::Rendered,
        spp: Some(spp),
        estimated_error,
    })
}

// --- Measured runs -----------------------------------------------------------------

/// One variant's run.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub rows: Vec<Row>,
    /// What the renderer warned about (the biased `light` strategy, fallbacks).
    pub warnings: Vec<String>,
    /// Samples that were NaN or infinite, counted as zero.
    pub discarded: u64,
}

/// Renders `variant` of `scene` once, progressively, reading it back at each rung of
/// `ladder` (ascending) and comparing it with `reference`. Squared samples are
/// accumulated too, for the error estimate. The pipeline is warmed up first
/// ([`Renderer::warm_up`]), so compile time is not counted; neither are the readbacks. `on_rung`
/// sees each row as it is measured.
pub fn measure_variant(
    ctx: &GpuContext,
    scene: &Scene,
    variant: Variant,
    ladder: &[u32],
    reference: &Reference,
    mut on_rung: impl FnMut(&Row),
) -> Result<Measurement, ConvergeError> {
    let (reference_error, reference) = (reference.estimated_error, &reference.image);
    let mut scene = scene.clone();
    scene
        .apply_overrides(&SceneOverrides {
            strategy: Some(variant.strategy),
            light_weight: variant.light_weight,
            reconstruction: variant.importance.then_some(Reconstruction::Importance),
            light_selection: variant.uniform_lights.then_some(LightSelection::Uniform),
            ..Default::default()
        })
        .map_err(|e| ConvergeError::Input(e.to_string()))?;
    if scene.render.seed == REFERENCE_SEED {
        return Err(ConvergeError::ReferenceSeed);
    }
    let mut renderer = renderer(ctx, &scene, true, variant.adaptive)?;
    let (width, height) = renderer.size();
    if (reference.width, reference.height) != (width, height) {
        return Err(ConvergeError::ReferenceSize {
            path: None,
            reference: (reference.width, reference.height),
            measured: (width, height),
        });
    }
    // One-sample submissions, as the first rung's.
    renderer.warm_up(1);

    let name = variant.name();
    let pixels = width as f64 * height as f64;
    let mut elapsed = Duration::ZERO;
    let mut rows = Vec::with_capacity(ladder.len());
    for &rung in ladder {
        let started = Instant::now();
        // Adaptive: `rung` samples per pixel on average, or fewer if every pixel
        // is at its cap.
        while renderer.samples() < rung {
            if renderer.advance(rung - renderer.samples()) == 0 {
                break;
            }
        }
        elapsed += started.elapsed();
        let accumulation = renderer.accumulation();
        let mean = accumulation.mean();
        let seconds = elapsed.as_secs_f64().max(1e-9);
        let rmse = stats::rmse(&mean, reference);
        let row = Row {
            variant: name.clone(),
            spp: renderer.samples(),
            seconds,
            paths_per_second: renderer.samples() as f64 * pixels / seconds,
            rmse,
            relative_rmse: stats::relative_rmse(&mean, reference),
            relative_mse: stats::relative_mse(&mean, reference),
            estimated_error: accumulation
                .standard_error()
                .map(|se| rms(&se).hypot(reference_error.unwrap_or(0.0))),
            efficiency: efficiency(rmse, seconds),
        };
        on_rung(&row);
        rows.push(row);
    }
    let discarded = renderer.check_counters()?.discarded as u64;
    Ok(Measurement {
        rows,
        warnings: renderer.warnings.clone(),
        discarded,
    })
}

/// Root mean square over all pixels and channels.
pub fn rms(image: &Image) -> f64 {
    stats::rmse(image, &Image::new(image.width, image.height))
}

// --- The whole study ---------------------------------------------------------------

/// Where the reference comes from.
#[derive(Clone, Debug)]
pub enum ReferenceChoice {
    /// The user's file, read by [`given_reference`].
    Given(Reference),
    /// Rendered (or reused from the cache in the output folder) at this many spp.
    Render { spp: u32 },
}

/// What to measure. `scene` carries the size, depth and seed of the measured runs.
pub struct Study<'a> {
    pub scene: &'a Scene,
    /// The scene file's bytes, for the reference cache key.
    pub scene_bytes: &'a [u8],
    pub out_dir: &'a Path,
    pub variants: &'a [Variant],
    pub max_spp: u32,
    pub reference: ReferenceChoice,
}

/// What a study reports as it goes, for the caller to display.
pub enum Event<'a> {
    /// The reference is being rendered.
    ReferenceProgress(&'a Progress),
    /// The reference is ready.
    Reference(&'a Reference),
    /// A variant's run starts.
    VariantStarted(Variant),
    Rung(&'a Row),
    /// Something the user should know (the renderer's warnings, discarded samples).
    Warning(String),
}

/// The measured study, ready to be written.
#[derive(Clone, Debug)]
pub struct Report {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub max_depth: u32,
    pub seed: u32,
    pub adapter: String,
    pub reference: String,
    pub rows: Vec<Row>,
    pub summaries: Vec<Summary>,
}

/// Creates the output folder, gets the reference, and measures every variant.
pub fn run_study(
    ctx: &GpuContext,
    study: &Study,
    mut on_event: impl FnMut(Event),
) -> Result<Report, ConvergeError> {
    let scene = study.scene;
    std::fs::create_dir_all(study.out_dir).map_err(|e| {
        ConvergeError::Input(format!("{}: cannot create: {e}", study.out_dir.display()))
    })?;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let reference = match &study.reference {
        ReferenceChoice::Given(reference) => reference.clone(),
        ReferenceChoice::Render { spp } => {
            cached_or_rendered_reference(ctx, scene, study.scene_bytes, study.out_dir, *spp, |p| {
                on_event(Event::ReferenceProgress(p))
            })?
        }
    };
    on_event(Event::Reference(&reference));

    let rungs = ladder(study.max_spp);
    let mut rows = Vec::new();
    for &variant in study.variants {
        on_event(Event::VariantStarted(variant));
        let measurement = measure_variant(ctx, scene, variant, &rungs, &reference, |row| {
            on_event(Event::Rung(row))
        })?;
        for warning in measurement.warnings {
            on_event(Event::Warning(format!("{variant}: {warning}")));
        }
        if measurement.discarded > 0 {
            on_event(Event::Warning(format!(
                "{variant}: {} samples were NaN or infinite and counted as zero",
                measurement.discarded
            )));
        }
        rows.extend(measurement.rows);
    }
    Ok(Report {
        scene: scene.source.clone(),
        width,
        height,
        max_depth: scene.render.max_depth,
        seed: scene.render.seed,
        adapter: ctx.describe(),
        reference: reference.describe(),
        summaries: summarize(&rows),
        rows,
    })
}

// --- Formatting and files ----------------------------------------------------------

/// About 3 significant digits, plain between 0.001 and 100 000, else in e-notation.
pub fn short_number(value: f64) -> String {
    if !value.is_finite() {
        return value.to_string();
    }
    let magnitude = value.abs();
    if magnitude == 0.0 {
        "0".to_string()
    } else if (1e-3..1e5).contains(&magnitude) {
        let decimals = (2 - magnitude.log10().floor() as i32).max(0) as usize;
        format!("{value:.decimals$}")
    } else {
        format!("{value:.2e}")
    }
}

fn optional(value: Option<f64>, format: impl Fn(f64) -> String) -> String {
    value.map_or_else(|| "–".to_string(), format)
}

/// The per-variant summary as a Markdown table.
pub fn summary_markdown(summaries: &[Summary]) -> String {
    let mut out = String::from(
        "| variant | slope | upper-half slope | RMSE last / two rungs before | \
         RMSE / noise est. | efficiency at last rung | verdict |\n\
         |---|--:|--:|--:|--:|--:|---|\n",
    );
    for s in summaries {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} |",
            s.variant,
            optional(s.slope, |v| format!("{v:.2}")),
            optional(s.upper_slope, |v| format!("{v:.2}")),
            optional(s.last_ratio, |v| format!("{v:.2}")),
            optional(s.excess, |v| format!("{v:.2}")),
            optional(s.last.as_ref().map(|r| r.efficiency), short_number),
            s.verdict
        );
    }
    out
}

/// The rows as a Markdown table.
pub fn rows_markdown(rows: &[Row]) -> String {
    let mut out = String::from(
        "| variant | spp | seconds | M paths/s | RMSE | rel. RMSE | relMSE | efficiency | noise est. |\n\
         |---|--:|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {:.2} | {} | {} | {} | {} | {} |",
            r.variant,
            r.spp,
            short_number(r.seconds),
            r.paths_per_second / 1e6,
            short_number(r.rmse),
            optional(r.relative_rmse, short_number),
            short_number(r.relative_mse),
            short_number(r.efficiency),
            optional(r.estimated_error, short_number)
        );
    }
    out
}

/// `converge.md`: the setup, the rows, and the per-variant summary.
pub fn markdown(report: &Report) -> String {
    format!(
        "# Convergence: {scene}\n\n\
         {w}x{h} pixels, max depth {d}, seed {seed}; reference: {reference}; adapter: {adapter}.\n\
         Seconds are render time from the first sample (pipeline warm-up and readbacks \
         excluded); relMSE = mean((x − r)² / (r² + 0.01)); efficiency = 1 / (MSE × \
         seconds); noise est. = the RMSE that noise \
         alone explains (the runs' and the reference's standard errors).\n\n\
         {rows}\n\
         Slopes: least-squares fits of ln RMSE against ln spp (ideal −0.5). A variant is \
         flagged \"error stops falling\" when its upper-half slope is shallower than \
         {slope_limit}, its last RMSE is at least {ratio_limit} times the RMSE two rungs \
         before, or its last RMSE is over {excess_limit} times its noise estimate.\n\n\
         {summary}",
        scene = report.scene,
        w = report.width,
        h = report.height,
        d = report.max_depth,
        seed = report.seed,
        reference = report.reference,
        adapter = report.adapter,
        rows = rows_markdown(&report.rows),
        slope_limit = UPPER_SLOPE_LIMIT,
        ratio_limit = LAST_RATIO_LIMIT,
        excess_limit = EXCESS_LIMIT,
        summary = summary_markdown(&report.summaries),
    )
}

/// The CSV header of [`csv`].
pub const CSV_HEADER: &str = "variant,spp,seconds,paths_per_second,rmse,relative_rmse,efficiency,estimated_error,relative_mse";

/// `converge.csv`: [`CSV_HEADER`], then one line per row, numbers at full precision
/// (an empty field for a missing relative RMSE or error estimate).
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{}",
            r.variant,
            r.spp,
            r.seconds,
            r.paths_per_second,
            r.rmse,
            r.relative_rmse.map_or_else(String::new, |v| v.to_string()),
            r.efficiency,
            r.estimated_error
                .map_or_else(String::new, |v| v.to_string()),
            r.relative_mse,
        );
    }
    out
}

/// The files [`write_report`] writes.
#[derive(Clone, Debug)]
pub struct ReportFiles {
    pub markdown: PathBuf,
    pub csv: PathBuf,
    pub plot: PathBuf,
}

/// Writes `converge.md`, `converge.csv` and `converge.png` into `dir`, each atomically.
pub fn write_report(dir: &Path, report: &Report) -> Result<ReportFiles, OutputError> {
    let files = ReportFiles {
        markdown: dir.join("converge.md"),
        csv: dir.join("converge.csv"),
        plot: dir.join("converge.png"),
    };
    for (path, text) in [
        (&files.markdown, markdown(report)),
        (&files.csv, csv(&report.rows)),
    ] {
        output::write_atomically(path, |w| w.write_all(text.as_bytes()))?;
    }
    let title = format!(
        "{}  {}x{}, max depth {}",
        Path::new(&report.scene)
            .file_name()
            .map_or_else(|| report.scene.clone(), |n| n.to_string_lossy().into()),
        report.width,
        report.height,
        report.max_depth
    );
    plot_png(&files.plot, &report.rows, &title)?;
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(variant: &str, spp: u32, rmse: f64) -> Row {
        let seconds = spp as f64 * 0.01;
        Row {
            variant: variant.to_string(),
            spp,
            seconds,
            paths_per_second: spp as f64 * 100.0 / seconds,
            rmse,
            relative_rmse: Some(rmse / 2.0),
            relative_mse: rmse * rmse,
            estimated_error: Some(rmse),
            efficiency: efficiency(rmse, seconds),
        }
    }

    #[test]
    fn ladder_is_powers_of_four_then_the_maximum() {
        assert_eq!(ladder(256), vec![1, 4, 16, 64, 256]);
        assert_eq!(ladder(64), vec![1, 4, 16, 64]);
        assert_eq!(ladder(100), vec![1, 4, 16, 64, 100]);
        assert_eq!(ladder(1), vec![1]);
        assert_eq!(ladder(0), Vec::<u32>::new());
        assert_eq!(*ladder(u32::MAX).last().unwrap(), u32::MAX);
    }

    #[test]
    fn variants_parse_and_print() {
        assert_eq!(Variant::parse("cosine"), Ok(Variant::BSDF));
        assert_eq!(Variant::parse(" light "), Ok(Variant::LIGHT));
        assert_eq!(Variant::parse("mixture"), Ok(Variant::mixture(0.5)));
        assert_eq!(Variant::parse("mixture:0.25"), Ok(Variant::mixture(0.25)));
        assert_eq!(Variant::parse("nee-mis"), Ok(Variant::NEE_MIS));
        let adaptive = Variant::parse("mixture:0.25+adaptive").unwrap();
        assert_eq!(
            adaptive,
            Variant {
                adaptive: true,
                ..Variant::mixture(0.25)
            }
        );
        assert_eq!(Variant::parse(&adaptive.name()), Ok(adaptive));
        let both = Variant {
            importance: true,
            ..adaptive
        };
        for text in ["nee-mis+adaptive+importance", "nee-mis+importance+adaptive"] {
            let variant = Variant::parse(text).unwrap();
            assert_eq!(
                variant,
                Variant {
                    strategy: Strategy::NeeMis,
                    light_weight: None,
                    ..both
                }
            );
            assert_eq!(Variant::parse(&variant.name()), Ok(variant));
        }
        let uniform = Variant::parse("nee-mis+uniform-lights+importance").unwrap();
        assert!(uniform.uniform_lights && uniform.importance && !uniform.adaptive);
        assert_eq!(uniform.name(), "nee-mis+importance+uniform-lights");
        assert_eq!(Variant::parse(&uniform.name()), Ok(uniform));
        for bad in [
            "uniform",
            "mixture+uniform-lights",
            "nee-mis+uniform-lights+uniform-lights",
            "mixture:1.5",
            "mixture:x",
            "cosine:0.5",
            "",
            "cosine+adaptive+adaptive",
            "+adaptive",
            "light+importance+importance",
        ] {
            assert!(Variant::parse(bad).is_err(), "{bad}");
        }
        let names: Vec<String> = Variant::defaults().iter().map(Variant::name).collect();
        assert_eq!(
            names,
            [
                "bsdf",
                "light",
                "nee-mis",
                "mixture:0.25",
                "mixture:0.5",
                "mixture:0.75"
            ]
        );
        for v in Variant::defaults() {
            assert_eq!(Variant::parse(&v.name()), Ok(v));
        }
    }

    /// Rows at `(spp, rmse)`, each with `noise` as its error estimate (None: unknown).
    fn rows(points: &[(f64, f64)], noise: impl Fn(f64) -> Option<f64>) -> Vec<Row> {
        points
            .iter()
            .map(|&(n, rmse)| Row {
                estimated_error: noise(n),
                ..row("v", n as u32, rmse)
            })
            .collect()
    }

    fn power_law(exponent: f64) -> Vec<(f64, f64)> {
        ladder(256)
            .into_iter()
            .map(|n| (n as f64, 0.3 * (n as f64).powf(exponent)))
            .collect()
    }

    #[test]
    fn ideal_convergence_is_not_flagged() {
        let s = summarize_variant(&rows(&power_law(-0.5), |n| Some(0.3 / n.sqrt())));
        assert!((s.slope.unwrap() + 0.5).abs() < 1e-12);
        assert!((s.upper_slope.unwrap() + 0.5).abs() < 1e-12);
        assert!((s.last_ratio.unwrap() - 0.25).abs() < 1e-12);
        assert!((s.excess.unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(s.verdict, Verdict::Converging);
        assert_eq!(s.last.unwrap().spp, 256);
        // Without error estimates, the slopes decide alone.
        let s = summarize_variant(&rows(&power_law(-0.5), |_| None));
        assert_eq!((s.excess, s.verdict), (None, Verdict::Converging));
    }

    /// Noise `0.3 / sqrt(n)` over a bias of `bias`: RMSE = sqrt(bias² + noise²).
    fn biased(bias: f64, max_spp: u32) -> Vec<Row> {
        let points: Vec<(f64, f64)> = ladder(max_spp)
            .into_iter()
            .map(|n| (n as f64, (bias.powi(2) + 0.09 / n as f64).sqrt()))
            .collect();
        rows(&points, |n| Some(0.3 / n.sqrt()))
    }

    #[test]
    fn a_plateau_is_flagged() {
        // Falls at first, then flattens at the bias.
        let s = summarize_variant(&biased(0.05, 256));
        assert!(s.slope.unwrap() < -0.25, "falls overall: {:?}", s.slope);
        assert!(
            s.upper_slope.unwrap() > UPPER_SLOPE_LIMIT,
            "{:?}",
            s.upper_slope
        );
        assert_eq!(s.verdict, Verdict::StopsFalling);
        let flat = summarize_variant(&rows(&power_law(0.0), |_| None));
        assert_eq!(flat.verdict, Verdict::StopsFalling);
    }

    #[test]
    fn the_last_rungs_alone_can_flag() {
        // Steep over the upper half (the last 2 of 3 rungs), but hardly lower than at
        // 16 times fewer samples.
        let points = [(1.0, 0.1), (4.0, 0.2), (16.0, 0.08)];
        let s = summarize_variant(&rows(&points, |_| None));
        assert!(s.upper_slope.unwrap() < UPPER_SLOPE_LIMIT);
        assert!(s.last_ratio.unwrap() >= LAST_RATIO_LIMIT);
        assert_eq!(s.verdict, Verdict::StopsFalling);
    }

    #[test]
    fn a_bias_below_the_noise_is_flagged_by_the_noise_estimate() {
        // At 64 spp the bias is 0.9 of the noise: the curve still falls steeply enough,
        // but the error is 1.35 times what noise explains.
        let s = summarize_variant(&biased(0.034, 64));
        assert!(
            s.upper_slope.unwrap() < UPPER_SLOPE_LIMIT,
            "{:?}",
            s.upper_slope
        );
        assert!(s.last_ratio.unwrap() < LAST_RATIO_LIMIT);
        assert!((s.excess.unwrap() - 1.0f64.hypot(0.034 / 0.0375)).abs() < 1e-12);
        assert_eq!(s.verdict, Verdict::Converging, "1.35 is under the limit");
        let s = summarize_variant(&biased(0.05, 64));
        assert!(
            s.upper_slope.unwrap() < UPPER_SLOPE_LIMIT,
            "{:?}",
            s.upper_slope
        );
        assert!(s.excess.unwrap() > EXCESS_LIMIT);
        assert_eq!(s.verdict, Verdict::StopsFalling);
    }

    #[test]
    fn short_ladders() {
        let none = |_| None;
        assert_eq!(summarize_variant(&[]).verdict, Verdict::TooFewRungs);
        assert_eq!(
            summarize_variant(&rows(&[(1.0, 1.0)], none)).verdict,
            Verdict::TooFewRungs
        );
        let s = summarize_variant(&rows(&[(1.0, 1.0), (4.0, 0.5)], none));
        assert!((s.upper_slope.unwrap() + 0.5).abs() < 1e-12);
        assert_eq!(s.last_ratio, None);
        assert_eq!(s.verdict, Verdict::Converging);
        // Upper half of 4 rungs: the last 3.
        let points = [(1.0, 9.0), (4.0, 1.0), (16.0, 0.5), (64.0, 0.25)];
        let s = summarize_variant(&rows(&points, none));
        assert!((s.upper_slope.unwrap() + 0.5).abs() < 1e-12);
        // A zero RMSE (identical to the reference) has no logarithm.
        let s = summarize_variant(&rows(&[(1.0, 0.0), (4.0, 0.0)], none));
        assert_eq!(s.verdict, Verdict::StopsFalling);
    }

    #[test]
    fn summaries_group_rows_by_variant_in_order() {
        let mut rows = Vec::new();
        for n in ladder(64) {
            rows.push(row("mixture:0.5", n, 0.4 / (n as f64).sqrt()));
            rows.push(row("light", n, 0.2));
        }
        let summaries = summarize(&rows);
        assert_eq!(summaries.len(), 2);
        assert_eq!(summaries[0].variant, "mixture:0.5");
        assert_eq!(summaries[0].verdict, Verdict::Converging);
        assert_eq!(summaries[0].last.as_ref().unwrap().spp, 64);
        assert_eq!(summaries[1].variant, "light");
        assert_eq!(summaries[1].verdict, Verdict::StopsFalling);
        assert_eq!(summaries[1].slope, Some(0.0));
    }

    #[test]
    fn efficiency_is_inverse_mse_times_seconds() {
        assert_eq!(efficiency(0.5, 2.0), 2.0);
        // At the ideal rate the MSE halves when the time doubles.
        assert!((efficiency(0.5 / 2f64.sqrt(), 4.0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn csv_has_a_header_and_one_parsable_line_per_row() {
        let mut rows = vec![row("cosine", 1, 0.125), row("mixture:0.25", 4, 0.0625)];
        rows[1].relative_rmse = None;
        let text = csv(&rows);
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some(CSV_HEADER));
        let fields: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        assert_eq!(fields.len(), 2);
        assert_eq!(fields[0][0], "cosine");
        assert_eq!(fields[0][1], "1");
        assert_eq!(fields[0][4].parse::<f64>().unwrap(), 0.125);
        assert_eq!(fields[0][5].parse::<f64>().unwrap(), 0.0625);
        assert_eq!(fields[1][5], "");
        assert_eq!(fields[0][7].parse::<f64>().unwrap(), 0.125);
        assert_eq!(fields[0][8].parse::<f64>().unwrap(), 0.125 * 0.125);
        for f in &fields {
            assert_eq!(f.len(), 9);
            for (i, v) in f.iter().enumerate().skip(1) {
                assert!(i == 5 || v.parse::<f64>().is_ok(), "{v}");
            }
        }
    }

    #[test]
    fn markdown_tables_have_a_line_per_row_and_variant() {
        let rows: Vec<Row> = ladder(16)
            .into_iter()
            .map(|n| row("cosine", n, 0.3 / (n as f64).sqrt()))
            .collect();
        let table = rows_markdown(&rows);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 2 + rows.len());
        assert_eq!(
            lines[0],
            "| variant | spp | seconds | M paths/s | RMSE | rel. RMSE | relMSE | efficiency | noise est. |"
        );
        assert_eq!(
            lines[2],
            "| cosine | 1 | 0.0100 | 0.01 | 0.300 | 0.150 | 0.0900 | 1111 | 0.300 |"
        );
        assert!(lines.iter().all(|l| l.matches('|').count() == 10));

        let summary = summary_markdown(&summarize(&rows));
        let lines: Vec<&str> = summary.lines().collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(
            lines[2],
            "| cosine | -0.50 | -0.50 | 0.25 | 1.00 | 1111 | converging |"
        );
        let report = Report {
            scene: "scenes/x.toml".into(),
            width: 8,
            height: 4,
            max_depth: 3,
            seed: 0,
            adapter: "test".into(),
            reference: "ref.exr (given)".into(),
            summaries: summarize(&rows),
            rows,
        };
        let text = markdown(&report);
        assert!(text.starts_with("# Convergence: scenes/x.toml\n"));
        assert!(text.contains("8x4 pixels, max depth 3"));
        assert!(text.contains(&table));
        assert!(text.contains(&summary));
    }

    #[test]
    fn short_numbers() {
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(1234.5), "1234");
        assert_eq!(short_number(12.345), "12.3");
        assert_eq!(short_number(0.012345), "0.0123");
        assert_eq!(short_number(123456.0), "1.23e5");
        assert_eq!(short_number(0.00012), "1.20e-4");
        assert_eq!(short_number(f64::INFINITY), "inf");
    }

    #[test]
    fn reference_key_is_stable_and_covers_its_inputs() {
        let scene = b"[camera]\nwidth = 600\n";
        let key = reference_key(scene, 128, 128, 50, 4096);
        // Pinned: a changed key would orphan every cached reference.
        assert_eq!(key, PINNED_KEY, "{key:#018x}");
        assert_eq!(reference_key(scene, 128, 128, 50, 4096), key);
        let others = [
            reference_key(b"[camera]\nwidth = 601\n", 128, 128, 50, 4096),
            reference_key(scene, 129, 128, 50, 4096),
            reference_key(scene, 128, 129, 50, 4096),
            reference_key(scene, 128, 128, 51, 4096),
            reference_key(scene, 128, 128, 50, 4097),
            // Depth and samples swapped.
            reference_key(scene, 128, 128, 4096, 50),
        ];
        for other in others {
            assert_ne!(other, key);
        }
        assert_eq!(
            reference_cache_path(Path::new("out"), 0xab),
            Path::new("out").join("reference-00000000000000ab.exr")
        );
    }

    /// Also computed with an independent FNV-1a implementation.
    const PINNED_KEY: u64 = 0x63c9_09b8_5633_a6e7;
}
