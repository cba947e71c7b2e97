//! Shared by the integration test files: one device per test process, the test
//! data kept outside the repository, temporary folders, and small helpers.
#![allow(dead_code)] // each test file uses a different subset

use pathmix::gpu::GpuContext;
use pathmix::render::{RenderOptions, Renderer};
use pathmix::scene::{Sampler, Scene, SceneOverrides};
use pathmix::stats::Accumulation;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Runs the `pathmix` command line with `args`, to its end.
pub fn pathmix(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_pathmix"))
        .args(args)
        .output()
        .unwrap()
}

/// The device shared by every test of this process, or `None` (test skipped)
/// when there is none and `PATHMIX_REQUIRE_GPU` is not `1`.
pub fn gpu() -> Option<&'static GpuContext> {
    static CONTEXT: OnceLock<Option<GpuContext>> = OnceLock::new();
    CONTEXT
        .get_or_init(|| match GpuContext::new(None) {
            Ok(ctx) => Some(ctx),
            Err(e) if std::env::var("PATHMIX_REQUIRE_GPU").as_deref() == Ok("1") => {
                panic!("PATHMIX_REQUIRE_GPU=1 but no adapter: {e}")
            }
            Err(e) => {
                eprintln!("skipping GPU tests: {e}");
                None
            }
        })
        .as_ref()
}

/// Returns from the test (skipping it) when there is no device.
#[macro_export]
macro_rules! gpu_or_skip {
    () => {
        match common::gpu() {
            Some(ctx) => ctx,
            None => return,
        }
    };
}

/// The folder of the test data too large for the repository (`mitsuba-scenes/`,
/// `scenes-bitterli/`): the one `PATHMIX_SHARED` names when set (the only place
/// looked then; relative to the package root, where tests run), else `../shared`
/// beside the repository.
pub fn shared_dir() -> PathBuf {
    match std::env::var_os("PATHMIX_SHARED").filter(|dir| !dir.is_empty()) {
        // Absolute, so that scene files written elsewhere can name files in it.
        Some(dir) => std::env::current_dir().unwrap().join(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"),
    }
}

/// The file (or folder) `relative` under `shared_dir()`, or `None` when it is
/// missing: the test is then skipped, saying so in one line on stderr, or, when
/// `PATHMIX_REQUIRE_SHARED` is `1` (as in CI), fails, so that a run meant to
/// use the data cannot pass without it.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let path = shared_dir().join(relative);
    if path.exists() {
        return Some(path);
    }
    // libtest runs each test on a thread named after it.
    let test = std::thread::current()
        .name()
        .unwrap_or("a test")
        .to_string();
    let how = "put the shared test data in ../shared beside the repository, \
               or name its folder in PATHMIX_SHARED";
    if std::env::var("PATHMIX_REQUIRE_SHARED").as_deref() == Ok("1") {
        panic!(
            "PATHMIX_REQUIRE_SHARED=1 but {} is missing ({how})",
            path.display()
        );
    }
    let line = format!(
        "skipped {test}: {} is missing ({how}; PATHMIX_REQUIRE_SHARED=1 makes this a failure)\n",
        path.display()
    );
    // Straight to stderr rather than by eprintln!, which the test harness captures
    // and hides for a passing test: the skip shows in a plain `cargo test` run. One
    // write, so that the line stays whole among other tests' output.
    std::io::Write::write_all(&mut std::io::stderr(), line.as_bytes()).unwrap();
    None
}

/// The shared data file `relative` (see `shared_file`), or returns from the test
/// (skipping it) when it is missing.
#[macro_export]
macro_rules! shared_or_skip {
    ($relative:expr) => {
        match common::shared_file($relative) {
            Some(path) => path,
            None => return,
        }
    };
}

/// A copy in `dir` of the repository's scene file `fixture`, its paths into the
/// shared data (written `"../../../shared/..."`, relative to the fixture, for the
/// scripts and people that read it beside a checkout) replaced by the files
/// `shared_file` finds, so that a test reads the data wherever `PATHMIX_SHARED`
/// puts it. `None` (the test skipped, as by `shared_file`) when one is missing.
/// The fixture must name no other relative path: the copy is elsewhere.
pub fn fixture_reading_shared(fixture: &str, dir: &Path) -> Option<PathBuf> {
    const SHARED: &str = "\"../../../shared/";
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join(fixture);
    let text = std::fs::read_to_string(&source).unwrap();
    let mut copy = String::with_capacity(text.len());
    let mut rest = text.as_str();
    while let Some(at) = rest.find(SHARED) {
        copy.push_str(&rest[..at]);
        let after = &rest[at + SHARED.len()..];
        let end = after.find('"').expect("a quoted path");
        let path = shared_file(&after[..end])?;
        write!(copy, "{:?}", path.to_str().unwrap()).unwrap();
        rest = &after[end + 1..];
    }
    copy.push_str(rest);
    let path = dir.join(source.file_name().unwrap());
    std::fs::write(&path, copy).unwrap();
    Some(path)
}

