//! A uniform run's error estimate reduced on the device (`shaders/error_estimate.wgsl`):
//! what `pilot::relative_noise` needs of each candidate, without reading back its
//! sums. At 600×600 with the replicates those are 57.6 MB, whose readback and
//! conversion took 0.2–0.4 s per candidate on lavapipe; the strips are 12 bytes
//! per 64 pixels.

use super::accumulator::{Accumulator, map_read};
use super::context::GpuContext;
use super::pipeline::{accumulator_binding, compute_entry, storage_buffer};
use crate::abi::{
    BINDING_ACCUMULATOR, BINDING_ERROR_STRIPS, BINDING_PARAMS, ERROR_ENTRY_POINT,
    ERROR_STRIP_PIXELS, ERROR_WORKGROUP_SIZE, ErrorStrip, EstimateParams, REPLICATES,
};
use crate::kernel::KernelConfig;
use crate::shader::ComposeError;
use crate::stats::Replicates;
use wgpu::util::DeviceExt;

/// The image's sums over pixels and channels, in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorSums {
    /// Pixels times channels.
    pub values: u64,
    /// Of the per-pixel means.
    pub mean: f64,
    /// Of the squared standard errors of the means (`stats::Accumulation::standard_error`).
    pub squared_error: f64,
    /// Sums (and sums of squares) that are NaN or infinite: f32 sums that overflowed.
    pub non_finite: u64,
}

/// The pipeline for a kernel's accumulator: variance on, uniform.
pub struct ErrorEstimator {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl ErrorEstimator {
    pub fn new(ctx: &GpuContext, config: &KernelConfig) -> Result<ErrorEstimator, ComposeError> {
        assert!(
            config.variance && !config.adaptive,
            "an error estimate needs a uniform run's variance sums"
        );
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("error estimate"),
                source: wgpu::ShaderSource::Wgsl(config.error_estimate_source()?.into()),
            });
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("error estimate"),
                entries: &[
                    compute_entry(BINDING_PARAMS, storage_buffer(true)),
                    compute_entry(BINDING_ACCUMULATOR, accumulator_binding(config.accumulator)),
                    compute_entry(BINDING_ERROR_STRIPS, storage_buffer(false)),
                ],
            });
        let pipeline_layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("error estimate"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = ctx
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("error estimate"),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(ERROR_ENTRY_POINT),
                compilation_options: Default::default(),
                cache: None,
            });
        Ok(ErrorEstimator { pipeline, layout })
    }

    /// The sums of `accumulator`, which holds sample indices `first_sample..` +
    /// `samples` of every pixel.
    pub fn sums(
        &self,
        ctx: &GpuContext,
        accumulator: &Accumulator,
        first_sample: u32,
        samples: u32,
    ) -> ErrorSums {
        let (width, height) = (accumulator.width, accumulator.height);
        let strips = width.div_ceil(ERROR_STRIP_PIXELS);
        let range = first_sample as u64..first_sample as u64 + samples as u64;
        let per_replicate = Replicates::samples_in(range, REPLICATES);
        let params = EstimateParams {
            width,
            height,
            samples,
            strips,
            replicate_samples: std::array::from_fn(|r| per_replicate[r] as u32),
        };
        let params = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("error estimate params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let size = strips as u64 * height as u64 * size_of::<ErrorStrip>() as u64;
        let output = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("error strips"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("error strips readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("error estimate"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: BINDING_PARAMS,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: BINDING_ACCUMULATOR,
                    resource: accumulator.binding(),
                },
                wgpu::BindGroupEntry {
                    binding: BINDING_ERROR_STRIPS,
                    resource: output.as_entire_binding(),
                },
            ],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(height.div_ceil(ERROR_WORKGROUP_SIZE), strips, 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &staging, 0, size);
        ctx.queue.submit([encoder.finish()]);
        map_read(ctx, &staging, |bytes| {
            let strips: &[ErrorStrip] = bytemuck::cast_slice(bytes);
            ErrorSums {
                values: 3 * width as u64 * height as u64,
                mean: strips.iter().map(|s| s.mean as f64).sum(),
                squared_error: strips.iter().map(|s| s.squared_error as f64).sum(),
                non_finite: strips.iter().map(|s| s.non_finite as u64).sum(),
            }
        })
    }
}
