//! The pixel reconstruction filters: Mitsuba 3's `rfilter` plugins, with its
//! definitions and defaults (`src/rfilters/*.cpp`), each separable, the
//! filter over the image plane being `f(x) f(y)` for the offset `(x, y)` from
//! the pixel centre in pixels.
//!
//! A filter is applied by **filter importance sampling**: each camera ray's
//! offset is drawn from the filter and the sample stays in its own pixel (no
//! splatting), weighted so that its mean weight is 1. The pixel's estimate is
//! then `∫ f L / ∫ f`, which Mitsuba's splatting film approaches as its samples
//! grow: unbiased, and deterministic. Mitsuba's JIT variants evaluate the
//! filters exactly, as here (its scalar variants look them up in a table of 31
//! steps per radius).
//!
//! How each is drawn (`shaders/filter.wgsl`, one `filter_offset` per filter,
//! only the scene's compiled in):
//!
//! - `box`: uniform over the pixel, weight 1 (`camera_ray` itself).
//! - `gaussian`: the truncated Gaussian exactly, by inverting its CDF, weighted
//!   by the ratio of the filter to it ([`GaussianFilterTerms`]).
//! - `tent`: exactly, by inverting its CDF per axis; weight 1.
//! - `mitchell`, `catmullrom`, `lanczos`, whose lobes are partly negative: per
//!   axis from `|f|` as tabulated on the host ([`FilterTable`]: the quantiles of
//!   `|f|` over the half axis, so that each of its bins holds an equal share of
//!   the mass, drawn uniformly within), with the weight `f(x) / (p(x) ∫ f)` for
//!   the table's density `p`: negative where `f` is. The weight uses `f` itself,
//!   so the estimate is unbiased whatever the table's resolution, which only
//!   sets how close `|weight|` stays to its ideal constant `∫|f| / ∫ f`
//!   (within 2.5% of its mean square at 64 bins, for Lanczos with 3 lobes).

use super::params::{ParamTable, Result, check_positive, fmt_num, list, type_name, unknown_name};
use crate::shader::{ShaderModule, shader_module};
use serde::Serialize;
use toml::{Table, Value};

/// The filters' offset samplers (`shaders/filter.wgsl`), each under its flags.
pub const FILTER_MODULE: ShaderModule = shader_module!("filter");

/// Every kernel flag a filter sets (`Filter::flags`).
pub const FILTER_FLAGS: &[&str] = &[
    "FILTER_OFFSET",
    "FILTER_GAUSSIAN",
    "FILTER_TENT",
    "FILTER_TABLE",
    "FILTER_MITCHELL",
    "FILTER_LANCZOS",
];

/// Bins of equal mass over a tabulated filter's half axis `[0, r]`.
pub const FILTER_TABLE_BINS: usize = 64;

/// A pixel reconstruction filter; the 1-D profile of each is [`Filter::eval`].
/// The scene's parameters are checked by the parser (`scene`): positive sizes,
/// `lobes` in `1..=Filter::LANCZOS_MAX_LOBES`, Mitchell's `b` and `c` in
/// `[-10, 10]`, where an f32 evaluation keeps its accuracy.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Filter {
    /// Uniform over the pixel (offsets in [-0.5, 0.5) per axis): the default.
    Box,
    /// Per axis `exp(-x^2 / (2 stddev^2))` minus its value at the radius `4 stddev`
    /// (in pixels), as Mitsuba's and pbrt-v4's Gaussian filters.
    Gaussian { stddev: f32 },
    /// `max(0, 1 - |x| / radius)`: never negative, so it never rings.
    Tent { radius: f32 },
    /// Mitchell and Netravali's cubic of parameters `b` and `c` (Mitsuba's `B`
    /// and `C`, default 1/3 each), radius 2.
    Mitchell { b: f32, c: f32 },
    /// The Mitchell cubic with `b = 0`, `c = 1/2` (the Catmull-Rom spline):
    /// sharper, with more ringing.
    CatmullRom,
    /// The Lanczos-windowed sinc `sinc(x) sinc(x / lobes)` (`sinc(x) = sin(pi x)
    /// / (pi x)`), radius `lobes`: sharp, ringing at strong edges.
    Lanczos { lobes: u32 },
}

