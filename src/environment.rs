//! The environment map as the kernel reads it (`shaders/environment.wgsl`): its
//! texels, and the density over the sphere that the light density samples. The
//! density is the luminance of the texels, interpolated bilinearly in `(phi,
//! cos theta)` between the texel centres (the lookup interpolates the radiance
//! bilinearly in `(phi, theta)` between the same centres), over its integral.
//! So it is proportional to the luminance of the radiance at every texel centre
//! and near it, positive exactly where the radiance is, continuous, and a
//! constant map is sampled uniformly over the sphere. Mitsuba's `envmap`
//! interpolates its density bilinearly too, in `(phi, theta)` with each texel
//! row weighed by its `sin theta`, so that its polar rows weigh nothing.
//!
//! The cells lie between texel centres: `width` columns (the last one wraps
//! around to the first centre) by `height - 1` rows (one for a map one texel
//! high). A cell is chosen by descending a pyramid of the cells' masses
//! (Mitsuba's `Hierarchical2D`, as its `envmap` samples): at each level the
//! sample picks one of a node's 2 x 2 children, a row then a column, in
//! proportion to their masses, and is rescaled within it. Nearby samples stay
//! together down to the cell, so a stratified (Sobol) set of samples stays
//! stratified over the sphere; a marginal CDF over rows and a conditional one
//! within each row (pbrt-v4's `PiecewiseConstant2D`) scatter a square of
//! samples over the different columns of every row it spans: on the teapot
//! under Mitsuba's museum map they had 1.26x the pyramid's noise at equal
//! samples. Within the cell, `cos theta` is drawn from the bilinear density's
//! marginal and `phi` from its conditional, both linear.

use crate::abi::gpu_struct;
use crate::scene::EnvironmentMap;
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
        /// Levels of the pyramid above the cells (`EnvironmentTables::pyramid`).
        pub levels: u32,
    }
}

/// What the kernel's environment arrays hold.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentTables {
    pub info: EnvironmentInfo,
    /// Per texel, row-major: the scaled radiance (xyz) and the density (per
    /// unit solid angle) at its centre (w), which the kernel interpolates.
    pub texels: Vec<[f32; 4]>,
    /// The nodes of the pyramid over the cells' probabilities, the top level
    /// (one node) first and then each level below it, row-major: a node of
    /// level `k` (`pyramid_size(width, k)` by `pyramid_size(rows, k)`, `rows`
    /// being `cell_rows(height)`) holds the masses of its children on level
    /// `k - 1` (level 0: the cells), in the order (2x, 2y), (2x + 1, 2y), (2x,
    /// 2y + 1), (2x + 1, 2y + 1); a child past the edge has none.
    pub pyramid: Vec<[f32; 4]>,
}

/// Nodes along an axis of `n` cells on level `level` of the pyramid.
pub fn pyramid_size(n: u32, level: u32) -> u32 {
    ((n - 1) >> level) + 1
}

/// Levels of the pyramid above `width` by `height` cells: up to one node (one
/// level over a single cell too).
pub fn pyramid_levels(width: u32, height: u32) -> u32 {
    (u32::BITS - (width.max(height) - 1).leading_zeros()).max(1)
}

/// The pyramid (`EnvironmentTables::pyramid`) over `masses`, row-major
/// `width` by `height`.
fn pyramid(masses: &[f32], width: u32, height: u32) -> Vec<[f32; 4]> {
    let mut level: Vec<f32> = masses.to_vec();
    let mut levels = Vec::new();
    for k in 1..=pyramid_levels(width, height) {
        let size = |n: u32, k: u32| pyramid_size(n, k) as usize;
        let (w, h) = (size(width, k - 1), size(height, k - 1));
        let (up_w, up_h) = (size(width, k), size(height, k));
        let child = |x: usize, y: usize| match x < w && y < h {
            true => level[y * w + x],
            false => 0.0,
        };
        let nodes: Vec<[f32; 4]> = (0..up_w * up_h)
            .map(|i| {
                let (x, y) = (2 * (i % up_w), 2 * (i / up_w));
                [
                    child(x, y),
                    child(x + 1, y),
                    child(x, y + 1),
                    child(x + 1, y + 1),
                ]
            })
            .collect();
        level = nodes
            .iter()
            .map(|m| (m[0] + m[1]) + (m[2] + m[3]))
            .collect();
        levels.push(nodes);
    }
    levels.into_iter().rev().flatten().collect()
}

/// `cos(pi a) - cos(pi b)` for `a <= b`, without cancellation near the poles.
fn cos_difference(a: f64, b: f64) -> f64 {
    let pi = std::f64::consts::PI;
    2.0 * (pi * (a + b) / 2.0).sin() * (pi * (b - a) / 2.0).sin()
}

