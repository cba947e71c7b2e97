//! The tables of a rough dielectric coat (`roughplastic`), computed on the host
//! once per material as Mitsuba 3's `roughplastic` does in its constructor: the
//! fraction of light a rough interface transmits, per incidence cosine (64
//! entries the kernel interpolates), and the coat's internal diffuse reflectance.
//!
//! Both are integrals over the microfacet normals visible from the incident
//! direction, taken as Mitsuba takes them (`eval_transmittance`,
//! `eval_reflectance` in `mitsuba/render/microfacet.h`): Gauss-Legendre nodes on
//! the unit square mapped through the visible-normal sampler, so the integrand
//! left is the Fresnel term times the masking of the outgoing direction. The
//! microfacet functions here are `shaders/microfacet.wgsl`'s, in f64.

use super::Distribution;
use glam::DVec3;
use std::f64::consts::PI;

/// Entries of a transmittance table: cosines 0, 1/63, ..., 1 (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`). Shared with the kernel as a generated constant.
pub const ROUGH_TRANSMITTANCE_RES: usize = 64;

/// What the kernel needs of a rough coat besides its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct CoatTables {
    /// Light transmitted into the coat from outside, at incidence cosine
    /// `i / (ROUGH_TRANSMITTANCE_RES - 1)` (the first at 1e-6, as Mitsuba).
    pub transmittance: [f32; ROUGH_TRANSMITTANCE_RES],
    /// The hemispherical average of the reflectance seen from inside the coat.
    pub internal_reflectance: f32,
}

