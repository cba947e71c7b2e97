//! What the compute kernel contains for a given scene and run: the WGSL modules
//! and flags (code for absent kinds and features is not compiled in), the
//! generated glue (`glue`) and the pipeline constants. Device-free, so every
//! variant is validated by naga in `cargo test`.

mod glue;
mod profile;

pub use profile::Stage;

use crate::abi::{
    LAYER_SQUARES_COMPENSATION, LAYER_SUM_COMPENSATION, PackedMaterial, REPLICATES, replicate_layer,
};
use crate::accel::{self, PackedInstance, WideBvh, WideBvhNode};
use crate::environment::EnvironmentInfo;
use crate::kinds::{
    ErasedLayout, FILTER_FLAGS, FILTER_MODULE, KindSet, MATERIAL_BUMP_SHIFT, MATERIAL_KINDS,
    PRIMITIVE_KINDS, PackedArray, TexelFormat, TextureInfo,
};
use crate::lights::{DeltaLight, LightGroup, LightPick, LightRef};
use crate::pack::SceneData;
use crate::scene::{
    AovKind, CameraModel, Filter, LightSelection, RenderSettings, Sampler, Strategy,
};
use crate::shader::{ArrayForm, ComposeError, Directives, ShaderModule, compose, shader_module};
use std::collections::{BTreeMap, BTreeSet};

pub const COMMON: ShaderModule = shader_module!("common");
pub const RNG: ShaderModule = shader_module!("rng");
pub const SAMPLING: ShaderModule = shader_module!("sampling");
pub const BVH: ShaderModule = shader_module!("bvh");
pub const LIGHT_GROUPS: ShaderModule = shader_module!("light_groups");
pub const MATERIALS: ShaderModule = shader_module!("materials");
pub const STRATEGY: ShaderModule = shader_module!("strategy");
pub const ACCUMULATE_TEXTURE: ShaderModule = shader_module!("accumulate_texture");
pub const ACCUMULATE_BUFFER: ShaderModule = shader_module!("accumulate_buffer");
pub const KERNEL: ShaderModule = shader_module!("kernel");
pub const CAMERA: ShaderModule = shader_module!("camera");
pub const AOV: ShaderModule = shader_module!("aov");
pub const SUMS: ShaderModule = shader_module!("sums");
pub const SPLAT: ShaderModule = shader_module!("splat");
pub const PROFILE: ShaderModule = shader_module!("profile");
pub const BSDF_PROBE: ShaderModule = shader_module!("bsdf_probe");
pub const ENVIRONMENT: ShaderModule = shader_module!("environment");
pub const ENVIRONMENT_PROBE: ShaderModule = shader_module!("environment_probe");
pub const FILTER_PROBE: ShaderModule = shader_module!("filter_probe");
pub const DELTA_LIGHTS: ShaderModule = shader_module!("delta_lights");
pub const TEXTURES: ShaderModule = shader_module!("textures");
pub const ERROR_ESTIMATE: ShaderModule = shader_module!("error_estimate");

/// Flags that are not a kind's presence flag.
const FEATURE_FLAGS: &[&str] = &[
    "STRATEGY_BSDF",
    "STRATEGY_LIGHT",
    "STRATEGY_NEE",
    "LIGHT_DENSITY",
    "LIGHT_POINTS",
    "LIGHT_SELECTION_SPATIAL",
    "VARIANCE",
    "REPLICATE_SUMS",
    "ADAPTIVE",
    "SAMPLER_SOBOL",
    "SAMPLER_REPLICATES",
    "BVH",
    "INSTANCES",
    "SHADING_NORMALS",
    "SIDES_BY_SHADING_NORMAL",
    "ONE_SIDED",
    "MASK",
    "OPACITY_TEXTURES",
    "ENVIRONMENT",
    "LIGHT_ENVIRONMENT",
    "SHADOW_LIGHTS_FIRST",
    "DELTA_LIGHTS",
    "DELTA_LIGHTS_PICK",
    "DIRECTIONAL_LIGHTS",
    "TEXTURES",
    "FLOAT_TEXELS",
    "BYTE_TEXELS",
    "BUMP_MAPS",
    "TEXTURED_NUMBERS",
    "NESTED_MATERIALS",
    "THIN_LENS",
    "ORTHOGRAPHIC",
    "SPLAT",
    "KERNEL_SUMS",
    "PROFILE",
    "AOV_MATERIAL",
];

/// Every flag a module may test: the features, the filters' and each kind's presence flags.
pub fn known_flags() -> Vec<String> {
    let primitives = PRIMITIVE_KINDS.iter().flat_map(|kind| {
        let normals = kind.shading_normals.is_some().then(|| kind.normals_flag());
        [kind.flag(), kind.light_flag()].into_iter().chain(normals)
    });
    let materials = MATERIAL_KINDS.iter().map(|kind| kind.flag());
    let aovs = AovKind::ALL.iter().map(|kind| kind.flag());
    FEATURE_FLAGS
        .iter()
        .chain(FILTER_FLAGS)
        .map(|flag| flag.to_string())
        .chain(primitives)
        .chain(materials)
        .chain(aovs)
        .collect()
}

/// The path kernel's entry point (`shaders/kernel.wgsl`).
pub const ENTRY_POINT: &str = "render";
/// The AOV pass's (`shaders/aov.wgsl`).
pub const AOV_ENTRY_POINT: &str = "aovs";
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
    /// Read-only storage buffers (group 1), every ray testing every primitive:
    /// any size, one kernel per feature set.
    Buffers,
    /// Storage buffers through a BVH (`accel`): cost that grows as log n.
    Bvh,
}

impl SceneStorage {
    /// Largest scene baked by default: primitives plus objects in the light
    /// density. Measured on lavapipe with random quads, a baked kernel renders
    /// 7-8x faster than buffers at 32 to 128 objects; its first compile (without
    /// Mesa's shader cache) takes 0.3 CPU-s at 32 objects, 0.5 at 64, 1.5 at 128
    /// and 5.3 at 256, where it also renders slower than buffers.
    pub const MAX_BAKED_OBJECTS: usize = 128;

    /// Baked for small scenes, a BVH for the rest and for any scene with
    /// instances; plain buffers for a scene with non-finite numbers (no
    /// literal to bake, no box to bound).
    pub fn auto(data: &SceneData) -> SceneStorage {
        let objects = data.geometry.primitive_count() + data.light_count();
        if data.has_instances() {
            // Instances are found through the two-level BVH alone.
            SceneStorage::Bvh
        } else if !data.is_finite() {
            SceneStorage::Buffers
        } else if objects <= Self::MAX_BAKED_OBJECTS {
            SceneStorage::Baked
        } else {
            SceneStorage::Bvh
        }
    }
}

/// How the arrays the kernel reads from memory are bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ArrayMemory {
    /// Every array a read-only storage buffer.
    Buffers,
    /// Arrays of whole 16- or 8-byte words (`ArraySource::word_size`) as
    /// textures of one word a texel (`gpu::texture_array`), read by
    /// `textureLoad`; the others storage buffers (tables of floats, 12-byte
    /// elements: as textures of 4-byte texels, a textured scene took 1.12x
    /// the time). Mesa 22.3's lavapipe loads a storage buffer lane by lane,
    /// each lane's value stored into a vector in memory that is then reloaded
    /// whole: without AVX-512 (LLVM's in-register insert) every such
    /// reload waits on a failed store forwarding. It fetches a texel per lane
    /// into registers. Measured with AVX2 code (`GALLIUM_OVERRIDE_CPU_CAPS=avx`,
    /// as on AMD's Zen 2 and 3): docs/benchmarks.md, "Arrays in textures".
    Textures,
}

/// Where a scene array's elements come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArraySource {
    Materials,
    /// The materials' tables (`SceneData::material_tables`).
    MaterialTables,
    /// The textures (`SceneData::textures`) and their texels.
    Textures,
    TextureTexels,
    /// The texture coordinates of the primitives of kind `k`.
    Uvs(usize),
    /// The primitives of kind `k` of `PRIMITIVE_KINDS`.
    Primitives(usize),
    /// Its large primitives, the first of `Primitives(k)` (`PrimitiveArrays::large`):
    /// beside a BVH, always compiled in.
    Large(usize),
    /// The primitives of kind `k` in the light density.
    Lights(usize),
    /// The shading normals of the primitives of kind `k`.
    Normals(usize),
    /// The light tables (`lights::LightTables`) of grouped light kind `k`.
    LightTable(usize, LightTablePart),
    BvhNodes,
    /// The instances (`accel::PackedInstance`) the BVH's instance leaves hold.
    Instances,
    /// The environment map's tables (`environment::EnvironmentTables`): always
    /// read from buffers, a map being far too large to bake.
    Environment(EnvironmentPart),
    /// The point and spot lights (`lights::DeltaLight`).
    DeltaLights,
}

impl ArraySource {
    /// Whether a baked kernel compiles this array in as constants. Large tables
    /// read at computed indices stay in buffers: a baked array is read through a
    /// binary tree of `if`s over its elements (`glue::index_tree`), and a
    /// constant array indexed at run time was 75x slower on lavapipe (Mesa
    /// 22.3). (A `switch` over the elements, used before, gave wrong values
    /// there over the 64-entry tables of a few `roughplastic` coats, and over
    /// the light tables of a mesh of 108 emitting faces.)
    pub fn bakes(self) -> bool {
        !matches!(
            self,
            ArraySource::Environment(_)
                | ArraySource::MaterialTables
                | ArraySource::Textures
                | ArraySource::TextureTexels
                | ArraySource::Uvs(_)
        )
    }

    /// The WGSL type and bytes of one element.
    pub fn element(self) -> (&'static str, usize) {
        match (self.element_layout(), self) {
            (Some(layout), _) => (layout.wgsl_name, layout.size),
            (
                None,
                ArraySource::Environment(EnvironmentPart::Texels | EnvironmentPart::Pyramid),
            ) => ("vec4<f32>", 16),
            (None, ArraySource::MaterialTables) => ("f32", 4),
            (None, ArraySource::TextureTexels) => ("u32", 4),
            (None, other) => unreachable!("{other:?} has a host struct"),
        }
    }

    /// The bytes of the words an element is read in, where it is whole words:
    /// 16 where its size is a multiple of 16, 8 for an 8-byte element.
    pub fn word_size(self) -> Option<usize> {
        match self.element().1 {
            8 => Some(8),
            size if size % 16 == 0 => Some(16),
            _ => None,
        }
    }

    /// The host struct of this array's elements, where they are one (else
    /// they are `vec4<f32>` texels or `f32` tables).
    pub fn element_layout(self) -> Option<ErasedLayout> {
        match self {
            ArraySource::Materials => Some(ErasedLayout::of::<PackedMaterial>()),
            ArraySource::Primitives(k) | ArraySource::Large(k) | ArraySource::Lights(k) => {
                Some(PRIMITIVE_KINDS[k].layout)
            }
            ArraySource::Normals(k) => Some(
                PRIMITIVE_KINDS[k]
                    .shading_normals
                    .expect("only kinds with shading normals have them"),
            ),
            ArraySource::Uvs(k) => Some(
                PRIMITIVE_KINDS[k]
                    .texture_uvs
                    .expect("only kinds with texture coordinates have them"),
            ),
            ArraySource::LightTable(_, LightTablePart::Groups) => {
                Some(ErasedLayout::of::<LightGroup>())
            }
            ArraySource::LightTable(_, LightTablePart::Picks) => {
                Some(ErasedLayout::of::<LightPick>())
            }
            ArraySource::LightTable(_, LightTablePart::BvhRefs) => {
                Some(ErasedLayout::of::<LightRef>())
            }
            ArraySource::LightTable(_, LightTablePart::BvhNodes) | ArraySource::BvhNodes => {
                Some(ErasedLayout::of::<WideBvhNode>())
            }
            ArraySource::Instances => Some(ErasedLayout::of::<PackedInstance>()),
            ArraySource::Textures => Some(ErasedLayout::of::<TextureInfo>()),
            ArraySource::Environment(EnvironmentPart::Info) => {
                Some(ErasedLayout::of::<EnvironmentInfo>())
            }
            ArraySource::DeltaLights => Some(ErasedLayout::of::<DeltaLight>()),
            ArraySource::MaterialTables
            | ArraySource::TextureTexels
            | ArraySource::Environment(_) => None,
        }
    }
}

/// One of the arrays of `environment::EnvironmentTables`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvironmentPart {
    Info,
    Texels,
    /// The pyramid of the cells' probabilities (the cells between texel
    /// centres): only where the light density samples the map.
    Pyramid,
}

/// One of the arrays of `lights::LightTables`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightTablePart {
    Groups,
    Picks,
    BvhNodes,
    BvhRefs,
}

impl LightTablePart {
    const ALL: [LightTablePart; 4] = [
        LightTablePart::Groups,
        LightTablePart::Picks,
        LightTablePart::BvhNodes,
        LightTablePart::BvhRefs,
    ];

    /// Its array for kind `name`: `light_triangle_groups`, ...
    fn array(self, name: &str) -> String {
        let part = match self {
            LightTablePart::Groups => "groups",
            LightTablePart::Picks => "picks",
            LightTablePart::BvhNodes => "nodes",
            LightTablePart::BvhRefs => "refs",
        };
        format!("light_{name}_{part}")
    }
}

