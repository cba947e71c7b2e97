//! Host mirrors of the WGSL structs, and packing a scene into them. Every struct
//! here is checked against naga's reading of the WGSL in `kernel::tests`.

use crate::accel::WideBvh;
use crate::environment::EnvironmentTables;
use crate::kernel::GroupedDensity;
use crate::kinds::{
    KindSet, MATERIAL_TEXTURE_SHIFT, MaterialTables, NO_LIGHT, PRIMITIVE_KINDS, PackedPrimitive,
    PrimitiveKind, TextureInfo, TextureTables, pack_material,
};
use crate::lights::{DeltaLight, LightBvh, LightTables, pack_delta_lights};
use crate::scene::{Camera, MaterialKind, Scene};
use bytemuck::Pod;
use glam::Vec3;
use std::sync::Arc;

/// A host struct with a WGSL twin of the same name and field order.
pub trait GpuLayout: Pod {
    const WGSL_NAME: &'static str;
    /// Field names, byte offsets and WGSL types, for the layout test and the
    /// kernel's accessors (`kernel::glue`).
    fn fields() -> Vec<(&'static str, usize, String)>;
    /// This value as a WGSL constant expression: the struct's constructor with
    /// every field in declaration order, bit-exact (see `WgslValue`).
    fn wgsl_value(&self) -> String;
    /// Whether every float field is finite (see `WgslValue`).
    fn is_finite(&self) -> bool;
}

/// A field value written as an exact WGSL constant expression, so the kernel
/// sees exactly what a buffer would hold. Floats use Rust's shortest
/// round-trip form with the `f` suffix (parsed as f32 directly, not rounded
/// twice through an abstract float); they must be finite.
pub trait WgslValue {
    /// Whether this is a scalar, so that an array of two to four is a vector.
    const SCALAR: bool;
    /// The WGSL type: a scalar's name; an array of two to four scalars is a
    /// vector, any other array a WGSL array.
    fn wgsl_type() -> String;
    fn wgsl_value(&self) -> String;
    fn is_finite(&self) -> bool;
}

impl WgslValue for u32 {
    const SCALAR: bool = true;
    fn wgsl_type() -> String {
        "u32".into()
    }
    fn wgsl_value(&self) -> String {
        format!("{self}u")
    }
    fn is_finite(&self) -> bool {
        true
    }
}

impl WgslValue for f32 {
    const SCALAR: bool = true;
    fn wgsl_type() -> String {
        "f32".into()
    }
    fn wgsl_value(&self) -> String {
        assert!(self.is_finite(), "{self} has no WGSL literal");
        format!("{self:?}f")
    }
    fn is_finite(&self) -> bool {
        f32::is_finite(*self)
    }
}

impl<T: WgslValue, const N: usize> WgslValue for [T; N] {
    const SCALAR: bool = false;
    fn wgsl_type() -> String {
        match T::SCALAR && (2..=4).contains(&N) {
            true => format!("vec{N}<{}>", T::wgsl_type()),
            false => format!("array<{}, {N}>", T::wgsl_type()),
        }
    }
    fn wgsl_value(&self) -> String {
        let components: Vec<String> = self.iter().map(WgslValue::wgsl_value).collect();
        format!("{}({})", Self::wgsl_type(), components.join(", "))
    }
    fn is_finite(&self) -> bool {
        self.iter().all(WgslValue::is_finite)
    }
}

macro_rules! gpu_struct {
    ($(#[$meta:meta])* pub struct $name:ident { $($(#[$field_meta:meta])* pub $field:ident : $ty:ty,)* }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name { $($(#[$field_meta])* pub $field: $ty,)* }

        impl $crate::gpu::layout::GpuLayout for $name {
            const WGSL_NAME: &'static str = stringify!($name);
            fn fields() -> Vec<(&'static str, usize, String)> {
                vec![$((
                    stringify!($field),
                    std::mem::offset_of!($name, $field),
                    <$ty as $crate::gpu::layout::WgslValue>::wgsl_type(),
                ),)*]
            }
            fn wgsl_value(&self) -> String {
                let fields: Vec<String> = vec![$($crate::gpu::layout::WgslValue::wgsl_value(&self.$field),)*];
                format!("{}({})", stringify!($name), fields.join(", "))
            }
            fn is_finite(&self) -> bool {
                true $(&& $crate::gpu::layout::WgslValue::is_finite(&self.$field))*
            }
        }
    };
}
pub(crate) use gpu_struct;

gpu_struct! {
    /// Per-dispatch uniform: camera, image, sample range and tile.
    pub struct Params {
        pub origin: [f32; 3],
        pub width: u32,
        /// From `origin` to the centre of pixel (0, 0) (see `CameraFrame`).
        pub to_pixel00: [f32; 3],
        pub height: u32,
        pub delta_u: [f32; 3],
        pub sample_start: u32,
        pub delta_v: [f32; 3],
        pub sample_count: u32,
        pub background: [f32; 3],
        pub seed: u32,
        pub tile_origin: [u32; 2],
        pub tile_size: [u32; 2],
        pub ray_offset: f32,
        pub reset: u32,
        pub zero_bits: u32,
        /// Adaptive sampling: entries of the active-pixel list this dispatch covers.
        pub active_count: u32,
        /// The dispatch's workgroup row `r` covers the tile's row of workgroups
        /// `r × step mod rows` (`render::workgroup_row_step`).
        pub workgroup_row_step: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    pub struct Counters {
        pub discarded: u32,
        pub truncated: u32,
        pub segments_low: u32,
        pub segments_high: u32,
    }
}

impl Counters {
    /// Ray segments traced so far.
    pub fn segments(&self) -> u64 {
        (self.segments_high as u64) << 32 | self.segments_low as u64
    }
}

gpu_struct! {
    /// Every material kind packs into this; what each field holds for each kind
    /// is said once, in `kinds::material::pack_material`.
    pub struct Material {
        pub albedo: [f32; 3],
        /// Index into `kinds::MATERIAL_KINDS`.
        pub kind: u32,
        pub emit: [f32; 3],
        pub param: f32,
        pub color2: [f32; 3],
        pub param2: f32,
        pub color3: [f32; 3],
        /// Bits of [`MATERIAL_FLAGS`].
        pub flags: u32,
    }
}

/// The bits of `Material::flags`, shared with WGSL (generated constants).
pub const MATERIAL_FLAGS: &[(&str, u32)] = &[
    // The Beckmann distribution (else GGX).
    ("MATERIAL_BECKMANN", 1),
    // Mitsuba's `nonlinear` for plastics.
    ("MATERIAL_NONLINEAR", 2),
    // Scatters only on the side its normal faces.
    ("MATERIAL_ONE_SIDED", 4),
];

/// The value of the bit named `name` of [`MATERIAL_FLAGS`].
pub fn material_flag(name: &str) -> u32 {
    MATERIAL_FLAGS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, bit)| bit)
        .expect("a material flag")
}

/// Ray origins leave a surface by this fraction of the scene's extent, times
/// its kind's `ray_offset_factor`.
pub const RAY_OFFSET_RELATIVE: f32 = 1e-6;

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

