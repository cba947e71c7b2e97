//! `principled`: Mitsuba 3's `principled`, the Disney BSDF as Blender's
//! Principled BSDF exports it (`src/bsdfs/principled.cpp`), term for term. A
//! mixture of lobes: a diffuse one (Burley's, with retro-reflection, blended
//! toward Hanrahan-Krueger's fake subsurface by `flatness`), a sheen, a
//! specular reflection (anisotropic GGX, with Fresnel blended between the
//! dielectric's, a Schlick metal and a tint), a specular transmission through
//! the same microfacets (rough glass, seen from both sides) and a clearcoat
//! (GTR1, Schlick at 0.04). Sampling picks the diffuse lobe (cosine), the
//! clearcoat (GTR1 normals) or the specular pair (visible GGX normals, then
//! reflection or transmission by the Fresnel reflectance) with Mitsuba's
//! probabilities, and the density is the whole mixture's: one `Lobe::Smooth`
//! kind to every strategy.
//!
//! - `base_color` (default 0.5, or a texture);
//! - `roughness` (default 0.5), `anisotropic` (0), `metallic` (0),
//!   `spec_trans` (0), `spec_tint` (0), `sheen` (0), `sheen_tint` (0),
//!   `clearcoat` (0), `clearcoat_gloss` (0), `flatness` (0): numbers in [0, 1];
//! - `eta` (> 0), or `specular` (in [0, 12.5), default 0.5: `eta` = 2 / (1 -
//!   sqrt(0.08 specular)) - 1), not both. As in Mitsuba, a transmitting
//!   material (`spec_trans` not 0) of index 1 takes 1.001, and one of
//!   `specular` 0 takes 1e-3.
//!
//! As Mitsuba: the surface is seen from behind only where it transmits
//! (reflection and transmission by the dielectric's Fresnel alone there),
//! roughness maps to alpha = max(0.001, roughness^2) (divided and multiplied
//! by sqrt(1 - 0.9 anisotropic) along the shading frame's tangents), and the
//! clearcoat's alpha runs from 0.1 to 0.001 as `clearcoat_gloss` goes from 0
//! to 1. The sheen is added wherever it is active, as Mitsuba's vectorised
//! variants (`llvm_*`, `cuda_*`) add it; its scalar ones skip it where the
//! diffuse lobe is off (`spec_trans` 1). Mitsuba's sampling-rate parameters
//! are not read. The lobes are not energy-conserving together (the Disney
//! model's known loss and gain, measured by `tests/bsdf.rs`: a white diffuse
//! lobe alone reflects (1 - F_i / 2)(1 - 1/42), 0.976 at normal incidence
//! and 0.788 at 80 degrees; a white default material with sheen and
//! clearcoat 1.07 and 1.22).
//!
//! Each number in [0, 1] above may be a texture instead, as in Mitsuba (`eta`
//! and `specular` may not): `roughness = { type = "bitmap", file =
//! "rough.png", raw = true }`, read at the hit as one number as Mitsuba's
//! `eval_1` reads it (a bitmap's luminance, a checkerboard colour's mean over
//! its channels), unchecked, as Mitsuba leaves it, and the same for the
//! BSDF's sampling and its density there.
//!
//! Packed: `albedo` = base_color, `param` = roughness, `param2` = the offset
//! of its four numbers in `MaterialTables` (anisotropic, spec_tint,
//! sheen_tint, flatness), `color2` = (metallic, spec_trans, eta), `color3` =
//! (sheen, clearcoat, clearcoat_gloss); a textured number packs its
//! texture's mean there, and the kernel reads the texture instead
//! (`material_number`). WGSL: `shaders/principled.wgsl`.

use super::common::{DISNEY, FRESNEL, MICROFACET, TextureSlot};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_positive, check_unit, fmt_num};
use crate::shader::shader_module;

/// Its numbers in [0, 1], each of which may be a texture: a number's slot
/// (`MaterialModel::textured_numbers`) is its place here ...
const WEIGHTS: [&str; 10] = [
    "roughness",
    "anisotropic",
    "metallic",
    "spec_trans",
    "spec_tint",
    "sheen",
    "sheen_tint",
    "clearcoat",
    "clearcoat_gloss",
    "flatness",
];

/// ... and Mitsuba's defaults.
const DEFAULTS: [f32; 10] = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

