//! The kinds of primitive, material, texture, point light, pixel filter and
//! AOV pathmix renders, each described once, with how scene files name it:
//! `params` is the table reader every kind and the scene read with,
//! `transform` where an object sits.
//!
//! A kind's description names its WGSL module and packed struct and says what it
//! supports; the kernel's presence flags, modules, scene arrays, bindings, baked
//! constants and generated WGSL glue (`kernel::glue`), the packed scene
//! (`pack::SceneData`), `pathmix info` and the scene files' lists of types and
//! keys (for messages and `scene::format_doc`) are all derived from it.
//!
//! A new **shape kind** touches:
//! - `shaders/NAME.wgsl` (the contract is [`PrimitiveKind`]'s doc comment);
//! - `src/kinds/NAME.rs`: its manual (the file's doc comment), its scene type
//!   with [`Shape`] (material, light density, extent, scale, problem), its
//!   packed struct, its [`PrimitiveKind`] with the `ObjectType` that reads its
//!   `[[objects]]` table, and its test;
//! - this file: `mod NAME;`, its `pub use`, and its line in `primitive_kinds!`.
//!
//! A new **material kind** touches:
//! - `shaders/NAME.wgsl` (the interface is in `shaders/materials.wgsl`);
//! - `src/kinds/material/NAME.rs`: its manual, its [`MaterialModel`] (lobes,
//!   keys, how it reads its table and packs, the Mitsuba plugin it is), and
//!   its test;
//! - `src/kinds/material/mod.rs`: `mod NAME;` and its entry in
//!   `material_kinds!` (its [`MaterialKind`] variant, with its parameters).
//!
//! A new **texture kind** touches `shaders/textures.wgsl`,
//! `src/kinds/texture/NAME.rs` (its manual, its type, its `TextureModel` and
//! `TextureValue`, its test) and its lines in `src/kinds/texture/mod.rs`
//! (`mod`, `pub use`, one `texture_kinds!` line, whose place is its id, the
//! WGSL constant `TEXTURE_NAME`). Point and spot lights are
//! `delta_light.rs`.
//!
//! Any of them also documents its type and keys in `docs/scene-format.md`
//! (`scene::format_doc` fails on one it lacks); ARCHITECTURE.md says what else
//! may follow (a Mitsuba plugin, the checkpoint identity's version).

mod aov;
mod coat;
mod cylinder;
mod delta_light;
mod disk;
pub(crate) mod filter;
mod material;
pub(crate) mod params;
mod quad;
mod sphere;
mod texture;
pub(crate) mod transform;
mod triangle;

pub use aov::{Aov, AovKind, aov_kinds, check_names, parse_aov, parse_aovs};
pub use coat::{CoatTables, ROUGH_TRANSMITTANCE_RES};
// For the format's page.
pub use cylinder::{Cylinder, PackedCylinder};
#[cfg(test)]
pub(crate) use delta_light::LIGHT_TYPES;
pub use delta_light::{PointLight, Spot};
pub(crate) use delta_light::{light_keys, light_types};
pub use disk::{Disk, PackedDisk};
pub use filter::{
    FILTER_FLAGS, FILTER_MODULE, FILTER_TABLE_BINS, Filter, FilterTable, GaussianFilterTerms,
    Reconstruction,
};
pub(crate) use material::NAMED_IORS;
pub use material::{
    Bump, Distribution, Lobe, MASK_RAY_HITS, MATERIAL_KINDS, MATERIAL_NESTING,
    MATERIAL_NUMBER_SLOTS, MATERIAL_TRANSPARENCY_MAX, MATERIAL_TRANSPARENCY_SHIFT, Material,
    MaterialKind, MaterialModel, MaterialTables, MitsubaPlugin, NumberTexture, pack_material,
    packed_is_masked, packed_kind_id, packed_nested,
};
// For the scene's tests of Mitsuba's conductors and of the format's page.
#[cfg(test)]
pub(crate) use material::{NAMED_CONDUCTORS, material_keys, material_types};
pub use params::{SceneError, excerpt};
pub use quad::{PackedQuad, Quad};
pub use sphere::{PackedSphere, Sphere};
// For the format's page.
#[cfg(test)]
pub(crate) use texture::TEXTURE_KINDS;
pub use texture::{
    Bitmap, Checkerboard, MATERIAL_BUMP_SHIFT, MATERIAL_TEXTURE_BITS, MATERIAL_TEXTURE_SHIFT,
    MAX_TEXTURES, TexelFormat, Texture, TextureFilter, TextureInfo, TextureKind, TextureTables,
    UvTransform, WrapMode, serialize_texels, texel_byte_values, texture_constants,
};
pub use triangle::{PackedTriangle, Triangle, TriangleNormals, TriangleUvs};

