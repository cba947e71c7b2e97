//! The scene as arrays: `SceneData::pack` turns a validated `Scene` into the
//! packed structs and tables the kernel reads (only what is present), with no
//! device. What a kernel compiles in of them, and how they are bound, is the
//! kernel's and the renderer's business.

use crate::abi::{GpuLayout, PackedMaterial, material_flag};
use crate::accel::{InstanceSet, Instancing, PrimitiveArrays, WideBvh};
use crate::environment::EnvironmentTables;
use crate::kinds::{
    Bump, KindSet, MATERIAL_BUMP_SHIFT, MATERIAL_TEXTURE_SHIFT, MATERIAL_TRANSPARENCY_SHIFT,
    MaterialTables, NO_LIGHT, PRIMITIVE_KINDS, PackedArray, PrimitiveKind, TextureInfo,
    TextureTables, pack_material, packed_is_masked, packed_kind_id, packed_nested,
};
use crate::lights::{DeltaLight, LightBvh, LightTables, pack_delta_lights};
use crate::scene::{Camera, MaterialKind, Scene};
use glam::Vec3;
use std::sync::Arc;

/// The scene as the kernel sees it: only what is present, tightly packed.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneData {
    pub materials: Vec<PackedMaterial>,
    /// The materials' tables (`kinds::MaterialTables`), where a kind has them.
    pub material_tables: Vec<f32>,
    /// The primitives rays can hit, and the arrays indexed like them.
    pub geometry: PrimitiveArrays,
    /// Per kind: copies of the primitives in the light density.
    pub lights: Vec<PackedArray>,
    /// The materials' textures (`kinds::TextureTables`); empty without.
    pub textures: Vec<TextureInfo>,
    /// Their bitmaps' texels, in words, and the formats they use, a bit each
    /// (`kinds::TextureTables`).
    pub texture_texels: Vec<u32>,
    pub texel_formats: u32,
    /// Per kind with grouped lights: each light's group and area, as `lights`.
    pub light_members: Vec<Vec<(u32, f32)>>,
    /// Per kind with grouped lights that has some: their groups, alias tables
    /// and BVH (`lights`), from `lights` and `light_members`.
    pub light_tables: Vec<Option<LightTables>>,
    /// Over `primitives` after the large ones, when the kernel traverses one.
    pub bvh: Option<WideBvh>,
    /// The scene's instanced groups (those some instance shows) and their
    /// instances, until the two-level BVH is built from them.
    pub instance_set: InstanceSet,
    /// The instances as the kernel reads them, once the two-level BVH is
    /// built (their groups' primitives then follow the scene's in `geometry`).
    pub instancing: Option<Instancing>,
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
            geometry: PrimitiveArrays::default(),
            lights: vec![PackedArray::default(); PRIMITIVE_KINDS.len()],
            textures: Vec::new(),
            texture_texels: Vec::new(),
            texel_formats: 0,
            light_members: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            light_tables: vec![None; PRIMITIVE_KINDS.len()],
            bvh: None,
            instance_set: InstanceSet::default(),
            instancing: None,
            environment: None,
            delta_lights: Vec::new(),
        }
    }
}

