//! `metal`: the book's fuzzed mirror: the mirror direction moved by a uniform
//! point of a sphere of radius `fuzz`, renormalised, times `albedo`.
//!
//! - `albedo` (vector, components in [0, 1], required), or a texture;
//! - `fuzz` (float in [0, 1], default 0: a perfect mirror);
//! - `one_sided` (bool, default false): black from behind.
//!
//! No Mitsuba plugin is this kind (Mitsuba's mirrors are `conductor`).
//! Packed: `albedo`, `param` = fuzz. WGSL: `shaders/metal.wgsl`.

use super::common::TextureSlot;
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_unit};
use crate::shader::shader_module;

pub(super) const METAL: MaterialModel = MaterialModel {
    name: "metal",
    module: Some(shader_module!("metal")),
    helpers: &[],
    // The fuzzed mirror has no closed-form density.
    lobe: Lobe::Delta,
    tables: false,
    keys: &["type", "albedo", "fuzz", "one_sided"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let albedo = t.require("albedo", slot.albedo(t, "albedo")?)?;
    let fuzz = t.float("fuzz", check_unit)?.unwrap_or(0.0);
    Ok(Parsed {
        albedo,
        ..MaterialKind::Metal { fuzz }.into()
    })
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Metal { fuzz } = material.kind else {
        unreachable!("METAL packs metals")
    };
    PackedMaterial {
        albedo: material.albedo.to_array(),
        param: fuzz,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;
    use glam::Vec3;

    #[test]
    fn reads_and_packs_albedo_and_fuzz() {
        let m = read("type = \"metal\"\nalbedo = [0.8, 0.6, 0.2]").unwrap();
        assert_eq!(m.kind, MaterialKind::Metal { fuzz: 0.0 });
        let m = read("type = \"metal\"\nalbedo = [0.8, 0.6, 0.2]\nfuzz = 0.3").unwrap();
        assert_eq!(
            (m.kind, m.albedo),
            (MaterialKind::Metal { fuzz: 0.3 }, Vec3::new(0.8, 0.6, 0.2))
        );
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!((packed.albedo, packed.param), ([0.8, 0.6, 0.2], 0.3));
        let e = read("type = \"metal\"\nalbedo = [1, 1, 1]\nfuzz = 2").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: materials.red.fuzz: must be in [0, 1], got 2"
        );
    }
}
