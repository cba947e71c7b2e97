//! Material kinds, one file each (`lambertian.rs`, `roughconductor.rs`, ...):
//! its manual (the file's doc comment: keys, defaults, ranges, Mitsuba's
//! equivalent), its description ([`MaterialModel`]: WGSL module, lobes, keys),
//! how it reads its `[materials.NAME]` table and what it packs into
//! `abi::PackedMaterial`, and its test. One entry of `material_kinds!` below
//! registers a kind: its `MaterialKind` variant (its parameters), its place in
//! [`MATERIAL_KINDS`] (its id in the kernel), and so the scene files' type
//! names and keys. What several kinds share is in `common.rs`.

mod blend;
mod bump;
mod common;
mod conductor;
mod dielectric;
mod lambertian;
mod light;
mod metal;
mod plastic;
mod principled;
mod principledthin;
mod roughconductor;
mod roughdielectric;
mod roughplastic;
mod smoothdielectric;
mod thindielectric;
mod twosided;

pub use bump::Bump;
pub use common::Distribution;
#[cfg(test)]
pub(crate) use common::NAMED_CONDUCTORS;
pub(crate) use common::NAMED_IORS;

use super::Texture;
use super::coat::CoatTables;
use super::params::{ParamTable, Result, check_unit, list, unknown_name};
use crate::abi::{PackedMaterial, material_flag};
use crate::shader::ShaderModule;
use common::TextureSlot;
use glam::Vec3;
use serde::Serialize;
use std::sync::Mutex;
use toml::Value;

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
    /// The keys of its table, `type` first, in the order an unknown key's
    /// message lists them.
    pub keys: &'static [&'static str],
    /// What an unknown key's message adds about the keys (`isotropic: ...`).
    pub keys_note: Option<&'static str>,
    /// Its numbers (of `keys`) that may be textures, as in Mitsuba, where a
    /// texture is read at the hit as one number ([`Texture::eval_number`]).
    /// A number's slot is its index here: `Material::number_textures` names
    /// it so, and the module reads it through `material_number` with the
    /// generated constant `NUMBER_KIND_KEY` ([`MaterialModel::number_constant`]).
    pub textured_numbers: &'static [&'static str],
    /// The Mitsuba 3 plugin it is, parameter for parameter (the book's kinds and
    /// pathmix's own: none).
    pub mitsuba: Option<MitsubaPlugin>,
    /// The keys (of `keys`, required) that name the materials it is made of
    /// (`twosided`'s `front` and `back`): [`Material::nested`], in this order,
    /// which the kernel resolves at the hit (`resolve_material`,
    /// materials.wgsl) before anything else is done there.
    pub nested: &'static [&'static str],
    /// Its packed `albedo`, textured, is its diffuse reflectance: the
    /// `albedo` AOV (`kinds::aov`), as Mitsuba's `eval_diffuse_reflectance`
    /// of `diffuse`, the plastics and the principled BSDFs. Other kinds give
    /// Mitsuba's default there: the BSDF's value toward the normal times π.
    pub diffuse_reflectance_is_albedo: bool,
    /// Reads its parameters from its table, whose keys are checked; the
    /// generic part (`one_sided`, the texture) is [`Material::parse`]'s.
    pub(crate) parse: fn(&ParamTable, &mut TextureSlot) -> Result<Parsed>,
    /// Its packed material, but for what every kind packs alike
    /// ([`pack_material`]): each kind's file says which fields it fills.
    pub(crate) pack: fn(&Material, &mut MaterialTables) -> PackedMaterial,
}

/// A Mitsuba BSDF plugin that is a material kind: a Mitsuba file's `<bsdf
/// type="NAME">` reads as the kind, each of the kind's keys from the parameter of
/// the same name, as Mitsuba reads it (`scene::mitsuba`).
#[derive(Clone, Copy, Debug)]
pub struct MitsubaPlugin {
    pub name: &'static str,
    /// The parameter that may be a texture.
    pub texture: Option<&'static str>,
    /// The parameters that are numbers (`<float>`), each read as one.
    pub numbers: &'static [&'static str],
}

