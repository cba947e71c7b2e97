//! The compute pipeline built from a `KernelConfig`, with explicit bind group
//! layouts derived from the same config as the WGSL.

use super::context::GpuContext;
use crate::abi::{
    BINDING_ACCUMULATOR, BINDING_ACTIVE_PIXELS, BINDING_COUNTERS, BINDING_PARAMS, BINDING_PROFILE,
    BINDING_SPLAT_SAMPLES, SPLAT_ENTRY_POINT,
};
use crate::kernel::{AccumulatorKind, KernelConfig};
use crate::shader::ComposeError;

#[derive(Clone)]
pub struct Kernel {
    pub config: KernelConfig,
    pub pipeline: wgpu::ComputePipeline,
    /// With `config.splat`: the splatting pass, run after each submission's
    /// samples (same bind groups).
    pub splat_pipeline: Option<wgpu::ComputePipeline>,
    pub frame_layout: wgpu::BindGroupLayout,
    pub scene_layout: wgpu::BindGroupLayout,
}

pub(crate) fn compute_entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

pub(crate) fn storage_buffer(read_only: bool) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

/// A scene array in a texture (`gpu::texture_array`).
fn texture_array() -> wgpu::BindingType {
    wgpu::BindingType::Texture {
        sample_type: wgpu::TextureSampleType::Uint,
        view_dimension: wgpu::TextureViewDimension::D2,
        multisampled: false,
    }
}

/// How the accumulator of `kind` is bound (`shaders/accumulate_*.wgsl`).
pub(crate) fn accumulator_binding(kind: AccumulatorKind) -> wgpu::BindingType {
    match kind {
        AccumulatorKind::Texture => wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::ReadWrite,
            format: wgpu::TextureFormat::Rgba32Float,
            view_dimension: wgpu::TextureViewDimension::D2Array,
        },
        AccumulatorKind::Buffer => storage_buffer(false),
    }
}

/// The compute pipeline of `entry_point` in the WGSL `source` under `layout`,
/// its override constants set to `constants`.
fn compute_pipeline(
    ctx: &GpuContext,
    label: &str,
    layout: &wgpu::PipelineLayout,
    source: String,
    (entry_point, constants): (&str, &[(&str, f64)]),
) -> wgpu::ComputePipeline {
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    ctx.device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            module: &module,
            entry_point: Some(entry_point),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        })
}

impl Kernel {
    pub fn new(ctx: &GpuContext, config: KernelConfig) -> Result<Kernel, ComposeError> {
        let accumulator = accumulator_binding(config.accumulator);
        let mut frame_entries = vec![
            compute_entry(BINDING_PARAMS, storage_buffer(true)),
            compute_entry(BINDING_ACCUMULATOR, accumulator),
            compute_entry(BINDING_COUNTERS, storage_buffer(false)),
        ];
        if config.adaptive {
            frame_entries.push(compute_entry(BINDING_ACTIVE_PIXELS, storage_buffer(true)));
        }
        if config.splat {
            frame_entries.push(compute_entry(BINDING_SPLAT_SAMPLES, storage_buffer(false)));
        }
        if config.profile {
            frame_entries.push(compute_entry(BINDING_PROFILE, storage_buffer(false)));
        }
        let frame_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("frame"),
                entries: &frame_entries,
            });
        let scene_entries: Vec<_> = config
            .scene_bindings()
            .into_iter()
            .map(|array| match config.in_texture(array.source) {
                true => compute_entry(array.binding, texture_array()),
                false => compute_entry(array.binding, storage_buffer(true)),
            })
            .collect();
        let scene_layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("scene"),
                entries: &scene_entries,
            });
        let layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("pathmix"),
                bind_group_layouts: &[Some(&frame_layout), Some(&scene_layout)],
                immediate_size: 0,
            });
        let pipeline = compute_pipeline(
            ctx,
            "pathmix kernel",
            &layout,
            config.source()?,
            (config.entry_point(), &config.constants()),
        );
        let splat_pipeline = match config.splat {
            true => Some(compute_pipeline(
                ctx,
                "splatting",
                &layout,
                config.splat_source()?,
                (SPLAT_ENTRY_POINT, &config.filter.constants()),
            )),
            false => None,
        };
        Ok(Kernel {
            config,
            pipeline,
            splat_pipeline,
            frame_layout,
            scene_layout,
        })
    }
}
