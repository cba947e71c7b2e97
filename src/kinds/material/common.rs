//! What several material kinds share: the readers of their common keys
//! (indices of refraction, a conductor's index, microfacet roughness, the
//! colour that may be a texture), Mitsuba's named indices and conductors, and
//! the packing helpers and limits of the Fresnel and microfacet models.

use super::NumberTexture;
use crate::abi::{PackedMaterial, material_flag};
use crate::kinds::Texture;
use crate::kinds::params::{
    ParamTable, Result, check_nonneg, check_positive, check_unit, colour, fmt_num, named,
    reflectance, unknown_name,
};
use crate::shader::{ShaderModule, shader_module};
use glam::Vec3;
use serde::Serialize;
use toml::Value;

pub(super) const FRESNEL: ShaderModule = shader_module!("fresnel");
pub(super) const MICROFACET: ShaderModule = shader_module!("microfacet");
/// What `principled` and `principledthin` share (Schlick, the tint, Burley's
/// diffuse, the sheen).
pub(super) const DISNEY: ShaderModule = shader_module!("disney");

// ---------------------------------------------------------------------------------
// Indices of refraction

/// Mitsuba's named indices of refraction (`mitsuba/render/ior.h`): what `int_ior`
/// and `ext_ior` take by name, in scene files and Mitsuba scenes.
pub(crate) const NAMED_IORS: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Mitsuba 3's named conductors (`material` of `conductor`/`roughconductor`): name,
/// RGB `eta`, RGB `k`. Mitsuba reduces each measured spectrum to RGB when it loads the
/// plugin (clamping out-of-gamut colours to 0); these are the values its RGB variants
/// then use, read back from Mitsuba 3.9.1's `scalar_rgb` by `scripts/conductor-presets.py`,
/// which prints these rows.
// One row per line, as the script prints them.
#[rustfmt::skip]
pub(crate) const NAMED_CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("a-C", [2.9440458, 2.2271364, 1.9681617], [0.8874649, 0.7992985, 0.81529]),
    ("Ag", [0.1552762, 0.116727956, 0.13838764], [4.8283544, 3.1222224, 2.1469011]),
    ("Al", [1.6575009, 0.8804047, 0.52124447], [9.223811, 6.269502, 4.837004]),
    ("AlAs", [3.605296, 3.2329378, 2.2163186], [0.0006794373, 0.0, 0.007512709]),
    ("AlSb", [0.0, 4.1393747, 4.6692543], [0.0, 0.09400908, 1.30057]),
    ("Au", [0.14303598, 0.37530708, 1.4420453], [3.982997, 2.3855565, 1.6033592]),
    ("Be", [4.1850123, 3.1850293, 2.7840612], [3.835466, 3.0101223, 2.868994]),
    ("Cr", [4.3696675, 2.9165053, 1.6549046], [5.206547, 4.231306, 3.7546988]),
    ("CsI", [2.1448996, 1.7023189, 1.6624272], [0.0, 0.0, 0.0]),
    ("Cu", [0.20100547, 0.9237495, 1.1022154], [3.9132621, 2.4530451, 2.1420898]),
    ("Cu2O", [3.5517726, 2.9498696, 2.7518754], [0.11420702, 0.19389686, 0.6061339]),
    ("CuO", [3.247541, 2.4478052, 2.2102196], [0.52108955, 0.57003075, 0.72217894]),
    ("d-C", [2.7087197, 2.3188257, 2.2288976], [0.0, 0.0, 0.0]),
    ("Hg", [2.3989387, 1.440028, 0.9095704], [6.327587, 4.371925, 3.4217637]),
    ("HgTe", [4.77904, 3.2311962, 2.6599011], [1.6316127, 1.5808104, 1.7292874]),
    ("Ir", [3.0863, 2.0821905, 1.6179146], [5.592153, 4.067088, 3.267312]),
    ("K", [0.06404319, 0.046409767, 0.038184915], [2.1041996, 1.34894, 0.9131259]),
    ("Li", [0.26579094, 0.19561832, 0.22094862], [3.540155, 2.3111234, 1.6686072]),
    ("MgO", [2.0895839, 1.6507235, 1.594879], [4.3326952e-12, 0.0, 2.4986457e-11]),
    ("Mo", [4.483974, 3.5251307, 2.7763104], [4.1114373, 3.420827, 3.1506073]),
    ("Na_palik", [0.060269356, 0.056140948, 0.061988432], [3.1792734, 2.1124904, 1.5790411]),
    ("Nb", [3.420074, 2.7900932, 2.3956294], [3.4413946, 2.7376661, 2.5797458]),
    ("Ni_palik", [2.3673046, 1.6633731, 1.4670781], [4.4988117, 3.050153, 2.3454392]),
    ("Rh", [2.5857935, 1.8602164, 1.5542634], [6.7822604, 4.702987, 3.976073]),
    ("Se", [4.0583115, 2.842935, 2.8208535], [0.75404954, 0.6384435, 0.52180755]),
    ("SiC", [3.1723416, 2.5259717, 2.4793706], [7.5376636e-07, 0.0, 1.0192531e-05]),
    ("SnTe", [4.5242496, 1.981645, 1.2815913], [0.0, 0.0, 0.0]),
    ("Ta", [2.062721, 2.3929389, 2.6279287], [2.4083598, 1.7414864, 1.9470278]),
    ("Te", [7.3902335, 4.482105, 2.637106], [3.2560222, 3.5270588, 3.2920542]),
    ("ThF4", [1.8307136, 1.4422286, 1.3876476], [0.0, 0.0, 0.0]),
    ("TiC", [3.7005284, 2.8374221, 2.582287], [3.265635, 2.3515892, 2.1727905]),
    ("TiN", [1.6484497, 1.150516, 1.3798234], [3.368328, 1.9434981, 1.1020677]),
    ("TiO2", [3.45661, 2.8017359, 2.905175], [0.00010526484, 0.0, 0.0006528865]),
    ("VC", [3.657566, 2.752736, 2.532672], [3.0683007, 2.1986873, 1.9631927]),
    ("V_palik", [4.277582, 3.5129488, 2.7610714], [3.4913008, 2.8894548, 3.111522]),
    ("VN", [2.8656023, 2.119189, 1.9400911], [3.0322425, 2.0561156, 1.6163063]),
    ("W", [4.3708167, 3.3002465, 2.9984074], [3.5006406, 2.604874, 2.2732332]),
    ("none", [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
];
pub(super) const IOR_AIR: f32 = 1.000277;
pub(super) const IOR_BK7: f32 = 1.5046;
pub(super) const IOR_POLYPROPYLENE: f32 = 1.49;

/// `int_ior` and `ext_ior` (numbers > 0 or names of [`NAMED_IORS`]), with
/// Mitsuba's defaults: `int_default` inside, air outside. They must differ.
pub(super) fn iors(t: &ParamTable, int_default: f32) -> Result<(f32, f32)> {
    let ior = |key: &str, default: f32| -> Result<f32> {
        match t.table.get(key) {
            None => Ok(default),
            Some(Value::String(name)) => match NAMED_IORS.iter().find(|(n, _)| n == name) {
                Some(&(_, ior)) => Ok(ior as f32),
                None => {
                    let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
                    Err(t.err(t.at(key), unknown_name("index of refraction", name, &names)))
                }
            },
            Some(_) => Ok(t.float(key, check_positive)?.expect("present")),
        }
    };
    let int_ior = ior("int_ior", int_default)?;
    let ext_ior = ior("ext_ior", IOR_AIR)?;
    if int_ior == ext_ior {
        return Err(t.err(
            t.here(),
            format!(
                "`int_ior` and `ext_ior` must differ, both are {}",
                fmt_num(int_ior)
            ),
        ));
    }
    Ok((int_ior, ext_ior))
}

/// The keys of a smooth interface between two dielectrics (`smoothdielectric`,
/// `thindielectric`).
pub(super) const INTERFACE_KEYS: &[&str] = &[
    "type",
    "int_ior",
    "ext_ior",
    "specular_reflectance",
    "specular_transmittance",
];

/// A smooth interface's parameters as Mitsuba names them: [`iors`] with BK7
/// inside, and the two tints (colours in [0, 1], default 1).
pub(super) struct Interface {
    pub int_ior: f32,
    pub ext_ior: f32,
    pub specular_reflectance: Vec3,
    pub specular_transmittance: Vec3,
}

impl Interface {
    pub(super) fn read(t: &ParamTable) -> Result<Interface> {
        let (int_ior, ext_ior) = iors(t, IOR_BK7)?;
        Ok(Interface {
            int_ior,
            ext_ior,
            specular_reflectance: reflectance(t, "specular_reflectance", 1.0)?,
            specular_transmittance: reflectance(t, "specular_transmittance", 1.0)?,
        })
    }

    /// Packed: `albedo` = specular_reflectance, `color2` =
    /// specular_transmittance, `param` = eta (int_ior / ext_ior).
    pub(super) fn pack(&self) -> PackedMaterial {
        PackedMaterial {
            albedo: self.specular_reflectance.to_array(),
            color2: self.specular_transmittance.to_array(),
            param: self.int_ior / self.ext_ior,
            ..Default::default()
        }
    }
}

/// A conductor's complex index `eta + i k`, per channel: `eta` and `k`, or a
/// `material` of [`NAMED_CONDUCTORS`]. Mitsuba's default (`material = "none"`) is
/// eta 0, k 1: reflectance 1 at every angle.
pub(super) fn conductor_ior(t: &ParamTable) -> Result<(Vec3, Vec3)> {
    let Some(name) = t.string("material")? else {
        let eta = colour(t, "eta", 0.0, check_nonneg)?;
        let k = colour(t, "k", 1.0, check_nonneg)?;
        return Ok((eta, k));
    };
    if let Some(key) = ["eta", "k"].into_iter().find(|k| t.table.contains_key(*k)) {
        return Err(t.err(
            t.at(key),
            format!("give either `material` (here `{name}`) or `eta` and `k`, not both"),
        ));
    }
    match NAMED_CONDUCTORS.iter().find(|(n, _, _)| *n == name) {
        Some(&(_, eta, k)) => Ok((Vec3::from_array(eta), Vec3::from_array(k))),
        None => {
            let names: Vec<&str> = NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
            Err(t.err(t.at("material"), unknown_name("conductor", name, &names)))
        }
    }
}

/// The largest conductor index (`eta`, `k`) the kernel evaluates: the Fresnel
/// formula takes fourth powers, which overflow f32 past about 1e9, and at 1e6
/// the reflectance is already 1 within 4e-6.
pub(super) const MAX_CONDUCTOR_INDEX: f32 = 1e6;

/// A conductor's `eta` or `k` as the kernel evaluates it (`MAX_CONDUCTOR_INDEX`).
pub(super) fn conductor_index(index: Vec3) -> [f32; 3] {
    index.min(Vec3::splat(MAX_CONDUCTOR_INDEX)).to_array()
}

// ---------------------------------------------------------------------------------
// Microfacets

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

/// `distribution`: `"beckmann"` (the default) or `"ggx"`.
pub(super) fn distribution(t: &ParamTable) -> Result<Distribution> {
    Ok(named(
        t,
        "distribution",
        &Distribution::ALL,
        Distribution::name,
        Distribution::from_name,
    )?
    .unwrap_or(Distribution::Beckmann))
}

/// The textured numbers of the kinds whose roughness Mitsuba reads as
/// textures (`roughconductor`, `roughdielectric`), in the same slots for
/// each: `microfacet_of` (microfacet.wgsl) reads them so.
pub(super) const ROUGHNESS_NUMBERS: [&str; 3] = ["alpha", "alpha_u", "alpha_v"];

/// `alpha` (default 0.1), or `alpha_u` and `alpha_v` together; each in (0, 1],
/// or a texture where the kind takes one (`ROUGHNESS_NUMBERS`; an `alpha`
/// texture then stands for both, and the packed pair holds its mean).
pub(super) fn roughness(t: &ParamTable, slot: &mut TextureSlot) -> Result<(f32, f32)> {
    let (u, v) = (
        t.table.contains_key("alpha_u"),
        t.table.contains_key("alpha_v"),
    );
    if u || v {
        if t.table.contains_key("alpha") {
            let key = if u { "alpha_u" } else { "alpha_v" };
            return Err(t.err(
                t.at(key),
                "give either `alpha` or `alpha_u` and `alpha_v`, not both",
            ));
        }
        let alpha_u = t.require("alpha_u", slot.number(t, "alpha_u", check_roughness)?)?;
        let alpha_v = t.require("alpha_v", slot.number(t, "alpha_v", check_roughness)?)?;
        return Ok((alpha_u, alpha_v));
    }
    let alpha = slot.number(t, "alpha", check_roughness)?.unwrap_or(0.1);
    Ok((alpha, alpha))
}

pub(super) fn check_roughness(x: f32) -> std::result::Result<(), String> {
    if x > 0.0 && x <= 1.0 {
        Ok(())
    } else {
        Err(format!("must be in (0, 1], got {}", fmt_num(x)))
    }
}

/// The smallest roughness the kernel evaluates (Mitsuba 3 and pbrt-v4 clamp
/// alike): below it a microfacet lobe is narrower than 32-bit floats can
/// evaluate (its density and slopes overflow into NaN), and it already
/// behaves as a mirror. Scenes keep the alpha they give.
pub(super) const MIN_ALPHA: f32 = 1e-4;

pub(super) fn beckmann_flag(distribution: Distribution) -> u32 {
    match distribution {
        Distribution::Beckmann => material_flag("MATERIAL_BECKMANN"),
        Distribution::Ggx => 0,
    }
}

// ---------------------------------------------------------------------------------
// Plastics

/// Mitsuba steers samples between a coat and its base by the lobes' mean
/// reflectances: the probability weight of the coat.
pub(super) fn specular_sampling_weight(diffuse: Vec3, specular: Vec3) -> f32 {
    let (d_mean, s_mean) = (diffuse.element_sum() / 3.0, specular.element_sum() / 3.0);
    s_mean / (d_mean + s_mean)
}

/// `nonlinear`: Mitsuba's account of the colour shift of light scattered
/// inside the coat several times (default false).
pub(super) fn nonlinear(t: &ParamTable) -> Result<bool> {
    Ok(t.boolean("nonlinear")?.unwrap_or(false))
}

pub(super) fn nonlinear_flag(nonlinear: bool) -> u32 {
    if nonlinear {
        material_flag("MATERIAL_NONLINEAR")
    } else {
        0
    }
}

// ---------------------------------------------------------------------------------
// Textures

/// The one colour of a material that may be a texture (`Material::texture`)
/// and its numbers that may be (`Material::number_textures`), which its kind
/// reads through this.
pub(crate) struct TextureSlot {
    pub texture: Option<Texture>,
    /// The kind's `MaterialModel::textured_numbers`.
    textured_numbers: &'static [&'static str],
    pub numbers: Vec<NumberTexture>,
}

