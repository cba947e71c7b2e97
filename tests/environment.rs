//! Environment maps (`[environment]`): furnaces and analytic irradiance under
//! every strategy, the sampler against its density (chi-square), and the
//! extremes (one texel, a sun 1e6 times the sky, a large map).

mod common;

use pathmix::kernel::{ArrayMemory, ArraySource, EnvironmentPart};
use pathmix::render::RenderOptions;
use pathmix::scene::{Scene, Strategy};
use std::path::Path;

/// A scene of `body` (materials and objects) under `[environment]` `environment`,
/// written next to the map in `dir`, seen by a `size`² camera from `lookfrom` toward the origin.
fn scene(
    dir: &Path,
    environment: &str,
    body: &str,
    render: &str,
    lookfrom: [f32; 3],
    size: u32,
) -> Scene {
    let text = format!(
        "[camera]\nlookfrom = {lookfrom:?}\nlookat = [0, 0, 0]\nvup = [0, 0, 1]\nvfov = 40\nwidth = {size}\nheight = {size}\n\
         [render]\n{render}\n[environment]\n{environment}\n{body}"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap()
}

const WHITE_SPHERE: &str = r#"
[materials.white]
type = "lambertian"
albedo = [1, 1, 1]
[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "white"
"#;

fn options() -> RenderOptions {
    common::with_variance()
}

/// A white sphere (albedo 1) under a map of constant radiance 1 is 1
/// everywhere: a convex surface reflects every ray to the sky, so each path is
/// one bounce at most. Exact under `bsdf` (every weight is 1); the others within
/// 4 standard errors (independent sampler: the error estimate is unbiased).
#[test]
fn constant_map_furnace() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("env", "furnace");
    common::write_exr(&dir.join("one.exr"), 8, 4, |_, _| [1.0, 1.0, 1.0]);
    // One texel: one cell over the whole sphere.
    common::write_exr(&dir.join("texel.exr"), 1, 1, |_, _| [1.0, 1.0, 1.0]);
    let strategies = [
        Strategy::Bsdf,
        Strategy::Mixture,
        Strategy::NeeMis,
        Strategy::Light,
    ];
    for file in ["one.exr", "texel.exr"] {
        for strategy in strategies {
            let render = format!(
                "spp = 64\nmax_depth = 8\nstrategy = \"{strategy}\"\nsampler = \"independent\""
            );
            let environment = format!("file = \"{file}\"");
            let s = scene(
                &dir,
                &environment,
                WHITE_SPHERE,
                &render,
                [0.0, -4.0, 0.0],
                16,
            );
            let acc = common::render(ctx, &s, &options());
            let (mean, error) = common::image_mean_and_error(&acc);
            eprintln!("{file}, {strategy}: {mean} +- {error}");
            if strategy == Strategy::Bsdf {
                common::assert_every_pixel_is(&acc, 1.0, 1e-6, "bsdf");
            } else {
                assert!(
                    (mean - 1.0).abs() <= 4.0 * error,
                    "{file}, {strategy}: {mean} +- {error}"
                );
            }
        }
    }
}

/// Mitsuba 3's lookup (`eval_spectrum` of src/emitters/envmap.cpp, transcribed
/// in f64): bilinear between texel centres, column `x` on `u = (x + 1/2) / W`,
/// row `y` on `v = y / (H - 1)`, the columns periodic; `(u, v)` of a map-space
/// direction as `direction_to_uv`.
fn mitsuba_lookup(
    width: usize,
    height: usize,
    texel: &dyn Fn(usize, usize) -> [f32; 3],
    u: f64,
    v: f64,
) -> f64 {
    let mut u = u - 0.5 / width as f64;
    u -= u.floor();
    let (px, py) = (u * width as f64, v * (height - 1) as f64);
    let x0 = (px as usize).min(width - 1);
    let y0 = (py as usize).min(height.max(2) - 2);
    let (tx, ty) = (px - x0 as f64, py - y0 as f64);
    let (x1, y1) = ((x0 + 1) % width, (y0 + 1).min(height - 1));
    let l = |x, y| texel(x, y)[0] as f64;
    let top = l(x0, y0) * (1.0 - tx) + l(x1, y0) * tx;
    let bottom = l(x0, y1) * (1.0 - tx) + l(x1, y1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The radiance of a white (albedo 1) diffuse plane facing world `normal`
/// under a grey map turned by `to_world`: (1 / pi) times the integral of the
/// lookup times the cosine, by the midpoint rule on a grid in `(u, v)` whose
/// lines pass through every texel centre (where the lookup has its kinks).
fn plane_radiance(
    width: usize,
    height: usize,
    texel: &dyn Fn(usize, usize) -> [f32; 3],
    to_world: glam::DMat3,
    normal: [f32; 3],
) -> f64 {
    let pi = std::f64::consts::PI;
    let n = glam::Vec3::from(normal).as_dvec3();
    let (nu, nv) = (
        2 * width * (2048 / width).max(1),
        (height - 1).max(1) * (1024 / height).max(1),
    );
    let mut sum = 0.0;
    for j in 0..nv {
        let v = (j as f64 + 0.5) / nv as f64;
        let (sin_theta, cos_theta) = (pi * v).sin_cos();
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let (sin_phi, cos_phi) = (2.0 * pi * u).sin_cos();
            let local = glam::DVec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta);
            let cosine = (to_world * local).dot(n);
            if cosine > 0.0 {
                sum += mitsuba_lookup(width, height, texel, u, v) * cosine * sin_theta;
            }
        }
    }
    // d omega = 2 pi^2 sin(theta) du dv.
    sum * 2.0 * pi * pi / (nu * nv) as f64 / pi
}

/// A large white plane through the origin facing `normal`, seen from 1 above it.
fn plane(normal: [f32; 3]) -> (String, [f32; 3]) {
    let n = glam::Vec3::from(normal);
    let (u, v) = n.any_orthonormal_pair();
    let (u, v) = if u.cross(v).dot(n) > 0.0 {
        (u, v)
    } else {
        (v, u)
    };
    let (u, v) = (u * 200.0, v * 200.0);
    let q = -(u + v) / 2.0;
    (
        format!(
            "[materials.white]\ntype = \"lambertian\"\nalbedo = [1, 1, 1]\n[[objects]]\ntype = \"quad\"\n\
             q = {:?}\nu = {:?}\nv = {:?}\nmaterial = \"white\"\n",
            q.to_array(),
            u.to_array(),
            v.to_array()
        ),
        n.to_array(),
    )
}

/// Renders `scene` and checks its mean against `expected` (grey) within 4
/// standard errors (independent sampler), or to 1e-5 relative when `exact`.
fn check_mean(ctx: &pathmix::gpu::GpuContext, s: &Scene, expected: f64, what: &str) {
    let acc = common::render(ctx, s, &options());
    let (mean, error) = common::image_mean_and_error(&acc);
    eprintln!("{what}: {mean} +- {error} (expected {expected})");
    assert!(
        (mean - expected).abs() <= 4.0 * error + 1e-5 * expected,
        "{what}: {mean} +- {error}, expected {expected}"
    );
}

const STRATEGIES: [Strategy; 3] = [Strategy::Bsdf, Strategy::Mixture, Strategy::NeeMis];

fn render_settings(strategy: Strategy, spp: u32) -> String {
    format!("spp = {spp}\nmax_depth = 1\nstrategy = \"{strategy}\"\nsampler = \"independent\"")
}

/// Upward planes under maps bright in bands of rows (the v convention), and
/// sideways planes under maps bright in ranges of columns (the u convention: u =
/// 0 looks down -z, u = 1/4 down +x), with rotations (the map turned by
/// `to_world`, not its inverse): each plane's radiance against the integral of
/// Mitsuba's lookup, within 4 standard errors.
#[test]
fn planes_under_banded_maps_match_the_analytic_irradiance() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("env", "bands");
    // Two bands of the upper hemisphere: the polar cap (v < 1/6) and the rest.
    let bands = |_: usize, y: usize| match y {
        0 => [3.0, 3.0, 3.0],
        1 => [1.0, 1.0, 1.0],
        _ => [0.0, 0.0, 0.0],
    };
    common::write_exr(&dir.join("bands.exr"), 8, 4, bands);
    // Columns 0..4 of 8: u in [0, 1/2), azimuths from -z through +x to +z.
    let half = |x: usize, _: usize| if x < 4 { [1.0; 3] } else { [0.0; 3] };
    common::write_exr(&dir.join("half.exr"), 8, 4, half);
    let identity = glam::DMat3::IDENTITY;
    let about_x = glam::DMat3::from_axis_angle(glam::DVec3::X, std::f64::consts::FRAC_PI_2);
    // The book's rotate_y 90: map +x to world -z.
    let about_y = glam::DMat3::from_axis_angle(glam::DVec3::Y, std::f64::consts::FRAC_PI_2);
    let facing_x = plane_radiance(8, 4, &half, identity, [1.0, 0.0, 0.0]);
    let facing_minus_x = plane_radiance(8, 4, &half, identity, [-1.0, 0.0, 0.0]);
    // The half map and its half-turn add up to a constant 1 (the lookup is linear).
    assert!(
        (facing_x + facing_minus_x - 1.0).abs() < 1e-6,
        "{facing_x} {facing_minus_x}"
    );
    assert!(facing_x > 0.9 && facing_minus_x < 0.1);
    let cases: [(&str, &str, [f32; 3], f64); 6] = [
        (
            "bands, map +y up",
            "file = \"bands.exr\"",
            [0.0, 1.0, 0.0],
            plane_radiance(8, 4, &bands, identity, [0.0, 1.0, 0.0]),
        ),
        (
            "bands turned onto +z",
            "file = \"bands.exr\"\nrotate = { axis = [1, 0, 0], angle = 90 }",
            [0.0, 0.0, 1.0],
            plane_radiance(8, 4, &bands, about_x, [0.0, 0.0, 1.0]),
        ),
        (
            "half, facing +x",
            "file = \"half.exr\"",
            [1.0, 0.0, 0.0],
            facing_x,
        ),
        (
            "half, facing -x",
            "file = \"half.exr\"",
            [-1.0, 0.0, 0.0],
            facing_minus_x,
        ),
        (
            "half, facing -z",
            "file = \"half.exr\"",
            [0.0, 0.0, -1.0],
            plane_radiance(8, 4, &half, identity, [0.0, 0.0, -1.0]),
        ),
        (
            "half turned, facing -z",
            "file = \"half.exr\"\nrotate_y = 90",
            [0.0, 0.0, -1.0],
            plane_radiance(8, 4, &half, about_y, [0.0, 0.0, -1.0]),
        ),
    ];
    // The turned cases are the unturned ones carried along.
    assert!((cases[1].3 - cases[0].3).abs() < 1e-9 && (cases[5].3 - facing_x).abs() < 1e-9);
    for (what, environment, normal, expected) in cases {
        let (body, n) = plane(normal);
        for strategy in STRATEGIES {
            let lookfrom = [n[0] * 1.0 + 0.01, n[1] * 1.0 + 0.02, n[2] * 1.0 + 0.03];
            let s = scene(
                &dir,
                environment,
                &body,
                &render_settings(strategy, 64),
                lookfrom,
                8,
            );
            check_mean(ctx, &s, expected, &format!("{what}, {strategy}"));
        }
    }
}