impl CoatTables {
    /// The tables of a coat of relative index `eta` (inside over outside) with
    /// an isotropic microfacet distribution of roughness `alpha`.
    pub fn new(distribution: Distribution, alpha: f32, eta: f32) -> CoatTables {
        let microfacet = Microfacet {
            alpha: alpha as f64,
            beckmann: distribution == Distribution::Beckmann,
        };
        let eta = eta as f64;
        let cosines: Vec<f64> = (0..ROUGH_TRANSMITTANCE_RES)
            .map(|i| (i as f64 / (ROUGH_TRANSMITTANCE_RES - 1) as f64).max(1e-6))
            .collect();
        // (T(mu), R_inside(mu)) per cosine: a million normals in all, so
        // spread over the cores.
        let rules = CoatRules::new();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk = cosines.len().div_ceil(threads);
        let integrals: Vec<(f64, f64)> = std::thread::scope(|scope| {
            let workers: Vec<_> = cosines
                .chunks(chunk)
                .map(|part| {
                    let (microfacet, rules) = (&microfacet, &rules);
                    scope.spawn(move || {
                        part.iter()
                            .map(|&mu| {
                                (
                                    microfacet.transmittance(mu, eta, rules),
                                    microfacet.reflectance(mu, 1.0 / eta, rules),
                                )
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            workers
                .into_iter()
                .flat_map(|w| w.join().expect("coat table worker"))
                .collect()
        });
        let mut transmittance = [0.0; ROUGH_TRANSMITTANCE_RES];
        for (t, &(integral, _)) in transmittance.iter_mut().zip(&integrals) {
            *t = integral as f32;
        }
        // Mitsuba's estimate of 2 ∫ R(mu) mu dmu: the mean over the same cosines.
        let internal = integrals
            .iter()
            .zip(&cosines)
            .map(|(&(_, reflectance), &mu)| reflectance * mu)
            .sum::<f64>()
            / cosines.len() as f64
            * 2.0;
        CoatTables {
            transmittance,
            internal_reflectance: internal as f32,
        }
    }
}

/// An isotropic Beckmann or GGX distribution, in a frame whose normal is +z.
struct Microfacet {
    alpha: f64,
    beckmann: bool,
}

impl Microfacet {
    /// Smith's masking G1(v, m), the closed forms `microfacet_g1` uses.
    fn g1(&self, v: DVec3, m: DVec3) -> f64 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy_alpha_2 = self.alpha * self.alpha * (v.x * v.x + v.y * v.y);
        if xy_alpha_2 == 0.0 {
            return 1.0;
        }
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        if self.beckmann {
            let a = tan_theta_alpha_2.sqrt().recip();
            2.0 / (1.0 + libm::erf(a) + (-a * a).exp() / (a * PI.sqrt()))
        } else {
            2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt())
        }
    }

    /// The frame `sample_visible` unstretches its slopes in, for `wi` (wi.z > 0).
    fn visible_frame(&self, wi: DVec3) -> VisibleFrame {
        let wi_p = DVec3::new(self.alpha * wi.x, self.alpha * wi.y, wi.z).normalize();
        let sin_theta = (wi_p.x * wi_p.x + wi_p.y * wi_p.y).sqrt();
        let (cos_phi, sin_phi) = if sin_theta > 1e-12 {
            (wi_p.x / sin_theta, wi_p.y / sin_theta)
        } else {
            (1.0, 0.0)
        };
        VisibleFrame {
            cos_theta: wi_p.z,
            cos_phi,
            sin_phi,
        }
    }

    /// The normal of a unit-roughness slope drawn in `frame`: rotated and
    /// unstretched.
    fn unstretch(&self, frame: &VisibleFrame, [sx, sy]: [f64; 2]) -> DVec3 {
        let x = (frame.cos_phi * sx - frame.sin_phi * sy) * self.alpha;
        let y = (frame.sin_phi * sx + frame.cos_phi * sy) * self.alpha;
        DVec3::new(-x, -y, 1.0).normalize()
    }

    /// A normal visible from `wi` (wi.z > 0), with density D(m) G1(wi, m)
    /// |wi.m| / wi.z: stretch, sample the unit distribution, unstretch.
    #[cfg(test)]
    fn sample_visible(&self, wi: DVec3, u: [f64; 2]) -> DVec3 {
        let frame = self.visible_frame(wi);
        let slope = match self.beckmann {
            true => [
                beckmann_slope_x(frame.cos_theta, u[0]),
                beckmann_slope_y(u[1]),
            ],
            false => ggx_slope(frame.cos_theta, u),
        };
        self.unstretch(&frame, slope)
    }

    /// Mitsuba's `eval_transmittance`: the light a rough interface of index
    /// `eta` transmits from incidence cosine `mu` (masking of the refracted
    /// direction included).
    fn transmittance(&self, mu: f64, eta: f64, rules: &CoatRules) -> f64 {
        self.integrate(mu, rules.for_eta(eta), |wi, m| {
            let cos_i = wi.dot(m);
            let (f, cos_t, eta_ti) = fresnel_dielectric(cos_i, eta);
            let wo = m * (cos_i * eta_ti + cos_t) - wi * eta_ti;
            if wo.z * wi.z >= 0.0 {
                0.0
            } else {
                (1.0 - f) * self.g1(wo, m)
            }
        })
    }

    /// Mitsuba's `eval_reflectance`: the light it reflects.
    fn reflectance(&self, mu: f64, eta: f64, rules: &CoatRules) -> f64 {
        self.integrate(mu, rules.for_eta(eta), |wi, m| {
            let cos_i = wi.dot(m);
            let wo = m * (2.0 * cos_i) - wi;
            if wo.z <= 0.0 {
                0.0
            } else {
                fresnel_dielectric(cos_i, eta).0 * self.g1(wo, m)
            }
        })
    }

    /// ∫ integrand(wi, m) over the normals visible from incidence cosine `mu`,
    /// by Mitsuba's rule: `rule`'s Gauss-Legendre nodes squared (32², or 128²
    /// when `eta` < 1, where total internal reflection cuts the integrand)
    /// through the sampler. Beckmann's slopes are solved once per node of each
    /// axis rather than once per pair: the same normals at a fraction of the cost.
    fn integrate(
        &self,
        mu: f64,
        rule: &QuadratureRule,
        integrand: impl Fn(DVec3, DVec3) -> f64,
    ) -> f64 {
        let wi = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let frame = self.visible_frame(wi);
        let u: Vec<f64> = rule.nodes.iter().map(|&x| 0.5 * x + 0.5).collect();
        let beckmann_slopes = self.beckmann.then(|| {
            let x: Vec<f64> = u
                .iter()
                .map(|&u0| beckmann_slope_x(frame.cos_theta, u0))
                .collect();
            let y: Vec<f64> = u.iter().map(|&u1| beckmann_slope_y(u1)).collect();
            (x, y)
        });
        let mut sum = 0.0;
        for (i, &wx) in rule.weights.iter().enumerate() {
            for (j, &wy) in rule.weights.iter().enumerate() {
                let slope = match &beckmann_slopes {
                    Some((x, y)) => [x[i], y[j]],
                    None => ggx_slope(frame.cos_theta, [u[i], u[j]]),
                };
                sum += integrand(wi, self.unstretch(&frame, slope)) * wx * wy;
            }
        }
        sum * 0.25
    }
}

/// Nodes and weights of a quadrature on [-1, 1].
struct QuadratureRule {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

/// Mitsuba's two rules for a coat's integrals: 32 Gauss-Legendre nodes per
/// axis, 128 where total internal reflection cuts the integrand.
struct CoatRules {
    coarse: QuadratureRule,
    fine: QuadratureRule,
}

impl CoatRules {
    fn new() -> CoatRules {
        let rule = |n| {
            let (nodes, weights) = gauss_legendre(n);
            QuadratureRule { nodes, weights }
        };
        CoatRules {
            coarse: rule(32),
            fine: rule(128),
        }
    }

    /// The rule for an interface of relative index `eta`.
    fn for_eta(&self, eta: f64) -> &QuadratureRule {
        if eta > 1.0 { &self.coarse } else { &self.fine }
    }
}

/// Where `Microfacet::sample_visible` unstretches its slopes: the stretched
/// incident direction's cosine and azimuth.
struct VisibleFrame {
    cos_theta: f64,
    cos_phi: f64,
    sin_phi: f64,
}

/// A slope of the unit-roughness GGX distribution's visible normals at
/// incidence cosine `cos_theta_i`: a point of the projected visible hemisphere
/// (Heitz 2018), as a slope.
fn ggx_slope(cos_theta_i: f64, u: [f64; 2]) -> [f64; 2] {
    let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
    let [px, py] = square_to_disk_concentric(u);
    let s = 0.5 * (1.0 + cos_theta_i);
    let py = (1.0 - px * px).max(0.0).sqrt() * (1.0 - s) + py * s;
    let z = (1.0 - px * px - py * py).max(0.0).sqrt();
    let norm = 1.0 / (sin_theta_i * py + cos_theta_i * z).max(1e-300);
    [(cos_theta_i * py - sin_theta_i * z) * norm, px * norm]
}

/// The x slope of the unit-roughness Beckmann distribution's visible normals
/// at incidence cosine `cos_theta_i`, from `u0` alone (the y slope,
/// `beckmann_slope_y`, is independent of it). Its CDF is C(s) = (1 + erf(s) +
/// tan_i e^(-s^2) / sqrt(pi)) / total on (-inf, cot_i] (Jakob's form, as
/// `microfacet_sample_visible_11`), with C'(s) = 2 e^(-s^2) (1 - s tan_i) /
/// sqrt(pi) / total: Newton's method from Mitsuba's first guess, kept inside a
/// bracket that bisection narrows, to f64 precision.
fn beckmann_slope_x(cos_theta_i: f64, u0: f64) -> f64 {
    let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
    let tan_theta_i = sin_theta_i / cos_theta_i;
    let cot_theta_i = cos_theta_i / sin_theta_i.max(1e-300);
    let sqrt_pi_inv = 1.0 / PI.sqrt();
    let cdf = |s: f64| 1.0 + libm::erf(s) + sqrt_pi_inv * tan_theta_i * (-s * s).exp();
    let u0 = u0.clamp(1e-12, 1.0 - 1e-12);
    let total = cdf(cot_theta_i);
    let target = u0 * total;
    let maxval = libm::erf(cot_theta_i);
    let mut s = erfinv(maxval - (maxval + 1.0) * libm::erf((-u0.ln()).sqrt()));
    let (mut lo, mut hi) = (-40.0f64, cot_theta_i.min(40.0));
    for _ in 0..100 {
        if !(s >= lo && s <= hi) {
            s = 0.5 * (lo + hi);
        }
        let value = cdf(s) - target;
        if value.abs() <= 1e-14 * total {
            break;
        }
        if value > 0.0 {
            hi = s;
        } else {
            lo = s;
        }
        let derivative = 2.0 * sqrt_pi_inv * (-s * s).exp() * (1.0 - s * tan_theta_i);
        s -= value / derivative;
    }
    s
}

/// The y slope of the unit-roughness Beckmann distribution's visible normals:
/// a normal deviate, whatever the incidence.
fn beckmann_slope_y(u1: f64) -> f64 {
    erfinv(2.0 * u1 - 1.0)
}

/// Reflectance, refracted cosine (opposite in sign to `cos_theta_i`) and the
/// index ratio across the interface in the direction of travel, as
/// `fresnel_dielectric` in `shaders/fresnel.wgsl`.
fn fresnel_dielectric(cos_theta_i: f64, eta: f64) -> (f64, f64, f64) {
    let (eta_it, eta_ti) = if cos_theta_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let cos_i = cos_theta_i.abs();
    let cos_t = cos_theta_t_sqr.max(0.0).sqrt();
    let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
    let r = if cos_theta_t_sqr <= 0.0 || cos_i == 0.0 {
        1.0
    } else {
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r, -cos_t.copysign(cos_theta_i), eta_ti)
}

fn square_to_disk_concentric(u: [f64; 2]) -> [f64; 2] {
    let (x, y) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if x == 0.0 && y == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if x.abs() > y.abs() {
        (x, PI / 4.0 * (y / x))
    } else {
        (y, PI / 2.0 - PI / 4.0 * (x / y))
    };
    [r * phi.cos(), r * phi.sin()]
}

/// The inverse error function on (-1, 1), to f64 precision: Giles's
/// single-precision approximation (`erfinv` in `shaders/sampling.wgsl`) and
/// two Newton steps on `libm::erf`.
fn erfinv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let w = -((1.0 - y) * (1.0 + y)).ln();
    let (w, coefficients) = if w < 5.0 {
        (
            w - 2.5,
            [
                2.81022636e-08,
                3.43273939e-07,
                -3.5233877e-06,
                -4.39150654e-06,
                0.00021858087,
                -0.00125372503,
                -0.00417768164,
                0.246640727,
                1.50140941,
            ],
        )
    } else {
        (
            w.sqrt() - 3.0,
            [
                -0.000200214257,
                0.000100950558,
                0.00134934322,
                -0.00367342844,
                0.00573950773,
                -0.0076224613,
                0.00943887047,
                1.00167406,
                2.83297682,
            ],
        )
    };
    let mut x = coefficients.iter().fold(0.0, |p, c| c + p * w) * y;
    for _ in 0..2 {
        let derivative = 2.0 / PI.sqrt() * (-x * x).exp();
        if derivative == 0.0 {
            break;
        }
        x -= (libm::erf(x) - y) / derivative;
    }
    x
}

/// The nodes and weights of `n`-point Gauss-Legendre quadrature on [-1, 1]
/// (Newton's method on the Legendre polynomial from Tricomi's guesses).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let step = p1 / derivative;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = -x;
        weights[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (nodes, weights) = gauss_legendre(32);
        // Exact up to degree 63: ∫ x^62 over [-1, 1] = 2 / 63.
        let integral: f64 = nodes
            .iter()
            .zip(&weights)
            .map(|(x, w)| w * x.powi(62))
            .sum();
        assert!((integral - 2.0 / 63.0).abs() < 1e-13, "{integral}");
        assert!((weights.iter().sum::<f64>() - 2.0).abs() < 1e-13);
    }

    #[test]
    fn erfinv_inverts_erf() {
        for y in [-0.999999, -0.9, -0.3, 0.0, 1e-8, 0.5, 0.99, 0.9999999] {
            let x = erfinv(y);
            assert!(
                (libm::erf(x) - y).abs() < 1e-14,
                "erf(erfinv({y})) = {}",
                libm::erf(x)
            );
        }
    }

    /// The microfacet density D(m), for checking the sampler against it.
    fn d(microfacet: &Microfacet, m: DVec3) -> f64 {
        let a2 = microfacet.alpha * microfacet.alpha;
        let c2 = m.z * m.z;
        let t2 = (m.x * m.x + m.y * m.y) / (c2 * a2);
        if microfacet.beckmann {
            (-t2).exp() / (PI * a2 * c2 * c2)
        } else {
            1.0 / (PI * a2 * c2 * c2 * (1.0 + t2) * (1.0 + t2))
        }
    }

    /// The sampler draws the visible normals: the quadrature through it of a
    /// smooth function of m equals the integral of that function against
    /// D(m) G1(wi, m) (wi.m) / wi.z over the hemisphere, taken directly.
    #[test]
    fn visible_normal_sampler_draws_the_visible_normals() {
        let f = |m: DVec3| m.x * m.x + 0.5 * m.y + m.z;
        for beckmann in [true, false] {
            let microfacet = Microfacet {
                alpha: 0.4,
                beckmann,
            };
            for mu in [0.1f64, 0.5, 0.95] {
                let wi = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let (nodes, weights) = gauss_legendre(64);
                let mut through_sampler = 0.0;
                for (&x, &wx) in nodes.iter().zip(&weights) {
                    for (&y, &wy) in nodes.iter().zip(&weights) {
                        let m = microfacet.sample_visible(wi, [0.5 * x + 0.5, 0.5 * y + 0.5]);
                        through_sampler += f(m) * wx * wy * 0.25;
                    }
                }
                // Directly, by Gauss-Legendre in (theta, phi).
                let (nodes, weights) = gauss_legendre(400);
                let mut direct = 0.0;
                for (&t, &wt) in nodes.iter().zip(&weights) {
                    let theta = (t + 1.0) * PI / 4.0;
                    for (&p, &wp) in nodes.iter().zip(&weights) {
                        let phi = (p + 1.0) * PI;
                        let m = DVec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        );
                        let visible = wi.dot(m).max(0.0) / wi.z;
                        let density = d(&microfacet, m) * microfacet.g1(wi, m) * visible;
                        direct += f(m) * density * theta.sin() * wt * wp * (PI / 4.0) * PI;
                    }
                }
                assert!(
                    (through_sampler - direct).abs() < 1e-4,
                    "beckmann {beckmann} at cos {mu}: {through_sampler} through the sampler, {direct} directly"
                );
            }
        }
    }

    /// The integral with each axis's slopes solved once equals, bit for bit, the
    /// one that draws every node pair's normal from the sampler.
    #[test]
    fn separable_slopes_give_the_sampler_normals() {
        let rules = CoatRules::new();
        let f = |wi: DVec3, m: DVec3| wi.dot(m) * m.x + m.y * m.y;
        for beckmann in [true, false] {
            let microfacet = Microfacet {
                alpha: 0.3,
                beckmann,
            };
            for mu in [0.05f64, 0.6, 1.0] {
                let rule = rules.for_eta(0.7);
                let wi = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let mut pairwise = 0.0;
                for (&x, &wx) in rule.nodes.iter().zip(&rule.weights) {
                    for (&y, &wy) in rule.nodes.iter().zip(&rule.weights) {
                        let m = microfacet.sample_visible(wi, [0.5 * x + 0.5, 0.5 * y + 0.5]);
                        pairwise += f(wi, m) * wx * wy;
                    }
                }
                assert_eq!(
                    microfacet.integrate(mu, rule, f),
                    pairwise * 0.25,
                    "beckmann {beckmann} at cos {mu}"
                );
            }
        }
    }

    /// A nearly smooth coat transmits 1 - F(mu), and reflects internally the
    /// hemispherical average of the inside Fresnel reflectance.
    #[test]
    fn smooth_limit_is_the_fresnel_transmittance() {
        for distribution in Distribution::ALL {
            let tables = CoatTables::new(distribution, 1e-4, 1.5);
            for (i, &t) in tables.transmittance.iter().enumerate() {
                let mu = (i as f64 / 63.0).max(1e-6);
                let expected = 1.0 - fresnel_dielectric(mu, 1.5).0;
                // Near grazing the lobe still spreads over F's steep edge.
                let tolerance = if mu < 0.05 { 0.02 } else { 1e-4 };
                assert!(
                    (t as f64 - expected).abs() < tolerance,
                    "{distribution:?} at cos {mu}: {t} against {expected}"
                );
            }
            // 2 ∫ F_inside(mu) mu dmu by a fine rule, against the table's 64-point mean.
            let fine: f64 = (0..100_000)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / 100_000.0;
                    fresnel_dielectric(mu, 1.0 / 1.5).0 * mu
                })
                .sum::<f64>()
                / 100_000.0
                * 2.0;
            let coarse: f64 = (0..64)
                .map(|i| {
                    let mu = (i as f64 / 63.0).max(1e-6);
                    fresnel_dielectric(mu, 1.0 / 1.5).0 * mu
                })
                .sum::<f64>()
                / 64.0
                * 2.0;
            assert!(
                (tables.internal_reflectance as f64 - coarse).abs() < 2e-3,
                "{}: {} against {coarse} (exact {fine})",
                distribution.name(),
                tables.internal_reflectance
            );
        }
    }

