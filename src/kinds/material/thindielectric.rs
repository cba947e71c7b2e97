//! `thindielectric`: Mitsuba 3's thin slab of dielectric, two parallel
//! interfaces (a window pane, a soap bubble). It reflects
//! `R' = R + T^2 R / (1 - R^2) = 2R / (1 + R)` of the light (`R` the exact
//! Fresnel reflectance of one interface at the incident angle, `T = 1 - R`,
//! every bounce inside the slab summed) times `specular_reflectance`, and lets
//! `1 - R'` straight through along the incident direction (the second
//! interface undoes the first one's bending) times `specular_transmittance`.
//! Both lobes are delta: a path picks one with its probability.
//!
//! - `int_ior`, `ext_ior` (as for `roughdielectric`: defaults `"bk7"` and
//!   `"air"`, numbers > 0 or Mitsuba's names, which must differ);
//! - `specular_reflectance`, `specular_transmittance` (colours in [0, 1],
//!   default 1).
//!
//! Two-sided, with no inside (no `one_sided`). Packed: `albedo` =
//! specular_reflectance, `color2` = specular_transmittance, `param` = eta
//! (int_ior / ext_ior). WGSL: `shaders/thindielectric.wgsl`.

use super::common::{FRESNEL, INTERFACE_KEYS, Interface, TextureSlot};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result};
use crate::shader::shader_module;

pub(super) const THINDIELECTRIC: MaterialModel = MaterialModel {
    name: "thindielectric",
    module: Some(shader_module!("thindielectric")),
    helpers: &[FRESNEL],
    lobe: Lobe::Delta,
    tables: false,
    keys: INTERFACE_KEYS,
    keys_note: None,
    textured_numbers: &[],
    mitsuba: Some(MitsubaPlugin {
        name: "thindielectric",
        texture: None,
        numbers: &[],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, _: &mut TextureSlot) -> Result<Parsed> {
    let Interface {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    } = Interface::read(t)?;
    Ok(MaterialKind::ThinDielectric {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::ThinDielectric {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    } = material.kind
    else {
        unreachable!("THINDIELECTRIC packs ThinDielectric")
    };
    Interface {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    }
    .pack()
}

#[cfg(test)]
mod tests {
    use super::super::common::{IOR_AIR, IOR_BK7};
    use super::super::read;
    use super::*;
    use glam::Vec3;

    #[test]
    fn reads_mitsubas_defaults() {
        let kind = |body: &str| read(body).unwrap().kind;
        assert_eq!(
            kind("type = \"thindielectric\""),
            MaterialKind::ThinDielectric {
                int_ior: IOR_BK7,
                ext_ior: IOR_AIR,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::ONE,
            }
        );
        assert_eq!(
            kind("type = \"thindielectric\"\nint_ior = \"water\"\nspecular_transmittance = 0.5"),
            MaterialKind::ThinDielectric {
                int_ior: 1.333,
                ext_ior: IOR_AIR,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::splat(0.5),
            }
        );
        let e = read("type = \"thindielectric\"\none_sided = true").unwrap_err();
        assert_eq!(e.location, "materials.red");
        assert!(e.message.contains("unknown key `one_sided`"), "{e}");
    }
}
