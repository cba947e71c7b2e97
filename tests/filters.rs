//! The pixel filters (`kinds::Filter`). On the device, the kernel's own WGSL
//! (composed with `shaders/filter_probe.wgsl`) draws 2^20 offsets of each
//! filter: they fall into the cells of a grid over its support as often as
//! the density it is sampled by says (|f|, or the Gaussian the Gaussian filter
//! is drawn from; Pearson's chi-square), and the weights they carry sum, cell
//! by cell, to the filter's own share `∫_cell f / ∫ f` (the condition for the
//! estimate to be unbiased). A constant scene renders its constant through
//! every filter, and pixels behind a light's edge match the filter's integral.
//! The filters' profiles here are written from Mitsuba 3's sources
//! (`src/rfilters/*.cpp`), apart from the library's. Then the scene formats:
//! names, Mitsuba's parameters and defaults, and refusals.

mod common;

use pathmix::gpu::GpuContext;
use pathmix::kernel::KernelConfig;
use pathmix::scene::{Filter, Scene};
use std::f64::consts::PI;
use std::process::Command;

const SAMPLES: u32 = 1 << 20;
const WORKGROUP: u32 = 64;
/// Cells per axis of the grid over `[-r, r]`.
const CELLS: usize = 16;

/// Mitsuba's filter profile along one axis, and its radius.
fn mitsuba_profile(filter: Filter) -> (Box<dyn Fn(f64) -> f64>, f64) {
    let mitchell = |b: f64, c: f64| {
        move |x: f64| {
            let x = x.abs();
            let value = if x < 1.0 {
                (12.0 - 9.0 * b - 6.0 * c) * x.powi(3)
                    + (-18.0 + 12.0 * b + 6.0 * c) * x * x
                    + (6.0 - 2.0 * b)
            } else {
                (-b - 6.0 * c) * x.powi(3)
                    + (6.0 * b + 30.0 * c) * x * x
                    + (-12.0 * b - 48.0 * c) * x
                    + (8.0 * b + 24.0 * c)
            };
            if x < 2.0 { value / 6.0 } else { 0.0 }
        }
    };
    match filter {
        Filter::Box => (
            Box::new(|x| f64::from(u8::from((-0.5..0.5).contains(&x)))),
            0.5,
        ),
        Filter::Gaussian { stddev } => {
            let (s, r) = (f64::from(stddev), 4.0 * f64::from(stddev));
            let g = move |x: f64| (-x * x / (2.0 * s * s)).exp();
            (Box::new(move |x| (g(x) - g(r)).max(0.0)), r)
        }
        Filter::Tent { radius } => {
            let r = f64::from(radius);
            (Box::new(move |x| (1.0 - x.abs() / r).max(0.0)), r)
        }
        Filter::Mitchell { b, c } => (Box::new(mitchell(b.into(), c.into())), 2.0),
        Filter::CatmullRom => (Box::new(mitchell(0.0, 0.5)), 2.0),
        Filter::Lanczos { lobes } => {
            let a = f64::from(lobes);
            let sinc = |x: f64| {
                if x == 0.0 {
                    1.0
                } else {
                    (PI * x).sin() / (PI * x)
                }
            };
            (
                Box::new(move |x| {
                    if x.abs() > a {
                        0.0
                    } else {
                        sinc(x) * sinc(x / a)
                    }
                }),
                a,
            )
        }
    }
}

/// The density (up to a factor) an axis of `filter` is drawn from.
fn sampled_profile(filter: Filter) -> Box<dyn Fn(f64) -> f64> {
    let (f, _) = mitsuba_profile(filter);
    match filter {
        Filter::Gaussian { stddev } => {
            let s = f64::from(stddev);
            Box::new(move |x| (-x * x / (2.0 * s * s)).exp())
        }
        _ => Box::new(move |x| f(x).abs()),
    }
}