pub fn scene_file(name: &str) -> Scene {
    Scene::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(name),
    )
    .unwrap()
}

/// A shipped scene with some settings overridden (small sizes keep GPU tests fast).
pub fn scene_with(name: &str, overrides: SceneOverrides) -> Scene {
    let mut scene = scene_file(name);
    scene.apply_overrides(&overrides).unwrap();
    scene
}

/// The Cornell boxes at `size`×`size`, max depth 8: small enough to render
/// thousands of samples per pixel within a test.
pub fn small_cornell_boxes(size: u32, sampler: Sampler) -> Scene {
    scene_with(
        "cornell-boxes.toml",
        SceneOverrides {
            width: Some(size),
            height: Some(size),
            max_depth: Some(8),
            sampler: Some(sampler),
            ..Default::default()
        },
    )
}

/// A one-pixel camera at the origin looking down +z through a `vfov`-degree view at
/// one quad of `emit` radiance (`q`, `u`, `v` as in a scene file), at depth 0:
/// every sample is `emit` where the jittered camera ray meets the quad, else 0.
pub fn camera_facing_emitter(
    vfov: f32,
    spp: u32,
    emit: f32,
    q: [f32; 3],
    u: [f32; 3],
    v: [f32; 3],
) -> Scene {
    scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, 1]
        vfov = {vfov}
        width = 1
        height = 1
        [render]
        spp = {spp}
        max_depth = 0
        [materials.glow]
        type = "light"
        emit = [{emit}, {emit}, {emit}]
        [[objects]]
        type = "quad"
        q = {q:?}
        u = {u:?}
        v = {v:?}
        material = "glow"
        "#
    ))
}

pub fn scene_text(text: &str) -> Scene {
    Scene::parse(text, "test.toml").unwrap()
}

/// Under each strategy, renders a tiny patch at the origin of a Lambertian floor
/// (the y = 0 plane, albedo `albedo`) seen straight down from `camera_height` (a
/// 4x4 image of a 0.2 degree field, direct light only, 4096 independent samples
/// per pixel), lit by `lights` (objects of the `lamp` material, which emits
/// `emit`, and `[[lights]]`), and asserts the patch's mean radiance is `expected`
/// within 4 standard errors (plus 1e-4 relative).
pub fn assert_lit_floor(
    ctx: &GpuContext,
    (albedo, emit, camera_height): (f64, f64, f64),
    lights: &str,
    expected: f64,
    what: &str,
) {
    let lamp = format!(
        r#"
        [materials.lamp]
        type = "light"
        emit = [{emit}, {emit}, {emit}]
        "#
    );
    assert_floor_patch(
        ctx,
        (albedo, camera_height),
        &format!("{lamp}\n{lights}"),
        (expected, 0.0),
        what,
    );
}

/// `assert_lit_floor`'s floor patch lit by `scene` (materials, objects and
/// lights of the caller's own), its mean asserted within 4 standard errors plus
/// 1e-4 relative plus `absolute`.
pub fn assert_floor_patch(
    ctx: &GpuContext,
    (albedo, camera_height): (f64, f64),
    scene: &str,
    (expected, absolute): (f64, f64),
    what: &str,
) {
    for strategy in ["bsdf", "light", "mixture", "nee-mis"] {
        let scene = floor_patch_scene((albedo, camera_height), strategy, 4096, scene);
        let acc = render(ctx, &scene, &with_variance());
        let (mean, error) = image_mean_and_error(&acc);
        println!("{what} {strategy}: {mean:.6} ± {error:.6}, expected {expected:.6}");
        assert!(
            (mean - expected).abs() < 4.0 * error + 1e-4 * expected + absolute,
            "{what} {strategy}: {mean} ± {error} against {expected}"
        );
    }
}

/// The floor patch of [`assert_floor_patch`] under `strategy` with `spp`
/// independent samples per pixel, lit by `scene` (materials, objects and lights
/// of the caller's own, after the floor).
pub fn floor_patch_scene(
    (albedo, camera_height): (f64, f64),
    strategy: &str,
    spp: u32,
    scene: &str,
) -> Scene {
    scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, {camera_height}, 0]
        lookat = [0, 0, 0]
        vup = [0, 0, -1]
        vfov = 0.2
        width = 4
        height = 4
        [render]
        spp = {spp}
        max_depth = 1
        strategy = "{strategy}"
        sampler = "independent"
        [materials.floor]
        type = "lambertian"
        albedo = [{albedo}, {albedo}, {albedo}]
        [[objects]]
        type = "quad"
        q = [-10, 0, -10]
        u = [0, 0, 20]
        v = [20, 0, 0]
        material = "floor"
        {scene}
        "#
    ))
}

