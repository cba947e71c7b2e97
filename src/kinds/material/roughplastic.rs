//! `roughplastic`: Mitsuba 3's rough plastic, a diffuse base under a rough
//! dielectric coat (isotropic microfacets): a glossy lobe sampled from its
//! visible normals and a cosine lobe for the base, picked with Mitsuba's
//! weights; both have densities, so every strategy applies to both. The base
//! is weighted by the rough coat's transmittance in and out, tabulated per
//! coat at 64 incidence cosines, and its internal reflectance, both computed
//! on the host by Mitsuba's quadrature (`kinds::coat`).
//!
//! - `distribution` (`"beckmann"`, the default, or `"ggx"`);
//! - `alpha` (roughness in (0, 1], default 0.1; isotropic only, as in Mitsuba);
//! - `diffuse_reflectance` (default 0.5, or a texture), `specular_reflectance`,
//!   `int_ior`, `ext_ior`, `nonlinear` and `one_sided`: as for `plastic`.
//!
//! Packed: as `plastic`, with `color3.y` the coat's internal reflectance,
//! `param` = alpha (at least `MIN_ALPHA`), `param2` = the offset of its
//! transmittance table in `MaterialTables` (an integer, exact in f32), `flags`
//! the distribution and nonlinear. WGSL: `shaders/roughplastic.wgsl`.

use super::common::{
    FRESNEL, IOR_POLYPROPYLENE, MICROFACET, MIN_ALPHA, TextureSlot, beckmann_flag, check_roughness,
    distribution, iors, nonlinear, nonlinear_flag, specular_sampling_weight,
};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, reflectance};
use crate::shader::shader_module;

pub(super) const ROUGHPLASTIC: MaterialModel = MaterialModel {
    name: "roughplastic",
    module: Some(shader_module!("roughplastic")),
    helpers: &[FRESNEL, MICROFACET],
    lobe: Lobe::Smooth,
    tables: true,
    keys: &[
        "type",
        "distribution",
        "alpha",
        "int_ior",
        "ext_ior",
        "diffuse_reflectance",
        "specular_reflectance",
        "nonlinear",
        "one_sided",
    ],
    keys_note: Some("isotropic: `alpha` only"),
    textured_numbers: &[],
    mitsuba: Some(MitsubaPlugin {
        name: "roughplastic",
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
    Ok(MaterialKind::RoughPlastic {
        distribution: distribution(t)?,
        alpha: t.float("alpha", check_roughness)?.unwrap_or(0.1),
        int_ior,
        ext_ior,
        diffuse_reflectance: slot.colour(t, "diffuse_reflectance", 0.5)?,
        specular_reflectance: reflectance(t, "specular_reflectance", 1.0)?,
        nonlinear: nonlinear(t)?,
    }
    .into())
}

fn pack(material: &Material, tables: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::RoughPlastic {
        distribution,
        alpha,
        int_ior,
        ext_ior,
        diffuse_reflectance,
        specular_reflectance,
        nonlinear,
    } = material.kind
    else {
        unreachable!("ROUGHPLASTIC packs rough plastics")
    };
    let eta = int_ior / ext_ior;
    let alpha = alpha.max(MIN_ALPHA);
    let (offset, internal_reflectance) = tables.coat(distribution, alpha, eta);
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
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Distribution, pack_material, read};
    use super::*;
    use crate::kinds::ROUGH_TRANSMITTANCE_RES;
    use glam::Vec3;

    #[test]
    fn reads_mitsubas_defaults_and_shares_a_coats_table() {
        let m = read(
            "type = \"roughplastic\"\nalpha = 0.05\nint_ior = 2\ndiffuse_reflectance = [0.07, 0.09, 0.13]",
        )
        .unwrap();
        assert_eq!(
            m.kind,
            MaterialKind::RoughPlastic {
                distribution: Distribution::Beckmann,
                alpha: 0.05,
                int_ior: 2.0,
                ext_ior: 1.000277,
                diffuse_reflectance: Vec3::new(0.07, 0.09, 0.13),
                specular_reflectance: Vec3::ONE,
                nonlinear: false,
            }
        );
        let other =
            read("type = \"roughplastic\"\nalpha = 0.05\nint_ior = 2\ndistribution = \"ggx\"")
                .unwrap();
        let mut tables = MaterialTables::default();
        let offsets: Vec<f32> = [&m, &other, &m]
            .map(|m| pack_material(m, &mut tables).param2)
            .to_vec();
        let res = ROUGH_TRANSMITTANCE_RES as f32;
        assert_eq!(offsets, [0.0, res, 0.0]);
        assert_eq!(tables.values.len(), 2 * ROUGH_TRANSMITTANCE_RES);
        let e = read("type = \"roughplastic\"\nalpha_u = 0.1").unwrap_err();
        assert!(
            e.message
                .contains("for a roughplastic material (isotropic: `alpha` only)"),
            "{e}"
        );
    }
}
