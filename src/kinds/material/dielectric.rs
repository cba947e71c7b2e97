//! `dielectric`: the book's glass, a smooth interface that reflects or
//! refracts by Schlick's approximation of the Fresnel reflectance of its
//! relative index.
//!
//! - `ior` (float > 0): the relative index (interior over exterior); or
//!   instead `int_ior` and `ext_ior` (numbers > 0 or Mitsuba's names, defaults
//!   `"bk7"` and `"air"`, which must differ), `ior` being their ratio. One of
//!   the two forms is required.
//!
//! Two-sided (no `one_sided`); no albedo or emission. Mitsuba's `dielectric`,
//! with the exact reflectance, is `smoothdielectric`. Packed: `param` = ior.
//! WGSL: `shaders/dielectric.wgsl`.

use super::common::{IOR_BK7, TextureSlot, iors};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_positive};
use crate::shader::shader_module;

pub(super) const DIELECTRIC: MaterialModel = MaterialModel {
    name: "dielectric",
    module: Some(shader_module!("dielectric")),
    helpers: &[],
    lobe: Lobe::Delta,
    tables: false,
    keys: &["type", "ior", "int_ior", "ext_ior"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, _: &mut TextureSlot) -> Result<Parsed> {
    let ior = match t.float("ior", check_positive)? {
        Some(ior) => {
            if let Some(key) = ["int_ior", "ext_ior"]
                .into_iter()
                .find(|k| t.table.contains_key(*k))
            {
                return Err(t.err(
                    t.at(key),
                    "give either `ior` or `int_ior`/`ext_ior`, not both",
                ));
            }
            ior
        }
        None if t.table.contains_key("int_ior") || t.table.contains_key("ext_ior") => {
            let (int_ior, ext_ior) = iors(t, IOR_BK7)?;
            int_ior / ext_ior
        }
        None => {
            return Err(t.err(
                t.here(),
                "missing required key `ior` (or `int_ior`/`ext_ior`)",
            ));
        }
    };
    Ok(MaterialKind::Dielectric { ior }.into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Dielectric { ior } = material.kind else {
        unreachable!("DIELECTRIC packs dielectrics")
    };
    PackedMaterial {
        param: ior,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;

    #[test]
    fn reads_ior_or_its_two_sides() {
        let kind = |body: &str| read(&format!("type = \"dielectric\"\n{body}")).map(|m| m.kind);
        assert_eq!(
            kind("ior = 1.5").unwrap(),
            MaterialKind::Dielectric { ior: 1.5 }
        );
        assert_eq!(
            kind("int_ior = 2\next_ior = 1.25").unwrap(),
            MaterialKind::Dielectric { ior: 1.6 }
        );
        let e = kind("ior = 1.5\next_ior = 1.2").unwrap_err();
        assert_eq!(e.location, "materials.red.ext_ior");
        assert_eq!(
            kind("").unwrap_err().message,
            "missing required key `ior` (or `int_ior`/`ext_ior`)"
        );
        let m = read("type = \"dielectric\"\nior = 1.5").unwrap();
        assert_eq!(pack_material(&m, &mut MaterialTables::default()).param, 1.5);
    }
}