    fn push(&mut self, primitive: &PackedPrimitive) {
        self.bytes.extend_from_slice(&primitive.bytes);
        self.materials.push(primitive.material);
    }

    /// Element `i`'s bytes, for a kind of element size `size`.
    pub fn element(&self, i: usize, size: usize) -> &[u8] {
        &self.bytes[i * size..(i + 1) * size]
    }

    /// Replaces the `u32` at byte `offset` of every element (of size `size`) by
    /// `f` of it.
    fn map_u32(&mut self, size: usize, offset: usize, f: impl Fn(u32) -> u32) {
        for element in self.bytes.chunks_exact_mut(size) {
            let field = &mut element[offset..offset + 4];
            let value = f(bytemuck::pod_read_unaligned(field));
            field.copy_from_slice(bytemuck::bytes_of(&value));
        }
    }
}

/// The scene as the kernel sees it: only what is present, tightly packed.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneData {
    pub materials: Vec<Material>,
    /// The materials' tables (`kinds::MaterialTables`), where a kind has them.
    pub material_tables: Vec<f32>,
    /// Per kind of `PRIMITIVE_KINDS`: the primitives rays can hit.
    pub primitives: Vec<PackedArray>,
    /// Per kind: copies of the primitives in the light density.
    pub lights: Vec<PackedArray>,
    /// Per kind: the shading normals of `primitives`, one element each, where
    /// any of them is smooth (else empty).
    pub normals: Vec<Vec<u8>>,
    /// Per kind with `texture_uvs`: the texture coordinates of `primitives`,
    /// one element each, where the scene has textures (else empty).
    pub uvs: Vec<Vec<u8>>,
    /// The materials' textures (`kinds::TextureTables`); empty without.
    pub textures: Vec<TextureInfo>,
    pub texture_texels: Vec<f32>,
    /// Per kind with grouped lights: each light's group and area, as `lights`.
    pub light_members: Vec<Vec<(u32, f32)>>,
    /// Per kind with grouped lights that has some: their groups, alias tables
    /// and BVH (`lights`), from `lights` and `light_members`.
    pub light_tables: Vec<Option<LightTables>>,
    /// Per kind: how many of `primitives`, first in its array, are large
    /// (`accel::put_large_first`): tested by every ray beside the BVH, which
    /// holds the rest.
    pub large: Vec<usize>,
    /// Over `primitives` after the large ones, when the kernel traverses one.
    pub bvh: Option<WideBvh>,
    /// The environment map's texels and sampling tables (shared: a map is large).
    pub environment: Option<Arc<EnvironmentTables>>,
    /// Point and spot lights.
    pub delta_lights: Vec<DeltaLight>,
}

