//! `twosided`: a surface with a different material on each side (Mitsuba's
//! `twosided` with two nested BSDFs): a ray that hits the side the normal
//! faces scatters by the material `front`, one that hits the other side by
//! `back`, which sees the surface as its front (the flipped frame: a
//! one-sided `back` is lit from behind, and a dielectric's inside is behind
//! its normal as the ray sees it).
//!
//! ```toml
//! [materials.leaf]
//! type = "twosided"
//! front = "leaf_top"
//! back = "leaf_underside"
//! ```
//!
//! - `front`, `back` (strings, required): names of `[materials.NAME]` tables.
//!   These may be any kind, `twosided` and `blend` too, at most
//!   `MATERIAL_NESTING` (4) deep, with no cycle; they may not emit nor be
//!   masked (an `opacity` below 1, or a texture): a surface's emission and opacity are the
//!   outer material's, whichever side scatters;
//! - `emit` (vector, components >= 0, default 0): radiance it emits, on the
//!   side its normal faces, as `lambertian`'s;
//! - `opacity` (number in [0, 1], or a texture; default 1), as on every material.
//!
//! The kernel picks the side's material at the hit, before anything else is
//! done there (`resolve_material`, materials.wgsl, under the kernel flag
//! `NESTED_MATERIALS`), so every strategy sees that material alone; the light
//! density and emission are the outer material's. Mitsuba's `twosided` with
//! one BSDF is that BSDF's material with `one_sided = false`; with two, this
//! kind. Packed: the two materials' indices in `color2.xy` (as floats,
//! `kinds::packed_nested`), set by `SceneData::pack`. No WGSL module.

use super::common::TextureSlot;
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_nonneg};
use glam::Vec3;

pub(super) const TWOSIDED: MaterialModel = MaterialModel {
    name: "twosided",
    module: None,
    helpers: &[],
    lobe: Lobe::Absorbing,
    tables: false,
    keys: &["type", "front", "back", "emit"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &["front", "back"],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, _: &mut TextureSlot) -> Result<Parsed> {
    Ok(Parsed {
        kind: MaterialKind::TwoSided,
        albedo: Vec3::ZERO,
        emit: t.vec3("emit", check_nonneg)?.unwrap_or(Vec3::ZERO),
    })
}

fn pack(_: &Material, _: &mut MaterialTables) -> PackedMaterial {
    PackedMaterial::default()
}

#[cfg(test)]
mod tests {
    use super::super::read;
    use super::*;

    #[test]
    fn reads_its_two_materials_by_name() {
        let m = read("type = \"twosided\"\nfront = \"a\"\nback = \"b\"").unwrap();
        assert_eq!(m.kind, MaterialKind::TwoSided);
        assert_eq!(m.nested, ["a", "b"]);
        assert!(!m.emits());
        let e = read("type = \"twosided\"\nfront = \"a\"").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: materials.red: missing required key `back`"
        );
        let e = read("type = \"twosided\"\nfront = \"a\"\nback = \"b\"\nalbedo = [1, 1, 1]")
            .unwrap_err();
        assert!(e.message.contains("unknown key `albedo`"), "{e}");
    }
}
