//! pathmix: a headless GPU path tracer (wgpu compute) with mixture-PDF
//! importance sampling. See DESIGN.md for the estimator.
//!
//! `scene` turns a file into a validated `Scene`; `kernel` and `shader` decide
//! and compose the WGSL for it; `gpu` owns the device, buffers and pipeline;
//! `render` runs the progressive accumulation (`adaptive`: which pixels
//! its rounds sample); `checkpoint` saves and restores
//! it; `shard` writes and merges partial results; `output` and `stats` work on
//! plain arrays; `paths` finds a command's paths that name one file;
//! `converge` measures the strategies' speed/accuracy trade; `pilot` chooses one
//! for `strategy = "auto"`.

pub mod abi;
pub mod accel;
pub mod adaptive;
pub mod bench;
pub mod checkpoint;
pub mod converge;
pub mod environment;
pub mod gpu;
pub mod kernel;
pub mod kinds;
pub mod lights;
pub mod output;
pub mod pack;
pub mod paths;
pub mod pilot;
pub mod render;
pub mod scene;
pub mod shader;
pub mod shard;
pub mod stats;
