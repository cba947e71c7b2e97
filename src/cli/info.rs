//! `pathmix info`: what a scene uses, and therefore what its kernel contains.

use super::Failure;
use super::render::StrategyArg;
use clap::Args;
use pathmix::kernel::{ArrayMemory, SceneStorage};
use pathmix::kinds::PackedArray;
use pathmix::kinds::{MATERIAL_KINDS, PRIMITIVE_KINDS, packed_kind_id};
use pathmix::render::{KernelPlan, RenderOptions, max_samples_per_dispatch, plan_kernel};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene file (TOML, or Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Set the Mitsuba scene's `$NAME` parameter, as `mitsuba -D` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<pathmix::scene::mitsuba::Define>,
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

pub fn info(args: InfoArgs) -> Result<(), Failure> {
    let mut scene = super::load_scene(&args.scene, &args.define)?;
    if let Some(arg) = args.strategy {
        match arg.strategy() {
            Some(strategy) => {
                scene.render.strategy = strategy;
                scene.render.auto_strategy = false;
            }
            None => scene.render.auto_strategy = true,
        }
    }
    // A pilot chooses at render time; the kernel shown is the default strategy's.
    let auto = std::mem::take(&mut scene.render.auto_strategy);
    let strategy = scene.render.strategy;
    let (width, height) = (scene.camera.width, scene.camera.height);
    let ctx = super::open_gpu(args.adapter.as_deref())?;
    let options = RenderOptions {
        variance: args.variance,
        ..RenderOptions::default()
    };
    // The kernel `render` would build: the scene packed once, for all that follows.
    let KernelPlan {
        data,
        config,
        warnings,
        dropped_materials,
    } = plan_kernel(&ctx, &scene, &options).map_err(Failure::input)?;

    println!("scene: {}", scene.source);
    println!(
        "  camera {}x{}, {} spp, max depth {}, strategy {}, light weight {}, {} sampler, {}",
        width,
        height,
        scene.render.spp,
        scene.render.max_depth,
        match auto {
            true =>
                format!("auto (a pilot chooses when rendering; the kernel below is {strategy}'s)"),
            false => config.describe_strategy(),
        },
        scene.render.light_weight,
        scene.render.sampler,
        config.describe_filter(),
    );
    if !scene.render.aovs.is_empty() {
        let aovs: Vec<String> = scene.render.aovs.iter().map(|aov| aov.spec()).collect();
        println!(
            "  AOVs (in the EXR, by a pass of their own): {}",
            aovs.join(", ")
        );
    }
    let kinds: Vec<&str> = MATERIAL_KINDS
        .iter()
        .enumerate()
        .filter(|&(id, _)| data.materials.iter().any(|m| packed_kind_id(m) == id))
        .map(|(_, kind)| kind.name)
        .collect();
    let counts = |arrays: &[PackedArray]| -> Vec<String> {
        PRIMITIVE_KINDS
            .iter()
            .zip(arrays)
            .map(|(kind, array)| format!("{} {}", array.len(), kind.array))
            .collect()
    };
    let mut lights = counts(&data.lights);
    if let Some(map) = &scene.environment {
        lights.push(format!(
            "environment map {}x{} ({})",
            map.width, map.height, map.file
        ));
    }
    println!(
        "  {}, {} materials ({}); light density: {}",
        counts(&data.geometry.primitives).join(", "),
        data.materials.len(),
        kinds.join(", "),
        lights.join(", ")
    );
    if !scene.point_lights.is_empty() {
        let spots = scene
            .point_lights
            .iter()
            .filter(|l| l.spot.is_some())
            .count();
        let points = scene.point_lights.len() - spots;
        println!(
            "  delta lights: {points} point, {spots} spot (each vertex's shadow ray picks one by power, under every strategy)"
        );
        for (i, light) in scene.point_lights.iter().enumerate() {
            let [x, y, z] = light.position.to_array();
            let [r, g, b] = light.intensity.to_array();
            match light.spot {
                None => println!(
                    "    lights[{i}]: point at ({x}, {y}, {z}), intensity ({r}, {g}, {b}) W/sr"
                ),
                Some(spot) => {
                    let [dx, dy, dz] = spot.direction.to_array();
                    println!(
                        "    lights[{i}]: spot at ({x}, {y}, {z}) toward ({dx}, {dy}, {dz}), intensity ({r}, {g}, {b}) W/sr, cutoff {}°, beam width {}°",
                        spot.cutoff_angle, spot.beam_width
                    );
                }
            }
        }
    }
    if dropped_materials > 0 {
        println!("  {dropped_materials} materials no object uses: dropped before packing");
    }
    println!("kernel:");
    for warning in warnings {
        println!("  note: {warning}");
    }
    let flags: Vec<String> = config.flags().into_iter().collect();
    println!("  flags: {}", flags.join(" "));
    let modules: Vec<&str> = config.modules().iter().map(|m| m.name).collect();
    println!("  modules: {}", modules.join(", "));
    let constants: Vec<String> = config
        .constants()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    println!("  constants: {}", constants.join(" "));
    if config.grouped_light_kinds().next().is_some() {
        println!(
            "  emitting mesh faces: {}",
            config.grouped_density.describe()
        );
    }
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
    match config.scene_storage() {
        SceneStorage::Baked => println!(
            "scene data: compiled into the kernel as constants (at most {} objects are baked)",
            SceneStorage::MAX_BAKED_OBJECTS
        ),
        SceneStorage::Buffers => {
            println!("scene data: in memory, every ray testing every primitive")
        }
        SceneStorage::Bvh => {
            let bvh = data.bvh.as_ref().expect("a BVH kernel has a BVH");
            // The estimate walks the scene's own tree: an instance's group adds its own.
            let level = match data.instancing {
                Some(_) => " in the top level",
                None => "",
            };
            println!(
                "scene data: in memory with a BVH: {} nodes, depth {}, built in {:.3} s, \
                 at most {:.0} walk steps a ray on average{level}; {} large primitives tested beside it",
                bvh.nodes.len(),
                bvh.depth,
                bvh.build_seconds,
                bvh.expected_steps(),
                data.geometry.large.iter().sum::<usize>()
            );
            if let Some(instancing) = &data.instancing {
                println!(
                    "  two levels: {} instances over their groups' BVHs (the deepest {} levels), \
                     whose nodes and primitives are stored once, after the scene's",
                    instancing.records.len(),
                    instancing.group_depth + 1
                );
            }
        }
    }
    if !config.scene_bindings().is_empty() {
        println!(
            "  arrays read from {}",
            match config.array_memory {
                ArrayMemory::Textures => "textures (this driver reads them faster than buffers)",
                ArrayMemory::Buffers => "storage buffers",
            }
        );
    }
    let mut scene_bytes = 0;
    for array in config.scene_arrays() {
        let count = data.array_bytes(array.source).len() / array.element_size();
        scene_bytes += count * array.element_size();
        // Beside a BVH some arrays are compiled in (`KernelConfig::compiles_in`).
        let compiled = config.bvh() && config.compiles_in(array.source);
        let place = match () {
            _ if compiled => " (compiled in)",
            _ if config.in_texture(array.source) => " (texture)",
            _ => "",
        };
        println!(
            "  {}: {count} x {} B = {} B{place}",
            array.name.replace('_', " "),
            array.element_size(),
            count * array.element_size(),
        );
    }
    let triangles = scene.shapes.triangles.len();
    let per_triangle = match triangles {
        0 => String::new(),
        _ => format!(
            ": {:.1} B per triangle",
            scene_bytes as f64 / triangles as f64
        ),
    };
    println!(
        "  in all {scene_bytes} B{per_triangle}; {} mesh faces with no area dropped",
        scene.degenerate_triangles
    );
    let accumulator = config.accumulator;
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
        "  max textures a kernel reads: {}",
        limits.max_sampled_textures_per_shader_stage
    );
    println!(
        "  max workgroups per dimension: {}",
        limits.max_compute_workgroups_per_dimension
    );
    Ok(())
}
