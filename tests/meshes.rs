//! Triangle meshes from files: watertight furnaces, emissive triangles as
//! lights, the BVH against the loop over every primitive, and a real mesh.

mod common;

use pathmix::kernel::SceneStorage;
use pathmix::render::{RenderOptions, Renderer};
use pathmix::scene::{Scene, Strategy};
use std::fmt::Write;
use std::path::PathBuf;

macro_rules! gpu_or_skip {
    () => {
        match common::gpu() {
            Some(ctx) => ctx,
            None => return,
        }
    };
}

/// The white furnace of `scenes/furnace.toml` (a closed cube, albedo 0.5,
/// emission 1, normals inward) with its walls as an OBJ mesh of 12 triangles,
/// two per wall, sharing the walls' edges and corners.
fn furnace_mesh(name: &str, strategy: Strategy, spp: u32, max_depth: u32) -> Scene {
    let quads = common::scene_file("furnace.toml").quads;
    let mut obj = String::new();
    for (i, q) in quads.iter().enumerate() {
        for p in [q.q, q.q + q.u, q.q + q.u + q.v, q.q + q.v] {
            writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
        }
        // A quad face, fanned by the reader into (0 1 2) and (0 2 3): normals u x v.
        let base = 4 * i + 1;
        writeln!(obj, "f {} {} {} {}", base, base + 1, base + 2, base + 3).unwrap();
    }
    let path: PathBuf =
        std::env::temp_dir().join(format!("pathmix-{name}-{}.obj", std::process::id()));
    std::fs::write(&path, obj).unwrap();
    let text = format!(
        "[camera]\nlookfrom = [0, 0, 0]\nlookat = [0, 0, 1]\nvfov = 90\nwidth = 16\nheight = 16\n\
         [render]\nspp = {spp}\nmax_depth = {max_depth}\nstrategy = \"{strategy}\"\n\
         [materials.wall]\ntype = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\nemit = [1, 1, 1]\n\
         [[objects]]\ntype = \"mesh\"\nfile = {path:?}\nmaterial = \"wall\"\n"
    );
    let scene = Scene::parse(&text, "furnace-mesh.toml").unwrap();
    assert_eq!(scene.triangles.len(), 12);
    scene
}

/// BSDF sampling weighs each bounce by exactly the albedo, so every path that
/// stays inside sees exactly the analytic value; a ray slipping through an edge
/// or a corner shared by two triangles (the test is watertight) would escape to
/// the black background.
#[test]
fn mesh_furnace_bsdf_is_exact() {
    let ctx = gpu_or_skip!();
    let scene = furnace_mesh("exact", Strategy::Bsdf, 64, 4);
    let expected = common::furnace_value(1.0, 0.5, 4) as f32;
    for storage in [
        SceneStorage::Baked,
        SceneStorage::Buffers,
        SceneStorage::Bvh,
    ] {
        let options = RenderOptions {
            scene_storage: Some(storage),
            ..RenderOptions::default()
        };
        let acc = common::render(ctx, &scene, &options);
        common::assert_every_pixel_is(&acc, expected, 1e-6, &format!("{storage:?}"));
    }
}

/// Emissive triangles are in the light density: the mixture, light sampling and
/// next-event estimation aim at them and stay unbiased.
#[test]
fn emissive_triangles_are_sampled_without_bias() {
    let ctx = gpu_or_skip!();
    let expected = common::furnace_value(1.0, 0.5, 4);
    for strategy in [Strategy::Mixture, Strategy::Light, Strategy::NeeMis] {
        let scene = furnace_mesh("lights", strategy, 256, 4);
        let renderer = Renderer::new(ctx, &scene, &common::with_variance()).unwrap();
        assert!(
            renderer.config().samples_lights(),
            "{strategy}: no light sampling"
        );
        let acc = common::render(ctx, &scene, &common::with_variance());
        let (mean, error) = common::image_mean_and_error(&acc);
        assert!(error > 0.0, "{strategy}: no noise at all");
        assert!(
            (mean - expected).abs() < 4.0 * error,
            "{strategy}: {mean} ± {error}, expected {expected}"
        );
    }
}

/// Mitsuba's Stanford bunny (69 451 triangles, binary PLY) from `../shared/`,
/// in the book's Cornell box: it loads, goes through the BVH, and renders a
/// finite image whose every invocation finishes.
#[test]
fn stanford_bunny_renders_through_the_bvh() {
    let ctx = gpu_or_skip!();
    let bunny = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/mitsuba-scenes/meshes/bunny.ply");
    if !bunny.exists() {
        eprintln!("skipped: {} is not there", bunny.display());
        return;
    }
    let mut text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-boxes.toml"),
    )
    .unwrap();
    write!(
        text,
        "\n[[objects]]\ntype = \"mesh\"\nfile = {:?}\nmaterial = \"white\"\nscale = 1800\n\
         rotate_y = 200\ntranslate = [290, -59.4, 300]\n",
        bunny.display().to_string()
    )
    .unwrap();
    let mut scene = Scene::parse(&text, "bunny.toml").unwrap();
    scene.camera.width = 32;
    scene.camera.height = 32;
    scene.render.spp = 4;
    scene.render.max_depth = 6;
    assert!(scene.triangles.len() + scene.degenerate_triangles == 69_451);
    let mut renderer = Renderer::new(ctx, &scene, &RenderOptions::default()).unwrap();
    assert_eq!(renderer.config().scene_storage(), SceneStorage::Bvh);
    while renderer.samples() < scene.render.spp {
        renderer.advance(scene.render.spp - renderer.samples());
    }
    let counters = renderer.check_counters().unwrap();
    assert_eq!(counters.discarded, 0);
    let mean = renderer.accumulation().mean();
    assert!(mean.pixels.iter().flatten().all(|c| c.is_finite()));
}
