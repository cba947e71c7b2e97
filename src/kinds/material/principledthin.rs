//! `principledthin`: Mitsuba 3's `principledthin`
//! (`src/bsdfs/principledthin.cpp`), term for term: the principled BSDF of a
//! thin sheet (a leaf, paper, a curtain), the same from both sides. A mixture
//! of a GGX reflection (the dielectric's Fresnel blended toward a tinted
//! Schlick by `spec_tint`) and a GGX transmission straight through the sheet
//! (roughness scaled by 0.65 eta - 0.35), weighted by `spec_trans`; and
//! Burley's diffuse with retro-reflection (toward the fake subsurface by
//! `flatness`), the sheen, and a diffuse transmission, weighted by
//! 1 - `spec_trans`. Sampled with Mitsuba's lobe probabilities, the density
//! the whole mixture's: one `Lobe::Smooth` kind to every strategy.
//!
//! - `base_color` (default 0.5, or a texture);
//! - `roughness` (default 0.5), `anisotropic`, `spec_trans`, `spec_tint`,
//!   `sheen`, `sheen_tint`, `flatness` (default 0): numbers in [0, 1];
//! - `diff_trans` (in [0, 2], default 0: the diffuse transmission's share of
//!   the diffuse lobes is half of it, as in Mitsuba);
//! - `eta` (> 0, default 1.5): the sheet's index.
//!
//! Each number above may be a texture instead, as in Mitsuba (`eta` too):
//! `diff_trans = { type = "checkerboard", color0 = 1, color1 = 0.2 }`, read
//! at the hit as one number as Mitsuba's `eval_1` reads it (a bitmap's
//! luminance, a checkerboard colour's mean over its channels), unchecked, as
//! Mitsuba leaves it. Mitsuba's sampling-rate parameters are not read.
//!
//! Packed: `albedo` = base_color, `param` = roughness, `param2` = the offset
//! of its four numbers in `MaterialTables` (anisotropic, spec_tint,
//! sheen_tint, flatness), `color2` = (spec_trans, eta, diff_trans / 2),
//! `color3.x` = sheen; a textured number packs its texture's mean there, and
//! the kernel reads the texture instead (`material_number`). WGSL:
//! `shaders/principledthin.wgsl`.

use super::common::{DISNEY, FRESNEL, MICROFACET, TextureSlot};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_positive, check_unit, fmt_num};
use crate::shader::shader_module;

/// Its parameters that are numbers in [0, 1], with Mitsuba's defaults.
const WEIGHTS: [(&str, f32); 7] = [
    ("roughness", 0.5),
    ("anisotropic", 0.0),
    ("spec_trans", 0.0),
    ("spec_tint", 0.0),
    ("sheen", 0.0),
    ("sheen_tint", 0.0),
    ("flatness", 0.0),
];

/// The numbers that may be textures, as in Mitsuba: the weights, the index
/// and `diff_trans`; a number's slot is its place here.
const TEXTURED: [&str; 9] = [
    "roughness",
    "anisotropic",
    "spec_trans",
    "spec_tint",
    "sheen",
    "sheen_tint",
    "flatness",
    "eta",
    "diff_trans",
];

pub(super) const PRINCIPLEDTHIN: MaterialModel = MaterialModel {
    name: "principledthin",
    module: Some(shader_module!("principledthin")),
    helpers: &[FRESNEL, MICROFACET, DISNEY],
    lobe: Lobe::Smooth,
    tables: true,
    keys: &[
        "type",
        "base_color",
        "roughness",
        "anisotropic",
        "spec_trans",
        "eta",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "flatness",
        "diff_trans",
    ],
    keys_note: None,
    textured_numbers: &TEXTURED,
    mitsuba: Some(MitsubaPlugin {
        name: "principledthin",
        texture: Some("base_color"),
        numbers: &[
            "roughness",
            "anisotropic",
            "spec_trans",
            "eta",
            "spec_tint",
            "sheen",
            "sheen_tint",
            "flatness",
            "diff_trans",
        ],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: true,
    parse,
    pack,
};

fn check_diff_trans(x: f32) -> std::result::Result<(), String> {
    if (0.0..=2.0).contains(&x) {
        Ok(())
    } else {
        Err(format!("must be in [0, 2], got {}", fmt_num(x)))
    }
}

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let mut weights = [0.0f32; WEIGHTS.len()];
    for (weight, (key, default)) in weights.iter_mut().zip(WEIGHTS) {
        *weight = slot.number(t, key, check_unit)?.unwrap_or(default);
    }
    let [
        roughness,
        anisotropic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
    ] = weights;
    Ok(MaterialKind::PrincipledThin {
        base_color: slot.colour(t, "base_color", 0.5)?,
        roughness,
        anisotropic,
        spec_trans,
        eta: slot.number(t, "eta", check_positive)?.unwrap_or(1.5),
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        diff_trans: (slot.number(t, "diff_trans", check_diff_trans)?).unwrap_or(0.0),
    }
    .into())
}

fn pack(material: &Material, tables: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::PrincipledThin {
        base_color,
        roughness,
        anisotropic,
        spec_trans,
        eta,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        diff_trans,
    } = material.kind
    else {
        unreachable!("PRINCIPLEDTHIN packs thin principled materials")
    };
    let offset = tables.push(&[anisotropic, spec_tint, sheen_tint, flatness]);
    PackedMaterial {
        albedo: base_color.to_array(),
        param: roughness,
        param2: offset as f32,
        color2: [spec_trans, eta, diff_trans / 2.0],
        color3: [sheen, 0.0, 0.0],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::read;
    use super::*;

    #[test]
    fn reads_mitsubas_defaults_and_ranges() {
        let m = read("type = \"principledthin\"").unwrap();
        assert!(matches!(
            m.kind,
            MaterialKind::PrincipledThin {
                roughness: 0.5,
                eta: 1.5,
                diff_trans: 0.0,
                ..
            }
        ));
        let packed = super::super::pack_material(
            &read("type = \"principledthin\"\ndiff_trans = 1.5").unwrap(),
            &mut MaterialTables::default(),
        );
        assert_eq!(packed.color2[2], 0.75);
        let e = read("type = \"principledthin\"\ndiff_trans = 2.5").unwrap_err();
        assert_eq!(e.location, "materials.red.diff_trans");
        assert!(e.message.contains("must be in [0, 2], got 2.5"), "{e}");
    }
}
