//! `light`: an emitter that scatters nothing: radiance `emit` leaves the side
//! its normal faces, and a path ends there.
//!
//! - `emit` (vector, components >= 0, required).
//!
//! A shape of this material (or any that emits) is in the light density.
//! Mitsuba's `area` emitters become `lambertian` materials that emit instead,
//! keeping their BSDF's albedo. Packed: nothing of its own (`emit`, as every
//! kind). No WGSL module.

use super::common::TextureSlot;
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_nonneg};
use glam::Vec3;

pub(super) const LIGHT: MaterialModel = MaterialModel {
    name: "light",
    module: None,
    helpers: &[],
    lobe: Lobe::Absorbing,
    tables: false,
    keys: &["type", "emit"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, _: &mut TextureSlot) -> Result<Parsed> {
    let emit = t.require("emit", t.vec3("emit", check_nonneg)?)?;
    Ok(Parsed {
        kind: MaterialKind::Light,
        albedo: Vec3::ZERO,
        emit,
    })
}

fn pack(_: &Material, _: &mut MaterialTables) -> PackedMaterial {
    PackedMaterial::default()
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;

    #[test]
    fn emits_and_packs_only_its_emission() {
        let m = read("type = \"light\"\nemit = [15, 15, 15]").unwrap();
        assert!(m.emits());
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!(
            packed,
            PackedMaterial {
                kind: m.kind.id() as u32,
                emit: [15.0; 3],
                ..Default::default()
            }
        );
        let e = read("type = \"light\"\nemit = [1, -1, 1]").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: materials.red.emit[1]: must be >= 0, got -1"
        );
    }
}