/// One array of the scene the kernel declares.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneArray {
    pub name: String,
    /// Its binding in group 1 when the scene is read from buffers: materials 0,
    /// then the primitive kinds in table order, then their light arrays, the
    /// BVH, the shading normals, the light tables, the environment map, the
    /// material tables, the textures and the texture coordinates (fixed per
    /// array, whichever arrays a kernel declares).
    pub binding: u32,
    /// Read by a dynamic index (`NAME_at`), not only walked by `#for_each`:
    /// baked, such an array needs its lookup tree (a buffer array has `NAME_at`
    /// whatever this says).
    pub indexed: bool,
    pub source: ArraySource,
}

impl SceneArray {
    pub fn wgsl_type(&self) -> &'static str {
        self.source.element().0
    }

    /// Bytes per element.
    pub fn element_size(&self) -> usize {
        self.source.element().1
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct KernelConfig {
    /// Primitive kinds rays can hit, by index into `PRIMITIVE_KINDS`.
    pub primitive_kinds: KindSet,
    /// Primitive kinds in the light density; empty: no light sampling compiled in
    /// (no smooth material, the `bsdf` strategy, or nothing to aim at).
    pub light_kinds: KindSet,
    /// Primitive kinds shaded with interpolated normals (smooth meshes); empty:
    /// every surface shades with its geometric normal, and no code for the
    /// shading normals' problems is compiled in.
    pub normal_kinds: KindSet,
    /// Material kinds, by index into `MATERIAL_KINDS`.
    pub material_kinds: KindSet,
    pub strategy: Strategy,
    pub max_depth: u32,
    pub light_weight: f32,
    /// Russian roulette from this depth on, or never.
    pub rr_depth: Option<u32>,
    pub sampler: Sampler,
    pub accumulator: AccumulatorKind,
    /// Accumulate squared samples too, for per-pixel error estimates.
    pub variance: bool,
    /// Adaptive sampling: each dispatch runs over a list of active pixels, each
    /// continuing its own sample sequence (needs `variance`).
    pub adaptive: bool,
    /// Under Sobol, a pixel's samples interleave `abi::REPLICATES` independently
    /// scrambled sequences, whose spread is the error estimate (needed by
    /// `variance`); without, they are one scrambled sequence, whose points
    /// stratify the pixel more finely (less noise at equal samples).
    pub replicates: bool,
    /// Scene data compiled into the kernel: the whole scene
    /// (`SceneStorage::Baked`), or beside a BVH its large primitives and a small
    /// light density (`beside_bvh`); `None`: everything is read from
    /// storage buffers.
    pub compiled_in: Option<SceneData>,
    /// Primitive kinds in the scene's BVH, through which closest hits are found
    /// (`SceneStorage::Bvh`); empty: no BVH.
    pub bvh_kinds: KindSet,
    /// Entries of the closest-hit traversal's private stack: one per level of
    /// the scene's BVH. Sized to the BVH rather than to `accel::MAX_DEPTH`:
    /// the 48 entries took 1.2x the time of 10 on Mitsuba's box with the bunny
    /// (lavapipe).
    pub bvh_stack: u32,
    /// The same for the light groups' BVHs (the deepest's levels).
    pub light_bvh_stack: u32,
    /// The scene's BVH has instance leaves (`accel::instances`): the closest
    /// hit walks a group's BVH in its space at each (`INSTANCES`).
    pub instances: bool,
    /// Entries of the stack of the walk of a group's BVH: its deepest's levels.
    pub instance_stack: u32,
    /// The pixel filter camera rays are drawn from, or their samples splatted by.
    pub filter: Filter,
    /// Samples are splatted into the pixels around by the filter
    /// (`Reconstruction::Splat`, `shaders/splat.wgsl`) rather than drawn from it.
    pub splat: bool,
    /// Count each `Stage`'s active SIMD lanes (`shaders/profile.wgsl`): for
    /// `pathmix bench --stages`; needs subgroup operations.
    pub profile: bool,
    /// How camera rays leave the camera (`camera_ray`).
    pub camera: CameraModel,
    /// Not empty: the kernel is the AOV pass (`shaders/aov.wgsl`), which sums
    /// these at each camera ray's first hit (`KernelConfig::for_aovs`), not
    /// the path kernel.
    pub aovs: Vec<AovKind>,
    /// Some material of the scene is one-sided (black from behind).
    pub one_sided: bool,
    /// The side of a smooth surface a ray meets is the shading normal's
    /// (`RenderSettings::sides_by_shading_normal`), where some surface is smooth.
    pub sides_by_shading_normal: bool,
    /// Some material of the scene is masked (`Material::opacity` below 1): rays
    /// pass through it by chance and shadow rays by its transparency.
    pub masked: bool,
    /// Some masked material's opacity is a texture (`Material::opacity_texture`;
    /// implies `masked` and `textures`), looked up where a ray finds it.
    pub opacity_textures: bool,
    /// Escaping rays find an environment map's radiance (else the background).
    pub environment: bool,
    /// The environment map is one object of the light density.
    pub light_environment: bool,
    /// Next-event estimation picks a light in proportion to a bound on what it
    /// sends toward the shading point (`PrimitiveKind::light_importance`), not
    /// uniformly (`LIGHT_SELECTION_SPATIAL`): under `nee-mis`, with two lights or
    /// more, each of a kind with such a bound, none grouped and no environment.
    pub spatial_light_selection: bool,
    /// Point and spot lights, estimated by shadow rays at every vertex with a
    /// smooth lobe whatever the strategy (none without a smooth material).
    pub delta_lights: bool,
    /// Some of them is directional (at infinity): its shadow ray has no end.
    pub directional_lights: bool,
    /// More than [`KernelConfig::MAX_DELTA_SHADOW_RAYS`] of them: one shadow ray
    /// per vertex, toward a light picked by power, instead of one toward each.
    pub delta_light_pick: bool,
    /// Some material has a texture: hits carry texture coordinates.
    pub textures: bool,
    /// Some bitmap's texels are floats (`kinds::TexelFormat::Float`).
    pub float_texels: bool,
    /// Some bitmap's texels are 8-bit codes, decoded by `TEXEL_BYTE_VALUES`.
    pub byte_texels: bool,
    /// Some material has a bump or normal map (`kinds::Bump`; implies
    /// `textures`): hits carry their tangents along u and v, the shading
    /// normal is perturbed, and the leak check of shading normals applies.
    pub bump_maps: bool,
    /// Some material has numbers given by textures (`Material::number_textures`;
    /// implies `textures`), looked up at each hit on it
    /// (`texture_numbers`, textures.wgsl).
    pub textured_numbers: bool,
    /// How the light density weighs the grouped lights (mesh faces).
    pub grouped_density: GroupedDensity,
    /// How the arrays read from memory are bound: textures unless the device
    /// reads buffers faster (`render::choose_array_memory`).
    pub array_memory: ArrayMemory,
}

/// How the light density weighs the lights of grouped kinds (a mesh's faces),
/// chosen by their number (`KernelConfig::for_scene`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupedDensity {
    /// A direction's density sums every member, each tested in turn: below
    /// [`KernelConfig::LIGHT_WALK_MIN`], where the walk costs more than it skips.
    Every,
    /// A direction's density sums the members the line meets, found through
    /// the groups' BVH (`LightTablePart::BvhNodes`): its cost grows as log n.
    Walk,
    /// Next-event estimation weighs a grouped light by the density of the point
    /// it hit (`NAME_light_point_pdf`), as Mitsuba and pbrt-v4 weigh area lights,
    /// rather than by that of the direction. Both are unbiased: a light sample
    /// then counts only where its shadow ray finds the point it aimed at first.
    /// The mixture and `light` keep the direction's density, the estimator
    /// their one sample divides by. From [`KernelConfig::LIGHT_POINTS_MIN`] on.
    Points,
}

impl GroupedDensity {
    /// As `pathmix info` says it.
    pub fn describe(self) -> &'static str {
        match self {
            GroupedDensity::Every => "each tested for a direction's density",
            GroupedDensity::Walk => "a direction's density walks their BVH",
            GroupedDensity::Points => "weighed by the density of the point hit, with no walk",
        }
    }
}

/// What a BVH kernel compiles in (`KernelConfig::compiled_in`): the large
/// primitives, and the light density where it is finite and small enough
/// to bake (with the large ones, at most `SceneStorage::MAX_BAKED_OBJECTS`,
/// as a baked scene); `None` when neither is there.
fn beside_bvh(data: &SceneData) -> Option<SceneData> {
    let large: usize = data.geometry.large.iter().sum();
    let lights_bake = large + data.light_count() <= SceneStorage::MAX_BAKED_OBJECTS
        && PRIMITIVE_KINDS.iter().enumerate().all(|(k, kind)| {
            let lights = &data.lights[k];
            (0..lights.len()).all(|i| (kind.layout.is_finite)(lights.element(i, kind.layout.size)))
        });
    if large == 0 && !(lights_bake && data.light_count() > 0) {
        return None;
    }
    let mut compiled = SceneData::default();
    compiled.geometry.large = data.geometry.large.clone();
    for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
        let array = &data.geometry.primitives[k];
        compiled.geometry.primitives[k] = PackedArray {
            bytes: array.bytes[..data.geometry.large[k] * kind.layout.size].to_vec(),
            materials: array.materials[..data.geometry.large[k]].to_vec(),
        };
    }
    if lights_bake {
        compiled.lights = data.lights.clone();
        compiled.light_members = data.light_members.clone();
        compiled.light_tables = data.light_tables.clone();
    }
    Some(compiled)
}

/// Loop iterations of one evaluation of the light density: one per light of
/// a kind tested in a loop (none when `baked`: the loops are unrolled); for
/// grouped lights weighed by `grouped`, none by points, and a walk of
/// their BVH (a loop even when baked: an inner step per node visited and
/// per leaf reached, an outer step per leaf, one per light tested, and a
/// leaf holds a light at least) counted as at most `bvh_allowance` of it.
pub fn light_density_iterations(
    data: &SceneData,
    bvh_allowance: impl Fn(&WideBvh) -> u64,
    baked: bool,
    grouped: GroupedDensity,
) -> u64 {
    PRIMITIVE_KINDS
        .iter()
        .zip(&data.lights)
        .zip(&data.light_tables)
        .enumerate()
        .map(|(k, ((kind, lights), tables))| match (tables, grouped) {
            (Some(_), GroupedDensity::Points) if kind.grouped_lights => 0,
            (Some(_), GroupedDensity::Walk) if kind.grouped_lights => {
                let walk = data.light_bvh(k);
                bvh_allowance(&walk.bvh).min((walk.bvh.nodes.len() + 3 * walk.refs.len()) as u64)
            }
            _ if baked => 0,
            _ => lights.len() as u64,
        })
        .sum()
}

/// What every probe kernel (a part of the kernel run on its own, for tests)
/// starts with: the shared constants, types, random numbers and sampling.
fn probe_prelude() -> Vec<ShaderModule> {
    vec![
        ShaderModule {
            name: "constants",
            source: glue::shared_constants().into(),
        },
        COMMON,
        RNG,
        SAMPLING,
    ]
}

/// Whether any of `kinds` has a smooth lobe (where strategies apply).
fn has_smooth_lobe(kinds: KindSet) -> bool {
    kinds.iter().any(|k| MATERIAL_KINDS[k].lobe.has_density())
}

impl KernelConfig {
    /// Most point and spot lights that each get a shadow ray at every vertex; a
    /// scene with more picks one per vertex by power. Measured on lavapipe (point
    /// lights over a floor and a sphere, 128², max depth 4, 2048 spp): one ray
    /// toward each light against one toward a picked light had 19x less error for
    /// 0.9-1.5x the time with 4 lights (over 150x the efficiency), 28x less for
    /// 1.25x with 16 (over 600x): direct light from every delta light is then
    /// noiseless but for visibility and pixel jitter. The cost grows with the count,
    /// the error of picking too, so the switch is far out.
    pub const MAX_DELTA_SHADOW_RAYS: usize = 64;

    /// Fewest grouped lights (mesh faces) whose density walks their BVH
    /// (`GroupedDensity::Walk`) rather than testing each. Measured under the
    /// mixture in Mitsuba's box with an emitting mesh beside its 2-face light
    /// (docs/benchmarks.md, "Emitting meshes"): testing each took 0.6-0.7x the CPU time
    /// of the walk with 14 and 34 faces, 2.5x with 130.
    pub const LIGHT_WALK_MIN: usize = 48;

    /// Fewest grouped lights (mesh faces) whose next-event estimation weighs
    /// by the point's density (`GroupedDensity::Points`). A sample of a face that the
    /// mesh hides from itself then counts nothing, where the line's density
    /// counted it through the face in front, so a small closed emitter, whose
    /// walk is cheap, loses: measured (docs/benchmarks.md, "Emitting meshes under
    /// `nee-mis`"), a lone 12-face cube 0.42x the efficiency and 1.08x in a
    /// Cornell box; 32 faces 0.85x and 1.51x; 512 faces 0.93x and 2.17x.
    pub const LIGHT_POINTS_MIN: usize = 32;

