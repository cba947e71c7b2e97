//! `pathmix._pathmix`: the Python binding of the pathmix library, a thin layer
//! over its session API (`pathmix::session`). Arguments become a `Request`;
//! `Session::plan_loaded` checks it against a scene read once; the run's sums
//! come back as NumPy arrays. `pathmix/__init__.py` is the public module.
//!
//! What is kept between calls: the device (opened at the first render, for
//! the process's life) and its kernels (`GpuContext::keep_kernels`: a render
//! whose kernel config equals an earlier one's reuses its pipelines), and each
//! `Scene`'s files as read. Each render makes its own buffers and sums, so
//! renders from several threads run at once.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray3};
use pathmix::gpu::GpuContext;
use pathmix::output::{self, Image};
use pathmix::render::aov::AovImage;
use pathmix::render::{Progress, RunSummary, StopReason};
use pathmix::scene::mitsuba::Define;
use pathmix::scene::{
    AdaptiveMetric, Aov, LightSelection, LoadedScene, Reconstruction, Sampler, Scene as SceneData,
    SceneOverrides, Strategy, parse_aovs,
};
use pathmix::session::converge::{ConvergeError, Event, ReferenceChoice, Study, Variant};
use pathmix::session::{self, Request, SessionError};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::ffi::CString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

create_exception!(
    pathmix,
    SceneError,
    PyValueError,
    "A scene file that cannot be read or is not valid; the message names the file, \
     the line and the field, as the command line's does."
);
create_exception!(
    pathmix,
    RenderError,
    PyRuntimeError,
    "A render that could not run or finish: no GPU adapter, a device error, sums that \
     overflowed, a file that could not be written."
);

/// The device, opened at the first render and kept with its kernels.
static GPU: OnceLock<GpuContext> = OnceLock::new();
/// Held while the device is opened, so that threads rendering first open one.
static OPENING: Mutex<()> = Mutex::new(());

fn gpu() -> PyResult<&'static GpuContext> {
    if let Some(ctx) = GPU.get() {
        return Ok(ctx);
    }
    let _opening = OPENING.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(ctx) = GPU.get() {
        return Ok(ctx);
    }
    let ctx = GpuContext::new(None)
        .map_err(|e| RenderError::new_err(e.to_string()))?
        .keep_kernels();
    Ok(GPU.get_or_init(|| ctx))
}

/// A session's refusal or failure as the exception a caller can catch.
fn session_error(e: SessionError) -> PyErr {
    match &e {
        SessionError::Scene(_) => SceneError::new_err(e.to_string()),
        _ if e.is_input() => PyValueError::new_err(e.to_string()),
        _ => RenderError::new_err(e.to_string()),
    }
}

fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    let message = CString::new(message.replace('\0', " ")).expect("NULs replaced");
    PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 2)
}

/// A scene file as read, to render any number of times.
#[pyclass(frozen, module = "pathmix")]
struct Scene {
    path: PathBuf,
    defines: Vec<Define>,
    loaded: LoadedScene,
}

#[pymethods]
impl Scene {
    /// The scene's settings and contents, as `pathmix info` prints them.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let scene = &self.loaded.scene;
        let render = &scene.render;
        let info = PyDict::new(py);
        info.set_item("source", &scene.source)?;
        info.set_item("width", scene.camera.width)?;
        info.set_item("height", scene.camera.height)?;
        info.set_item("spp", render.spp)?;
        info.set_item("max_depth", render.max_depth)?;
        let strategy = match render.auto_strategy {
            true => "auto",
            false => render.strategy.name(),
        };
        info.set_item("strategy", strategy)?;
        info.set_item("light_weight", render.light_weight)?;
        info.set_item("sampler", render.sampler.to_string())?;
        info.set_item("light_selection", render.light_selection.name())?;
        info.set_item(
            "reconstruction",
            render.reconstruction_with(scene.camera.filter).name(),
        )?;
        info.set_item("seed", render.seed)?;
        info.set_item("adaptive", render.adaptive)?;
        // `None`: the run's default (relative; absolute under an error target).
        info.set_item(
            "adaptive_metric",
            render.adaptive_metric.map(AdaptiveMetric::name),
        )?;
        info.set_item("shapes", scene.shapes.iter().count())?;
        info.set_item("materials", scene.materials.len())?;
        info.set_item("point_lights", scene.point_lights.len())?;
        info.set_item("environment", scene.environment.is_some())?;
        info.set_item("importance_shapes", scene.importance_count())?;
        info.set_item("inputs", &scene.inputs)?;
        info.set_item("approximations", &self.loaded.warnings)?;
        info.set_item("warnings", &scene.warnings)?;
        Ok(info)
    }

    fn __repr__(&self) -> String {
        let camera = &self.loaded.scene.camera;
        format!(
            "<pathmix.Scene {} {}x{}>",
            self.path.display(),
            camera.width,
            camera.height
        )
    }
}

