//! The environment map as the kernel reads it (`shaders/environment.wgsl`): its
//! texels, and the piecewise-constant density over its cells (each texel's: the
//! directions nearest its centre) that the light density samples (pbrt-v4's
//! `PiecewiseConstant2D` in spirit: a marginal CDF over rows, a conditional CDF
//! within each row). A cell's mass is the mean luminance of the bilinear lookup
//! over it times its solid angle, and a direction is drawn uniformly in `(cos
//! theta, phi)` within its cell: the density is positive wherever the radiance
//! is, and a constant map is sampled uniformly over the sphere.

use crate::abi::gpu_struct;
use crate::scene::EnvironmentMap;
use crate::scene::envmap::row_edge;
use crate::stats::luminance_f64;

gpu_struct! {
    /// The map's size and the world-to-map rotation, by rows (the inverse of
    /// `to_world`, orthogonal: its transpose).
    pub struct EnvironmentInfo {
        pub to_local_x: [f32; 3],
        pub width: u32,
        pub to_local_y: [f32; 3],
        pub height: u32,
        pub to_local_z: [f32; 3],
        pub _pad: u32,
    }
}

/// What the kernel's environment arrays hold.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentTables {
    pub info: EnvironmentInfo,
    /// Per texel, row-major: the scaled radiance (xyz) and the conditional CDF
    /// of its row at the texel's left edge (w); the CDF is 1 at the row's end.
    pub texels: Vec<[f32; 4]>,
    /// The marginal CDF over rows: `height + 1` entries, 0 first and 1 last.
    pub rows: Vec<f32>,
}

/// The mean over each texel's cell of `values` interpolated bilinearly between
/// texel centres, as the kernel looks the radiance up (columns periodic; the
/// polar rows' cells reach only toward the equator): per axis 3/4 of the
/// texel and 1/8 of each neighbour, or 3/4 and 1/4 at a pole. Positive wherever
/// the interpolation is, over the cell.
fn cell_means(values: &[f64], width: usize, height: usize) -> Vec<f64> {
    let across: Vec<f64> = (0..width * height)
        .map(|i| {
            let (x, row) = (i % width, i - i % width);
            let left = row + (x + width - 1) % width;
            let right = row + (x + 1) % width;
            0.75 * values[i] + 0.125 * (values[left] + values[right])
        })
        .collect();
    (0..width * height)
        .map(|i| {
            let y = i / width;
            let up = |k: usize| across[i - k * width];
            let down = |k: usize| across[i + k * width];
            match (y, height) {
                (_, 1) => across[i],
                (0, _) => 0.75 * across[i] + 0.25 * down(1),
                (y, h) if y == h - 1 => 0.75 * across[i] + 0.25 * up(1),
                _ => 0.75 * across[i] + 0.125 * (up(1) + down(1)),
            }
        })
        .collect()
}

/// `cos(pi a) - cos(pi b)` for `a <= b`, without cancellation near the poles.
pub fn cos_difference(a: f64, b: f64) -> f64 {
    let pi = std::f64::consts::PI;
    2.0 * (pi * (a + b) / 2.0).sin() * (pi * (b - a) / 2.0).sin()
}

/// Normalised running sums of `weights` (all >= 0), `weights.len() + 1`
/// entries from 0 to 1; all zero: uniform.
fn cdf(weights: &[f64]) -> Vec<f32> {
    let total: f64 = weights.iter().sum();
    let n = weights.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut sum = 0.0;
    out.push(0.0);
    for (i, w) in weights.iter().enumerate() {
        sum += w;
        out.push(if total > 0.0 {
            (sum / total) as f32
        } else {
            ((i + 1) as f64 / n as f64) as f32
        });
    }
    out[n] = 1.0;
    out
}

impl EnvironmentTables {
    pub fn build(map: &EnvironmentMap) -> EnvironmentTables {
        let (width, height) = (map.width as usize, map.height as usize);
        // The rows of the world-to-map rotation are the columns of `to_world`.
        let to_local = map.to_world;
        let mut texels = Vec::with_capacity(width * height);
        let mut row_weights = Vec::with_capacity(height);
        let lum: Vec<f64> = map
            .texels
            .iter()
            .map(|&t| luminance_f64(t.map(f64::from)))
            .collect();
        let weights = cell_means(&lum, width, height);
        for (y, (row, weights)) in map
            .texels
            .chunks_exact(width)
            .zip(weights.chunks_exact(width))
            .enumerate()
        {
            let solid_angle = cos_difference(
                row_edge(y as u32, map.height),
                row_edge(y as u32 + 1, map.height),
            );
            row_weights.push(weights.iter().sum::<f64>() * solid_angle);
            let conditional = cdf(weights);
            texels.extend(
                row.iter()
                    .zip(&conditional)
                    .map(|(t, &c)| [t[0] * map.scale, t[1] * map.scale, t[2] * map.scale, c]),
            );
        }
        // A black map: uniform over the sphere (by solid angle), never weighed anyway.
        if row_weights.iter().all(|&w| w == 0.0) {
            row_weights = (0..height as u32)
                .map(|y| cos_difference(row_edge(y, map.height), row_edge(y + 1, map.height)))
                .collect();
        }
        EnvironmentTables {
            info: EnvironmentInfo {
                to_local_x: to_local.x_axis.to_array(),
                width: map.width,
                to_local_y: to_local.y_axis.to_array(),
                height: map.height,
                to_local_z: to_local.z_axis.to_array(),
                _pad: 0,
            },
            texels,
            rows: cdf(&row_weights),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_means_weigh_the_neighbours_the_bilinear_lookup_reaches() {
        // One hot texel of a 4 x 3 map: its cell 3/4 x 3/4, the sides 1/8, the
        // row below (a pole's cell reaches one way) 1/8 of 3/4 across.
        let mut values = vec![0.0; 12];
        values[5] = 64.0;
        let means = cell_means(&values, 4, 3);
        assert_eq!(means[5], 36.0);
        assert_eq!((means[4], means[6], means[7]), (6.0, 6.0, 0.0));
        assert_eq!((means[1], means[9]), (0.25 * 48.0, 0.25 * 48.0));
        assert_eq!(cell_means(&[2.0], 1, 1), vec![2.0]);
        // A constant map stays constant.
        assert!(cell_means(&[1.5; 12], 4, 3).iter().all(|&m| m == 1.5));
    }

    #[test]
    fn cdfs_run_from_zero_to_one_and_skip_empty_cells() {
        assert_eq!(cdf(&[1.0, 0.0, 3.0]), vec![0.0, 0.25, 0.25, 1.0]);
        assert_eq!(cdf(&[0.0, 0.0]), vec![0.0, 0.5, 1.0]);
        assert_eq!(cdf(&[5.0]), vec![0.0, 1.0]);
    }

    #[test]
    fn cos_difference_is_cancellation_free() {
        let direct =
            |a: f64, b: f64| (std::f64::consts::PI * a).cos() - (std::f64::consts::PI * b).cos();
        assert!((cos_difference(0.2, 0.7) - direct(0.2, 0.7)).abs() < 1e-15);
        assert_eq!(cos_difference(0.0, 1.0), 2.0);
        // The polar row of a 4096-row map: 1 - cos(x) ~ x^2 / 2 to 1e-12 relative.
        let x = std::f64::consts::PI * 0.5 / 4095.0;
        assert!((cos_difference(0.0, 0.5 / 4095.0) / (x * x / 2.0) - 1.0).abs() < 1e-6);
    }
}