/// Renders `scene.render.spp` samples and returns the sums.
pub fn render(ctx: &GpuContext, scene: &Scene, options: &RenderOptions) -> Accumulation {
    let mut renderer = Renderer::new(ctx, scene, options).unwrap();
    while renderer.samples() < scene.render.spp {
        renderer.advance(scene.render.spp - renderer.samples());
    }
    let counters = renderer.counters();
    assert_eq!(counters.discarded, 0, "NaN or infinite samples");
    assert_eq!(counters.truncated, 0, "invocations cut short");
    renderer.accumulation()
}

pub fn with_variance() -> RenderOptions {
    RenderOptions {
        variance: true,
        ..RenderOptions::default()
    }
}

/// Mean over the image of the per-pixel channel mean, and its standard error from
/// the per-pixel sample variances (pixels are independent).
///
/// The channels of one sample are not independent (in a grey scene they are
/// equal), and the sums hold no cross-channel covariances, so a pixel's variance
/// is bounded by Cauchy-Schwarz: `Var(mean of channels) <= mean of channel
/// variances`, with equality when the channels are equal. (Summing the channel
/// variances as if independent understates the error by up to sqrt(3).)
pub fn image_mean_and_error(acc: &Accumulation) -> (f64, f64) {
    let n = acc.samples as f64;
    let sum_sq = acc.sum_sq.as_ref().expect("render with variance");
    let pixels = acc.sum.len() as f64;
    let mut mean = 0.0;
    let mut variance_of_mean = 0.0;
    for (sum, sq) in acc.sum.iter().zip(sum_sq) {
        for c in 0..3 {
            let m = sum[c] / n;
            let sample_variance = (sq[c] - n * m * m).max(0.0) / (n - 1.0);
            mean += m / (3.0 * pixels);
            variance_of_mean += sample_variance / 3.0 / n / (pixels * pixels);
        }
    }
    (mean, variance_of_mean.sqrt())
}

/// The white furnace's pixel value: E (1 + a + ... + a^max_depth) for emission E
/// and albedo a.
pub fn furnace_value(emit: f64, albedo: f64, max_depth: u32) -> f64 {
    (0..=max_depth).map(|k| emit * albedo.powi(k as i32)).sum()
}

/// Every channel of every pixel of the mean is `expected` within relative `tolerance`.
pub fn assert_every_pixel_is(acc: &Accumulation, expected: f32, tolerance: f32, what: &str) {
    for pixel in acc.mean().pixels {
        for channel in pixel {
            assert!(
                (channel - expected).abs() <= tolerance * expected,
                "{what}: {channel} != {expected}"
            );
        }
    }
}

/// A fresh folder under the system's temporary one, named `pathmix-{prefix}-{name}-`
/// and a random suffix, removed with everything in it when dropped.
pub struct TempDir(tempfile::TempDir);

impl TempDir {
    pub fn new(prefix: &str, name: &str) -> TempDir {
        let dir = tempfile::Builder::new()
            .prefix(&format!("pathmix-{prefix}-{name}-"))
            .tempdir()
            .unwrap();
        TempDir(dir)
    }
}

impl std::ops::Deref for TempDir {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

/// Writes a `width` x `height` RGB EXR whose texel (x, y) is `texel(x, y)`.
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    texel: impl Fn(usize, usize) -> [f32; 3] + Sync,
) {
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let [r, g, b] = texel(x, y);
        (r, g, b)
    })
    .unwrap();
}

/// Pearson's statistic over the cells, those expecting fewer than 5 samples
/// pooled into one (as pbrt and Mitsuba do), and its p-value. A pool still
/// expecting fewer than 5 is left out, unless it holds clearly more samples
/// than that: samples where the density says there are almost none.
pub fn chi_square_p_value(observed: &[f64], expected: &[f64]) -> f64 {
    let (mut statistic, mut cells) = (0.0, 0usize);
    let (mut pooled_observed, mut pooled_expected) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pooled_observed += o;
            pooled_expected += e;
        } else {
            statistic += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled_expected >= 5.0 {
        statistic += (pooled_observed - pooled_expected).powi(2) / pooled_expected;
        cells += 1;
    } else if pooled_observed > 10.0 + 4.0 * pooled_expected.sqrt() {
        return 0.0;
    }
    chi_square_survival(statistic, cells.saturating_sub(1).max(1) as f64)
}