impl Filter {
    /// Mitsuba's default Gaussian: standard deviation 0.5 pixels.
    pub const GAUSSIAN_DEFAULT_STDDEV: f32 = 0.5;
    pub const TENT_DEFAULT_RADIUS: f32 = 1.0;
    pub const MITCHELL_DEFAULT_B: f32 = 1.0 / 3.0;
    pub const MITCHELL_DEFAULT_C: f32 = 1.0 / 3.0;
    pub const LANCZOS_DEFAULT_LOBES: u32 = 3;
    /// The most lobes a Lanczos filter may have: a radius of 64 pixels, past
    /// any use, keeps the host's integration of the filter exact.
    pub const LANCZOS_MAX_LOBES: u32 = 64;
    /// The bound on `|b|` and `|c|` of a Mitchell filter.
    pub const MITCHELL_MAX_PARAMETER: f32 = 10.0;

    /// The name scene files give it (Mitsuba's plugin name).
    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Gaussian { .. } => "gaussian",
            Filter::Tent { .. } => "tent",
            Filter::Mitchell { .. } => "mitchell",
            Filter::CatmullRom => "catmullrom",
            Filter::Lanczos { .. } => "lanczos",
        }
    }

    /// Half the width of its support, in pixels.
    pub fn radius(self) -> f64 {
        match self {
            Filter::Box => 0.5,
            Filter::Gaussian { stddev } => 4.0 * f64::from(stddev),
            Filter::Tent { radius } => radius.into(),
            Filter::Mitchell { .. } | Filter::CatmullRom => 2.0,
            Filter::Lanczos { lobes } => lobes.into(),
        }
    }

    /// The filter's profile along one axis at `x` pixels from the centre: Mitsuba's
    /// `eval`, in f64 (the kernel's is `shaders/filter.wgsl`'s, in f32).
    pub fn eval(self, x: f64) -> f64 {
        match self {
            Filter::Box => f64::from(u8::from((-0.5..0.5).contains(&x))),
            Filter::Gaussian { stddev } => {
                let terms = GaussianFilterTerms::new(stddev.into());
                let g = (-x * x / (2.0 * terms.stddev * terms.stddev)).exp();
                (g - terms.floor).max(0.0)
            }
            Filter::Tent { radius } => (1.0 - (x / f64::from(radius)).abs()).max(0.0),
            Filter::Mitchell { b, c } => mitchell(b.into(), c.into(), x),
            Filter::CatmullRom => mitchell(0.0, 0.5, x),
            Filter::Lanczos { lobes } => {
                let (x, lobes) = (x.abs(), f64::from(lobes));
                let (x1, x2) = (std::f64::consts::PI * x, std::f64::consts::PI * x / lobes);
                match x {
                    _ if x < f64::from(f32::EPSILON) / 2.0 => 1.0,
                    _ if x > lobes => 0.0,
                    _ => x1.sin() * x2.sin() / (x1 * x2),
                }
            }
        }
    }

    /// The kernel flags its code is compiled under (none for the box filter,
    /// which `camera_ray` draws itself).
    pub fn flags(self) -> &'static [&'static str] {
        match self {
            Filter::Box => &[],
            Filter::Gaussian { .. } => &["FILTER_OFFSET", "FILTER_GAUSSIAN"],
            Filter::Tent { .. } => &["FILTER_OFFSET", "FILTER_TENT"],
            Filter::Mitchell { .. } | Filter::CatmullRom => {
                &["FILTER_OFFSET", "FILTER_TABLE", "FILTER_MITCHELL"]
            }
            Filter::Lanczos { .. } => &["FILTER_OFFSET", "FILTER_TABLE", "FILTER_LANCZOS"],
        }
    }

    /// Values of its WGSL `override` constants.
    pub fn constants(self) -> Vec<(&'static str, f64)> {
        let mut constants = match self {
            Filter::Box => vec![],
            Filter::Gaussian { stddev } => {
                let g = GaussianFilterTerms::new(stddev.into());
                vec![
                    ("FILTER_STDDEV", g.stddev),
                    ("FILTER_RADIUS", g.radius),
                    ("FILTER_ERF_RADIUS", g.erf_radius),
                    ("FILTER_FLOOR", g.floor),
                    ("FILTER_WEIGHT_SCALE", g.weight_scale),
                ]
            }
            Filter::Tent { radius } => vec![("FILTER_RADIUS", radius.into())],
            Filter::Mitchell { b, c } => vec![("FILTER_B", b.into()), ("FILTER_C", c.into())],
            Filter::CatmullRom => vec![("FILTER_B", 0.0), ("FILTER_C", 0.5)],
            Filter::Lanczos { lobes } => vec![("FILTER_LOBES", lobes.into())],
        };
        if let Some(table) = self.table() {
            constants.push(("FILTER_TABLE_SCALE", table.weight_scale));
        }
        constants
    }

    /// Pixels, along each axis, beyond its own that a sample reaches when it is
    /// splatted: those whose centre can lie within the radius of a point of the
    /// pixel (0 for the box filter).
    pub fn splat_reach(self) -> u32 {
        ((self.radius() + 0.5).ceil() as u32).saturating_sub(1)
    }

    /// `∫_0^min(r, j + 1/2) f` for `j` in `0..=splat_reach()`: the filter's
    /// integral over the image on one side of a pixel `j` pixels from the
    /// image's edge, which splatting divides by (`shaders/splat.wgsl`).
    pub fn splat_edge_integrals(self) -> Vec<f64> {
        let radius = self.radius();
        let cells_per_pixel = FilterTable::CELLS_PER_PIXEL;
        (0..=self.splat_reach())
            .map(|j| {
                let end = radius.min(f64::from(j) + 0.5);
                let cells = (cells_per_pixel as f64 * end).ceil().max(1.0) as usize;
                let h = end / cells as f64;
                (0..cells)
                    .map(|k| gauss_legendre(|x| self.eval(x), k as f64 * h, h).0)
                    .sum()
            })
            .collect()
    }

    /// The sampling table of a filter drawn from a table (those with negative lobes).
    pub fn table(self) -> Option<FilterTable> {
        matches!(
            self,
            Filter::Mitchell { .. } | Filter::CatmullRom | Filter::Lanczos { .. }
        )
        .then(|| FilterTable::new(self))
    }
}

