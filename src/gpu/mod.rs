//! Device, buffers and pipelines.

pub mod accumulator;
pub mod context;
pub mod layout;
pub mod pipeline;

pub use context::{GpuContext, GpuError};
