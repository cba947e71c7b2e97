//! Material kinds. Every material packs into one `gpu::layout::Material`;
//! [`pack_material`] says what each field holds for each kind, and a kind's
//! description which BSDF lobes its WGSL module implements.

use crate::gpu::layout::{Material, material_flag};
use crate::scene::{self, Distribution};
use crate::shader::{ShaderModule, shader_module};

/// What a material kind's BSDF is made of (the interface is in materials.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// A density over directions: the module defines `NAME_eval`, `NAME_pdf` and
    /// `NAME_sample`, and every strategy applies (light sampling, mixtures, MIS).
    Smooth,
    /// A smooth lobe and a delta one (a specular coat over a diffuse base):
    /// `NAME_eval` and `NAME_pdf` cover the smooth part only, and `NAME_sample`
    /// says per sample whether it drew the delta part. Strategies apply to the
    /// smooth part; a delta sample is followed.
    SmoothAndDelta,
    /// Specular, or with no density to evaluate: the module defines only
    /// `NAME_sample`, and a path follows it whatever the strategy.
    Delta,
    /// Scatters nothing: no module, a path ends there after its emission.
    Absorbing,
}

impl Lobe {
    /// Whether it has a density the strategies can mix (`NAME_eval`, `NAME_pdf`).
    pub fn has_density(self) -> bool {
        matches!(self, Lobe::Smooth | Lobe::SmoothAndDelta)
    }
}

pub struct MaterialKind {
    /// Lower case, as in scene files: the module's name and its functions'
    /// prefix; the kernel's flag is `NAME` and its id constant `MATERIAL_NAME`.
    pub name: &'static str,
    pub module: Option<ShaderModule>,
    /// Modules it calls into (`fresnel`, `microfacet`), composed before it once
    /// however many kinds use them.
    pub helpers: &'static [ShaderModule],
    pub lobe: Lobe,
}

impl MaterialKind {
    pub fn flag(&self) -> String {
        self.name.to_uppercase()
    }

    /// The WGSL constant holding its id (its index in [`MATERIAL_KINDS`]).
    pub fn id_constant(&self) -> String {
        format!("MATERIAL_{}", self.flag())
    }
}

pub const FRESNEL: ShaderModule = shader_module!("fresnel");
pub const MICROFACET: ShaderModule = shader_module!("microfacet");

/// Every material kind; a kind's id in the packed material is its index.
pub const MATERIAL_KINDS: &[MaterialKind] = &[
    MaterialKind {
        name: "lambertian",
        module: Some(shader_module!("lambertian")),
        helpers: &[],
        lobe: Lobe::Smooth,
    },
    MaterialKind {
        name: "metal",
        module: Some(shader_module!("metal")),
        helpers: &[],
        // The book's fuzzed mirror has no closed-form density.
        lobe: Lobe::Delta,
    },
    MaterialKind {
        name: "dielectric",
        module: Some(shader_module!("dielectric")),
        helpers: &[],
        lobe: Lobe::Delta,
    },
    MaterialKind {
        name: "light",
        module: None,
        helpers: &[],
        lobe: Lobe::Absorbing,
    },
    MaterialKind {
        name: "conductor",
        module: Some(shader_module!("conductor")),
        helpers: &[FRESNEL],
        lobe: Lobe::Delta,
    },
    MaterialKind {
        name: "roughconductor",
        module: Some(shader_module!("roughconductor")),
        helpers: &[FRESNEL, MICROFACET],
        lobe: Lobe::Smooth,
    },
    MaterialKind {
        name: "roughdielectric",
        module: Some(shader_module!("roughdielectric")),
        helpers: &[FRESNEL, MICROFACET],
        lobe: Lobe::Smooth,
    },
    MaterialKind {
        name: "plastic",
        module: Some(shader_module!("plastic")),
        helpers: &[FRESNEL],
        lobe: Lobe::SmoothAndDelta,
    },
];

/// The index of the kind named `name` in [`MATERIAL_KINDS`].
pub fn material_kind_id(name: &str) -> usize {
    MATERIAL_KINDS
        .iter()
        .position(|k| k.name == name)
        .expect("every scene material kind is described")
}

fn beckmann_flag(distribution: Distribution) -> u32 {
    match distribution {
        Distribution::Beckmann => material_flag("MATERIAL_BECKMANN"),
        Distribution::Ggx => 0,
    }
}