/// `∫ g` over `[a, b]`: 64 panels of 8-point Gauss-Legendre (the filters are
/// smooth but for a few joints and zeros, whose error is far below the tests').
fn integral(g: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const NODES: [(f64, f64); 4] = [
        (0.183_434_642_495_649_8, 0.362_683_783_378_362),
        (0.525_532_409_916_329, 0.313_706_645_877_887_3),
        (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
        (0.960_289_856_497_536_3, 0.101_228_536_290_376_3),
    ];
    let panels = 64;
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|i| {
            let mid = a + (i as f64 + 0.5) * h;
            let sum: f64 = NODES
                .iter()
                .map(|&(x, w)| w * (g(mid - x * h / 2.0) + g(mid + x * h / 2.0)))
                .sum();
            sum * h / 2.0
        })
        .sum()
}

/// 2^20 offsets `(x, y, weight)` of `filter`, drawn by the kernel's WGSL.
fn probe(ctx: &GpuContext, filter: Filter) -> Vec<[f32; 4]> {
    let source = KernelConfig::filter_probe_source(filter).unwrap();
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("filter probe"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    let constants = filter.constants();
    let pipeline = ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("filter probe"),
            layout: None,
            module: &module,
            entry_point: Some("probe_filter"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        });
    let out = common::ProbeOutput::new(ctx, u64::from(SAMPLES));
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("filter probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: out.buffer.as_entire_binding(),
        }],
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(SAMPLES / WORKGROUP, 1, 1);
    }
    out.read(ctx, encoder)
}

/// What the offsets of one filter showed.
#[derive(Debug)]
struct Measured {
    /// Chi-square of the cell counts against the density the filter is drawn from.
    count_p_value: f64,
    /// Chi-square of the weight sums per cell, each against `n ∫_cell f / ∫ f`
    /// by its standard error (the cells expecting fewer than 5 samples pooled).
    weight_p_value: f64,
    /// The mean weight and its standard error.
    mean_weight: f64,
    weight_error: f64,
    /// Offsets outside the support or with a non-finite weight.
    outside: usize,
    /// For a filter drawn from a table of |f|: the total variation distance
    /// between the table's density and |f| over the cells of an axis.
    table_distance: Option<f64>,
}

/// The share of the density that the table of `filter` (`Filter::table`,
/// uniform within each of its bins on either side) gives `[a, b]`.
fn table_share(filter: Filter, a: f64, b: f64) -> f64 {
    let table = filter.table().unwrap();
    let bins = table.quantiles.len() - 1;
    let overlap = |low: f64, high: f64| (b.min(high) - a.max(low)).max(0.0) / (high - low);
    table
        .quantiles
        .windows(2)
        .map(|w| {
            let (low, high) = (f64::from(w[0]), f64::from(w[1]));
            (overlap(low, high) + overlap(-high, -low)) / (2 * bins) as f64
        })
        .sum()
}

