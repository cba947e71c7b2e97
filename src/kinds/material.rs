//! Material kinds. Every material packs into one `gpu::layout::Material`
//! (albedo, emission and one parameter); a kind says how its parameter is
//! read and which BSDF lobes its WGSL module implements.

use crate::scene;
use crate::shader::{ShaderModule, shader_module};

/// What a material kind's BSDF is made of (the interface is in materials.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// A density over directions: the module defines `NAME_eval`, `NAME_pdf` and
    /// `NAME_sample`, and every strategy applies (light sampling, mixtures, MIS).
    Smooth,
    /// Specular, or with no density to evaluate: the module defines only
    /// `NAME_sample`, and a path follows it whatever the strategy.
    Delta,
    /// Scatters nothing: no module, a path ends there after its emission.
    Absorbing,
}

pub struct MaterialKind {
    /// Lower case, as in scene files: the module's name and its functions'
    /// prefix; the kernel's flag is `NAME` and its id constant `MATERIAL_NAME`.
    pub name: &'static str,
    pub module: Option<ShaderModule>,
    pub lobe: Lobe,
}

impl MaterialKind {
    pub fn flag(&self) -> String {
        self.name.to_uppercase()
    }

    /// The WGSL constant holding its id (its index in [`MATERIAL_KINDS`]).
    pub fn id_constant(&self) -> String {
        format!("MATERIAL_{}", self.flag())
    }
}

/// Every material kind; a kind's id in the packed material is its index.
pub const MATERIAL_KINDS: &[MaterialKind] = &[
    MaterialKind {
        name: "lambertian",
        module: Some(shader_module!("lambertian")),
        lobe: Lobe::Smooth,
    },
    MaterialKind {
        name: "metal",
        module: Some(shader_module!("metal")),
        // The book's fuzzed mirror has no closed-form density.
        lobe: Lobe::Delta,
    },
    MaterialKind {
        name: "dielectric",
        module: Some(shader_module!("dielectric")),
        lobe: Lobe::Delta,
    },
    MaterialKind {
        name: "light",
        module: None,
        lobe: Lobe::Absorbing,
    },
];

/// The kind of a scene material (its index in [`MATERIAL_KINDS`]) and its
/// packed parameter.
pub fn material_kind(kind: &scene::MaterialKind) -> (usize, f32) {
    let (name, param) = match *kind {
        scene::MaterialKind::Lambertian => ("lambertian", 0.0),
        scene::MaterialKind::Metal { fuzz } => ("metal", fuzz),
        scene::MaterialKind::Dielectric { ior } => ("dielectric", ior),
        scene::MaterialKind::Light => ("light", 0.0),
    };
    let id = MATERIAL_KINDS
        .iter()
        .position(|k| k.name == name)
        .expect("every scene material kind is described");
    (id, param)
}