    /// The kernel for `data`; `strategy` must have objects to aim at unless it is `bsdf`.
    #[allow(clippy::too_many_arguments)] // the scene's parts and the run's choices, each plain
    pub fn for_scene(
        data: &SceneData,
        strategy: Strategy,
        settings: &RenderSettings,
        filter: Filter,
        camera: CameraModel,
        accumulator: AccumulatorKind,
        variance: bool,
        scene_storage: SceneStorage,
    ) -> KernelConfig {
        let material_kinds = data.material_kinds();
        let samples_lights = has_smooth_lobe(material_kinds) && strategy != Strategy::Bsdf;
        let environment = data.environment.is_some();
        let grouped_lights: usize = (0..PRIMITIVE_KINDS.len())
            .filter(|&k| PRIMITIVE_KINDS[k].grouped_lights)
            .map(|k| data.lights[k].len())
            .sum();
        let grouped_density = match grouped_lights {
            n if samples_lights && strategy == Strategy::NeeMis && n >= Self::LIGHT_POINTS_MIN => {
                GroupedDensity::Points
            }
            n if samples_lights && n >= Self::LIGHT_WALK_MIN => GroupedDensity::Walk,
            _ => GroupedDensity::Every,
        };
        // Built here (`SceneData::light_bvh`) where walked, before the scene
        // is copied to be compiled in.
        let light_bvh_stack = (0..PRIMITIVE_KINDS.len())
            .filter(|&k| grouped_density == GroupedDensity::Walk && data.light_tables[k].is_some())
            .map(|k| data.light_bvh(k).bvh.depth + 1)
            .max()
            .unwrap_or(accel::MAX_DEPTH);
        KernelConfig {
            primitive_kinds: data.geometry.primitive_kinds(),
            light_kinds: if samples_lights {
                data.light_kinds()
            } else {
                KindSet::default()
            },
            normal_kinds: data.geometry.normal_kinds(),
            material_kinds,
            strategy,
            max_depth: settings.max_depth,
            light_weight: settings.light_weight,
            rr_depth: settings.roulette_depth(),
            sampler: settings.sampler,
            accumulator,
            variance,
            adaptive: false,
            replicates: true,
            compiled_in: match scene_storage {
                SceneStorage::Baked => Some(data.clone()),
                SceneStorage::Bvh => beside_bvh(data),
                SceneStorage::Buffers => None,
            },
            bvh_kinds: match scene_storage {
                SceneStorage::Bvh => (0..PRIMITIVE_KINDS.len())
                    .filter(|&k| data.geometry.primitives[k].len() > data.geometry.large[k])
                    .collect(),
                _ => KindSet::default(),
            },
            bvh_stack: data
                .bvh
                .as_ref()
                .map_or(accel::MAX_DEPTH, |bvh| bvh.depth + 1),
            light_bvh_stack,
            instances: data.instancing.is_some(),
            instance_stack: data
                .instancing
                .as_ref()
                .map_or(accel::MAX_DEPTH, |instancing| instancing.group_depth + 1),
            filter,
            splat: false,
            profile: false,
            camera,
            aovs: Vec::new(),
            one_sided: data.has_one_sided_materials(),
            sides_by_shading_normal: settings.sides_by_shading_normal
                && !data.geometry.normal_kinds().is_empty(),
            masked: data.has_masked_materials(),
            opacity_textures: data.has_opacity_textures(),
            environment,
            light_environment: samples_lights && environment,
            spatial_light_selection: samples_lights
                && settings.light_selection == LightSelection::Spatial
                && strategy == Strategy::NeeMis
                && !environment
                && data.light_count() >= 2
                && data
                    .light_kinds()
                    .iter()
                    .all(|k| PRIMITIVE_KINDS[k].light_importance),
            delta_lights: !data.delta_lights.is_empty() && has_smooth_lobe(material_kinds),
            directional_lights: data.delta_lights.iter().any(|l| l.infinite != 0.0),
            delta_light_pick: data.delta_lights.len() > Self::MAX_DELTA_SHADOW_RAYS,
            textures: !data.textures.is_empty(),
            float_texels: data.texel_formats & (1 << TexelFormat::Float as u32) != 0,
            byte_texels: data.texel_formats & !(1 << TexelFormat::Float as u32) != 0,
            bump_maps: data
                .materials
                .iter()
                .any(|m| m.flags >> MATERIAL_BUMP_SHIFT != 0),
            textured_numbers: data.has_textured_numbers(),
            grouped_density,
            array_memory: ArrayMemory::Textures,
        }
    }

    /// This kernel with every primitive and material kind compiled in, as a kernel
    /// not specialised to the scene would be (for measuring what specialising saves).
    /// The light density stays as the scene needs it: it changes the estimator.
    /// Nothing is compiled in (the scene having no large primitives), and the
    /// stacks take the deepest BVH.
    pub fn generalized(self) -> KernelConfig {
        let all_primitives = KindSet::all(PRIMITIVE_KINDS.len());
        KernelConfig {
            primitive_kinds: all_primitives,
            material_kinds: KindSet::all(MATERIAL_KINDS.len()),
            compiled_in: None,
            bvh_kinds: match self.bvh() {
                true => all_primitives,
                false => KindSet::default(),
            },
            bvh_stack: accel::MAX_DEPTH,
            light_bvh_stack: accel::MAX_DEPTH,
            instance_stack: accel::MAX_DEPTH,
            ..self
        }
    }

    /// Everything compiled in: the kernel any scene could use.
    pub fn general(strategy: Strategy, accumulator: AccumulatorKind) -> KernelConfig {
        let all_primitives = KindSet::all(PRIMITIVE_KINDS.len());
        KernelConfig {
            primitive_kinds: all_primitives,
            normal_kinds: (0..PRIMITIVE_KINDS.len())
                .filter(|&k| PRIMITIVE_KINDS[k].shading_normals.is_some())
                .collect(),
            light_kinds: if strategy == Strategy::Bsdf {
                KindSet::default()
            } else {
                all_primitives
            },
            material_kinds: KindSet::all(MATERIAL_KINDS.len()),
            strategy,
            max_depth: 50,
            light_weight: 0.5,
            rr_depth: Some(5),
            sampler: Sampler::Sobol,
            accumulator,
            variance: true,
            adaptive: false,
            replicates: true,
            compiled_in: None,
            bvh_kinds: KindSet::default(),
            bvh_stack: accel::MAX_DEPTH,
            light_bvh_stack: accel::MAX_DEPTH,
            instances: false,
            instance_stack: accel::MAX_DEPTH,
            filter: Filter::Box,
            splat: false,
            profile: false,
            camera: CameraModel::Pinhole,
            aovs: Vec::new(),
            one_sided: true,
            sides_by_shading_normal: false,
            masked: true,
            opacity_textures: true,
            environment: true,
            light_environment: strategy != Strategy::Bsdf,
            spatial_light_selection: false,
            delta_lights: true,
            directional_lights: true,
            delta_light_pick: false,
            textures: true,
            float_texels: true,
            byte_texels: true,
            bump_maps: true,
            textured_numbers: true,
            grouped_density: GroupedDensity::Walk,
            array_memory: ArrayMemory::Textures,
        }
    }

    /// Whether a material kind made of other materials (`twosided`) is
    /// compiled in: the kernel resolves the material at each hit
    /// (`resolve_material`, materials.wgsl).
    pub fn nested_materials(&self) -> bool {
        self.material_kinds
            .iter()
            .any(|k| !MATERIAL_KINDS[k].nested.is_empty())
    }

    /// Whether shading normals differ from the geometric ones anywhere:
    /// interpolated on smooth meshes, or perturbed by bump and normal maps.
    pub fn shading_normals(&self) -> bool {
        !self.normal_kinds.is_empty() || self.bump_maps
    }

    pub fn scene_storage(&self) -> SceneStorage {
        match (&self.compiled_in, self.bvh()) {
            (_, true) => SceneStorage::Bvh,
            (Some(_), false) => SceneStorage::Baked,
            (None, false) => SceneStorage::Buffers,
        }
    }

    /// Whether closest hits are found through a BVH.
    pub fn bvh(&self) -> bool {
        !self.bvh_kinds.is_empty()
    }

    /// Whether the kernel compiles `source` in as constants rather than
    /// reading it from a storage buffer.
    pub fn compiles_in(&self, source: ArraySource) -> bool {
        let Some(data) = &self.compiled_in else {
            return false;
        };
        match source {
            _ if !self.bvh() => source.bakes(),
            ArraySource::Large(_) => true,
            ArraySource::Lights(k) => !data.lights[k].is_empty(),
            ArraySource::LightTable(k, _) => data.light_tables[k].is_some(),
            _ => false,
        }
    }

    /// Whether the array of `source` is read from a texture (else from a
    /// storage buffer, or compiled in).
    pub fn in_texture(&self, source: ArraySource) -> bool {
        self.array_memory == ArrayMemory::Textures && self.can_be_texture(source)
    }

    /// Whether the array of `source` is read from a texture under
    /// `ArrayMemory::Textures`: words, and not compiled in.
    pub fn can_be_texture(&self, source: ArraySource) -> bool {
        source.word_size().is_some() && !self.compiles_in(source)
    }

    /// Whether a material kind of the scene reads `material_tables`, or its
    /// textured numbers' lists are there.
    pub fn reads_material_tables(&self) -> bool {
        self.textured_numbers || self.material_kinds.iter().any(|k| MATERIAL_KINDS[k].tables)
    }

    /// Whether the samples interleave Sobol's replicates: `replicates` is moot for
    /// the independent sampler.
    pub fn sobol_replicates(&self) -> bool {
        self.replicates && self.sampler == Sampler::Sobol
    }

    pub fn samples_lights(&self) -> bool {
        !self.light_kinds.is_empty() || self.light_environment
    }

    /// Whether next-event estimation's shadow rays find their closest hit for
    /// less (`SHADOW_LIGHTS_FIRST`, `glue::shadow_intersection`): the nearest of
    /// the lights, each tested in turn, then `occluded` asks whether anything
    /// is nearer, its walk ending at the first hit it finds. Every emitting
    /// surface is in the light density, and under nee-mis nothing else is, so
    /// that is the closest hit's emitter or none. Where the environment is the
    /// only light (no light to test), and where `occluded` walks a BVH and
    /// the lights are kinds listed one by one (not a mesh's faces, held in
    /// groups); not where surfaces let shadow rays through.
    pub fn shadow_rays_find_lights_first(&self) -> bool {
        let environment_alone = self.light_environment && self.light_kinds.is_empty();
        let lights_one_by_one = self.bvh() && self.grouped_light_kinds().next().is_none();
        self.strategy == Strategy::NeeMis
            && !self.masked
            && (environment_alone || lights_one_by_one)
    }

    /// Whether the kernel traces shadow rays through `occluded`: nee-mis's
    /// (`shadow_rays_find_lights_first`), and the point, spot and directional
    /// lights', unless masked surfaces make them sum transparencies.
    pub fn traces_occlusion(&self) -> bool {
        self.aovs.is_empty()
            && !self.masked
            && (self.delta_lights || self.shadow_rays_find_lights_first())
    }

    /// Whether the kernel evaluates BSDFs (`bsdf_eval` and its kin): light
    /// sampling and the delta lights' shadow rays do, and so does the AOV
    /// pass's `albedo`, for materials whose albedo is their BSDF toward the
    /// normal (whatever strategy renders the image).
    pub fn evaluates_bsdfs(&self) -> bool {
        self.samples_lights() || self.delta_lights || self.aovs.contains(&AovKind::Albedo)
    }

    /// The kinds in the light density whose lights come in groups.
    pub fn grouped_light_kinds(&self) -> impl Iterator<Item = usize> {
        self.light_kinds
            .iter()
            .filter(|&k| PRIMITIVE_KINDS[k].grouped_lights)
    }

    /// Whether the light density walks the groups' BVH (`LightTablePart::BvhNodes`).
    pub fn walks_light_groups(&self) -> bool {
        self.grouped_light_kinds().next().is_some() && self.grouped_density == GroupedDensity::Walk
    }

    /// Whether next-event estimation weighs grouped lights by the points hit.
    pub fn light_points(&self) -> bool {
        self.grouped_density == GroupedDensity::Points
    }

    /// The strategy, for a run's header: "nee-mis", or "nee-mis, spatial light
    /// selection" where its next-event estimates pick lights spatially.
    pub fn describe_strategy(&self) -> String {
        match self.spatial_light_selection {
            true => format!("{}, spatial light selection", self.strategy),
            false => self.strategy.to_string(),
        }
    }

    /// The pixel filter and how samples are made pixels of, for a run's header:
    /// "box filter", "gaussian filter, splatted" or "tent filter, offsets drawn"
    /// (an adaptive run: "splatted in uniform rounds, offsets drawn in others").
    pub fn describe_filter(&self) -> String {
        match (self.filter, self.splat, self.adaptive) {
            (Filter::Box, _, _) => "box filter".into(),
            (filter, true, true) => format!(
                "{} filter, splatted in uniform rounds, offsets drawn in others",
                filter.name()
            ),
            (filter, true, false) => format!("{} filter, splatted", filter.name()),
            (filter, false, _) => format!("{} filter, offsets drawn", filter.name()),
        }
    }

    /// The sampler, for a run's header: "independent sampler", "sobol sampler"
    /// (one sequence per pixel) or "sobol sampler, 4 replicates".
    pub fn describe_sampler(&self) -> String {
        match (self.sampler, self.replicates) {
            (Sampler::Sobol, true) => format!("sobol sampler, {REPLICATES} replicates"),
            (sampler, _) => format!("{sampler} sampler"),
        }
    }

