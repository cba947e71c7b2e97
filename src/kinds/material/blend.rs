//! `blend`: a linear blend of two materials (Mitsuba's `blendbsdf`): the BSDF
//! `(1 - weight) f_first + weight f_second`.
//!
//! ```toml
//! [materials.worn]
//! type = "blend"
//! weight = { type = "bitmap", file = "wear.png" }   # or a number
//! first = "paint"
//! second = "metal"
//! ```
//!
//! - `first`, `second` (strings, required): names of `[materials.NAME]`
//!   tables, as for `twosided`: any kind, at most `MATERIAL_NESTING` (4) deep,
//!   no cycle, neither emitting nor masked;
//! - `weight` (number in [0, 1], default 0.5, Mitsuba's), or a texture whose
//!   value as a number is the weight where a ray hits (Mitsuba's `eval_1`: an
//!   RGB bitmap's luminance, a checkerboard's colours swapped, each its
//!   channels' mean; keep its texels in [0, 1]): 0 is `first` alone, 1
//!   `second` alone;
//! - `emit` (vector, components >= 0, default 0), as `lambertian`'s;
//! - `opacity` (number in [0, 1], or a texture; default 1), as on every material.
//!
//! The blend is resolved at the hit, as pbrt-v4's `MixMaterial` resolves its
//! own: the kernel picks `second` with probability `weight` and `first`
//! otherwise (one random number of the path's sampler per hit, however deep the
//! blends nest: a nested blend reuses the rest of it), and the path goes on
//! with the material picked alone, its sampling, density and MIS. Its expected
//! contribution is the blended BSDF's, so the estimate is unbiased; it is
//! noisier than evaluating both where the two differ much. Under the kernel
//! flag `NESTED_MATERIALS` (`resolve_material`, materials.wgsl). Packed: the
//! constant weight in `param` (a texture's: its mean as a number), the
//! two materials' indices in `color2.xy` (as floats, `kinds::packed_nested`,
//! set by `SceneData::pack`), the texture as every kind's. No WGSL module.

use super::common::TextureSlot;
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result, check_nonneg, check_unit};
use glam::Vec3;

pub(super) const BLEND: MaterialModel = MaterialModel {
    name: "blend",
    module: None,
    helpers: &[],
    lobe: Lobe::Absorbing,
    tables: false,
    keys: &["type", "weight", "first", "second", "emit"],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: None,
    nested: &["first", "second"],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let weight = match slot.texture(t, "weight")? {
        Some(_) => slot.texture.as_ref().expect("kept").mean_number(),
        None => t.float("weight", check_unit)?.unwrap_or(0.5),
    };
    Ok(Parsed {
        kind: MaterialKind::Blend { weight },
        albedo: Vec3::ZERO,
        emit: t.vec3("emit", check_nonneg)?.unwrap_or(Vec3::ZERO),
    })
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Blend { weight } = material.kind else {
        unreachable!("a blend material")
    };
    PackedMaterial {
        param: weight,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::{pack_material, read};
    use super::*;

    #[test]
    fn reads_its_weight_and_two_materials() {
        let m = read("type = \"blend\"\nweight = 0.25\nfirst = \"a\"\nsecond = \"b\"").unwrap();
        assert_eq!(m.kind, MaterialKind::Blend { weight: 0.25 });
        assert_eq!(m.nested, ["a", "b"]);
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!(packed.param, 0.25);
        let m = read("type = \"blend\"\nfirst = \"a\"\nsecond = \"b\"").unwrap();
        assert_eq!(m.kind, MaterialKind::Blend { weight: 0.5 });
        let e = read("type = \"blend\"\nweight = 1.5\nfirst = \"a\"\nsecond = \"b\"").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: materials.red.weight: must be in [0, 1], got 1.5"
        );
        let e = read("type = \"blend\"\nfirst = \"a\"").unwrap_err();
        assert!(e.message.contains("missing required key `second`"), "{e}");
    }
}