/// Reads a scene file (TOML or Mitsuba 3 XML); `params` set a Mitsuba scene's
/// `$name` parameters, as `mitsuba -D name=value`.
#[pyfunction]
#[pyo3(signature = (path, **params))]
fn load(py: Python<'_>, path: PathBuf, params: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
    let mut defines = Vec::new();
    for (name, value) in params.into_iter().flatten() {
        // Mitsuba spells booleans in lower case; Python's str() does not.
        let value = match value.extract::<bool>() {
            Ok(flag) if value.is_instance_of::<pyo3::types::PyBool>() => flag.to_string(),
            _ => value.str()?.to_string(),
        };
        defines.push(Define {
            name: name.str()?.to_string(),
            value,
        });
    }
    let loaded = py
        .detach(|| SceneData::load_with(&path, &defines))
        .map_err(|e| SceneError::new_err(e.to_string()))?;
    if !loaded.warnings.is_empty() {
        let message = format!(
            "{}: approximated: {}",
            path.display(),
            loaded.warnings.join("; ")
        );
        warn(py, &message)?;
    }
    Ok(Scene {
        path,
        defines,
        loaded,
    })
}

/// What a render or session asks for beyond the scene file's settings.
struct Settings {
    spp: Option<u32>,
    strategy: Option<String>,
    light_weight: Option<f32>,
    sampler: Option<String>,
    seed: Option<u32>,
    width: Option<u32>,
    height: Option<u32>,
    max_depth: Option<u32>,
    /// `Some(None)`: roulette off.
    rr_depth: Option<Option<u32>>,
    time: Option<f64>,
    target_error: Option<f64>,
    adaptive: bool,
    adaptive_metric: Option<String>,
    light_selection: Option<String>,
    reconstruction: Option<String>,
}

/// `rr_depth`: a number of bounces, or "off" (`Some(None)`), as `--rr-depth`.
fn parse_rr_depth(value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Option<u32>>> {
    let Some(value) = value else {
        return Ok(None);
    };
    if let Ok(depth) = value.extract::<u32>() {
        return Ok(Some(Some(depth)));
    }
    match value.extract::<String>() {
        Ok(off) if off == "off" => Ok(Some(None)),
        _ => Err(PyValueError::new_err(format!(
            "rr_depth: a number of bounces >= 0 or \"off\", got {value}"
        ))),
    }
}

/// A named choice given as `argument`, read by `from_name`, or a `ValueError`
/// listing the `names` it may be.
fn choice<T>(
    argument: &str,
    value: Option<&str>,
    from_name: fn(&str) -> Option<T>,
    names: &[&str],
) -> PyResult<Option<T>> {
    value
        .map(|name| {
            from_name(name).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{argument}: `{name}` is not one of {}",
                    names.join(", ")
                ))
            })
        })
        .transpose()
}

impl Settings {
    /// Whether a setting the samples depend on is given (a resumed run keeps
    /// its checkpoint's).
    fn fixes_the_scene(&self) -> bool {
        self.strategy.is_some()
            || self.light_weight.is_some()
            || self.sampler.is_some()
            || self.light_selection.is_some()
            || self.reconstruction.is_some()
            || self.seed.is_some()
            || self.width.is_some()
            || self.height.is_some()
            || self.max_depth.is_some()
            || self.rr_depth.is_some()
    }

