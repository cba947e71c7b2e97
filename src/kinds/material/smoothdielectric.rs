//! `smoothdielectric`: Mitsuba 3's `dielectric` (and pbrt-v4's), a smooth
//! interface between two dielectrics. It reflects the exact Fresnel reflectance
//! `R` of the interface at the incident angle (all of it under total internal
//! reflection) times `specular_reflectance`, and refracts the rest by Snell's law
//! times `specular_transmittance`; radiance that crosses is scaled by the squared
//! index ratio, as Mitsuba does in radiance mode (so a closed object is
//! unchanged by it, but not a light inside glass). Both lobes are delta: a path
//! picks one with its probability. The book's `dielectric` uses Schlick's
//! approximation of `R` instead, which strays from it at grazing angles and
//! under total internal reflection (a glass pane lit along its length).
//!
//! - `int_ior`, `ext_ior` (defaults `"bk7"` and `"air"`, numbers > 0 or
//!   Mitsuba's names, which must differ);
//! - `specular_reflectance`, `specular_transmittance` (colours in [0, 1],
//!   default 1).
//!
//! Two-sided, its inside behind its normal (no `one_sided`). Mitsuba's
//! `dielectric` becomes this kind. Packed: `albedo` = specular_reflectance,
//! `color2` = specular_transmittance, `param` = eta (int_ior / ext_ior). WGSL:
//! `shaders/smoothdielectric.wgsl`.

use super::common::{FRESNEL, INTERFACE_KEYS, Interface, TextureSlot};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result};
use crate::shader::shader_module;

pub(super) const SMOOTHDIELECTRIC: MaterialModel = MaterialModel {
    name: "smoothdielectric",
    module: Some(shader_module!("smoothdielectric")),
    helpers: &[FRESNEL],
    lobe: Lobe::Delta,
    tables: false,
    keys: INTERFACE_KEYS,
    keys_note: None,
    textured_numbers: &[],
    mitsuba: Some(MitsubaPlugin {
        name: "dielectric",
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
    Ok(MaterialKind::SmoothDielectric {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::SmoothDielectric {
        int_ior,
        ext_ior,
        specular_reflectance,
        specular_transmittance,
    } = material.kind
    else {
        unreachable!("SMOOTHDIELECTRIC packs SmoothDielectric")
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
            kind("type = \"smoothdielectric\""),
            MaterialKind::SmoothDielectric {
                int_ior: IOR_BK7,
                ext_ior: IOR_AIR,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::ONE,
            }
        );
        assert_eq!(
            kind("type = \"smoothdielectric\"\nint_ior = \"water\"\nspecular_reflectance = 0.5"),
            MaterialKind::SmoothDielectric {
                int_ior: 1.333,
                ext_ior: IOR_AIR,
                specular_reflectance: Vec3::splat(0.5),
                specular_transmittance: Vec3::ONE,
            }
        );
        let e = read("type = \"smoothdielectric\"\nior = 1.5").unwrap_err();
        assert!(e.message.contains("unknown key `ior`"), "{e}");
    }
}