/// Mitsuba's `mitchell.cpp`: the cubic of Mitchell and Netravali (1988).
fn mitchell(b: f64, c: f64, x: f64) -> f64 {
    let x = x.abs();
    let (x2, x3) = (x * x, x * x * x);
    let value = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else {
        (-b - 6.0 * c) * x3
            + (6.0 * b + 30.0 * c) * x2
            + (-12.0 * b - 48.0 * c) * x
            + (8.0 * b + 24.0 * c)
    };
    if x < 2.0 { value / 6.0 } else { 0.0 }
}

/// How the kernel draws a filter along one axis from `|f|`: a sign, then `|x|`
/// on `[0, r]` in bin `j` of `quantiles` (the points below which `|f|` holds
/// `j / N` of its mass, `N = FILTER_TABLE_BINS`), uniformly within it. The
/// density over the whole axis is `1 / (2 N width_j)`, so the weight
/// `f(x) / (p(x) ∫ f)` is `f(x) width_j weight_scale`.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterTable {
    /// `0 = q_0 < q_1 < ... < q_N = r`, exactly as the kernel reads them.
    pub quantiles: [f32; FILTER_TABLE_BINS + 1],
    /// `N / ∫_0^r f`.
    pub weight_scale: f64,
}

impl FilterTable {
    /// Cells of the integration per pixel of radius: the radii of tabulated
    /// filters are whole, so the Mitchell cubics' joint and Lanczos's zeros fall
    /// on cell boundaries, and 4-point Gauss-Legendre is exact on a cubic's cell
    /// and converges fast on the smooth sinc.
    const CELLS_PER_PIXEL: usize = 256;