fn measure(samples: &[[f32; 4]], filter: Filter) -> Measured {
    let (f, r) = mitsuba_profile(filter);
    let edges: Vec<f64> = (0..=CELLS)
        .map(|i| -r + 2.0 * r * i as f64 / CELLS as f64)
        .collect();
    let cell_integrals = |g: &dyn Fn(f64) -> f64| -> Vec<f64> {
        let cells: Vec<f64> = edges.windows(2).map(|w| integral(g, w[0], w[1])).collect();
        let total: f64 = cells.iter().sum();
        cells.iter().map(|c| c / total).collect()
    };
    let filter_share = cell_integrals(&*f);
    let (density_share, table_distance) = match filter.table() {
        Some(_) => {
            let table: Vec<f64> = (edges.windows(2))
                .map(|w| table_share(filter, w[0], w[1]))
                .collect();
            let absolute = cell_integrals(&|x| f(x).abs());
            let distance = table.iter().zip(&absolute).map(|(t, a)| (t - a).abs());
            (table.clone(), Some(distance.sum::<f64>() / 2.0))
        }
        None => (cell_integrals(&*sampled_profile(filter)), None),
    };
    let mut counts = vec![0.0; CELLS * CELLS];
    let mut weights = vec![0.0; CELLS * CELLS];
    let mut squares = vec![0.0; CELLS * CELLS];
    let mut outside = 0;
    let cell = |x: f32| ((f64::from(x) + r) / (2.0 * r) * CELLS as f64).floor() as i64;
    for s in samples {
        let (i, j) = (cell(s[0]), cell(s[1]));
        let w = f64::from(s[2]);
        let inside = (0..CELLS as i64).contains(&i) && (0..CELLS as i64).contains(&j);
        if !inside || !w.is_finite() {
            outside += 1;
            continue;
        }
        let k = j as usize * CELLS + i as usize;
        counts[k] += 1.0;
        weights[k] += w;
        squares[k] += w * w;
    }
    let n = samples.len() as f64;
    let expected: Vec<f64> = (0..CELLS * CELLS)
        .map(|k| n * density_share[k % CELLS] * density_share[k / CELLS])
        .collect();
    // Per cell (the few expecting under 5 samples pooled): the weight sum, its
    // expectation and the sum of squared weights.
    let mut groups = Vec::new();
    let mut pool = (0.0, 0.0, 0.0);
    for k in 0..CELLS * CELLS {
        let share = filter_share[k % CELLS] * filter_share[k / CELLS];
        let group = (weights[k], n * share, squares[k]);
        match expected[k] < 5.0 {
            true => pool = (pool.0 + group.0, pool.1 + group.1, pool.2 + group.2),
            false => groups.push(group),
        }
    }
    let pooled = expected.iter().filter(|&&e| e < 5.0).sum::<f64>();
    if pooled >= 5.0 {
        groups.push(pool);
    }
    // The variance of a weight sum over n samples is n Var(w 1_cell).
    let statistic: f64 = (groups.iter())
        .map(|&(sum, mean, squares)| (sum - mean).powi(2) / (squares - sum * sum / n))
        .sum();
    let mean_weight = weights.iter().sum::<f64>() / n;
    let mean_square = squares.iter().sum::<f64>() / n;
    Measured {
        count_p_value: common::chi_square_p_value(&counts, &expected),
        weight_p_value: common::chi_square_survival(statistic, groups.len() as f64),
        mean_weight,
        weight_error: ((mean_square - mean_weight * mean_weight) / n).sqrt(),
        outside,
        table_distance,
    }
}

/// Each filter, with Mitsuba's defaults and other parameters.
const FILTERS: [Filter; 10] = [
    Filter::Box,
    Filter::Gaussian { stddev: 0.5 },
    Filter::Tent { radius: 1.0 },
    Filter::Tent { radius: 1.25 },
    Filter::Mitchell {
        b: 1.0 / 3.0,
        c: 1.0 / 3.0,
    },
    Filter::Mitchell { b: 0.25, c: 0.55 },
    Filter::CatmullRom,
    Filter::Lanczos { lobes: 1 },
    Filter::Lanczos { lobes: 2 },
    Filter::Lanczos { lobes: 3 },
];