use crate::abi::GpuLayout;
use crate::shader::ShaderModule;
use params::{ParamTable, Result};
use transform::Transform;

/// What the scene needs of a shape of any kind.
pub trait Shape {
    /// Its index into the scene's materials.
    fn material_mut(&mut self) -> &mut u32;
    fn material(&self) -> u32;
    /// In the light density (emitters always are; others when marked).
    fn importance(&self) -> bool;
    /// Its largest absolute coordinate, toward the scene's size (`Scene::extent`).
    fn extent(&self) -> f32;
    /// Every position and length multiplied by `factor` (`Scene::scaled`).
    fn scale(&mut self, factor: f32);
    /// Why 32-bit floats cannot render it (coordinates that overflow, a size
    /// out of their range), checked where it is read and again after a
    /// `[scene] scale`.
    fn problem(&self) -> Option<String>;
}

/// `|u x v| <= DEGENERATE |u| |v|`: a flat shape (or camera basis) with no area.
pub(crate) const DEGENERATE: f64 = 1e-6;

/// A squared length a renderer can work with in 32-bit floats.
pub(crate) fn usable_length_squared(l2: f32) -> bool {
    l2.is_finite() && l2 >= f32::MIN_POSITIVE
}

/// How scene files make one shape of a kind: an `[[objects]]` table whose
/// `type` is the kind's name. The scene reads its `type`, `material`,
/// `importance` and transform keys (and its own objects: boxes, meshes).
pub(crate) struct ObjectType {
    /// Its other keys, in the order an unknown key's message lists them.
    pub keys: &'static [&'static str],
    /// Reads the object's geometry, placed by its transform, into its list of
    /// `Shapes`, with the object's material index and whether it is in the
    /// light density; refuses a shape with a [`Shape::problem`].
    pub parse: fn(&ParamTable, &Transform, u32, bool, &mut Shapes) -> Result<()>,
}

/// The object types of the primitive kinds that have one, by name, in kind order.
pub(crate) fn object_types() -> impl Iterator<Item = (&'static str, &'static ObjectType)> {
    PRIMITIVE_KINDS
        .iter()
        .filter_map(|kind| Some((kind.name, kind.object.as_ref()?)))
}