// ---------------------------------------------------------------------------------
// The sampler against its density, through the kernel's own WGSL

const WORKGROUP: u32 = 64;

struct Probe {
    sample: wgpu::ComputePipeline,
    pdf: wgpu::ComputePipeline,
}

fn probe(ctx: &pathmix::gpu::GpuContext) -> &'static Probe {
    static PROBE: std::sync::OnceLock<Probe> = std::sync::OnceLock::new();
    PROBE.get_or_init(|| {
        let source = pathmix::kernel::KernelConfig::environment_probe_source().unwrap();
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("environment probe"),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = |entry: &str| {
            ctx.device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: None,
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
        };
        Probe {
            sample: pipeline("probe_sample"),
            pdf: pipeline("probe_pdf"),
        }
    })
}

/// Runs `pipeline` over `items` invocations on the tables of `map`, with the
/// directions (for `probe_pdf`), and reads its `items` vec4s back.
fn run_probe(
    ctx: &pathmix::gpu::GpuContext,
    pipeline: &wgpu::ComputePipeline,
    tables: &pathmix::environment::EnvironmentTables,
    directions: &[[f32; 4]],
    items: u32,
) -> Vec<[f32; 4]> {
    let out = common::ProbeOutput::new(ctx, u64::from(items));
    let seed = common::storage(ctx, bytemuck::bytes_of(&11u32));
    let dirs = common::storage(ctx, bytemuck::cast_slice(directions));
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: 10,
            resource: seed.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 12,
            resource: out.buffer.as_entire_binding(),
        },
    ];
    if !directions.is_empty() {
        entries.retain(|e| e.binding != 10);
        entries.push(wgpu::BindGroupEntry {
            binding: 11,
            resource: dirs.as_entire_binding(),
        });
    }
    let frame = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    // The map's arrays, bound where a scene's kernel binds them.
    let config = pathmix::kernel::KernelConfig::general(
        Strategy::Mixture,
        pathmix::kernel::AccumulatorKind::Buffer,
    );
    let data = pathmix::pack::SceneData {
        environment: Some(std::sync::Arc::new(tables.clone())),
        ..Default::default()
    };
    // `probe_pdf` reads the cells' probabilities from the texels, not the pyramid.
    let bound = |part: EnvironmentPart| part != EnvironmentPart::Pyramid || directions.is_empty();
    let buffers: Vec<(u32, wgpu::Buffer)> = config
        .scene_arrays()
        .into_iter()
        .filter(|a| matches!(a.source, ArraySource::Environment(part) if bound(part)))
        .map(|a| (a.binding, common::storage(ctx, data.array_bytes(a.source))))
        .collect();
    let scene_entries: Vec<_> = buffers
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    let scene = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("environment"),
        layout: &pipeline.get_bind_group_layout(1),
        entries: &scene_entries,
    });
    let groups = items.div_ceil(WORKGROUP);
    let (x, y) = (groups.min(32768), groups.div_ceil(32768));
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &frame, &[]);
        pass.set_bind_group(1, &scene, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
    out.read(ctx, encoder)
}