impl Default for SceneData {
    fn default() -> Self {
        SceneData {
            materials: Vec::new(),
            material_tables: Vec::new(),
            primitives: vec![PackedArray::default(); PRIMITIVE_KINDS.len()],
            lights: vec![PackedArray::default(); PRIMITIVE_KINDS.len()],
            normals: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            uvs: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            textures: Vec::new(),
            texture_texels: Vec::new(),
            light_members: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            light_tables: vec![None; PRIMITIVE_KINDS.len()],
            large: vec![0; PRIMITIVE_KINDS.len()],
            bvh: None,
            environment: None,
            delta_lights: Vec::new(),
        }
    }
}

impl SceneData {
    pub fn pack(scene: &Scene) -> SceneData {
        let mut material_tables = MaterialTables::default();
        let mut textures = TextureTables::default();
        let materials = scene
            .materials
            .iter()
            .map(|m| {
                let packed = pack_material(m, &mut material_tables);
                match &m.texture {
                    Some(texture) => Material {
                        flags: packed.flags | (textures.add(texture) + 1) << MATERIAL_TEXTURE_SHIFT,
                        ..packed
                    },
                    None => packed,
                }
            })
            .collect();
        // A dielectric of ior 1 bends and reflects nothing: it is left out of the
        // geometry (it may still guide sampling if marked for importance).
        let invisible = |material: u32| matches!(scene.materials[material as usize].kind, MaterialKind::Dielectric { ior } if ior == 1.0);
        let mut data = SceneData {
            materials,
            material_tables: material_tables.values,
            textures: textures.infos,
            texture_texels: textures.texels,
            environment: scene
                .environment
                .as_ref()
                .map(|map| Arc::new(EnvironmentTables::build(map))),
            delta_lights: pack_delta_lights(&scene.point_lights),
            ..SceneData::default()
        };
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let mut smooth = false;
            for mut primitive in (kind.pack)(scene) {
                let in_density = primitive.importance && kind.light_density;
                if let Some(offset) = kind.light_field() {
                    let light = match in_density {
                        true => data.lights[k].len() as u32,
                        false => NO_LIGHT,
                    };
                    primitive.bytes[offset..offset + 4].copy_from_slice(bytemuck::bytes_of(&light));
                }
                if !invisible(primitive.material) {
                    data.primitives[k].push(&primitive);
                    data.normals[k].extend_from_slice(&primitive.normals);
                    if !data.textures.is_empty() {
                        data.uvs[k].extend_from_slice(&primitive.uvs);
                    }
                    smooth |= primitive.smooth;
                }
                if in_density {
                    data.lights[k].push(&primitive);
                    data.light_members[k].extend(primitive.light_group);
                }
            }
            if !smooth {
                data.normals[k] = Vec::new();
            }
        }
        data.build_light_tables();
        data
    }

    /// Puts kind `k`'s primitives, and every array indexed like them (the
    /// shading normals, the texture coordinates), in `order`: element `j`
    /// becomes the one at `order[j]` (each index once).
    pub fn reorder(&mut self, k: usize, order: &[u32]) {
        let array = &mut self.primitives[k];
        let size = PRIMITIVE_KINDS[k].layout.size;
        let mut sorted = PackedArray::default();
        for &i in order {
            sorted
                .bytes
                .extend_from_slice(array.element(i as usize, size));
            sorted.materials.push(array.materials[i as usize]);
        }
        *array = sorted;
        for per_primitive in [&mut self.normals[k], &mut self.uvs[k]] {
            if !per_primitive.is_empty() {
                let size = per_primitive.len() / order.len();
                assert_eq!(
                    per_primitive.len(),
                    size * order.len(),
                    "one element per primitive"
                );
                *per_primitive = order
                    .iter()
                    .flat_map(|&i| &per_primitive[i as usize * size..(i as usize + 1) * size])
                    .copied()
                    .collect();
            }
        }
    }

    /// What a BVH kernel compiles in (`KernelConfig::compiled_in`): the large
    /// primitives, and the light density where it is finite and small enough
    /// to bake (with the large ones, at most `SceneStorage::MAX_BAKED_OBJECTS`,
    /// as a baked scene); `None` when neither is there.
    pub fn beside_bvh(&self) -> Option<SceneData> {
        let large: usize = self.large.iter().sum();
        let lights_bake = large + self.light_count()
            <= crate::kernel::SceneStorage::MAX_BAKED_OBJECTS
            && PRIMITIVE_KINDS.iter().enumerate().all(|(k, kind)| {
                let lights = &self.lights[k];
                (0..lights.len())
                    .all(|i| (kind.layout.is_finite)(lights.element(i, kind.layout.size)))
            });
        if large == 0 && !(lights_bake && self.light_count() > 0) {
            return None;
        }
        let mut compiled = SceneData {
            large: self.large.clone(),
            ..SceneData::default()
        };
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let array = &self.primitives[k];
            compiled.primitives[k] = PackedArray {
                bytes: array.bytes[..self.large[k] * kind.layout.size].to_vec(),
                materials: array.materials[..self.large[k]].to_vec(),
            };
        }
        if lights_bake {
            compiled.lights = self.lights.clone();
            compiled.light_members = self.light_members.clone();
            compiled.light_tables = self.light_tables.clone();
        }
        Some(compiled)
    }

    /// Drops non-emitting objects from the light density.
    pub fn keep_emitting_lights(&mut self) {
        let emits = |material: u32| {
            self.materials[material as usize]
                .emit
                .iter()
                .any(|&e| e > 0.0)
        };
        let mut members = vec![Vec::new(); PRIMITIVE_KINDS.len()];
        // Per kind, each light's index among those kept (`NO_LIGHT`: dropped).
        let mut renumbered = vec![Vec::new(); PRIMITIVE_KINDS.len()];
        let kept: Vec<PackedArray> = PRIMITIVE_KINDS
            .iter()
            .enumerate()
            .map(|(k, kind)| {
                let lights = &self.lights[k];
                let mut kept = PackedArray::default();
                for (i, &material) in lights.materials.iter().enumerate() {
                    if emits(material) {
                        renumbered[k].push(kept.len() as u32);
                        kept.bytes
                            .extend_from_slice(lights.element(i, kind.layout.size));
                        kept.materials.push(material);
                        members[k].extend(self.light_members[k].get(i));
                    } else {
                        renumbered[k].push(NO_LIGHT);
                    }
                }
                kept
            })
            .collect();
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            if let Some(offset) = kind.light_field() {
                let renumber = |light: u32| match light {
                    NO_LIGHT => NO_LIGHT,
                    light => renumbered[k][light as usize],
                };
                self.primitives[k].map_u32(kind.layout.size, offset, renumber);
            }
        }
        self.lights = kept;
        self.light_members = members;
        self.build_light_tables();
    }

    fn build_light_tables(&mut self) {
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let lights = &self.lights[k];
            self.light_tables[k] = (kind.grouped_lights && !lights.is_empty()).then(|| {
                let (groups, areas): (Vec<u32>, Vec<f32>) =
                    self.light_members[k].iter().copied().unzip();
                LightTables::build(lights, &groups, &areas, &self.materials)
            });
        }
    }

    /// The BVH over the lights of grouped kind `k` (which has some), built on
    /// the first call: only a kernel that walks it needs it.
    pub fn light_bvh(&self, k: usize) -> &LightBvh {
        let tables = self.light_tables[k]
            .as_ref()
            .expect("a grouped kind with lights has their tables");
        (tables.walk).get_or_init(|| LightBvh::build(k, &self.lights[k], &tables.picks))
    }

    /// Whether every float is finite (has a WGSL literal, so it can be baked).
    pub fn is_finite(&self) -> bool {
        let array_finite = |kind: &PrimitiveKind, array: &PackedArray| {
            (0..array.len()).all(|i| (kind.layout.is_finite)(array.element(i, kind.layout.size)))
        };
        self.materials.iter().all(GpuLayout::is_finite)
            && self.delta_lights.iter().all(GpuLayout::is_finite)
            && PRIMITIVE_KINDS.iter().enumerate().all(|(k, kind)| {
                array_finite(kind, &self.primitives[k]) && array_finite(kind, &self.lights[k])
            })
    }

    pub fn primitive_count(&self) -> usize {
        self.primitives.iter().map(PackedArray::len).sum()
    }

    pub fn light_count(&self) -> usize {
        self.lights.iter().map(PackedArray::len).sum()
    }

    /// Loop iterations of one evaluation of the light density: one per light of
    /// a kind tested in a loop (none when `baked`: the loops are unrolled); for
    /// grouped lights weighed by `grouped`, none by points, and a walk of
    /// their BVH (a loop even when baked: an inner step per node visited and
    /// per leaf reached, an outer step per leaf, one per light tested, and a
    /// leaf holds a light at least) counted as at most `bvh_allowance` of it.
    pub fn light_density_iterations(
        &self,
        bvh_allowance: impl Fn(&WideBvh) -> u64,
        baked: bool,
        grouped: GroupedDensity,
    ) -> u64 {
        PRIMITIVE_KINDS
            .iter()
            .zip(&self.lights)
            .zip(&self.light_tables)
            .enumerate()
            .map(|(k, ((kind, lights), tables))| match (tables, grouped) {
                (Some(_), GroupedDensity::Points) if kind.grouped_lights => 0,
                (Some(_), GroupedDensity::Walk) if kind.grouped_lights => {
                    let walk = self.light_bvh(k);
                    bvh_allowance(&walk.bvh)
                        .min((walk.bvh.nodes.len() + 3 * walk.refs.len()) as u64)
                }
                _ if baked => 0,
                _ => lights.len() as u64,
            })
            .sum()
    }

    /// The material kinds referenced by geometry the kernel sees.
    pub fn material_kinds(&self) -> KindSet {
        self.primitives
            .iter()
            .flat_map(|array| &array.materials)
            .map(|&m| self.materials[m as usize].kind as usize)
            .collect()
    }

    /// Whether a material rays can hit is one-sided.
    pub fn has_one_sided_materials(&self) -> bool {
        self.primitives
            .iter()
            .flat_map(|array| &array.materials)
            .any(|&m| self.materials[m as usize].flags & material_flag("MATERIAL_ONE_SIDED") != 0)
    }

    /// The primitive kinds rays can hit.
    pub fn primitive_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.primitives[k].is_empty())
            .collect()
    }

    /// The primitive kinds shaded with interpolated normals.
    pub fn normal_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.normals[k].is_empty())
            .collect()
    }

    /// The primitive kinds in the light density.
    pub fn light_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.lights[k].is_empty())
            .collect()
    }
}