    fn new(filter: Filter) -> FilterTable {
        let radius = filter.radius();
        let cells = Self::CELLS_PER_PIXEL * radius.ceil() as usize;
        let h = radius / cells as f64;
        // ∫ f and ∫ |f| from 0 to each cell boundary.
        let mut integral = 0.0;
        let mut cumulative = vec![0.0; cells + 1];
        for k in 0..cells {
            let (signed, absolute) = gauss_legendre(|x| filter.eval(x), k as f64 * h, h);
            integral += signed;
            cumulative[k + 1] = cumulative[k] + absolute;
        }
        let mass = cumulative[cells];
        let mut quantiles = [0.0; FILTER_TABLE_BINS + 1];
        for (j, q) in quantiles.iter_mut().enumerate().skip(1) {
            let target = mass * j as f64 / FILTER_TABLE_BINS as f64;
            let k = cumulative.partition_point(|&c| c < target).clamp(1, cells) - 1;
            let within = (target - cumulative[k]) / (cumulative[k + 1] - cumulative[k]);
            *q = ((k as f64 + within.clamp(0.0, 1.0)) * h) as f32;
        }
        quantiles[FILTER_TABLE_BINS] = radius as f32;
        FilterTable {
            quantiles,
            weight_scale: FILTER_TABLE_BINS as f64 / integral,
        }
    }
}

/// `(∫ f, ∫ |f|)` over `[a, a + h]` by 4-point Gauss-Legendre.
fn gauss_legendre(f: impl Fn(f64) -> f64, a: f64, h: f64) -> (f64, f64) {
    const NODES: [(f64, f64); 4] = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];
    NODES
        .iter()
        .fold((0.0, 0.0), |(signed, absolute), &(node, weight)| {
            let value = f(a + h * (node + 1.0) / 2.0) * weight * h / 2.0;
            (signed + value, absolute + value.abs())
        })
}

/// The host-side terms of the Gaussian filter's sampling (`shaders/filter.wgsl`).
/// Per axis the filter is `f(x) = g(x) - g(r)` on `[-r, r]`, `g(x) = exp(-x^2 / 2s^2)`,
/// `r = 4s`. The kernel draws `x` from the truncated Gaussian `g / Z_g` exactly, by
/// inverting its CDF, and weights the sample by `f(x) / g(x) * Z_g / Z_f`, whose mean
/// is 1: the estimate is `integral f L / integral f`, unbiased.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianFilterTerms {
    pub stddev: f64,
    pub radius: f64,
    /// `erf(r / (s sqrt 2))`: the CDF's range to invert into.
    pub erf_radius: f64,
    /// `g(r)`, subtracted so the filter reaches zero at its radius.
    pub floor: f64,
    /// `Z_g / Z_f`, with `Z_g = s sqrt(2 pi) erf(r / (s sqrt 2))` and `Z_f = Z_g - 2 r g(r)`.
    pub weight_scale: f64,
}

impl GaussianFilterTerms {
    pub fn new(stddev: f64) -> GaussianFilterTerms {
        let radius = 4.0 * stddev;
        let erf_radius = libm::erf(radius / (stddev * std::f64::consts::SQRT_2));
        let floor = (-radius * radius / (2.0 * stddev * stddev)).exp();
        let z_g = stddev * (2.0 * std::f64::consts::PI).sqrt() * erf_radius;
        let z_f = z_g - 2.0 * radius * floor;
        GaussianFilterTerms {
            stddev,
            radius,
            erf_radius,
            floor,
            weight_scale: z_g / z_f,
        }
    }
}

/// How a pixel's estimate is made of the samples around it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Reconstruction {
    /// Each sample weighted into every pixel its filter reaches, as Mitsuba's
    /// film splats: a pixel averages the samples of its neighbours too (about
    /// 3x as many with Mitsuba's Gaussian), so the image is less noisy at equal
    /// samples, its noise correlated over the filter's width.
    Splat,
    /// Filter importance sampling: each sample's offset drawn from the filter,
    /// the sample kept by its own pixel.
    Importance,
}

impl Reconstruction {
    pub const ALL: [Reconstruction; 2] = [Reconstruction::Splat, Reconstruction::Importance];

