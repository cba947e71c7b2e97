//! Device, buffers and pipelines.

pub mod accumulator;
pub mod context;
pub mod error_estimate;
pub mod pipeline;
pub mod texture_array;

pub use context::{GpuContext, GpuError};