/// Camera terms of `Params`: the book's camera, focus distance 1.
pub struct CameraFrame {
    pub origin: Vec3,
    /// From `origin` to the centre of pixel (0, 0) on the image plane. Relative, not
    /// a point: the image plane is 1 from the eye whatever the scene's scale, and
    /// a point there, next to a large `origin`, would lose the pixel grid to
    /// rounding (at `lookfrom` 8e6 the f32 spacing is 0.5, coarser than the pixels).
    pub to_pixel00: Vec3,
    pub delta_u: Vec3,
    pub delta_v: Vec3,
}

impl CameraFrame {
    pub fn new(camera: &Camera) -> CameraFrame {
        let viewport_height = 2.0 * (camera.vfov_degrees.to_radians() / 2.0).tan();
        let viewport_width = viewport_height * camera.width as f32 / camera.height as f32;
        let w = (camera.lookfrom - camera.lookat).normalize();
        let u = camera.vup.cross(w).normalize();
        let v = w.cross(u);
        let viewport_u = viewport_width * u;
        let viewport_v = -viewport_height * v;
        let delta_u = viewport_u / camera.width as f32;
        let delta_v = viewport_v / camera.height as f32;
        let to_upper_left = -w - viewport_u / 2.0 - viewport_v / 2.0;
        CameraFrame {
            origin: camera.lookfrom,
            to_pixel00: to_upper_left + 0.5 * (delta_u + delta_v),
            delta_u,
            delta_v,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_are_wgsl_vectors_or_arrays() {
        assert_eq!(
            [1.5f32, 2.0, 0.25].wgsl_value(),
            "vec3<f32>(1.5f, 2.0f, 0.25f)"
        );
        assert_eq!(
            [[1u32, 2], [3, 4]].wgsl_value(),
            "array<vec2<u32>, 2>(vec2<u32>(1u, 2u), vec2<u32>(3u, 4u))"
        );
        assert_eq!(<[f32; 5]>::wgsl_type(), "array<f32, 5>");
    }
}