    pub fn flags(&self) -> BTreeSet<String> {
        let mut flags = BTreeSet::new();
        for k in self.primitive_kinds.iter() {
            flags.insert(PRIMITIVE_KINDS[k].flag());
        }
        for k in self.light_kinds.iter() {
            flags.insert(PRIMITIVE_KINDS[k].light_flag());
        }
        for k in self.normal_kinds.iter() {
            flags.insert(PRIMITIVE_KINDS[k].normals_flag());
        }
        for k in self.material_kinds.iter() {
            flags.insert(MATERIAL_KINDS[k].flag());
        }
        let features = [
            ("STRATEGY_BSDF", self.strategy == Strategy::Bsdf),
            ("STRATEGY_LIGHT", self.strategy == Strategy::Light),
            ("STRATEGY_NEE", self.strategy == Strategy::NeeMis),
            ("LIGHT_DENSITY", self.samples_lights()),
            ("LIGHT_POINTS", self.light_points()),
            ("LIGHT_SELECTION_SPATIAL", self.spatial_light_selection),
            ("VARIANCE", self.variance),
            (
                "REPLICATE_SUMS",
                self.variance && self.sampler == Sampler::Sobol,
            ),
            ("ADAPTIVE", self.adaptive),
            ("SAMPLER_SOBOL", self.sampler == Sampler::Sobol),
            ("SAMPLER_REPLICATES", self.sobol_replicates()),
            ("BVH", self.bvh()),
            ("INSTANCES", self.instances),
            ("SHADING_NORMALS", self.shading_normals()),
            ("SIDES_BY_SHADING_NORMAL", self.sides_by_shading_normal),
            ("ONE_SIDED", self.one_sided),
            ("MASK", self.masked),
            ("OPACITY_TEXTURES", self.opacity_textures),
            ("ENVIRONMENT", self.environment),
            ("LIGHT_ENVIRONMENT", self.light_environment),
            ("SHADOW_LIGHTS_FIRST", self.shadow_rays_find_lights_first()),
            ("DELTA_LIGHTS", self.delta_lights),
            (
                "DELTA_LIGHTS_PICK",
                self.delta_lights && self.delta_light_pick,
            ),
            (
                "DIRECTIONAL_LIGHTS",
                self.delta_lights && self.directional_lights,
            ),
            ("TEXTURES", self.textures),
            ("FLOAT_TEXELS", self.textures && self.float_texels),
            ("BYTE_TEXELS", self.textures && self.byte_texels),
            ("BUMP_MAPS", self.bump_maps),
            ("TEXTURED_NUMBERS", self.textured_numbers),
            ("NESTED_MATERIALS", self.nested_materials()),
            ("THIN_LENS", self.camera == CameraModel::ThinLens),
            ("ORTHOGRAPHIC", self.camera == CameraModel::Orthographic),
            ("SPLAT", self.splat),
            // The kernel adds samples to their pixel's sums.
            ("KERNEL_SUMS", self.draws_offsets()),
            ("PROFILE", self.profile),
            (
                "AOV_MATERIAL",
                self.aovs.contains(&AovKind::Albedo) || self.aovs.contains(&AovKind::ShNormal),
            ),
        ];
        for (flag, on) in features {
            if on {
                flags.insert(flag.to_string());
            }
        }
        flags.extend(self.aovs.iter().map(|kind| kind.flag()));
        // A splatting kernel's pass evaluates the filter.
        let filter_flags = self.filter.flags().iter();
        flags.extend(
            filter_flags
                .filter(|&&flag| self.draws_offsets() || flag != "FILTER_OFFSET")
                .map(|flag| flag.to_string()),
        );
        flags
    }

    /// Whether the kernel draws its camera rays' offsets from the filter and
    /// adds each sample to its own pixel's sums: a kernel that does not splat,
    /// and an adaptive one in the rounds it does not splat (`Params::splatting`).
    fn draws_offsets(&self) -> bool {
        !self.splat || self.adaptive
    }

    /// The modules in composition order; `constants`, `scene` and `bsdf` are
    /// generated (`glue`).
    pub fn modules(&self) -> Vec<ShaderModule> {
        let generated = |name: &'static str, source: String| ShaderModule {
            name,
            source: source.into(),
        };
        let mut modules = vec![generated("constants", glue::shared_constants()), COMMON];
        if self.profile {
            modules.push(PROFILE);
        }
        modules.extend([RNG, SAMPLING]);
        let geometry = self.primitive_kinds.iter().chain(self.light_kinds.iter());
        let geometry: KindSet = geometry.collect();
        modules.extend(geometry.iter().map(|k| PRIMITIVE_KINDS[k].module.clone()));
        let grouped_lights = self.grouped_light_kinds().next().is_some();
        // The light groups' density walks a BVH of its own.
        if self.bvh() || self.walks_light_groups() {
            modules.push(BVH);
        }
        if grouped_lights {
            modules.push(LIGHT_GROUPS);
        }
        modules.push(generated("scene", glue::scene(self)));
        if self.environment {
            modules.push(ENVIRONMENT);
        }
        modules.extend(self.material_modules());
        if self.delta_lights {
            modules.push(DELTA_LIGHTS);
        }
        modules.push(STRATEGY);
        modules.push(self.accumulate_module());
        modules.push(SUMS);
        if self.draws_offsets() {
            modules.extend(self.filter_modules());
        }
        modules.push(CAMERA);
        match self.aovs.is_empty() {
            true => modules.push(KERNEL),
            false => modules.extend([generated("aov_layout", glue::aov_layout(self)), AOV]),
        }
        modules
    }

    /// The entry point of `source()`: the path kernel's, or the AOV pass's.
    pub fn entry_point(&self) -> &'static str {
        match self.aovs.is_empty() {
            true => ENTRY_POINT,
            false => AOV_ENTRY_POINT,
        }
    }

    /// The AOV pass over this kernel's scene, camera and filter, summing
    /// `aovs` (in `AovKind` order, each once) into an accumulator of
    /// `aov_layers` layers: its scene bindings are this kernel's, so it runs
    /// on the same scene bind group. It draws offsets from the filter where
    /// the path kernel splats (the same expected values, and no splatting
    /// pass for AOVs).
    pub fn for_aovs(&self, aovs: &[AovKind]) -> KernelConfig {
        assert!(!aovs.is_empty(), "an AOV pass computes some AOV");
        KernelConfig {
            aovs: aovs.to_vec(),
            variance: false,
            adaptive: false,
            splat: false,
            profile: false,
            ..self.clone()
        }
    }

    /// The accumulator layers of the AOV pass: a running sum and its
    /// compensation per AOV type.
    pub fn aov_layers(&self) -> u32 {
        2 * self.aovs.len() as u32
    }

    /// The splatting pass over this kernel's samples and accumulator
    /// (`shaders/splat.wgsl`), whose override constants are `filter.constants()`.
    pub fn splat_source(&self) -> Result<String, ComposeError> {
        let mut modules = vec![
            ShaderModule {
                name: "constants",
                source: glue::shared_constants().into(),
            },
            COMMON,
            self.accumulate_module(),
            SUMS,
        ];
        modules.extend(self.filter_modules());
        modules.push(ShaderModule {
            name: "splat_window",
            source: glue::splat_window(self.filter).into(),
        });
        modules.push(SPLAT);
        // The pass evaluates the filter; an adaptive kernel's offsets are its own.
        let mut flags = self.flags();
        flags.remove("FILTER_OFFSET");
        self.compose_with_flags(&modules, flags)
    }

    /// The pixel filter's sampler and, for a tabulated filter, its table;
    /// nothing for the box filter, which `camera_ray` draws itself.
    fn filter_modules(&self) -> Vec<ShaderModule> {
        let table = self.filter.table().map(|table| ShaderModule {
            name: "filter_table",
            source: glue::filter_table(&table).into(),
        });
        match self.filter {
            Filter::Box => vec![],
            _ => table.into_iter().chain([FILTER_MODULE]).collect(),
        }
    }

    /// The error estimate's shader over this kernel's accumulator
    /// (`gpu::error_estimate`).
    pub fn error_estimate_source(&self) -> Result<String, ComposeError> {
        let modules = [
            ShaderModule {
                name: "constants",
                source: glue::shared_constants().into(),
            },
            self.accumulate_module(),
            ERROR_ESTIMATE,
        ];
        self.compose(&modules)
    }

    fn accumulate_module(&self) -> ShaderModule {
        match self.accumulator {
            AccumulatorKind::Texture => ACCUMULATE_TEXTURE,
            AccumulatorKind::Buffer => ACCUMULATE_BUFFER,
        }
    }

    /// The BSDF interface, the helpers the material kinds share (each once),
    /// the kinds' modules and the generated dispatch.
    fn material_modules(&self) -> Vec<ShaderModule> {
        let mut modules = vec![MATERIALS];
        if self.textures {
            modules.push(TEXTURES);
        }
        for k in self.material_kinds.iter() {
            for helper in MATERIAL_KINDS[k].helpers {
                if !modules.iter().any(|m| m.name == helper.name) {
                    modules.push(helper.clone());
                }
            }
        }
        modules.extend(
            self.material_kinds
                .iter()
                .filter_map(|k| MATERIAL_KINDS[k].module.clone()),
        );
        modules.push(ShaderModule {
            name: "bsdf",
            source: glue::bsdf(self).into(),
        });
        modules
    }

    pub fn source(&self) -> Result<String, ComposeError> {
        self.compose(&self.modules())
    }

    fn compose(&self, modules: &[ShaderModule]) -> Result<String, ComposeError> {
        self.compose_with_flags(modules, self.flags())
    }

    fn compose_with_flags(
        &self,
        modules: &[ShaderModule],
        flags: BTreeSet<String>,
    ) -> Result<String, ComposeError> {
        let flags: BTreeSet<&str> = flags.iter().map(String::as_str).collect();
        let known = known_flags();
        let known: Vec<&str> = known.iter().map(String::as_str).collect();
        let arrays = self.scene_arrays();
        let forms: BTreeMap<&str, ArrayForm> = arrays
            .iter()
            .map(|array| (array.name.as_str(), self.array_form(array)))
            .collect();
        let directives = Directives {
            flags: &flags,
            known_flags: &known,
            arrays: &forms,
        };
        compose(modules, &directives)
    }

    /// A compute shader running the BSDF interface of `material_kinds` (plus
    /// Lambertian) on its own, with independent random numbers: the entry
    /// points `probe_sample` and `probe_eval` of `shaders/bsdf_probe.wgsl`, for
    /// testing each material's sampling against its density on the device.
    pub fn bsdf_probe_source(material_kinds: KindSet) -> Result<String, ComposeError> {
        let lambertian = MATERIAL_KINDS
            .iter()
            .position(|k| k.name == "lambertian")
            .expect("lambertian is a kind");
        let config = KernelConfig {
            primitive_kinds: KindSet::default(),
            // Light sampling on: the dispatch then has `bsdf_eval` and `bsdf_pdf`.
            light_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
            // Kinds made of others have no BSDF of their own to probe (and the
            // probe no scene to resolve them in).
            material_kinds: material_kinds
                .iter()
                .filter(|&k| MATERIAL_KINDS[k].nested.is_empty())
                .collect::<KindSet>()
                .with(lambertian),
            sampler: Sampler::Independent,
            environment: false,
            light_environment: false,
            textures: false,
            float_texels: false,
            byte_texels: false,
            bump_maps: false,
            textured_numbers: false,
            opacity_textures: false,
            ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
        };
        let mut modules = probe_prelude();
        modules.extend(config.material_modules());
        modules.push(BSDF_PROBE);
        config.compose(&modules)
    }

    /// A compute shader running the environment map's sampling and density on
    /// their own, with independent random numbers: the entry points
    /// `probe_sample` and `probe_pdf` of `shaders/environment_probe.wgsl`, the
    /// map's arrays in group 1 as a scene's kernel binds them.
    pub fn environment_probe_source() -> Result<String, ComposeError> {
        let config = KernelConfig {
            primitive_kinds: KindSet::default(),
            light_kinds: KindSet::default(),
            normal_kinds: KindSet::default(),
            material_kinds: KindSet::default(),
            sampler: Sampler::Independent,
            ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
        };
        let arrays = config
            .scene_arrays()
            .into_iter()
            .filter(|array| matches!(array.source, ArraySource::Environment(_)))
            .collect();
        let mut modules = probe_prelude();
        modules.extend([
            ShaderModule {
                name: "environment_arrays",
                source: glue::buffer_arrays(arrays).into(),
            },
            ENVIRONMENT,
            ENVIRONMENT_PROBE,
        ]);
        config.compose(&modules)
    }

    /// A compute shader running the offset sampler of a pixel filter other than
    /// the box (which `camera_ray` draws itself) on its own, with independent
    /// random numbers: the entry point `probe_filter` of
    /// `shaders/filter_probe.wgsl`, whose override constants are `filter.constants()`.
    pub fn filter_probe_source(filter: Filter) -> Result<String, ComposeError> {
        let config = KernelConfig {
            sampler: Sampler::Independent,
            filter,
            ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
        };
        let mut modules = probe_prelude();
        modules.extend(config.filter_modules());
        modules.push(FILTER_PROBE);
        config.compose(&modules)
    }

    /// The scene arrays this kernel declares, in binding order.
    pub fn scene_arrays(&self) -> Vec<SceneArray> {
        let count = PRIMITIVE_KINDS.len() as u32;
        let mut arrays = vec![SceneArray {
            name: "materials".into(),
            binding: 0,
            indexed: true,
            source: ArraySource::Materials,
        }];
        if self.reads_material_tables() {
            arrays.push(SceneArray {
                name: "material_tables".into(),
                binding: 6 + 7 * count,
                indexed: true,
                source: ArraySource::MaterialTables,
            });
        }
        for k in self.primitive_kinds.iter() {
            let kind = PRIMITIVE_KINDS[k];
            arrays.push(SceneArray {
                name: kind.array.into(),
                binding: 1 + k as u32,
                // The BVH's leaves, and the shading normal and texture
                // coordinates at the closest hit (the normal itself, for kinds
                // that keep the primitive), look primitives up by index.
                indexed: self.bvh()
                    || self.normal_kinds.contains(k)
                    || self.textures
                    || kind.keeps_primitive,
                source: ArraySource::Primitives(k),
            });
        }
        if let Some(data) = self.compiled_in.as_ref().filter(|_| self.bvh()) {
            for k in self
                .primitive_kinds
                .iter()
                .filter(|&k| data.geometry.large[k] > 0)
            {
                arrays.push(SceneArray {
                    name: format!("large_{}", PRIMITIVE_KINDS[k].array),
                    // Never a buffer.
                    binding: 10 + 8 * count + k as u32,
                    indexed: false,
                    source: ArraySource::Large(k),
                });
            }
        }
        for k in self.normal_kinds.iter() {
            arrays.push(SceneArray {
                name: PRIMITIVE_KINDS[k].normals_array(),
                binding: 3 + 2 * count + k as u32,
                indexed: true,
                source: ArraySource::Normals(k),
            });
        }
        for k in self.grouped_light_kinds() {
            for (j, part) in LightTablePart::ALL.into_iter().enumerate() {
                let walk = matches!(part, LightTablePart::BvhNodes | LightTablePart::BvhRefs);
                if walk && !self.walks_light_groups() {
                    continue;
                }
                arrays.push(SceneArray {
                    name: part.array(PRIMITIVE_KINDS[k].name),
                    binding: 3 + 3 * count + 4 * k as u32 + j as u32,
                    indexed: true,
                    source: ArraySource::LightTable(k, part),
                });
            }
        }
        for k in self.light_kinds.iter() {
            let kind = PRIMITIVE_KINDS[k];
            arrays.push(SceneArray {
                name: kind.light_array(),
                binding: 1 + count + k as u32,
                indexed: true,
                source: ArraySource::Lights(k),
            });
        }
        if self.bvh() {
            arrays.push(SceneArray {
                name: "bvh_nodes".into(),
                binding: 1 + 2 * count,
                indexed: true,
                source: ArraySource::BvhNodes,
            });
        }
        if self.instances {
            arrays.push(SceneArray {
                name: "instances".into(),
                // After the large primitives (one binding per primitive kind).
                binding: 10 + 9 * count,
                indexed: true,
                source: ArraySource::Instances,
            });
        }
        if self.textures {
            arrays.push(SceneArray {
                name: "textures".into(),
                binding: 7 + 7 * count,
                indexed: true,
                source: ArraySource::Textures,
            });
            arrays.push(SceneArray {
                name: "texture_texels".into(),
                binding: 8 + 7 * count,
                indexed: true,
                source: ArraySource::TextureTexels,
            });
            for k in self.primitive_kinds.iter() {
                let kind = PRIMITIVE_KINDS[k];
                if kind.texture_uvs.is_some() {
                    arrays.push(SceneArray {
                        name: kind.uvs_array(),
                        binding: 9 + 7 * count + k as u32,
                        indexed: true,
                        source: ArraySource::Uvs(k),
                    });
                }
            }
        }
        if self.environment {
            let parts = [
                (EnvironmentPart::Info, "environment_info"),
                (EnvironmentPart::Texels, "environment_texels"),
                (EnvironmentPart::Pyramid, "environment_pyramid"),
            ];
            for (j, (part, name)) in parts.into_iter().enumerate() {
                if part == EnvironmentPart::Pyramid && !self.light_environment {
                    continue;
                }
                arrays.push(SceneArray {
                    name: name.into(),
                    // After the grouped lights' tables (4 per kind).
                    binding: 3 + 7 * count + j as u32,
                    indexed: true,
                    source: ArraySource::Environment(part),
                });
            }
        }
        if self.delta_lights {
            arrays.push(SceneArray {
                name: "delta_lights".into(),
                // After the texture coordinates (one binding per primitive kind).
                binding: 9 + 8 * count,
                indexed: true,
                source: ArraySource::DeltaLights,
            });
        }
        arrays
    }

    /// Where `#for_each` finds the elements of `array`.
    fn array_form(&self, array: &SceneArray) -> ArrayForm {
        match &self.compiled_in {
            Some(data) if self.compiles_in(array.source) => {
                ArrayForm::Constants(match array.source {
                    ArraySource::Materials => data.materials.len(),
                    ArraySource::Primitives(k) | ArraySource::Large(k) => {
                        data.geometry.primitives[k].len()
                    }
                    ArraySource::Lights(k) => data.lights[k].len(),
                    ArraySource::Normals(k) => data.geometry.primitives[k].len(),
                    ArraySource::LightTable(..) | ArraySource::DeltaLights => {
                        data.array_bytes(array.source).len() / array.element_size()
                    }
                    ArraySource::BvhNodes | ArraySource::Instances => {
                        unreachable!("a BVH is never compiled in")
                    }
                    ArraySource::Environment(_)
                    | ArraySource::MaterialTables
                    | ArraySource::Textures
                    | ArraySource::TextureTexels
                    | ArraySource::Uvs(_) => unreachable!("never baked"),
                })
            }
            _ => ArrayForm::Buffer,
        }
    }

    /// Values of the WGSL `override` constants.
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let mut constants = vec![
            ("MAX_DEPTH", self.max_depth as f64),
            ("LIGHT_WEIGHT", self.light_weight as f64),
            ("RR_DEPTH", self.rr_depth.unwrap_or(u32::MAX) as f64),
        ];
        if self.draws_offsets() {
            constants.extend(self.filter.constants());
        }
        constants
    }

    /// Scene arrays read from storage buffers (group 1): when the scene is
    /// baked, only those never baked (an environment map's).
    pub fn scene_bindings(&self) -> Vec<SceneArray> {
        self.scene_arrays()
            .into_iter()
            .filter(|array| !self.compiles_in(array.source))
            .collect()
    }

    /// Running sums the accumulator holds: each sum and its compensation
    /// (`abi::LAYER_*`).
    pub fn accumulator_layers(&self) -> u32 {
        accumulator_layers(self.variance, self.sampler)
    }
}

