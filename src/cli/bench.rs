//! `pathmix bench`: the speed figures used to track performance.

use super::Failure;
use clap::Args;
use pathmix::gpu::GpuContext;
use pathmix::kernel::{AccumulatorKind, ArrayMemory, SceneStorage};
use pathmix::pack::SceneData;
use pathmix::render::RenderOptions;
use pathmix::scene::{self, Sampler, Scene, SceneOverrides, Strategy};
use pathmix::session::bench::{self, Measurement};
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Fewer samples and repetitions: a smoke test of the figures, not a measurement.
    #[arg(long)]
    pub quick: bool,
    /// Repetitions per configuration (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub repetitions: usize,
    /// Skip the time-to-first-sample measurement (it starts child processes).
    #[arg(long)]
    pub no_startup: bool,
    /// Use the first adapter whose name contains NAME [env: PATHMIX_ADAPTER].
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Print the scale curve's field of N spheres as a scene file (TOML) and
    /// exit, to render it elsewhere (e.g. against Mitsuba with
    /// scripts/compare-mitsuba.py).
    #[arg(long, value_name = "N")]
    pub write_sphere_field: Option<usize>,
    /// Instead of the speed figures: per stage of the path loop, the work per
    /// path and the share of SIMD lanes active, on SCENEs or the real scenes
    /// (`../shared`, skipped where missing) and the book's boxes.
    #[arg(long)]
    pub stages: bool,
    /// With `--stages`: the scenes to profile (TOML or Mitsuba XML), at their
    /// own sizes.
    #[arg(requires = "stages")]
    pub scenes: Vec<PathBuf>,
}

struct Case {
    scene: &'static str,
    width: u32,
    height: u32,
    samples: u32,
    quick_samples: u32,
}

/// The shipped scenes at fixed sizes.
const CASES: [Case; 4] = [
    Case {
        scene: "cornell-boxes.toml",
        width: 256,
        height: 256,
        samples: 64,
        quick_samples: 4,
    },
    Case {
        scene: "cornell.toml",
        width: 600,
        height: 600,
        samples: 8,
        quick_samples: 1,
    },
    Case {
        scene: "furnace.toml",
        width: 256,
        height: 256,
        samples: 64,
        quick_samples: 4,
    },
    Case {
        scene: "knot.toml",
        width: 256,
        height: 192,
        samples: 16,
        quick_samples: 1,
    },
];

/// Sphere counts of the scale curve (`scene::sphere_field`).
const FIELD_SIZES: [usize; 3] = [100, 1000, 4000];

/// Paths/s of the sphere field against its sphere count, in the default storage
/// (baked up to 128 objects, the BVH above), and the BVH's with its arrays in
/// the other memory (`--array-memory`).
fn scale_curve(
    ctx: &GpuContext,
    (default_memory, other_memory): (ArrayMemory, ArrayMemory),
    samples: u32,
    repetitions: usize,
) -> Result<(), Failure> {
    println!("\nscale curve (a field of spheres, 256x256, {samples} spp, max depth 8, mixture):\n");
    println!(
        "| spheres | storage | arrays | M paths/s | vs {} spheres |",
        FIELD_SIZES[0]
    );
    println!("|--:|---|---|--:|--:|");
    let mut first: Option<f64> = None;
    for n in FIELD_SIZES {
        let scene = scene::sphere_field(n);
        let storage = SceneStorage::auto(&SceneData::pack(&scene));
        let memories = match storage {
            SceneStorage::Bvh => vec![default_memory, other_memory],
            _ => vec![default_memory],
        };
        for memory in memories {
            let options = RenderOptions {
                array_memory: Some(memory),
                ..RenderOptions::default()
            };
            let m = bench::measure(ctx, &scene, &options, samples, repetitions)
                .map_err(Failure::runtime)?;
            let ratio = m.paths_per_second / *first.get_or_insert(m.paths_per_second);
            println!(
                "| {n} | {storage:?} | {memory:?} | {:.2} | {ratio:.2}x |",
                m.paths_per_second / 1e6
            );
        }
    }
    Ok(())
}

/// A scene `--stages` profiles by default: a path from the repository, and the
/// size it is rendered at.
struct StageCase {
    path: &'static str,
    width: u32,
    height: u32,
}

