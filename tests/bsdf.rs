//! Each material's sampling against its density, on the device: the kernel's
//! own WGSL (composed with `shaders/bsdf_probe.wgsl`, not a re-implementation)
//! draws 10^6 samples for one outgoing direction, and the host compares them
//! with the density `pdf` integrated over the cells of a partition of the
//! sphere (Pearson's chi-square, with a Bonferroni correction over every
//! configuration of a test). The same cells integrate `eval`, the material's
//! albedo, which the mean sample weight must match (a white furnace of one
//! bounce), and each sample's weight must be eval / pdf at its direction.

mod common;

use glam::DVec3;
use pathmix::abi::PackedMaterial;
use pathmix::gpu::GpuContext;
use pathmix::kernel::KernelConfig;
use pathmix::kinds::{
    KindSet, MATERIAL_KINDS, MaterialTables, ROUGH_TRANSMITTANCE_RES, pack_material,
};
use pathmix::scene::{self, Distribution, MaterialKind, Strategy};
use std::sync::OnceLock;

const SAMPLES: u32 = 1_000_000;
const WORKGROUP: u32 = 64;

/// The probe's two pipelines, compiled once per test process.
struct Probe {
    sample: wgpu::ComputePipeline,
    eval: wgpu::ComputePipeline,
}

fn probe(ctx: &GpuContext) -> &'static Probe {
    static PROBE: OnceLock<Probe> = OnceLock::new();
    PROBE.get_or_init(|| {
        let source = KernelConfig::bsdf_probe_source(KindSet::all(MATERIAL_KINDS.len())).unwrap();
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("bsdf probe"),
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
            eval: pipeline("probe_eval"),
        }
    })
}

/// One material seen from one direction, in a frame whose normal is +z.
#[derive(Clone, Copy, Debug)]
struct Setup {
    material: PackedMaterial,
    /// Its tables (`material_tables`): one material has at most one coat's.
    tables: [f32; ROUGH_TRANSMITTANCE_RES],
    wo: DVec3,
    front_face: bool,
}

impl Setup {
    fn new(kind: MaterialKind, theta_degrees: f64, front_face: bool) -> Setup {
        let mut material_tables = MaterialTables::default();
        let material = pack_material(
            &scene::Material {
                name: "probe".into(),
                kind,
                albedo: glam::Vec3::splat(0.8),
                emit: glam::Vec3::ZERO,
                one_sided: false,
                opacity: 1.0,
                opacity_texture: None,
                number_textures: Vec::new(),
                texture: None,
                bump: None,
                nested: Vec::new(),
            },
            &mut material_tables,
        );
        let mut tables = [0.0; ROUGH_TRANSMITTANCE_RES];
        tables[..material_tables.values.len()].copy_from_slice(&material_tables.values);
        let theta = theta_degrees.to_radians();
        // Off the frame's axes, so anisotropy and the azimuth are exercised.
        let phi = 0.3f64;
        let wo = DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        Setup {
            material,
            tables,
            wo,
            front_face,
        }
    }

    fn input(&self, seed: u32) -> Vec<u8> {
        let mut bytes = bytemuck::bytes_of(&self.material).to_vec();
        let wo = self.wo.as_vec3();
        for word in [
            wo.x.to_bits(),
            wo.y.to_bits(),
            wo.z.to_bits(),
            self.front_face as u32,
        ] {
            bytes.extend_from_slice(&word.to_ne_bytes());
        }
        for word in [0f32.to_bits(), 0f32.to_bits(), 1f32.to_bits(), seed] {
            bytes.extend_from_slice(&word.to_ne_bytes());
        }
        bytes
    }
}

/// Runs `pipeline` over `items` invocations with the input, directions and an
/// output of `out_vec4s` vec4s, and reads the output back.
fn run(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    setup: &Setup,
    directions: &[[f32; 4]],
    items: u32,
    out_vec4s: u64,
) -> Vec<[f32; 4]> {
    let input = common::storage(ctx, &setup.input(7));
    let tables = common::storage(ctx, bytemuck::cast_slice(&setup.tables));
    let dirs = common::storage(
        ctx,
        bytemuck::cast_slice(if directions.is_empty() {
            &[[0f32; 4]]
        } else {
            directions
        }),
    );
    let out = common::ProbeOutput::new(ctx, out_vec4s);
    let layout = pipeline.get_bind_group_layout(0);
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: 10,
            resource: input.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 12,
            resource: out.buffer.as_entire_binding(),
        },
        wgpu::BindGroupEntry {
            binding: 13,
            resource: tables.as_entire_binding(),
        },
    ];
    if !directions.is_empty() {
        entries.push(wgpu::BindGroupEntry {
            binding: 11,
            resource: dirs.as_entire_binding(),
        });
    }
    let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probe"),
        layout: &layout,
        entries: &entries,
    });
    let groups = items.div_ceil(WORKGROUP);
    let (x, y) = (groups.min(32768), groups.div_ceil(32768));
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
    out.read(ctx, encoder)
}

/// A partition of the sphere into cells of (z = cos theta, phi) about the
/// normal: the horizon is a cell boundary (densities jump there), and the
/// boundaries crowd geometrically around the lobes' peaks (`peaks`), so every
/// cell is small against the variation of the density inside it and
/// Gauss-Legendre quadrature integrates it accurately even at alpha 1e-3.
struct Cells {
    z: Vec<f64>,
    phi: Vec<f64>,
}

fn breakpoints(lo: f64, hi: f64, uniform: usize, peaks: &[f64], finest: f64) -> Vec<f64> {
    let mut points: Vec<f64> = (0..=uniform)
        .map(|i| lo + (hi - lo) * i as f64 / uniform as f64)
        .collect();
    for &peak in peaks {
        let mut step = finest;
        while step < (hi - lo) / uniform as f64 {
            points.extend([peak - step, peak + step]);
            step *= 1.6;
        }
        points.push(peak);
    }
    points.retain(|p| (lo..=hi).contains(p));
    points.sort_by(f64::total_cmp);
    points.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    points
}

