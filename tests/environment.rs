//! Environment maps (`[environment]`): furnaces and analytic irradiance under
//! every strategy, the sampler against its density (chi-square), and the
//! extremes (one texel, a sun 1e6 times the sky, a large map).

mod common;

use pathmix::render::RenderOptions;
use pathmix::scene::{Scene, Strategy};
use std::path::{Path, PathBuf};

/// A temporary directory removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("pathmix-env-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Writes a `width` x `height` RGB EXR whose texel (x, y) is `texel(x, y)`.
fn write_exr(
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

/// A scene of `body` (materials and objects) under `[environment]` `environment`,
/// written next to the map in `dir`, seen by a `size`² camera from `lookfrom` toward the origin.
fn scene(
    dir: &Path,
    environment: &str,
    body: &str,
    render: &str,
    lookfrom: [f32; 3],
    size: u32,
) -> Scene {
    let text = format!(
        "[camera]\nlookfrom = {lookfrom:?}\nlookat = [0, 0, 0]\nvup = [0, 0, 1]\nvfov = 40\nwidth = {size}\nheight = {size}\n\
         [render]\n{render}\n[environment]\n{environment}\n{body}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap()
}

const WHITE_SPHERE: &str = r#"
[materials.white]
type = "lambertian"
albedo = [1, 1, 1]
[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "white"
"#;

fn options() -> RenderOptions {
    common::with_variance()
}

/// A white sphere (albedo 1) under a map of constant radiance 1 is 1
/// everywhere: a convex surface reflects every ray to the sky, so each path is
/// one bounce at most. Exact under `bsdf` (every weight is 1); the others within
/// 4 standard errors (independent sampler: the error estimate is unbiased).
#[test]
fn constant_map_furnace() {
    let ctx = gpu_or_skip!();
    let dir = TempDir::new("furnace");
    write_exr(&dir.0.join("one.exr"), 8, 4, |_, _| [1.0, 1.0, 1.0]);
    for strategy in [
        Strategy::Bsdf,
        Strategy::Mixture,
        Strategy::NeeMis,
        Strategy::Light,
    ] {
        let render = format!(
            "spp = 64\nmax_depth = 8\nstrategy = \"{strategy}\"\nsampler = \"independent\""
        );
        let s = scene(
            &dir.0,
            "file = \"one.exr\"",
            WHITE_SPHERE,
            &render,
            [0.0, -4.0, 0.0],
            16,
        );
        let acc = common::render(ctx, &s, &options());
        let (mean, error) = common::image_mean_and_error(&acc);
        eprintln!("{strategy}: {mean} +- {error}");
        if strategy == Strategy::Bsdf {
            common::assert_every_pixel_is(&acc, 1.0, 1e-6, "bsdf");
        } else {
            assert!(
                (mean - 1.0).abs() <= 4.0 * error,
                "{strategy}: {mean} +- {error}"
            );
        }
    }
}

/// The irradiance-derived radiance of a white (albedo 1) diffuse plane whose
/// normal is map-space +y under a map `height` rows high (even: the equator is a
/// row edge) whose texel is `texel(x, y)`: each cell of the upper hemisphere
/// gives `L dphi (z_top^2 - z_bottom^2) / 2` of irradiance, over pi.
fn plane_radiance(
    width: usize,
    height: usize,
    texel: &dyn Fn(usize, usize) -> [f32; 3],
) -> [f64; 3] {
    assert!(height % 2 == 0);
    let mut out = [0.0; 3];
    let edge = |y: usize| pathmix::scene::envmap::row_edge(y as u32, height as u32);
    for y in 0..height / 2 {
        let (z_top, z_bottom) = (
            (std::f64::consts::PI * edge(y)).cos(),
            (std::f64::consts::PI * edge(y + 1)).cos(),
        );
        let weight = 2.0 * std::f64::consts::PI / width as f64
            * (z_top * z_top - z_bottom.max(0.0).powi(2))
            / 2.0;
        for x in 0..width {
            let l = texel(x, y);
            for c in 0..3 {
                out[c] += l[c] as f64 * weight / std::f64::consts::PI;
            }
        }
    }
    out
}

/// A large white plane through the origin facing `normal`, seen from 1 above it.
fn plane(normal: [f32; 3]) -> (String, [f32; 3]) {
    let n = glam::Vec3::from(normal);
    let (u, v) = n.any_orthonormal_pair();
    let (u, v) = if u.cross(v).dot(n) > 0.0 {
        (u, v)
    } else {
        (v, u)
    };
    let (u, v) = (u * 200.0, v * 200.0);
    let q = -(u + v) / 2.0;
    (
        format!(
            "[materials.white]\ntype = \"lambertian\"\nalbedo = [1, 1, 1]\n[[objects]]\ntype = \"quad\"\n\
             q = {:?}\nu = {:?}\nv = {:?}\nmaterial = \"white\"\n",
            q.to_array(),
            u.to_array(),
            v.to_array()
        ),
        n.to_array(),
    )
}

/// Renders `scene` and checks its mean against `expected` (grey) within 4
/// standard errors (independent sampler), or to 1e-5 relative when `exact`.
fn check_mean(ctx: &pathmix::gpu::GpuContext, s: &Scene, expected: f64, what: &str) {
    let acc = common::render(ctx, s, &options());
    let (mean, error) = common::image_mean_and_error(&acc);
    eprintln!("{what}: {mean} +- {error} (expected {expected})");
    assert!(
        (mean - expected).abs() <= 4.0 * error + 1e-5 * expected,
        "{what}: {mean} +- {error}, expected {expected}"
    );
}

const STRATEGIES: [Strategy; 3] = [Strategy::Bsdf, Strategy::Mixture, Strategy::NeeMis];

fn render_settings(strategy: Strategy, spp: u32) -> String {
    format!("spp = {spp}\nmax_depth = 1\nstrategy = \"{strategy}\"\nsampler = \"independent\"")
}

/// Upward planes under maps bright in bands of rows (the v convention and the
/// row edges), and sideways planes under maps bright in ranges of columns (the
/// u convention: u = 0 looks down -z, u = 1/4 down +x), with rotations (the map
/// turned by `to_world`, not its inverse): each plane's radiance is analytic.
#[test]
fn planes_under_banded_maps_match_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let dir = TempDir::new("bands");
    // Two bands of the upper hemisphere: the polar cap (v < 1/6) and the rest.
    let bands = |_: usize, y: usize| match y {
        0 => [3.0, 3.0, 3.0],
        1 => [1.0, 1.0, 1.0],
        _ => [0.0, 0.0, 0.0],
    };
    write_exr(&dir.0.join("bands.exr"), 8, 4, bands);
    let cap = plane_radiance(8, 4, &bands)[0];
    // The cap holds 1/4 of the cosine-weighted hemisphere: 3/4 + 3/4.
    assert!((cap - 1.5).abs() < 1e-12, "{cap}");
    // Columns 0..4 of 8: u in [0, 1/2), azimuths from -z through +x to +z.
    write_exr(&dir.0.join("half.exr"), 8, 4, |x, _| {
        if x < 4 { [1.0; 3] } else { [0.0; 3] }
    });
    let cases: [(&str, &str, [f32; 3], f64); 6] = [
        (
            "bands, map +y up",
            "file = \"bands.exr\"",
            [0.0, 1.0, 0.0],
            cap,
        ),
        (
            "bands turned onto +z",
            "file = \"bands.exr\"\nrotate = { axis = [1, 0, 0], angle = 90 }",
            [0.0, 0.0, 1.0],
            cap,
        ),
        (
            "half, facing +x",
            "file = \"half.exr\"",
            [1.0, 0.0, 0.0],
            1.0,
        ),
        (
            "half, facing -x",
            "file = \"half.exr\"",
            [-1.0, 0.0, 0.0],
            0.0,
        ),
        (
            "half, facing -z",
            "file = \"half.exr\"",
            [0.0, 0.0, -1.0],
            0.5,
        ),
        // rotate_y 90 (the book's) carries map +x to world -z.
        (
            "half turned, facing -z",
            "file = \"half.exr\"\nrotate_y = 90",
            [0.0, 0.0, -1.0],
            1.0,
        ),
    ];
    for (what, environment, normal, expected) in cases {
        let (body, n) = plane(normal);
        for strategy in STRATEGIES {
            let lookfrom = [n[0] * 1.0 + 0.01, n[1] * 1.0 + 0.02, n[2] * 1.0 + 0.03];
            let s = scene(
                &dir.0,
                environment,
                &body,
                &render_settings(strategy, 64),
                lookfrom,
                8,
            );
            check_mean(ctx, &s, expected, &format!("{what}, {strategy}"));
        }
    }
}
