//! Material kinds. Every material packs into one `abi::PackedMaterial`;
//! [`pack_material`] says what each field holds for each kind, and a kind's
//! description which BSDF lobes its WGSL module implements.

use super::Texture;
use super::coat::CoatTables;
use crate::abi::{PackedMaterial, material_flag};
use crate::shader::{ShaderModule, shader_module};
use glam::Vec3;
use serde::Serialize;
use std::sync::Mutex;

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

pub struct MaterialModel {
    /// Lower case, as in scene files: the module's name and its functions'
    /// prefix; the kernel's flag is `NAME` and its id constant `MATERIAL_NAME`.
    pub name: &'static str,
    pub module: Option<ShaderModule>,
    /// Modules it calls into (`fresnel`, `microfacet`), composed before it once
    /// however many kinds use them.
    pub helpers: &'static [ShaderModule],
    pub lobe: Lobe,
    /// Its module reads per-material tables from the scene's `material_tables`
    /// array (`MaterialTables`), which kernels declare only for such kinds.
    pub tables: bool,
}

impl MaterialModel {
    pub fn flag(&self) -> String {
        self.name.to_uppercase()
    }

    /// The WGSL constant holding its id (its index in [`MATERIAL_KINDS`]).
    pub fn id_constant(&self) -> String {
        format!("MATERIAL_{}", self.flag())
    }
}

/// The material kinds. The book's (`Lambertian`, `Metal`, `Dielectric`, `Light`)
/// keep the book's parameters; the others are Mitsuba 3's plugins of the same
/// names, with Mitsuba's parameter names, meanings and defaults (so a Mitsuba
/// scene maps onto them field for field).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum MaterialKind {
    Lambertian,
    Metal {
        fuzz: f32,
    },
    /// The book's glass: `ior` is the relative index (interior over exterior).
    Dielectric {
        ior: f32,
    },
    /// Emits `emit` on the side its normal faces; scatters nothing.
    Light,
    /// A perfectly smooth conductor: a mirror with the Fresnel reflectance of the
    /// complex index `eta + i k` (per RGB channel), times `specular_reflectance`.
    Conductor {
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Vec3,
    },
    /// A conductor with a microfacet surface (Cook-Torrance with Smith shadowing).
    RoughConductor {
        distribution: Distribution,
        /// Roughness along the shading frame's two tangents (equal: isotropic).
        alpha_u: f32,
        alpha_v: f32,
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Vec3,
    },
    /// A rough interface between two dielectrics (Walter et al. 2007).
    RoughDielectric {
        distribution: Distribution,
        alpha_u: f32,
        alpha_v: f32,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Vec3,
        specular_transmittance: Vec3,
    },
    /// A thin slab of dielectric (two parallel interfaces): reflects with the
    /// slab's reflectance summed over its internal bounces and lets the rest
    /// through without bending it (Mitsuba's `thindielectric`).
    ThinDielectric {
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Vec3,
        specular_transmittance: Vec3,
    },
    /// A diffuse base under a smooth dielectric coat: a specular (delta) lobe and
    /// a diffuse one.
    Plastic {
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        /// Mitsuba's `nonlinear`: account for the colour shift of light scattered
        /// inside the coat several times.
        nonlinear: bool,
    },
    /// A diffuse base under a rough dielectric coat (isotropic microfacets): a
    /// glossy lobe and a diffuse one, both with densities.
    RoughPlastic {
        distribution: Distribution,
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        nonlinear: bool,
    },
}

/// A microfacet normal distribution (Mitsuba's `distribution`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Distribution {
    Beckmann,
    /// Trowbridge-Reitz.
    Ggx,
}

impl Distribution {
    pub const ALL: [Distribution; 2] = [Distribution::Beckmann, Distribution::Ggx];

    pub fn name(self) -> &'static str {
        match self {
            Distribution::Beckmann => "beckmann",
            Distribution::Ggx => "ggx",
        }
    }

    pub fn from_name(name: &str) -> Option<Distribution> {
        Distribution::ALL.into_iter().find(|d| d.name() == name)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    /// The book's materials' reflectance (`lambertian`, `metal`); zero for the
    /// others, whose colours are parameters of their kind.
    pub albedo: Vec3,
    /// Emitted radiance (one-sided, along the surface normal); zero for most materials.
    pub emit: Vec3,
    /// Scatters only on the side the normal faces, black from behind (Mitsuba's
    /// BSDFs outside `twosided`); the book's materials scatter on both sides.
    pub one_sided: bool,
    /// A texture on the kind's colour that `kinds::pack_material` packs as
    /// `albedo` (lambertian and metal `albedo`, conductors' and rough
    /// dielectrics' `specular_reflectance`, plastics' `diffuse_reflectance`),
    /// which then holds the texture's mean.
    pub texture: Option<Texture>,
}

impl Material {
    pub fn emits(&self) -> bool {
        self.emit.max_element() > 0.0
    }
}

pub const FRESNEL: ShaderModule = shader_module!("fresnel");
pub const MICROFACET: ShaderModule = shader_module!("microfacet");