    /// The session request: no files written but a checkpoint where asked,
    /// the sums of squares kept where `error` is wanted.
    fn request(&self, scene: &Scene, error: bool) -> PyResult<Request> {
        let (strategy, auto_strategy) = match self.strategy.as_deref() {
            None => (None, false),
            Some("auto") => (None, true),
            Some(name) => match Strategy::from_name(name) {
                Some(strategy) => (Some(strategy), false),
                None => {
                    return Err(PyValueError::new_err(format!(
                        "strategy: `{name}` is not one of mixture, bsdf (or cosine), light, \
                         nee-mis, auto"
                    )));
                }
            },
        };
        let sampler = choice(
            "sampler",
            self.sampler.as_deref(),
            Sampler::from_name,
            &Sampler::ALL.map(Sampler::name),
        )?;
        let light_selection = choice(
            "light_selection",
            self.light_selection.as_deref(),
            LightSelection::from_name,
            &LightSelection::ALL.map(LightSelection::name),
        )?;
        let adaptive_metric = choice(
            "adaptive_metric",
            self.adaptive_metric.as_deref(),
            AdaptiveMetric::from_name,
            &AdaptiveMetric::ALL.map(AdaptiveMetric::name),
        )?;
        let reconstruction = choice(
            "reconstruction",
            self.reconstruction.as_deref(),
            Reconstruction::from_name,
            &Reconstruction::ALL.map(Reconstruction::name),
        )?;
        let time_budget = match self.time {
            None => None,
            Some(seconds) if seconds.is_finite() && seconds > 0.0 => {
                Some(Duration::from_secs_f64(seconds))
            }
            Some(seconds) => {
                return Err(PyValueError::new_err(format!(
                    "time: must be a number of seconds > 0, got {seconds}"
                )));
            }
        };
        if let Some(target) = self.target_error {
            if !(target.is_finite() && target > 0.0) {
                return Err(PyValueError::new_err(format!(
                    "target_error: must be a number > 0, got {target}"
                )));
            }
        }
        let mut request = Request {
            scene: Some(scene.path.clone()),
            defines: scene.defines.clone(),
            overrides: SceneOverrides {
                width: self.width,
                height: self.height,
                max_depth: self.max_depth,
                rr_depth: self.rr_depth,
                strategy,
                light_weight: self.light_weight,
                seed: self.seed,
                sampler,
                light_selection,
                adaptive_metric,
                reconstruction,
                ..SceneOverrides::default()
            },
            spp: self.spp,
            auto_strategy,
            time_budget,
            target_error: self.target_error,
            adaptive: self.adaptive,
            ..Request::default()
        };
        request.render.variance = error;
        Ok(request)
    }
}

/// Stops a run between submissions when Python has a signal to raise (Ctrl-C)
/// or the progress callback raised, keeping that exception to raise after.
struct Watch<'a> {
    stop: AtomicBool,
    raised: Mutex<Option<PyErr>>,
    callback: Option<&'a Py<PyAny>>,
}

impl<'a> Watch<'a> {
    fn new(callback: Option<&'a Py<PyAny>>) -> Watch<'a> {
        Watch {
            stop: AtomicBool::new(false),
            raised: Mutex::new(None),
            callback,
        }
    }

    /// After each submission, with the interpreter attached for a moment.
    fn check(&self, progress: &Progress) {
        let outcome = Python::attach(|py| {
            py.check_signals()?;
            if let Some(callback) = self.callback {
                let report = PyDict::new(py);
                report.set_item("samples", progress.samples)?;
                if progress.max_samples != u32::MAX {
                    report.set_item("max_samples", progress.max_samples)?;
                }
                report.set_item("elapsed", progress.elapsed.as_secs_f64())?;
                report.set_item("relative_error", progress.relative_error)?;
                callback.call1(py, (report,))?;
            }
            Ok::<(), PyErr>(())
        });
        if let Err(e) = outcome {
            *self.raised.lock().unwrap_or_else(|e| e.into_inner()) = Some(e);
            self.stop.store(true, Ordering::SeqCst);
        }
    }

    /// The exception that stopped the run, if one did.
    fn raised(&self) -> PyResult<()> {
        match self.raised.lock().unwrap_or_else(|e| e.into_inner()).take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// The command line's warning about samples counted as zero, where there were any.
fn discarded(count: u64) -> Option<String> {
    (count > 0).then(|| format!("{count} samples were NaN or infinite and counted as zero"))
}

/// A render's images, before they become arrays.
struct Rendered {
    mean: Image,
    error: Option<Image>,
    sample_counts: Option<Vec<u32>>,
    aovs: Option<AovImage>,
    warnings: Vec<String>,
}

/// Each AOV by name: float32 (height, width, channels), its channels in
/// Mitsuba's order (`albedo`: R, G, B; `depth`: one; `uv`: U, V).
fn aov_dict<'py>(py: Python<'py>, aovs: &[Aov], image: &AovImage) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let (width, height) = (image.width as usize, image.height as usize);
    let mut channels = image.channels.iter();
    for aov in aovs {
        let count = aov.kind.suffixes().len();
        let parts: Vec<&Vec<f32>> = channels
            .by_ref()
            .take(count)
            .map(|(_, values)| values)
            .collect();
        let values: Vec<f32> = (0..width * height)
            .flat_map(|i| parts.iter().map(move |part| part[i]))
            .collect();
        let array = Array3::from_shape_vec((height, width, count), values)
            .expect("one value per pixel and channel");
        dict.set_item(&aov.name, array.into_pyarray(py))?;
    }
    Ok(dict)
}

fn array<'py>(py: Python<'py>, image: &Image) -> Bound<'py, PyArray3<f32>> {
    let (width, height) = (image.width as usize, image.height as usize);
    let values: Vec<f32> = image.pixels.iter().flatten().copied().collect();
    Array3::from_shape_vec((height, width, 3), values)
        .expect("an image holds width x height pixels")
        .into_pyarray(py)
}

