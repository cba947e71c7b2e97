//! WGSL generated from the kind descriptions (`kinds`) and the Rust constants
//! the kernel shares: what would otherwise be copied by hand into the shaders.
//! The generated modules go through the same composer as the files in
//! `shaders/`, so they may use `#for_each`.

use super::{ArraySource, KernelConfig, LightTablePart, SceneArray, Stage, WORKGROUP_SIZE};
use crate::abi::{
    BINDING_ACCUMULATOR, BINDING_ACTIVE_PIXELS, BINDING_COUNTERS, BINDING_ERROR_STRIPS,
    BINDING_PARAMS, BINDING_PROFILE, BINDING_SPLAT_SAMPLES, ERROR_STRIP_PIXELS,
    ERROR_WORKGROUP_SIZE, GpuLayout, LAYER_REPLICATES, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION,
    LAYER_SUM, LAYER_SUM_COMPENSATION, LUMINANCE, MATERIAL_FLAGS, REPLICATES, SPLAT_STRIP_ROWS,
    TEXTURE_ARRAY_WIDTH, WgslValue,
};
use crate::accel::instances::INSTANCE_LEAF;
use crate::accel::{self, WideBvhNode};
use crate::kinds::{
    ErasedLayout, FILTER_TABLE_BINS, Filter, FilterTable, Lobe, MASK_RAY_HITS, MATERIAL_BUMP_SHIFT,
    MATERIAL_KINDS, MATERIAL_NESTING, MATERIAL_NUMBER_SLOTS, MATERIAL_TEXTURE_BITS,
    MATERIAL_TEXTURE_SHIFT, MATERIAL_TRANSPARENCY_MAX, MATERIAL_TRANSPARENCY_SHIFT, NO_LIGHT,
    PRIMITIVE_KINDS, PrimitiveKind, ROUGH_TRANSMITTANCE_RES, texel_byte_values, texture_constants,
};
use crate::pack::SceneData;
use crate::shader::element_constant;
use std::fmt::Write;

/// Constants every module may use: workgroup size, frame bindings, accumulator
/// layers, material kind ids and the BVH's leaf layout, from their Rust
/// definitions.
pub fn shared_constants() -> String {
    let mut out = String::new();
    let mut constant = |name: &str, value: u32| {
        writeln!(out, "const {name}: u32 = {value}u;").unwrap();
    };
    constant("WORKGROUP_SIZE_X", WORKGROUP_SIZE.0);
    constant("WORKGROUP_SIZE_Y", WORKGROUP_SIZE.1);
    constant("BINDING_PARAMS", BINDING_PARAMS);
    constant("BINDING_ACCUMULATOR", BINDING_ACCUMULATOR);
    constant("BINDING_COUNTERS", BINDING_COUNTERS);
    constant("BINDING_ACTIVE_PIXELS", BINDING_ACTIVE_PIXELS);
    constant("BINDING_SPLAT_SAMPLES", BINDING_SPLAT_SAMPLES);
    constant("SPLAT_STRIP_ROWS", SPLAT_STRIP_ROWS);
    constant("BINDING_ERROR_STRIPS", BINDING_ERROR_STRIPS);
    constant("ERROR_STRIP_PIXELS", ERROR_STRIP_PIXELS);
    constant("ERROR_WORKGROUP_SIZE", ERROR_WORKGROUP_SIZE);
    constant("LAYER_SUM", LAYER_SUM);
    constant("LAYER_SUM_COMPENSATION", LAYER_SUM_COMPENSATION);
    constant("LAYER_SQUARES", LAYER_SQUARES);
    constant("LAYER_SQUARES_COMPENSATION", LAYER_SQUARES_COMPENSATION);
    constant("BINDING_PROFILE", BINDING_PROFILE);
    constant("PROFILE_STAGES", Stage::ALL.len() as u32);
    for stage in Stage::ALL {
        constant(stage.constant(), stage.index());
    }
    constant("LAYER_REPLICATES", LAYER_REPLICATES);
    constant("REPLICATES", REPLICATES);
    for (id, kind) in MATERIAL_KINDS.iter().enumerate() {
        constant(&kind.id_constant(), id as u32);
        for (slot, key) in kind.textured_numbers.iter().enumerate() {
            constant(&kind.number_constant(key), slot as u32);
        }
    }
    constant("MATERIAL_NUMBER_SLOTS", MATERIAL_NUMBER_SLOTS as u32);
    for &(name, bit) in MATERIAL_FLAGS {
        constant(name, bit);
    }
    constant("MATERIAL_TEXTURE_SHIFT", MATERIAL_TEXTURE_SHIFT);
    constant("MATERIAL_TRANSPARENCY_SHIFT", MATERIAL_TRANSPARENCY_SHIFT);
    constant("MATERIAL_TRANSPARENCY_MAX", MATERIAL_TRANSPARENCY_MAX);
    constant("MASK_RAY_HITS", MASK_RAY_HITS);
    constant("MATERIAL_NESTING", MATERIAL_NESTING);
    constant("MATERIAL_TEXTURE_BITS", MATERIAL_TEXTURE_BITS);
    constant("MATERIAL_BUMP_SHIFT", MATERIAL_BUMP_SHIFT);
    for (name, value) in texture_constants() {
        constant(&name, value);
    }
    constant("ROUGH_TRANSMITTANCE_RES", ROUGH_TRANSMITTANCE_RES as u32);
    constant("BVH_LEAF_KIND_SHIFT", accel::LEAF_KIND_SHIFT);
    constant("BVH_LEAF_COUNT_MASK", accel::LEAF_COUNT_MASK);
    constant("TEXTURE_ARRAY_WIDTH", TEXTURE_ARRAY_WIDTH);
    constant("NO_LIGHT", NO_LIGHT);
    writeln!(
        out,
        "const LUMINANCE: vec3<f32> = {};",
        LUMINANCE.wgsl_value()
    )
    .unwrap();
    writeln!(
        out,
        "const TEXEL_BYTE_VALUES: array<f32, 512> = {};",
        texel_byte_values().wgsl_value()
    )
    .unwrap();
    out
}

/// A tabulated pixel filter's bins (`shaders/filter.wgsl`): bin `j` as the
/// constant `FILTER_BINS_j`, its bounds `(q_j, q_j+1)` bit for bit the host's
/// quantiles, read by `filter_bins_at(j)` through a tree of `if`s, as a baked
/// scene array is. Indexing a constant array by a variable instead made
/// `scenes/cornell.toml` 8.6x slower on lavapipe (256², Catmull-Rom: 0.95 M
/// paths/s against 8.2 through the tree; 10.2 with the box filter).
pub fn filter_table(table: &FilterTable) -> String {
    let mut out = format!("const FILTER_TABLE_BINS: u32 = {FILTER_TABLE_BINS}u;\n");
    for (j, bounds) in table.quantiles.windows(2).enumerate() {
        let constant = element_constant("filter_bins", j);
        let value = [bounds[0], bounds[1]].wgsl_value();
        writeln!(out, "const {constant}: vec2<f32> = {value};").unwrap();
    }
    out.push_str("fn filter_bins_at(i: u32) -> vec2<f32> {\n");
    index_tree(&mut out, "filter_bins", 0..FILTER_TABLE_BINS, "    ");
    out.push_str("}\n");
    out
}

/// The splatting pass's reach and edge integrals (`shaders/splat.wgsl`):
/// `SPLAT_REACH` and `splat_edge_integral(j)`, `Filter::splat_edge_integrals`
/// bit for bit, through a tree of `if`s like the filter's table.
pub fn splat_window(filter: Filter) -> String {
    let integrals = filter.splat_edge_integrals();
    let mut out = format!("const SPLAT_REACH: u32 = {}u;\n", filter.splat_reach());
    for (j, integral) in integrals.iter().enumerate() {
        let constant = element_constant("splat_edge", j);
        writeln!(
            out,
            "const {constant}: f32 = {};",
            (*integral as f32).wgsl_value()
        )
        .unwrap();
    }
    out.push_str("fn splat_edge_integral(i: u32) -> f32 {\n");
    index_tree(&mut out, "splat_edge", 0..integrals.len(), "    ");
    out.push_str("}\n");
    out
}