    pub fn name(self) -> &'static str {
        match self {
            Reconstruction::Splat => "splat",
            Reconstruction::Importance => "importance",
        }
    }

    pub fn from_name(name: &str) -> Option<Reconstruction> {
        Self::ALL.into_iter().find(|r| r.name() == name)
    }
}

/// Each filter type and its keys besides `type`.
pub(crate) const FILTER_KEYS: &[(&str, &[&str])] = &[
    ("box", &[]),
    ("gaussian", &["stddev"]),
    ("tent", &["radius"]),
    ("mitchell", &["b", "c"]),
    ("catmullrom", &[]),
    ("lanczos", &["lobes"]),
];

impl Filter {
    /// The camera table's `filter`: `"NAME"` (with its defaults) or `{ type =
    /// "NAME", KEY = VALUE }`, a filter's keys being those [`FILTER_KEYS`] names
    /// for its type; the box filter without one.
    pub(crate) fn parse(t: &ParamTable) -> Result<Filter> {
        let no_keys = Table::new();
        let (f, name, name_at) = match t.table.get("filter") {
            None => return Ok(Filter::Box),
            Some(Value::String(name)) => {
                let f = ParamTable {
                    file: t.file,
                    table: &no_keys,
                    path: t.at("filter"),
                    inputs: t.inputs,
                };
                (f, name.as_str(), t.at("filter"))
            }
            Some(Value::Table(_)) => {
                let f = t.sub("filter")?.expect("key exists");
                let name = f.require("type", f.string("type")?)?;
                let name_at = f.at("type");
                (f, name, name_at)
            }
            Some(other) => {
                return Err(t.err(
                    t.at("filter"),
                    format!(
                        "expected a filter name (one of {}) or a table, got {}",
                        list(&filter_types()),
                        type_name(other)
                    ),
                ));
            }
        };
        let Some(&(_, keys)) = FILTER_KEYS.iter().find(|(n, _)| *n == name) else {
            return Err(f.err(name_at, unknown_name("filter type", name, &filter_types())));
        };
        let known: Vec<&str> = ["type"].into_iter().chain(keys.iter().copied()).collect();
        f.check_keys(&known, Some(&format!("the {name} filter")))?;
        Ok(match name {
            "box" => Filter::Box,
            "gaussian" => Filter::Gaussian {
                stddev: f
                    .float("stddev", check_positive)?
                    .unwrap_or(Filter::GAUSSIAN_DEFAULT_STDDEV),
            },
            "tent" => Filter::Tent {
                radius: f
                    .float("radius", check_positive)?
                    .unwrap_or(Filter::TENT_DEFAULT_RADIUS),
            },
            "mitchell" => Filter::Mitchell {
                b: f.float("b", check_mitchell_parameter)?
                    .unwrap_or(Filter::MITCHELL_DEFAULT_B),
                c: f.float("c", check_mitchell_parameter)?
                    .unwrap_or(Filter::MITCHELL_DEFAULT_C),
            },
            "catmullrom" => Filter::CatmullRom,
            _ => Filter::Lanczos {
                lobes: f
                    .int("lobes", (1, Filter::LANCZOS_MAX_LOBES.into()))?
                    .unwrap_or(Filter::LANCZOS_DEFAULT_LOBES),
            },
        })
    }
}

pub(crate) fn filter_types() -> Vec<&'static str> {
    FILTER_KEYS.iter().map(|&(name, _)| name).collect()
}

