//! `roughconductor`: Mitsuba 3's rough conductor, a microfacet surface
//! (Cook-Torrance with Smith shadowing) with a conductor's Fresnel
//! reflectance, sampled from the visible normals.
//!
//! - `distribution` (`"beckmann"`, the default, or `"ggx"`);
//! - `alpha` (roughness in (0, 1], default 0.1), or `alpha_u` and `alpha_v`
//!   together (anisotropic, along the two tangents of the shading frame);
//!   each may be a texture, as in Mitsuba, read at the hit as one number as
//!   Mitsuba's `eval_1` reads it (a bitmap's luminance, a checkerboard
//!   colour's channel mean), at least `MIN_ALPHA` there too;
//! - `material`, or `eta` and `k`; `specular_reflectance` (default 1, or a
//!   texture); `one_sided`: as for `conductor`.
//!
//! Packed: as `conductor`, and `param`/`param2` = alpha_u/alpha_v (at least
//! `MIN_ALPHA`), `flags` the distribution. WGSL: `shaders/roughconductor.wgsl`.

use super::common::{
    FRESNEL, MICROFACET, MIN_ALPHA, ROUGHNESS_NUMBERS, TextureSlot, beckmann_flag, conductor_index,
    conductor_ior, distribution, roughness,
};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result};
use crate::shader::shader_module;

pub(super) const ROUGHCONDUCTOR: MaterialModel = MaterialModel {
    name: "roughconductor",
    module: Some(shader_module!("roughconductor")),
    helpers: &[FRESNEL, MICROFACET],
    lobe: Lobe::Smooth,
    tables: false,
    keys: &[
        "type",
        "distribution",
        "alpha",
        "alpha_u",
        "alpha_v",
        "material",
        "eta",
        "k",
        "specular_reflectance",
        "one_sided",
    ],
    keys_note: None,
    textured_numbers: &ROUGHNESS_NUMBERS,
    mitsuba: Some(MitsubaPlugin {
        name: "roughconductor",
        texture: Some("specular_reflectance"),
        numbers: &[],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let distribution = distribution(t)?;
    let (alpha_u, alpha_v) = roughness(t, slot)?;
    let (eta, k) = conductor_ior(t)?;
    let specular_reflectance = slot.colour(t, "specular_reflectance", 1.0)?;
    Ok(MaterialKind::RoughConductor {
        distribution,
        alpha_u,
        alpha_v,
        eta,
        k,
        specular_reflectance,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::RoughConductor {
        distribution,
        alpha_u,
        alpha_v,
        eta,
        k,
        specular_reflectance,
    } = material.kind
    else {
        unreachable!("ROUGHCONDUCTOR packs rough conductors")
    };
    PackedMaterial {
        albedo: specular_reflectance.to_array(),
        color2: conductor_index(eta),
        color3: conductor_index(k),
        param: alpha_u.max(MIN_ALPHA),
        param2: alpha_v.max(MIN_ALPHA),
        flags: beckmann_flag(distribution),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Distribution, pack_material, read};
    use super::*;
    use crate::abi::material_flag;
    use glam::Vec3;

    #[test]
    fn reads_and_packs_an_anisotropic_roughness() {
        let m = read(
            "type = \"roughconductor\"\neta = [0.2, 0.4, 1.4]\nk = 3\nspecular_reflectance = 0.9",
        )
        .unwrap();
        assert_eq!(
            m.kind,
            MaterialKind::RoughConductor {
                distribution: Distribution::Beckmann,
                alpha_u: 0.1,
                alpha_v: 0.1,
                eta: Vec3::new(0.2, 0.4, 1.4),
                k: Vec3::splat(3.0),
                specular_reflectance: Vec3::splat(0.9),
            }
        );
        let m = read(
            "type = \"roughconductor\"\nalpha_u = 1e-6\nalpha_v = 0.3\ndistribution = \"ggx\"",
        )
        .unwrap();
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!((packed.param, packed.param2), (MIN_ALPHA, 0.3));
        assert_eq!(packed.flags & material_flag("MATERIAL_BECKMANN"), 0);
        let e = read("type = \"roughconductor\"\nalpha = 0.1\nalpha_v = 0.2").unwrap_err();
        assert_eq!(e.location, "materials.red.alpha_v");
    }

    /// `alpha` as a texture stands for both (its slot, its mean packed in
    /// both); `alpha_u` as one keeps `alpha_v` a number.
    #[test]
    fn its_roughness_may_be_a_texture() {
        let checks = "{ type = \"checkerboard\", color0 = 0.4, color1 = 0.2 }";
        let m = read(&format!("type = \"roughconductor\"\nalpha = {checks}")).unwrap();
        assert!(
            matches!(m.kind, MaterialKind::RoughConductor { alpha_u, alpha_v, .. }
            if (alpha_u - 0.3).abs() < 1e-6 && alpha_u == alpha_v)
        );
        let slots: Vec<u32> = m.number_textures.iter().map(|n| n.slot).collect();
        assert_eq!(slots, [0]);
        let m = read(&format!(
            "type = \"roughconductor\"\nalpha_u = {checks}\nalpha_v = 0.05"
        ))
        .unwrap();
        assert!(matches!(m.kind, MaterialKind::RoughConductor { alpha_v, .. } if alpha_v == 0.05));
        let slots: Vec<u32> = m.number_textures.iter().map(|n| n.slot).collect();
        assert_eq!(slots, [1]);
        assert_eq!(ROUGHNESS_NUMBERS[1], "alpha_u");
    }
}