impl Cells {
    /// Boundaries down to `finest` apart in z at the peaks: a lobe of roughness
    /// alpha is about 2 alpha wide in z, but only 2 alpha cos(theta_o) across
    /// the plane of incidence (3.5e-6 rad at alpha 1e-3 and 89.9 degrees), hence
    /// the azimuth's finer steps.
    fn around(peaks: &[DVec3], finest: f64, wo: DVec3) -> Cells {
        let finest_phi = (finest * 2.0 * wo.z.abs()).max(5e-7);
        let mut z_peaks = vec![0.0];
        let mut phi_peaks = Vec::new();
        for p in peaks {
            z_peaks.push(p.z);
            let phi = p.y.atan2(p.x).rem_euclid(std::f64::consts::TAU);
            phi_peaks.extend([
                phi,
                phi - std::f64::consts::TAU,
                phi + std::f64::consts::TAU,
            ]);
        }
        Cells {
            // A lobe near a pole is narrower in z: sin(theta) times its width.
            z: breakpoints(-1.0, 1.0, 40, &z_peaks, finest * 0.2),
            phi: breakpoints(0.0, std::f64::consts::TAU, 60, &phi_peaks, finest_phi),
        }
    }

    fn count(&self) -> usize {
        (self.z.len() - 1) * (self.phi.len() - 1)
    }

    fn index(&self, dir: DVec3) -> usize {
        let find = |edges: &[f64], x: f64| {
            edges.partition_point(|&e| e <= x).clamp(1, edges.len() - 1) - 1
        };
        let phi = dir.y.atan2(dir.x).rem_euclid(std::f64::consts::TAU);
        find(&self.z, dir.z.clamp(-1.0, 1.0)) * (self.phi.len() - 1) + find(&self.phi, phi)
    }

    /// Quadrature nodes (direction, weight) of every cell, cell by cell.
    fn nodes(&self) -> Vec<(DVec3, f64)> {
        // 4-point Gauss-Legendre on [-1, 1].
        const X: [f64; 4] = [
            -0.861136311594053,
            -0.339981043584856,
            0.339981043584856,
            0.861136311594053,
        ];
        const W: [f64; 4] = [
            0.347854845137454,
            0.652145154862546,
            0.652145154862546,
            0.347854845137454,
        ];
        let mut nodes = Vec::with_capacity(self.count() * 16);
        for zw in self.z.windows(2) {
            for pw in self.phi.windows(2) {
                let (zc, zh) = ((zw[0] + zw[1]) / 2.0, (zw[1] - zw[0]) / 2.0);
                let (pc, ph) = ((pw[0] + pw[1]) / 2.0, (pw[1] - pw[0]) / 2.0);
                for (xi, wi) in X.iter().zip(W) {
                    for (xj, wj) in X.iter().zip(W) {
                        let z = zc + zh * xi;
                        let phi = pc + ph * xj;
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        // dω = dz dφ.
                        nodes.push((
                            DVec3::new(r * phi.cos(), r * phi.sin(), z),
                            wi * wj * zh * ph,
                        ));
                    }
                }
            }
        }
        nodes
    }
}

/// What one configuration measured.
struct Measured {
    p_value: f64,
    /// ∫ pdf over the sphere (quadrature), and the fraction of samples with a
    /// density (neither absorbed nor from a delta lobe).
    pdf_integral: f64,
    smooth_fraction: f64,
    /// Fraction of samples from a delta lobe.
    delta_fraction: f64,
    /// The albedo (first channel): mean sample weight, its standard error, and
    /// ∫ eval over the sphere (quadrature; the delta lobes not included).
    mean_weight: f64,
    weight_error: f64,
    eval_integral: f64,
    /// Mean weight of the smooth samples times their fraction, and its standard error.
    smooth_weight: f64,
    smooth_weight_error: f64,
    /// Fraction of the smooth samples whose weight differs from eval / pdf at
    /// their direction (or whose density from `pdf`) by more than f32 explains.
    weight_mismatches: f64,
    /// Samples with a non-finite direction, weight or density.
    non_finite: usize,
}

fn measure(ctx: &GpuContext, setup: &Setup, peaks: &[DVec3], alpha: f64) -> Measured {
    // Cells down to alpha / 20 at the peaks resolve every lobe.
    let finest = alpha * 0.05;
    // f32 loses the half vector of (wo, wi) near grazing incidence: about
    // 6e-8 / (2 cos theta_i) radians, against a lobe alpha wide.
    let weight_tolerance = 1e-3 + 1e-6 / (setup.wo.z.abs() * alpha);
    let probe = probe(ctx);
    let out = run(ctx, &probe.sample, setup, &[], SAMPLES, 3 * SAMPLES as u64);
    let cells = Cells::around(peaks, finest, setup.wo);
    let nodes = cells.nodes();
    let directions: Vec<[f32; 4]> = nodes
        .iter()
        .map(|(d, _)| [d.x as f32, d.y as f32, d.z as f32, 0.0])
        .collect();
    let evaluated = run(
        ctx,
        &probe.eval,
        setup,
        &directions,
        directions.len() as u32,
        directions.len() as u64,
    );
    let mut expected = vec![0.0f64; cells.count()];
    let mut eval_integral = 0.0;
    for (i, ((_, weight), value)) in nodes.iter().zip(&evaluated).enumerate() {
        expected[i / 16] += weight * value[3] as f64;
        eval_integral += weight * value[0] as f64;
    }
    let mut observed = vec![0.0f64; cells.count()];
    let (mut delta, mut absorbed, mut non_finite) = (0usize, 0usize, 0usize);
    let (mut weight_sum, mut weight_squares) = (0.0f64, 0.0f64);
    let (mut smooth_weight, mut smooth_squares) = (0.0f64, 0.0f64);
    let mut weight_mismatches = 0usize;
    for sample in out.chunks_exact(3) {
        let [wi, weight, at_wi] = [sample[0], sample[1], sample[2]];
        if !wi
            .iter()
            .chain(&weight)
            .chain(&at_wi)
            .all(|x| x.is_finite())
        {
            non_finite += 1;
            continue;
        }
        let w = weight[0] as f64;
        weight_sum += w;
        weight_squares += w * w;
        if wi[3] <= 0.0 {
            absorbed += 1;
        } else if weight[3] != 0.0 {
            delta += 1;
        } else {
            smooth_weight += w;
            smooth_squares += w * w;
            let dir = DVec3::new(wi[0] as f64, wi[1] as f64, wi[2] as f64);
            observed[cells.index(dir)] += 1.0;
            // The weight is eval / pdf, and the density the one `pdf` gives.
            let from_eval = at_wi[0] as f64 / at_wi[3] as f64;
            let mismatch = (w - from_eval).abs() / from_eval.max(1e-3)
                + (wi[3] as f64 - at_wi[3] as f64).abs() / (at_wi[3] as f64).max(1e-3);
            if mismatch > weight_tolerance {
                weight_mismatches += 1;
            }
        }
    }
    let n = SAMPLES as f64;
    let pdf_integral: f64 = expected.iter().sum();
    // The remaining mass (delta lobes and absorbed samples) is one more cell.
    let mut cells_observed = observed;
    let mut cells_expected: Vec<f64> = expected.iter().map(|e| e * n).collect();
    cells_observed.push((delta + absorbed) as f64);
    cells_expected.push(((1.0 - pdf_integral) * n).max(0.0));
    let mean = weight_sum / n;
    Measured {
        p_value: common::chi_square_p_value(&cells_observed, &cells_expected),
        pdf_integral,
        smooth_fraction: (SAMPLES as usize - delta - absorbed - non_finite) as f64 / n,
        delta_fraction: delta as f64 / n,
        mean_weight: mean,
        weight_error: ((weight_squares / n - mean * mean).max(0.0) / n).sqrt(),
        eval_integral,
        smooth_weight: smooth_weight / n,
        smooth_weight_error: ((smooth_squares / n - (smooth_weight / n).powi(2)).max(0.0) / n)
            .sqrt(),
        weight_mismatches: weight_mismatches as f64 / n,
        non_finite,
    }
}