fn map(
    width: u32,
    height: u32,
    to_world: glam::Mat3,
    texel: impl Fn(u32, u32) -> [f32; 3],
) -> pathmix::scene::EnvironmentMap {
    let texels = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| texel(x, y))
        .collect();
    pathmix::scene::EnvironmentMap {
        file: "test.exr".into(),
        width,
        height,
        texels: std::sync::Arc::new(texels),
        scale: 1.0,
        to_world,
    }
}

/// A sub-cell of the density's cells (between texel centres: columns from
/// `(x + 1/2) / W` to `(x + 3/2) / W` of `u`, rows between the texel rows'
/// `cos theta`): `split` x `split` of each, equal in `(cos theta, phi)` of map
/// space. Returns (index, world direction of its centre, solid angle) for
/// every sub-cell, and a classifier of world directions.
struct Cells {
    width: u32,
    height: u32,
    split: u32,
    to_world: glam::DMat3,
}

impl Cells {
    fn rows(&self) -> u32 {
        pathmix::environment::cell_rows(self.height)
    }

    fn z_edges(&self, y: u32) -> (f64, f64) {
        let edge = |y: u32| (std::f64::consts::PI * y as f64 / self.rows() as f64).cos();
        (edge(y), edge(y + 1))
    }

    fn count(&self) -> usize {
        (self.width * self.rows() * self.split * self.split) as usize
    }

