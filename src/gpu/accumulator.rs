//! The running sums on the device and their readback.

use super::context::GpuContext;
use crate::kernel::AccumulatorKind;

/// Each pixel's sum in f64 (the running sum minus its compensation) from
/// layer-major `texels` of `pixels` pixels per layer.
pub fn compensated_sums(
    texels: &[[f32; 4]],
    pixels: usize,
    sum: u32,
    compensation: u32,
) -> impl Iterator<Item = [f64; 3]> + '_ {
    let layer = |l: u32| &texels[l as usize * pixels..(l as usize + 1) * pixels];
    layer(sum)
        .iter()
        .zip(layer(compensation))
        .map(|(s, c)| std::array::from_fn(|i| s[i] as f64 - c[i] as f64))
}

/// Bytes per pixel per layer (one `vec4<f32>`).
pub const TEXEL_BYTES: u32 = 16;

enum Storage {
    Texture {
        texture: wgpu::Texture,
        view: wgpu::TextureView,
    },
    Buffer(wgpu::Buffer),
}

/// `layers` images of `vec4<f32>` per pixel: each running sum and its compensation.
pub struct Accumulator {
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    storage: Storage,
}

impl Accumulator {
    pub fn new(
        ctx: &GpuContext,
        kind: AccumulatorKind,
        width: u32,
        height: u32,
        layers: u32,
    ) -> Accumulator {
        let storage = match kind {
            AccumulatorKind::Texture => {
                let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("accumulator"),
                    size: wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: layers,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::STORAGE_BINDING
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                });
                let view = texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2Array),
                    ..Default::default()
                });
                Storage::Texture { texture, view }
            }
            AccumulatorKind::Buffer => {
                Storage::Buffer(ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("accumulator"),
                    size: Self::layer_bytes(width, height) * layers as u64,
                    usage: wgpu::BufferUsages::STORAGE
                        | wgpu::BufferUsages::COPY_SRC
                        | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }))
            }
        };
        Accumulator {
            width,
            height,
            layers,
            storage,
        }
    }

    fn layer_bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * TEXEL_BYTES as u64
    }

    /// Row pitch of a texture copy: a multiple of 256 bytes.
    fn padded_row_bytes(&self) -> u32 {
        (self.width * TEXEL_BYTES).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
    }

    pub fn binding(&self) -> wgpu::BindingResource<'_> {
        match &self.storage {
            Storage::Texture { view, .. } => wgpu::BindingResource::TextureView(view),
            Storage::Buffer(buffer) => buffer.as_entire_binding(),
        }
    }

    /// Every layer, row-major, top row first (`layers * width * height` texels).
    pub fn read(&self, ctx: &GpuContext) -> Vec<[f32; 4]> {
        let row_bytes = self.width * TEXEL_BYTES;
        let (padded_row, rows) = match self.storage {
            Storage::Texture { .. } => (self.padded_row_bytes(), self.height * self.layers),
            Storage::Buffer(_) => (row_bytes, self.height * self.layers),
        };
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("accumulator readback"),
            size: padded_row as u64 * rows as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        match &self.storage {
            Storage::Texture { texture, .. } => encoder.copy_texture_to_buffer(
                texture.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &staging,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(padded_row),
                        rows_per_image: Some(self.height),
                    },
                },
                wgpu::Extent3d {
                    width: self.width,
                    height: self.height,
                    depth_or_array_layers: self.layers,
                },
            ),
            Storage::Buffer(buffer) => {
                encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, staging.size())
            }
        }
        ctx.queue.submit([encoder.finish()]);
        let texels = map_read(ctx, &staging, |bytes| {
            let mut texels = Vec::with_capacity((self.width * rows) as usize);
            for row in bytes.chunks_exact(padded_row as usize) {
                texels.extend_from_slice(bytemuck::cast_slice(&row[..row_bytes as usize]));
            }
            texels
        });
        staging.destroy();
        texels
    }

    /// Replaces every layer with `texels` (as `read` returns them). The
    /// queue orders this before any later dispatch.
    pub fn write(&self, ctx: &GpuContext, texels: &[[f32; 4]]) {
        assert_eq!(
            texels.len(),
            (self.width * self.height * self.layers) as usize,
            "accumulator write of the wrong size"
        );
        let bytes: &[u8] = bytemuck::cast_slice(texels);
        match &self.storage {
            Storage::Texture { texture, .. } => ctx.queue.write_texture(
                texture.as_image_copy(),
                bytes,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.width * TEXEL_BYTES),
                    rows_per_image: Some(self.height),
                },
                wgpu::Extent3d {
                    width: self.width,
                    height: self.height,
                    depth_or_array_layers: self.layers,
                },
            ),
            Storage::Buffer(buffer) => ctx.queue.write_buffer(buffer, 0, bytes),
        }
    }
}