/// The AOV pass's layout (`shaders/aov.wgsl`): `AOV_SLOTS`, the slot of each
/// AOV type of `config.aovs` (`AOV_SLOT_NAME`, in their order), and which of
/// the scene's material kinds give their albedo as their diffuse reflectance.
pub fn aov_layout(config: &KernelConfig) -> String {
    let mut out = format!("const AOV_SLOTS: u32 = {}u;\n", config.aovs.len());
    for (slot, kind) in config.aovs.iter().enumerate() {
        writeln!(
            out,
            "const AOV_SLOT_{}: u32 = {slot}u;",
            kind.name().to_uppercase()
        )
        .unwrap();
    }
    let ids: Vec<String> = config
        .material_kinds
        .iter()
        .filter(|&k| MATERIAL_KINDS[k].diffuse_reflectance_is_albedo)
        .map(|k| format!("m.kind == {}", MATERIAL_KINDS[k].id_constant()))
        .collect();
    let test = match ids.is_empty() {
        true => "false".to_string(),
        false => ids.join(" || "),
    };
    writeln!(
        out,
        "fn albedo_is_diffuse_reflectance(m: Material) -> bool {{ return {test}; }}"
    )
    .unwrap();
    out
}

/// The scene's arrays, the closest-hit query over the primitive kinds present
/// and, when the kernel samples lights, the light density.
///
/// Each array `NAME` gets `NAME_count()` and, when read by a dynamic index,
/// `NAME_at(i)`: over a storage buffer or a texture of group 1
/// (`memory_array`), or over one module constant per element (bit for bit the
/// buffer's contents) when the scene is baked, which `#for_each` unrolls into
/// straight-line code the driver's compiler folds.
pub fn scene(config: &KernelConfig) -> String {
    let mut out = String::new();
    for array in config.scene_arrays() {
        match &config.compiled_in {
            Some(data) if config.compiles_in(array.source) => baked_array(&mut out, &array, data),
            _ => memory_array(&mut out, &array, config.in_texture(array.source)),
        }
    }
    closest_hit(&mut out, config);
    if config.traces_occlusion() {
        occlusion(&mut out, config);
        if config.shadow_rays_find_lights_first() {
            shadow_intersection(&mut out, config);
        }
    }
    if config.samples_lights() {
        light_density(&mut out, config);
    }
    out
}

/// `arrays` declared over storage buffers of group 1, as a scene's kernel reads them.
pub fn buffer_arrays(arrays: Vec<SceneArray>) -> String {
    let mut out = String::new();
    for array in &arrays {
        memory_array(&mut out, array, false);
    }
    out
}

/// An array in memory is read through `NAME_count` and `NAME_at`. Where its
/// elements are structs of whole words (16-byte vectors, or one 8-byte one) of
/// 4-byte fields, a buffer is declared as `vec4<u32>` (`vec2<u32>`) words, read
/// by `NAME_word`, from which `NAME_at` rebuilds the struct: lavapipe (Mesa
/// 22.3) loads a storage buffer in a loop over the SIMD lanes per load
/// instruction, and a struct's load is one instruction per field (a
/// `Triangle`'s four, a `Material`'s eight), its words' one per word. In a
/// texture (`gpu::texture_array`) an array is always words, with `NAME_at`
/// where its fields allow (a wide BVH node's are read as words by its walk).
fn memory_array(out: &mut String, array: &SceneArray, texture: bool) {
    let SceneArray { name, binding, .. } = array;
    let wgsl_type = array.wgsl_type();
    let layout = array.source.element_layout();
    let word = array.source.word_size();
    let fields = match layout {
        Some(layout) => word.and_then(|word| vector_words(layout, word)),
        // An environment map's `vec4<f32>` texels.
        None => Some(vec![format!("bitcast<{wgsl_type}>(w0)")]),
    };
    let word = match word {
        Some(word) if texture || (layout.is_some() && fields.is_some()) => word,
        _ => {
            writeln!(
                out,
                "@group(1) @binding({binding}) var<storage, read> {name}: array<{wgsl_type}>;
fn {name}_count() -> u32 {{ return arrayLength(&{name}); }}
fn {name}_at(i: u32) -> {wgsl_type} {{ return {name}[i]; }}"
            )
            .unwrap();
            return;
        }
    };
    let per_element = array.element_size() / word;
    let (word_type, swizzle) = match word {
        16 => ("vec4<u32>", ""),
        _ => ("vec2<u32>", ".xy"),
    };
    if texture {
        writeln!(
            out,
            "@group(1) @binding({binding}) var {name}: texture_2d<u32>;
fn {name}_count() -> u32 {{ return textureLoad({name}, vec2<u32>(0u), 0).x; }}
fn {name}_word(i: u32) -> {word_type} {{
    let texel = i + 1u;
    return textureLoad({name}, vec2<u32>(texel % TEXTURE_ARRAY_WIDTH, texel / TEXTURE_ARRAY_WIDTH), 0){swizzle};
}}"
        )
        .unwrap();
    } else {
        writeln!(
            out,
            "@group(1) @binding({binding}) var<storage, read> {name}: array<{word_type}>;
fn {name}_count() -> u32 {{ return arrayLength(&{name}) / {per_element}u; }}
fn {name}_word(i: u32) -> {word_type} {{ return {name}[i]; }}"
        )
        .unwrap();
    }
    let Some(fields) = fields else {
        return;
    };
    let mut loads = String::new();
    for w in 0..per_element {
        writeln!(
            loads,
            "    let w{w} = {name}_word({per_element}u * i + {w}u);"
        )
        .unwrap();
    }
    writeln!(
        out,
        "fn {name}_at(i: u32) -> {wgsl_type} {{
{loads}    return {wgsl_type}({});
}}",
        fields.join(", ")
    )
    .unwrap();
}

/// Each field of `layout` read from the words `w0`, `w1`, ... of its element
/// (of `word` bytes), or `None` where a field is not a 4-byte scalar or a
/// vector of them within one word.
fn vector_words(layout: ErasedLayout, word: usize) -> Option<Vec<String>> {
    (layout.fields)()
        .into_iter()
        .map(|(_, offset, wgsl_type)| {
            let components = match wgsl_type.as_str() {
                "u32" | "f32" => 1,
                "vec2<u32>" | "vec2<f32>" => 2,
                "vec3<u32>" | "vec3<f32>" => 3,
                "vec4<u32>" | "vec4<f32>" => 4,
                _ => return None,
            };
            let first = offset % word / 4;
            if offset % 4 != 0 || first + components > word / 4 {
                return None;
            }
            let bits = format!("w{}.{}", offset / word, &"xyzw"[first..first + components]);
            Some(match wgsl_type.ends_with("f32>") || wgsl_type == "f32" {
                true => format!("bitcast<{wgsl_type}>({bits})"),
                false => bits,
            })
        })
        .collect()
}