/// The book's boxes, then the real scenes of `../shared`.
const STAGE_CASES: [StageCase; 5] = [
    StageCase {
        path: "scenes/cornell-boxes.toml",
        width: 256,
        height: 256,
    },
    StageCase {
        path: "../shared/mitsuba-scenes/veach/veach-mis.xml",
        width: 384,
        height: 256,
    },
    StageCase {
        path: "../shared/scenes-bitterli/staircase2/scene.xml",
        width: 320,
        height: 180,
    },
    StageCase {
        path: "../shared/scenes-bitterli/veach_mi/scene.xml",
        width: 320,
        height: 180,
    },
    StageCase {
        path: "../shared/scenes-bitterli/cbox/scene.xml",
        width: 256,
        height: 256,
    },
];

/// `--stages`: per scene, its speed (uninstrumented, median of warm runs) and
/// what a profiling kernel counts per stage (`kernel::Stage`).
fn stages(ctx: &GpuContext, args: &BenchArgs) -> Result<(), Failure> {
    let samples = if args.quick { 1 } else { 4 };
    let repetitions = if args.quick {
        1
    } else {
        args.repetitions.clamp(1, 3)
    };
    let cases: Vec<(PathBuf, Option<(u32, u32)>)> = match args.scenes.is_empty() {
        true => STAGE_CASES
            .iter()
            .map(|case| {
                let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(case.path);
                (path, Some((case.width, case.height)))
            })
            .collect(),
        false => args
            .scenes
            .iter()
            .map(|path| (path.clone(), None))
            .collect(),
    };
    println!("adapter: {}", ctx.describe());
    println!(
        "{samples} spp per scene; per path: times a lane ran the stage; SIMD lanes per path: \
         lanes of the SIMD groups that ran it, active or not (what it cost); lanes active: \
         the first over the second"
    );
    for (path, size) in cases {
        if size.is_some() && !path.exists() {
            println!("\nskipped {}: it is missing", path.display());
            continue;
        }
        let mut scene = Scene::load(&path).map_err(Failure::input)?;
        if let Some((width, height)) = size {
            let overrides = SceneOverrides {
                width: Some(width),
                height: Some(height),
                ..Default::default()
            };
            scene
                .apply_overrides(&overrides)
                .map_err(Failure::runtime)?;
        }
        let options = RenderOptions::default();
        let timed = bench::measure(ctx, &scene, &options, samples, repetitions)
            .map_err(Failure::runtime)?;
        let profile =
            bench::profile_stages(ctx, &scene, &options, samples).map_err(Failure::runtime)?;
        let settings = &scene.render;
        println!(
            "\n{} ({}x{}, strategy {}, max depth {}): {:.3} M paths/s, {:.2} M segments/s\n",
            path.display(),
            scene.camera.width,
            scene.camera.height,
            settings.strategy.name(),
            settings.max_depth,
            timed.paths_per_second / 1e6,
            timed.segments_per_second / 1e6
        );
        println!("| stage | per path | SIMD lanes per path | lanes active |");
        println!("|---|--:|--:|--:|");
        let per_path = |count: u64| count as f64 / profile.paths as f64;
        for (stage, counts) in profile.stages {
            let active = match counts.slots() {
                0 => "-".to_string(),
                slots => format!("{:.0}%", 100.0 * counts.lanes() as f64 / slots as f64),
            };
            println!(
                "| {} | {:.2} | {:.2} | {active} |",
                stage.name(),
                per_path(counts.lanes()),
                per_path(counts.slots()),
            );
        }
    }
    Ok(())
}

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

