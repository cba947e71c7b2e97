//! Environment maps (`[environment]`): a latitude-longitude image of the
//! radiance arriving from every direction, read from OpenEXR (`exr`) or Radiance
//! HDR (`image`), laid on the sphere as Mitsuba 3's `envmap` plugin lays it.
//!
//! Map space (before `to_world`): the direction `d` has `u = atan2(d.x, -d.z) /
//! 2 pi` (wrapped into [0, 1)) and `v = acos(d.y) / pi`; column `x` of a map
//! `W` wide is centred on `u = (x + 1/2) / W` and row `y` of `H` on `v = y / (H -
//! 1)` (the first and last rows sit on the poles). The radiance is interpolated
//! bilinearly between those centres, as Mitsuba does (`shaders/environment.wgsl`).

use crate::kinds::serialize_texels;
use crate::output;
use glam::Mat3;
use serde::Serialize;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

/// A validated environment map.
#[derive(Clone, PartialEq, Serialize)]
pub struct EnvironmentMap {
    /// The image file as the scene names it (relative to the scene file).
    pub file: String,
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row-major, row 0 at `v = 0` (map-space +y); finite, >= 0.
    #[serde(serialize_with = "serialize_texels")]
    pub texels: Arc<Vec<[f32; 3]>>,
    /// Radiance multiplier.
    pub scale: f32,
    /// Map space to world: a rotation (or a mirrored one).
    pub to_world: Mat3,
}

impl fmt::Debug for EnvironmentMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EnvironmentMap")
            .field("file", &self.file)
            .field("size", &(self.width, self.height))
            .field("scale", &self.scale)
            .field("to_world", &self.to_world)
            .finish()
    }
}

impl EnvironmentMap {
    /// The texel of the largest value (of any channel), and that value, unscaled.
    pub fn brightest_texel(&self) -> (u32, u32, f32) {
        let (index, value) = (self.texels.iter().enumerate())
            .map(|(i, t)| (i, t.iter().copied().fold(0.0f32, f32::max)))
            .fold((0, 0.0f32), |best, texel| match texel.1 > best.1 {
                true => texel,
                false => best,
            });
        // The texel count fits u32: `load_image` reads at most `MAX_IMAGE_TEXELS`.
        let index = index as u32;
        (index % self.width, index / self.width, value)
    }
}

/// Reads the map `path` (`output::read_linear_image`).
pub fn load_image(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), String> {
    output::read_linear_image(path, "environment map")
}