/// Every material kind; a kind's id in the packed material is its index.
pub const MATERIAL_KINDS: &[MaterialModel] = &[
    MaterialModel {
        name: "lambertian",
        module: Some(shader_module!("lambertian")),
        helpers: &[],
        lobe: Lobe::Smooth,
        tables: false,
    },
    MaterialModel {
        name: "metal",
        module: Some(shader_module!("metal")),
        helpers: &[],
        // The book's fuzzed mirror has no closed-form density.
        lobe: Lobe::Delta,
        tables: false,
    },
    MaterialModel {
        name: "dielectric",
        module: Some(shader_module!("dielectric")),
        helpers: &[],
        lobe: Lobe::Delta,
        tables: false,
    },
    MaterialModel {
        name: "light",
        module: None,
        helpers: &[],
        lobe: Lobe::Absorbing,
        tables: false,
    },
    MaterialModel {
        name: "conductor",
        module: Some(shader_module!("conductor")),
        helpers: &[FRESNEL],
        lobe: Lobe::Delta,
        tables: false,
    },
    MaterialModel {
        name: "roughconductor",
        module: Some(shader_module!("roughconductor")),
        helpers: &[FRESNEL, MICROFACET],
        lobe: Lobe::Smooth,
        tables: false,
    },
    MaterialModel {
        name: "roughdielectric",
        module: Some(shader_module!("roughdielectric")),
        helpers: &[FRESNEL, MICROFACET],
        lobe: Lobe::Smooth,
        tables: false,
    },
    MaterialModel {
        name: "plastic",
        module: Some(shader_module!("plastic")),
        helpers: &[FRESNEL],
        lobe: Lobe::SmoothAndDelta,
        tables: false,
    },
    MaterialModel {
        name: "roughplastic",
        module: Some(shader_module!("roughplastic")),
        helpers: &[FRESNEL, MICROFACET],
        lobe: Lobe::Smooth,
        tables: true,
    },
    MaterialModel {
        name: "thindielectric",
        module: Some(shader_module!("thindielectric")),
        helpers: &[FRESNEL],
        lobe: Lobe::Delta,
        tables: false,
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

/// A coat's distribution, alpha and eta (as bits).
type CoatKey = (Distribution, u32, u32);

/// The tables of a scene's materials (`MaterialModel::tables`), one array of
/// floats the kernel reads at the offset a packed material holds. Materials with
/// the same coat share one table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTables {
    pub values: Vec<f32>,
    /// The coats tabulated so far (distribution, alpha and eta, as bits), and
    /// their tables' offsets and internal reflectances.
    coats: Vec<(CoatKey, u32, f32)>,
}

impl MaterialTables {
    /// The offset of the coat's transmittance table, and its internal reflectance.
    fn coat(&mut self, distribution: Distribution, alpha: f32, eta: f32) -> (u32, f32) {
        let key = (distribution, alpha.to_bits(), eta.to_bits());
        if let Some(&(_, offset, internal)) = self.coats.iter().find(|(k, ..)| *k == key) {
            return (offset, internal);
        }
        let tables = coat_tables(key);
        let offset = self.values.len() as u32;
        self.values.extend_from_slice(&tables.transmittance);
        self.coats.push((key, offset, tables.internal_reflectance));
        (offset, tables.internal_reflectance)
    }
}

/// [`CoatTables::new`] for a coat, computed once per
/// process: a run may pack its scene once per kernel (the `auto` strategy's pilot
/// candidates, `converge`'s variants), and each coat costs a million samples.
fn coat_tables(key: CoatKey) -> CoatTables {
    static COMPUTED: Mutex<Vec<(CoatKey, CoatTables)>> = Mutex::new(Vec::new());
    let mut computed = COMPUTED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((_, tables)) = computed.iter().find(|(k, _)| *k == key) {
        return tables.clone();
    }
    let (distribution, alpha, eta) = key;
    let tables = CoatTables::new(distribution, f32::from_bits(alpha), f32::from_bits(eta));
    computed.push((key, tables.clone()));
    tables
}

/// Mitsuba steers samples between a coat and its base by the lobes' mean
/// reflectances: the probability weight of the coat.
fn specular_sampling_weight(diffuse: glam::Vec3, specular: glam::Vec3) -> f32 {
    let (d_mean, s_mean) = (diffuse.element_sum() / 3.0, specular.element_sum() / 3.0);
    s_mean / (d_mean + s_mean)
}

fn nonlinear_flag(nonlinear: bool) -> u32 {
    if nonlinear {
        material_flag("MATERIAL_NONLINEAR")
    } else {
        0
    }
}

/// The smallest roughness the kernel evaluates (Mitsuba 3 and pbrt-v4 clamp
/// alike): below it a microfacet lobe is narrower than 32-bit floats can
/// evaluate (its density and slopes overflow into NaN), and it already
/// behaves as a mirror. Scenes keep the alpha they give.
pub const MIN_ALPHA: f32 = 1e-4;

/// The largest conductor index (`eta`, `k`) the kernel evaluates: the Fresnel
/// formula takes fourth powers, which overflow f32 past about 1e9, and at 1e6
/// the reflectance is already 1 within 4e-6.
pub const MAX_CONDUCTOR_INDEX: f32 = 1e6;

/// A conductor's `eta` or `k` as the kernel evaluates it (`MAX_CONDUCTOR_INDEX`).
fn conductor_index(index: Vec3) -> [f32; 3] {
    index.min(Vec3::splat(MAX_CONDUCTOR_INDEX)).to_array()
}

/// The packed material. Per kind (the WGSL modules read the same fields):
/// - lambertian: `albedo`; metal: `albedo`, `param` = fuzz; dielectric:
///   `param` = ior; every kind: `emit`;
/// - conductor: `albedo` = specular_reflectance, `color2` = eta, `color3` = k;
///   roughconductor: the same, `param`/`param2` = alpha_u/alpha_v, `flags`
///   the distribution (eta and k at most `MAX_CONDUCTOR_INDEX`, every alpha at
///   least `MIN_ALPHA`);
/// - roughdielectric: `albedo` = specular_reflectance, `color2` =
///   specular_transmittance, `color3.x` = eta (int_ior / ext_ior), `param`/`param2`
///   = alpha_u/alpha_v, `flags` the distribution;
/// - plastic: `albedo` = diffuse_reflectance, `color2` = specular_reflectance,
///   `color3` = (eta, the coat's internal diffuse Fresnel reflectance, the
///   probability weight of the specular lobe), `flags` nonlinear;
/// - every kind: `flags` one-sided;
/// - roughplastic: as plastic, with `color3.y` the coat's internal reflectance
///   (`coat::CoatTables`), `param` = alpha, `param2` = the offset of its
///   transmittance table in `tables` (an integer, exact in f32), `flags` the
///   distribution and nonlinear.
pub fn pack_material(material: &Material, tables: &mut MaterialTables) -> PackedMaterial {
    use MaterialKind as K;
    let (name, packed) = match material.kind {
        K::Lambertian => ("lambertian", PackedMaterial::default()),
        K::Metal { fuzz } => (
            "metal",
            PackedMaterial {
                param: fuzz,
                ..Default::default()
            },
        ),
        K::Dielectric { ior } => (
            "dielectric",
            PackedMaterial {
                param: ior,
                ..Default::default()
            },
        ),
        K::Light => ("light", PackedMaterial::default()),
        K::Conductor {
            eta,
            k,
            specular_reflectance,
        } => (
            "conductor",
            PackedMaterial {
                albedo: specular_reflectance.to_array(),
                color2: conductor_index(eta),
                color3: conductor_index(k),
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
            PackedMaterial {
                albedo: specular_reflectance.to_array(),
                color2: conductor_index(eta),
                color3: conductor_index(k),
                param: alpha_u.max(MIN_ALPHA),
                param2: alpha_v.max(MIN_ALPHA),
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
            PackedMaterial {
                albedo: specular_reflectance.to_array(),
                color2: specular_transmittance.to_array(),
                color3: [int_ior / ext_ior, 0.0, 0.0],
                param: alpha_u.max(MIN_ALPHA),
                param2: alpha_v.max(MIN_ALPHA),
                flags: beckmann_flag(distribution),
                ..Default::default()
            },
        ),
        K::ThinDielectric {
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        } => (
            "thindielectric",
            PackedMaterial {
                albedo: specular_reflectance.to_array(),
                color2: specular_transmittance.to_array(),
                param: int_ior / ext_ior,
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
            (
                "plastic",
                PackedMaterial {
                    albedo: diffuse_reflectance.to_array(),
                    color2: specular_reflectance.to_array(),
                    color3: [
                        eta,
                        fresnel_diffuse_reflectance(1.0 / eta),
                        specular_sampling_weight(diffuse_reflectance, specular_reflectance),
                    ],
                    flags: nonlinear_flag(nonlinear),
                    ..Default::default()
                },
            )
        }
        K::RoughPlastic {
            distribution,
            alpha,
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        } => {
            let eta = int_ior / ext_ior;
            let alpha = alpha.max(MIN_ALPHA);
            let (offset, internal_reflectance) = tables.coat(distribution, alpha, eta);
            (
                "roughplastic",
                PackedMaterial {
                    albedo: diffuse_reflectance.to_array(),
                    color2: specular_reflectance.to_array(),
                    color3: [
                        eta,
                        internal_reflectance,
                        specular_sampling_weight(diffuse_reflectance, specular_reflectance),
                    ],
                    param: alpha,
                    param2: offset as f32,
                    flags: beckmann_flag(distribution) | nonlinear_flag(nonlinear),
                    ..Default::default()
                },
            )
        }
    };
    let albedo = match material.kind {
        K::Lambertian | K::Metal { .. } => material.albedo.to_array(),
        _ => packed.albedo,
    };
    let one_sided = if material.one_sided {
        material_flag("MATERIAL_ONE_SIDED")
    } else {
        0
    };
    PackedMaterial {
        albedo,
        kind: material_kind_id(name) as u32,
        emit: material.emit.to_array(),
        flags: packed.flags | one_sided,
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
