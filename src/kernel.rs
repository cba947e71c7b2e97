//! What the compute kernel contains for a given scene and run: the WGSL modules
//! and flags (code for absent features is not compiled in) and the pipeline
//! constants. Device-free, so every variant is validated by naga in `cargo test`.

use crate::gpu::layout::{
    GpuLayout, MATERIAL_DIELECTRIC, MATERIAL_LAMBERTIAN, MATERIAL_METAL, SceneData,
};
use crate::scene::{RenderSettings, Sampler, Strategy};
use crate::shader::{ArrayForm, ComposeError, Directives, ShaderModule, compose, element_constant};
use std::collections::{BTreeMap, BTreeSet};

macro_rules! shader_module {
    ($name:literal) => {
        ShaderModule {
            name: $name,
            source: include_str!(concat!("../shaders/", $name, ".wgsl")),
        }
    };
}

pub const COMMON: ShaderModule = shader_module!("common");
pub const RNG: ShaderModule = shader_module!("rng");
pub const SAMPLING: ShaderModule = shader_module!("sampling");
pub const QUAD: ShaderModule = shader_module!("quad");
pub const SPHERE: ShaderModule = shader_module!("sphere");
pub const SCENE: ShaderModule = shader_module!("scene");
pub const LIGHTS: ShaderModule = shader_module!("lights");
pub const MATERIALS: ShaderModule = shader_module!("materials");
pub const ACCUMULATE_TEXTURE: ShaderModule = shader_module!("accumulate_texture");
pub const ACCUMULATE_BUFFER: ShaderModule = shader_module!("accumulate_buffer");
pub const KERNEL: ShaderModule = shader_module!("kernel");

/// Every flag a module may test.
pub const FLAGS: &[&str] = &[
    "QUADS",
    "SPHERES",
    "LIGHT_QUADS",
    "LIGHT_SPHERES",
    "LAMBERTIAN",
    "METAL",
    "DIELECTRIC",
    "STRATEGY_COSINE",
    "STRATEGY_LIGHT",
    "STRATEGY_NEE",
    "VARIANCE",
    "BAKED_SCENE",
    "SAMPLER_SOBOL",
];

pub const ENTRY_POINT: &str = "render";
pub const WORKGROUP_SIZE: (u32, u32) = (8, 8);

/// Where the running sums live.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AccumulatorKind {
    /// A read-write `rgba32float` storage texture array (adapter-specific feature).
    Texture,
    /// A storage buffer: works on every adapter.
    Buffer,
}

/// Where the kernel reads the scene from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneStorage {
    /// Compiled into the kernel as module constants: no loads, and every loop
    /// over the scene unrolled into straight-line code the driver's compiler folds.
    Baked,
    /// Read-only storage buffers (group 1): any size, one kernel per feature set.
    Buffers,
}

impl SceneStorage {
    /// Largest scene baked by default: primitives plus objects in the light
    /// density. Measured on lavapipe with random quads, a baked kernel renders
    /// 7-8x faster than buffers at 32 to 128 objects; its first compile (without
    /// Mesa's shader cache) takes 0.3 CPU-s at 32 objects, 0.5 at 64, 1.5 at 128
    /// and 5.3 at 256, where it also renders slower than buffers.
    pub const MAX_BAKED_OBJECTS: usize = 128;

    /// Baked for small scenes, buffers for the rest.
    pub fn auto(data: &SceneData) -> SceneStorage {
        let objects = data.quads.len() + data.spheres.len() + data.light_count();
        if objects <= Self::MAX_BAKED_OBJECTS && data.is_finite() {
            SceneStorage::Baked
        } else {
            SceneStorage::Buffers
        }
    }
}

/// Bindings of group 1, the scene (storage buffers only). Present only when the kernel declares them.
pub const BINDING_MATERIALS: u32 = 0;
pub const BINDING_QUADS: u32 = 1;
pub const BINDING_SPHERES: u32 = 2;
pub const BINDING_LIGHT_QUADS: u32 = 3;
pub const BINDING_LIGHT_SPHERES: u32 = 4;