fn baked_array(out: &mut String, array: &SceneArray, data: &SceneData) {
    let name = &array.name;
    let wgsl_type = array.wgsl_type();
    let values: Vec<String> = match array.source {
        ArraySource::Materials => data.materials.iter().map(GpuLayout::wgsl_value).collect(),
        ArraySource::Primitives(k) | ArraySource::Large(k) | ArraySource::Lights(k) => {
            // Beside a BVH the compiled-in primitives are the large ones alone.
            let packed = match array.source {
                ArraySource::Lights(_) => &data.lights[k],
                _ => &data.geometry.primitives[k],
            };
            let layout = PRIMITIVE_KINDS[k].layout;
            (0..packed.len())
                .map(|i| (layout.wgsl_value)(packed.element(i, layout.size)))
                .collect()
        }
        ArraySource::Normals(k) => {
            let layout = PRIMITIVE_KINDS[k]
                .shading_normals
                .expect("only kinds with shading normals have them");
            data.geometry.normals[k]
                .chunks_exact(layout.size)
                .map(layout.wgsl_value)
                .collect()
        }
        ArraySource::LightTable(k, part) => {
            let tables = data.light_tables[k]
                .as_ref()
                .expect("a kernel with grouped lights has their tables");
            match part {
                LightTablePart::Groups => tables.groups.iter().map(GpuLayout::wgsl_value).collect(),
                LightTablePart::Picks => tables.picks.iter().map(GpuLayout::wgsl_value).collect(),
                LightTablePart::BvhNodes => (data.light_bvh(k).bvh.nodes.iter())
                    .map(GpuLayout::wgsl_value)
                    .collect(),
                LightTablePart::BvhRefs => (data.light_bvh(k).refs.iter())
                    .map(GpuLayout::wgsl_value)
                    .collect(),
            }
        }
        ArraySource::DeltaLights => data
            .delta_lights
            .iter()
            .map(GpuLayout::wgsl_value)
            .collect(),
        ArraySource::BvhNodes | ArraySource::Instances => unreachable!("a baked scene has no BVH"),
        ArraySource::Environment(_)
        | ArraySource::MaterialTables
        | ArraySource::Textures
        | ArraySource::TextureTexels
        | ArraySource::Uvs(_) => unreachable!("never baked"),
    };
    let n = values.len();
    writeln!(out, "fn {name}_count() -> u32 {{ return {n}u; }}").unwrap();
    for (i, value) in values.iter().enumerate() {
        let constant = element_constant(name, i);
        writeln!(out, "const {constant}: {wgsl_type} = {value};").unwrap();
    }
    if array.indexed && n > 0 {
        writeln!(out, "fn {name}_at(i: u32) -> {wgsl_type} {{").unwrap();
        index_tree(out, name, 0..n, "    ");
        out.push_str("}\n");
    } else if array.indexed {
        // Nothing to index (a scene without objects has no materials): never called.
        writeln!(
            out,
            "fn {name}_at(i: u32) -> {wgsl_type} {{ return {wgsl_type}(); }}"
        )
        .unwrap();
    }
}

/// Returns the constant of `name` at index `i` for `i` in `range` (the last one
/// for any index past it), by halving the range: a binary tree of `if`s. A
/// `switch` over the indices was miscompiled by lavapipe (Mesa 22.3) past some
/// size: over the light tables of a mesh of 108 emitting faces (95 nodes, 108
/// picks and references) the `light` strategy saw no light and the mixture 3.3x
/// too much, where this tree and the same tables in buffers agree bit for bit.
fn index_tree(out: &mut String, name: &str, range: std::ops::Range<usize>, indent: &str) {
    if range.len() == 1 {
        let constant = element_constant(name, range.start);
        writeln!(out, "{indent}return {constant};").unwrap();
        return;
    }
    let middle = range.start + range.len() / 2;
    writeln!(out, "{indent}if i < {middle}u {{").unwrap();
    index_tree(out, name, range.start..middle, &format!("{indent}    "));
    writeln!(out, "{indent}}} else {{").unwrap();
    index_tree(out, name, middle..range.end, &format!("{indent}    "));
    writeln!(out, "{indent}}}").unwrap();
}

/// The closest hit keeps only each kind's `NAME_hit_keep` of the closest
/// primitive (and its index, for kinds with shading normals and in kernels
/// with textures), and computes the normals (and texture coordinates) from it
/// once at the end. The primitives are walked by `#for_each`,
/// or reached through the BVH.
fn closest_hit(out: &mut String, config: &KernelConfig) {
    let kinds: Vec<usize> = config.primitive_kinds.iter().collect();
    out.push_str("fn intersect_scene(ray: Ray) -> Hit {\n    var hit = no_hit();\n");
    if kinds.is_empty() {
        out.push_str("    return hit;\n}\n");
        return;
    }
    let keeps_primitive = |k: usize| PRIMITIVE_KINDS[k].keeps_primitive;
    if !kinds.iter().all(|&k| keeps_primitive(k)) {
        out.push_str("    var hit_keep = vec4<f32>(0.0);\n");
    }
    let keeps_index =
        |k: usize| config.normal_kinds.contains(k) || config.textures || keeps_primitive(k);
    if kinds.iter().any(|&k| keeps_index(k)) {
        out.push_str("    var hit_index = 0u;\n");
    }
    let several = kinds.len() > 1;
    if several {
        out.push_str("    var hit_kind = 0xffffffffu;\n");
    }
    if config.instances {
        out.push_str("    var hit_instance = NO_INSTANCE;\n");
    }
    // The test `hit_t` of `primitive`, a kind-`k` element in scope, along `ray`;
    // with instances, `instance` is the one whose group holds it (`NO_INSTANCE`:
    // none).
    let test = |k: usize, hit_t: &str, indent: &str, ray: &str, instance: &str| {
        let name = PRIMITIVE_KINDS[k].name;
        let mut tag = if several {
            format!("{indent}    hit_kind = {k}u;\n")
        } else {
            String::new()
        };
        if config.instances {
            writeln!(tag, "{indent}    hit_instance = {instance};").unwrap();
        }
        if keeps_index(k) {
            writeln!(tag, "{indent}    hit_index = primitive_index;").unwrap();
        }
        if config.light_points() {
            let light = match PRIMITIVE_KINDS[k].grouped_lights {
                true => "primitive.light",
                false => "NO_LIGHT",
            };
            writeln!(tag, "{indent}    hit.light = {light};").unwrap();
        }
        let keep = match keeps_primitive(k) {
            true => String::new(),
            false => format!("{indent}    hit_keep = {name}_hit_keep(primitive);\n"),
        };
        format!(
            "{indent}let t = {hit_t}(primitive, {ray}, hit.t);
{indent}if t > 0.0 {{
{indent}    hit.t = t;
{indent}    hit.material = primitive.material;
{keep}{tag}{indent}}}
"
        )
    };
    if config.bvh() {
        // The large primitives first: the BVH then starts from their closest hit.
        large_primitive_tests(out, config, &test);
        let bvh_kinds: Vec<usize> = config.bvh_kinds.iter().collect();
        bvh_traversal(out, config, &bvh_kinds, &CLOSEST_HIT, test);
    } else {
        for &k in &kinds {
            let kind = PRIMITIVE_KINDS[k];
            let array = kind.array;
            let hit_t = kind.hit_t(config.compiles_in(ArraySource::Primitives(k)));
            write!(
                out,
                "#for_each primitive in {array}\n{}#end_for\n",
                test(k, &hit_t, "    ", "ray", "NO_INSTANCE")
            )
            .unwrap();
        }
    }
    out.push_str("    hit.p = ray.origin + hit.t * ray.dir;\n");
    // An instance's hit is shaded from its group's space: the point goes there,
    // the normals and tangents come back (`instance_to_world`).
    if config.instances {
        out.push_str(
            "    let in_instance = hit_instance != NO_INSTANCE;
    let instance = instances_at(select(0u, hit_instance, in_instance));
    if in_instance {
        let object = instance_ray(instance, ray);
        hit.p = object.ray.origin + (hit.t * object.scale) * object.ray.dir;
    }
",
        );
    }
    // Both normals of the closest hit of kind `k`.
    let normals = |k: usize| {
        let name = PRIMITIVE_KINDS[k].name;
        let shading = if config.normal_kinds.contains(k) {
            format!("{name}_shading_normal(hit_index, hit.p, hit.normal)")
        } else {
            "hit.normal".to_string()
        };
        let factor = PRIMITIVE_KINDS[k].ray_offset_factor;
        let mut set = String::new();
        let keep = match keeps_primitive(k) {
            true => {
                write!(
                    set,
                    "let kept = {}_at(hit_index); ",
                    PRIMITIVE_KINDS[k].array
                )
                .unwrap();
                "kept"
            }
            false => "hit_keep",
        };
        if PRIMITIVE_KINDS[k].reprojects_hit_point {
            write!(set, "hit.p = {name}_hit_point({keep}, hit.p); ").unwrap();
        }
        write!(
            set,
            "hit.normal = {name}_hit_normal({keep}, hit.p); hit.shading_normal = {shading}; \
             hit.offset = {factor:?} * params.ray_offset;"
        )
        .unwrap();
        if config.textures {
            let kind = PRIMITIVE_KINDS[k];
            let uvs = match kind.texture_uvs {
                Some(_) => format!("{}_at(hit_index), ", kind.uvs_array()),
                None => String::new(),
            };
            write!(
                set,
                " hit.uv = {name}_hit_uv({}_at(hit_index), {uvs}hit.p);",
                kind.array
            )
            .unwrap();
        }
        if config.bump_maps {
            let kind = PRIMITIVE_KINDS[k];
            let uvs = match kind.texture_uvs {
                Some(_) => format!("{}_at(hit_index), ", kind.uvs_array()),
                None => String::new(),
            };
            write!(
                set,
                " hit.tangents = {name}_hit_tangents({}_at(hit_index), {uvs}hit.p);",
                kind.array
            )
            .unwrap();
        }
        set
    };
    if several {
        out.push_str("    switch hit_kind {\n");
        for &k in &kinds {
            writeln!(out, "        case {k}u: {{ {} }}", normals(k)).unwrap();
        }
        out.push_str("        default: {}\n    }\n");
    } else {
        writeln!(
            out,
            "    if hit.t < F32_MAX {{\n        {}\n    }}",
            normals(kinds[0])
        )
        .unwrap();
    }
    if config.instances {
        out.push_str(
            "    if in_instance {\n        hit = instance_to_world(hit, instance);\n    }\n",
        );
    }
    out.push_str("    return hit;\n}\n");
}