/// Layers of the accumulator: the sum, with `variance` the sum of squares, and
/// with both `variance` and Sobol the replicates' sums, each with its compensation.
pub fn accumulator_layers(variance: bool, sampler: Sampler) -> u32 {
    match (variance, sampler) {
        (false, _) => LAYER_SUM_COMPENSATION + 1,
        (true, Sampler::Independent) => LAYER_SQUARES_COMPENSATION + 1,
        (true, Sampler::Sobol) => replicate_layer(REPLICATES - 1) + 2,
    }
}

impl SceneData {
    /// The packed contents of one of the kernel's scene arrays.
    pub fn array_bytes(&self, source: ArraySource) -> &[u8] {
        match source {
            ArraySource::Materials => bytemuck::cast_slice(&self.materials),
            ArraySource::MaterialTables => bytemuck::cast_slice(&self.material_tables),
            ArraySource::Textures => bytemuck::cast_slice(&self.textures),
            ArraySource::TextureTexels => bytemuck::cast_slice(&self.texture_texels),
            ArraySource::Uvs(k) => &self.geometry.uvs[k],
            ArraySource::Primitives(k) => &self.geometry.primitives[k].bytes,
            ArraySource::Large(k) => {
                &self.geometry.primitives[k].bytes
                    [..self.geometry.large[k] * PRIMITIVE_KINDS[k].layout.size]
            }
            ArraySource::Lights(k) => &self.lights[k].bytes,
            ArraySource::Normals(k) => &self.geometry.normals[k],
            ArraySource::LightTable(k, part) => {
                let tables = self.light_tables[k]
                    .as_ref()
                    .expect("a kernel with grouped lights has their tables");
                match part {
                    LightTablePart::Groups => bytemuck::cast_slice(&tables.groups),
                    LightTablePart::Picks => bytemuck::cast_slice(&tables.picks),
                    LightTablePart::BvhNodes => bytemuck::cast_slice(&self.light_bvh(k).bvh.nodes),
                    LightTablePart::BvhRefs => bytemuck::cast_slice(&self.light_bvh(k).refs),
                }
            }
            ArraySource::BvhNodes => bytemuck::cast_slice(&self.bvh_part().nodes),
            ArraySource::Instances => bytemuck::cast_slice(
                &(self.instancing.as_ref())
                    .expect("an instancing kernel's scene has its instances built")
                    .records,
            ),
            ArraySource::DeltaLights => bytemuck::cast_slice(&self.delta_lights),
            ArraySource::Environment(part) => {
                let tables = self
                    .environment
                    .as_ref()
                    .expect("a kernel with an environment map has its tables");
                match part {
                    EnvironmentPart::Info => bytemuck::bytes_of(&tables.info),
                    EnvironmentPart::Texels => bytemuck::cast_slice(&tables.texels),
                    EnvironmentPart::Pyramid => bytemuck::cast_slice(&tables.pyramid),
                }
            }
        }
    }

    fn bvh_part(&self) -> &crate::accel::WideBvh {
        self.bvh
            .as_ref()
            .expect("a BVH kernel's scene has its BVH built")
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::abi::{Counters, Params};
    use crate::kinds::PackedArray;
    use crate::kinds::{ErasedLayout, Lobe, PackedQuad};

    /// `KernelConfig::for_scene` with a box filter, a buffer accumulator and no
    /// variance, as the kernel tests take it.
    fn box_filtered_kernel(
        data: &SceneData,
        strategy: Strategy,
        settings: &RenderSettings,
        storage: SceneStorage,
    ) -> KernelConfig {
        KernelConfig::for_scene(
            data,
            strategy,
            settings,
            Filter::Box,
            CameraModel::Pinhole,
            AccumulatorKind::Buffer,
            false,
            storage,
        )
    }

    /// Parses and validates `source`, failing with `what` and naga's report.
    fn validate_source(source: &str, what: &dyn std::fmt::Debug) -> naga::Module {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{what:?}\n{}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{what:?}\n{}", e.emit_to_string(source)));
        module
    }

    pub(crate) fn validate(config: &KernelConfig) -> naga::Module {
        validate_source(&config.source().unwrap(), config)
    }

    /// Every subset of primitive kinds with every set of at most two material
    /// kinds and with all of them (what a module needs of another shows in
    /// pairs: shared helpers, dispatch), with and without variance, the BVH and
    /// adaptive sampling,
    /// for every strategy and accumulator. Lights are sampled where a smooth
    /// material exists: from the kinds present, or from all when none is.
    fn all_variants() -> Vec<KernelConfig> {
        let (primitives, materials) = (PRIMITIVE_KINDS.len(), MATERIAL_KINDS.len());
        let material_sets: Vec<KindSet> = (0..1u32 << materials)
            .filter(|mask| mask.count_ones() <= 2 || mask.count_ones() == materials as u32)
            .map(KindSet::from_mask)
            .collect();
        let mut configs = Vec::new();
        for strategy in Strategy::ALL {
            for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
                let general = KernelConfig::general(strategy, accumulator);
                for mask in 0..(1u32 << (primitives + 2)) {
                    for &material_kinds in &material_sets {
                        let primitive_kinds = KindSet::from_mask(mask & ((1 << primitives) - 1));
                        let samples = has_smooth_lobe(material_kinds) && strategy != Strategy::Bsdf;
                        let light_kinds = match (samples, primitive_kinds.is_empty()) {
                            (false, _) => KindSet::default(),
                            (true, true) => KindSet::all(primitives),
                            (true, false) => primitive_kinds,
                        };
                        let variance = mask >> primitives & 1 != 0;
                        // Smooth shading, delta lights and textures go with variance (independent
                        // features on one bit, to keep the variants few).
                        let normal_kinds = primitive_kinds
                            .iter()
                            .filter(|&k| variance && general.normal_kinds.contains(k))
                            .collect();
                        configs.push(KernelConfig {
                            primitive_kinds,
                            light_kinds,
                            normal_kinds,
                            material_kinds,
                            variance,
                            // Adaptive sampling needs variance; with the BVH
                            // bit, to keep the variants few.
                            adaptive: variance && mask >> (primitives + 1) != 0,
                            bvh_kinds: match mask >> (primitives + 1) != 0 {
                                true => primitive_kinds,
                                false => KindSet::default(),
                            },
                            // Instances too, so that the BVH goes without them
                            // (and without variance) as well.
                            instances: variance
                                && mask >> (primitives + 1) != 0
                                && !primitive_kinds.is_empty(),
                            environment: false,
                            light_environment: false,
                            delta_lights: variance && has_smooth_lobe(material_kinds),
                            directional_lights: variance,
                            // Both ways of estimating them, on the BVH bit.
                            delta_light_pick: mask >> (primitives + 1) != 0,
                            textures: variance,
                            bump_maps: variance,
                            textured_numbers: variance,
                            opacity_textures: variance,
                            ..general.clone()
                        });
                    }
                }
            }
        }
        configs
    }