pub(super) const PRINCIPLED: MaterialModel = MaterialModel {
    name: "principled",
    module: Some(shader_module!("principled")),
    helpers: &[FRESNEL, MICROFACET, DISNEY],
    lobe: Lobe::Smooth,
    tables: true,
    keys: &[
        "type",
        "base_color",
        "roughness",
        "anisotropic",
        "metallic",
        "spec_trans",
        "eta",
        "specular",
        "spec_tint",
        "sheen",
        "sheen_tint",
        "clearcoat",
        "clearcoat_gloss",
        "flatness",
    ],
    keys_note: None,
    textured_numbers: &WEIGHTS,
    mitsuba: Some(MitsubaPlugin {
        name: "principled",
        texture: Some("base_color"),
        numbers: &[
            "roughness",
            "anisotropic",
            "metallic",
            "spec_trans",
            "eta",
            "specular",
            "spec_tint",
            "sheen",
            "sheen_tint",
            "clearcoat",
            "clearcoat_gloss",
            "flatness",
        ],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: true,
    parse,
    pack,
};

/// The largest `specular`: its index 2 / (1 - sqrt(0.08 specular)) - 1 is
/// finite below it.
const MAX_SPECULAR: f32 = 12.5;

fn check_specular(x: f32) -> std::result::Result<(), String> {
    if (0.0..MAX_SPECULAR).contains(&x) {
        Ok(())
    } else {
        Err(format!(
            "must be in [0, 12.5) (its index of refraction is finite there), got {}",
            fmt_num(x)
        ))
    }
}

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let mut weights = [0.0f32; WEIGHTS.len()];
    for ((weight, key), default) in weights.iter_mut().zip(WEIGHTS).zip(DEFAULTS) {
        *weight = slot.number(t, key, check_unit)?.unwrap_or(default);
    }
    let [
        roughness,
        anisotropic,
        metallic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        clearcoat,
        clearcoat_gloss,
        flatness,
    ] = weights;
    // Mitsuba's `has_spec_trans`: a texture transmits wherever it is not 0.
    let transmits = spec_trans != 0.0 || slot.is_textured("spec_trans");
    let eta = match (
        t.float("eta", check_positive)?,
        t.float("specular", check_specular)?,
    ) {
        (Some(_), Some(_)) => {
            return Err(t.err(
                t.at("specular"),
                "give either `eta` or `specular` (its Schlick equivalent), not both",
            ));
        }
        (Some(eta), None) if transmits && eta == 1.0 => 1.001,
        (Some(eta), None) => eta,
        (None, specular) => {
            let specular = match specular.unwrap_or(0.5) {
                0.0 if transmits => 1e-3,
                s => s,
            };
            2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
        }
    };
    Ok(MaterialKind::Principled {
        base_color: slot.colour(t, "base_color", 0.5)?,
        roughness,
        anisotropic,
        metallic,
        spec_trans,
        eta,
        spec_tint,
        sheen,
        sheen_tint,
        clearcoat,
        clearcoat_gloss,
        flatness,
    }
    .into())
}

fn pack(material: &Material, tables: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Principled {
        base_color,
        roughness,
        anisotropic,
        metallic,
        spec_trans,
        eta,
        spec_tint,
        sheen,
        sheen_tint,
        clearcoat,
        clearcoat_gloss,
        flatness,
    } = material.kind
    else {
        unreachable!("PRINCIPLED packs principled materials")
    };
    let offset = tables.push(&[anisotropic, spec_tint, sheen_tint, flatness]);
    PackedMaterial {
        albedo: base_color.to_array(),
        param: roughness,
        param2: offset as f32,
        color2: [metallic, spec_trans, eta],
        color3: [sheen, clearcoat, clearcoat_gloss],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;
    use glam::Vec3;

    #[test]
    fn reads_mitsubas_defaults_and_its_specular() {
        let m = read("type = \"principled\"").unwrap();
        let MaterialKind::Principled {
            base_color,
            roughness,
            eta,
            ..
        } = m.kind
        else {
            panic!("{:?}", m.kind)
        };
        assert_eq!((base_color, roughness), (Vec3::splat(0.5), 0.5));
        // specular 0.5: eta = 2 / (1 - sqrt(0.04)) - 1 = 1.5.
        assert!((eta - 1.5).abs() < 1e-6, "{eta}");
        let glass = read("type = \"principled\"\nspec_trans = 1\neta = 1").unwrap();
        assert!(matches!(glass.kind, MaterialKind::Principled { eta, .. } if eta == 1.001));
        let mut tables = MaterialTables::default();
        let packed = pack_material(
            &read("type = \"principled\"\nanisotropic = 0.3\nflatness = 0.7").unwrap(),
            &mut tables,
        );
        assert_eq!(packed.param2, 0.0);
        assert_eq!(tables.values, [0.3, 0.0, 0.0, 0.7]);
        let e = read("type = \"principled\"\nsheen = 1.5").unwrap_err();
        assert_eq!(e.location, "materials.red.sheen");
        assert!(e.message.contains("must be in [0, 1], got 1.5"), "{e}");
        let e = read("type = \"principled\"\neta = 1.4\nspecular = 0.3").unwrap_err();
        assert!(e.message.contains("not both"), "{e}");
    }

    /// A number may be a texture, kept by its slot with its mean packed; a
    /// textured `spec_trans` transmits (Mitsuba's `has_spec_trans`) even where
    /// its mean is 0; `eta` takes numbers only, as in Mitsuba.
    #[test]
    fn numbers_may_be_textures() {
        let checks = "{ type = \"checkerboard\", color0 = 0.8, color1 = 0.2 }";
        let m = read(&format!(
            "type = \"principled\"\nmetallic = {checks}\nclearcoat = 0.5"
        ))
        .unwrap();
        let MaterialKind::Principled { metallic, .. } = m.kind else {
            panic!("{:?}", m.kind)
        };
        assert!((metallic - 0.5).abs() < 1e-6, "{metallic}");
        let slots: Vec<u32> = m.number_textures.iter().map(|n| n.slot).collect();
        assert_eq!(slots, [2]);
        assert_eq!(WEIGHTS[2], "metallic");
        let black = "{ type = \"checkerboard\", color0 = 0, color1 = 0 }";
        let glass = read(&format!(
            "type = \"principled\"\nspec_trans = {black}\neta = 1"
        ))
        .unwrap();
        assert!(matches!(glass.kind, MaterialKind::Principled { eta, .. } if eta == 1.001));
        let e = read(&format!("type = \"principled\"\neta = {checks}")).unwrap_err();
        assert_eq!(e.location, "materials.red.eta");
    }
}