/// A traversal stack of `size` entries held in as many `u32` variables, the
/// top in `NAME_0`: a push or pop shifts every variable by a `select` under
/// its condition (none: unconditional, inside a branch). lavapipe keeps a
/// private array indexed by a per-lane depth in memory, each indexed store or
/// load a loop over the SIMD lanes; the shifts are whole-vector `select`s.
/// Against the array: 0.87-0.96x the CPU time on the BVH scenes measured
/// (docs/benchmarks.md), and faster at every size tried (6 to 48 entries).
struct RegisterStack {
    name: &'static str,
    size: u32,
}

impl RegisterStack {
    fn entry(&self, i: u32) -> String {
        format!("{}_{i}", self.name)
    }

    /// The top entry (meaningless when the stack is empty).
    fn top(&self) -> String {
        self.entry(0)
    }

    fn declare(&self, indent: &str) -> String {
        (0..self.size)
            .map(|i| format!("{indent}var {} = 0u;\n", self.entry(i)))
            .collect()
    }

    /// `entry(i) = select(entry(i), value, condition)`, or plain assignments.
    fn assign(&self, i: u32, value: &str, condition: Option<&str>, indent: &str) -> String {
        let target = self.entry(i);
        match condition {
            Some(c) => format!("{indent}{target} = select({target}, {value}, {c});\n"),
            None => format!("{indent}{target} = {value};\n"),
        }
    }

    /// Pushes `value` (the bottom entry falls off: the stack is sized to the tree).
    fn push(&self, value: &str, condition: Option<&str>, indent: &str) -> String {
        let mut out: String = (1..self.size)
            .rev()
            .map(|i| self.assign(i, &self.entry(i - 1), condition, indent))
            .collect();
        out.push_str(&self.assign(0, value, condition, indent));
        out
    }

    /// Replaces the top entry by `value`.
    fn set_top(&self, value: &str, condition: Option<&str>, indent: &str) -> String {
        self.assign(0, value, condition, indent)
    }

    /// Drops the top entry.
    fn pop(&self, condition: Option<&str>, indent: &str) -> String {
        (1..self.size)
            .map(|i| self.assign(i - 1, &self.entry(i), condition, indent))
            .collect()
    }
}

/// A walk of a wide BVH (`accel::WideBvh`) from its root, the code of
/// `wide_bvh_walk`: where its nodes are and which boxes it opens.
struct WideWalk<'a> {
    /// The nodes' array.
    nodes: &'a str,
    memory: NodeMemory,
    /// The ray's origin; `inv_dir` is its direction's reciprocal, in scope.
    origin: &'a str,
    /// Boxes entered beyond this distance are skipped.
    t_max: &'a str,
    /// The root node's index.
    root: &'a str,
    /// The name of its stack's entries (`RegisterStack`).
    stack: &'static str,
}

/// How a walk reads its nodes' arrays.
#[derive(Clone, Copy)]
enum NodeMemory {
    /// Compiled in: a node is read through `NAME_at`.
    Baked,
    /// A storage buffer, whose nodes are read in place: copying each node out
    /// through `NAME_at` took 1.25x the time of the light walk in place
    /// (Mitsuba's box with the bunny emitting, under the mixture).
    Buffer,
    /// A texture, read a word at a time through `NAME_word`.
    Texture,
}

impl NodeMemory {
    fn of(config: &KernelConfig, nodes: ArraySource) -> NodeMemory {
        if config.compiles_in(nodes) {
            NodeMemory::Baked
        } else if config.in_texture(nodes) {
            NodeMemory::Texture
        } else {
            NodeMemory::Buffer
        }
    }
}

/// The word of a wide BVH node holding `field` (`accel::WideBvhNode`'s layout).
fn node_word(field: &str) -> usize {
    let (_, offset, _) = (WideBvhNode::fields().into_iter())
        .find(|(name, _, _)| *name == field)
        .expect("a field of WideBvhNode");
    offset / 16
}

/// Depth-first walk of a wide BVH with a stack, running `visit` at every
/// interior node it opens and `leaf` at every leaf
/// whose box the ray enters before `walk.t_max` (with `link` the leaf's
/// `(first, count)` and `end` its range's end): the nearest hit child next,
/// the others later, nearer first. While-while (Aila and Laine 2009): an inner
/// loop descends to a leaf, so SIMD lanes walking interior nodes stay in step.
/// A node's farther hit children are one stack entry (`wide_bvh_entry`), so
/// the stack holds one entry per level (a `RegisterStack`); a pop takes the
/// entry's nearest child and reads its link from the node. lavapipe runs both
/// sides of every branch (masked), so a node visit reads one link, its nearest
/// hit child's or the popped one's (two reads took 1.08x the CPU time on 4 000
/// spheres), and updates the stack by `select`s rather than under branches.
fn wide_bvh_walk(out: &mut String, walk: &WideWalk, stack_size: u32, visit: &str, leaf: &str) {
    let WideWalk {
        nodes,
        memory,
        origin,
        t_max,
        root,
        stack,
    } = walk;
    let stack = RegisterStack {
        name: stack,
        size: stack_size,
    };
    let top = stack.top();
    let words = size_of::<WideBvhNode>() / 16;
    let box_fields = ["planes_a", "planes_b", "origin"];
    // The visited node (`node`), and its box vectors: the three arguments of
    // `wide_bvh_children_t`.
    let (node, boxes) = match memory {
        NodeMemory::Baked => (
            format!("{nodes}_at(link.x)"),
            box_fields.map(|field| format!("node.{field}")),
        ),
        NodeMemory::Buffer => (
            format!("&{nodes}[link.x]"),
            box_fields.map(|field| format!("(*node).{field}")),
        ),
        NodeMemory::Texture => (
            format!("{words}u * link.x"),
            box_fields.map(|field| {
                let word = format!("{nodes}_word(node + {}u)", node_word(field));
                match field {
                    "origin" => format!("bitcast<vec4<f32>>({word})"),
                    _ => word,
                }
            }),
        ),
    };
    let boxes = boxes.join(", ");
    // `link = ` the link in `slot` of node `index`.
    let read_link = |index: &str, indent: &str| match memory {
        NodeMemory::Baked => format!("{indent}link = {nodes}_at({index}).links[slot];\n"),
        NodeMemory::Buffer => format!("{indent}link = {nodes}[{index}].links[slot];\n"),
        NodeMemory::Texture => format!(
            "{indent}let pair = {nodes}_word({words}u * ({index}) + {}u + (slot >> 1u));\n\
             {indent}link = select(pair.xy, pair.zw, (slot & 1u) != 0u);\n",
            node_word("links")
        ),
    };
    // The top entry once `entry`, its nearest child, is taken: the rest, or
    // popped when none is left (where `taken`, if given).
    let pop_rest = |taken: Option<&str>, indent: &str| {
        let done = match taken {
            Some(c) => format!("{c} && (rest & 0xc0u) == 0u"),
            None => "(rest & 0xc0u) == 0u".to_string(),
        };
        format!(
            "{indent}let rest = wide_bvh_entry_rest(entry);
{indent}let done = {done};
{}{}{indent}depth -= select(0u, 1u, done);
",
            stack.set_top("rest", taken, indent),
            stack.pop(Some("done"), indent),
        )
    };
    write!(
        out,
        "{}    var depth = 0u;
    // The child being walked to: (first, count) as in a node (count 0: interior).
    var link = vec2<u32>({root}, 0u);
    loop {{
        var missed = false;
        loop {{
            if link.y != 0u {{
                break;
            }}
{visit}            let node = {node};
            let keys = wide_bvh_order(wide_bvh_children_t({boxes}, {origin}, inv_dir, {t_max}));
            let hits = select(vec4<u32>(0u), vec4<u32>(1u), keys < vec4<u32>(WIDE_BVH_MISS));
            let pending = hits.y + hits.z + hits.w;
            let pushed = pending != 0u;
{}            depth += select(0u, 1u, pushed);
            let from_stack = hits.x == 0u;
            if from_stack && depth == 0u {{
                missed = true;
                break;
            }}
            // The nearest hit child, else the stack top's nearest.
            let entry = {top};
            let slot = select(keys.x, entry, from_stack) & 3u;
{}{}        }}
        if missed {{
            break;
        }}
        let end = link.x + (link.y & BVH_LEAF_COUNT_MASK);
{leaf}        if depth == 0u {{
            break;
        }}
        let entry = {top};
        let slot = entry & 3u;
{}{}    }}
",
        stack.declare("    "),
        stack.push(
            "wide_bvh_entry(link.x, keys, pending)",
            Some("pushed"),
            "            "
        ),
        read_link("select(link.x, entry >> 8u, from_stack)", "            "),
        pop_rest(Some("from_stack"), "            "),
        read_link("entry >> 8u", "        "),
        pop_rest(None, "        "),
    )
    .unwrap();
}

