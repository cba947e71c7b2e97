//! `pathmix info`: what a scene uses, and therefore what its kernel contains.

use super::Failure;
use super::render::StrategyArg;
use clap::Args;
use pathmix::gpu::GpuContext;
use pathmix::gpu::layout::{Material, Quad, Sphere};
use pathmix::kernel::{KernelConfig, SceneStorage};
use pathmix::render::{choose_accumulator, max_samples_per_dispatch, prepare_scene};
use pathmix::scene::{MaterialKind, Scene, Strategy};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Show the kernel for this strategy [scene: render.strategy].
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// Also accumulate squared samples (as --variance / --target-error do).
    #[arg(long)]
    pub variance: bool,
    /// Use the first adapter whose name contains NAME [env: PATHMIX_ADAPTER].
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
}

fn bytes<T>(count: usize) -> String {
    format!(
        "{count} x {} B = {} B",
        size_of::<T>(),
        count * size_of::<T>()
    )
}

pub fn info(args: InfoArgs) -> Result<(), Failure> {
    let scene = Scene::load(&args.scene).map_err(Failure::input)?;
    let strategy = args.strategy.map_or(scene.render.strategy, Strategy::from);
    let (data, effective, warnings) = prepare_scene(&scene, strategy).map_err(Failure::input)?;
    let (width, height) = (scene.camera.width, scene.camera.height);

    println!("scene: {}", scene.source);
    println!(
        "  camera {}x{}, {} spp, max depth {}, strategy {}, light weight {}, {} sampler",
        width,
        height,
        scene.render.spp,
        scene.render.max_depth,
        strategy,
        scene.render.light_weight,
        scene.render.sampler
    );
    let kinds: Vec<&str> = ["lambertian", "metal", "dielectric", "light"]
        .into_iter()
        .filter(|kind| {
            scene.materials.iter().any(|m| {
                matches!(
                    (m.kind, *kind),
                    (MaterialKind::Lambertian, "lambertian")
                        | (MaterialKind::Metal { .. }, "metal")
                        | (MaterialKind::Dielectric { .. }, "dielectric")
                        | (MaterialKind::Light, "light")
                )
            })
        })
        .collect();
    println!(
        "  {} quads, {} spheres, {} materials ({}); light density: {} quads, {} spheres",
        data.quads.len(),
        data.spheres.len(),
        data.materials.len(),
        kinds.join(", "),
        data.light_quads.len(),
        data.light_spheres.len()
    );

    let ctx = GpuContext::new(args.adapter.as_deref()).map_err(Failure::runtime)?;
    let accumulator = choose_accumulator(&ctx, None, width, height).map_err(Failure::input)?;
    let storage = SceneStorage::auto(&data);
    let config = KernelConfig::for_scene(
        &data,
        effective,
        &scene.render,
        accumulator,
        args.variance,
        storage,
    );
    println!("kernel:");
    for warning in warnings {
        println!("  note: {warning}");
    }
    let flags: Vec<&str> = config.flags().into_iter().collect();
    println!("  flags: {}", flags.join(" "));
    let modules: Vec<&str> = config.modules().iter().map(|m| m.name).collect();
    println!("  modules: {}", modules.join(", "));
    let constants: Vec<String> = config
        .constants()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    println!("  constants: {}", constants.join(" "));
    let source = config.source().map_err(Failure::runtime)?;
    println!(
        "  composed WGSL: {} lines, {} bytes",
        source.lines().count(),
        source.len()
    );
    println!(
        "  at most {} samples per pixel per dispatch (driver loop-limit budget)",
        max_samples_per_dispatch(&data, &config)
    );
    match storage {
        SceneStorage::Baked => println!(
            "scene data: compiled into the kernel as constants (at most {} objects are baked)",
            SceneStorage::MAX_BAKED_OBJECTS
        ),
        SceneStorage::Buffers => println!("scene data: storage buffers"),
    }
    println!("  materials: {}", bytes::<Material>(data.materials.len()));
    if config.quads {
        println!("  quads: {}", bytes::<Quad>(data.quads.len()));
    }
    if config.spheres {
        println!("  spheres: {}", bytes::<Sphere>(data.spheres.len()));
    }
    if config.light_quads {
        println!("  light quads: {}", bytes::<Quad>(data.light_quads.len()));
    }
    if config.light_spheres {
        println!(
            "  light spheres: {}",
            bytes::<Sphere>(data.light_spheres.len())
        );
    }
    let layers = config.accumulator_layers() as u64;
    println!(
        "  accumulator ({:?}): {width} x {height} x {layers} layers x 16 B = {} B",
        accumulator,
        width as u64 * height as u64 * layers * 16
    );
    let limits = ctx.limits();
    println!("adapter: {}", ctx.describe());
    println!(
        "  read-write rgba32float storage textures: {}",
        ctx.storage_texture_accumulator
    );
    println!(
        "  max texture dimension: {}",
        limits.max_texture_dimension_2d
    );
    println!(
        "  max storage buffer binding: {} B",
        limits.max_storage_buffer_binding_size
    );
    println!("  max buffer size: {} B", limits.max_buffer_size);
    println!(
        "  max workgroups per dimension: {}",
        limits.max_compute_workgroups_per_dimension
    );
    Ok(())
}