/// The packed material. Per kind (the WGSL modules read the same fields):
/// - lambertian: `albedo`; metal: `albedo`, `param` = fuzz; dielectric:
///   `param` = ior; every kind: `emit`;
/// - conductor: `albedo` = specular_reflectance, `color2` = eta, `color3` = k;
///   roughconductor: the same, `param`/`param2` = alpha_u/alpha_v, `flags`
///   the distribution;
/// - roughdielectric: `albedo` = specular_reflectance, `color2` =
///   specular_transmittance, `color3.x` = eta (int_ior / ext_ior), `param`/`param2`
///   = alpha_u/alpha_v, `flags` the distribution;
/// - plastic: `albedo` = diffuse_reflectance, `color2` = specular_reflectance,
///   `color3` = (eta, the coat's internal diffuse Fresnel reflectance, the
///   probability weight of the specular lobe), `flags` nonlinear.
pub fn pack_material(material: &scene::Material) -> Material {
    use scene::MaterialKind as K;
    let (name, packed) = match material.kind {
        K::Lambertian => ("lambertian", Material::default()),
        K::Metal { fuzz } => (
            "metal",
            Material {
                param: fuzz,
                ..Default::default()
            },
        ),
        K::Dielectric { ior } => (
            "dielectric",
            Material {
                param: ior,
                ..Default::default()
            },
        ),
        K::Light => ("light", Material::default()),
        K::Conductor {
            eta,
            k,
            specular_reflectance,
        } => (
            "conductor",
            Material {
                albedo: specular_reflectance.to_array(),
                color2: eta.to_array(),
                color3: k.to_array(),
                ..Default::default()
            },
        ),
        K::RoughConductor {
            distribution,
            alpha_u,
            alpha_v,
            eta,
            k,
            specular_reflectance,
        } => (
            "roughconductor",
            Material {
                albedo: specular_reflectance.to_array(),
                color2: eta.to_array(),
                color3: k.to_array(),
                param: alpha_u,
                param2: alpha_v,
                flags: beckmann_flag(distribution),
                ..Default::default()
            },
        ),
        K::RoughDielectric {
            distribution,
            alpha_u,
            alpha_v,
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => (
            "roughdielectric",
            Material {
                albedo: specular_reflectance.to_array(),
                color2: specular_transmittance.to_array(),
                color3: [int_ior / ext_ior, 0.0, 0.0],
                param: alpha_u,
                param2: alpha_v,
                flags: beckmann_flag(distribution),
                ..Default::default()
            },
        ),
        K::Plastic {
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        } => {
            let eta = int_ior / ext_ior;
            // Mitsuba steers samples by the mean reflectances of the two lobes.
            let (d_mean, s_mean) = (
                diffuse_reflectance.element_sum() / 3.0,
                specular_reflectance.element_sum() / 3.0,
            );
            (
                "plastic",
                Material {
                    albedo: diffuse_reflectance.to_array(),
                    color2: specular_reflectance.to_array(),
                    color3: [
                        eta,
                        fresnel_diffuse_reflectance(1.0 / eta),
                        s_mean / (d_mean + s_mean),
                    ],
                    flags: if nonlinear {
                        material_flag("MATERIAL_NONLINEAR")
                    } else {
                        0
                    },
                    ..Default::default()
                },
            )
        }
    };
    let albedo = match material.kind {
        K::Lambertian | K::Metal { .. } => material.albedo.to_array(),
        _ => packed.albedo,
    };
    Material {
        albedo,
        kind: material_kind_id(name) as u32,
        emit: material.emit.to_array(),
        ..packed
    }
}

/// The hemispherical average of the dielectric Fresnel reflectance at relative
/// index `eta`: Mitsuba's `fresnel_diffuse_reflectance` (the fits of Egan and
/// Hilgeman 1973 below 1, d'Eon and Irving 2011 above), computed once per
/// material on the host as Mitsuba does.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * (eta * eta) + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let inv = 1.0 / eta;
        let (inv2, inv3, inv4, inv5) = (inv * inv, inv * inv * inv, inv.powi(4), inv.powi(5));
        0.919317 - 3.4793 * inv + 6.75335 * inv2 - 7.80989 * inv3 + 4.98554 * inv4 - 1.36881 * inv5
    }
}