/// `test` (a kind, its test's function, an indent, the ray and the instance)
/// run on each of the large primitives compiled in beside the BVH, by their
/// kind's test of constants (`PrimitiveKind::hit_t`), as a baked scene's.
fn large_primitive_tests(
    out: &mut String,
    config: &KernelConfig,
    test: &impl Fn(usize, &str, &str, &str, &str) -> String,
) {
    for array in config.scene_arrays() {
        if let ArraySource::Large(k) = array.source {
            write!(
                out,
                "#for_each primitive in {}\n{}#end_for\n",
                array.name,
                test(
                    k,
                    &PRIMITIVE_KINDS[k].hit_t(true),
                    "    ",
                    "ray",
                    "NO_INSTANCE"
                )
            )
            .unwrap();
        }
    }
}

/// `occluded(ray, t_max)`: whether the ray hits anything nearer than `t_max`,
/// for the shadow rays that need only that (`KernelConfig::traces_occlusion`).
/// Through the BVH (and the instances' groups) the walk ends at the first hit
/// it finds and computes nothing of it; a baked or listed scene's loops, which
/// the driver folds, ask the closest hit.
fn occlusion(out: &mut String, config: &KernelConfig) {
    out.push_str("fn occluded(ray: Ray, t_max: f32) -> bool {\n");
    if !config.bvh() {
        out.push_str("    return intersect_scene(ray).t < t_max;\n}\n");
        return;
    }
    let test = |_k: usize, hit_t: &str, indent: &str, ray: &str, _instance: &str| {
        format!("{indent}blocked = blocked || {hit_t}(primitive, {ray}, t_bound) > 0.0;\n")
    };
    out.push_str("    var blocked = false;\n    var t_bound = t_max;\n");
    large_primitive_tests(out, config, &test);
    let bvh_kinds: Vec<usize> = config.bvh_kinds.iter().collect();
    out.push_str("    if blocked {\n        return true;\n    }\n");
    let stop = "        if blocked {\n            break;\n        }\n";
    let bound = WalkBound {
        t: "t_bound",
        after_leaf: stop,
        enter_instance: "t_bound = t_max * object.scale;",
        leave_instance: "t_bound = t_max;\n                    if blocked {\n                        break;\n                    }",
    };
    bvh_traversal(out, config, &bvh_kinds, &bound, test);
    out.push_str("    return blocked;\n}\n");
}

/// `intersect_shadow_ray(ray)`: what a next-event shadow ray reads of
/// `intersect_scene`'s hit (its distance, material and normal), found for less
/// (`KernelConfig::shadow_rays_find_lights_first`): the nearest light, each
/// tested in turn, then whether anything is nearer (`occluded`). Every emitter
/// is a light, so a nearer surface emits nothing and hides the light: the ray
/// then ends at a hit at 0 that faces nowhere. A light's hit is the walk's (the
/// same primitive's bytes, the same tests).
fn shadow_intersection(out: &mut String, config: &KernelConfig) {
    out.push_str("fn intersect_shadow_ray(ray: Ray) -> Hit {\n    var hit = no_hit();\n");
    for k in config.light_kinds.iter() {
        let kind = PRIMITIVE_KINDS[k];
        let name = kind.name;
        let keep = match kind.keeps_primitive {
            true => "light".to_string(),
            false => format!("{name}_hit_keep(light)"),
        };
        let point = match kind.reprojects_hit_point {
            true => format!("{name}_hit_point({keep}, ray.origin + t * ray.dir)"),
            false => "ray.origin + t * ray.dir".to_string(),
        };
        write!(
            out,
            "#for_each light in {lights}
    let t = {name}_hit_t(light, ray, hit.t);
    if t > 0.0 {{
        hit.t = t;
        hit.material = light.material;
        hit.normal = {name}_hit_normal({keep}, {point});
    }}
#end_for
",
            lights = kind.light_array()
        )
        .unwrap();
    }
    out.push_str(
        "    if occluded(ray, hit.t) {
        hit.t = 0.0;
        hit.normal = vec3<f32>(0.0);
    }
    return hit;
}
",
    );
}

/// Where a walk keeps its bound on the distance and what it does after a leaf
/// and around an instance's group (`object`: the ray there and its scale).
struct WalkBound {
    /// A variable: the closest hit's `hit.t`, or the bound `occluded` asks.
    t: &'static str,
    after_leaf: &'static str,
    /// Into the group's space, where the bound is scaled, and back out.
    enter_instance: &'static str,
    leave_instance: &'static str,
}

/// The closest hit's bound: the hit's distance, scaled into an instance's
/// group and back unless the closest hit is there.
const CLOSEST_HIT: WalkBound = WalkBound {
    t: "hit.t",
    after_leaf: "",
    enter_instance: "let t_world = hit.t;\n                    hit.t = t_world * object.scale;",
    leave_instance: "hit.t = select(t_world, hit.t / object.scale, hit_instance == instance_index);",
};