    /// The map-space direction of world direction `dir`: its column coordinate
    /// (texel centres on whole numbers, in [0, width)) and cos theta.
    fn local(&self, dir: glam::DVec3) -> (f64, f64) {
        let d = self.to_world.transpose() * dir.normalize();
        let u = d.x.atan2(-d.z) / (2.0 * std::f64::consts::PI) - 0.5 / self.width as f64;
        ((u - u.floor()) * self.width as f64, d.y.clamp(-1.0, 1.0))
    }

    /// The cell (column, row) and the fractions within it of world direction `dir`.
    fn cell(&self, dir: glam::DVec3) -> (u32, u32, f64, f64) {
        let (u, z) = self.local(dir);
        let x = (u as u32).min(self.width - 1);
        let y =
            ((z.acos() / std::f64::consts::PI * self.rows() as f64) as u32).min(self.rows() - 1);
        let (top, bottom) = self.z_edges(y);
        (
            x,
            y,
            u - x as f64,
            ((top - z) / (top - bottom)).clamp(0.0, 1.0),
        )
    }

    /// The sub-cell a world direction falls in.
    fn index(&self, dir: glam::DVec3) -> usize {
        let (x, y, tx, tz) = self.cell(dir);
        let sub = |t: f64| ((t * self.split as f64) as u32).min(self.split - 1);
        (((y * self.width + x) * self.split + sub(tz)) * self.split + sub(tx)) as usize
    }

    /// The density the tables describe at world direction `dir`, in f64: the
    /// texels' densities interpolated bilinearly in (phi, cos theta).
    fn density(&self, tables: &pathmix::environment::EnvironmentTables, dir: glam::DVec3) -> f64 {
        let (x, y, tx, tz) = self.cell(dir);
        let w = |x: u32, y: u32| {
            let texel = y.min(self.height - 1) * self.width + x % self.width;
            tables.texels[texel as usize][3] as f64
        };
        let upper = w(x, y) * (1.0 - tx) + w(x + 1, y) * tx;
        let lower = w(x, y + 1) * (1.0 - tx) + w(x + 1, y + 1) * tx;
        upper * (1.0 - tz) + lower * tz
    }