impl SceneData {
    pub fn pack(scene: &Scene) -> SceneData {
        let textured_numbers = (scene.materials.iter()).any(|m| !m.number_textures.is_empty());
        let mut material_tables = match textured_numbers {
            true => MaterialTables::with_number_directory(scene.materials.len()),
            false => MaterialTables::default(),
        };
        let mut textures = TextureTables::default();
        let materials = scene
            .materials
            .iter()
            .enumerate()
            .map(|(index, m)| {
                let mut packed = pack_material(m, &mut material_tables);
                if let Some(texture) = &m.texture {
                    packed.flags |= (textures.add(texture) + 1) << MATERIAL_TEXTURE_SHIFT;
                }
                if let Some(bump) = &m.bump {
                    let index = textures.add(bump.texture());
                    textures.infos[index as usize].bump_scale = bump.scale();
                    packed.flags |= (index + 1) << MATERIAL_BUMP_SHIFT;
                    if matches!(bump, Bump::NormalMap { .. }) {
                        packed.flags |= material_flag("MATERIAL_NORMAL_MAP");
                    }
                }
                // In the transparency's place (`kinds::MATERIAL_TRANSPARENCY_SHIFT`).
                if let Some(opacity) = &m.opacity_texture {
                    packed.kind |= (textures.add(opacity) + 1) << MATERIAL_TRANSPARENCY_SHIFT;
                    packed.flags |= material_flag("MATERIAL_OPACITY_TEXTURE");
                }
                if !m.number_textures.is_empty() {
                    let pairs: Vec<(u32, u32)> = (m.number_textures.iter())
                        .map(|n| (n.slot, textures.add(&n.texture)))
                        .collect();
                    material_tables.add_number_textures(index, &pairs);
                    packed.flags |= material_flag("MATERIAL_TEXTURED_NUMBERS");
                }
                // The materials it is made of, by index (`kinds::packed_nested`).
                for (slot, name) in m.nested.iter().enumerate() {
                    let index = scene.materials.iter().position(|n| &n.name == name);
                    packed.color2[slot] = index.expect("a validated scene's material") as f32;
                }
                packed
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
            texel_formats: textures.texel_formats,
            environment: scene
                .environment
                .as_ref()
                .map(|map| Arc::new(EnvironmentTables::build(map))),
            delta_lights: pack_delta_lights(&scene.point_lights, scene.extent()),
            ..SceneData::default()
        };
        // The groups some instance shows, renumbered in order of first use.
        let mut packed_group = vec![None; scene.instancing.groups.len()];
        for instance in &scene.instancing.instances {
            let group = &mut packed_group[instance.group as usize];
            if group.is_none() {
                *group = Some(data.instance_set.groups.len() as u32);
                data.instance_set.groups.push(PrimitiveArrays::default());
            }
            let to_world = instance.to_world();
            (data.instance_set.instances).push((group.expect("set above"), to_world));
        }
        let groups: Vec<(usize, u32)> = (packed_group.iter().enumerate())
            .filter_map(|(g, packed)| Some((g, (*packed)?)))
            .collect();
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let mut smooth = false;
            for mut primitive in (kind.pack)(&scene.shapes) {
                let in_density = primitive.importance && kind.light_density;
                if let Some(offset) = kind.light_field() {
                    let light = match in_density {
                        true => data.lights[k].len() as u32,
                        false => NO_LIGHT,
                    };
                    primitive.bytes[offset..offset + 4].copy_from_slice(bytemuck::bytes_of(&light));
                }
                if !invisible(primitive.material) {
                    data.geometry.primitives[k].push(&primitive);
                    data.geometry.normals[k].extend_from_slice(&primitive.normals);
                    if !data.textures.is_empty() {
                        data.geometry.uvs[k].extend_from_slice(&primitive.uvs);
                    }
                    smooth |= primitive.smooth;
                }
                if in_density {
                    data.lights[k].push(&primitive);
                    data.light_members[k].extend(primitive.light_group);
                }
            }
            // A group's primitives are in no light density (the scene refuses
            // emitters in groups, as Mitsuba does).
            for &(g, packed) in &groups {
                let arrays = &mut data.instance_set.groups[packed as usize];
                for mut primitive in (kind.pack)(&scene.instancing.groups[g].shapes) {
                    if let Some(offset) = kind.light_field() {
                        primitive.bytes[offset..offset + 4]
                            .copy_from_slice(bytemuck::bytes_of(&NO_LIGHT));
                    }
                    if !invisible(primitive.material) {
                        arrays.primitives[k].push(&primitive);
                        arrays.normals[k].extend_from_slice(&primitive.normals);
                        if !data.textures.is_empty() {
                            arrays.uvs[k].extend_from_slice(&primitive.uvs);
                        }
                        smooth |= primitive.smooth;
                    }
                }
            }
            if !smooth {
                data.geometry.normals[k] = Vec::new();
                for arrays in &mut data.instance_set.groups {
                    arrays.normals[k] = Vec::new();
                }
            }
        }
        data.build_light_tables();
        data
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
                self.geometry.primitives[k].map_u32(kind.layout.size, offset, renumber);
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
                array_finite(kind, &self.geometry.primitives[k])
                    && array_finite(kind, &self.lights[k])
            })
    }

    pub fn light_count(&self) -> usize {
        self.lights.iter().map(PackedArray::len).sum()
    }

    /// The materials a hit can scatter by, by index: those of the geometry
    /// the kernel sees, and those they are made of (`kinds::packed_nested`).
    pub fn reachable_materials(&self) -> Vec<bool> {
        let mut reached = vec![false; self.materials.len()];
        let mut stack: Vec<u32> = self
            .hit_primitive_arrays()
            .flat_map(|array| array.materials.iter().copied())
            .collect();
        while let Some(m) = stack.pop() {
            if !std::mem::replace(&mut reached[m as usize], true) {
                stack.extend(packed_nested(&self.materials[m as usize]));
            }
        }
        reached
    }

    /// The material kinds of `reachable_materials`.
    pub fn material_kinds(&self) -> KindSet {
        self.reachable_materials()
            .iter()
            .enumerate()
            .filter(|&(_, &reached)| reached)
            .map(|(m, _)| packed_kind_id(&self.materials[m]))
            .collect()
    }

    /// Whether a material of `reachable_materials` is one-sided.
    pub fn has_one_sided_materials(&self) -> bool {
        self.reachable_materials()
            .iter()
            .enumerate()
            .any(|(m, &reached)| {
                reached && self.materials[m].flags & material_flag("MATERIAL_ONE_SIDED") != 0
            })
    }

    /// Whether a material of `reachable_materials` is made of others
    /// (`twosided`): the kernel resolves them at a hit (`NESTED_MATERIALS`).
    pub fn has_nested_materials(&self) -> bool {
        self.reachable_materials()
            .iter()
            .enumerate()
            .any(|(m, &reached)| reached && !packed_nested(&self.materials[m]).is_empty())
    }

    /// Whether a material rays can hit is masked (`Material::opacity` below 1).
    pub fn has_masked_materials(&self) -> bool {
        self.hit_materials().any(packed_is_masked)
    }

    /// Whether a material rays can hit has a textured opacity
    /// (`Material::opacity_texture`).
    pub fn has_opacity_textures(&self) -> bool {
        let flag = material_flag("MATERIAL_OPACITY_TEXTURE");
        self.hit_materials().any(|m| m.flags & flag != 0)
    }

    /// Whether a material has numbers given by textures
    /// (`Material::number_textures`): nested materials count, since the hit
    /// resolves to them.
    pub fn has_textured_numbers(&self) -> bool {
        let flag = material_flag("MATERIAL_TEXTURED_NUMBERS");
        self.materials.iter().any(|m| m.flags & flag != 0)
    }

    /// The materials of the primitives rays can hit (with repeats).
    fn hit_materials(&self) -> impl Iterator<Item = &PackedMaterial> {
        self.hit_primitive_arrays()
            .flat_map(|array| &array.materials)
            .map(|&m| &self.materials[m as usize])
    }

    /// The arrays of primitives rays can hit: the scene's, and its instanced
    /// groups' until the BVH appends them to the scene's.
    fn hit_primitive_arrays(&self) -> impl Iterator<Item = &PackedArray> {
        let groups = self.instance_set.groups.iter();
        (self.geometry.primitives.iter()).chain(groups.flat_map(|g| &g.primitives))
    }

    /// Whether the scene has instances: its kernel walks the two-level BVH.
    pub fn has_instances(&self) -> bool {
        !self.instance_set.instances.is_empty() || self.instancing.is_some()
    }

    /// The primitive kinds in the light density.
    pub fn light_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.lights[k].is_empty())
            .collect()
    }
}