fn counts_array<'py>(
    py: Python<'py>,
    counts: Vec<u32>,
    (width, height): (u32, u32),
) -> Bound<'py, PyArray2<u32>> {
    numpy::ndarray::Array2::from_shape_vec((height as usize, width as usize), counts)
        .expect("a count per pixel")
        .into_pyarray(py)
}

/// Renders `scene` once and returns the mean radiance as a float32 array of
/// shape (height, width, 3), linear; with `return_error` also the standard
/// error of each pixel's mean, with `return_sample_counts` (adaptive runs) each
/// pixel's sample count, with `aovs` (Mitsuba's `aovs` string, as `--aov`) a
/// dict of each AOV's float32 (height, width, channels) array, as a tuple in
/// that order.
#[pyfunction]
#[pyo3(signature = (
    scene, *, spp=None, strategy=None, seed=None, width=None, height=None, max_depth=None,
    rr_depth=None, time=None, target_error=None, adaptive=false, adaptive_metric=None,
    light_weight=None, sampler=None, light_selection=None, reconstruction=None,
    return_error=false, return_sample_counts=false, aovs=None, progress=None,
))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    scene: &Bound<'_, Scene>,
    spp: Option<u32>,
    strategy: Option<String>,
    seed: Option<u32>,
    width: Option<u32>,
    height: Option<u32>,
    max_depth: Option<u32>,
    rr_depth: Option<Bound<'_, PyAny>>,
    time: Option<f64>,
    target_error: Option<f64>,
    adaptive: bool,
    adaptive_metric: Option<String>,
    light_weight: Option<f32>,
    sampler: Option<String>,
    light_selection: Option<String>,
    reconstruction: Option<String>,
    return_error: bool,
    return_sample_counts: bool,
    aovs: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyAny>> {
    let aovs = match &aovs {
        Some(spec) => {
            Some(parse_aovs(spec).map_err(|e| PyValueError::new_err(format!("aovs: {e}")))?)
        }
        None => None,
    };
    let settings = Settings {
        spp,
        strategy,
        light_weight,
        sampler,
        seed,
        width,
        height,
        max_depth,
        rr_depth: parse_rr_depth(rr_depth.as_ref())?,
        time,
        target_error,
        adaptive,
        adaptive_metric,
        light_selection,
        reconstruction,
    };
    let scene = scene.get();
    let mut request = settings.request(scene, return_error)?;
    // Computed here, from the argument alone: not the file's list, which the
    // command line writes into its EXR.
    request.overrides.aovs = Some(Vec::new());
    let watch = Watch::new(progress.as_ref());
    let rendered = py.detach(|| -> PyResult<Rendered> {
        let mut planned =
            session::Session::plan_loaded(&request, scene.loaded.clone()).map_err(session_error)?;
        let ctx = gpu()?;
        let mut pilot = planned.choose_strategy(ctx).map_err(session_error)?;
        let mut run = planned.start(ctx, pilot.as_mut()).map_err(session_error)?;
        let summary = run
            .render(&watch.stop, |p| watch.check(p))
            .map_err(session_error)?;
        watch.raised()?;
        let outcome = run.finish(summary).map_err(session_error)?;
        let mut warnings = run.session.warnings.clone();
        warnings.extend(run.renderer.warnings.iter().cloned());
        warnings.extend(discarded(outcome.discarded));
        let accumulation = run.renderer.accumulation();
        Ok(Rendered {
            mean: accumulation.mean(),
            error: match return_error {
                true => Some(accumulation.standard_error().ok_or_else(|| {
                    PyValueError::new_err("return_error: a standard error needs spp >= 2")
                })?),
                false => None,
            },
            sample_counts: run.renderer.sample_counts().map(<[u32]>::to_vec),
            aovs: match &aovs {
                Some(aovs) => Some(
                    run.renderer
                        .render_aovs(aovs, run.renderer.samples())
                        .map_err(|e| match e {
                            pathmix::render::RenderError::UvAovWithoutTextures { .. } => {
                                PyValueError::new_err(format!("aovs: {e}"))
                            }
                            e => session_error(e.into()),
                        })?,
                ),
                None => None,
            },
            warnings,
        })
    })?;
    for warning in &rendered.warnings {
        warn(py, warning)?;
    }
    let image = array(py, &rendered.mean).into_any().unbind();
    if !return_error && !return_sample_counts && aovs.is_none() {
        return Ok(image);
    }
    let mut parts = vec![image];
    if let Some(error) = &rendered.error {
        parts.push(array(py, error).into_any().unbind());
    }
    if return_sample_counts {
        let size = (rendered.mean.width, rendered.mean.height);
        let counts = rendered.sample_counts.ok_or_else(|| {
            PyValueError::new_err("return_sample_counts: only an adaptive run has per-pixel counts")
        })?;
        parts.push(counts_array(py, counts, size).into_any().unbind());
    }
    if let (Some(asked), Some(image)) = (&aovs, &rendered.aovs) {
        parts.push(aov_dict(py, asked, image)?.into_any().unbind());
    }
    Ok(pyo3::types::PyTuple::new(py, parts)?.into_any().unbind())
}

