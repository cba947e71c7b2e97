//! `plastic`: Mitsuba 3's smooth plastic, a diffuse base under a smooth
//! dielectric coat. The base is weighted by the coat's Fresnel transmission in
//! and out, its internal diffuse reflectance and 1/eta^2; the coat is a delta
//! lobe, picked with Mitsuba's specular sampling weight, and the strategies
//! apply to the base.
//!
//! - `diffuse_reflectance` (colour in [0, 1], default 0.5), or a texture;
//! - `specular_reflectance` (colour in [0, 1], default 1);
//! - `int_ior` (default `"polypropylene"`, 1.49), `ext_ior` (default `"air"`):
//!   numbers > 0 or Mitsuba's names, which must differ;
//! - `nonlinear` (bool, default false): Mitsuba's account of the colour shift
//!   of light scattered inside the coat several times;
//! - `one_sided` (bool, default false): black from behind.
//!
//! Packed: `albedo` = diffuse_reflectance, `color2` = specular_reflectance,
//! `color3` = (eta, the coat's internal diffuse Fresnel reflectance, the
//! probability weight of the specular lobe), `flags` nonlinear. WGSL:
//! `shaders/plastic.wgsl`.

use super::common::{
    FRESNEL, IOR_POLYPROPYLENE, TextureSlot, iors, nonlinear, nonlinear_flag,
    specular_sampling_weight,
};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, reflectance};
use crate::shader::shader_module;

pub(super) const PLASTIC: MaterialModel = MaterialModel {
    name: "plastic",
    module: Some(shader_module!("plastic")),
    helpers: &[FRESNEL],
    lobe: Lobe::SmoothAndDelta,
    tables: false,
    keys: &[
        "type",
        "int_ior",
        "ext_ior",
        "diffuse_reflectance",
        "specular_reflectance",
        "nonlinear",
        "one_sided",
    ],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: Some(MitsubaPlugin {
        name: "plastic",
        texture: Some("diffuse_reflectance"),
        numbers: &[],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: true,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let (int_ior, ext_ior) = iors(t, IOR_POLYPROPYLENE)?;
    Ok(MaterialKind::Plastic {
        int_ior,
        ext_ior,
        diffuse_reflectance: slot.colour(t, "diffuse_reflectance", 0.5)?,
        specular_reflectance: reflectance(t, "specular_reflectance", 1.0)?,
        nonlinear: nonlinear(t)?,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Plastic {
        int_ior,
        ext_ior,
        diffuse_reflectance,
        specular_reflectance,
        nonlinear,
    } = material.kind
    else {
        unreachable!("PLASTIC packs plastics")
    };
    let eta = int_ior / ext_ior;
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
    }
}

/// The hemispherical average of the dielectric Fresnel reflectance at relative
/// index `eta`: Mitsuba's `fresnel_diffuse_reflectance` (the fits of Egan and
/// Hilgeman 1973 below 1, d'Eon and Irving 2011 above), computed once per
/// material on the host as Mitsuba does.
fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * (eta * eta) + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let inv = 1.0 / eta;
        let (inv2, inv3, inv4, inv5) = (inv * inv, inv * inv * inv, inv.powi(4), inv.powi(5));
        0.919317 - 3.4793 * inv + 6.75335 * inv2 - 7.80989 * inv3 + 4.98554 * inv4 - 1.36881 * inv5
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;
    use crate::abi::material_flag;
    use glam::Vec3;

    #[test]
    fn reads_mitsubas_defaults_and_packs_the_coats_terms() {
        let m = read("type = \"plastic\"\nnonlinear = true\ndiffuse_reflectance = [0.5, 0.25, 0]")
            .unwrap();
        assert_eq!(
            m.kind,
            MaterialKind::Plastic {
                int_ior: 1.49,
                ext_ior: 1.000277,
                diffuse_reflectance: Vec3::new(0.5, 0.25, 0.0),
                specular_reflectance: Vec3::ONE,
                nonlinear: true,
            }
        );
        let packed = pack_material(&m, &mut MaterialTables::default());
        let eta = 1.49 / 1.000277;
        assert_eq!(packed.color3[0], eta);
        // Mitsuba's weight: the specular mean over both means.
        assert_eq!(packed.color3[2], 1.0 / (0.25 + 1.0));
        assert_eq!(packed.flags, material_flag("MATERIAL_NONLINEAR"));
    }
}