impl TextureSlot {
    pub fn new(textured_numbers: &'static [&'static str]) -> TextureSlot {
        TextureSlot {
            texture: None,
            textured_numbers,
            numbers: Vec::new(),
        }
    }

    /// The number `key` (one of the kind's `textured_numbers`): a number
    /// that `check` accepts, or a texture, kept, whose mean number it gives
    /// (Mitsuba checks no texture's values); `None` when absent.
    pub fn number(
        &mut self,
        t: &ParamTable,
        key: &str,
        check: fn(f32) -> std::result::Result<(), String>,
    ) -> Result<Option<f32>> {
        let slot = (self.textured_numbers.iter().position(|&k| k == key))
            .expect("a number the kind lists as textured");
        if !t.table.get(key).is_some_and(Value::is_table) {
            return t.float(key, check);
        }
        let texture = Texture::parse(&t.sub(key)?.expect("a table"))?;
        let mean = texture.mean_number();
        self.numbers.push(NumberTexture {
            slot: slot as u32,
            texture,
        });
        Ok(Some(mean))
    }

    /// Whether the number `key` is a texture.
    pub fn is_textured(&self, key: &str) -> bool {
        let slot = self.textured_numbers.iter().position(|&k| k == key);
        self.numbers.iter().any(|n| Some(n.slot as usize) == slot)
    }

    /// The book's `albedo`: a vector in [0, 1] or a texture (whose mean it
    /// gives); `None` when absent.
    pub fn albedo(&mut self, t: &ParamTable, key: &str) -> Result<Option<Vec3>> {
        match self.texture(t, key)? {
            Some(mean) => Ok(Some(mean)),
            None => t.vec3(key, check_unit),
        }
    }

    /// A reflectance in [0, 1] (a vector, or one number for grey; `default`
    /// when absent) or a texture (whose mean it gives).
    pub fn colour(&mut self, t: &ParamTable, key: &str, default: f32) -> Result<Vec3> {
        match self.texture(t, key)? {
            Some(mean) => Ok(mean),
            None => colour(t, key, default, check_unit),
        }
    }

    /// The texture at `key`, kept, and its mean; `None` where `key` holds no table.
    pub(super) fn texture(&mut self, t: &ParamTable, key: &str) -> Result<Option<Vec3>> {
        if !t.table.get(key).is_some_and(Value::is_table) {
            return Ok(None);
        }
        let texture = Texture::parse(&t.sub(key)?.expect("a table"))?;
        let mean = texture.mean();
        self.texture = Some(texture);
        Ok(Some(mean))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two entries against Mitsuba itself: these were read by hand from Mitsuba
    /// 3.9.1's `scalar_rgb` variant (`mi.traverse` of a loaded `conductor` with
    /// `material` `Au` and `Cu`: `eta.value`, `k.value`, printed to 6 digits), not from
    /// the generator's output, so a table from a wrong variant, a swapped `eta`/`k` or a
    /// shifted row fails here.
    #[test]
    fn conductor_presets_match_mitsuba() {
        let mitsuba: [(&str, [f32; 3], [f32; 3]); 2] = [
            (
                "Au",
                [0.143036, 0.375307, 1.44205],
                [3.983, 2.38556, 1.60336],
            ),
            (
                "Cu",
                [0.201005, 0.92375, 1.10222],
                [3.91326, 2.45305, 2.14209],
            ),
        ];
        for (name, eta, k) in mitsuba {
            let &(_, table_eta, table_k) = NAMED_CONDUCTORS
                .iter()
                .find(|(n, _, _)| *n == name)
                .expect("in the table");
            for (table, printed) in [(table_eta, eta), (table_k, k)] {
                for (t, p) in table.into_iter().zip(printed) {
                    // 6 significant digits: within half a unit of the sixth.
                    assert!(
                        (t - p).abs() <= 5e-6 * p,
                        "{name}: {table:?} vs {printed:?}"
                    );
                }
            }
        }
        let names: Vec<&str> = NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
        assert_eq!(names.len(), 38, "{names:?}");
    }
}