/// The state of a progressive run between its steps.
struct Progressive {
    run: session::Run<'static>,
    /// The last step's summary, for `finish` (a checkpoint's last save).
    last: Option<RunSummary>,
}

/// A progressive render (`pathmix.Session`): steps of samples, the image and
/// its error after each.
#[pyclass(frozen, module = "pathmix")]
struct Run {
    /// `None` once closed: the run, and the lock on its checkpoint, dropped.
    state: Mutex<Option<Progressive>>,
}

#[pymethods]
impl Run {
    #[new]
    #[pyo3(signature = (
        scene, *, spp=None, strategy=None, seed=None, width=None, height=None, max_depth=None,
        rr_depth=None, time=None, target_error=None, adaptive=false, adaptive_metric=None,
        light_weight=None, sampler=None, light_selection=None, reconstruction=None,
        checkpoint=None, resume=None,
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, Scene>,
        spp: Option<u32>,
        strategy: Option<String>,
        seed: Option<u32>,
        width: Option<u32>,
        height: Option<u32>,
        max_depth: Option<u32>,
        rr_depth: Option<Bound<'_, PyAny>>,
        time: Option<f64>,
        target_error: Option<f64>,
        adaptive: bool,
        adaptive_metric: Option<String>,
        light_weight: Option<f32>,
        sampler: Option<String>,
        light_selection: Option<String>,
        reconstruction: Option<String>,
        checkpoint: Option<PathBuf>,
        resume: Option<PathBuf>,
    ) -> PyResult<Run> {
        let settings = Settings {
            spp,
            strategy,
            light_weight,
            sampler,
            seed,
            width,
            height,
            max_depth,
            rr_depth: parse_rr_depth(rr_depth.as_ref())?,
            time,
            target_error,
            adaptive,
            adaptive_metric,
            light_selection,
            reconstruction,
        };
        if resume.is_some() && settings.fixes_the_scene() {
            return Err(PyValueError::new_err(
                "resume: the checkpoint records the size, depth, strategy, light weight, \
                 roulette depth, seed, sampler, light selection and reconstruction it was \
                 rendered with; give only spp, time or target_error",
            ));
        }
        let scene = scene.get();
        let mut request = settings.request(scene, true)?;
        request.checkpoint = checkpoint;
        request.resume = resume;
        let (run, warnings) = py.detach(|| -> PyResult<_> {
            let mut planned = session::Session::plan_loaded(&request, scene.loaded.clone())
                .map_err(session_error)?;
            let ctx = gpu()?;
            let mut pilot = planned.choose_strategy(ctx).map_err(session_error)?;
            let run = planned.start(ctx, pilot.as_mut()).map_err(session_error)?;
            let mut warnings = run.session.warnings.clone();
            warnings.extend(run.renderer.warnings.iter().cloned());
            Ok((run, warnings))
        })?;
        for warning in &warnings {
            warn(py, warning)?;
        }
        Ok(Run {
            state: Mutex::new(Some(Progressive { run, last: None })),
        })
    }

    /// Renders up to `every` more samples per pixel and returns the step's
    /// results as a dict; `done` says the run's own rule stopped it.
    #[pyo3(signature = (every, progress=None))]
    fn step<'py>(
        &self,
        py: Python<'py>,
        every: u32,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        if every == 0 {
            return Err(PyValueError::new_err(
                "every: must be at least 1 sample per pixel",
            ));
        }
        let watch = Watch::new(progress.as_ref());
        let (mean, error, counts, size, samples, elapsed, relative_error, done) =
            py.detach(|| -> PyResult<_> {
                let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
                let Some(state) = state.as_mut() else {
                    return Err(PyValueError::new_err("the session is closed"));
                };
                let run = &mut state.run;
                let target = run.renderer.samples().saturating_add(every);
                let summary = run
                    .render_until(target, &watch.stop, |p| watch.check(p))
                    .map_err(session_error)?;
                watch.raised()?;
                let samples = run.renderer.samples();
                let done = summary.reason != StopReason::Samples
                    || samples >= run.session.stop.max_samples
                    || samples < target;
                let accumulation = run.renderer.accumulation();
                let result = (
                    accumulation.mean(),
                    accumulation.standard_error(),
                    run.renderer.sample_counts().map(<[u32]>::to_vec),
                    run.renderer.size(),
                    samples,
                    run.rendered_for(),
                    summary.relative_error,
                    done,
                );
                state.last = Some(summary);
                Ok(result)
            })?;
        let step = PyDict::new(py);
        step.set_item("image", array(py, &mean))?;
        step.set_item("error", error.as_ref().map(|e| array(py, e)))?;
        step.set_item("sample_counts", counts.map(|c| counts_array(py, c, size)))?;
        step.set_item("samples", samples)?;
        step.set_item("elapsed", elapsed.as_secs_f64())?;
        step.set_item("relative_error", relative_error)?;
        step.set_item("done", done)?;
        Ok(step)
    }

    /// Ends the run: saves the checkpoint where one was asked for, and lets
    /// go of it (another session may resume it). Later calls do nothing.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        let outcome = py.detach(|| {
            let state = self.state.lock().unwrap_or_else(|e| e.into_inner()).take();
            match state {
                Some(Progressive {
                    run,
                    last: Some(summary),
                }) => run.finish(summary).map(Some).map_err(session_error),
                _ => Ok(None),
            }
        })?;
        match outcome.and_then(|outcome| discarded(outcome.discarded)) {
            Some(warning) => warn(py, &warning),
            None => Ok(()),
        }
    }
}

