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