/// Each filter's offsets against the density it is drawn from, and its weights
/// against the filter, cell by cell (p-values above 0.01 after a Bonferroni
/// correction over the filters and both tests); every offset within the
/// support; the mean weight 1 within 5 standard errors. A filter drawn from a
/// table of |f| is drawn from the table's density, which 2^20 samples tell
/// from |f| itself (p < 0.001 for each); the table is within 2% of |f| (total
/// variation over the cells of an axis: 0.6-1.2% measured, the cost of its
/// density's being flat within each bin), and its bins' masses are checked
/// finely in `kinds::filter`.
#[test]
fn offsets_and_weights_match_the_filters() {
    let ctx = gpu_or_skip!();
    let threshold = 0.01 / (2 * FILTERS.len()) as f64;
    let mut failures = Vec::new();
    // The box filter is drawn by `camera_ray` itself, and has no sampler to probe.
    for filter in FILTERS.into_iter().filter(|&f| f != Filter::Box) {
        let m = measure(&probe(ctx, filter), filter);
        println!(
            "{filter:?}: counts p = {:.3}, weights p = {:.3}, mean weight {:.5} ± {:.5}, \
             table's distance to |f| {:?}",
            m.count_p_value, m.weight_p_value, m.mean_weight, m.weight_error, m.table_distance
        );
        if m.count_p_value < threshold
            || m.weight_p_value < threshold
            || m.outside > 0
            || m.table_distance.is_some_and(|d| d > 0.02)
            || (m.mean_weight - 1.0).abs() > 5.0 * m.weight_error + 1e-6
        {
            failures.push(format!("{filter:?}: {m:?}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The tests above can fail: Lanczos's offsets drawn from |f| are far from the
/// Catmull-Rom's |f|, and Lanczos's weights are not the tent's.
#[test]
fn a_wrong_filter_fails_the_tests() {
    let ctx = gpu_or_skip!();
    let lanczos = probe(ctx, Filter::Lanczos { lobes: 2 });
    let as_catmull_rom = measure(&lanczos, Filter::CatmullRom);
    assert!(as_catmull_rom.count_p_value < 1e-6, "{as_catmull_rom:?}");
    // Same support and radius 2: the counts differ, and the weights too.
    let as_tent = measure(&lanczos, Filter::Tent { radius: 2.0 });
    assert!(as_tent.weight_p_value < 1e-6, "{as_tent:?}");
}

/// Both ways a filter makes pixels of samples (`render.reconstruction`).
const RECONSTRUCTIONS: [&str; 2] = ["splat", "importance"];

fn filter_toml(filter: Filter) -> String {
    match filter {
        Filter::Box => "\"box\"".into(),
        Filter::Gaussian { stddev } => format!("{{ type = \"gaussian\", stddev = {stddev} }}"),
        Filter::Tent { radius } => format!("{{ type = \"tent\", radius = {radius} }}"),
        Filter::Mitchell { b, c } => format!("{{ type = \"mitchell\", b = {b}, c = {c} }}"),
        Filter::CatmullRom => "\"catmullrom\"".into(),
        Filter::Lanczos { lobes } => format!("{{ type = \"lanczos\", lobes = {lobes} }}"),
    }
}

/// Under a constant radiance of 1 (the background, no objects) every filter's
/// image is 1, splatted or drawn from: the mean weight is 1, over the image within 4 standard errors
/// and in every pixel within 5.
#[test]
fn a_constant_scene_renders_its_constant() {
    let ctx = gpu_or_skip!();
    for (filter, reconstruction) in FILTERS
        .iter()
        .flat_map(|&f| RECONSTRUCTIONS.map(|r| (f, r)))
    {
        let scene = common::scene_text(&format!(
            r#"
            [camera]
            lookfrom = [0, 0, 0]
            lookat = [0, 0, 1]
            width = 4
            height = 4
            filter = {}
            [render]
            spp = 65536
            max_depth = 0
            background = [1, 1, 1]
            sampler = "independent"
            reconstruction = "{reconstruction}"
            "#,
            filter_toml(filter)
        ));
        assert_eq!(scene.camera.filter, filter);
        let acc = common::render(ctx, &scene, &common::with_variance());
        let (mean, error) = common::image_mean_and_error(&acc);
        println!("{filter:?} by {reconstruction}: {mean:.5} ± {error:.5}");
        assert!(
            (mean - 1.0).abs() < 4.0 * error + 1e-6,
            "{filter:?} by {reconstruction}: {mean} ± {error}"
        );
        let (means, errors) = (acc.mean(), acc.standard_error().unwrap());
        for (m, e) in means.pixels.iter().zip(&errors.pixels) {
            let (m, e) = (f64::from(m[0]), f64::from(e[0]));
            assert!(
                (m - 1.0).abs() < 5.0 * e + 1e-6,
                "{filter:?} by {reconstruction}: a pixel {m} ± {e}"
            );
        }
    }
}

/// The tent's mass below `t` (its CDF), in closed form.
fn tent_cdf(radius: f64, t: f64) -> f64 {
    let t = t.clamp(-radius, radius);
    match t <= 0.0 {
        true => (t + radius).powi(2) / (2.0 * radius * radius),
        false => 1.0 - (radius - t).powi(2) / (2.0 * radius * radius),
    }
}

/// Behind a vertical light edge through the image centre, pixel `k`'s value is
/// the filter's share on the light's side, `∫_{-r}^{-d} f / ∫ f` for the pixel
/// centre at `d` pixels from the edge: the tent's in closed form, the others'
/// by quadrature, overshoot and undershoot included (within 4 standard errors).
/// Pixels beyond the radius are exactly 0, or 1 on average. Both ways of
/// reconstruction: splatting's share at the image's edge is of the filter
/// truncated there, which here is all lit or all dark alike.
#[test]
fn a_light_edge_is_the_filters_integral() {
    let ctx = gpu_or_skip!();
    for filter in FILTERS {
        let (f, r) = mitsuba_profile(filter);
        let total = integral(&*f, -r, r);
        let share = |t: f64| match filter {
            Filter::Tent { radius } => tent_cdf(radius.into(), t),
            _ => integral(&*f, -r, t.clamp(-r, r)) / total,
        };
        for reconstruction in RECONSTRUCTIONS {
            let what = format!("{filter:?} by {reconstruction}");
            let filter = (&filter_toml(filter)[..], reconstruction);
            common::assert_light_edge(ctx, (12, 65536), filter, r, share, &what);
        }
    }
}

/// The names and defaults of `filter = "NAME"` and of its table.
#[test]
fn toml_filters_take_mitsubas_defaults() {
    let parse = |filter: &str| {
        let text =
            format!("[camera]\nlookfrom = [0, 0, 0]\nlookat = [0, 0, 1]\nfilter = {filter}\n");
        Scene::parse(&text, "f.toml").map(|scene| scene.camera.filter)
    };
    let third = 1.0 / 3.0;
    for (text, expected) in [
        ("\"tent\"", Filter::Tent { radius: 1.0 }),
        ("{ type = \"tent\" }", Filter::Tent { radius: 1.0 }),
        (
            "{ type = \"tent\", radius = 1.5 }",
            Filter::Tent { radius: 1.5 },
        ),
        ("\"mitchell\"", Filter::Mitchell { b: third, c: third }),
        (
            "{ type = \"mitchell\", c = 0.5 }",
            Filter::Mitchell { b: third, c: 0.5 },
        ),
        ("\"catmullrom\"", Filter::CatmullRom),
        ("\"lanczos\"", Filter::Lanczos { lobes: 3 }),
        (
            "{ type = \"lanczos\", lobes = 2 }",
            Filter::Lanczos { lobes: 2 },
        ),
        ("\"gaussian\"", Filter::Gaussian { stddev: 0.5 }),
        ("\"box\"", Filter::Box),
    ] {
        assert_eq!(parse(text).unwrap(), expected, "{text}");
    }
    for (text, message) in [
        (
            "{ type = \"tent\", radius = 0 }",
            "f.toml: camera.filter.radius: must be > 0, got 0",
        ),
        (
            "{ type = \"tent\", radius = -1.5 }",
            "camera.filter.radius: must be > 0, got -1.5",
        ),
        (
            "{ type = \"lanczos\", lobes = 0 }",
            "camera.filter.lobes: must be between 1 and 64, got 0",
        ),
        (
            "{ type = \"lanczos\", lobes = 65 }",
            "camera.filter.lobes: must be between 1 and 64, got 65",
        ),
        (
            "{ type = \"lanczos\", lobes = 2.5 }",
            "camera.filter.lobes: expected an integer",
        ),
        (
            "{ type = \"mitchell\", b = 11 }",
            "camera.filter.b: must be in [-10, 10], got 11",
        ),
        (
            "{ type = \"mitchell\", radius = 2 }",
            "unknown key `radius` for the mitchell filter",
        ),
        (
            "{ type = \"catmullrom\", c = 0.5 }",
            "unknown key `c` for the catmullrom filter",
        ),
        (
            "\"bicubic\"",
            "camera.filter: unknown filter type `bicubic`",
        ),
        (
            "{ type = \"lanczo\" }",
            "camera.filter.type: unknown filter type `lanczo` (did you mean `lanczos`?)",
        ),
    ] {
        let error = parse(text).unwrap_err().to_string();
        assert!(error.contains(message), "{text}: {error}");
    }
}

/// A TOML scene with a filter of radius 0 is refused by `render` with exit
/// code 2, naming the file and the field.
#[test]
fn a_bad_filter_exits_with_code_2() {
    let dir = common::TempDir::new("filters", "bad");
    let scene = dir.join("bad.toml");
    std::fs::write(
        &scene,
        "[camera]\nlookfrom = [0, 0, 0]\nlookat = [0, 0, 1]\nfilter = { type = \"tent\", radius = 0 }\n",
    )
    .unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_pathmix"))
        .args(["render", scene.to_str().unwrap(), "-o"])
        .arg(dir.join("out.png"))
        .env("NODEVICE_SELECT", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("bad.toml: camera.filter.radius: must be > 0, got 0"),
        "{stderr}"
    );
}

/// `<rfilter>` of each type, its parameters named and defaulted as Mitsuba's
/// plugins name them (Mitchell's `B` and `C`, Lanczos's integer `lobes`); a
/// filter of radius 0.5 is Mitsuba's box filter.
#[test]
fn mitsuba_rfilters_read_with_their_defaults() {
    let dir = common::TempDir::new("filters", "mitsuba");
    let read = |rfilter: &str| {
        let path = dir.join("scene.xml");
        std::fs::write(
            &path,
            format!(
                "<scene version=\"3.0.0\"><sensor type=\"perspective\"><float name=\"fov\" \
                 value=\"40\"/><film type=\"hdrfilm\">{rfilter}</film></sensor></scene>"
            ),
        )
        .unwrap();
        Scene::load(&path).map(|scene| scene.camera.filter)
    };
    let third = 1.0 / 3.0;
    for (rfilter, expected) in [
        ("", Filter::Gaussian { stddev: 0.5 }),
        ("<rfilter type=\"tent\"/>", Filter::Tent { radius: 1.0 }),
        (
            "<rfilter type=\"tent\"><float name=\"radius\" value=\"1.25\"/></rfilter>",
            Filter::Tent { radius: 1.25 },
        ),
        (
            "<rfilter type=\"mitchell\"/>",
            Filter::Mitchell { b: third, c: third },
        ),
        (
            "<rfilter type=\"mitchell\"><float name=\"B\" value=\"0.25\"/><float name=\"C\" value=\"0.55\"/></rfilter>",
            Filter::Mitchell { b: 0.25, c: 0.55 },
        ),
        ("<rfilter type=\"catmullrom\"/>", Filter::CatmullRom),
        ("<rfilter type=\"lanczos\"/>", Filter::Lanczos { lobes: 3 }),
        (
            "<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"4\"/></rfilter>",
            Filter::Lanczos { lobes: 4 },
        ),
        (
            "<rfilter type=\"tent\"><float name=\"radius\" value=\"0.5\"/></rfilter>",
            Filter::Box,
        ),
        (
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.125\"/></rfilter>",
            Filter::Box,
        ),
    ] {
        assert_eq!(read(rfilter).unwrap(), expected, "{rfilter}");
    }
    for (rfilter, message) in [
        (
            "<rfilter type=\"tent\"><float name=\"radius\" value=\"-1\"/></rfilter>",
            "<rfilter type=\"tent\">: must be > 0, got -1 (pathmix field `camera.filter.radius`)",
        ),
        (
            "<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"0\"/></rfilter>",
            "<rfilter type=\"lanczos\">: must be between 1 and 64, got 0",
        ),
        (
            "<rfilter type=\"lanczos\"><float name=\"lobes\" value=\"2.5\"/></rfilter>",
            "expected <integer name=\"lobes\">",
        ),
        (
            "<rfilter type=\"mitchell\"><float name=\"A\" value=\"0.25\"/></rfilter>",
            "<float name=\"A\">: not supported in <rfilter type=\"mitchell\">",
        ),
        (
            "<rfilter type=\"bilinear\"/>",
            "rfilter `bilinear`: not supported (supported: box, gaussian, tent, mitchell, catmullrom, lanczos)",
        ),
    ] {
        let error = read(rfilter).unwrap_err().to_string();
        assert!(error.contains(message), "{rfilter}: {error}");
    }
}