/// A walk of the scene's BVH (`bvh_nodes`) over the boxes the ray enters
/// before `bound.t`: a leaf is a range of one kind's array, tested by `test` (a
/// kind, an indent, the ray and the instance the primitive is in), then
/// `bound.after_leaf` runs; one switch per leaf, none with one kind.
/// With instances a leaf may be a range of instances (`accel::instances`):
/// each carries the ray into its group's space and walks the group's BVH
/// there (its own stack), distances scaled to that space's.
fn bvh_traversal(
    out: &mut String,
    config: &KernelConfig,
    kinds: &[usize],
    bound: &WalkBound,
    test: impl Fn(usize, &str, &str, &str, &str) -> String,
) {
    // A profiling kernel counts the walk's node visits and primitive tests
    // toward the closest hit's stages or the shadow ray's (`profile_walk`).
    let hook = |stage: &str, indent: &str| match config.profile {
        true => format!("{indent}profile({stage});\n"),
        false => String::new(),
    };
    let range = |k: usize, indent: &str, ray: &str, instance: &str| {
        let kind = PRIMITIVE_KINDS[k];
        format!(
            "{indent}for (var primitive_index = link.x; primitive_index < end; primitive_index += 1u) {{\n{}{indent}    let primitive = {}_at(primitive_index);\n{}{indent}}}\n",
            hook("profile_walk + 1u", &format!("{indent}    ")),
            kind.array,
            test(
                k,
                &kind.hit_t(false),
                &format!("{indent}    "),
                ray,
                instance
            )
        )
    };
    // A leaf's ranges by its kind.
    let leaves = |ray: &str, instance: &str, instances: Option<&str>| {
        if let ([only], None) = (kinds, instances) {
            return range(*only, "        ", ray, instance);
        }
        let mut cases = String::from("        switch link.y >> BVH_LEAF_KIND_SHIFT {\n");
        for &k in kinds {
            write!(
                cases,
                "            case {k}u: {{\n{}            }}\n",
                range(k, "                ", ray, instance)
            )
            .unwrap();
        }
        if let Some(instances) = instances {
            write!(
                cases,
                "            case {INSTANCE_LEAF}u: {{\n{instances}            }}\n"
            )
            .unwrap();
        }
        cases.push_str("            default: {}\n        }\n");
        cases
    };
    let visit = hook("profile_walk", "            ");
    let instances = config.instances.then(|| {
        let walk = WideWalk {
            nodes: "bvh_nodes",
            memory: NodeMemory::of(config, ArraySource::BvhNodes),
            origin: "object.ray.origin",
            t_max: bound.t,
            root: "instance.root",
            stack: "group_stack",
        };
        let mut group = String::new();
        let leaf = leaves("object.ray", "instance_index", None) + bound.after_leaf;
        wide_bvh_walk(&mut group, &walk, config.instance_stack, &visit, &leaf);
        format!(
            "                for (var instance_index = link.x; instance_index < end; instance_index += 1u) {{
                    let instance = instances_at(instance_index);
                    let object = instance_ray(instance, ray);
                    {}
                    let inv_dir = 1.0 / object.ray.dir;
{group}                    {}
                }}
",
            bound.enter_instance, bound.leave_instance
        )
    });
    let leaf = leaves("ray", "NO_INSTANCE", instances.as_deref()) + bound.after_leaf;
    out.push_str("    let inv_dir = 1.0 / ray.dir;\n");
    let walk = WideWalk {
        nodes: "bvh_nodes",
        memory: NodeMemory::of(config, ArraySource::BvhNodes),
        origin: "ray.origin",
        t_max: bound.t,
        root: "0u",
        stack: "stack",
    };
    wide_bvh_walk(out, &walk, config.bvh_stack, &visit, &leaf);
}

/// The light density p_light: the average of the solid-angle densities of every
/// object in it (emitters, and objects marked for importance), where a group of
/// a grouped kind (a mesh) is one object whose density is its members', each
/// weighted by its probability within the group, and an environment map is one
/// more object (the last). Choosing one object uniformly and sampling it draws
/// from exactly this density.
fn light_density(out: &mut String, config: &KernelConfig) {
    let kinds: Vec<usize> = config.light_kinds.iter().collect();
    let grouped = |k: usize| PRIMITIVE_KINDS[k].grouped_lights;
    let points = config.light_points();
    for &k in kinds.iter().filter(|&&k| grouped(k)) {
        group_sample(out, PRIMITIVE_KINDS[k]);
        if config.walks_light_groups() {
            groups_pdf(out, k, config);
        }
    }
    let mut counts: Vec<String> = kinds
        .iter()
        .map(|&k| match grouped(k) {
            true => format!(
                "{}_count()",
                LightTablePart::Groups.array(PRIMITIVE_KINDS[k].name)
            ),
            false => format!("{}_count()", PRIMITIVE_KINDS[k].light_array()),
        })
        .collect();
    let environment = config.light_environment;
    if environment {
        counts.push("1u".into());
    }
    writeln!(
        out,
        "fn light_count() -> u32 {{ return {}; }}",
        counts.join(" + ")
    )
    .unwrap();
    if config.spatial_light_selection {
        spatial_light_density(out, &kinds);
        return;
    }
    // `select` (uniform in [0, 1)) picks the object, `u` the point on it; what
    // is left of `select` picks a group's member.
    out.push_str(
        "fn light_sample(origin: vec3<f32>, select: f32, u: vec2<f32>) -> LightSample {\n",
    );
    if !kinds.is_empty() {
        out.push_str(
            "    let count = light_count();
    let k = min(u32(select * f32(count)), count - 1u);
    var first = 0u;
",
        );
    }
    for (i, &k) in kinds.iter().enumerate() {
        let kind = PRIMITIVE_KINDS[k];
        let call = match grouped(k) {
            true => format!(
                "{}_group_sample(k - first, select * f32(count) - f32(k), origin, u)",
                kind.light_array()
            ),
            false => format!(
                "LightSample({}_light_sample({}_at(k - first), origin, u), NO_LIGHT)",
                kind.name,
                kind.light_array()
            ),
        };
        if i + 1 == kinds.len() && !environment {
            writeln!(out, "    return {call};").unwrap();
        } else {
            writeln!(
                out,
                "    if k < first + {count} {{\n        return {call};\n    }}\n    first += {count};",
                count = counts[i]
            )
            .unwrap();
        }
    }
    if environment {
        out.push_str("    return LightSample(environment_sample(u), NO_LIGHT);\n");
    }
    out.push_str("}\n");
    out.push_str(
        "fn light_pdf(origin: vec3<f32>, dir: vec3<f32>) -> f32 {\n    var total = 0.0;\n",
    );
    for &k in &kinds {
        let kind = PRIMITIVE_KINDS[k];
        if grouped(k) && points {
            // Its points' densities are found where rays hit them (`light_point_pdf`).
            continue;
        }
        if grouped(k) && config.walks_light_groups() {
            writeln!(
                out,
                "    total += {}_groups_pdf(origin, dir);",
                kind.light_array()
            )
            .unwrap();
        } else {
            // Each light; a group's member weighted by its probability within the group.
            let weight = match grouped(k) {
                true => format!(
                    "{}_at(light_index).pmf * ",
                    LightTablePart::Picks.array(kind.name)
                ),
                false => String::new(),
            };
            write!(
                out,
                "#for_each light in {}
    total += {weight}{}_light_pdf(light, origin, dir);
#end_for
",
                kind.light_array(),
                kind.name
            )
            .unwrap();
        }
    }
    if environment {
        out.push_str("    total += environment_pdf(dir);\n");
    }
    out.push_str("    return total / f32(light_count());\n}\n");
    if points {
        light_point_pdf(out, &kinds);
    }
}

/// The share of the spatial light selection (`KernelConfig::spatial_light_selection`)
/// that picks uniformly: a defensive mixture (Hesterberg 1995), so that a light
/// the bound undervalues at a point, one far off while nearer ones are hidden
/// behind walls, is still picked with probability at least this over the light
/// count, and its samples' weights stay bounded.
pub const SPATIAL_UNIFORM_SHARE: f32 = 0.1;