impl MaterialModel {
    pub fn flag(&self) -> String {
        self.name.to_uppercase()
    }

    /// The WGSL constant holding its id (its index in [`MATERIAL_KINDS`]).
    pub fn id_constant(&self) -> String {
        format!("MATERIAL_{}", self.flag())
    }

    /// The WGSL constant holding the slot of its textured number `key`.
    pub fn number_constant(&self, key: &str) -> String {
        format!("NUMBER_{}_{}", self.flag(), key.to_uppercase())
    }

    /// The table it reads, as messages name it: `a roughplastic material`.
    fn what(&self) -> String {
        match self.keys_note {
            Some(note) => format!("a {} material ({note})", self.name),
            None => format!("a {} material", self.name),
        }
    }
}

/// Registers the material kinds, each as `Variant { parameters } = module::MODEL`:
/// `MaterialKind` has the variant, and [`MATERIAL_KINDS`] the description, in
/// this order (the variants' order shapes the checkpoint identity's encoding,
/// and the kinds' order their ids in the kernel).
macro_rules! material_kinds {
    ($(
        $(#[$doc:meta])*
        $variant:ident $({ $($(#[$field_doc:meta])* $field:ident: $type:ty),* $(,)? })? = $model:path,
    )*) => {
        /// A material's kind and its parameters. The book's (`Lambertian`,
        /// `Metal`, `Dielectric`, `Light`) keep the book's parameters; the others
        /// are Mitsuba 3's plugins of the same names, with Mitsuba's parameter
        /// names, meanings and defaults (so a Mitsuba scene maps onto them field
        /// for field). Each kind's file is its manual.
        #[derive(Clone, Copy, Debug, PartialEq, Serialize)]
        pub enum MaterialKind {
            $($(#[$doc])* $variant $({ $($(#[$field_doc])* $field: $type,)* })?,)*
        }

        /// Every material kind; a kind's id in the packed material is its index.
        pub const MATERIAL_KINDS: &[MaterialModel] = &[$($model,)*];

        impl MaterialKind {
            /// Its index in [`MATERIAL_KINDS`].
            pub fn id(&self) -> usize {
                enum Id {
                    $($variant,)*
                }
                match self {
                    $(MaterialKind::$variant { .. } => Id::$variant as usize,)*
                }
            }
        }
    };
}

material_kinds! {
    Lambertian = lambertian::LAMBERTIAN,
    Metal { fuzz: f32 } = metal::METAL,
    /// The book's glass: `ior` is the relative index (interior over exterior).
    Dielectric { ior: f32 } = dielectric::DIELECTRIC,
    /// Emits `emit` on the side its normal faces; scatters nothing.
    Light = light::LIGHT,
    /// A perfectly smooth conductor of complex index `eta + i k` (per RGB channel).
    Conductor { eta: Vec3, k: Vec3, specular_reflectance: Vec3 } = conductor::CONDUCTOR,
    /// A conductor with a microfacet surface.
    RoughConductor {
        distribution: Distribution,
        /// Roughness along the shading frame's two tangents (equal: isotropic).
        alpha_u: f32,
        alpha_v: f32,
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Vec3,
    } = roughconductor::ROUGHCONDUCTOR,
    /// A rough interface between two dielectrics.
    RoughDielectric {
        distribution: Distribution,
        alpha_u: f32,
        alpha_v: f32,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Vec3,
        specular_transmittance: Vec3,
    } = roughdielectric::ROUGHDIELECTRIC,
    /// A thin slab of dielectric (two parallel interfaces).
    ThinDielectric {
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Vec3,
        specular_transmittance: Vec3,
    } = thindielectric::THINDIELECTRIC,
    /// A diffuse base under a smooth dielectric coat.
    Plastic {
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        /// Mitsuba's `nonlinear`: account for the colour shift of light scattered
        /// inside the coat several times.
        nonlinear: bool,
    } = plastic::PLASTIC,
    /// A diffuse base under a rough dielectric coat (isotropic microfacets).
    RoughPlastic {
        distribution: Distribution,
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        nonlinear: bool,
    } = roughplastic::ROUGHPLASTIC,
    /// A smooth interface between two dielectrics, by the exact Fresnel
    /// reflectance (Mitsuba's `dielectric`).
    SmoothDielectric {
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Vec3,
        specular_transmittance: Vec3,
    } = smoothdielectric::SMOOTHDIELECTRIC,
    /// Mitsuba's `twosided` with two BSDFs: the material `front` on the side
    /// the normal faces, `back` (seeing the flipped frame) on the other
    /// ([`Material::nested`]).
    TwoSided = twosided::TWOSIDED,
    /// Mitsuba's `blendbsdf`: `(1 - weight) first + weight second`, resolved
    /// at the hit by picking one ([`Material::nested`]; `weight` the constant,
    /// or the mean of its texture's luminance).
    Blend { weight: f32 } = blend::BLEND,
    /// Mitsuba's Disney-style BSDF (Blender's Principled BSDF): a mixture of
    /// diffuse, sheen, specular reflection and transmission, and clearcoat
    /// lobes weighted by these numbers (`principled.rs` says each).
    Principled {
        base_color: Vec3,
        roughness: f32,
        anisotropic: f32,
        metallic: f32,
        spec_trans: f32,
        /// The interior's relative index (from `eta`, or from `specular`).
        eta: f32,
        spec_tint: f32,
        sheen: f32,
        sheen_tint: f32,
        clearcoat: f32,
        clearcoat_gloss: f32,
        flatness: f32,
    } = principled::PRINCIPLED,
    /// Mitsuba's principled BSDF of a thin sheet, the same from both sides
    /// (`principledthin.rs` says each number).
    PrincipledThin {
        base_color: Vec3,
        roughness: f32,
        anisotropic: f32,
        spec_trans: f32,
        /// The sheet's index.
        eta: f32,
        spec_tint: f32,
        sheen: f32,
        sheen_tint: f32,
        flatness: f32,
        diff_trans: f32,
    } = principledthin::PRINCIPLEDTHIN,
}

/// The scene files' material types, in [`MATERIAL_KINDS`] order.
pub(crate) fn material_types() -> Vec<&'static str> {
    MATERIAL_KINDS.iter().map(|kind| kind.name).collect()
}

/// Every key of some material kind, in kind order: what a table without a
/// `type` may hold (its typos are suggested from these).
pub(crate) fn material_keys() -> Vec<&'static str> {
    let mut keys = Vec::new();
    for &key in MATERIAL_KINDS
        .iter()
        .flat_map(|kind| kind.keys)
        .chain(bump::BUMP_KEYS)
    {
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys
}

/// What a kind reads from its table.
pub(crate) struct Parsed {
    pub kind: MaterialKind,
    /// The book's colours (`Material::albedo`, `Material::emit`); zero for
    /// kinds without them.
    pub albedo: Vec3,
    pub emit: Vec3,
}

impl From<MaterialKind> for Parsed {
    fn from(kind: MaterialKind) -> Parsed {
        Parsed {
            kind,
            albedo: Vec3::ZERO,
            emit: Vec3::ZERO,
        }
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
    /// The probability that the surface is there (Mitsuba's `mask`): a ray finds
    /// it with this probability and passes through it unchanged otherwise (a
    /// null event), and a shadow ray is let through by `1 - opacity`. 1: opaque.
    /// 1 where `opacity_texture` gives it instead.
    pub opacity: f32,
    /// A texture whose value as a number at the hit (`Texture::eval_number`),
    /// clamped to [0, 1], is the opacity (Mitsuba's `mask` with a textured
    /// `opacity`, as its `eval_1` reads it).
    /// Left out of the serialized material when absent, so the checkpoint
    /// identities of scenes without one are as before.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub opacity_texture: Option<Texture>,
    /// A texture on the kind's colour that `kinds::pack_material` packs as
    /// `albedo` (lambertian and metal `albedo`, conductors' and rough
    /// dielectrics' `specular_reflectance`, plastics' `diffuse_reflectance`),
    /// which then holds the texture's mean; `blend`'s `weight`.
    pub texture: Option<Texture>,
    /// The kind's numbers that are textures (`MaterialModel::textured_numbers`),
    /// whose packed values then hold the textures' means. Left out of the
    /// serialized material when empty, so the checkpoint identities of scenes
    /// without one are as before.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub number_textures: Vec<NumberTexture>,
    /// A bump or normal map (Mitsuba's `bumpmap`, `normalmap`). Left out of
    /// the serialized material when absent, so the checkpoint identities of
    /// scenes without one are as before.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bump: Option<Bump>,
    /// The materials a `twosided` or `blend` material is made of, by name (the values
    /// of its kind's `MaterialModel::nested` keys, in that order); empty for
    /// the others, and then left out of the serialized material.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nested: Vec<String>,
}

/// A material's number given by a texture.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NumberTexture {
    /// Its slot: its key's index in the kind's `MaterialModel::textured_numbers`.
    pub slot: u32,
    pub texture: Texture,
}

/// The most textured numbers a kind has: the kernel keeps which of them a
/// hit's material has textured as the bits of one `u32`.
pub const MATERIAL_NUMBER_SLOTS: usize = 32;

impl Material {
    pub fn emits(&self) -> bool {
        self.emit.max_element() > 0.0
    }

    /// Whether rays may pass through it: an opacity below 1, or a texture's.
    pub fn is_masked(&self) -> bool {
        self.opacity < 1.0 || self.opacity_texture.is_some()
    }

    /// The material `name` of table `t` (`[materials.NAME]`): `type` names its
    /// kind, which reads the rest; `one_sided` (default false) where the kind
    /// takes it, and `opacity` (default 1) on every kind.
    pub(crate) fn parse(name: &str, t: &ParamTable) -> Result<Material> {
        let Some(ty) = t.string("type")? else {
            t.check_keys(&material_keys(), None)?;
            return Err(t.err(
                t.here(),
                format!(
                    "missing required key `type` (expected one of {})",
                    list(&material_types())
                ),
            ));
        };
        let Some(model) = MATERIAL_KINDS.iter().find(|kind| kind.name == ty) else {
            return Err(t.err(
                t.at("type"),
                unknown_name("material type", ty, &material_types()),
            ));
        };
        // Any material that scatters may have its shading normal perturbed.
        let scatters = model.lobe != Lobe::Absorbing;
        let mut keys: Vec<&str> = model.keys.iter().chain([&OPACITY]).copied().collect();
        if scatters {
            keys.extend(bump::BUMP_KEYS);
        }
        t.check_keys(&keys, Some(&model.what()))?;
        let mut slot = TextureSlot::new(model.textured_numbers);
        let Parsed { kind, albedo, emit } = (model.parse)(t, &mut slot)?;
        let bump = match scatters {
            true => bump::parse_bump(t)?,
            false => None,
        };
        // `opacity`: a number, or a texture whose value as a number it is.
        let opacity_texture = match t.table.get(OPACITY).is_some_and(Value::is_table) {
            true => Some(Texture::parse(&t.sub(OPACITY)?.expect("a table"))?),
            false => None,
        };
        let opacity = match opacity_texture {
            Some(_) => 1.0,
            None => t.float(OPACITY, check_unit)?.unwrap_or(1.0),
        };
        let nested = model
            .nested
            .iter()
            .map(|&key| Ok(t.require(key, t.string(key)?)?.to_string()))
            .collect::<Result<Vec<String>>>()?;
        Ok(Material {
            name: name.to_string(),
            kind,
            albedo,
            emit,
            one_sided: t.boolean("one_sided")?.unwrap_or(false),
            opacity,
            opacity_texture,
            texture: slot.texture,
            number_textures: slot.numbers,
            bump,
            nested,
        })
    }
}

/// The key every kind takes besides its own: the surface's presence probability.
const OPACITY: &str = "opacity";

/// Where the transparency `1 - opacity` starts in `PackedMaterial::kind`, as a
/// 16-bit fixed-point number (of [`MATERIAL_TRANSPARENCY_MAX`]); below it is the
/// kind's id. `PackedMaterial` has no free field, and 0 there (every unmasked
/// material) reads as opaque, so no other material's packing changes. The
/// value is off by at most 2^-17. A material whose opacity is a texture
/// (`Material::opacity_texture`) has the flag `MATERIAL_OPACITY_TEXTURE`, and
/// holds that texture's index + 1 here instead (`SceneData::pack`), which
/// [`MAX_TEXTURES`](crate::kinds::MAX_TEXTURES) keeps within these 16 bits.
pub const MATERIAL_TRANSPARENCY_SHIFT: u32 = 16;

/// The transparency 1 in [`MATERIAL_TRANSPARENCY_SHIFT`]'s fixed point.
pub const MATERIAL_TRANSPARENCY_MAX: u32 = 0xffff;

/// `1 - opacity` in fixed point (see [`MATERIAL_TRANSPARENCY_SHIFT`]).
fn transparency_bits(opacity: f32) -> u32 {
    ((1.0 - opacity) * MATERIAL_TRANSPARENCY_MAX as f32).round() as u32
}

/// The most surfaces one ray finds between two bounces: a shadow ray passes
/// through masked ones by their transparency, and one still in its way at the
/// last of these counts as opaque; a path that draws to pass that one too ends
/// there. So every strategy misses the same light, that behind more masks than
/// this (a bias toward dark, only there). Bounds the kernel's loops for
/// lavapipe's loop limit (`render::max_samples_per_dispatch` budgets these
/// closest hits and path-loop iterations).
pub const MASK_RAY_HITS: u32 = 8;

/// A packed material's kind id (its index in [`MATERIAL_KINDS`]).
pub fn packed_kind_id(m: &PackedMaterial) -> usize {
    (m.kind & MATERIAL_TRANSPARENCY_MAX) as usize
}

/// Whether a packed material is masked (some transparency, or an opacity texture).
pub fn packed_is_masked(m: &PackedMaterial) -> bool {
    m.kind >> MATERIAL_TRANSPARENCY_SHIFT != 0
}

/// The most materials one hit passes through to the material it scatters by
/// (`twosided` inside `twosided`, ...): the kernel's resolving loop
/// (`resolve_material`, materials.wgsl) takes at most this many steps, and a
/// scene whose materials nest deeper is refused.
pub const MATERIAL_NESTING: u32 = 4;

/// The materials a packed material is made of (`Material::nested`, which
/// `SceneData::pack` stores as floats in `color2`), by index; none for the
/// kinds without.
pub fn packed_nested(m: &PackedMaterial) -> Vec<u32> {
    let count = MATERIAL_KINDS[packed_kind_id(m)].nested.len();
    m.color2[..count].iter().map(|&i| i as u32).collect()
}

/// A coat's distribution, alpha and eta (as bits).
type CoatKey = (Distribution, u32, u32);

/// The tables of a scene's materials (`MaterialModel::tables`), one array of
/// floats the kernel reads at the offset a packed material holds: coats'
/// transmittances (materials with the same coat share one table) and the
/// parameters that do not fit a packed material (`principled`'s).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTables {
    pub values: Vec<f32>,
    /// The coats tabulated so far (distribution, alpha and eta, as bits), and
    /// their tables' offsets and internal reflectances.
    coats: Vec<(CoatKey, u32, f32)>,
}

impl MaterialTables {
    /// Tables that begin with one entry per material (of `materials`), the
    /// offset of the list of its textured numbers (0: none), which
    /// [`MaterialTables::add_number_textures`] fills; the kernel reads it by
    /// the hit's material index where the material has the flag
    /// `MATERIAL_TEXTURED_NUMBERS` (`texture_numbers`, textures.wgsl). Scenes
    /// without textured numbers pack their tables as before, without it.
    pub fn with_number_directory(materials: usize) -> MaterialTables {
        MaterialTables {
            values: vec![0.0; materials],
            ..MaterialTables::default()
        }
    }

    /// Material `material`'s textured numbers as its list: the count, then
    /// each (slot, texture index), all exact as floats; its directory entry
    /// the list's offset.
    pub fn add_number_textures(&mut self, material: usize, pairs: &[(u32, u32)]) {
        let mut list = vec![pairs.len() as f32];
        list.extend(
            pairs
                .iter()
                .flat_map(|&(slot, texture)| [slot as f32, texture as f32]),
        );
        self.values[material] = self.push(&list) as f32;
    }

    /// Appends `values`; their offset.
    fn push(&mut self, values: &[f32]) -> u32 {
        let offset = self.values.len() as u32;
        self.values.extend_from_slice(values);
        offset
    }

    /// The offset of the coat's transmittance table, and its internal reflectance.
    fn coat(&mut self, distribution: Distribution, alpha: f32, eta: f32) -> (u32, f32) {
        let key = (distribution, alpha.to_bits(), eta.to_bits());
        if let Some(&(_, offset, internal)) = self.coats.iter().find(|(k, ..)| *k == key) {
            return (offset, internal);
        }
        let tables = coat_tables(key);
        let offset = self.push(&tables.transmittance);
        self.coats.push((key, offset, tables.internal_reflectance));
        (offset, tables.internal_reflectance)
    }
}

/// [`CoatTables::new`] for a coat, computed once per
/// process: a run may pack its scene once per kernel (the `auto` strategy's pilot
/// candidates, `converge`'s variants), and each coat costs a million normals.
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

/// The packed material: its kind's packing (`MaterialModel::pack`; each kind's
/// file says which fields it fills, and the WGSL module reads the same), and
/// what every kind packs alike: `kind` its id (and the transparency above
/// [`MATERIAL_TRANSPARENCY_SHIFT`]), `emit`, and the one-sided bit of `flags`.
pub fn pack_material(material: &Material, tables: &mut MaterialTables) -> PackedMaterial {
    let id = material.kind.id();
    let packed = (MATERIAL_KINDS[id].pack)(material, tables);
    let one_sided = if material.one_sided {
        material_flag("MATERIAL_ONE_SIDED")
    } else {
        0
    };
    PackedMaterial {
        kind: id as u32 | transparency_bits(material.opacity) << MATERIAL_TRANSPARENCY_SHIFT,
        emit: material.emit.to_array(),
        flags: packed.flags | one_sided,
        ..packed
    }
}

/// `body` read as the table `[materials.red]` of `scenes/x.toml`: for the
/// kinds' tests.
#[cfg(test)]
fn read(body: &str) -> Result<Material> {
    let table: toml::Table = toml::from_str(body).expect("valid TOML");
    let inputs = std::cell::RefCell::new(Vec::new());
    let t = ParamTable {
        file: "scenes/x.toml",
        table: &table,
        path: "materials.red".to_string(),
        inputs: &inputs,
    };
    Material::parse("red", &t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_names_a_registered_kind() {
        let e = read("albedo = [0.5, 0.5, 0.5]").unwrap_err();
        assert_eq!(e.location, "materials.red");
        assert!(
            e.message
                .starts_with("missing required key `type` (expected one of `lambertian`, `metal`"),
            "{e}"
        );
        let e = read("type = \"lambertain\"").unwrap_err();
        assert_eq!(e.location, "materials.red.type");
        assert!(e.message.contains("did you mean `lambertian`?"), "{e}");
        // A key of some kind but no `type`: the type is what is missing.
        let e = read("alpha_u = 0.1").unwrap_err();
        assert!(e.message.starts_with("missing required key `type`"), "{e}");
        let e = read("alpah = 0.1").unwrap_err();
        assert!(e.message.contains("did you mean `alpha`?"), "{e}");
    }

    /// `opacity` is every kind's, in [0, 1], 1 by default; it packs above the
    /// kind's id as the transparency, and an opaque material packs as before.
    #[test]
    fn opacity_packs_as_the_transparency_above_the_kind() {
        let m = read("type = \"light\"\nemit = [1, 1, 1]\nopacity = 0.25").unwrap();
        assert_eq!(m.opacity, 0.25);
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!(packed_kind_id(&packed), m.kind.id());
        assert!(packed_is_masked(&packed));
        let transparency =
            (packed.kind >> MATERIAL_TRANSPARENCY_SHIFT) as f32 / MATERIAL_TRANSPARENCY_MAX as f32;
        assert!((transparency - 0.75).abs() <= 1e-5, "{transparency}");
        let opaque = read("type = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]").unwrap();
        assert_eq!(opaque.opacity, 1.0);
        let packed = pack_material(&opaque, &mut MaterialTables::default());
        assert_eq!(packed.kind as usize, opaque.kind.id());
        let e = read("type = \"lambertian\"\nalbedo = [0.5, 0.5, 0.5]\nopacity = 1.5").unwrap_err();
        assert_eq!(e.location, "materials.red.opacity");
        assert!(e.message.contains("must be in [0, 1], got 1.5"), "{e}");
    }

    /// With textured numbers the tables begin with one entry per material,
    /// the offset of its list (count, then slot and texture index pairs);
    /// the kinds' own tables follow. Every kind's textured numbers fit the
    /// kernel's bits.
    #[test]
    fn textured_numbers_are_listed_after_a_directory() {
        let mut tables = MaterialTables::with_number_directory(3);
        let coat = tables.push(&[7.0]);
        assert_eq!(coat, 3);
        tables.add_number_textures(1, &[(0, 5), (4, 6)]);
        assert_eq!(tables.values, [0.0, 4.0, 0.0, 7.0, 2.0, 0.0, 5.0, 4.0, 6.0]);
        for kind in MATERIAL_KINDS {
            assert!(
                kind.textured_numbers.len() <= MATERIAL_NUMBER_SLOTS,
                "{}",
                kind.name
            );
            assert!(
                kind.textured_numbers
                    .iter()
                    .all(|key| kind.keys.contains(key)),
                "{}",
                kind.name
            );
        }
    }

    #[test]
    fn each_kind_is_its_variants_id() {
        for (id, model) in MATERIAL_KINDS.iter().enumerate() {
            // Each kind's required keys, of those it takes.
            let body: String = [
                ("albedo", "[0.5, 0.5, 0.5]"),
                ("emit", "[1, 1, 1]"),
                ("ior", "1.5"),
                ("front", "\"a\""),
                ("first", "\"a\""),
                ("second", "\"b\""),
                ("back", "\"b\""),
            ]
            .iter()
            .filter(|(key, _)| model.keys.contains(key))
            .map(|(key, value)| format!("{key} = {value}\n"))
            .collect();
            let material = read(&format!("type = \"{}\"\n{body}", model.name)).unwrap();
            assert_eq!(material.kind.id(), id, "{}", model.name);
            let packed = pack_material(&material, &mut MaterialTables::default());
            assert_eq!(packed_kind_id(&packed), id, "{}", model.name);
        }
    }
}