fn check_mitchell_parameter(x: f32) -> std::result::Result<(), String> {
    let bound = Filter::MITCHELL_MAX_PARAMETER;
    if x.abs() <= bound {
        Ok(())
    } else {
        Err(format!(
            "must be in [-{bound}, {bound}], got {}",
            fmt_num(x)
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The host terms against values computed independently (Mitsuba's default).
    #[test]
    fn gaussian_filter_terms() {
        let g = GaussianFilterTerms::new(0.5);
        assert_eq!(g.radius, 2.0);
        assert!((g.erf_radius - 0.999_936_657_516_333_8).abs() < 1e-15);
        assert!((g.floor - (-8f64).exp()).abs() < 1e-18);
        // Z_g = 0.5 sqrt(2 pi) erf(2 sqrt 2); Z_f = Z_g - 4 exp(-8).
        let z_g = 0.5 * (2.0 * std::f64::consts::PI).sqrt() * 0.999_936_657_516_333_8;
        assert!((g.weight_scale - z_g / (z_g - 4.0 * (-8f64).exp())).abs() < 1e-12);
    }

    /// Values worked by hand from Mitsuba's formulas.
    #[test]
    fn profiles_match_mitsuba() {
        let mitchell = Filter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        };
        let lanczos = Filter::Lanczos { lobes: 3 };
        let cases = [
            (Filter::Tent { radius: 1.5 }, 0.75, 0.5),
            (Filter::Tent { radius: 1.5 }, -1.5, 0.0),
            // (6 - 2B) / 6 at 0; B / 6 at 1 (both pieces agree); 0 from 2 on.
            (mitchell, 0.0, 8.0 / 9.0),
            (mitchell, 1.0, 1.0 / 18.0),
            (mitchell, 2.0, 0.0),
            (Filter::CatmullRom, 0.0, 1.0),
            (Filter::CatmullRom, 0.5, 0.5625),
            (Filter::CatmullRom, 1.0, 0.0),
            (Filter::CatmullRom, -1.5, -0.0625),
            (lanczos, 0.0, 1.0),
            // sin(pi / 2) sin(pi / 6) / ((pi / 2) (pi / 6)) = 6 / pi^2.
            (
                lanczos,
                0.5,
                6.0 / (std::f64::consts::PI * std::f64::consts::PI),
            ),
            (lanczos, 2.0, 0.0),
            (lanczos, 3.5, 0.0),
            (Filter::Box, -0.5, 1.0),
            (Filter::Box, 0.5, 0.0),
        ];
        for (filter, x, expected) in cases {
            let value = filter.eval(x);
            // b = 1/3 is an f32.
            assert!(
                (value - expected).abs() < 1e-8,
                "{filter:?} at {x}: {value}, expected {expected}"
            );
        }
        // A Mitchell cubic's lobes sum to 1 whatever b and c: ∫ f = 1.
        for filter in [
            mitchell,
            Filter::CatmullRom,
            Filter::Mitchell { b: -2.0, c: 7.0 },
        ] {
            let table = filter.table().unwrap();
            let half = FILTER_TABLE_BINS as f64 / table.weight_scale;
            assert!((half - 0.5).abs() < 1e-13, "{filter:?}: {half}");
        }
    }

    /// The quantiles rise strictly from 0 to the radius, and each bin holds
    /// `1 / N` of `∫ |f|` (a finer integration than the table's).
    #[test]
    fn table_bins_hold_equal_mass() {
        let filters = [
            Filter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Mitchell { b: 0.0, c: 0.0 },
            Filter::Mitchell { b: -10.0, c: 10.0 },
            Filter::CatmullRom,
            Filter::Lanczos { lobes: 1 },
            Filter::Lanczos { lobes: 3 },
            Filter::Lanczos {
                lobes: Filter::LANCZOS_MAX_LOBES,
            },
        ];
        for filter in filters {
            let table = filter.table().unwrap();
            let q = table.quantiles;
            assert_eq!(q[0], 0.0);
            assert_eq!(f64::from(q[FILTER_TABLE_BINS]), filter.radius());
            assert!(q.windows(2).all(|w| w[0] < w[1]), "{filter:?}: {q:?}");
            let absolute = |a: f64, b: f64| {
                let steps = 4000;
                let h = (b - a) / steps as f64;
                (0..steps)
                    .map(|i| filter.eval(a + (i as f64 + 0.5) * h).abs() * h)
                    .sum::<f64>()
            };
            let total = absolute(0.0, filter.radius());
            for w in q.windows(2) {
                let share = absolute(w[0].into(), w[1].into()) / total;
                assert!(
                    (share * FILTER_TABLE_BINS as f64 - 1.0).abs() < 1e-3,
                    "{filter:?}: a bin of [{}, {}] holds {share}",
                    w[0],
                    w[1]
                );
            }
        }
    }
}