/// Registers the primitive kinds, each in one line `array: SceneType = KIND`:
/// `PRIMITIVE_KINDS` lists the descriptions, and `Shapes` holds a scene's
/// shapes of every kind in a field named as the kind's array.
macro_rules! primitive_kinds {
    ($($(#[$doc:meta])* $array:ident: $shape:ty = $kind:path,)*) => {
        /// Every primitive kind, in the order of the kernel's closest-hit test and light
        /// density (which fixes the order of floating-point sums: images depend on it).
        pub const PRIMITIVE_KINDS: &[&PrimitiveKind] = &[$(&$kind,)*];

        /// A scene's shapes, world space: one list per primitive kind, in
        /// scene order, named as the kind's array. It serializes (for the scene
        /// identity) every kind's list in turn: a new kind is covered by construction.
        #[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
        pub struct Shapes {
            $($(#[$doc])* pub $array: Vec<$shape>,)*
        }

        impl Shapes {
            /// Every shape of every kind, in kind order.
            pub fn iter(&self) -> impl Iterator<Item = &dyn Shape> {
                std::iter::empty()$(.chain(self.$array.iter().map(|s| s as &dyn Shape)))*
            }

            pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut dyn Shape> {
                std::iter::empty()$(.chain(self.$array.iter_mut().map(|s| s as &mut dyn Shape)))*
            }

            /// How many shapes of each kind, in the order of [`PRIMITIVE_KINDS`].
            pub fn counts(&self) -> Vec<usize> {
                vec![$(self.$array.len(),)*]
            }
        }

        #[cfg(test)]
        const SHAPE_ARRAYS: &[&str] = &[$(stringify!($array),)*];
    };
}

primitive_kinds! {
    quads: Quad = quad::QUAD,
    spheres: Sphere = sphere::SPHERE,
    /// Mesh faces, degenerate ones dropped.
    triangles: Triangle = triangle::TRIANGLE,
    disks: Disk = disk::DISK,
    cylinders: Cylinder = cylinder::CYLINDER,
}

/// A kind of primitive: what the host packs and what its WGSL module defines.
///
/// The module (named `name`) defines the struct `layout.wgsl_name` and
/// - `fn NAME_hit_t(p: S, ray: Ray, t_max: f32) -> f32`: the distance to the
///   primitive in (0, t_max), or a negative number;
/// - `fn NAME_hit_keep(p: S) -> vec4<f32>`: what the closest hit keeps of the
///   primitive (the closest-hit loop copies only this, so keep it small), and
///   `fn NAME_hit_normal(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32>`: the
///   geometric, outward normal at the hit point `p` from it;
/// - with `light_density`, `fn NAME_light_sample(p: S, origin: vec3<f32>, u:
///   vec2<f32>) -> vec3<f32>` (a direction toward the primitive) and `fn
///   NAME_light_pdf(p: S, origin: vec3<f32>, dir: vec3<f32>) -> f32` (its
///   solid-angle density);
/// - with `shading_normals`, under the flag `NAME_NORMALS` (`TRIANGLE_NORMALS`),
///   `fn NAME_shading_normal(index: u32, p: vec3<f32>, normal: vec3<f32>) ->
///   vec3<f32>`: the shading normal at `p` on primitive `index`, on the side of
///   the geometric `normal`, from the array `NAME_normals` (one element per
///   primitive). Kinds without it shade with the geometric normal;
/// - under the flag `TEXTURES`, `fn NAME_hit_uv(p: S, point: vec3<f32>) ->
///   vec2<f32>`: Mitsuba's texture coordinates of the shape at a hit point; a
///   kind with `texture_uvs` takes them from its element `uvs` of the array
///   `NAME_uvs` as a second argument;
/// - under the flag `BUMP_MAPS`, `fn NAME_hit_tangents(p: S, point:
///   vec3<f32>) -> Tangents` (with the uvs as `NAME_hit_uv` takes them): the
///   surface's derivatives along its texture coordinates, Mitsuba's `dp_du`
///   and `dp_dv` (which bump and normal maps orient and scale their
///   perturbation by), or any frame about the normal where its uvs give none;
///   zero where Mitsuba's are (a disk's centre, a sphere's poles), which
///   `bumped_normal` (`shaders/textures.wgsl`) survives.
///
/// The WGSL struct's first `u32` field named `material` indexes the materials.
/// A kind with `grouped_lights` also has a `u32` field named `light`: the
/// primitive's index in the kind's light array, or `NO_LIGHT` (written by
/// `SceneData::pack`), so that a hit tells which light it found.
pub struct PrimitiveKind {
    /// Singular, lower case: the module's name and its functions' prefix.
    pub name: &'static str,
    /// The scene array of this kind (`quads`); the kernel's presence flag is its
    /// upper-case form (`QUADS`), and the light density's array is `light_quads`.
    pub array: &'static str,
    pub module: ShaderModule,
    pub layout: ErasedLayout,
    /// Whether the light density can sample it (emitters and `importance = true`).
    pub light_density: bool,
    /// The scene's primitives of this kind, packed, in scene order.
    pub pack: fn(&Shapes) -> Vec<PackedPrimitive>,
    /// An element no ray hits: what a kernel that declares this kind binds when
    /// the scene has none (bindings cannot be empty).
    pub never_hit: fn() -> Vec<u8>,
    /// The axis-aligned box around one packed element (for the BVH).
    pub bounds: fn(&[u8]) -> (glam::Vec3, glam::Vec3),
    /// The packed per-primitive shading normals (`PackedPrimitive::normals`),
    /// for kinds that can be shaded smooth; the array and its code exist only in
    /// kernels of scenes with such a primitive.
    pub shading_normals: Option<ErasedLayout>,
    /// Per-primitive texture coordinates (`PackedPrimitive::uvs`), for kinds
    /// whose own geometry does not give them (mesh faces); the array exists
    /// only in kernels of scenes with textures.
    pub texture_uvs: Option<ErasedLayout>,
    /// Its lights come in groups (a mesh's faces), each group one object of the
    /// light density, a member picked by power (`lights::LightTables`). The
    /// module then defines `fn NAME_light_sample` and `NAME_light_pdf` per
    /// primitive, and the generated light density walks the groups; and `fn
    /// NAME_light_point_pdf(p: S, t: f32, dir: vec3<f32>) -> f32`, the density
    /// of `dir` where it meets the primitive at distance `t` (the point's own
    /// share, which next-event estimation weighs hits by: `GroupedDensity::Points`).
    pub grouped_lights: bool,
    /// How far rays leave a surface of this kind, in units of the scene's ray
    /// offset (`Params::ray_offset`): where its hit points err by more than a
    /// few ulps of the scene's extent, a larger factor keeps a ray from hitting
    /// the surface it leaves.
    pub ray_offset_factor: f32,
    /// Its module defines `fn NAME_hit_point(keep: vec4<f32>, p: vec3<f32>) ->
    /// vec3<f32>`, the computed hit point moved onto the surface: `o + t d` errs
    /// by ulps of the ray's origin and length, which on a curved surface can pass
    /// the ray offset and let a ray leaving it find it again (as Mitsuba's sphere
    /// reprojects its hit point).
    pub reprojects_hit_point: bool,
    /// What the closest hit keeps is the primitive itself, read again by the
    /// hit's index once the closest is found, where four floats cannot give the
    /// normal (a cylinder's axis, radius and side): its module then defines
    /// `NAME_hit_normal` and `NAME_hit_point` of the primitive `p: S` in place
    /// of `keep`, and no `NAME_hit_keep`.
    pub keeps_primitive: bool,
    /// Its module defines, under `LIGHT_SELECTION_SPATIAL`, `fn
    /// NAME_light_importance(p: S, origin: vec3<f32>) -> f32`: a bound on what the
    /// light sends toward `origin`, its radiance's luminance times the solid angle
    /// it could subtend and how squarely it could face there (0 where it cannot
    /// light `origin`). Next-event estimation under `nee-mis` picks such lights
    /// mostly in proportion to it (`KernelConfig::spatial_light_selection`).
    pub light_importance: bool,
    /// Its module defines `fn NAME_constant_hit_t(p: S, ray: Ray, t_max: f32) ->
    /// f32`, the test of a primitive compiled into the kernel (a baked scene's,
    /// or one of the largest beside a BVH, `accel::MAX_LARGE`), which every ray
    /// runs: cheaper than `NAME_hit_t` once the primitive's constants fold.
    pub constant_test: bool,
    /// How scene files name one shape of this kind, if they do.
    pub(crate) object: Option<ObjectType>,
}

/// The `light` field of a primitive outside the light density.
pub const NO_LIGHT: u32 = u32::MAX;

impl PrimitiveKind {
    /// The kernel's presence flag for the primitives (`QUADS`).
    pub fn flag(&self) -> String {
        self.array.to_uppercase()
    }

    /// The light density's array of this kind (`light_quads`).
    pub fn light_array(&self) -> String {
        format!("light_{}", self.array)
    }

    pub fn light_flag(&self) -> String {
        self.light_array().to_uppercase()
    }

    /// The texture coordinates' array of this kind (`triangle_uvs`).
    pub fn uvs_array(&self) -> String {
        format!("{}_uvs", self.name)
    }

    /// The shading normals' array of this kind (`triangle_normals`).
    pub fn normals_array(&self) -> String {
        format!("{}_normals", self.name)
    }

    pub fn normals_flag(&self) -> String {
        self.normals_array().to_uppercase()
    }

    /// The kernel's test of a primitive of this kind: `NAME_hit_t`, or where the
    /// primitive is compiled in, its test of constants if it has one.
    pub fn hit_t(&self, compiled_in: bool) -> String {
        match compiled_in && self.constant_test {
            true => format!("{}_constant_hit_t", self.name),
            false => format!("{}_hit_t", self.name),
        }
    }

    /// The byte offset of the `light` field of a kind with `grouped_lights`.
    pub fn light_field(&self) -> Option<usize> {
        self.grouped_lights.then(|| {
            (self.layout.fields)()
                .into_iter()
                .find(|&(name, _, _)| name == "light")
                .map(|(_, offset, _)| offset)
                .expect("a kind with grouped lights has a `light` field")
        })
    }
}

/// One packed primitive and what the host needs to know of it.
#[derive(Clone, Debug, PartialEq)]
pub struct PackedPrimitive {
    /// The packed struct, as the storage buffer holds it.
    pub bytes: Vec<u8>,
    /// Index into the scene's materials.
    pub material: u32,
    /// In the light density.
    pub importance: bool,
    /// Its packed shading normals, for kinds with `PrimitiveKind::shading_normals`
    /// (a flat primitive's are its face normal, for scenes that mix flat and smooth).
    pub normals: Vec<u8>,
    /// Shaded with interpolated normals: the scene needs the kind's normals array.
    pub smooth: bool,
    /// Its packed texture coordinates, for kinds with `PrimitiveKind::texture_uvs`.
    pub uvs: Vec<u8>,
    /// For kinds with `PrimitiveKind::grouped_lights`: its group (the object it
    /// belongs to) and its area, for picking it by power (`lights`).
    pub light_group: Option<(u32, f32)>,
}

impl PackedPrimitive {
    pub fn new<T: GpuLayout>(value: &T, material: u32, importance: bool) -> PackedPrimitive {
        PackedPrimitive {
            bytes: bytemuck::bytes_of(value).to_vec(),
            material,
            importance,
            normals: Vec::new(),
            smooth: false,
            uvs: Vec::new(),
            light_group: None,
        }
    }
}

/// Packed elements of one scene array, as its storage buffer holds them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedArray {
    pub bytes: Vec<u8>,
    /// Each element's material index.
    pub materials: Vec<u32>,
}

impl PackedArray {
    pub fn len(&self) -> usize {
        self.materials.len()
    }

    pub fn is_empty(&self) -> bool {
        self.materials.is_empty()
    }

    pub(crate) fn push(&mut self, primitive: &PackedPrimitive) {
        self.bytes.extend_from_slice(&primitive.bytes);
        self.materials.push(primitive.material);
    }

    /// Element `i`'s bytes, for a kind of element size `size`.
    pub fn element(&self, i: usize, size: usize) -> &[u8] {
        &self.bytes[i * size..(i + 1) * size]
    }

    /// Replaces the `u32` at byte `offset` of every element (of size `size`) by
    /// `f` of it.
    pub(crate) fn map_u32(&mut self, size: usize, offset: usize, f: impl Fn(u32) -> u32) {
        for element in self.bytes.chunks_exact_mut(size) {
            let field = &mut element[offset..offset + 4];
            let value = f(bytemuck::pod_read_unaligned(field));
            field.copy_from_slice(bytemuck::bytes_of(&value));
        }
    }
}

/// A `GpuLayout` type behind function pointers, so kinds of different packed
/// structs fit one table.
#[derive(Clone, Copy)]
pub struct ErasedLayout {
    pub wgsl_name: &'static str,
    /// Bytes per element.
    pub size: usize,
    /// Field names, offsets and WGSL types (`GpuLayout::fields`).
    pub fields: fn() -> Vec<(&'static str, usize, String)>,
    /// One element's bytes as an exact WGSL constant expression.
    pub wgsl_value: fn(&[u8]) -> String,
    /// Whether every float of one element is finite (has a WGSL literal).
    pub is_finite: fn(&[u8]) -> bool,
}

impl ErasedLayout {
    pub const fn of<T: GpuLayout>() -> ErasedLayout {
        fn wgsl_value<T: GpuLayout>(bytes: &[u8]) -> String {
            bytemuck::pod_read_unaligned::<T>(bytes).wgsl_value()
        }
        fn is_finite<T: GpuLayout>(bytes: &[u8]) -> bool {
            bytemuck::pod_read_unaligned::<T>(bytes).is_finite()
        }
        ErasedLayout {
            wgsl_name: T::WGSL_NAME,
            size: size_of::<T>(),
            fields: T::fields,
            wgsl_value: wgsl_value::<T>,
            is_finite: is_finite::<T>,
        }
    }
}

/// A set of kinds, by index into [`PRIMITIVE_KINDS`] or [`MATERIAL_KINDS`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct KindSet(u32);

impl KindSet {
    /// Every kind of a table of `count`.
    pub fn all(count: usize) -> KindSet {
        KindSet(((1u64 << count) - 1) as u32)
    }

    /// The kinds whose bits are set in `mask`.
    pub fn from_mask(mask: u32) -> KindSet {
        KindSet(mask)
    }

    pub fn with(self, kind: usize) -> KindSet {
        KindSet(self.0 | 1 << kind)
    }

    pub fn contains(self, kind: usize) -> bool {
        self.0 & (1 << kind) != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The indices in the set, in table order.
    pub fn iter(self) -> impl Iterator<Item = usize> {
        (0..32).filter(move |&k| self.contains(k))
    }
}

impl FromIterator<usize> for KindSet {
    fn from_iter<I: IntoIterator<Item = usize>>(iter: I) -> KindSet {
        iter.into_iter().fold(KindSet::default(), KindSet::with)
    }
}

/// `body` read as `objects[0]` of `scenes/x.toml` by `kind`'s object type
/// (material 0, outside the light density): for the kinds' tests.
#[cfg(test)]
fn read_object(kind: &PrimitiveKind, body: &str) -> Result<Shapes> {
    let table: toml::Table = toml::from_str(body).expect("valid TOML");
    let inputs = std::cell::RefCell::new(Vec::new());
    let t = ParamTable {
        file: "scenes/x.toml",
        table: &table,
        path: "objects[0]".to_string(),
        inputs: &inputs,
    };
    let object = kind.object.as_ref().expect("an object type");
    let mut shapes = Shapes::default();
    (object.parse)(&t, &Transform::parse(&t)?, 0, false, &mut shapes)?;
    Ok(shapes)
}

/// A kind's manual: the doc comment at the top of its file's `source`.
#[cfg(test)]
fn manual(source: &str) -> String {
    source
        .lines()
        .map_while(|line| line.strip_prefix("//!"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_is_held_in_the_shapes_field_named_as_its_array() {
        let arrays: Vec<&str> = PRIMITIVE_KINDS.iter().map(|kind| kind.array).collect();
        assert_eq!(arrays, SHAPE_ARRAYS);
    }
}