    /// Roughness only moves energy between transmission, reflection and the
    /// masking's loss: T + R <= 1, nearly 1 for a nearly smooth coat, and
    /// visibly less for a rough one seen at grazing incidence.
    #[test]
    fn transmittance_and_reflectance_conserve_energy() {
        let rules = CoatRules::new();
        for distribution in Distribution::ALL {
            let microfacet = |alpha| Microfacet {
                alpha,
                beckmann: distribution == Distribution::Beckmann,
            };
            for mu in [0.02, 0.3, 0.7, 1.0] {
                for alpha in [0.01, 0.1, 0.5, 1.0] {
                    let m = microfacet(alpha);
                    let sum = m.transmittance(mu, 1.5, &rules) + m.reflectance(mu, 1.5, &rules);
                    assert!(sum <= 1.0 + 1e-9, "{distribution:?} {alpha} {mu}: {sum}");
                    if alpha == 0.01 && mu >= 0.3 {
                        assert!(sum > 1.0 - 1e-4, "{distribution:?} {alpha} {mu}: {sum}");
                    }
                }
            }
            let rough = microfacet(1.0);
            let sum = rough.transmittance(0.02, 1.5, &rules) + rough.reflectance(0.02, 1.5, &rules);
            assert!(sum < 0.9, "{distribution:?}: {sum}");
        }
    }
}