/// Measures each strategy variant's error against time and samples, as
/// `pathmix converge` does, and returns its table: a dict per rung.
#[pyfunction]
#[pyo3(signature = (
    scene, *, variants=None, max_spp=256, width=None, height=None, max_depth=None, seed=None,
    reference_spp=4096, out=None,
))]
#[allow(clippy::too_many_arguments)]
fn converge<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    variants: Option<Vec<String>>,
    max_spp: u32,
    width: Option<u32>,
    height: Option<u32>,
    max_depth: Option<u32>,
    seed: Option<u32>,
    reference_spp: u32,
    out: Option<PathBuf>,
) -> PyResult<Bound<'py, PyList>> {
    if max_spp == 0 || reference_spp == 0 {
        return Err(PyValueError::new_err(
            "max_spp and reference_spp: at least 1 sample per pixel",
        ));
    }
    let variants = match variants {
        Some(names) => names
            .iter()
            .map(|name| {
                Variant::parse(name).map_err(|e| PyValueError::new_err(format!("variants: {e}")))
            })
            .collect::<PyResult<Vec<_>>>()?,
        None => Variant::defaults(),
    };
    let scene = scene.get();
    let mut measured = scene.loaded.scene.clone();
    let (width, height) = session::converge::measured_size(&measured, width, height);
    measured
        .apply_overrides(&SceneOverrides {
            width: Some(width),
            height: Some(height),
            max_depth,
            seed,
            ..SceneOverrides::default()
        })
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let convergence_error = |e: ConvergeError| match e {
        ConvergeError::Input(_)
        | ConvergeError::ReferenceSize { .. }
        | ConvergeError::ReferenceSeed
        | ConvergeError::Unsupported(_) => PyValueError::new_err(e.to_string()),
        ConvergeError::Render(_) | ConvergeError::Output(_) => RenderError::new_err(e.to_string()),
    };
    let scene_bytes =
        session::converge::scene_bytes(&scene.path, &scene.defines).map_err(convergence_error)?;
    // Without a folder to keep it in, the reference is rendered for this call only.
    let scratch = match &out {
        Some(_) => None,
        None => Some(tempfile::tempdir().map_err(|e| {
            RenderError::new_err(format!("a temporary folder for the reference: {e}"))
        })?),
    };
    let out_dir = out
        .as_deref()
        .or(scratch.as_ref().map(|dir| dir.path()))
        .expect("a folder given or made");
    let study = Study {
        scene: &measured,
        scene_bytes: &scene_bytes,
        out_dir,
        variants: &variants,
        max_spp,
        reference: ReferenceChoice::Render { spp: reference_spp },
    };
    let (report, warnings) = py.detach(|| -> PyResult<_> {
        let mut warnings = Vec::new();
        let report = session::converge::run_study(gpu()?, &study, |event| {
            if let Event::Warning(warning) = event {
                warnings.push(warning);
            }
        })
        .map_err(convergence_error)?;
        Ok((report, warnings))
    })?;
    for warning in &warnings {
        warn(py, warning)?;
    }
    let rows = PyList::empty(py);
    for row in &report.rows {
        let entry = PyDict::new(py);
        entry.set_item("variant", &row.variant)?;
        entry.set_item("spp", row.spp)?;
        entry.set_item("seconds", row.seconds)?;
        entry.set_item("paths_per_second", row.paths_per_second)?;
        entry.set_item("rmse", row.rmse)?;
        entry.set_item("relative_rmse", row.relative_rmse)?;
        entry.set_item("relative_mse", row.relative_mse)?;
        entry.set_item("estimated_error", row.estimated_error)?;
        entry.set_item("efficiency", row.efficiency)?;
        rows.append(entry)?;
    }
    Ok(rows)
}