pub fn bench(args: BenchArgs) -> Result<(), Failure> {
    if let Some(n) = args.write_sphere_field {
        print!("{}", scene::sphere_field_toml(n));
        return Ok(());
    }
    let ctx = super::open_gpu(args.adapter.as_deref())?;
    if args.stages {
        return stages(&ctx, &args);
    }
    let repetitions = if args.quick {
        1
    } else {
        args.repetitions.max(1)
    };
    println!("adapter: {}", ctx.describe());
    println!("median of {repetitions} warm runs (each configuration is warmed up before timing)\n");
    println!(
        "| scene | size | spp | configuration | median s | M paths/s | M segments/s | vs specialised |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let default_accumulator = if ctx.storage_texture_accumulator {
        AccumulatorKind::Texture
    } else {
        AccumulatorKind::Buffer
    };
    // The array memory this adapter gets by default (`choose_array_memory`), and the other.
    let (memories, other_memory_name) = match ctx.textures_read_faster {
        true => (
            (ArrayMemory::Textures, ArrayMemory::Buffers),
            "arrays in buffers",
        ),
        false => (
            (ArrayMemory::Buffers, ArrayMemory::Textures),
            "arrays in textures",
        ),
    };
    // Renderer options, and scene settings changed from the scene file's.
    let options = |options: RenderOptions| (options, SceneOverrides::default());
    let settings = |overrides: SceneOverrides| (RenderOptions::default(), overrides);
    let configurations = [
        ("specialised", options(RenderOptions::default())),
        (
            "general kernel",
            options(RenderOptions {
                general_kernel: true,
                ..RenderOptions::default()
            }),
        ),
        (
            "+ variance sums",
            options(RenderOptions {
                variance: true,
                ..RenderOptions::default()
            }),
        ),
        (
            "buffer accumulator",
            options(RenderOptions {
                accumulator: Some(AccumulatorKind::Buffer),
                ..RenderOptions::default()
            }),
        ),
        (
            other_memory_name,
            options(RenderOptions {
                array_memory: Some(memories.1),
                ..RenderOptions::default()
            }),
        ),
        (
            "independent sampler",
            settings(SceneOverrides {
                sampler: Some(Sampler::Independent),
                ..Default::default()
            }),
        ),
        (
            "nee-mis, roulette from 5",
            settings(SceneOverrides {
                strategy: Some(Strategy::NeeMis),
                rr_depth: Some(Some(5)),
                ..Default::default()
            }),
        ),
    ];
    for case in &CASES {
        let mut scene = Scene::load(&scenes_dir().join(case.scene)).map_err(Failure::runtime)?;
        scene
            .apply_overrides(&SceneOverrides {
                width: Some(case.width),
                height: Some(case.height),
                ..Default::default()
            })
            .map_err(Failure::runtime)?;
        let samples = if args.quick {
            case.quick_samples
        } else {
            case.samples
        };
        let mut baseline: Option<Measurement> = None;
        for (name, (options, overrides)) in &configurations {
            if *name == "buffer accumulator" && default_accumulator == AccumulatorKind::Buffer {
                continue;
            }
            // A baked scene reads (next to) nothing from memory.
            if *name == other_memory_name
                && SceneStorage::auto(&SceneData::pack(&scene)) == SceneStorage::Baked
            {
                continue;
            }
            let mut scene = scene.clone();
            scene.apply_overrides(overrides).map_err(Failure::runtime)?;
            let m = bench::measure(&ctx, &scene, options, samples, repetitions)
                .map_err(Failure::runtime)?;
            let ratio = baseline
                .as_ref()
                .map_or(1.0, |b| m.paths_per_second / b.paths_per_second);
            println!(
                "| {} | {}x{} | {} | {} | {:.3} | {:.2} | {:.2} | {:.2}x |",
                case.scene,
                case.width,
                case.height,
                samples,
                name,
                m.median_seconds,
                m.paths_per_second / 1e6,
                m.segments_per_second / 1e6,
                ratio
            );
            baseline.get_or_insert(m);
        }
    }
    scale_curve(&ctx, memories, if args.quick { 1 } else { 16 }, repetitions)?;
    if !args.no_startup {
        startup(args.adapter.as_deref())?;
    }
    Ok(())
}

/// Time from process start to the first full sample of the Cornell box, with an
/// empty driver shader cache (cold) and again with it filled (warm).
fn startup(adapter: Option<&str>) -> Result<(), Failure> {
    let cache = std::env::temp_dir().join(format!("pathmix-bench-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let image = cache.join("first-sample.png");
    std::fs::create_dir_all(&cache)
        .map_err(|e| Failure::runtime(format!("{}: {e}", cache.display())))?;
    let exe = std::env::current_exe().map_err(Failure::runtime)?;
    let scene = scenes_dir().join("cornell.toml");
    println!("\ntime to first sample (scenes/cornell.toml, 600x600, 1 spp, whole process):");
    for label in ["cold shader cache", "warm shader cache"] {
        let mut command = Command::new(&exe);
        command
            .arg("render")
            .arg(&scene)
            .args(["--spp", "1", "--quiet", "-o"])
            .arg(&image);
        if let Some(name) = adapter {
            command.args(["--adapter", name]);
        }
        // Mesa keeps compiled pipelines here; a fresh folder is a cold cache.
        let output = command
            .env("MESA_SHADER_CACHE_DIR", &cache)
            .output()
            .map_err(Failure::runtime)?;
        let stdout = String::from_utf8_lossy(&output.stdout);
        let first = stdout
            .lines()
            .find_map(|line| line.strip_prefix("first samples done "))
            .and_then(|rest| rest.split_whitespace().next())
            .ok_or_else(|| {
                Failure::runtime(format!(
                    "child render failed: {}",
                    String::from_utf8_lossy(&output.stderr)
                ))
            })?;
        println!("  {label}: {first} ms");
    }
    let _ = std::fs::remove_dir_all(&cache);
    Ok(())
}