/// Camera terms of `Params`: the book's camera (its image plane 1 ahead) and
/// the thin lens.
pub struct CameraFrame {
    pub origin: Vec3,
    /// From `origin` to the centre of pixel (0, 0) on the image plane (for the
    /// orthographic projection, on the plane through `origin`). Relative, not
    /// a point: the image plane is 1 from the eye whatever the scene's scale, and
    /// a point there, next to a large `origin`, would lose the pixel grid to
    /// rounding (at `lookfrom` 8e6 the f32 spacing is 0.5, coarser than the pixels).
    pub to_pixel00: Vec3,
    pub delta_u: Vec3,
    pub delta_v: Vec3,
    /// The thin lens's radius (0: a pinhole) and distance to the plane in
    /// focus, along the view axis.
    pub lens_radius: f32,
    pub focus_distance: f32,
}

impl CameraFrame {
    pub fn new(camera: &Camera) -> CameraFrame {
        let (viewport_width, viewport_height) = match camera.view_width {
            Some(width) => (width, width * camera.height as f32 / camera.width as f32),
            None => {
                let height = 2.0 * (camera.vfov_degrees.to_radians() / 2.0).tan();
                (height * camera.width as f32 / camera.height as f32, height)
            }
        };
        let w = (camera.lookfrom - camera.lookat).normalize();
        let u = camera.vup.cross(w).normalize();
        let v = w.cross(u);
        let viewport_u = viewport_width * u;
        let viewport_v = -viewport_height * v;
        let delta_u = viewport_u / camera.width as f32;
        let delta_v = viewport_v / camera.height as f32;
        // The orthographic view's pixels lie on the plane through the eye.
        let ahead = if camera.view_width.is_some() {
            Vec3::ZERO
        } else {
            -w
        };
        let to_upper_left = ahead - viewport_u / 2.0 - viewport_v / 2.0;
        CameraFrame {
            origin: camera.lookfrom,
            to_pixel00: to_upper_left + 0.5 * (delta_u + delta_v),
            delta_u,
            delta_v,
            lens_radius: camera.aperture_radius,
            focus_distance: camera.focus_distance(),
        }
    }
}