/// The light density of the spatial selection (`KernelConfig::spatial_light_selection`):
/// at a point `origin`, each light's solid-angle density weighted by its
/// share there, `(1 - b) I_i / sum I + b / N` for importances `I`
/// (`PrimitiveKind::light_importance`), `N` lights and `b` the
/// [`SPATIAL_UNIFORM_SHARE`] (uniform where every importance is 0: behind every
/// one-sided emitter). Picking a light by its share and sampling it draws from
/// exactly this density; the pick and the density sum the importances in one
/// order, so their totals agree to the bit. After `light_count`, which
/// `light_density` writes for both selections.
fn spatial_light_density(out: &mut String, kinds: &[usize]) {
    // A block per light: `body(i, kind)` with `light` the element of kind
    // `kinds[i]`, in braces so that unrolled copies declare their own names.
    let each_light = |out: &mut String, body: &dyn Fn(usize, &str) -> String| {
        for (i, &k) in kinds.iter().enumerate() {
            let kind = PRIMITIVE_KINDS[k];
            writeln!(out, "#for_each light in {}", kind.light_array()).unwrap();
            writeln!(out, "    {{\n{}    }}\n#end_for", body(i, kind.name)).unwrap();
        }
    };
    // A light's share is `importance * shares.x + shares.y`.
    writeln!(
        out,
        "fn light_shares(total: f32) -> vec2<f32> {{
    let uniform = {SPATIAL_UNIFORM_SHARE:?};
    let spatial = select(0.0, (1.0 - uniform) / total, total > 0.0);
    return vec2<f32>(spatial, select(1.0, uniform, total > 0.0) / f32(light_count()));
}}"
    )
    .unwrap();
    out.push_str("fn light_importance_total(origin: vec3<f32>) -> f32 {\n    var total = 0.0;\n");
    each_light(out, &|_, name| {
        format!("        total += {name}_light_importance(light, origin);\n")
    });
    out.push_str("    return total;\n}\n");
    // `select` (uniform in [0, 1)) picks the light in whose share of the running
    // sum it falls (the last, should rounding leave it past them all), `u` the
    // point on it.
    out.push_str(
        "fn light_sample(origin: vec3<f32>, select: f32, u: vec2<f32>) -> LightSample {
    let shares = light_shares(light_importance_total(origin));
    var running = 0.0;
    var found = false;
    var chosen_kind = 0u;
    var chosen = 0u;
",
    );
    each_light(out, &|i, name| {
        format!(
            "        if !found {{
            running += {name}_light_importance(light, origin) * shares.x + shares.y;
            chosen_kind = {i}u;
            chosen = light_index;
            found = running > select;
        }}
"
        )
    });
    for (i, &k) in kinds.iter().enumerate() {
        let kind = PRIMITIVE_KINDS[k];
        let call = format!(
            "return LightSample({}_light_sample({}_at(chosen), origin, u), NO_LIGHT);",
            kind.name,
            kind.light_array()
        );
        match i + 1 == kinds.len() {
            true => writeln!(out, "    {call}\n}}").unwrap(),
            false => {
                writeln!(out, "    if chosen_kind == {i}u {{\n        {call}\n    }}").unwrap()
            }
        }
    }
    // Sum over lights of (importance * shares.x + shares.y) * pdf, gathered as
    // shares.x * sum(importance * pdf) + shares.y * sum(pdf) in one walk.
    out.push_str(
        "fn light_pdf(origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    var total = 0.0;
    var weighted = 0.0;
    var plain = 0.0;
",
    );
    each_light(out, &|_, name| {
        format!(
            "        let importance = {name}_light_importance(light, origin);
        let pdf = {name}_light_pdf(light, origin, dir);
        total += importance;
        weighted += importance * pdf;
        plain += pdf;
"
        )
    });
    out.push_str(
        "    let shares = light_shares(total);\n    return shares.x * weighted + shares.y * plain;\n}\n",
    );
}

/// `light_point_pdf(hit, dir)`: the light density's share of the grouped light
/// `hit` found along `dir` (`GroupedDensity::Points`), that point's own
/// (0 where it found none): the probability of its group's pick and of the
/// member within it, times the member's density at the point.
fn light_point_pdf(out: &mut String, kinds: &[usize]) {
    let grouped: Vec<&PrimitiveKind> = kinds
        .iter()
        .map(|&k| PRIMITIVE_KINDS[k])
        .filter(|kind| kind.grouped_lights)
        .collect();
    // `Hit::light` indexes one kind's lights.
    let [kind] = grouped[..] else {
        panic!("one grouped light kind, not {}", grouped.len());
    };
    let (name, lights) = (kind.name, kind.light_array());
    let picks = LightTablePart::Picks.array(name);
    // Selects rather than an early return: lavapipe runs both sides, and the
    // reads stay in bounds.
    writeln!(
        out,
        "fn light_point_pdf(hit: Hit, dir: vec3<f32>) -> f32 {{
    let found = hit.light != NO_LIGHT;
    let light = select(0u, hit.light, found);
    let pdf = {picks}_at(light).pmf * {name}_light_point_pdf({lights}_at(light), hit.t, dir);
    return select(0.0, pdf / f32(light_count()), found);
}}"
    )
    .unwrap();
}

/// `LIGHTS_group_sample` (LIGHTS: the kind's light array): a member of a group
/// of grouped light kind `kind` (`lights::LightTables`), picked by its alias
/// table, and the direction toward a point on it.
fn group_sample(out: &mut String, kind: &PrimitiveKind) {
    let (name, lights) = (kind.name, kind.light_array());
    let groups = LightTablePart::Groups.array(name);
    let picks = LightTablePart::Picks.array(name);
    write!(
        out,
        "fn {lights}_group_sample(group_index: u32, choice: f32, origin: vec3<f32>, u: vec2<f32>) -> LightSample {{
    let group = {groups}_at(group_index);
    let scaled = choice * f32(group.count);
    let slot = min(u32(scaled), group.count - 1u);
    let pick = {picks}_at(group.first + slot);
    let member = group.first + select(pick.other, slot, scaled - f32(slot) < pick.threshold);
    return LightSample({name}_light_sample({lights}_at(member), origin, u), member);
}}
"
    )
    .unwrap();
}

/// `LIGHTS_groups_pdf`: the density of a direction over the groups of grouped
/// light kind `kind`, summed over every member the ray
/// meets (not only the first: a direction's density counts every point that
/// could have been sampled along it) through the lights' own wide BVH (leaves
/// are ranges of its `refs`, which index the light array), each member's
/// density weighted by its probability within its group.
fn groups_pdf(out: &mut String, k: usize, config: &KernelConfig) {
    let kind = PRIMITIVE_KINDS[k];
    let (name, lights) = (kind.name, kind.light_array());
    let nodes = LightTablePart::BvhNodes.array(name);
    let refs = LightTablePart::BvhRefs.array(name);
    write!(
        out,
        "fn {lights}_groups_pdf(origin: vec3<f32>, dir: vec3<f32>) -> f32 {{
    var total = 0.0;
    let inv_dir = 1.0 / dir;
"
    )
    .unwrap();
    let leaf = format!(
        "        for (var r = link.x; r < end; r += 1u) {{
            let entry = {refs}_at(r);
            total += entry.pmf * {name}_light_pdf({lights}_at(entry.light), origin, dir);
        }}
"
    );
    let walk = WideWalk {
        nodes: &nodes,
        memory: NodeMemory::of(config, ArraySource::LightTable(k, LightTablePart::BvhNodes)),
        origin: "origin",
        t_max: "F32_MAX",
        root: "0u",
        stack: "stack",
    };
    wide_bvh_walk(out, &walk, config.light_bvh_stack, "", &leaf);
    out.push_str("    return total;\n}\n");
}

