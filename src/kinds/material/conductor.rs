//! `conductor`: Mitsuba 3's smooth conductor, a mirror with the Fresnel
//! reflectance of the complex index `eta + i k` (per RGB channel), times
//! `specular_reflectance`.
//!
//! - `eta`, `k` (colours >= 0: a vector, or one number for grey; defaults 0
//!   and 1, Mitsuba's `none`: reflectance 1 at every angle); or instead
//!   `material`, one of Mitsuba's measured conductors by name (`"Au"`, `"Cu"`,
//!   ..., `NAMED_CONDUCTORS`), with the RGB `eta` and `k` Mitsuba 3's RGB
//!   variants use for it. `material` with `eta` or `k` is an error;
//! - `specular_reflectance` (colour in [0, 1], default 1), or a texture;
//! - `one_sided` (bool, default false): black from behind.
//!
//! Packed: `albedo` = specular_reflectance, `color2` = eta, `color3` = k
//! (each at most `MAX_CONDUCTOR_INDEX`). WGSL: `shaders/conductor.wgsl`.

use super::common::{FRESNEL, TextureSlot, conductor_index, conductor_ior};
use super::{Lobe, Material, MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, Parsed};
use crate::abi::PackedMaterial;
use crate::kinds::params::{ParamTable, Result};
use crate::shader::shader_module;

pub(super) const CONDUCTOR: MaterialModel = MaterialModel {
    name: "conductor",
    module: Some(shader_module!("conductor")),
    helpers: &[FRESNEL],
    lobe: Lobe::Delta,
    tables: false,
    keys: &[
        "type",
        "material",
        "eta",
        "k",
        "specular_reflectance",
        "one_sided",
    ],
    keys_note: None,
    textured_numbers: &[],
    mitsuba: Some(MitsubaPlugin {
        name: "conductor",
        texture: Some("specular_reflectance"),
        numbers: &[],
    }),
    nested: &[],
    diffuse_reflectance_is_albedo: false,
    parse,
    pack,
};

fn parse(t: &ParamTable, slot: &mut TextureSlot) -> Result<Parsed> {
    let (eta, k) = conductor_ior(t)?;
    let specular_reflectance = slot.colour(t, "specular_reflectance", 1.0)?;
    Ok(MaterialKind::Conductor {
        eta,
        k,
        specular_reflectance,
    }
    .into())
}

fn pack(material: &Material, _: &mut MaterialTables) -> PackedMaterial {
    let MaterialKind::Conductor {
        eta,
        k,
        specular_reflectance,
    } = material.kind
    else {
        unreachable!("CONDUCTOR packs conductors")
    };
    PackedMaterial {
        albedo: specular_reflectance.to_array(),
        color2: conductor_index(eta),
        color3: conductor_index(k),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::common::{MAX_CONDUCTOR_INDEX, NAMED_CONDUCTORS};
    use super::super::{Distribution, pack_material, read};
    use super::*;
    use glam::Vec3;

    fn kind(body: &str) -> MaterialKind {
        read(body).unwrap().kind
    }

    #[test]
    fn reads_mitsubas_defaults_and_named_conductors() {
        assert_eq!(
            kind("type = \"conductor\""),
            MaterialKind::Conductor {
                eta: Vec3::ZERO,
                k: Vec3::ONE,
                specular_reflectance: Vec3::ONE
            }
        );
        for (name, eta, k) in [
            NAMED_CONDUCTORS[0],
            NAMED_CONDUCTORS[5],
            NAMED_CONDUCTORS[37],
        ] {
            assert_eq!(
                kind(&format!("type = \"conductor\"\nmaterial = \"{name}\"")),
                MaterialKind::Conductor {
                    eta: Vec3::from_array(eta),
                    k: Vec3::from_array(k),
                    specular_reflectance: Vec3::ONE
                },
                "{name}"
            );
        }
        assert_eq!(
            kind("type = \"roughconductor\"\nmaterial = \"Cu\"\nalpha = 0.3"),
            MaterialKind::RoughConductor {
                distribution: Distribution::Beckmann,
                alpha_u: 0.3,
                alpha_v: 0.3,
                eta: Vec3::new(0.20100547, 0.9237495, 1.1022154),
                k: Vec3::new(3.9132621, 2.4530451, 2.1420898),
                specular_reflectance: Vec3::ONE,
            }
        );
        // `none` is Mitsuba's default: the perfect conductor.
        assert_eq!(
            kind("type = \"conductor\"\nmaterial = \"none\""),
            kind("type = \"conductor\"")
        );
    }

    #[test]
    fn packs_an_index_the_kernel_can_evaluate() {
        let m = read("type = \"conductor\"\neta = 1e30\nk = [1, 2, 3]\nspecular_reflectance = 0.5")
            .unwrap();
        let packed = pack_material(&m, &mut MaterialTables::default());
        assert_eq!(packed.albedo, [0.5; 3]);
        assert_eq!(packed.color2, [MAX_CONDUCTOR_INDEX; 3]);
        assert_eq!(packed.color3, [1.0, 2.0, 3.0]);
    }
}
