//! `roughdielectric`: Mitsuba 3's rough interface between two dielectrics
//! (Walter et al. 2007), reflecting and refracting through microfacets, with
//! Mitsuba's radiance scale of 1/eta^2 across the interface.
//!
//! - `distribution` (`"beckmann"`, the default, or `"ggx"`);
//! - `alpha` (roughness in (0, 1], default 0.1), or `alpha_u` and `alpha_v`
//!   together (anisotropic); each may be a texture, as for `roughconductor`;
//! - `int_ior` (default `"bk7"`, 1.5046), `ext_ior` (default `"air"`,
//!   1.000277): numbers > 0 or Mitsuba's names (`"water"`, `"diamond"`, ...,
//!   `NAMED_IORS`); their ratio must be at least `MIN_ROUGH_IOR_CONTRAST` from 1;
//! - `specular_reflectance` (colour in [0, 1], default 1), or a texture;
//!   `specular_transmittance` (colour in [0, 1], default 1).
//!
//! Two-sided (no `one_sided`). Packed: `albedo` = specular_reflectance, `color2`
//! = specular_transmittance, `color3.x` = eta (int_ior / ext_ior),
//! `param`/`param2` = alpha_u/alpha_v (at least `MIN_ALPHA`), `flags` the
//! distribution. WGSL: `shaders/roughdielectric.wgsl`.

use super::common::{
    FRESNEL, IOR_BK7, MICROFACET, MIN_ALPHA, ROUGHNESS_NUMBERS, TextureSlot, beckmann_flag,
    distribution, iors, roughness,
};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, fmt_num, reflectance};
use crate::shader::shader_module;

pub(super) const ROUGHDIELECTRIC: MaterialModel = MaterialModel {
    name: "roughdielectric",
    module: Some(shader_module!("roughdielectric")),
    helpers: &[FRESNEL, MICROFACET],
    lobe: Lobe::Smooth,
    tables: false,
    keys: &[
        "type",
        "distribution",
        "alpha",
        "alpha_u",
        "alpha_v",
        "int_ior",
        "ext_ior",
        "specular_reflectance",
        "specular_transmittance",
    ],
    keys_note: None,
    textured_numbers: &ROUGHNESS_NUMBERS,
    mitsuba: Some(MitsubaPlugin {
        name: "roughdielectric",
        texture: Some("specular_reflectance"),
        numbers: &[],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

/// How far from 1 `int_ior / ext_ior` must be: nearer, the refracted lobe's
/// Jacobian divides by a difference that rounds to zero in 32-bit floats, and
/// samples turn NaN.
const MIN_ROUGH_IOR_CONTRAST: f32 = 1e-3;

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let distribution = distribution(t)?;
    let (alpha_u, alpha_v) = roughness(t, slot)?;
    let (int_ior, ext_ior) = iors(t, IOR_BK7)?;
    let eta = int_ior / ext_ior;
    if (eta - 1.0).abs() < MIN_ROUGH_IOR_CONTRAST {
        return Err(t.err(
            t.here(),
            format!(
                "`int_ior` / `ext_ior` = {} is within {MIN_ROUGH_IOR_CONTRAST} of 1: \
                 a rough interface so nearly index-matched refracts into a lobe \
                 too narrow for 32-bit floats (use ratios further from 1, or no \
                 interface)",
                fmt_num(eta)
            ),
        ));
    }
    Ok(MaterialKind::RoughDielectric {
        distribution,
        alpha_u,
        alpha_v,
        int_ior,
        ext_ior,
        specular_reflectance: slot.colour(t, "specular_reflectance", 1.0)?,
        specular_transmittance: reflectance(t, "specular_transmittance", 1.0)?,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::RoughDielectric {
        distribution,
        alpha_u,
        alpha_v,
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    } = material.kind
    else {
        unreachable!("ROUGHDIELECTRIC packs rough dielectrics")
    };
    PackedMaterial {
        albedo: specular_reflectance.to_array(),
        color2: specular_transmittance.to_array(),
        color3: [int_ior / ext_ior, 0.0, 0.0],
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
    use glam::Vec3;

    #[test]
    fn reads_named_indices_and_refuses_a_near_match() {
        let m = read(
            "type = \"roughdielectric\"\ndistribution = \"ggx\"\nalpha_u = 0.05\nalpha_v = 0.3\next_ior = \"water\"",
        )
        .unwrap();
        assert_eq!(
            m.kind,
            MaterialKind::RoughDielectric {
                distribution: Distribution::Ggx,
                alpha_u: 0.05,
                alpha_v: 0.3,
                int_ior: 1.5046,
                ext_ior: 1.333,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::ONE,
            }
        );
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!(packed.color3, [1.5046 / 1.333, 0.0, 0.0]);
        assert_eq!((packed.param, packed.param2), (0.05, 0.3));
        let e = read("type = \"roughdielectric\"\nint_ior = 1.0005\next_ior = 1").unwrap_err();
        assert_eq!(e.location, "materials.red");
        assert!(e.message.contains("is within 0.001 of 1"), "{e}");
    }
}