#[test]
fn chi_square_survival_matches_tables() {
    // Upper 1% and 5% points of chi-square tables.
    for (x, dof, p) in [
        (6.635, 1.0, 0.01),
        (18.307, 10.0, 0.05),
        (124.342, 100.0, 0.05),
        (3.841, 1.0, 0.05),
    ] {
        let q = common::chi_square_survival(x, dof);
        assert!((q - p).abs() < 2e-4, "Q({x}, {dof}) = {q}, expected {p}");
    }
}

fn mirror(wo: DVec3) -> DVec3 {
    DVec3::new(-wo.x, -wo.y, wo.z)
}

/// The refracted direction of `wo` through a flat interface of relative index `eta`.
fn refracted(wo: DVec3, eta: f64) -> Option<DVec3> {
    let sin2 = (1.0 - wo.z * wo.z) / (eta * eta);
    (sin2 < 1.0).then(|| DVec3::new(-wo.x / eta, -wo.y / eta, -(1.0 - sin2).sqrt()))
}

// Not 0: at normal incidence a lobe of alpha 1e-3 is 2e-6 wide in cos theta,
// a few f32 steps; 5 degrees keeps it resolvable.
const ANGLES: [f64; 4] = [5.0, 40.0, 70.0, 89.9];
const ALPHAS: [f32; 3] = [1e-3, 0.1, 1.0];

/// Runs every configuration, reports them all, and fails if any fails the
/// chi-square test at 0.01 after the Bonferroni correction, or another check.
/// A configuration: its name, the material and direction, the directions of
/// its lobes' peaks, and its roughness (1 for smooth lobes).
type Configuration = (String, Setup, Vec<DVec3>, f64);

