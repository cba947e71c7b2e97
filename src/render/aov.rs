//! The AOV pass (`kinds::aov`, `shaders/aov.wgsl`): after a renderer's
//! samples, the same sample indices' camera rays traced once more to the
//! first surface each meets, whose AOVs are summed on the device beside the
//! image's sums and read back as per-pixel means.

use super::{RenderError, Renderer, submission_shape, workgroup_row_step};
use crate::abi::{BINDING_ACCUMULATOR, BINDING_COUNTERS, BINDING_PARAMS, Params};
use crate::gpu::accumulator::{Accumulator, TEXEL_BYTES, compensated_sums};
use crate::kernel::WORKGROUP_SIZE;
use crate::kinds::{Aov, AovKind, aov_kinds};

/// Most bytes of running sums the pass holds: the image is summed a band of
/// rows at a time (4K at every AOV type would take 1.6 GB at once).
const AOV_BAND_BYTES: u64 = 1 << 26;

/// AOVs as written beside an image: each channel's name (`NAME.SUFFIX`) and
/// its values, row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct AovImage {
    pub width: u32,
    pub height: u32,
    pub channels: Vec<(String, Vec<f32>)>,
}

/// The `uv` AOV needs the texture coordinates that only a scene with
/// textures packs (`has_textures`): refused before any sample where it lacks them.
pub(super) fn check_texture_coordinates(
    aovs: &[Aov],
    has_textures: bool,
) -> Result<(), RenderError> {
    match aovs.iter().find(|aov| aov.kind == AovKind::Uv) {
        Some(aov) if !has_textures => Err(RenderError::UvAovWithoutTextures { aov: aov.spec() }),
        _ => Ok(()),
    }
}

impl Renderer<'_> {
    /// The AOVs `aovs` of this renderer's scene: each pixel's mean over the
    /// camera rays of its sample indices `first_sample()..` up to `samples`
    /// (at least one), drawn as the image's are.
    pub fn render_aovs(&self, aovs: &[Aov], samples: u32) -> Result<AovImage, RenderError> {
        let kinds = aov_kinds(aovs);
        check_texture_coordinates(aovs, self.kernel.config.textures)?;
        let device = &self.ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let kernel = self.ctx.kernel(self.kernel.config.for_aovs(&kinds))?;
        let (width, height) = self.size();
        let samples = samples.max(1);
        // A camera ray costs at most a path's first segment: a path's
        // dispatch budget holds. Bands of rows, each one dispatch wide, keep
        // the sums' memory to AOV_BAND_BYTES however large the image.
        let (per_dispatch, rows) = submission_shape(
            self.paths_per_submission,
            width,
            height,
            samples.min(self.max_samples_per_dispatch),
        );
        let layers = kernel.config.aov_layers();
        let band_bytes = u64::from(width * layers * TEXEL_BYTES);
        let band_rows = rows.min((AOV_BAND_BYTES / band_bytes).max(1) as u32);
        let accumulator = Accumulator::new(
            self.ctx,
            kernel.config.accumulator,
            width,
            band_rows,
            layers,
        );
        let frame_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("aov frame"),
            layout: &kernel.frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: BINDING_PARAMS,
                    resource: self.params_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: BINDING_ACCUMULATOR,
                    resource: accumulator.binding(),
                },
                wgpu::BindGroupEntry {
                    binding: BINDING_COUNTERS,
                    resource: self.counters_buffer.as_entire_binding(),
                },
            ],
        });
        let mut means: Vec<Vec<[f64; 3]>> = vec![Vec::new(); kinds.len()];
        let mut band = 0;
        while band < height {
            let band_size = band_rows.min(height - band);
            let mut done = 0;
            while done < samples {
                let count = per_dispatch.min(samples - done);
                let params = Params {
                    sample_start: self.first_sample.saturating_add(done),
                    sample_count: count,
                    tile_origin: [0, band],
                    tile_size: [width, band_size],
                    reset: (done == 0) as u32,
                    workgroup_row_step: workgroup_row_step(band_size.div_ceil(WORKGROUP_SIZE.1)),
                    // The sums' rows, as the buffer accumulator lays its layers
                    // out; the camera and the sampler number pixels by the width.
                    height: band_rows,
                    ..self.params
                };
                self.submit_pass_with(&kernel.pipeline, &frame_group, params);
                self.wait();
                done += count;
            }
            let texels = accumulator.read(self.ctx);
            let band_pixels = (width * band_rows) as usize;
            for (slot, mean) in means.iter_mut().enumerate() {
                let slot = slot as u32;
                let sums = compensated_sums(&texels, band_pixels, 2 * slot, 2 * slot + 1);
                let rows_here = sums.take((width * band_size) as usize);
                mean.extend(rows_here.map(|sum| sum.map(|s| s / samples as f64)));
            }
            band += band_size;
        }
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(RenderError::KernelBuild {
                message: error.to_string(),
            });
        }
        let channels = aovs
            .iter()
            .flat_map(|aov| {
                let slot = kinds
                    .iter()
                    .position(|&k| k == aov.kind)
                    .expect("each kind has a slot");
                let values = &means[slot];
                aov.channels()
                    .enumerate()
                    .map(|(c, name)| (name, values.iter().map(|v| v[c] as f32).collect()))
                    .collect::<Vec<_>>()
            })
            .collect();
        Ok(AovImage {
            width,
            height,
            channels,
        })
    }
}