#[derive(Clone, Debug, PartialEq)]
pub struct KernelConfig {
    pub quads: bool,
    pub spheres: bool,
    pub lambertian: bool,
    pub metal: bool,
    pub dielectric: bool,
    /// The light density is sampled (a Lambertian surface exists and the strategy uses it).
    pub light_quads: bool,
    pub light_spheres: bool,
    pub strategy: Strategy,
    pub max_depth: u32,
    pub light_weight: f32,
    /// Russian roulette from this depth on, or never.
    pub rr_depth: Option<u32>,
    pub sampler: Sampler,
    pub accumulator: AccumulatorKind,
    /// Accumulate squared samples too, for per-pixel error estimates.
    pub variance: bool,
    /// The scene compiled into the kernel (`SceneStorage::Baked`), or `None`
    /// to read it from storage buffers.
    pub baked_scene: Option<SceneData>,
}

impl KernelConfig {
    /// The kernel for `data`; `strategy` must have objects to aim at unless it is cosine.
    pub fn for_scene(
        data: &SceneData,
        strategy: Strategy,
        settings: &RenderSettings,
        accumulator: AccumulatorKind,
        variance: bool,
        scene_storage: SceneStorage,
    ) -> KernelConfig {
        let lambertian = data.uses_material(MATERIAL_LAMBERTIAN);
        let samples_lights = lambertian && strategy != Strategy::Cosine;
        KernelConfig {
            quads: !data.quads.is_empty(),
            spheres: !data.spheres.is_empty(),
            lambertian,
            metal: data.uses_material(MATERIAL_METAL),
            dielectric: data.uses_material(MATERIAL_DIELECTRIC),
            light_quads: samples_lights && !data.light_quads.is_empty(),
            light_spheres: samples_lights && !data.light_spheres.is_empty(),
            strategy,
            max_depth: settings.max_depth,
            light_weight: settings.light_weight,
            rr_depth: settings.rr_depth,
            sampler: settings.sampler,
            accumulator,
            variance,
            baked_scene: (scene_storage == SceneStorage::Baked).then(|| data.clone()),
        }
    }

    /// This kernel with every primitive and material kind compiled in, as a kernel
    /// not specialised to the scene would be (for measuring what specialising saves).
    /// The light density stays as the scene needs it: it changes the estimator.
    pub fn generalized(self) -> KernelConfig {
        KernelConfig {
            quads: true,
            spheres: true,
            lambertian: true,
            metal: true,
            dielectric: true,
            ..self
        }
    }

    /// Everything compiled in: the kernel any scene could use.
    pub fn general(strategy: Strategy, accumulator: AccumulatorKind) -> KernelConfig {
        KernelConfig {
            quads: true,
            spheres: true,
            lambertian: true,
            metal: true,
            dielectric: true,
            light_quads: strategy != Strategy::Cosine,
            light_spheres: strategy != Strategy::Cosine,
            strategy,
            max_depth: 50,
            light_weight: 0.5,
            rr_depth: Some(5),
            sampler: Sampler::Sobol,
            accumulator,
            variance: true,
            baked_scene: None,
        }
    }

    pub fn scene_storage(&self) -> SceneStorage {
        match self.baked_scene {
            Some(_) => SceneStorage::Baked,
            None => SceneStorage::Buffers,
        }
    }

    pub fn samples_lights(&self) -> bool {
        self.light_quads || self.light_spheres
    }