fn check_all(
    ctx: &GpuContext,
    configurations: &[Configuration],
    extra: impl Fn(&str, &Measured) -> Result<(), String>,
) {
    let threshold = 0.01 / configurations.len() as f64;
    let mut failures = Vec::new();
    for (name, setup, peaks, alpha) in configurations {
        let m = measure(ctx, setup, peaks, *alpha);
        println!(
            "{name}: p = {:.3e}, ∫pdf = {:.5} (smooth samples {:.5}), albedo {:.5} ± {:.5}, ∫eval {:.5} (smooth samples {:.5}), delta {:.4}, weights off eval / pdf {:.1e}",
            m.p_value,
            m.pdf_integral,
            m.smooth_fraction,
            m.mean_weight,
            m.weight_error,
            m.eval_integral,
            m.smooth_weight,
            m.delta_fraction,
            m.weight_mismatches
        );
        let mut problems = Vec::new();
        if m.non_finite > 0 {
            problems.push(format!("{} non-finite samples", m.non_finite));
        }
        if m.p_value < threshold {
            problems.push(format!(
                "chi-square p = {:.3e} < {threshold:.1e}",
                m.p_value
            ));
        }
        // The density's mass is the fraction of samples it accounts for: within
        // 4 binomial standard errors, plus the quadrature's 1e-3.
        let sigma = (m.smooth_fraction * (1.0 - m.smooth_fraction) / SAMPLES as f64).sqrt();
        if (m.pdf_integral - m.smooth_fraction).abs() > 4.0 * sigma + 1e-3 {
            problems.push(format!(
                "∫pdf {:.5} against {:.5} of the samples",
                m.pdf_integral, m.smooth_fraction
            ));
        }
        // ∫eval is what the smooth samples' weights estimate.
        if (m.eval_integral - m.smooth_weight).abs()
            > 4.0 * m.smooth_weight_error + 2e-3 * m.eval_integral.max(0.01)
        {
            problems.push(format!(
                "∫eval {:.5} against smooth weights {:.5}",
                m.eval_integral, m.smooth_weight
            ));
        }
        if m.weight_mismatches > 1e-3 {
            problems.push(format!(
                "{:.1e} of the weights differ from eval / pdf",
                m.weight_mismatches
            ));
        }
        if let Err(e) = extra(name, &m) {
            problems.push(e);
        }
        if !problems.is_empty() {
            failures.push(format!("{name}: {}", problems.join("; ")));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn no_extra(_: &str, _: &Measured) -> Result<(), String> {
    Ok(())
}

const GOLD_ETA: glam::Vec3 = glam::Vec3::new(0.143, 0.374, 1.442);
const GOLD_K: glam::Vec3 = glam::Vec3::new(3.983, 2.385, 1.603);

fn rough_conductor(distribution: Distribution, alpha_u: f32, alpha_v: f32) -> MaterialKind {
    MaterialKind::RoughConductor {
        distribution,
        alpha_u,
        alpha_v,
        eta: GOLD_ETA,
        k: GOLD_K,
        specular_reflectance: glam::Vec3::ONE,
    }
}

#[test]
fn roughconductor_samples_its_density() {
    let ctx = gpu_or_skip!();
    let mut configurations = Vec::new();
    for distribution in Distribution::ALL {
        for alpha in ALPHAS {
            for theta in ANGLES {
                let setup = Setup::new(rough_conductor(distribution, alpha, alpha), theta, true);
                let name = format!("{} alpha {alpha} at {theta}°", distribution.name());
                configurations.push((name, setup, vec![mirror(setup.wo)], alpha as f64));
            }
        }
        let setup = Setup::new(rough_conductor(distribution, 0.05, 0.4), 50.0, true);
        configurations.push((
            format!("{} anisotropic 0.05 x 0.4 at 50°", distribution.name()),
            setup,
            vec![mirror(setup.wo)],
            0.05,
        ));
    }
    check_all(ctx, &configurations, no_extra);
}

/// At 89.9 degrees a Beckmann lobe of alpha 1e-3 is 3.5e-6 rad across (60 f32
/// steps) and cut by the horizon: the quadrature of its density there misses
/// 0.2% (p ~ 1e-5), so such a configuration cannot be tested; GGX's passes.
fn beyond_the_quadrature(distribution: Distribution, alpha: f32, theta: f64) -> bool {
    distribution == Distribution::Beckmann && alpha < 1e-2 && theta > 89.0
}

#[test]
fn roughdielectric_samples_its_density() {
    let ctx = gpu_or_skip!();
    let mut configurations = Vec::new();
    for distribution in Distribution::ALL {
        for alpha in ALPHAS {
            for theta in ANGLES {
                if beyond_the_quadrature(distribution, alpha, theta) {
                    continue;
                }
                for front_face in [true, false] {
                    let kind = MaterialKind::RoughDielectric {
                        distribution,
                        alpha_u: alpha,
                        alpha_v: alpha,
                        int_ior: 1.5,
                        ext_ior: 1.0,
                        specular_reflectance: glam::Vec3::ONE,
                        specular_transmittance: glam::Vec3::ONE,
                    };
                    let setup = Setup::new(kind, theta, front_face);
                    let eta = if front_face { 1.5 } else { 1.0 / 1.5 };
                    let mut peaks = vec![mirror(setup.wo)];
                    peaks.extend(refracted(setup.wo, eta));
                    // Where the transmitting microfacet would be vertical
                    // ((wo + eta wi).z = 0) the density drops to 0 at once
                    // (the density of vertical facets is not 0): a cell boundary.
                    peaks.push(DVec3::new(1.0, 0.0, -setup.wo.z / eta));
                    let side = if front_face { "outside" } else { "inside" };
                    let name = format!(
                        "{} alpha {alpha} at {theta}° from {side}",
                        distribution.name()
                    );
                    configurations.push((name, setup, peaks, alpha as f64));
                }
            }
        }
    }
    check_all(ctx, &configurations, no_extra);
}

#[test]
fn plastic_samples_its_diffuse_density_and_its_coat() {
    let ctx = gpu_or_skip!();
    let mut configurations = Vec::new();
    for nonlinear in [false, true] {
        for theta in ANGLES {
            let kind = MaterialKind::Plastic {
                int_ior: 1.49,
                ext_ior: 1.00028,
                diffuse_reflectance: glam::Vec3::new(0.7, 0.4, 0.2),
                specular_reflectance: glam::Vec3::ONE,
                nonlinear,
            };
            let setup = Setup::new(kind, theta, true);
            configurations.push((
                format!("plastic nonlinear={nonlinear} at {theta}°"),
                setup,
                vec![],
                1.0,
            ));
        }
    }
    check_all(ctx, &configurations, |_, m| {
        // Every sample is the coat's (delta) or the base's (in the density).
        if (m.delta_fraction + m.smooth_fraction - 1.0).abs() > 1e-6 {
            return Err(format!(
                "{} of the samples neither delta nor smooth",
                1.0 - m.delta_fraction - m.smooth_fraction
            ));
        }
        Ok(())
    });
}

#[test]
fn roughplastic_samples_its_density() {
    let ctx = gpu_or_skip!();
    let mut configurations = Vec::new();
    for distribution in Distribution::ALL {
        for alpha in ALPHAS {
            for theta in ANGLES {
                if beyond_the_quadrature(distribution, alpha, theta) {
                    continue;
                }
                // Veach's plates: a dark base under a coat of index 2 (`nonlinear`
                // changes the base's colour, not the sampling: once is enough).
                let nonlinear = theta == ANGLES[1];
                let kind = MaterialKind::RoughPlastic {
                    distribution,
                    alpha,
                    int_ior: 2.0,
                    ext_ior: 1.000277,
                    diffuse_reflectance: glam::Vec3::new(0.07, 0.09, 0.13),
                    specular_reflectance: glam::Vec3::ONE,
                    nonlinear,
                };
                let setup = Setup::new(kind, theta, true);
                let name = format!(
                    "{} alpha {alpha} at {theta}° nonlinear={nonlinear}",
                    distribution.name()
                );
                // The coat's lobe at the mirror direction; the base is broad.
                configurations.push((name, setup, vec![mirror(setup.wo)], alpha as f64));
            }
        }
    }
    check_all(ctx, &configurations, |_, m| {
        // Both lobes have densities: no sample is delta, and only a coat
        // sample reflected below the horizon is lost.
        if m.delta_fraction != 0.0 {
            return Err(format!("{} of the samples delta", m.delta_fraction));
        }
        Ok(())
    });
}

#[test]
fn lambertian_density_is_the_cosine_lobe() {
    let ctx = gpu_or_skip!();
    let setup = Setup::new(MaterialKind::Lambertian, 30.0, true);
    check_all(ctx, &[("lambertian".into(), setup, vec![], 1.0)], |_, m| {
        // Exactly: ∫pdf = 1 and the albedo is 0.8.
        if (m.pdf_integral - 1.0).abs() > 1e-4 || (m.mean_weight - 0.8).abs() > 1e-6 {
            return Err(format!("∫pdf {}, albedo {}", m.pdf_integral, m.mean_weight));
        }
        Ok(())
    });
}

/// Mean sample weight (the one-bounce albedo) of `kind` seen at `theta`.
fn albedo(ctx: &GpuContext, kind: MaterialKind, theta: f64) -> (f64, f64) {
    let setup = Setup::new(kind, theta, true);
    let out = run(
        ctx,
        &probe(ctx).sample,
        &setup,
        &[],
        SAMPLES,
        3 * SAMPLES as u64,
    );
    let weights: Vec<f64> = out.chunks_exact(3).map(|s| s[1][0] as f64).collect();
    let n = weights.len() as f64;
    let mean = weights.iter().sum::<f64>() / n;
    let variance = weights.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / n;
    (mean, (variance / n).sqrt())
}

/// Mitsuba's default conductor (eta 0, k 1) reflects everything, and as alpha
/// goes to 0 a rough conductor's albedo goes to the smooth one's Fresnel
/// reflectance (Smith's masking vanishes, and so does the spread of facet angles).
#[test]
fn rough_conductors_converge_to_the_smooth_conductor() {
    let ctx = gpu_or_skip!();
    let perfect = MaterialKind::Conductor {
        eta: glam::Vec3::ZERO,
        k: glam::Vec3::ONE,
        specular_reflectance: glam::Vec3::ONE,
    };
    let (mirror_albedo, spread) = albedo(ctx, perfect, 40.0);
    assert_eq!(
        (mirror_albedo, spread),
        (1.0, 0.0),
        "a perfect mirror reflects everything"
    );
    let gold = MaterialKind::Conductor {
        eta: GOLD_ETA,
        k: GOLD_K,
        specular_reflectance: glam::Vec3::ONE,
    };
    for theta in [0.0, 40.0, 70.0] {
        let (smooth, _) = albedo(ctx, gold, theta);
        for distribution in Distribution::ALL {
            let mut gaps = Vec::new();
            for alpha in [0.3, 0.1, 0.01, 1e-4] {
                let (rough, error) =
                    albedo(ctx, rough_conductor(distribution, alpha, alpha), theta);
                println!(
                    "{} alpha {alpha} at {theta}°: {rough:.6} ± {error:.1e}, smooth {smooth:.6}",
                    distribution.name()
                );
                gaps.push((smooth - rough).abs());
            }
            // Masking loses energy at alpha 0.3; the Fresnel term averaged over
            // the facets may give back a little more than the mirror's at small
            // alpha, but the difference vanishes.
            assert!(
                gaps[3] < gaps[0],
                "{} at {theta}°: gaps {gaps:?}",
                distribution.name()
            );
            assert!(
                gaps[3] < 2e-4,
                "{} at alpha 1e-4, {theta}°: gap {}",
                distribution.name(),
                gaps[3]
            );
        }
    }
}

/// A roughdielectric of alpha 1e-4 and an index close to 1 or far from it stays
/// finite, and its albedo (reflection plus transmission, the radiance scale
/// 1 / eta^2 taken out on entering) is the smooth interface's 1.
#[test]
fn rough_dielectric_extremes_conserve_energy() {
    let ctx = gpu_or_skip!();
    for eta in [1.0001f32, 1.5, 4.0] {
        for theta in [0.0, 40.0, 80.0] {
            let kind = MaterialKind::RoughDielectric {
                distribution: Distribution::Ggx,
                alpha_u: 1e-4,
                alpha_v: 1e-4,
                int_ior: eta,
                ext_ior: 1.0,
                specular_reflectance: glam::Vec3::ONE,
                specular_transmittance: glam::Vec3::ONE,
            };
            let setup = Setup::new(kind, theta, true);
            let out = run(
                ctx,
                &probe(ctx).sample,
                &setup,
                &[],
                SAMPLES,
                3 * SAMPLES as u64,
            );
            let mut energy = 0.0;
            for s in out.chunks_exact(3) {
                assert!(
                    s.iter().flatten().all(|x| x.is_finite()),
                    "eta {eta} at {theta}°: {s:?}"
                );
                // Transmitted samples carry 1 / eta^2: undo it to count energy.
                let scale = if s[0][2] < 0.0 {
                    (eta * eta) as f64
                } else {
                    1.0
                };
                energy += s[1][0] as f64 * scale;
            }
            let energy = energy / SAMPLES as f64;
            println!("eta {eta} at {theta}°: energy {energy:.6}");
            assert!(
                (energy - 1.0).abs() < 2e-3,
                "eta {eta} at {theta}°: energy {energy}"
            );
        }
    }
}

/// Different estimators, one answer, on every smooth and mixed material: the
/// image means of BSDF sampling, the mixture and NEE+MIS agree within their
/// combined standard errors on a small scene of plastic (a delta coat over a
/// diffuse base), a rough plastic, rough conductors and a rough dielectric
/// under a quad light and a sky.
#[test]
fn strategies_agree_on_the_microfacet_materials() {
    let ctx = gpu_or_skip!();
    let text = r#"
        [camera]
        lookfrom = [0, 1.5, 5]
        lookat = [0, 0.5, 0]
        vfov = 40
        width = 16
        height = 16
        [render]
        spp = 1024
        max_depth = 6
        sampler = "independent"
        background = [0.2, 0.25, 0.3]
        [materials.floor]
        type = "plastic"
        diffuse_reflectance = [0.6, 0.5, 0.4]
        [materials.coated]
        type = "plastic"
        diffuse_reflectance = [0.7, 0.1, 0.1]
        nonlinear = true
        [materials.gold]
        type = "roughconductor"
        distribution = "ggx"
        alpha = 0.15
        eta = [0.143, 0.374, 1.442]
        k = [3.983, 2.385, 1.603]
        [materials.brushed]
        type = "roughconductor"
        alpha_u = 0.05
        alpha_v = 0.4
        [materials.frosted]
        type = "roughdielectric"
        alpha = 0.3
        [materials.rough_coat]
        type = "roughplastic"
        alpha = 0.2
        diffuse_reflectance = [0.1, 0.3, 0.6]
        [materials.lamp]
        type = "light"
        emit = [6, 6, 6]
        [[objects]]
        type = "quad"
        q = [-5, 0, -5]
        u = [0, 0, 10]
        v = [10, 0, 0]
        material = "floor"
        [[objects]]
        type = "quad"
        q = [-1, 3, -1]
        u = [2, 0, 0]
        v = [0, 0, 2]
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [-1.2, 0.5, 0]
        radius = 0.5
        material = "gold"
        [[objects]]
        type = "sphere"
        center = [0, 0.5, 0]
        radius = 0.5
        material = "frosted"
        [[objects]]
        type = "sphere"
        center = [1.2, 0.5, 0]
        radius = 0.5
        material = "coated"
        [[objects]]
        type = "sphere"
        center = [0, 0.4, 1.2]
        radius = 0.4
        material = "brushed"
        [[objects]]
        type = "sphere"
        center = [-1.2, 0.4, 1.2]
        radius = 0.4
        material = "rough_coat"
    "#;
    let mut results = Vec::new();
    for strategy in [Strategy::Bsdf, Strategy::Mixture, Strategy::NeeMis] {
        let mut scene = common::scene_text(text);
        scene.render.strategy = strategy;
        let acc = common::render(ctx, &scene, &common::with_variance());
        results.push((strategy, common::image_mean_and_error(&acc)));
    }
    let (_, (reference, reference_error)) = results[0];
    for &(strategy, (mean, error)) in &results[1..] {
        let combined = (error * error + reference_error * reference_error).sqrt();
        println!("{strategy}: {mean:.5} ± {error:.5}; bsdf {reference:.5} ± {reference_error:.5}");
        assert!(
            (mean - reference).abs() < 4.0 * combined,
            "{strategy}: {mean} against bsdf {reference} ± {combined}"
        );
    }
}

/// A principled material of these numbers (`base_color` white unless given).
#[derive(Clone, Copy)]
struct Principled {
    base_color: glam::Vec3,
    roughness: f32,
    anisotropic: f32,
    metallic: f32,
    spec_trans: f32,
    eta: f32,
    spec_tint: f32,
    sheen: f32,
    clearcoat: f32,
    clearcoat_gloss: f32,
    flatness: f32,
}

const PRINCIPLED: Principled = Principled {
    base_color: glam::Vec3::ONE,
    roughness: 0.5,
    anisotropic: 0.0,
    metallic: 0.0,
    spec_trans: 0.0,
    eta: 1.5,
    spec_tint: 0.0,
    sheen: 0.0,
    clearcoat: 0.0,
    clearcoat_gloss: 0.0,
    flatness: 0.0,
};

impl Principled {
    fn kind(self) -> MaterialKind {
        MaterialKind::Principled {
            base_color: self.base_color,
            roughness: self.roughness,
            anisotropic: self.anisotropic,
            metallic: self.metallic,
            spec_trans: self.spec_trans,
            eta: self.eta,
            spec_tint: self.spec_tint,
            sheen: self.sheen,
            sheen_tint: 0.5,
            clearcoat: self.clearcoat,
            clearcoat_gloss: self.clearcoat_gloss,
            flatness: self.flatness,
        }
    }
}

/// Principled's mixture against its density over the corners of its
/// parameters: diffuse (with retro-reflection, flattened), metal, glass seen
/// from both sides, half-transmitting, a clearcoat as glossy as it gets,
/// sheen, anisotropy, and roughness down to 0 (alpha 0.001).
#[test]
fn principled_samples_its_density() {
    let ctx = gpu_or_skip!();
    let tinted = glam::Vec3::new(0.8, 0.5, 0.2);
    let cases: [(&str, Principled, &[f64]); 11] = [
        (
            "diffuse rough",
            Principled {
                roughness: 1.0,
                base_color: tinted,
                ..PRINCIPLED
            },
            &ANGLES,
        ),
        (
            "flat with sheen",
            Principled {
                flatness: 1.0,
                sheen: 1.0,
                spec_tint: 1.0,
                base_color: tinted,
                ..PRINCIPLED
            },
            &[40.0, 89.9],
        ),
        (
            "metal roughness 0",
            Principled {
                metallic: 1.0,
                roughness: 0.0,
                ..PRINCIPLED
            },
            &[5.0, 70.0, 89.9],
        ),
        (
            "metal anisotropic",
            Principled {
                metallic: 0.7,
                roughness: 0.4,
                anisotropic: 1.0,
                ..PRINCIPLED
            },
            &[40.0],
        ),
        (
            "glass roughness 0",
            Principled {
                spec_trans: 1.0,
                roughness: 0.0,
                ..PRINCIPLED
            },
            &[5.0, 70.0],
        ),
        (
            "glass roughness 0.3",
            Principled {
                spec_trans: 1.0,
                roughness: 0.3,
                base_color: tinted,
                ..PRINCIPLED
            },
            &[40.0, 89.9],
        ),
        (
            "half glass",
            Principled {
                spec_trans: 0.5,
                metallic: 0.3,
                roughness: 0.6,
                clearcoat: 0.5,
                ..PRINCIPLED
            },
            &[40.0, 70.0],
        ),
        (
            "glass of index 0.7",
            Principled {
                spec_trans: 1.0,
                eta: 0.7,
                roughness: 0.2,
                ..PRINCIPLED
            },
            &[40.0],
        ),
        (
            "clearcoat glossy",
            Principled {
                clearcoat: 1.0,
                clearcoat_gloss: 1.0,
                roughness: 0.8,
                ..PRINCIPLED
            },
            &[5.0, 40.0, 89.9],
        ),
        (
            "clearcoat rough",
            Principled {
                clearcoat: 1.0,
                roughness: 0.1,
                metallic: 0.5,
                ..PRINCIPLED
            },
            &[70.0],
        ),
        (
            "everything",
            Principled {
                metallic: 0.2,
                spec_trans: 0.3,
                spec_tint: 0.5,
                sheen: 0.7,
                clearcoat: 0.6,
                clearcoat_gloss: 0.5,
                anisotropic: 0.5,
                flatness: 0.5,
                roughness: 0.35,
                base_color: tinted,
                ..PRINCIPLED
            },
            &[40.0],
        ),
    ];
    let mut configurations = Vec::new();
    for (name, p, angles) in cases {
        for &theta in angles {
            let sides: &[bool] = if p.spec_trans > 0.0 {
                &[true, false]
            } else {
                &[true]
            };
            for &front_face in sides {
                let setup = Setup::new(p.kind(), theta, front_face);
                let eta = if front_face {
                    p.eta as f64
                } else {
                    1.0 / p.eta as f64
                };
                let mut peaks = vec![mirror(setup.wo)];
                if p.spec_trans > 0.0 {
                    peaks.extend(refracted(setup.wo, eta));
                    // Where a transmitting microfacet would be vertical.
                    peaks.push(DVec3::new(1.0, 0.0, -setup.wo.z / eta));
                }
                let alpha = (p.roughness * p.roughness).max(1e-3) as f64;
                // The clearcoat's GTR1 narrows to alpha 0.001 at gloss 1.
                let coat_alpha = if p.clearcoat > 0.0 {
                    0.1 + (0.001 - 0.1) * p.clearcoat_gloss as f64
                } else {
                    1.0
                };
                let side = if front_face { "outside" } else { "inside" };
                configurations.push((
                    format!("{name} at {theta}° from {side}"),
                    setup,
                    peaks,
                    alpha.min(coat_alpha),
                ));
            }
        }
    }
    check_all(ctx, &configurations, |_, m| {
        // Every lobe has a density: no sample is delta.
        if m.delta_fraction != 0.0 {
            return Err(format!("{} of the samples delta", m.delta_fraction));
        }
        Ok(())
    });
}

/// A white furnace of one bounce: what a white principled reflects, against
/// what it should. A mirror-smooth white metal and a smooth glass (its
/// transmitted radiance's 1 / eta^2 undone) conserve energy; the diffuse lobe
/// alone (roughness 0: no retro-reflection; `specular` 0: no coat) reflects
/// Burley's (1 - F_i / 2)(1 - 1/42), F_i = (1 - cos theta)^5: the Disney
/// diffuse's known loss, 2.4% at normal incidence and 50% at grazing. The
/// whole model is not energy-conserving (its lobes add, and single-scattering
/// GGX loses what bounces between microfacets): printed for the default
/// material with a clearcoat and sheen.
#[test]
fn principled_white_furnace() {
    let ctx = gpu_or_skip!();
    let energy = |p: Principled, theta: f64| {
        let setup = Setup::new(p.kind(), theta, true);
        let out = run(
            ctx,
            &probe(ctx).sample,
            &setup,
            &[],
            SAMPLES,
            3 * SAMPLES as u64,
        );
        let mut sum = 0.0;
        for s in out.chunks_exact(3) {
            assert!(s.iter().flatten().all(|x| x.is_finite()), "{s:?}");
            let scale = if s[0][2] < 0.0 {
                (p.eta * p.eta) as f64
            } else {
                1.0
            };
            sum += s[1][0] as f64 * scale;
        }
        sum / SAMPLES as f64
    };
    let mut failures = Vec::new();
    for theta in [0.0f64, 40.0, 80.0] {
        let fi = (1.0 - theta.to_radians().cos()).powi(5);
        for (name, p, expected) in [
            (
                "metal",
                Principled {
                    metallic: 1.0,
                    roughness: 0.0,
                    ..PRINCIPLED
                },
                1.0,
            ),
            (
                "glass",
                Principled {
                    spec_trans: 1.0,
                    roughness: 0.0,
                    ..PRINCIPLED
                },
                1.0,
            ),
            (
                "diffuse",
                Principled {
                    roughness: 0.0,
                    eta: 1.0,
                    ..PRINCIPLED
                },
                (1.0 - 0.5 * fi) * (1.0 - 1.0 / 42.0),
            ),
        ] {
            let measured = energy(p, theta);
            println!("{name} at {theta}°: {measured:.5}, expected {expected:.5}");
            if (measured - expected).abs() > 3e-3 {
                failures.push(format!("{name} at {theta}°: {measured} against {expected}"));
            }
        }
        let full = Principled {
            sheen: 1.0,
            clearcoat: 1.0,
            ..PRINCIPLED
        };
        println!(
            "default with sheen and clearcoat at {theta}°: {:.4}",
            energy(full, theta)
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The strategies see `principled` through the BSDF interface alone: BSDF
/// sampling, the mixture and NEE+MIS agree within their combined standard
/// errors on principled spheres (a textured base colour under sheen and
/// clearcoat, a brushed metal, a rough glass, a half-transmitting one) under
/// a quad light and a sky.
#[test]
fn strategies_agree_on_principled() {
    let ctx = gpu_or_skip!();
    let text = r#"
        [camera]
        lookfrom = [0, 1.5, 5]
        lookat = [0, 0.5, 0]
        vfov = 40
        width = 16
        height = 16
        [render]
        spp = 1024
        max_depth = 6
        sampler = "independent"
        background = [0.2, 0.25, 0.3]
        [materials.floor]
        type = "principled"
        base_color = { type = "checkerboard", color0 = [0.8, 0.2, 0.1], color1 = [0.9, 0.85, 0.7] }
        sheen = 0.6
        clearcoat = 0.8
        clearcoat_gloss = 0.6
        [materials.brushed]
        type = "principled"
        base_color = [0.95, 0.7, 0.35]
        metallic = 0.9
        roughness = 0.3
        anisotropic = 0.8
        [materials.glass]
        type = "principled"
        spec_trans = 1
        roughness = 0.2
        eta = 1.5
        [materials.half]
        type = "principled"
        base_color = [0.2, 0.45, 0.75]
        spec_trans = 0.4
        metallic = 0.2
        roughness = 0.7
        flatness = 0.5
        [materials.lamp]
        type = "light"
        emit = [6, 6, 6]
        [[objects]]
        type = "quad"
        q = [-5, 0, -5]
        u = [0, 0, 10]
        v = [10, 0, 0]
        material = "floor"
        [[objects]]
        type = "quad"
        q = [-1, 3, -1]
        u = [2, 0, 0]
        v = [0, 0, 2]
        material = "lamp"
        [[objects]]
        type = "sphere"
        center = [-1.2, 0.5, 0]
        radius = 0.5
        material = "brushed"
        [[objects]]
        type = "sphere"
        center = [0, 0.5, 0]
        radius = 0.5
        material = "glass"
        [[objects]]
        type = "sphere"
        center = [1.2, 0.5, 0]
        radius = 0.5
        material = "half"
    "#;
    let mut results = Vec::new();
    for strategy in [Strategy::Bsdf, Strategy::Mixture, Strategy::NeeMis] {
        let mut scene = common::scene_text(text);
        scene.render.strategy = strategy;
        let acc = common::render(ctx, &scene, &common::with_variance());
        results.push((strategy, common::image_mean_and_error(&acc)));
    }
    let (_, (reference, reference_error)) = results[0];
    for &(strategy, (mean, error)) in &results[1..] {
        let combined = (error * error + reference_error * reference_error).sqrt();
        println!("{strategy}: {mean:.5} ± {error:.5}; bsdf {reference:.5} ± {reference_error:.5}");
        assert!(
            (mean - reference).abs() < 4.0 * combined,
            "{strategy}: {mean} against bsdf {reference} ± {combined}"
        );
    }
}

/// A thin principled material of these numbers, white.
fn principled_thin(
    roughness: f32,
    anisotropic: f32,
    spec_trans: f32,
    eta: f32,
    diff_trans: f32,
    spec_tint: f32,
) -> MaterialKind {
    MaterialKind::PrincipledThin {
        base_color: glam::Vec3::ONE,
        roughness,
        anisotropic,
        spec_trans,
        eta,
        spec_tint,
        sheen: 0.5,
        sheen_tint: 0.5,
        flatness: 0.5,
        diff_trans,
    }
}

/// The thin principled's mixture against its density: diffuse, glossy and
/// mirror-smooth sheets (alpha 0.001), transmitting by their microfacets
/// (straight through: the peak is -wo) and diffusely, anisotropic, of an
/// index below 1 (its transmission's roughness scaled to the floor), seen
/// from either side (the same sheet).
#[test]
fn principledthin_samples_its_density() {
    let ctx = gpu_or_skip!();
    let cases: [(&str, MaterialKind, &[f64]); 6] = [
        (
            "diffuse",
            principled_thin(0.5, 0.0, 0.0, 1.5, 0.0, 0.5),
            &ANGLES,
        ),
        (
            "smooth sheet",
            principled_thin(0.0, 0.0, 1.0, 1.5, 0.0, 0.5),
            &[5.0, 40.0, 70.0],
        ),
        (
            "glossy and diffuse transmission",
            principled_thin(0.3, 0.7, 0.5, 1.5, 1.0, 0.5),
            &[40.0, 89.9],
        ),
        (
            "diffuse transmission only",
            principled_thin(0.5, 0.0, 0.0, 1.5, 2.0, 0.5),
            &[40.0],
        ),
        (
            "index 0.6",
            principled_thin(0.4, 0.0, 1.0, 0.6, 0.0, 0.5),
            &[40.0],
        ),
        (
            "rough sheet",
            principled_thin(1.0, 0.0, 0.6, 2.0, 0.8, 0.5),
            &[70.0],
        ),
    ];
    let mut configurations = Vec::new();
    for (name, kind, angles) in cases {
        let MaterialKind::PrincipledThin { roughness, eta, .. } = kind else {
            unreachable!()
        };
        let alpha = |r: f32| (r * r).max(1e-3) as f64;
        let cell_alpha = alpha(roughness).min(alpha((0.65 * eta - 0.35) * roughness));
        for &theta in angles {
            for front_face in [true, false] {
                if !front_face && theta != angles[0] {
                    continue;
                }
                let setup = Setup::new(kind, theta, front_face);
                let peaks = vec![mirror(setup.wo), -setup.wo];
                let side = if front_face { "front" } else { "back" };
                configurations.push((
                    format!("{name} at {theta}° ({side})"),
                    setup,
                    peaks,
                    cell_alpha,
                ));
            }
        }
    }
    check_all(ctx, &configurations, |_, m| {
        if m.delta_fraction != 0.0 {
            return Err(format!("{} of the samples delta", m.delta_fraction));
        }
        Ok(())
    });
}

/// A white furnace of one bounce for the thin principled: a mirror-smooth
/// sheet reflects F and passes 1 - F straight through (no 1 / eta^2: the
/// light leaves the sheet's far side into the same medium), and a sheet of
/// diffuse transmission only (`diff_trans` 2) passes everything: both
/// conserve energy.
#[test]
fn principledthin_white_furnace() {
    let ctx = gpu_or_skip!();
    let mut failures = Vec::new();
    for theta in [0.0f64, 40.0, 80.0] {
        for (name, kind) in [
            (
                "smooth sheet",
                principled_thin(0.0, 0.0, 1.0, 1.5, 0.0, 0.0),
            ),
            (
                "diffuse transmission",
                principled_thin(0.5, 0.0, 0.0, 1.5, 2.0, 0.0),
            ),
        ] {
            let (mean, error) = albedo(ctx, kind, theta);
            println!("{name} at {theta}°: {mean:.5} ± {error:.5}");
            if (mean - 1.0).abs() > 3e-3 {
                failures.push(format!("{name} at {theta}°: {mean}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