    /// Each sub-cell's centre (world) and solid angle, in index order.
    fn centres(&self) -> Vec<(glam::DVec3, f64)> {
        let mut out = Vec::with_capacity(self.count());
        let n = self.split as f64;
        for y in 0..self.rows() {
            let (top, bottom) = self.z_edges(y);
            for x in 0..self.width {
                for sz in 0..self.split {
                    let z = top + (bottom - top) * (sz as f64 + 0.5) / n;
                    for sx in 0..self.split {
                        let phi =
                            2.0 * std::f64::consts::PI * (x as f64 + 0.5 + (sx as f64 + 0.5) / n)
                                / self.width as f64;
                        let s = (1.0 - z * z).max(0.0).sqrt();
                        let local = glam::DVec3::new(phi.sin() * s, z, -phi.cos() * s);
                        let omega =
                            2.0 * std::f64::consts::PI / self.width as f64 / n * (top - bottom) / n;
                        out.push((self.to_world * local, omega));
                    }
                }
            }
        }
        out
    }
}

/// Pearson's statistic over the cells expecting >= 5 samples (the rest pooled),
/// as a standard normal deviate by the Wilson-Hilferty cube root (accurate to a
/// few 1e-3 in the tail at the hundreds of degrees of freedom here).
fn chi_square_deviate(observed: &[f64], expected: &[f64]) -> f64 {
    let (mut statistic, mut cells, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            statistic += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pool_e >= 5.0 {
        statistic += (pool_o - pool_e).powi(2) / pool_e;
        cells += 1;
    }
    let k = (cells - 1) as f64;
    ((statistic / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt()
}

/// 10^6 directions drawn by the WGSL sampler fall into the sub-cells (4 per
/// cell of the density) as often as the WGSL density integrated over each says
/// (exactly, by the midpoint rule, as the density is bilinear in (phi, cos
/// theta) over each; chi-square, deviate below 4.5: p < 4e-6 per map); that
/// density integrates to 1 over the sphere and is, at every sub-cell's centre
/// and every sample's direction, the tables' bilinear density computed in f64;
/// and no sample lands where the density is 0. Maps: smooth with a black row
/// and black texels, turned; a 1e6 sun; one texel; a black map; a sun next
/// to the pole of a 2048-row map (rows 1e-3 of a degree of cos theta tall
/// there); bright poles over a black band next to them.
#[test]
fn sampler_matches_its_density() {
    let ctx = gpu_or_skip!();
    let turned = glam::Mat3::from_axis_angle(glam::Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
    let maps = [
        (
            "smooth, black row and texels, turned",
            map(16, 9, turned, |x, y| {
                let l = if y == 3 || (x + y) % 5 == 0 {
                    0.0
                } else {
                    1.0 + (x as f32 * 0.7).sin() + 0.3 * y as f32
                };
                [l, 0.5 * l, 2.0 * l]
            }),
        ),
        (
            "sun 1e6 times the sky",
            map(32, 16, glam::Mat3::IDENTITY, |x, y| {
                if (x, y) == (5, 4) { [1e6; 3] } else { [1.0; 3] }
            }),
        ),
        ("one texel", map(1, 1, turned, |_, _| [2.0, 1.0, 0.5])),
        ("black", map(4, 4, glam::Mat3::IDENTITY, |_, _| [0.0; 3])),
        (
            "a sun next to the pole of a tall map",
            map(8, 2048, glam::Mat3::IDENTITY, |x, y| {
                if (x, y) == (3, 1) { [1e4; 3] } else { [1.0; 3] }
            }),
        ),
        (
            "bright poles beside black rows",
            map(8, 64, glam::Mat3::IDENTITY, |x, y| match y {
                0 | 63 => [50.0 + x as f32; 3],
                1 | 2 | 61 | 62 => [0.0; 3],
                _ => [0.5; 3],
            }),
        ),
    ];
    const SAMPLES: u32 = 1_000_000;
    for (what, m) in maps {
        let tables = pathmix::environment::EnvironmentTables::build(&m);
        let cells = Cells {
            width: m.width,
            height: m.height,
            split: 2,
            to_world: m.to_world.as_dmat3(),
        };
        let centres = cells.centres();
        let directions: Vec<[f32; 4]> = centres
            .iter()
            .map(|(d, _)| [d.x as f32, d.y as f32, d.z as f32, 0.0])
            .collect();
        let at_centres = run_probe(
            ctx,
            &probe(ctx).pdf,
            &tables,
            &directions,
            directions.len() as u32,
        );
        for ((r, (dir, _)), i) in at_centres.iter().zip(&centres).zip(0..) {
            let exact = cells.density(&tables, *dir);
            assert!(
                (r[3] as f64 - exact).abs() <= 1e-4 * exact,
                "{what}: the density at sub-cell {i}'s centre is {}, not {exact}",
                r[3]
            );
        }
        let expected: Vec<f64> = at_centres
            .iter()
            .zip(&centres)
            .map(|(r, (_, omega))| r[3] as f64 * omega * SAMPLES as f64)
            .collect();
        let total: f64 = expected.iter().sum::<f64>() / SAMPLES as f64;
        assert!(
            (total - 1.0).abs() < 1e-4,
            "{what}: the density integrates to {total}"
        );
        let samples = run_probe(ctx, &probe(ctx).sample, &tables, &[], SAMPLES);
        let mut observed = vec![0.0; cells.count()];
        let mut mismatched = 0;
        for s in &samples {
            let dir = glam::DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64);
            assert!((dir.length() - 1.0).abs() < 1e-5, "{what}: {dir}");
            let exact = cells.density(&tables, dir);
            assert!(
                s[3] > 0.0 && exact > 0.0,
                "{what}: a sample where the density is 0"
            );
            // Float rounding of the direction (atan2's, 1e-6 of a column on
            // lavapipe) moves the density by far less than this.
            if (s[3] as f64 / exact - 1.0).abs() > 1e-3 {
                mismatched += 1;
            }
            observed[cells.index(dir)] += 1.0;
        }
        eprintln!("{what}: {mismatched} mismatched");
        assert!(
            mismatched <= SAMPLES / 10_000,
            "{what}: {mismatched} samples report another density than theirs"
        );
        let deviate = chi_square_deviate(&observed, &expected);
        eprintln!("{what}: chi-square deviate {deviate:.2}");
        assert!(deviate < 4.5, "{what}: chi-square deviate {deviate}");
    }
}

/// A sun 1e6 times as bright as the sky, in one texel of 64 x 32, over an
/// upward plane: finite samples (no NaN or infinity is discarded) and the
/// integral of Mitsuba's lookup within 4 standard errors under the strategies that sample
/// the map (under `bsdf` the sun is hit by 1 path in 3000: its error estimate
/// is not to be trusted at test sizes).
#[test]
fn a_sun_is_sampled_without_bias() {
    let ctx = gpu_or_skip!();
    let dir = common::TempDir::new("env", "sun");
    let sky = |x: usize, y: usize| {
        if (x, y) == (5, 6) {
            [1e6, 1e6, 1e6]
        } else {
            [1.0, 1.0, 1.0]
        }
    };
    common::write_exr(&dir.join("sun.exr"), 64, 32, sky);
    let expected = plane_radiance(64, 32, &sky, glam::DMat3::IDENTITY, [0.0, 1.0, 0.0]);
    assert!(expected > 100.0, "the sun dominates: {expected}");
    let (body, n) = plane([0.0, 1.0, 0.0]);
    for strategy in [Strategy::Mixture, Strategy::NeeMis] {
        let s = scene(
            &dir,
            "file = \"sun.exr\"",
            &body,
            &render_settings(strategy, 256),
            [n[0] + 0.01, 1.0, 0.02],
            8,
        );
        check_mean(ctx, &s, expected, &format!("sun, {strategy}"));
    }
}

/// The largest map an adapter with 128 MiB storage bindings (lavapipe's) holds,
/// 4096 x 2048 (8 M texels of 16 bytes), renders a furnace of 1; 8192 x 4096 is
/// refused before the device is asked, naming the array and the limit. (From a
/// texture, `ArrayMemory::Textures`, the limit is the largest texture's rows.)
#[test]
fn large_maps_render_or_are_refused_by_the_binding_limit() {
    let ctx = gpu_or_skip!();
    let options = || RenderOptions {
        array_memory: Some(ArrayMemory::Buffers),
        ..options()
    };
    let dir = common::TempDir::new("env", "large");
    common::write_exr(&dir.join("one.exr"), 2, 2, |_, _| [1.0; 3]);
    let limit = ctx.limits().max_storage_buffer_binding_size;
    for (width, height) in [(4096u32, 2048u32), (8192, 4096)] {
        let mut s = scene(
            &dir,
            "file = \"one.exr\"",
            WHITE_SPHERE,
            &render_settings(Strategy::NeeMis, 16),
            [0.0, -4.0, 0.0],
            8,
        );
        s.environment = Some(map(width, height, glam::Mat3::IDENTITY, |_, _| [1.0; 3]));
        let bytes = width as u64 * height as u64 * 16;
        if bytes <= limit {
            let acc = common::render(ctx, &s, &options());
            let (mean, error) = common::image_mean_and_error(&acc);
            eprintln!("{width}x{height}: {mean} +- {error}");
            assert!(
                (mean - 1.0).abs() <= 4.0 * error + 1e-6,
                "{width}x{height}: {mean} +- {error}"
            );
        } else {
            match pathmix::render::Renderer::new(ctx, &s, &options()) {
                Err(e @ pathmix::render::RenderError::ResourceLimit { .. }) => {
                    let message = e.to_string();
                    assert!(message.contains("environment_texels"), "{message}");
                    assert!(
                        message.contains("max_storage_buffer_binding_size"),
                        "{message}"
                    );
                }
                Err(e) => panic!("{width}x{height}: {e}"),
                Ok(_) => panic!("{width}x{height}: {bytes} bytes over the limit {limit} accepted"),
            }
        }
    }
}

/// A missing, unreadable, non-image or unsupported map file, a map with a NaN,
/// infinite or negative texel, and a map of no texels exit with code 2, naming
/// the scene file, the field (`environment.file`) and the image file, and write
/// nothing; so does `background` next to `[environment]`.
#[test]
fn bad_maps_exit_2_naming_scene_field_and_image() {
    let dir = common::TempDir::new("env", "bad");
    let d = &dir;
    common::write_exr(&d.join("nan.exr"), 4, 2, |x, _| {
        if x == 3 {
            [1.0, f32::NAN, 1.0]
        } else {
            [1.0; 3]
        }
    });
    common::write_exr(&d.join("inf.exr"), 4, 2, |x, y| {
        if (x, y) == (1, 1) {
            [f32::INFINITY, 1.0, 1.0]
        } else {
            [1.0; 3]
        }
    });
    common::write_exr(&d.join("negative.exr"), 4, 2, |_, y| {
        if y == 1 { [1.0, 1.0, -0.5] } else { [1.0; 3] }
    });
    std::fs::write(d.join("text.exr"), "not an image\n").unwrap();
    std::fs::write(d.join("text.hdr"), "not an image either\n").unwrap();
    std::fs::write(
        d.join("empty.hdr"),
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n",
    )
    .unwrap();
    std::fs::write(d.join("sky.png"), "").unwrap();
    let unreadable = d.join("unreadable.exr");
    std::fs::create_dir_all(&unreadable).unwrap();
    let cases: [(&str, &str); 9] = [
        ("missing.exr", "cannot read"),
        ("unreadable.exr", "cannot read"),
        ("text.exr", "cannot read the OpenEXR image"),
        ("text.hdr", "cannot read the Radiance HDR image"),
        ("empty.hdr", ""),
        ("sky.png", "unknown environment map format"),
        ("nan.exr", "texel (3, 0)"),
        ("inf.exr", "texel (1, 1) is [inf, 1, 1]"),
        ("negative.exr", "must be finite and >= 0"),
    ];
    let body = "[camera]\nlookfrom = [0, 0, -5]\nlookat = [0, 0, 0]\nwidth = 4\nheight = 4\n";
    let run = |scene_name: &str, text: String| {
        let scene_path = d.join(scene_name);
        std::fs::write(&scene_path, text).unwrap();
        let out = d.join(format!("{scene_name}.png"));
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_pathmix"))
            .args([
                "render",
                scene_path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let message = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.code(), Some(2), "{scene_name}: {message}");
        assert!(!message.contains("panicked"), "{message}");
        assert!(!out.exists(), "{scene_name}: an image was written");
        message
    };
    for (file, problem) in cases {
        let scene_name = format!("{file}.toml");
        let message = run(
            &scene_name,
            format!("{body}[environment]\nfile = \"{file}\"\n"),
        );
        for part in [scene_name.as_str(), "environment.file", file, problem] {
            assert!(message.contains(part), "{file}: no {part:?} in {message}");
        }
    }
    common::write_exr(&d.join("one.exr"), 2, 2, |_, _| [1.0; 3]);
    let message = run(
        "both.toml",
        format!("{body}[render]\nbackground = [1, 1, 1]\n[environment]\nfile = \"one.exr\"\n"),
    );
    for part in ["both.toml", "render.background", "[environment]"] {
        assert!(message.contains(part), "no {part:?} in {message}");
    }
}

/// `[environment]`'s keys: a rotation as objects take one, an orthogonal
/// matrix (translation ignored), and refusals naming the field.
#[test]
fn environment_keys_parse_and_refuse() {
    let dir = common::TempDir::new("env", "keys");
    common::write_exr(&dir.join("one.exr"), 2, 2, |_, _| [1.0; 3]);
    let load = |environment: &str| {
        let path = dir.join("keys.toml");
        std::fs::write(&path, format!("[camera]\nlookfrom = [0, 0, -5]\nlookat = [0, 0, 0]\n[environment]\nfile = \"one.exr\"\n{environment}")).unwrap();
        Scene::load(&path)
    };
    let map = load("scale = 2.5\nrotate_y = 90")
        .unwrap()
        .environment
        .unwrap();
    assert_eq!((map.width, map.height, map.scale), (2, 2, 2.5));
    // The book's rotate_y: x goes to -z.
    assert!((map.to_world * glam::Vec3::X - glam::Vec3::NEG_Z).length() < 1e-7);
    let matrix = load("matrix = [0, 0, 1, 5,  0, 1, 0, 6,  -1, 0, 0, 7,  0, 0, 0, 1]")
        .unwrap()
        .environment
        .unwrap();
    assert_eq!(matrix.to_world, map.to_world);
    for (environment, location, problem) in [
        ("scale = -1", "environment.scale", "must be >= 0"),
        (
            "matrix = [2, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]",
            "environment.matrix",
            "must be a rotation",
        ),
        (
            "matrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]\nrotate_y = 3",
            "environment.rotate_y",
            "cannot be combined",
        ),
        (
            "translate = [1, 2, 3]",
            "environment",
            "unknown key `translate`",
        ),
    ] {
        let e = load(environment).unwrap_err();
        assert_eq!(e.location, location, "{environment}: {e}");
        assert!(e.message.contains(problem), "{environment}: {e}");
    }
}

/// The procedural sky of `scenes/sky.exr` (128 x 64): a blue-to-white sky, a
/// brown ground and a sun of one texel, 30 degrees up, at u = 0.3 (between
/// map -z and +x). Radiance at each texel's centre, Mitsuba's mapping.
fn procedural_sky(x: usize, y: usize) -> [f32; 3] {
    let (width, height) = (128.0f32, 64.0f32);
    let phi = 2.0 * std::f32::consts::PI * (x as f32 + 0.5) / width;
    let theta = std::f32::consts::PI * y as f32 / (height - 1.0);
    let up = theta.cos();
    if (x, y)
        == (
            (0.3 * width) as usize,
            ((height - 1.0) / 3.0).round() as usize,
        )
    {
        return [5000.0, 4600.0, 4000.0];
    }
    if up > 0.0 {
        let t = up.powf(0.6);
        let horizon = [1.1, 1.05, 1.0];
        let zenith = [0.25, 0.45, 1.0];
        // A little brighter toward the sun's side.
        let glow = 1.0 + 0.3 * (phi - 0.3 * 2.0 * std::f32::consts::PI).cos().max(0.0);
        std::array::from_fn(|c| (horizon[c] * (1.0 - t) + zenith[c] * t) * glow)
    } else {
        [0.12, 0.1, 0.08]
    }
}

/// `scenes/sky.exr` is exactly `procedural_sky` (regenerate it with
/// `PATHMIX_WRITE_SKY=1` after changing the function).
#[test]
fn the_shipped_sky_is_the_procedural_one() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sky.exr");
    if std::env::var("PATHMIX_WRITE_SKY").as_deref() == Ok("1") {
        common::write_exr(&path, 128, 64, procedural_sky);
    }
    let (width, height, texels) = pathmix::scene::envmap::load_image(&path).unwrap();
    assert_eq!((width, height), (128, 64));
    for (i, texel) in texels.iter().enumerate() {
        let expected = procedural_sky(i % 128, i / 128);
        assert_eq!(*texel, expected, "texel {i}");
    }
}