    pub fn flags(&self) -> BTreeSet<&'static str> {
        let pairs = [
            ("QUADS", self.quads),
            ("SPHERES", self.spheres),
            ("LIGHT_QUADS", self.light_quads),
            ("LIGHT_SPHERES", self.light_spheres),
            ("LAMBERTIAN", self.lambertian),
            ("METAL", self.metal),
            ("DIELECTRIC", self.dielectric),
            ("STRATEGY_COSINE", self.strategy == Strategy::Cosine),
            ("STRATEGY_LIGHT", self.strategy == Strategy::Light),
            ("STRATEGY_NEE", self.strategy == Strategy::NeeMis),
            ("VARIANCE", self.variance),
            ("BAKED_SCENE", self.baked_scene.is_some()),
            ("SAMPLER_SOBOL", self.sampler == Sampler::Sobol),
        ];
        pairs
            .into_iter()
            .filter(|&(_, on)| on)
            .map(|(flag, _)| flag)
            .collect()
    }

    pub fn modules(&self) -> Vec<ShaderModule> {
        let mut modules = vec![COMMON, RNG, SAMPLING];
        if self.quads || self.light_quads {
            modules.push(QUAD);
        }
        if self.spheres || self.light_spheres {
            modules.push(SPHERE);
        }
        modules.push(SCENE);
        if self.samples_lights() {
            modules.push(LIGHTS);
        }
        modules.push(MATERIALS);
        modules.push(match self.accumulator {
            AccumulatorKind::Texture => ACCUMULATE_TEXTURE,
            AccumulatorKind::Buffer => ACCUMULATE_BUFFER,
        });
        modules.push(KERNEL);
        modules
    }

    pub fn source(&self) -> Result<String, ComposeError> {
        let flags = self.flags();
        let arrays = self.arrays();
        let directives = Directives {
            flags: &flags,
            known_flags: FLAGS,
            arrays: &arrays,
        };
        let mut source = compose(&self.modules(), &directives)?;
        if let Some(data) = &self.baked_scene {
            source.push_str(&self.baked_scene_wgsl(data));
        }
        Ok(source)
    }

    /// The scene arrays this kernel has, and where `#for_each` finds their elements.
    fn arrays(&self) -> BTreeMap<&'static str, ArrayForm> {
        let baked = self.baked_scene.as_ref();
        let form = |len: fn(&SceneData) -> usize| match baked {
            Some(data) => ArrayForm::Constants(len(data)),
            None => ArrayForm::Buffer,
        };
        let arrays = [
            ("materials", true, form(|d| d.materials.len())),
            ("quads", self.quads, form(|d| d.quads.len())),
            ("spheres", self.spheres, form(|d| d.spheres.len())),
            (
                "light_quads",
                self.light_quads,
                form(|d| d.light_quads.len()),
            ),
            (
                "light_spheres",
                self.light_spheres,
                form(|d| d.light_spheres.len()),
            ),
        ];
        arrays
            .into_iter()
            .filter(|&(_, present, _)| present)
            .map(|(name, _, form)| (name, form))
            .collect()
    }

    /// The scene as WGSL: for each array the kernel declares as a storage buffer
    /// otherwise, its length `NAME_COUNT`, one constant per element (what
    /// `#for_each` reads; bit for bit the buffer's contents) and, for arrays
    /// also read by a dynamic index, a `NAME_at(i)` switch over them.
    fn baked_scene_wgsl(&self, data: &SceneData) -> String {
        fn array<T: GpuLayout>(out: &mut String, name: &str, items: &[T], indexed: bool) {
            let n = items.len();
            let upper = name.to_uppercase();
            let ty = T::WGSL_NAME;
            out.push_str(&format!("const {upper}_COUNT: u32 = {n}u;\n"));
            for (i, item) in items.iter().enumerate() {
                let constant = element_constant(name, i);
                out.push_str(&format!(
                    "const {constant}: {ty} = {};\n",
                    item.wgsl_value()
                ));
            }
            if indexed && n > 0 {
                out.push_str(&format!(
                    "fn {name}_at(i: u32) -> {ty} {{\n    switch i {{\n"
                ));
                for i in 0..n {
                    let label = if i + 1 == n {
                        "default".to_string()
                    } else {
                        format!("case {i}u")
                    };
                    let constant = element_constant(name, i);
                    out.push_str(&format!("        {label}: {{ return {constant}; }}\n"));
                }
                out.push_str("    }\n}\n");
            }
        }
        let mut out = String::from("// ---- baked scene ----\n");
        array(&mut out, "materials", &data.materials, true);
        if self.quads {
            array(&mut out, "quads", &data.quads, false);
        }
        if self.spheres {
            array(&mut out, "spheres", &data.spheres, false);
        }
        if self.light_quads {
            array(&mut out, "light_quads", &data.light_quads, true);
        }
        if self.light_spheres {
            array(&mut out, "light_spheres", &data.light_spheres, true);
        }
        out
    }

    /// Values of the WGSL `override` constants.
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("MAX_DEPTH", self.max_depth as f64),
            ("LIGHT_WEIGHT", self.light_weight as f64),
            ("RR_DEPTH", self.rr_depth.unwrap_or(u32::MAX) as f64),
        ]
    }

    /// Scene bindings (group 1) the kernel declares: none when the scene is baked.
    pub fn scene_bindings(&self) -> Vec<u32> {
        if self.baked_scene.is_some() {
            return Vec::new();
        }
        let mut bindings = vec![BINDING_MATERIALS];
        for (binding, present) in [
            (BINDING_QUADS, self.quads),
            (BINDING_SPHERES, self.spheres),
            (BINDING_LIGHT_QUADS, self.light_quads),
            (BINDING_LIGHT_SPHERES, self.light_spheres),
        ] {
            if present {
                bindings.push(binding);
            }
        }
        bindings
    }

    /// Running sums the accumulator holds: each sum and its compensation.
    pub fn accumulator_layers(&self) -> u32 {
        if self.variance { 4 } else { 2 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::{Counters, GpuLayout, Material, Params, Quad, Sphere};

    fn parse(config: &KernelConfig) -> naga::Module {
        let source = config.source().unwrap();
        naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{config:?}\n{}", e.emit_to_string(&source)))
    }

    pub(crate) fn validate(config: &KernelConfig) -> naga::Module {
        let module = parse(config);
        let source = config.source().unwrap();
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{config:?}\n{}", e.emit_to_string(&source)));
        module
    }

    fn all_variants() -> Vec<KernelConfig> {
        let mut configs = Vec::new();
        for strategy in Strategy::ALL {
            for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
                let general = KernelConfig::general(strategy, accumulator);
                for mask in 0..(1 << 6) {
                    let bit = |i: u32| mask & (1 << i) != 0;
                    let mut config = KernelConfig {
                        quads: bit(0),
                        spheres: bit(1),
                        lambertian: bit(2),
                        metal: bit(3),
                        dielectric: bit(4),
                        variance: bit(5),
                        ..general.clone()
                    };
                    let samples = config.lambertian && strategy != Strategy::Cosine;
                    config.light_quads = samples && config.quads;
                    config.light_spheres = samples && !config.quads;
                    configs.push(config);
                }
            }
        }
        configs
    }

    #[test]
    fn every_module_combination_validates() {
        for config in all_variants() {
            validate(&config);
        }
    }

    #[test]
    fn every_shipped_scene_specialisation_validates() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut scenes = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let scene = crate::scene::Scene::load(&entry.unwrap().path()).unwrap();
            for strategy in Strategy::ALL {
                for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
                    for variance in [false, true] {
                        let (data, strategy, _) =
                            crate::render::prepare_scene(&scene, strategy).unwrap();
                        for storage in [SceneStorage::Baked, SceneStorage::Buffers] {
                            let config = KernelConfig::for_scene(
                                &data,
                                strategy,
                                &scene.render,
                                accumulator,
                                variance,
                                storage,
                            );
                            validate(&config);
                        }
                    }
                }
            }
            scenes += 1;
        }
        assert!(scenes >= 3);
    }

    /// The 32-bit words of a constant expression, in declaration order.
    fn constant_words(module: &naga::Module, expr: naga::Handle<naga::Expression>) -> Vec<u32> {
        match &module.global_expressions[expr] {
            naga::Expression::Literal(naga::Literal::F32(x)) => vec![x.to_bits()],
            naga::Expression::Literal(naga::Literal::U32(x)) => vec![*x],
            naga::Expression::Compose { components, .. } => components
                .iter()
                .flat_map(|&c| constant_words(module, c))
                .collect(),
            other => panic!("unexpected constant expression {other:?}"),
        }
    }

    /// The words of every element constant of baked array `name`, in order.
    fn baked_words(module: &naga::Module, name: &str) -> Vec<u32> {
        let value = |constant: &str| {
            let (_, c) = module
                .constants
                .iter()
                .find(|(_, c)| c.name.as_deref() == Some(constant))?;
            Some(constant_words(module, c.init))
        };
        (0..)
            .map_while(|i| value(&crate::shader::element_constant(name, i)))
            .flatten()
            .collect()
    }

    /// What naga reads from the baked constants is exactly what the buffers hold.
    #[test]
    fn baked_constants_are_the_buffer_contents() {
        for file in ["cornell.toml", "cornell-boxes.toml", "furnace.toml"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("scenes")
                .join(file);
            let scene = crate::scene::Scene::load(&path).unwrap();
            let data = SceneData::pack(&scene);
            let config = KernelConfig::for_scene(
                &data,
                Strategy::Mixture,
                &scene.render,
                AccumulatorKind::Buffer,
                false,
                SceneStorage::Baked,
            );
            let module = validate(&config);
            let words = |name: &str| baked_words(&module, name);
            let expected = |bytes: &[u8]| bytemuck::cast_slice::<u8, u32>(bytes).to_vec();
            assert_eq!(
                words("materials"),
                expected(bytemuck::cast_slice(&data.materials))
            );
            assert_eq!(words("quads"), expected(bytemuck::cast_slice(&data.quads)));
            assert_eq!(
                words("light_quads"),
                expected(bytemuck::cast_slice(&data.light_quads))
            );
            assert_eq!(
                words("spheres"),
                expected(bytemuck::cast_slice(&data.spheres))
            );
            assert_eq!(
                words("light_spheres"),
                expected(bytemuck::cast_slice(&data.light_spheres))
            );
        }
    }

    #[test]
    fn small_finite_scenes_are_baked_by_default() {
        let quads = |n: usize| SceneData {
            materials: vec![Default::default()],
            quads: vec![Quad::default(); n],
            ..SceneData::default()
        };
        let max = SceneStorage::MAX_BAKED_OBJECTS;
        assert_eq!(SceneStorage::auto(&quads(max)), SceneStorage::Baked);
        assert_eq!(SceneStorage::auto(&quads(max + 1)), SceneStorage::Buffers);
        let mut infinite = quads(1);
        infinite.quads[0].w[0] = f32::INFINITY;
        assert_eq!(SceneStorage::auto(&infinite), SceneStorage::Buffers);
    }

    /// Every float of the scene, including awkward ones, survives the WGSL text.
    #[test]
    fn baked_floats_round_trip_exactly() {
        let values = [
            0.1f32,
            -0.0,
            1e-30,
            f32::MIN_POSITIVE,
            1e-45,
            f32::MAX,
            -f32::MAX,
            16777217.0,
            0.65,
            1.0 / 3.0,
        ];
        let material = |x: f32| crate::gpu::layout::Material {
            albedo: [x, -x, x * 0.5],
            param: x,
            ..Default::default()
        };
        let data = SceneData {
            materials: values.iter().map(|&x| material(x)).collect(),
            ..SceneData::default()
        };
        let config = KernelConfig {
            quads: false,
            spheres: false,
            light_quads: false,
            light_spheres: false,
            baked_scene: Some(data.clone()),
            ..KernelConfig::general(Strategy::Cosine, AccumulatorKind::Buffer)
        };
        let module = validate(&config);
        assert_eq!(
            baked_words(&module, "materials"),
            bytemuck::cast_slice::<_, u32>(&data.materials)
        );
    }

    #[test]
    fn absent_features_are_not_compiled_in() {
        let config = KernelConfig {
            spheres: false,
            dielectric: false,
            metal: false,
            light_spheres: false,
            ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
        };
        let source = config.source().unwrap();
        for absent in [
            "sphere_hit_t",
            "scatter_dielectric",
            "scatter_metal",
            "light_spheres",
        ] {
            assert!(!source.contains(absent), "{absent} compiled in");
        }
        let cosine = KernelConfig::general(Strategy::Cosine, AccumulatorKind::Buffer)
            .source()
            .unwrap();
        assert!(!cosine.contains("fn light_pdf"));
    }

    fn check_layout<T: GpuLayout>(module: &naga::Module) {
        let (members, span) = module
            .types
            .iter()
            .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
                (Some(name), naga::TypeInner::Struct { members, span }) if name == T::WGSL_NAME => {
                    Some((members, *span))
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("struct {} not in the WGSL", T::WGSL_NAME));
        let wgsl: Vec<(&str, usize)> = members
            .iter()
            .map(|m| (m.name.as_deref().unwrap(), m.offset as usize))
            .collect();
        assert_eq!(wgsl, T::fields(), "field offsets of {}", T::WGSL_NAME);
        assert_eq!(
            span as usize,
            std::mem::size_of::<T>(),
            "size of {}",
            T::WGSL_NAME
        );
    }

    #[test]
    fn host_structs_match_wgsl_layouts() {
        let module = validate(&KernelConfig::general(
            Strategy::Mixture,
            AccumulatorKind::Texture,
        ));
        check_layout::<Params>(&module);
        check_layout::<Counters>(&module);
        check_layout::<Material>(&module);
        check_layout::<Quad>(&module);
        check_layout::<Sphere>(&module);
    }
}