/// An image array (height, width, 3) of float32 as the library's image.
fn image_of(array: PyReadonlyArray3<'_, f32>) -> PyResult<Image> {
    let view = array.as_array();
    let (height, width, channels) = view.dim();
    if channels != 3 {
        return Err(PyValueError::new_err(format!(
            "image: expected shape (height, width, 3), got ({height}, {width}, {channels})"
        )));
    }
    let pixels = view
        .outer_iter()
        .flat_map(|row| {
            row.outer_iter()
                .map(|p| [p[0], p[1], p[2]])
                .collect::<Vec<_>>()
        })
        .collect();
    Ok(Image {
        width: width as u32,
        height: height as u32,
        pixels,
    })
}

/// Writes a linear float32 (height, width, 3) image as RGB OpenEXR, as the
/// command line's `--exr` does.
#[pyfunction]
fn write_exr(path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    let image = image_of(image)?;
    output::write_exr(&path, &image, &[]).map_err(|e| RenderError::new_err(e.to_string()))
}

/// Writes a linear float32 (height, width, 3) image as 8-bit sRGB PNG, as the
/// command line's `-o` does: scaled by 2^exposure, clamped to [0, 1].
#[pyfunction]
#[pyo3(signature = (path, image, exposure=0.0))]
fn write_png(path: PathBuf, image: PyReadonlyArray3<'_, f32>, exposure: f32) -> PyResult<()> {
    let image = image_of(image)?;
    output::write_png(&path, &image, exposure).map_err(|e| RenderError::new_err(e.to_string()))
}

/// Reads an RGB OpenEXR image (the command line's `--exr` or `--variance`
/// output) as a float32 (height, width, 3) array.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let image = output::read_exr(&path).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(array(py, &image))
}

#[pymodule]
fn _pathmix(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("RenderError", py.get_type::<RenderError>())?;
    m.add_class::<Scene>()?;
    m.add_class::<Run>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(converge, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_png, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    Ok(())
}