/// Rows of cells between the texel rows of a map `height` high: one fewer,
/// or one over the whole sphere for a single row.
pub fn cell_rows(height: u32) -> u32 {
    height.max(2) - 1
}

/// Each cell's mass, row-major: the integral of the interpolated luminance
/// `lum` over it, in units of `2 pi / width` (the cells' common width in
/// `phi`), which is the mean of its four corners times its span of `cos theta`.
fn cell_masses(lum: &[f64], width: usize, height: usize) -> Vec<f64> {
    let rows = cell_rows(height as u32) as usize;
    let corner = |x: usize, y: usize| lum[y.min(height - 1) * width + x % width];
    (0..width * rows)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let corners =
                (corner(x, y) + corner(x + 1, y)) + (corner(x, y + 1) + corner(x + 1, y + 1));
            let span = cos_difference(y as f64 / rows as f64, (y + 1) as f64 / rows as f64);
            corners / 4.0 * span
        })
        .collect()
}

impl EnvironmentTables {
    pub fn build(map: &EnvironmentMap) -> EnvironmentTables {
        let (width, height) = (map.width as usize, map.height as usize);
        // The rows of the world-to-map rotation are the columns of `to_world`.
        let to_local = map.to_world;
        let mut lum: Vec<f64> = map
            .texels
            .iter()
            .map(|&t| luminance_f64(t.map(f64::from)))
            .collect();
        // A black map: uniform over the sphere, never weighed anyway.
        if lum.iter().all(|&l| l == 0.0) {
            lum.fill(1.0);
        }
        let masses = cell_masses(&lum, width, height);
        let total: f64 = masses.iter().sum();
        let probabilities: Vec<f32> = masses.iter().map(|m| (m / total) as f32).collect();
        let integral = total * 2.0 * std::f64::consts::PI / width as f64;
        let texels = (map.texels.iter().zip(&lum))
            .map(|(t, l)| {
                let density = (l / integral) as f32;
                [
                    t[0] * map.scale,
                    t[1] * map.scale,
                    t[2] * map.scale,
                    density,
                ]
            })
            .collect();
        let rows = cell_rows(map.height);
        EnvironmentTables {
            info: EnvironmentInfo {
                to_local_x: to_local.x_axis.to_array(),
                width: map.width,
                to_local_y: to_local.y_axis.to_array(),
                height: map.height,
                to_local_z: to_local.z_axis.to_array(),
                levels: pyramid_levels(map.width, rows),
            },
            texels,
            pyramid: pyramid(&probabilities, map.width, rows),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_masses_integrate_the_interpolated_luminance() {
        // One hot texel of a 4 x 3 map (2 rows of cells, each 1 of cos theta
        // high): a quarter of it in each of the four cells it is a corner of.
        let mut lum = vec![0.0; 12];
        lum[5] = 64.0;
        let masses = cell_masses(&lum, 4, 3);
        assert_eq!(masses.len(), 8);
        let hot = [0, 1, 4, 5].map(|i| masses[i]);
        for m in hot {
            assert!((m - 16.0).abs() < 1e-12, "{masses:?}");
        }
        assert_eq!(masses.iter().filter(|&&m| m == 0.0).count(), 4);
        // The last column's cells wrap around to the first column.
        lum[5] = 0.0;
        lum[4] = 8.0;
        let masses = cell_masses(&lum, 4, 3);
        assert!((masses[3] - 2.0).abs() < 1e-12 && masses[0] > 0.0 && masses[1] == 0.0);
        // A constant map: each cell its span of cos theta, 2 in all per column.
        let masses = cell_masses(&[1.5; 12], 4, 3);
        assert!(masses.iter().all(|&m| (m - 1.5).abs() < 1e-12));
        // One row: one cell over the sphere.
        assert_eq!(cell_masses(&[2.0], 1, 1), vec![4.0]);
    }

    #[test]
    fn pyramid_levels_sum_their_children_down_to_the_cells() {
        assert_eq!(
            (
                pyramid_levels(1, 1),
                pyramid_levels(2, 1),
                pyramid_levels(512, 256)
            ),
            (1, 1, 9)
        );
        assert_eq!(
            (pyramid_size(5, 1), pyramid_size(5, 2), pyramid_size(5, 3)),
            (3, 2, 1)
        );
        // 3 x 2 cells: level 1 is 2 x 1 nodes, level 2 the root.
        let masses = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let nodes = pyramid(&masses, 3, 2);
        assert_eq!(
            nodes,
            vec![
                [1.0 + 2.0 + 4.0 + 5.0, 3.0 + 6.0, 0.0, 0.0],
                [1.0, 2.0, 4.0, 5.0],
                [3.0, 0.0, 6.0, 0.0],
            ]
        );
        assert_eq!(pyramid(&[0.5], 1, 1), vec![[0.5, 0.0, 0.0, 0.0]]);
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