    #[test]
    fn every_module_combination_validates() {
        let check = |config: &KernelConfig| {
            validate(config);
            // The same arrays from storage buffers (the variants read textures),
            // over every primitive kind and feature with all materials.
            assert_eq!(config.array_memory, ArrayMemory::Textures);
            if config.material_kinds == KindSet::all(MATERIAL_KINDS.len()) {
                validate(&KernelConfig {
                    array_memory: ArrayMemory::Buffers,
                    ..config.clone()
                });
            }
            let mut bindings: Vec<u32> = config.scene_arrays().iter().map(|a| a.binding).collect();
            bindings.sort_unstable();
            let before = bindings.len();
            bindings.dedup();
            assert_eq!(bindings.len(), before, "two scene arrays share a binding");
        };
        // The longest test of the suite: spread over the cores.
        let variants = all_variants();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::thread::scope(|scope| {
            for t in 0..threads {
                let variants = &variants;
                scope.spawn(move || variants.iter().skip(t).step_by(threads).for_each(check));
            }
        });
    }

    /// The AOV pass over every kind and feature (textured numbers and
    /// instances among them), each AOV type alone (the material-free ones
    /// without materials' textures too) and all together, under either
    /// accumulator and from a splatting kernel: it validates, has
    /// the AOV entry point and no path kernel's, and its scene arrays are its
    /// path kernel's (it runs on that kernel's scene bind group).
    #[test]
    fn aov_kernels_validate() {
        for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
            let general = KernelConfig::general(Strategy::NeeMis, accumulator);
            let splatting = KernelConfig {
                splat: true,
                filter: Filter::Gaussian { stddev: 0.5 },
                ..general.clone()
            };
            let plain = KernelConfig {
                textures: false,
                textured_numbers: false,
                bump_maps: false,
                opacity_textures: false,
                masked: false,
                ..general.clone()
            };
            let instanced = KernelConfig {
                bvh_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
                instances: true,
                instance_stack: 12,
                ..general.clone()
            };
            // The `bsdf` strategy samples no light, yet the albedo evaluates BSDFs.
            let unaimed = KernelConfig::general(Strategy::Bsdf, accumulator);
            let mut passes = vec![
                general.for_aovs(&AovKind::ALL),
                unaimed.for_aovs(&AovKind::ALL),
                splatting.for_aovs(&AovKind::ALL),
                instanced.for_aovs(&AovKind::ALL),
            ];
            for kind in AovKind::ALL {
                passes.push(general.for_aovs(&[kind]));
                if kind != AovKind::Uv {
                    passes.push(plain.for_aovs(&[kind]));
                }
            }
            for pass in &passes {
                let module = validate(pass);
                let entries: Vec<&str> = module
                    .entry_points
                    .iter()
                    .map(|e| e.name.as_str())
                    .collect();
                assert_eq!(entries, [AOV_ENTRY_POINT]);
                assert_eq!(pass.entry_point(), AOV_ENTRY_POINT);
                let path_kernel = KernelConfig {
                    aovs: Vec::new(),
                    ..pass.clone()
                };
                assert_eq!(pass.scene_bindings(), path_kernel.scene_bindings());
            }
            assert!(!splatting.for_aovs(&[AovKind::Depth]).splat);
        }
    }

    /// An environment map with no other object in the light density, with every
    /// primitive kind, and with one of each grouped and plain kind, under every
    /// strategy and scene storage: the environment's buffers are bound even in
    /// a baked kernel.
    #[test]
    fn environment_kernels_validate() {
        let environment = crate::scene::EnvironmentMap {
            file: "sky.exr".into(),
            width: 4,
            height: 3,
            texels: std::sync::Arc::new(vec![[1.0, 0.5, 0.25]; 12]),
            scale: 2.0,
            to_world: glam::Mat3::IDENTITY,
        };
        let mut data = SceneData {
            materials: vec![Default::default()],
            environment: Some(std::sync::Arc::new(
                crate::environment::EnvironmentTables::build(&environment),
            )),
            ..SceneData::default()
        };
        data.geometry.primitives[0] = PackedArray {
            bytes: vec![0; size_of::<PackedQuad>()],
            materials: vec![0],
        };
        let settings = crate::scene::RenderSettings {
            spp: 1,
            max_depth: 4,
            strategy: Strategy::Mixture,
            auto_strategy: false,
            light_weight: 0.5,
            background: glam::Vec3::ZERO,
            seed: 0,
            rr_depth: crate::scene::Roulette::Off,
            sampler: Sampler::Sobol,
            light_selection: LightSelection::Spatial,
            adaptive: false,
            adaptive_metric: None,
            reconstruction: None,
            aovs: Vec::new(),
            sides_by_shading_normal: false,
        };
        for strategy in Strategy::ALL {
            for storage in [
                SceneStorage::Baked,
                SceneStorage::Buffers,
                SceneStorage::Bvh,
            ] {
                let config = box_filtered_kernel(&data, strategy, &settings, storage);
                assert!(config.environment);
                assert_eq!(config.light_environment, strategy != Strategy::Bsdf);
                validate(&config);
                let bound: Vec<String> = config
                    .scene_bindings()
                    .into_iter()
                    .map(|a| a.name)
                    .collect();
                assert!(
                    bound.contains(&"environment_texels".to_string()),
                    "{bound:?}"
                );
                // Every kind in the light density, grouped ones weighed each way
                // (by the points hit under `nee-mis` alone): only the walk binds
                // the light BVH.
                for density in [
                    GroupedDensity::Every,
                    GroupedDensity::Walk,
                    GroupedDensity::Points,
                ] {
                    if density == GroupedDensity::Points && strategy != Strategy::NeeMis {
                        continue;
                    }
                    let all_lights = KernelConfig {
                        light_kinds: if strategy == Strategy::Bsdf {
                            KindSet::default()
                        } else {
                            KindSet::all(PRIMITIVE_KINDS.len())
                        },
                        compiled_in: None,
                        grouped_density: density,
                        ..config.clone()
                    };
                    validate(&all_lights);
                    assert_eq!(
                        all_lights.flags().contains("LIGHT_POINTS"),
                        density == GroupedDensity::Points
                    );
                    let nodes = LightTablePart::BvhNodes.array("triangle");
                    assert_eq!(
                        all_lights.scene_bindings().iter().any(|a| a.name == nodes),
                        density == GroupedDensity::Walk && strategy != Strategy::Bsdf,
                        "{density:?} {strategy:?}"
                    );
                }
            }
        }
    }

    /// Textured numbers (a rough conductor's alpha, a principled roughness
    /// inside a `twosided`, so resolved at the hit) under every strategy and
    /// scene storage: the flag, the tables and their directory where the scene
    /// has them, and the kernel and tables as before where it has none.
    #[test]
    fn textured_number_kernels_validate() {
        let text = r#"
            [camera]
            lookfrom = [0, 0, -5]
            lookat = [0, 0, 0]
            [materials.brushed]
            type = "roughconductor"
            alpha = { type = "checkerboard", color0 = 0.3, color1 = 0.05 }
            [materials.leaf]
            type = "principled"
            roughness = { type = "checkerboard", to_uv = { scale = 4 } }
            sheen = 0.5
            [materials.both]
            type = "twosided"
            front = "leaf"
            back = "leaf"
            [materials.lamp]
            type = "light"
            emit = [1, 1, 1]
            [[objects]]
            type = "quad"
            q = [0, 0, 0]
            u = [1, 0, 0]
            v = [0, 1, 0]
            material = "brushed"
            [[objects]]
            type = "sphere"
            center = [0, 0, 2]
            radius = 1
            material = "both"
            [[objects]]
            type = "disk"
            center = [0, 2, 0]
            u = [1, 0, 0]
            v = [0, 1, 0]
            material = "lamp"
        "#;
        let mut scene = crate::scene::Scene::parse(text, "numbers.toml").unwrap();
        let data = SceneData::pack(&scene);
        for strategy in Strategy::ALL {
            for storage in [
                SceneStorage::Baked,
                SceneStorage::Buffers,
                SceneStorage::Bvh,
            ] {
                let config = box_filtered_kernel(&data, strategy, &scene.render, storage);
                assert!(config.textured_numbers && config.textures);
                assert!(config.nested_materials());
                validate(&config);
                let bound: Vec<String> = config
                    .scene_bindings()
                    .into_iter()
                    .map(|a| a.name)
                    .collect();
                assert!(bound.contains(&"material_tables".to_string()), "{bound:?}");
            }
        }
        // Its list is at the directory entry of its index: one texture in slot 0.
        let leaf = scene
            .materials
            .iter()
            .position(|m| m.name == "leaf")
            .unwrap();
        let list = data.material_tables[leaf] as usize;
        assert_eq!(&data.material_tables[list..list + 3], [1.0, 0.0, 1.0]);
        // Without them, the kernel and the tables are as before.
        for material in &mut scene.materials {
            material.number_textures.clear();
        }
        let plain = SceneData::pack(&scene);
        assert!(!plain.has_textured_numbers() && plain.textures.is_empty());
        assert_eq!(
            plain.material_tables.len(),
            4,
            "the principled's four numbers only"
        );
        let config = box_filtered_kernel(
            &plain,
            Strategy::Mixture,
            &scene.render,
            SceneStorage::Baked,
        );
        assert!(!config.textured_numbers);
    }

    /// A textured scene of every primitive kind (a mesh face too) under every
    /// strategy and scene storage: the texture arrays and the faces' uvs are
    /// bound in baked kernels too, and only where the scene has a texture.
    #[test]
    fn textured_kernels_validate() {
        let text = r#"
            [camera]
            lookfrom = [0, 0, -5]
            lookat = [0, 0, 0]
            [materials.checks]
            type = "lambertian"
            albedo = { type = "checkerboard", to_uv = { scale = 4 } }
            [materials.lamp]
            type = "light"
            emit = [1, 1, 1]
            [[objects]]
            type = "quad"
            q = [0, 0, 0]
            u = [1, 0, 0]
            v = [0, 1, 0]
            material = "checks"
            [[objects]]
            type = "sphere"
            center = [0, 0, 2]
            radius = 1
            material = "lamp"
            [[objects]]
            type = "disk"
            center = [0, 2, 0]
            u = [1, 0, 0]
            v = [0, 1, 0]
            material = "checks"
        "#;
        let mut scene = crate::scene::Scene::parse(text, "textured.toml").unwrap();
        scene.shapes.triangles.push(crate::scene::Triangle {
            vertices: [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
            normals: None,
            uvs: None,
            material: 0,
            importance: false,
            mesh: 0,
        });
        let data = SceneData::pack(&scene);
        assert_eq!(data.textures.len(), 1);
        for strategy in Strategy::ALL {
            for storage in [
                SceneStorage::Baked,
                SceneStorage::Buffers,
                SceneStorage::Bvh,
            ] {
                let config = box_filtered_kernel(&data, strategy, &scene.render, storage);
                assert!(config.textures);
                validate(&config);
                let bound: Vec<String> = config
                    .scene_bindings()
                    .into_iter()
                    .map(|a| a.name)
                    .collect();
                for array in ["textures", "texture_texels", "triangle_uvs"] {
                    assert!(bound.contains(&array.to_string()), "{bound:?}");
                }
            }
        }
        // Without the texture (its mean colour left as the constant) the
        // materials differ only by the texture's index in the flags.
        scene.materials[0].texture = None;
        let plain = SceneData::pack(&scene);
        assert!(plain.textures.is_empty() && plain.geometry.uvs.iter().all(Vec::is_empty));
        let shift = crate::kinds::MATERIAL_TEXTURE_SHIFT;
        assert_eq!(data.materials[0].flags >> shift, 1);
        let mut untextured = data.materials.clone();
        untextured[0].flags &= (1 << shift) - 1;
        assert_eq!(plain.materials, untextured);
        assert!(
            !box_filtered_kernel(
                &plain,
                Strategy::Mixture,
                &scene.render,
                SceneStorage::Baked
            )
            .textures
        );
    }

    #[test]
    fn environment_probe_validates() {
        let source = KernelConfig::environment_probe_source().unwrap();
        validate_source(&source, &"the environment probe");
    }

    /// The BSDF probe of tests/bsdf.rs, with every material kind.
    #[test]
    fn bsdf_probe_validates() {
        let source = KernelConfig::bsdf_probe_source(KindSet::all(MATERIAL_KINDS.len())).unwrap();
        validate_source(&source, &"the BSDF probe");
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

    fn named_constant(module: &naga::Module, name: &str) -> Option<Vec<u32>> {
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))?;
        Some(constant_words(module, c.init))
    }

    /// The words of every element constant of baked array `name`, in order.
    fn baked_words(module: &naga::Module, name: &str) -> Vec<u32> {
        (0..)
            .map_while(|i| named_constant(module, &crate::shader::element_constant(name, i)))
            .flatten()
            .collect()
    }

    /// What naga reads from the baked constants is exactly what the buffers hold.
    #[test]
    fn baked_constants_are_the_buffer_contents() {
        let mut arrays_checked = 0;
        for file in [
            "cornell.toml",
            "cornell-boxes.toml",
            "furnace.toml",
            "materials.toml",
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("scenes")
                .join(file);
            let scene = crate::scene::Scene::load(&path).unwrap();
            let data = SceneData::pack(&scene);
            let config = KernelConfig::for_scene(
                &data,
                Strategy::Mixture,
                &scene.render,
                scene.camera.filter,
                scene.camera.model(),
                AccumulatorKind::Buffer,
                false,
                SceneStorage::Baked,
            );
            let module = validate(&config);
            // The material tables stay in a buffer (`ArraySource::bakes`).
            let baked = config
                .scene_arrays()
                .into_iter()
                .filter(|a| a.source.bakes());
            for array in baked {
                let expected: Vec<u32> =
                    bytemuck::pod_collect_to_vec(data.array_bytes(array.source));
                assert_eq!(
                    baked_words(&module, &array.name),
                    expected,
                    "{file}: {}",
                    array.name
                );
                arrays_checked += 1;
            }
        }
        // materials, quads, light quads (x3), the cornell box's sphere and light
        // sphere, and the materials scene's arrays.
        assert!(arrays_checked >= 14, "{arrays_checked}");
    }

    /// How a kernel weighs emitting mesh faces follows their number and the
    /// strategy, and only one that walks their BVH builds it.
    #[test]
    fn emitting_faces_are_weighed_by_their_number() {
        let text = r#"
            [camera]
            lookfrom = [0, 0, 5]
            lookat = [0, 0, 0]
            [materials.floor]
            type = "lambertian"
            albedo = [0.5, 0.5, 0.5]
            [materials.lamp]
            type = "light"
            emit = [1, 1, 1]
            [[objects]]
            type = "sphere"
            center = [0, -101, 0]
            radius = 100
            material = "floor"
        "#;
        let (every, walk, points) = (
            GroupedDensity::Every,
            GroupedDensity::Walk,
            GroupedDensity::Points,
        );
        for (faces, expected) in [
            (12, [every, every, every]),
            (40, [every, every, points]),
            (60, [walk, walk, points]),
        ] {
            let mut scene = crate::scene::Scene::parse(text, "lamp.toml").unwrap();
            let lamp = scene
                .materials
                .iter()
                .position(|m| m.name == "lamp")
                .unwrap();
            for i in 0..faces {
                let x = glam::Vec3::X * i as f32;
                scene.shapes.triangles.push(crate::scene::Triangle {
                    vertices: [x, x + glam::Vec3::X, x + glam::Vec3::Y],
                    normals: None,
                    uvs: None,
                    material: lamp as u32,
                    importance: true,
                    mesh: 0,
                });
            }
            let strategies = [Strategy::Mixture, Strategy::Light, Strategy::NeeMis];
            for (strategy, expected) in strategies.into_iter().zip(expected) {
                let data = SceneData::pack(&scene);
                let config =
                    box_filtered_kernel(&data, strategy, &scene.render, SceneStorage::Buffers);
                assert_eq!(config.grouped_density, expected, "{faces} {strategy:?}");
                let triangle = kind_index("triangle");
                let built = data.light_tables[triangle].as_ref().unwrap().walk.get();
                assert_eq!(built.is_some(), expected == walk, "{faces} {strategy:?}");
            }
        }
    }

    /// Beside a BVH the large primitives (the sphere field's ground) and a
    /// small light density (its lamp) are compiled in, bit for bit what their
    /// buffers would hold, and left out of the bindings; a large light density
    /// stays in buffers.
    #[test]
    fn large_primitives_and_few_lights_are_compiled_in_beside_a_bvh() {
        let scene = crate::scene::sphere_field(300);
        let mut data = SceneData::pack(&scene);
        crate::accel::put_large_first(&mut data.geometry);
        data.bvh = crate::accel::WideBvh::build(&mut data.geometry);
        let sphere = kind_index("sphere");
        assert_eq!(data.geometry.large[sphere], 1);
        let config_for = |data: &SceneData| {
            box_filtered_kernel(data, Strategy::NeeMis, &scene.render, SceneStorage::Bvh)
        };
        let config = config_for(&data);
        let module = validate(&config);
        for (name, source) in [
            ("large_spheres", ArraySource::Large(sphere)),
            ("light_spheres", ArraySource::Lights(sphere)),
        ] {
            assert!(config.compiles_in(source), "{name}");
            let expected: Vec<u32> = bytemuck::pod_collect_to_vec(data.array_bytes(source));
            assert!(!expected.is_empty());
            assert_eq!(baked_words(&module, name), expected, "{name}");
        }
        let bound: Vec<String> = config
            .scene_bindings()
            .into_iter()
            .map(|a| a.name)
            .collect();
        assert_eq!(bound, ["materials", "spheres", "bvh_nodes"]);

        let lamp = data.lights[sphere].clone();
        let lights = &mut data.lights[sphere];
        for _ in 0..SceneStorage::MAX_BAKED_OBJECTS {
            lights.bytes.extend_from_slice(&lamp.bytes);
            lights.materials.extend_from_slice(&lamp.materials);
        }
        let config = config_for(&data);
        validate(&config);
        assert!(config.compiles_in(ArraySource::Large(sphere)));
        assert!(!config.compiles_in(ArraySource::Lights(sphere)));
    }

    #[test]
    fn small_finite_scenes_are_baked_by_default() {
        let quads = |n: usize| {
            let mut data = SceneData {
                materials: vec![Default::default()],
                ..SceneData::default()
            };
            data.geometry.primitives[0] = PackedArray {
                bytes: vec![0; n * size_of::<PackedQuad>()],
                materials: vec![0; n],
            };
            data
        };
        let max = SceneStorage::MAX_BAKED_OBJECTS;
        assert_eq!(SceneStorage::auto(&quads(max)), SceneStorage::Baked);
        assert_eq!(SceneStorage::auto(&quads(max + 1)), SceneStorage::Bvh);
        let mut infinite = quads(1);
        infinite.geometry.primitives[0].bytes[..4].copy_from_slice(&f32::INFINITY.to_ne_bytes());
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
        let material = |x: f32| PackedMaterial {
            albedo: [x, -x, x * 0.5],
            param: x,
            ..Default::default()
        };
        let data = SceneData {
            materials: values.iter().map(|&x| material(x)).collect(),
            ..SceneData::default()
        };
        let config = KernelConfig {
            primitive_kinds: KindSet::default(),
            light_kinds: KindSet::default(),
            normal_kinds: KindSet::default(),
            compiled_in: Some(data.clone()),
            ..KernelConfig::general(Strategy::Bsdf, AccumulatorKind::Buffer)
        };
        let module = validate(&config);
        assert_eq!(
            baked_words(&module, "materials"),
            bytemuck::cast_slice::<_, u32>(&data.materials)
        );
    }

    fn kind_index(name: &str) -> usize {
        let primitive = PRIMITIVE_KINDS.iter().position(|k| k.name == name);
        let material = || MATERIAL_KINDS.iter().position(|k| k.name == name);
        primitive.or_else(material).unwrap()
    }

    /// One of each pixel filter.
    pub(crate) const FILTERS: [Filter; 6] = [
        Filter::Box,
        Filter::Gaussian { stddev: 0.5 },
        Filter::Tent { radius: 1.25 },
        Filter::Mitchell { b: 0.25, c: 0.55 },
        Filter::CatmullRom,
        Filter::Lanczos { lobes: 3 },
    ];

    /// `constants` sets only override constants `module` declares, and every
    /// one it declares without a default (a pipeline fails on one without a value).
    fn assert_overrides_set(module: &naga::Module, constants: &[(&str, f64)], what: &str) {
        let set: BTreeSet<&str> = constants.iter().map(|&(name, _)| name).collect();
        for (_, o) in module.overrides.iter() {
            let name = o.name.as_deref().unwrap();
            assert!(
                o.init.is_some() || set.contains(name),
                "{what}: {name} unset"
            );
        }
        for name in set {
            let mut declared = module.overrides.iter();
            let declared = declared.any(|(_, o)| o.name.as_deref() == Some(name));
            assert!(declared, "{what}: {name} not declared");
        }
    }

    /// Each filter's code, with both samplers, and its probe: they validate
    /// with their override constants set. Only the scene's filter is compiled in.
    /// Each camera model's kernel validates, with each filter and sampler, and
    /// only the thin lens's reads the lens, only the orthographic's aims every
    /// ray one way.
    #[test]
    fn camera_kernels_validate() {
        for camera in [
            CameraModel::Pinhole,
            CameraModel::ThinLens,
            CameraModel::Orthographic,
        ] {
            for filter in [Filter::Box, Filter::Gaussian { stddev: 0.5 }] {
                for sampler in Sampler::ALL {
                    let config = KernelConfig {
                        filter,
                        sampler,
                        camera,
                        ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
                    };
                    validate(&config);
                    let source = config.source().unwrap();
                    assert_eq!(
                        source.contains("params.lens_radius"),
                        camera == CameraModel::ThinLens,
                        "{camera:?}"
                    );
                    assert_eq!(
                        source.contains("cross(params.delta_u, params.delta_v)"),
                        camera == CameraModel::Orthographic,
                        "{camera:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn filter_kernels_validate() {
        for filter in FILTERS {
            for sampler in Sampler::ALL {
                let config = KernelConfig {
                    filter,
                    sampler,
                    ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
                };
                let what = format!("{filter:?}");
                assert_overrides_set(&validate(&config), &config.constants(), &what);
                let source = config.source().unwrap();
                assert_eq!(source.contains("fn filter_offset"), filter != Filter::Box);
                assert_eq!(
                    source.contains("fn filter_bins_at"),
                    filter.table().is_some(),
                    "{what}"
                );
            }
            if filter != Filter::Box {
                let source = KernelConfig::filter_probe_source(filter).unwrap();
                let module = validate_source(&source, &filter);
                assert_overrides_set(&module, &filter.constants(), &format!("{filter:?} probe"));
            }
        }
    }

    #[test]
    fn absent_features_are_not_compiled_in() {
        let config = KernelConfig {
            primitive_kinds: KindSet::default().with(kind_index("quad")),
            light_kinds: KindSet::default().with(kind_index("quad")),
            normal_kinds: KindSet::default(),
            material_kinds: KindSet::default()
                .with(kind_index("lambertian"))
                .with(kind_index("light")),
            environment: false,
            light_environment: false,
            delta_lights: false,
            directional_lights: false,
            textures: false,
            float_texels: false,
            byte_texels: false,
            bump_maps: false,
            textured_numbers: false,
            opacity_textures: false,
            ..KernelConfig::general(Strategy::Mixture, AccumulatorKind::Buffer)
        };
        let source = config.source().unwrap();
        for absent in [
            "bumped_normal",
            "tangents",
            "sphere_hit_t",
            "dielectric_sample",
            "metal_sample",
            "light_spheres",
            "hit_kind",
            "shading_normal(",
            "bsdf_leaks",
            "environment",
            "delta_light",
        ] {
            assert!(!source.contains(absent), "{absent} compiled in");
        }
        let bsdf = KernelConfig::general(Strategy::Bsdf, AccumulatorKind::Buffer)
            .source()
            .unwrap();
        assert!(!bsdf.contains("fn light_pdf"));
        assert!(!bsdf.contains("fn scatter_smooth"));
    }

    /// A path samples each kind once a vertex: the strategy samples the
    /// smooth kinds, and the fallback after it only the kinds without a smooth
    /// lobe (lavapipe runs the code of every case, taken or not).
    #[test]
    fn smooth_kinds_are_sampled_once_a_vertex() {
        let fallback = |materials: &[&str]| {
            let config = KernelConfig {
                material_kinds: materials.iter().map(|name| kind_index(name)).collect(),
                // Without shading normals the dispatch is the function itself.
                normal_kinds: KindSet::default(),
                bump_maps: false,
                ..KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer)
            };
            let source = config.source().unwrap();
            // The function's body, after its signature's line.
            let signature = source
                .find("fn delta_bsdf_sample(")
                .expect("a fallback sampler");
            let start = signature + source[signature..].find('\n').unwrap();
            let end = start + source[start..].find("\n}\n").unwrap();
            source[start..end].to_string()
        };
        let mixed = fallback(&["lambertian", "roughplastic", "dielectric"]);
        assert!(mixed.contains("dielectric_sample("), "{mixed}");
        assert!(!mixed.contains("lambertian_sample("), "{mixed}");
        assert!(!mixed.contains("roughplastic_sample("), "{mixed}");
        let smooth_only = fallback(&["lambertian", "roughplastic"]);
        assert!(!smooth_only.contains("_sample("), "{smooth_only}");
    }

    /// nee-mis's shadow rays find the nearest light and then ask `occluded`
    /// where the environment is the only light, or where a BVH holds the
    /// surfaces and the lights are listed one by one (with instances too);
    /// not through masks, a mesh's emitting faces (in groups) or a baked scene.
    #[test]
    fn shadow_rays_find_lights_first_where_occluded_walks_a_bvh() {
        // With no point lights (whose shadow rays ask `occluded` whatever the strategy).
        let baked = KernelConfig {
            delta_lights: false,
            masked: false,
            opacity_textures: false,
            ..KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer)
        };
        let lights_first = |config: &KernelConfig| {
            let flag = config.flags().contains("SHADOW_LIGHTS_FIRST");
            let source = config.source().unwrap();
            assert_eq!(flag, source.contains("fn occluded("));
            assert_eq!(flag, source.contains("fn intersect_shadow_ray("));
            flag
        };
        assert!(!baked.bvh() && !baked.light_kinds.is_empty());
        assert!(!lights_first(&baked));
        let environment_alone = KernelConfig {
            light_kinds: KindSet::default(),
            ..baked.clone()
        };
        assert!(lights_first(&environment_alone));
        validate(&environment_alone);
        let one_by_one: KindSet = (PRIMITIVE_KINDS.iter().enumerate())
            .filter(|(_, kind)| kind.light_density && !kind.grouped_lights)
            .map(|(k, _)| k)
            .collect();
        let bvh = KernelConfig {
            bvh_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
            light_kinds: one_by_one,
            instances: false,
            ..baked.clone()
        };
        assert!(lights_first(&bvh));
        validate(&bvh);
        assert!(!lights_first(&KernelConfig {
            light_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
            ..bvh.clone()
        }));
        let instanced = KernelConfig {
            instances: true,
            ..bvh.clone()
        };
        assert!(lights_first(&instanced));
        validate(&instanced);
        assert!(!lights_first(&KernelConfig {
            masked: true,
            ..bvh.clone()
        }));
        assert!(!lights_first(&KernelConfig {
            strategy: Strategy::Mixture,
            ..bvh
        }));
    }

    /// The kernel's constants are the Rust ones: naga reads them back.
    #[test]
    fn shared_constants_match_rust() {
        use crate::abi::*;
        let module = validate(&KernelConfig::general(
            Strategy::NeeMis,
            AccumulatorKind::Buffer,
        ));
        let value = |name: &str| named_constant(&module, name).map(|words| words[0]);
        let mut expected = vec![
            ("LAYER_SUM", LAYER_SUM),
            ("LAYER_SUM_COMPENSATION", LAYER_SUM_COMPENSATION),
            ("LAYER_SQUARES", LAYER_SQUARES),
            ("LAYER_SQUARES_COMPENSATION", LAYER_SQUARES_COMPENSATION),
            ("LAYER_REPLICATES", LAYER_REPLICATES),
            ("REPLICATES", REPLICATES),
            ("BINDING_PARAMS", BINDING_PARAMS),
            ("BINDING_ACCUMULATOR", BINDING_ACCUMULATOR),
            ("BINDING_COUNTERS", BINDING_COUNTERS),
            ("BINDING_ACTIVE_PIXELS", BINDING_ACTIVE_PIXELS),
            (
                "ROUGH_TRANSMITTANCE_RES",
                crate::kinds::ROUGH_TRANSMITTANCE_RES as u32,
            ),
        ];
        let ids: Vec<(String, u32)> = MATERIAL_KINDS
            .iter()
            .enumerate()
            .map(|(id, kind)| (kind.id_constant(), id as u32))
            .collect();
        expected.extend(ids.iter().map(|(name, id)| (name.as_str(), *id)));
        let slots: Vec<(String, u32)> = (MATERIAL_KINDS.iter())
            .flat_map(|kind| {
                (kind.textured_numbers.iter().enumerate())
                    .map(move |(slot, key)| (kind.number_constant(key), slot as u32))
            })
            .collect();
        assert!(
            slots
                .iter()
                .any(|(name, _)| name == "NUMBER_PRINCIPLED_ROUGHNESS")
        );
        expected.extend(slots.iter().map(|(name, slot)| (name.as_str(), *slot)));
        expected.extend(crate::abi::MATERIAL_FLAGS.iter().copied());
        for (name, rust) in expected {
            assert_eq!(value(name), Some(rust), "{name}");
        }
        let byte_values = crate::kinds::texel_byte_values().map(f32::to_bits);
        assert_eq!(
            named_constant(&module, "TEXEL_BYTE_VALUES").as_deref(),
            Some(&byte_values[..])
        );
        let entry = &module.entry_points[0];
        assert_eq!(entry.name, ENTRY_POINT);
        assert_eq!(
            entry.workgroup_size,
            [WORKGROUP_SIZE.0, WORKGROUP_SIZE.1, 1]
        );
        let binding = |name: &str| {
            module
                .global_variables
                .iter()
                .find(|(_, v)| v.name.as_deref() == Some(name))
                .and_then(|(_, v)| v.binding)
                .map(|b| (b.group, b.binding))
        };
        assert_eq!(binding("dispatch_params"), Some((0, BINDING_PARAMS)));
        assert_eq!(binding("accumulator"), Some((0, BINDING_ACCUMULATOR)));
        assert_eq!(binding("counters"), Some((0, BINDING_COUNTERS)));
        assert_eq!(binding("active_pixels"), None);
        let adaptive = validate(&KernelConfig {
            adaptive: true,
            ..KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer)
        });
        let active = adaptive
            .global_variables
            .iter()
            .find(|(_, v)| v.name.as_deref() == Some("active_pixels"))
            .and_then(|(_, v)| v.binding.as_ref())
            .map(|b| (b.group, b.binding));
        assert_eq!(active, Some((0, BINDING_ACTIVE_PIXELS)));
        for array in KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer).scene_arrays()
        {
            assert_eq!(
                binding(&array.name),
                Some((1, array.binding)),
                "{}",
                array.name
            );
        }
    }

    /// The kernel with everything compiled in (textures, the environment, every
    /// kind) under `nee-mis` weighing grouped lights by the points hit.
    #[test]
    fn light_points_kernel_validates() {
        let config = KernelConfig {
            grouped_density: GroupedDensity::Points,
            ..KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer)
        };
        assert!(config.textures && config.environment && config.delta_lights);
        validate(&config);
    }

    /// The spatial light selection over every kind with a light importance,
    /// each module defining it, with the scene in storage buffers and (the
    /// `#for_each` blocks unrolled) compiled in.
    #[test]
    fn spatial_light_selection_kernel_validates() {
        let light_kinds: KindSet = (0..PRIMITIVE_KINDS.len())
            .filter(|&k| PRIMITIVE_KINDS[k].light_importance)
            .collect();
        assert!(light_kinds.iter().count() >= 3, "spheres, quads and disks");
        let config = KernelConfig {
            light_kinds,
            grouped_density: GroupedDensity::Every,
            environment: false,
            light_environment: false,
            spatial_light_selection: true,
            ..KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Buffer)
        };
        assert!(config.flags().contains("LIGHT_SELECTION_SPATIAL"));
        let module = validate(&config);
        for k in light_kinds.iter() {
            let name = format!("{}_light_importance", PRIMITIVE_KINDS[k].name);
            assert!(
                module
                    .functions
                    .iter()
                    .any(|(_, f)| f.name.as_deref() == Some(name.as_str())),
                "{name}"
            );
        }
    }

    /// Each kind's module defines what its description promises.
    #[test]
    fn kind_modules_define_their_interface() {
        let module = validate(&KernelConfig::general(
            Strategy::NeeMis,
            AccumulatorKind::Buffer,
        ));
        let defines = |name: &str| {
            module
                .functions
                .iter()
                .any(|(_, f)| f.name.as_deref() == Some(name))
        };
        for kind in PRIMITIVE_KINDS {
            let mut functions = vec!["hit_t", "hit_normal"];
            if !kind.keeps_primitive {
                functions.push("hit_keep");
            }
            if kind.light_density {
                functions.extend(["light_sample", "light_pdf"]);
            }
            if kind.grouped_lights {
                functions.push("light_point_pdf");
            }
            for function in functions {
                assert!(
                    defines(&format!("{}_{function}", kind.name)),
                    "{}_{function}",
                    kind.name
                );
            }
        }
        for kind in MATERIAL_KINDS {
            let functions: &[&str] = match kind.lobe {
                Lobe::Smooth | Lobe::SmoothAndDelta => &["eval", "pdf", "sample"],
                Lobe::Delta => &["sample"],
                Lobe::Absorbing => &[],
            };
            assert_eq!(
                kind.module.is_some(),
                !functions.is_empty(),
                "{}",
                kind.name
            );
            for function in functions {
                assert!(
                    defines(&format!("{}_{function}", kind.name)),
                    "{}_{function}",
                    kind.name
                );
            }
        }
    }

    /// A scalar, vector or array member's type as WGSL spells it.
    fn wgsl_type_name(module: &naga::Module, ty: &naga::TypeInner) -> String {
        match ty {
            // The host's counters are plain integers.
            naga::TypeInner::Scalar(scalar) | naga::TypeInner::Atomic(scalar) => {
                scalar_name(*scalar)
            }
            naga::TypeInner::Vector { size, scalar } => {
                format!("vec{}<{}>", *size as u32, scalar_name(*scalar))
            }
            naga::TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                ..
            } => format!(
                "array<{}, {n}>",
                wgsl_type_name(module, &module.types[*base].inner)
            ),
            other => panic!("no host field type for {other:?}"),
        }
    }

    fn scalar_name(scalar: naga::Scalar) -> String {
        match (scalar.kind, scalar.width) {
            (naga::ScalarKind::Uint, 4) => "u32".into(),
            (naga::ScalarKind::Float, 4) => "f32".into(),
            other => panic!("no host field type for {other:?}"),
        }
    }

    fn check_layout(module: &naga::Module, layout: ErasedLayout) {
        let (members, span) = module
            .types
            .iter()
            .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
                (Some(name), naga::TypeInner::Struct { members, span })
                    if name == layout.wgsl_name =>
                {
                    Some((members, *span))
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("struct {} not in the WGSL", layout.wgsl_name));
        let wgsl: Vec<(&str, usize, String)> = members
            .iter()
            .map(|m| {
                let ty = &module.types[m.ty].inner;
                (
                    m.name.as_deref().unwrap(),
                    m.offset as usize,
                    wgsl_type_name(module, ty),
                )
            })
            .collect();
        assert_eq!(
            wgsl,
            (layout.fields)(),
            "fields (names, offsets, types) of {}",
            layout.wgsl_name
        );
        assert_eq!(span as usize, layout.size, "size of {}", layout.wgsl_name);
    }

    /// The error estimate's shader validates over both accumulators, with and
    /// without replicates, and its structs are the host's.
    #[test]
    fn the_error_estimate_validates_and_matches_the_host() {
        use crate::abi::{ERROR_ENTRY_POINT, ErrorStrip, EstimateParams};
        for sampler in [Sampler::Sobol, Sampler::Independent] {
            for accumulator in [AccumulatorKind::Texture, AccumulatorKind::Buffer] {
                let config = KernelConfig {
                    variance: true,
                    sampler,
                    ..KernelConfig::general(Strategy::Mixture, accumulator)
                };
                let module = validate_source(&config.error_estimate_source().unwrap(), &config);
                assert!(
                    module
                        .entry_points
                        .iter()
                        .any(|e| e.name == ERROR_ENTRY_POINT)
                );
                check_layout(&module, ErasedLayout::of::<EstimateParams>());
                check_layout(&module, ErasedLayout::of::<ErrorStrip>());
            }
        }
    }

    /// The profiling kernel under every strategy, with a BVH (whose walks it
    /// counts) and without, and its counts' layout.
    #[test]
    fn profiling_kernels_validate() {
        for strategy in Strategy::ALL {
            let general = KernelConfig {
                profile: true,
                ..KernelConfig::general(strategy, AccumulatorKind::Texture)
            };
            let with_bvh = KernelConfig {
                bvh_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
                ..general.clone()
            };
            validate(&general);
            let module = validate(&with_bvh);
            check_layout(&module, ErasedLayout::of::<crate::abi::StageCounts>());
        }
    }

    /// The kernel of a scene with instances, over every kind and feature,
    /// from textures and from buffers, and its instance records' layout.
    #[test]
    fn instancing_kernels_validate() {
        let general = KernelConfig::general(Strategy::NeeMis, AccumulatorKind::Texture);
        let instanced = KernelConfig {
            bvh_kinds: KindSet::all(PRIMITIVE_KINDS.len()),
            instances: true,
            instance_stack: 12,
            ..general
        };
        let module = validate(&instanced);
        check_layout(&module, ErasedLayout::of::<PackedInstance>());
        validate(&KernelConfig {
            array_memory: ArrayMemory::Buffers,
            profile: true,
            ..instanced
        });
    }

    #[test]
    fn host_structs_match_wgsl_layouts() {
        let module = validate(&KernelConfig::general(
            Strategy::Mixture,
            AccumulatorKind::Texture,
        ));
        check_layout(&module, ErasedLayout::of::<Params>());
        check_layout(&module, ErasedLayout::of::<Counters>());
        check_layout(&module, ErasedLayout::of::<PackedMaterial>());
        check_layout(&module, ErasedLayout::of::<crate::lights::LightGroup>());
        check_layout(&module, ErasedLayout::of::<crate::lights::LightPick>());
        check_layout(&module, ErasedLayout::of::<crate::lights::LightRef>());
        check_layout(&module, ErasedLayout::of::<EnvironmentInfo>());
        check_layout(&module, ErasedLayout::of::<DeltaLight>());
        check_layout(&module, ErasedLayout::of::<TextureInfo>());
        check_layout(&module, ErasedLayout::of::<WideBvhNode>());
        for kind in PRIMITIVE_KINDS {
            check_layout(&module, kind.layout);
            if let Some(normals) = kind.shading_normals {
                check_layout(&module, normals);
            }
            if let Some(uvs) = kind.texture_uvs {
                check_layout(&module, uvs);
            }
        }
    }
}
