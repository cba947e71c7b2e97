//! pathmix: a headless GPU path tracer (wgpu compute) with mixture-PDF
//! importance sampling (docs/estimator.md has the estimator).
//!
//! The modules are layers, each using only those below it (ARCHITECTURE.md;
//! `tests/architecture.rs` checks it), from the top:
//!
//! - `session`: what a run is beyond its samples: checkpoints, shards, the
//!   `auto` strategy's pilot, convergence measurements, benchmarks;
//! - `render`: the progressive accumulation loop and its stopping rules
//!   (`render::adaptive`: which pixels adaptive rounds sample);
//! - `gpu`: the device, buffers, textures and pipelines;
//! - `kernel`: which WGSL a scene and run need, and the generated glue;
//! - `pack`: the scene as the arrays the kernel reads, with no device;
//! - `accel`, `lights`, `environment`: the BVH, the light tables, the
//!   environment map's sampling tables (plain data);
//! - `scene`: scene files (TOML, Mitsuba XML, meshes, images) read into a
//!   validated `Scene`;
//! - `kinds`: each kind of shape, material and texture, described once;
//! - `abi`: the layouts, bindings and constants shared with the WGSL.
//!
//! Beside the layers, used by any of them: `shader` composes WGSL modules,
//! `stats` and `output` work on plain arrays and image files, and `paths`
//! finds a command's paths that name one file.

pub mod abi;
pub mod accel;
pub mod environment;
pub mod gpu;
pub mod kernel;
pub mod kinds;
pub mod lights;
pub mod output;
pub mod pack;
pub mod paths;
pub mod render;
pub mod scene;
pub mod session;
pub mod shader;
pub mod stats;
