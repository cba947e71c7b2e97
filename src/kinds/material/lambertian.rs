//! `lambertian`: the book's diffuse material, a cosine lobe of reflectance
//! `albedo`, which may also emit.
//!
//! ```toml
//! [materials.white]
//! type = "lambertian"
//! albedo = [0.73, 0.73, 0.73]
//! ```
//!
//! - `albedo` (vector, components in [0, 1], required), or a texture;
//! - `emit` (vector, components >= 0, default 0): radiance it also emits, on
//!   the side its normal faces (the white furnace);
//! - `one_sided` (bool, default false): black from behind.
//!
//! Mitsuba's `diffuse` becomes this kind (`reflectance` as `albedo`).
//! Packed: `albedo`. WGSL: `shaders/lambertian.wgsl`.

use super::common::TextureSlot;
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_nonneg};
use crate::shader::shader_module;
use glam::Vec3;

pub(super) const LAMBERTIAN: MaterialModel = MaterialModel {
    name: "lambertian",
    module: Some(shader_module!("lambertian")),
    helpers: &[],
    lobe: Lobe::Smooth,
    tables: false,
    keys: &["type", "albedo", "emit", "one_sided"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &[],
    diffuse_reflectance_is_albedo: true,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let albedo = t.require("albedo", slot.albedo(t, "albedo")?)?;
    let emit = t.vec3("emit", check_nonneg)?.unwrap_or(Vec3::ZERO);
    Ok(Parsed {
        kind: MaterialKind::Lambertian,
        albedo,
        emit,
    })
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    PackedMaterial {
        albedo: material.albedo.to_array(),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;

    #[test]
    fn reads_and_packs_the_books_albedo_and_emission() {
        let m = read("type = \"lambertian\"\nalbedo = [0.5, 0.25, 1]\nemit = [2, 2, 2]").unwrap();
        assert_eq!(m.kind, MaterialKind::Lambertian);
        assert_eq!(
            (m.albedo, m.emit),
            (Vec3::new(0.5, 0.25, 1.0), Vec3::splat(2.0))
        );
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!((packed.albedo, packed.emit), ([0.5, 0.25, 1.0], [2.0; 3]));
        let e = read("type = \"lambertian\"").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: materials.red: missing required key `albedo`"
        );
    }
}