/// P(X >= x) for X chi-square with `dof` degrees of freedom: the regularised
/// upper incomplete gamma Q(dof / 2, x / 2), by its series below a + 1 and its
/// continued fraction above (Numerical Recipes, 6.2).
pub fn chi_square_survival(x: f64, dof: f64) -> f64 {
    let (a, x) = (dof / 2.0, x / 2.0);
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = -x + a * x.ln() - libm::lgamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * log_prefactor.exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        log_prefactor.exp() * h
    }
}

/// A storage buffer holding `contents`, for a probe kernel's inputs.
pub fn storage(ctx: &GpuContext, contents: &[u8]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("probe"),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
}

/// The `vec4<f32>` array a probe kernel (a part of the kernel run on its own)
/// writes, and the buffer it is read back through.
pub struct ProbeOutput {
    pub buffer: wgpu::Buffer,
    staging: wgpu::Buffer,
}

impl ProbeOutput {
    pub fn new(ctx: &GpuContext, vec4s: u64) -> ProbeOutput {
        let buffer = |label, usage| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: vec4s * 16,
                usage,
                mapped_at_creation: false,
            })
        };
        ProbeOutput {
            buffer: buffer(
                "probe out",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            ),
            staging: buffer(
                "probe readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
        }
    }

    /// Submits `encoder` (the probe's passes), then reads the output back.
    pub fn read(&self, ctx: &GpuContext, mut encoder: wgpu::CommandEncoder) -> Vec<[f32; 4]> {
        encoder.copy_buffer_to_buffer(&self.buffer, 0, &self.staging, 0, self.staging.size());
        ctx.queue.submit([encoder.finish()]);
        pathmix::gpu::accumulator::map_read(ctx, &self.staging, bytemuck::pod_collect_to_vec)
    }
}

/// Renders `width` x 1 pixels across a vertical light edge through the image
/// centre with the pixel filter `filter` (its TOML value) applied by
/// `reconstruction` (`render.reconstruction`), `spp` samples, and
/// asserts pixel `k`'s value is `share(-d)` within 4 standard errors, `d` its
/// centre's distance from the edge in pixels: the filter's share on the
/// light's side. Pixels `radius` or more beyond the edge are exactly 0.
pub fn assert_light_edge(
    ctx: &GpuContext,
    (width, spp): (u32, u32),
    (filter, reconstruction): (&str, &str),
    radius: f64,
    share: impl Fn(f64) -> f64,
    what: &str,
) {
    // The camera at the origin looks down +z, so the image's right is world
    // -x: a light on world x >= 0 fills the image's left half.
    let scene = scene_text(&format!(
        r#"
        [camera]
        lookfrom = [0, 0, 0]
        lookat = [0, 0, 1]
        vfov = 5
        width = {width}
        height = 1
        filter = {filter}
        [render]
        spp = {spp}
        max_depth = 0
        sampler = "independent"
        reconstruction = "{reconstruction}"
        [materials.glow]
        type = "light"
        emit = [1, 1, 1]
        [[objects]]
        type = "quad"
        q = [0, -10, 1]
        u = [0, 20, 0]
        v = [10, 0, 0]
        material = "glow"
        "#
    ));
    let acc = render(ctx, &scene, &with_variance());
    let (mean, se) = (acc.mean(), acc.standard_error().unwrap());
    for k in 0..width {
        let d = f64::from(k) + 0.5 - f64::from(width) / 2.0;
        let expected = share(-d);
        let (value, error) = (f64::from(mean.get(k, 0)[0]), f64::from(se.get(k, 0)[0]));
        println!("{what} pixel {k}: {value:.5} ± {error:.5}, expected {expected:.5}");
        if d >= radius {
            assert_eq!(value, 0.0, "{what}: pixel {k} is beyond the filter's reach");
        } else {
            assert!(
                (value - expected).abs() <= 4.0 * error + 1e-6,
                "{what} pixel {k}: {value} against {expected} (standard error {error:.2e})"
            );
        }
    }
}

/// Every channel of an EXR by name (f32 or f16 samples).
pub fn exr_channels(path: &Path) -> std::collections::BTreeMap<String, Vec<f32>> {
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    image
        .layer_data
        .channel_data
        .list
        .into_iter()
        .map(|channel| {
            let values = match channel.sample_data {
                FlatSamples::F32(v) => v,
                FlatSamples::F16(v) => v.into_iter().map(f32::from).collect(),
                FlatSamples::U32(v) => v.into_iter().map(|x| x as f32).collect(),
            };
            (channel.name.to_string(), values)
        })
        .collect()
}