/// The BSDF interface's dispatch by material kind (materials.wgsl), over the
/// kinds compiled in. `bsdf_sample` takes any material; `bsdf_is_smooth`,
/// `bsdf_eval`, `bsdf_pdf`, `smooth_bsdf_sample` and `delta_bsdf_sample` exist
/// where the kernel evaluates BSDFs (`KernelConfig::evaluates_bsdfs`); the
/// three before the last take only materials with a smooth lobe (a direct call
/// when the kernel has one such kind), the last only those without.
pub fn bsdf(config: &KernelConfig) -> String {
    let mut out = String::new();
    let scattering: Vec<usize> = config
        .material_kinds
        .iter()
        .filter(|&k| MATERIAL_KINDS[k].lobe != Lobe::Absorbing)
        .collect();
    let smooth: Vec<usize> = scattering
        .iter()
        .copied()
        .filter(|&k| MATERIAL_KINDS[k].lobe.has_density())
        .collect();
    // With shading normals, each entry point of the interface passes through
    // the leak check of materials.wgsl (`shading_`: the material's own answer).
    let shading = config.shading_normals();
    let prefix = if shading { "shading_" } else { "" };
    dispatch(
        &mut out,
        &format!("{prefix}bsdf_sample"),
        "sample",
        "wo: vec3<f32>",
        "wo",
        "BsdfSample",
        &scattering,
        Some("bsdf_absorbed()"),
    );
    if shading {
        out.push_str(
            "fn bsdf_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    return bsdf_sample_checked(frame, shading_bsdf_sample(m, frame, wo));
}
",
        );
    }
    if !config.evaluates_bsdfs() {
        return out;
    }
    let ids: Vec<String> = smooth
        .iter()
        .map(|&k| format!("m.kind == {}", MATERIAL_KINDS[k].id_constant()))
        .collect();
    let test = if ids.is_empty() {
        "false".to_string()
    } else {
        ids.join(" || ")
    };
    writeln!(
        out,
        "fn bsdf_is_smooth(m: Material) -> bool {{ return {test}; }}"
    )
    .unwrap();
    let wi = "wo: vec3<f32>, wi: vec3<f32>";
    dispatch(
        &mut out,
        &format!("{prefix}bsdf_eval"),
        "eval",
        wi,
        "wo, wi",
        "vec3<f32>",
        &smooth,
        None,
    );
    dispatch(
        &mut out, "bsdf_pdf", "pdf", wi, "wo, wi", "f32", &smooth, None,
    );
    dispatch(
        &mut out,
        &format!("{prefix}smooth_bsdf_sample"),
        "sample",
        "wo: vec3<f32>",
        "wo",
        "BsdfSample",
        &smooth,
        None,
    );
    // What a path follows where the material has no smooth lobe (strategy.wgsl):
    // only those kinds' samplers, for lavapipe runs every case of a switch,
    // taken or not (masked), and the smooth kinds' would run twice a vertex.
    let delta: Vec<usize> = scattering
        .iter()
        .copied()
        .filter(|k| !smooth.contains(k))
        .collect();
    dispatch(
        &mut out,
        &format!("{prefix}delta_bsdf_sample"),
        "sample",
        "wo: vec3<f32>",
        "wo",
        "BsdfSample",
        &delta,
        Some("bsdf_absorbed()"),
    );
    if shading {
        // Bump and normal maps shadow themselves (`bump_shadowing`); the
        // density is left as it is, as Mitsuba leaves it.
        let value = match config.bump_maps {
            true => "shading_bsdf_eval(m, frame, wo, wi) * bump_shadowing(frame, wi)",
            false => "shading_bsdf_eval(m, frame, wo, wi)",
        };
        write!(
            out,
            "fn bsdf_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {{
    return select({value}, vec3<f32>(0.0), bsdf_leaks(frame, wi));
}}
"
        )
        .unwrap();
        for name in ["smooth_bsdf_sample", "delta_bsdf_sample"] {
            writeln!(
                out,
                "fn {name}(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {{
    return bsdf_sample_checked(frame, shading_{name}(m, frame, wo));
}}"
            )
            .unwrap();
        }
    }
    out
}

/// `fn NAME(m, frame, PARAMS) -> RESULT` calling `KIND_FUNCTION` for each kind
/// of `kinds`: a switch on the kind with `fallback` as default, or, without a
/// fallback and with one kind, a direct call. Without a fallback the default is
/// the last kind's call.
#[allow(clippy::too_many_arguments)]
fn dispatch(
    out: &mut String,
    name: &str,
    function: &str,
    params: &str,
    args: &str,
    result: &str,
    kinds: &[usize],
    fallback: Option<&str>,
) {
    writeln!(
        out,
        "fn {name}(m: Material, frame: Frame, {params}) -> {result} {{"
    )
    .unwrap();
    let call = |k: usize| format!("{}_{function}(m, frame, {args})", MATERIAL_KINDS[k].name);
    match (kinds, fallback) {
        ([], None) => unreachable!("`{name}` over no material kind"),
        ([only], None) => writeln!(out, "    return {};", call(*only)).unwrap(),
        _ => {
            out.push_str("    switch m.kind {\n");
            let (cases, default) = match fallback {
                Some(fallback) => (kinds, fallback.to_string()),
                None => (&kinds[..kinds.len() - 1], call(kinds[kinds.len() - 1])),
            };
            for &k in cases {
                writeln!(
                    out,
                    "        case {}: {{ return {}; }}",
                    MATERIAL_KINDS[k].id_constant(),
                    call(k)
                )
                .unwrap();
            }
            writeln!(out, "        default: {{ return {default}; }}\n    }}").unwrap();
        }
    }
    out.push_str("}\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::WideBvhNode;
    use crate::kinds::PackedTriangle;
    use crate::lights::LightRef;
    use std::collections::HashMap;

    #[test]
    fn structs_of_whole_words_are_read_as_words() {
        assert_eq!(
            vector_words(ErasedLayout::of::<PackedTriangle>(), 16).unwrap(),
            [
                "bitcast<vec3<f32>>(w0.xyz)",
                "w0.w",
                "bitcast<vec3<f32>>(w1.xyz)",
                "w1.w",
                "bitcast<vec3<f32>>(w2.xyz)",
                "w2.w",
            ]
        );
        // An 8-byte element is one two-component word.
        assert_eq!(
            vector_words(ErasedLayout::of::<LightRef>(), 8).unwrap(),
            ["w0.x", "bitcast<f32>(w0.y)"]
        );
        // 12 bytes an element, or a table of floats: not words; an
        // environment map's `vec4<f32>` texels are; an array field: words
        // without `NAME_at`.
        let triangle = PRIMITIVE_KINDS
            .iter()
            .position(|kind| kind.name == "triangle")
            .unwrap();
        assert_eq!(ArraySource::Normals(triangle).word_size(), None);
        assert_eq!(ArraySource::MaterialTables.word_size(), None);
        assert_eq!(ArraySource::Primitives(triangle).word_size(), Some(16));
        assert_eq!(
            ArraySource::Environment(crate::kernel::EnvironmentPart::Texels).word_size(),
            Some(16)
        );
        assert_eq!(ArraySource::BvhNodes.word_size(), Some(16));
        assert_eq!(vector_words(ErasedLayout::of::<WideBvhNode>(), 16), None);
    }

    /// Runs the stack's generated assignments (`x = v;` or `x = select(x, v, c);`,
    /// each reading the values of the statements before it) on `vars`.
    fn run(code: &str, vars: &mut HashMap<String, u32>) {
        for line in code.lines() {
            let (target, value) = line.trim().trim_end_matches(';').split_once(" = ").unwrap();
            let value = match value.strip_prefix("select(") {
                Some(args) => {
                    let args: Vec<&str> = args.trim_end_matches(')').split(", ").collect();
                    args[if vars[args[2]] != 0 { 1 } else { 0 }]
                }
                None => value,
            };
            vars.insert(target.to_string(), vars[value]);
        }
    }

    #[test]
    fn register_stack_is_last_in_first_out() {
        let stack = RegisterStack { name: "s", size: 3 };
        let mut vars: HashMap<String, u32> =
            [("s_0", 0), ("s_1", 0), ("s_2", 0), ("yes", 1), ("no", 0)]
                .map(|(k, v)| (k.to_string(), v))
                .into();
        let top = |vars: &HashMap<String, u32>| vars[&stack.top()];
        for value in [7, 8, 9] {
            vars.insert("v".into(), value);
            run(&stack.push("v", None, ""), &mut vars);
            assert_eq!(top(&vars), value);
        }
        // Not taken: nothing moves.
        vars.insert("v".into(), 1);
        run(&stack.push("v", Some("no"), ""), &mut vars);
        run(&stack.pop(Some("no"), ""), &mut vars);
        run(&stack.set_top("v", Some("no"), ""), &mut vars);
        assert_eq!(top(&vars), 9);
        run(&stack.set_top("v", Some("yes"), ""), &mut vars);
        assert_eq!(top(&vars), 1);
        run(&stack.pop(Some("yes"), ""), &mut vars);
        assert_eq!(top(&vars), 8);
        run(&stack.pop(None, ""), &mut vars);
        assert_eq!(top(&vars), 7);
        vars.insert("v".into(), 5);
        run(&stack.push("v", Some("yes"), ""), &mut vars);
        assert_eq!((vars["s_0"], vars["s_1"]), (5, 7));
    }
}