impl Accumulator {
    /// Replaces this accumulator's first `layers` layers with `source`'s, on the
    /// device: `source` is of the same size and kind. The queue orders this
    /// before any later dispatch.
    pub fn copy_layers_from(&self, ctx: &GpuContext, source: &Accumulator, layers: u32) {
        assert_eq!(
            (self.width, self.height),
            (source.width, source.height),
            "accumulators of different sizes"
        );
        assert!(layers <= self.layers.min(source.layers), "too many layers");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        match (&source.storage, &self.storage) {
            (Storage::Texture { texture: from, .. }, Storage::Texture { texture: to, .. }) => {
                encoder.copy_texture_to_texture(
                    from.as_image_copy(),
                    to.as_image_copy(),
                    wgpu::Extent3d {
                        width: self.width,
                        height: self.height,
                        depth_or_array_layers: layers,
                    },
                )
            }
            (Storage::Buffer(from), Storage::Buffer(to)) => {
                let bytes = Self::layer_bytes(self.width, self.height) * layers as u64;
                encoder.copy_buffer_to_buffer(from, 0, to, 0, bytes)
            }
            _ => panic!("accumulators of different kinds"),
        }
        ctx.queue.submit([encoder.finish()]);
    }
}

/// `buffer`'s contents, copied to a mappable buffer and read by `read`.
pub fn read_back<T>(ctx: &GpuContext, buffer: &wgpu::Buffer, read: impl FnOnce(&[u8]) -> T) -> T {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: buffer.size(),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, staging.size());
    ctx.queue.submit([encoder.finish()]);
    map_read(ctx, &staging, read)
}

/// Maps `buffer` for reading, waits, and hands its bytes to `read`.
pub fn map_read<T>(ctx: &GpuContext, buffer: &wgpu::Buffer, read: impl FnOnce(&[u8]) -> T) -> T {
    let (sender, receiver) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |result| {
        let _ = sender.send(result);
    });
    ctx.device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("device lost while reading back");
    receiver
        .recv()
        .expect("map callback dropped")
        .expect("mapping the readback buffer failed");
    let value = read(&buffer.get_mapped_range(..).expect("mapped range"));
    buffer.unmap();
    value
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abi::{
        LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, LAYER_SUM, LAYER_SUM_COMPENSATION,
    };

    #[test]
    fn compensated_sums_subtract_each_layers_compensation() {
        // Two pixels per layer, layer-major; w is unused.
        let texels = [
            [1.5, 2.0, 3.0, 9.0],
            [4.0, 5.0, 6.0, 9.0],
            [0.25, -0.5, 0.0, 9.0],
            [1.0, 0.0, 2.0, 9.0],
            [9.0, 8.0, 7.0, 9.0],
            [16.0, 0.5, 1.0, 9.0],
            [0.5, 0.0, -1.0, 9.0],
            [0.0, 0.25, 0.125, 9.0],
        ];
        let sums: Vec<_> =
            compensated_sums(&texels, 2, LAYER_SUM, LAYER_SUM_COMPENSATION).collect();
        assert_eq!(sums, [[1.25, 2.5, 3.0], [3.0, 5.0, 4.0]]);
        let squares: Vec<_> =
            compensated_sums(&texels, 2, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION).collect();
        assert_eq!(squares, [[8.5, 8.0, 8.0], [16.0, 0.25, 0.875]]);
    }
}
