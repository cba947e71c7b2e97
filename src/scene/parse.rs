//! The scene file format: TOML, parsed by hand into a validated [`Scene`].
//! Each kind reads its own table (`kinds`): a material kind its
//! `[materials.NAME]`, a primitive kind its `[[objects]]`, a texture kind the
//! texture a material names, a point or spot light its `[[lights]]` and the
//! pixel filter `camera.filter`; this file reads the rest (the sections, the
//! environment), dispatches to them by `type`, and reads boxes and meshes.
//!
//! The reference for every table and key (meaning, default, range) is
//! docs/scene-format.md: keep it in step with the parser. Unknown keys are errors
//! everywhere (with a "did you mean" suggestion), and every error names the file,
//! the field path and the problem, e.g.
//! `scenes/x.toml: objects[3].radius: must be > 0, got -1`.

use std::collections::BTreeMap;

use glam::{DMat3, DVec3, Vec3};
use toml::{Table, Value};

use super::envmap::{EnvironmentMap, load_image};
use super::mesh::{is_serialized, load_mesh, vertex_normals};
use super::{
    AdaptiveMetric, Aov, Camera, Filter, LightSelection, Material, MaterialKind, PointLight, Quad,
    Reconstruction, RenderSettings, Roulette, Sampler, Scene, SceneError, Shapes, Sphere, Strategy,
    Triangle, excerpt,
};
use super::{Instance, Instancing, ShapeGroup};
use crate::kinds::params::{
    ParamTable, Result, U32_MAX, check_finite, check_int, check_nonneg, check_open_angle,
    check_positive, check_unit, fmt_num, fmt_vec, list, named, ok, type_name, unknown_name,
};
use crate::kinds::transform::{TRANSFORM_KEYS, Transform, matrix, rotation};
use crate::kinds::{self, DEGENERATE, Shape, light_keys, light_types, usable_length_squared};
use crate::kinds::{MATERIAL_KINDS, MATERIAL_NESTING, MAX_TEXTURES};
use std::cell::RefCell;

// Mitsuba's reader takes these from here, as the TOML reader does from the kinds.
#[cfg(test)]
pub(super) use crate::kinds::NAMED_CONDUCTORS;
pub(super) use crate::kinds::NAMED_IORS;
pub(super) use crate::kinds::transform::sin_cos_degrees;

/// Settings given over the scene file's (a command line's), validated like the
/// file's values by [`Scene::apply_overrides`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneOverrides {
    pub spp: Option<u32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub max_depth: Option<u32>,
    pub strategy: Option<Strategy>,
    pub light_weight: Option<f32>,
    pub seed: Option<u32>,
    /// `Some(None)` turns Russian roulette off.
    pub rr_depth: Option<Option<u32>>,
    pub sampler: Option<Sampler>,
    pub light_selection: Option<LightSelection>,
    pub adaptive_metric: Option<AdaptiveMetric>,
    pub reconstruction: Option<Reconstruction>,
    /// Replaces the file's AOVs.
    pub aovs: Option<Vec<Aov>>,
}

/// The `render.strategy` that asks for a pilot's choice.
pub const AUTO_STRATEGY: &str = "auto";
pub(super) const IMAGE_SIDE: (i64, i64) = (1, 65536);
const SPP: (i64, i64) = (1, U32_MAX);
const MAX_DEPTH: (i64, i64) = (0, 100_000);
const SEED: (i64, i64) = (0, U32_MAX);

pub(super) const TOP_KEYS: &[&str] = &[
    "scene",
    "camera",
    "render",
    "materials",
    "objects",
    "groups",
    "environment",
    "lights",
];
pub(super) const ENVIRONMENT_KEYS: &[&str] = &["file", "scale", "rotate_y", "rotate", "matrix"];
pub(super) const SCENE_KEYS: &[&str] = &["scale"];
pub(super) const CAMERA_KEYS: &[&str] = &[
    "lookfrom",
    "lookat",
    "vup",
    "vfov",
    "width",
    "height",
    "filter",
    "aperture_radius",
    "focus_distance",
    "projection",
    "view_width",
];
pub(super) const RENDER_KEYS: &[&str] = &[
    "spp",
    "max_depth",
    "strategy",
    "light_weight",
    "background",
    "seed",
    "rr_depth",
    "sampler",
    "light_selection",
    "adaptive",
    "adaptive_metric",
    "reconstruction",
    "aovs",
    "sides_by_shading_normal",
];
// ---------------------------------------------------------------------------------
// Entry points

pub(crate) fn parse_scene(text: &str, file: &str) -> Result<Scene> {
    let root: Table = toml::from_str(text).map_err(|e| syntax_error(file, text, &e))?;
    let inputs = RefCell::new(Vec::new());
    let top = ParamTable {
        file,
        table: &root,
        path: String::new(),
        inputs: &inputs,
    };
    top.check_keys(TOP_KEYS, None)?;

    let scale = match top.sub("scene")? {
        Some(t) => {
            t.check_keys(SCENE_KEYS, None)?;
            t.float("scale", check_positive)?.unwrap_or(1.0)
        }
        None => 1.0,
    };
    let camera = match top.sub("camera")? {
        Some(t) => parse_camera(&t)?,
        None => return Err(top.err("camera", "missing required table `[camera]`")),
    };
    let render = match top.sub("render")? {
        Some(t) => parse_render(&t)?,
        None => default_render(),
    };
    let mut materials = parse_materials(&top)?;
    let (groups, group_materials) = parse_groups(&top, &materials)?;
    materials.extend(group_materials);
    let objects = parse_objects(&top, &materials, Some(&groups))?;
    let sphere_radius_keys = objects.sphere_radius_keys;
    materials.extend(objects.extra_materials);
    let environment = match top.sub("environment")? {
        Some(t) => Some(parse_environment(&t)?),
        None => None,
    };
    let point_lights = parse_lights(&top)?;
    if environment.is_some()
        && let Some(r) = top.sub("render")?
        && r.table.contains_key("background")
    {
        return Err(top.err(
            r.at("background"),
            "cannot be combined with `[environment]`, which gives the radiance of escaping \
             rays (for a constant background, use a map of one texel)",
        ));
    }

    let scene = Scene {
        source: file.to_string(),
        camera,
        render,
        materials,
        shapes: objects.shapes,
        instancing: Instancing {
            groups,
            instances: objects.instances,
        },
        degenerate_triangles: objects.degenerate_triangles,
        point_lights,
        warnings: objects.warnings,
        environment,
        inputs: inputs.take(),
    };
    if let Some((key, problem)) = scene
        .shapes
        .spheres
        .iter()
        .zip(&sphere_radius_keys)
        .find_map(|(sphere, key)| Some((key, tiny_sphere_light(sphere, scene.extent())?)))
    {
        return Err(top.err(key, problem));
    }
    if scale == 1.0 {
        return Ok(scene);
    }
    let mut scene = scene.scaled(scale);
    // Re-check what the scale could break (overflow, underflow).
    let problem = camera_problem(&scene.camera)
        .map(|(_, p)| p)
        .or_else(|| scene.shapes.iter().find_map(|shape| shape.problem()))
        .or_else(|| drop_scaled_out_faces(&mut scene, file));
    match problem {
        Some(p) => Err(top.err(
            "scene.scale",
            format!(
                "scaling by {} makes the scene unusable: {p}",
                fmt_num(scale)
            ),
        )),
        None => Ok(scene),
    }
}

/// The smallest radius of a sphere in the light density, relative to the
/// scene's extent. A 32-bit float direction errs by a few 1e-8 radians, so a
/// sphere that subtends little more cannot be aimed at exactly: measured at 1024
/// spp, a sphere light subtending 2e-5 radians from the floor it lights (radius
/// 1e-4 at distance 5) is 0.04% dim, at 2e-6 0.6%, at 2e-7 27%. At this bound a
/// sphere subtends at least 6e-6 radians from anywhere within the scene's box
/// (at most about 0.2% dim there).
pub const MIN_LIGHT_SPHERE_RADIUS: f32 = 2e-5;

/// Why a sphere in the light density is too small for its scene, if it is.
fn tiny_sphere_light(sphere: &Sphere, extent: f32) -> Option<String> {
    let smallest = MIN_LIGHT_SPHERE_RADIUS * extent;
    (sphere.importance && sphere.radius < smallest).then(|| {
        format!(
            "a sphere light of radius {} is below {} ({MIN_LIGHT_SPHERE_RADIUS:e} of the \
             scene's extent, {}): 32-bit float directions cannot aim at so small a light \
             exactly, so its light would be underestimated; use a point light of the same \
             power ([[lights]] type = \"point\"), or a larger sphere",
            fmt_num(sphere.radius),
            fmt_num(smallest),
            fmt_num(extent)
        )
    })
}

/// An override that breaks the scene file's rules: the field it overrides
/// (`camera.width`), and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct OverrideError {
    pub field: &'static str,
    pub message: String,
}

impl Scene {
    /// Applies overrides, validated with the same rules as the file. Nothing
    /// is changed when any override is invalid.
    pub fn apply_overrides(
        &mut self,
        o: &SceneOverrides,
    ) -> std::result::Result<(), OverrideError> {
        let err = |field: &'static str, message: String| OverrideError { field, message };
        let int = |field: &'static str, v: Option<u32>, range: (i64, i64)| {
            v.map(|v| check_int(i64::from(v), range).map_err(|m| err(field, m)))
                .transpose()
        };
        let spp = int("render.spp", o.spp, SPP)?;
        let width = int("camera.width", o.width, IMAGE_SIDE)?;
        let height = int("camera.height", o.height, IMAGE_SIDE)?;
        let max_depth = int("render.max_depth", o.max_depth, MAX_DEPTH)?;
        let seed = int("render.seed", o.seed, SEED)?;
        let rr_depth = match o.rr_depth {
            Some(Some(depth)) => {
                int("render.rr_depth", Some(depth), MAX_DEPTH)?.map(Roulette::From)
            }
            Some(None) => Some(Roulette::Off),
            None => None,
        };
        if let Some(w) = o.light_weight {
            check_finite(w)
                .and_then(|()| check_unit(w))
                .map_err(|m| err("render.light_weight", m))?;
        }

        if let Some(v) = spp {
            self.render.spp = v;
        }
        if let Some(v) = width {
            self.camera.width = v;
        }
        if let Some(v) = height {
            self.camera.height = v;
        }
        if let Some(v) = max_depth {
            self.render.max_depth = v;
        }
        if let Some(v) = seed {
            self.render.seed = v;
        }
        if let Some(v) = o.strategy {
            self.render.strategy = v;
            self.render.auto_strategy = false;
        }
        if let Some(v) = o.light_weight {
            self.render.light_weight = v;
        }
        if let Some(v) = rr_depth {
            self.render.rr_depth = v;
        }
        if let Some(v) = o.sampler {
            self.render.sampler = v;
        }
        if let Some(v) = o.light_selection {
            self.render.light_selection = v;
        }
        if let Some(v) = o.adaptive_metric {
            self.render.adaptive_metric = Some(v);
        }
        if let Some(v) = o.reconstruction {
            self.render.reconstruction = Some(v);
        }
        if let Some(aovs) = &o.aovs {
            kinds::check_names(aovs).map_err(|m| err("render.aovs", m))?;
            self.render.aovs = aovs.clone();
        }
        Ok(())
    }

    /// The same scene with every position and length (camera `lookfrom`/`lookat`
    /// and its lens's radius and focus distance, its orthographic view's width,
    /// every shape's geometry (`Shape::scale`), light positions) multiplied by
    /// `factor`, and point and spot lights' intensities by `factor^2`, so that
    /// the irradiance they give, and the image, stay the same (a directional
    /// light's irradiance stays as it is).
    pub fn scaled(&self, factor: f32) -> Scene {
        let mut s = self.clone();
        s.camera.lookfrom *= factor;
        s.camera.lookat *= factor;
        s.camera.aperture_radius *= factor;
        s.camera.focus_distance = s.camera.focus_distance.map(|d| d * factor);
        s.camera.view_width = s.camera.view_width.map(|w| w * factor);
        for shape in s.shapes.iter_mut() {
            shape.scale(factor);
        }
        // An instance's world point `A p + b` becomes `A (factor p) + factor b`.
        for group in &mut s.instancing.groups {
            for shape in group.shapes.iter_mut() {
                shape.scale(factor);
            }
        }
        for instance in &mut s.instancing.instances {
            for row in &mut instance.to_world {
                row[3] *= factor;
            }
        }
        for l in s
            .point_lights
            .iter_mut()
            .filter(|l| l.directional.is_none())
        {
            l.position *= factor;
            l.intensity *= factor * factor;
        }
        s
    }
}

// ---------------------------------------------------------------------------------
// Sections

fn parse_camera(t: &ParamTable) -> Result<Camera> {
    t.check_keys(CAMERA_KEYS, None)?;
    let camera = Camera {
        lookfrom: t.require("lookfrom", t.vec3("lookfrom", ok)?)?,
        lookat: t.require("lookat", t.vec3("lookat", ok)?)?,
        vup: t.vec3("vup", ok)?.unwrap_or(Vec3::Y),
        vfov_degrees: t.float("vfov", check_open_angle)?.unwrap_or(40.0),
        width: t.int("width", IMAGE_SIDE)?.unwrap_or(600),
        height: t.int("height", IMAGE_SIDE)?.unwrap_or(600),
        filter: Filter::parse(t)?,
        aperture_radius: t.float("aperture_radius", check_nonneg)?.unwrap_or(0.0),
        focus_distance: t.float("focus_distance", check_positive)?,
        view_width: parse_projection(t)?,
    };
    if let Some((key, problem)) = camera_problem(&camera) {
        return Err(t.err(t.at(key), problem));
    }
    Ok(camera)
}

/// The projection's names, in the order messages list them.
const PROJECTIONS: &[&str] = &["perspective", "orthographic"];

/// `camera.projection`: the orthographic view's width (`view_width`,
/// required there), or `None` for the perspective projection. The keys of
/// the other projection are errors, not silently ignored.
fn parse_projection(t: &ParamTable) -> Result<Option<f32>> {
    match t.string("projection")? {
        None | Some("perspective") => {
            if t.table.contains_key("view_width") {
                return Err(t.err(
                    t.at("view_width"),
                    "applies only to `projection = \"orthographic\"`",
                ));
            }
            Ok(None)
        }
        Some("orthographic") => {
            for key in ["vfov", "aperture_radius", "focus_distance"] {
                if t.table.contains_key(key) {
                    return Err(t.err(
                        t.at(key),
                        "does not apply to `projection = \"orthographic\"`, whose view is \
                         `view_width` wide",
                    ));
                }
            }
            let width = t.float("view_width", check_positive)?;
            Ok(Some(t.require("view_width", width)?))
        }
        Some(other) => Err(t.err(
            t.at("projection"),
            kinds::params::unknown_name("projection", other, PROJECTIONS),
        )),
    }
}

fn default_render() -> RenderSettings {
    RenderSettings {
        spp: 100,
        max_depth: 50,
        strategy: Strategy::Mixture,
        auto_strategy: false,
        light_weight: 0.5,
        background: Vec3::ZERO,
        seed: 0,
        rr_depth: Roulette::StrategyDefault,
        sampler: Sampler::Sobol,
        light_selection: LightSelection::Spatial,
        adaptive: false,
        adaptive_metric: None,
        reconstruction: None,
        aovs: Vec::new(),
        sides_by_shading_normal: false,
    }
}

fn parse_render(t: &ParamTable) -> Result<RenderSettings> {
    t.check_keys(RENDER_KEYS, None)?;
    let d = default_render();
    let (strategy, auto_strategy) = parse_strategy(t)?;
    Ok(RenderSettings {
        spp: t.int("spp", SPP)?.unwrap_or(d.spp),
        max_depth: t.int("max_depth", MAX_DEPTH)?.unwrap_or(d.max_depth),
        strategy: strategy.unwrap_or(d.strategy),
        auto_strategy,
        light_weight: t
            .float("light_weight", check_unit)?
            .unwrap_or(d.light_weight),
        background: t.vec3("background", check_nonneg)?.unwrap_or(d.background),
        seed: t.int("seed", SEED)?.unwrap_or(d.seed),
        rr_depth: match t.table.get("rr_depth") {
            Some(Value::String(off)) if off == "off" => Roulette::Off,
            Some(Value::String(other)) => {
                return Err(t.err(
                    t.at("rr_depth"),
                    format!(
                        "must be an integer between {} and {} or \"off\", got {other:?}",
                        MAX_DEPTH.0, MAX_DEPTH.1
                    ),
                ));
            }
            _ => t
                .int("rr_depth", MAX_DEPTH)?
                .map_or(d.rr_depth, Roulette::From),
        },
        sampler: named(
            t,
            "sampler",
            &Sampler::ALL,
            Sampler::name,
            Sampler::from_name,
        )?
        .unwrap_or(d.sampler),
        light_selection: named(
            t,
            "light_selection",
            &LightSelection::ALL,
            LightSelection::name,
            LightSelection::from_name,
        )?
        .unwrap_or(d.light_selection),
        adaptive: t.boolean("adaptive")?.unwrap_or(d.adaptive),
        adaptive_metric: named(
            t,
            "adaptive_metric",
            &AdaptiveMetric::ALL,
            AdaptiveMetric::name,
            AdaptiveMetric::from_name,
        )?
        .or(d.adaptive_metric),
        reconstruction: named(
            t,
            "reconstruction",
            &Reconstruction::ALL,
            Reconstruction::name,
            Reconstruction::from_name,
        )?
        .or(d.reconstruction),
        aovs: parse_render_aovs(t)?,
        sides_by_shading_normal: t
            .boolean("sides_by_shading_normal")?
            .unwrap_or(d.sides_by_shading_normal),
    })
}

/// `render.aovs`: a list of Mitsuba's `NAME:TYPE` (or `TYPE`) strings.
fn parse_render_aovs(t: &ParamTable) -> Result<Vec<Aov>> {
    let Some(value) = t.table.get("aovs") else {
        return Ok(Vec::new());
    };
    let at = t.at("aovs");
    let Value::Array(items) = value else {
        return Err(t.err(
            at,
            format!(
                "expected a list of \"NAME:TYPE\" strings, got {}",
                type_name(value)
            ),
        ));
    };
    let mut aovs = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let Value::String(item) = item else {
            return Err(t.err(
                format!("{at}[{i}]"),
                format!("expected a \"NAME:TYPE\" string, got {}", type_name(item)),
            ));
        };
        aovs.push(kinds::parse_aov(item).map_err(|m| t.err(format!("{at}[{i}]"), m))?);
    }
    kinds::check_names(&aovs).map_err(|m| t.err(at, m))?;
    Ok(aovs)
}

/// `render.strategy`: a strategy's name, or `auto` (true: the pilot chooses).
fn parse_strategy(t: &ParamTable) -> Result<(Option<Strategy>, bool)> {
    match t.string("strategy")? {
        None => Ok((None, false)),
        Some(AUTO_STRATEGY) => Ok((None, true)),
        Some(given) => match Strategy::from_name(given) {
            Some(strategy) => Ok((Some(strategy), false)),
            None => {
                let mut names: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
                names.push(AUTO_STRATEGY);
                Err(t.err(t.at("strategy"), unknown_name("strategy", given, &names)))
            }
        },
    }
}

/// `[environment]`: the map's file (relative to the scene file), `scale`, and its
/// rotation as objects take one (`rotate_y`, `rotate`, or an orthogonal `matrix`,
/// whose translation moves nothing at infinity).
fn parse_environment(t: &ParamTable) -> Result<EnvironmentMap> {
    t.check_keys(ENVIRONMENT_KEYS, None)?;
    let file = t.require("file", t.string("file")?)?;
    let scale = t.float("scale", check_nonneg)?.unwrap_or(1.0);
    let to_world = if t.table.contains_key("matrix") {
        let (linear, _) = matrix(t, &["rotate_y", "rotate"])?;
        let error = (linear.transpose() * linear - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |e, x| e.max(x.abs()));
        if error > 1e-5 {
            return Err(t.err(
                t.at("matrix"),
                "must be a rotation (orthonormal columns, maybe mirrored): an environment \
                 map is only turned",
            ));
        }
        linear
    } else {
        rotation(t)?
    };
    let path = t.input(file);
    let (width, height, texels) = load_image(&path).map_err(|m| t.err(t.at("file"), m))?;
    Ok(EnvironmentMap {
        file: file.to_string(),
        width,
        height,
        texels: std::sync::Arc::new(texels),
        scale,
        to_world: to_world.as_mat3(),
    })
}

/// `[materials.NAME]`, sorted by name; each kind reads its own table
/// (`kinds::Material::parse`).
fn parse_materials(top: &ParamTable) -> Result<Vec<Material>> {
    let Some(mats) = top.sub("materials")? else {
        return Ok(Vec::new());
    };
    let mut names: Vec<&String> = mats.table.keys().collect();
    names.sort();
    let mut out = Vec::with_capacity(names.len());
    let mut textures = 0;
    for name in names {
        let t = mats.sub(name)?.expect("key exists");
        let material = Material::parse(name, &t)?;
        textures += material.texture.is_some() as usize
            + material.bump.is_some() as usize
            + material.opacity_texture.is_some() as usize
            + material.number_textures.len();
        if textures > MAX_TEXTURES {
            return Err(t.err(
                t.here(),
                format!(
                    "more than {MAX_TEXTURES} textures (bump, normal and opacity maps and \
                     textured numbers included) in one scene"
                ),
            ));
        }
        out.push(material);
    }
    check_nested_materials(&mats, &out)?;
    Ok(out)
}

/// The materials `twosided` materials are made of (`Material::nested`):
/// each names a material of the scene that neither emits nor is masked (the
/// surface's emission and opacity are the outer material's), with no cycle and
/// at most `MATERIAL_NESTING` deep.
fn check_nested_materials(mats: &ParamTable, materials: &[Material]) -> Result<()> {
    let index = |name: &str| materials.iter().position(|m| m.name == name);
    // Every name first: the depth walk below follows them all.
    for material in materials {
        let t = mats.sub(&material.name)?.expect("key exists");
        let model = &MATERIAL_KINDS[material.kind.id()];
        for (&key, name) in model.nested.iter().zip(&material.nested) {
            let Some(i) = index(name) else {
                let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
                return Err(t.err(t.at(key), unknown_name("material", name, &names)));
            };
            let inner = &materials[i];
            if inner.emits() || inner.is_masked() {
                return Err(t.err(
                    t.at(key),
                    format!(
                        "material `{}` {} inside a {} material: its emission and opacity would \
                         be the {} material's (give them to `{}`)",
                        excerpt(name),
                        if inner.emits() { "emits" } else { "is masked" },
                        model.name,
                        model.name,
                        excerpt(&material.name),
                    ),
                ));
            }
        }
    }
    for material in materials {
        let t = mats.sub(&material.name)?.expect("key exists");
        // How deep the materials below this one go: a chain of nested
        // materials longer than the kernel resolves, or a cycle.
        let mut chain = vec![material.name.as_str()];
        let mut frontier: Vec<Vec<&str>> = vec![chain.clone()];
        while let Some(path) = frontier.pop() {
            let last = &materials[index(path[path.len() - 1]).expect("checked")];
            for name in &last.nested {
                if path.contains(&name.as_str()) {
                    let cycle: Vec<String> = path
                        .iter()
                        .chain([&name.as_str()])
                        .map(|n| format!("`{}`", excerpt(n)))
                        .collect();
                    return Err(t.err(
                        t.here(),
                        format!("its materials make a cycle: {}", cycle.join(" -> ")),
                    ));
                }
                let mut longer = path.clone();
                longer.push(name);
                if longer.len() > chain.len() {
                    chain = longer.clone();
                }
                // Far enough to know it is too deep: a DAG's paths stay few.
                if longer.len() <= MATERIAL_NESTING as usize + 2 {
                    frontier.push(longer);
                }
            }
        }
        // The chain's last material scatters; each before it is a step.
        if chain.len() - 1 > MATERIAL_NESTING as usize {
            let chain: Vec<String> = chain.iter().map(|n| format!("`{}`", excerpt(n))).collect();
            return Err(t.err(
                t.here(),
                format!(
                    "its materials nest {} deep ({}), deeper than the {MATERIAL_NESTING} \
                     the kernel resolves",
                    chain.len() - 1,
                    chain.join(" -> ")
                ),
            ));
        }
    }
    Ok(())
}

/// The tables of the top-level array `key` (`[[key]]`, none when absent), each
/// with its `type`, read one at a time as the caller walks them (so errors come
/// in file order); a table without a `type` is refused, its keys checked against
/// `all_keys` first, naming the `types` it may take.
fn typed_tables<'a, 'b>(
    top: &'b ParamTable<'a>,
    key: &'b str,
    all_keys: &'b [&'b str],
    types: &'b [&'b str],
) -> Result<impl ExactSizeIterator<Item = Result<(ParamTable<'a>, &'a str)>> + 'b> {
    let items: &'a [Value] = match top.table.get(key) {
        None => &[],
        Some(Value::Array(items)) => items,
        Some(value) => {
            return Err(top.err(
                top.at(key),
                format!(
                    "expected an array of tables (`[[{key}]]`), got {}",
                    type_name(value)
                ),
            ));
        }
    };
    Ok(items.iter().enumerate().map(move |(i, item)| {
        let path = format!("{}[{i}]", top.at(key));
        let Value::Table(table) = item else {
            return Err(top.err(path, format!("expected a table, got {}", type_name(item))));
        };
        let t = ParamTable {
            file: top.file,
            table,
            path,
            inputs: top.inputs,
        };
        let Some(ty) = t.string("type")? else {
            t.check_keys(all_keys, None)?;
            return Err(t.err(
                t.here(),
                format!(
                    "missing required key `type` (expected one of {})",
                    list(types)
                ),
            ));
        };
        Ok((t, ty))
    }))
}

/// The `[[lights]]`: point and spot lights, each read by its type
/// (`kinds::PointLight`).
fn parse_lights(top: &ParamTable) -> Result<Vec<PointLight>> {
    let (keys, types) = (light_keys(), light_types());
    let tables = typed_tables(top, "lights", &keys, &types)?;
    let mut lights = Vec::with_capacity(tables.len());
    for table in tables {
        let (t, ty) = table?;
        lights.push(PointLight::parse(&t, ty)?);
    }
    Ok(lights)
}

/// The objects of a scene file, in world space.
#[derive(Default)]
struct Objects {
    shapes: Shapes,
    /// Where each sphere was given (`objects[3].radius`), for messages about it.
    sphere_radius_keys: Vec<String>,
    degenerate_triangles: usize,
    /// Materials taken from mesh files, after the scene's own.
    extra_materials: Vec<Material>,
    warnings: Vec<String>,
    instances: Vec<Instance>,
}

/// The object types the scene reads itself, and their keys besides the common
/// ones: a box (six quads) and a mesh (its file's faces).
const SCENE_OBJECTS: &[(&str, &[&str])] = &[
    ("box", &["min", "max"]),
    ("mesh", &["file", "smooth", "shape_index"]),
    ("instance", &["group"]),
];

/// The keys of a `[[groups]]` table.
pub(super) const GROUP_KEYS: &[&str] = &["name", "objects"];

/// The `[[groups]]`: each a name and its `objects`, read as the scene's are,
/// in the group's own space; and the materials their mesh files gave.
fn parse_groups(
    top: &ParamTable,
    materials: &[Material],
) -> Result<(Vec<ShapeGroup>, Vec<Material>)> {
    let items: &[Value] = match top.table.get("groups") {
        None => &[],
        Some(Value::Array(items)) => items,
        Some(value) => {
            return Err(top.err(
                "groups",
                format!(
                    "expected an array of tables (`[[groups]]`), got {}",
                    type_name(value)
                ),
            ));
        }
    };
    let mut groups: Vec<ShapeGroup> = Vec::new();
    let mut extra_materials = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let path = format!("groups[{i}]");
        let Value::Table(table) = item else {
            return Err(top.err(path, format!("expected a table, got {}", type_name(item))));
        };
        let t = ParamTable {
            file: top.file,
            table,
            path,
            inputs: top.inputs,
        };
        t.check_keys(GROUP_KEYS, Some("a group"))?;
        let name = t.require("name", t.string("name")?)?;
        if groups.iter().any(|g| g.name == name) {
            return Err(t.err(
                t.at("name"),
                format!("a second group named `{}`", excerpt(name)),
            ));
        }
        let known: Vec<Material> = materials.iter().chain(&extra_materials).cloned().collect();
        let objects = parse_objects(&t, &known, None)?;
        extra_materials.extend(objects.extra_materials);
        groups.push(ShapeGroup {
            name: name.to_string(),
            shapes: objects.shapes,
        });
    }
    Ok((groups, extra_materials))
}

/// Every object type and its own keys: the primitive kinds'
/// (`kinds::ObjectType`), then the scene's.
fn object_types() -> Vec<(&'static str, &'static [&'static str])> {
    kinds::object_types()
        .map(|(name, object)| (name, object.keys))
        .chain(SCENE_OBJECTS.iter().copied())
        .collect()
}

/// Every key of some object type, the common ones first: what an object
/// without a `type` may hold.
pub(super) fn object_keys() -> Vec<&'static str> {
    let mut keys = vec!["type", "material"];
    keys.extend(TRANSFORM_KEYS);
    keys.push("importance");
    for (_, own) in object_types() {
        for key in own {
            if !keys.contains(key) {
                keys.push(key);
            }
        }
    }
    keys
}

/// The scene files' object types, in the order messages list them.
pub(super) fn object_type_names() -> Vec<&'static str> {
    object_types().into_iter().map(|(name, _)| name).collect()
}

/// The `objects` of `top`: the scene's, with `groups` to instance, or a
/// group's (`groups` is `None`), where instances and emitters are refused as
/// Mitsuba refuses them.
fn parse_objects(
    top: &ParamTable,
    materials: &[Material],
    groups: Option<&[ShapeGroup]>,
) -> Result<Objects> {
    let mut objects = Objects::default();
    let Objects {
        shapes,
        sphere_radius_keys,
        degenerate_triangles,
        extra_materials,
        warnings,
        instances,
    } = &mut objects;
    let (all_keys, names) = (object_keys(), object_type_names());
    for (i, table) in typed_tables(top, "objects", &all_keys, &names)?.enumerate() {
        let (t, ty) = table?;
        let kind = kinds::object_types()
            .find(|&(name, _)| name == ty)
            .map(|(_, object)| object);
        let keys = match (kind, SCENE_OBJECTS.iter().find(|&&(name, _)| name == ty)) {
            (Some(object), _) => object.keys,
            (None, Some(&(_, keys))) => keys,
            (None, None) => {
                return Err(t.err(t.at("type"), unknown_name("object type", ty, &names)));
            }
        };
        let known: Vec<&str> = TRANSFORM_KEYS
            .iter()
            .copied()
            .chain(["type", "material", "importance"])
            .chain(keys.iter().copied())
            .collect();
        if ty == "instance" {
            let Some(groups) = groups else {
                return Err(t.err(
                    t.at("type"),
                    "an instance inside a group: nested instancing is not permitted \
                     (Mitsuba refuses it too)",
                ));
            };
            let known: Vec<&str> = TRANSFORM_KEYS
                .iter()
                .copied()
                .chain(["type", "group"])
                .collect();
            t.check_keys(&known, Some("an instance"))?;
            let name = t.require("group", t.string("group")?)?;
            let Some(group) = groups.iter().position(|g| g.name == name) else {
                let names: Vec<&str> = groups.iter().map(|g| g.name.as_str()).collect();
                let message = match names.is_empty() {
                    true => format!(
                        "unknown group `{}` (no `[[groups]]` are defined)",
                        excerpt(name)
                    ),
                    false => unknown_name("group", name, &names),
                };
                return Err(t.err(t.at("group"), message));
            };
            instances.push(Instance {
                group: group as u32,
                to_world: Transform::parse(&t)?.rows(),
            });
            continue;
        }
        t.check_keys(&known, Some(&format!("a {ty}")))?;

        // A mesh may take its materials from its file (glTF) instead.
        let name = match t.string("material")? {
            None if ty == "mesh" => None,
            name => Some(t.require("material", name)?),
        };
        let chosen = match name {
            None => None,
            Some(name) => match materials.iter().position(|m| m.name == name) {
                Some(material) => Some(material),
                None => {
                    let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
                    let message = if names.is_empty() {
                        format!(
                            "unknown material `{}` (no `[materials.NAME]` tables are defined)",
                            excerpt(name)
                        )
                    } else {
                        unknown_name("material", name, &names)
                    };
                    return Err(t.err(t.at("material"), message));
                }
            },
        };
        let marked = t.boolean("importance")?.unwrap_or(false);
        let importance = marked || chosen.is_some_and(|m| materials[m].emits());
        let in_group = groups.is_none();
        if in_group && importance {
            return Err(t.err(
                t.here(),
                "an emitting or `importance` shape inside a group: instancing of emitters \
                 is not supported (Mitsuba refuses it too)",
            ));
        }
        let xf = Transform::parse(&t)?;
        // Only a mesh has no `material`; it resolves its faces' below.
        let material = chosen.unwrap_or_default() as u32;
        if let Some(object) = kind {
            (object.parse)(&t, &xf, material, importance, shapes)?;
            sphere_radius_keys.resize(shapes.spheres.len(), t.at("radius"));
            continue;
        }

        match ty {
            "mesh" => {
                let name = t.require("file", t.string("file")?)?;
                let path = t.input(name);
                let smooth = t.boolean("smooth")?.unwrap_or(true);
                let shape_index = t.int("shape_index", (0, u32::MAX.into()))?;
                if shape_index.is_some() && !is_serialized(&path) {
                    return Err(t.err(
                        t.at("shape_index"),
                        "only a `.serialized` file holds several meshes to pick from",
                    ));
                }
                let mesh = load_mesh(&path, shape_index.unwrap_or(0))
                    .map_err(|e| t.err(t.at("file"), e.to_string()))?;
                let world: Vec<Vec3> = mesh
                    .positions
                    .iter()
                    .map(|p| xf.point(p.as_dvec3()))
                    .collect();
                // A mirroring transform reverses the winding; keep the face's side.
                let faces: Vec<[u32; 3]> = mesh
                    .triangles
                    .iter()
                    .map(|&[a, b, c]| if xf.mirrors() { [a, c, b] } else { [a, b, c] })
                    .collect();
                let normals = smooth.then(|| match &mesh.normals {
                    Some(normals) => normals.iter().map(|&n| xf.normal(n)).collect(),
                    None => vertex_normals(&world, &faces),
                });
                // A smooth face is on the side of its file's vertex normals, as
                // Mitsuba (its shading frame) and pbrt-v4 (`FaceForward`) decide it,
                // whatever its winding says.
                let faces: Vec<[u32; 3]> = match (&normals, &mesh.normals) {
                    (Some(normals), Some(_)) => faces
                        .into_iter()
                        .map(|[a, b, c]| {
                            let [pa, pb, pc] = [a, b, c].map(|i| world[i as usize]);
                            let shading: Vec3 = [a, b, c].map(|i| normals[i as usize]).iter().sum();
                            match (pb - pa).cross(pc - pa).dot(shading) < 0.0 {
                                true => [a, c, b],
                                false => [a, b, c],
                            }
                        })
                        .collect(),
                    _ => faces,
                };
                // Each face's material and whether it is in the light density.
                let face_materials: Vec<(u32, bool)> = match chosen {
                    Some(_) => vec![(material, importance); faces.len()],
                    None => {
                        let base = (materials.len() + extra_materials.len()) as u32;
                        let mapped = file_materials(&t, &mesh, base)?;
                        warnings.push(format!(
                            "{}: {}: materials from {} mapped to the nearest pathmix has: \
                             lambertian with the base colour, emitting the emission \
                             (textures, metalness, roughness and transmission are not read); \
                             `material` overrides them",
                            t.file,
                            t.at("file"),
                            path.display()
                        ));
                        let faces = mesh.triangle_materials.iter().map(|&m| {
                            let m = m.expect("file_materials checked every face has one");
                            (base + m as u32, marked || mapped[m].emits())
                        });
                        let faces: Vec<(u32, bool)> = faces.collect();
                        if in_group && faces.iter().any(|&(_, emits)| emits) {
                            return Err(t.err(
                                t.at("file"),
                                "emitting materials inside a group: instancing of emitters \
                                 is not supported (Mitsuba refuses it too)",
                            ));
                        }
                        extra_materials.extend(mapped);
                        faces
                    }
                };
                let faces_in_file = faces.len();
                let mut dropped = 0;
                for (face, (material, importance)) in faces.into_iter().zip(face_materials) {
                    let triangle = Triangle {
                        vertices: face.map(|i| world[i as usize]),
                        normals: normals.as_ref().map(|n| face.map(|i| n[i as usize])),
                        uvs: mesh.uvs.as_ref().map(|uvs| face.map(|i| uvs[i as usize])),
                        material,
                        importance,
                        mesh: i as u32,
                    };
                    if triangle.is_degenerate() {
                        dropped += 1;
                        continue;
                    }
                    shapes.triangles.push(triangle);
                }
                // As a quad that 32-bit floats cannot hold is refused, so is a
                // mesh none of whose faces they can.
                if let Some(message) = dropped_faces_problem(dropped, faces_in_file) {
                    return Err(t.err(t.here(), message));
                }
                if dropped > 0 {
                    warnings.push(dropped_faces_warning(
                        t.file,
                        &t.here(),
                        dropped,
                        faces_in_file,
                    ));
                }
                *degenerate_triangles += dropped;
            }
            _ => {
                let min = t.require("min", t.vec3("min", ok)?)?;
                let max = t.require("max", t.vec3("max", ok)?)?;
                for (axis, (lo, hi)) in ["x", "y", "z"]
                    .into_iter()
                    .zip(min.to_array().into_iter().zip(max.to_array()))
                {
                    if hi <= lo {
                        return Err(t.err(
                            t.at("max"),
                            format!(
                                "must be greater than min in every axis, got max.{axis} = {} <= min.{axis} = {}",
                                fmt_num(hi),
                                fmt_num(lo)
                            ),
                        ));
                    }
                }
                for (face, q, u, v) in box_faces(min.as_dvec3(), max.as_dvec3()) {
                    let quad = Quad {
                        q: xf.point(q),
                        u: xf.vector(u),
                        v: xf.vector(v),
                        material,
                        importance,
                    };
                    if let Some(p) = quad.problem() {
                        return Err(t.err(t.here(), format!("{face} face of the box: {p}")));
                    }
                    shapes.quads.push(quad);
                }
            }
        }
    }
    Ok(objects)
}

/// The scene materials nearest to a mesh file's own (glTF), named after the
/// object and the file's names, numbered from `base` in the scene; an error
/// where a face has none (it needs the object's `material`) or a colour is
/// out of range.
fn file_materials(t: &ParamTable, mesh: &super::mesh::Mesh, base: u32) -> Result<Vec<Material>> {
    let missing = || {
        t.err(
            t.here(),
            "missing required key `material` (the mesh file gives not every face a material)",
        )
    };
    if mesh.triangle_materials.is_empty() || mesh.triangle_materials.iter().any(Option::is_none) {
        return Err(missing());
    }
    mesh.materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let in_range = |c: Vec3, max: f32| c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= max;
            if !in_range(m.base_color, 1.0) || !in_range(m.emission, f32::MAX) {
                return Err(t.err(
                    t.at("file"),
                    format!(
                        "material `{}` of the mesh file: base colour {} must be in [0, 1] and emission {} finite and >= 0",
                        m.name, m.base_color, m.emission
                    ),
                ));
            }
            Ok(Material {
                name: format!("{}.file:{} (scene material {})", t.path, m.name, base as usize + i),
                kind: MaterialKind::Lambertian,
                albedo: m.base_color,
                emit: m.emission,
                one_sided: false,
                opacity: 1.0,
                opacity_texture: None,
                number_textures: Vec::new(),
                texture: None,
                bump: None,
                nested: Vec::new(),
            })
        })
        .collect()
}

/// Why a mesh object is refused when `dropped` of its `faces` have no usable
/// area: all of them (nothing of it would render).
fn dropped_faces_problem(dropped: usize, faces: usize) -> Option<String> {
    (dropped == faces).then(|| {
        format!(
            "none of the mesh's {faces} faces has an area 32-bit floats can hold (each is \
             degenerate, or the transform or scale makes its size overflow or vanish): \
             nothing of it would render"
        )
    })
}

/// The warning for a mesh object some of whose faces were dropped.
fn dropped_faces_warning(file: &str, object: &str, dropped: usize, faces: usize) -> String {
    format!(
        "{file}: {object}: {dropped} of the mesh's {faces} faces dropped: they have no area \
         32-bit floats can hold (degenerate, or too large or small at this scale)"
    )
}

/// The six outward-facing sides of an axis-aligned box, as the book's `box()`.
fn box_faces(a: DVec3, b: DVec3) -> [(&'static str, DVec3, DVec3, DVec3); 6] {
    let dx = DVec3::new(b.x - a.x, 0.0, 0.0);
    let dy = DVec3::new(0.0, b.y - a.y, 0.0);
    let dz = DVec3::new(0.0, 0.0, b.z - a.z);
    [
        ("front", DVec3::new(a.x, a.y, b.z), dx, dy),
        ("right", DVec3::new(b.x, a.y, b.z), -dz, dy),
        ("back", DVec3::new(b.x, a.y, a.z), -dx, dy),
        ("left", DVec3::new(a.x, a.y, a.z), dz, dy),
        ("top", DVec3::new(a.x, b.y, b.z), dx, -dz),
        ("bottom", DVec3::new(a.x, a.y, a.z), dx, dz),
    ]
}

/// Drops the mesh faces a `[scene] scale` left with no usable area, with a
/// warning per object that lost some; the problem if one lost them all.
fn drop_scaled_out_faces(scene: &mut Scene, file: &str) -> Option<String> {
    // Per object (`Triangle::mesh`): faces before, and dropped.
    let mut counts: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
    scene.shapes.triangles.retain(|t| {
        let count = counts.entry(t.mesh).or_default();
        count.0 += 1;
        let degenerate = t.is_degenerate();
        count.1 += usize::from(degenerate);
        !degenerate
    });
    for (&object, &(faces, dropped)) in &counts {
        let object = format!("objects[{object}]");
        if let Some(problem) = dropped_faces_problem(dropped, faces) {
            return Some(format!("{object}: {problem}"));
        }
        if dropped > 0 {
            scene.degenerate_triangles += dropped;
            (scene.warnings).push(dropped_faces_warning(file, &object, dropped, faces));
        }
    }
    None
}

// ---------------------------------------------------------------------------------
// The camera's geometry (checked where read and after a `[scene] scale`)

/// The offending camera key and the problem.
fn camera_problem(c: &Camera) -> Option<(&'static str, String)> {
    if !c.lookfrom.is_finite() {
        return Some((
            "lookfrom",
            "coordinates overflow a 32-bit float".to_string(),
        ));
    }
    if !c.lookat.is_finite() {
        return Some(("lookat", "coordinates overflow a 32-bit float".to_string()));
    }
    let dir = c.lookat - c.lookfrom;
    if dir == Vec3::ZERO {
        return Some((
            "lookat",
            format!("must differ from lookfrom, both are {}", fmt_vec(c.lookat)),
        ));
    }
    if !usable_length_squared(dir.length_squared()) {
        return Some((
            "lookat",
            format!(
                "distance from lookfrom ({}) is out of the range 32-bit float arithmetic can handle",
                fmt_num(dir.as_dvec3().length())
            ),
        ));
    }
    if !usable_length_squared(c.vup.length_squared()) {
        return Some((
            "vup",
            format!(
                "must be a non-zero direction of moderate length, got {}",
                fmt_vec(c.vup)
            ),
        ));
    }
    if !c.aperture_radius.is_finite() {
        return Some(("aperture_radius", "overflows a 32-bit float".to_string()));
    }
    if let Some(width) = c.view_width
        && !(width > 0.0 && width.is_finite())
    {
        return Some((
            "view_width",
            format!(
                "must be a positive width a 32-bit float holds, got {}",
                fmt_num(width)
            ),
        ));
    }
    if let Some(d) = c.focus_distance
        && !(d > 0.0 && d.is_finite())
    {
        return Some((
            "focus_distance",
            format!(
                "must be a positive distance a 32-bit float holds, got {}",
                fmt_num(d)
            ),
        ));
    }
    let (w, up) = (dir.as_dvec3().normalize(), c.vup.as_dvec3().normalize());
    if w.cross(up).length() <= DEGENERATE {
        return Some((
            "vup",
            format!(
                "must not be parallel to lookat - lookfrom = {}, got {}",
                fmt_vec(dir),
                fmt_vec(c.vup)
            ),
        ));
    }
    None
}

// ---------------------------------------------------------------------------------
// Messages

fn syntax_error(file: &str, text: &str, e: &toml::de::Error) -> SceneError {
    let location = match e.span() {
        Some(span) => {
            let (line, column) = line_col(text, span.start);
            format!("line {line}, column {column}")
        }
        None => String::new(),
    };
    let message: Vec<&str> = e
        .message()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    SceneError {
        file: file.to_string(),
        location,
        message: format!("invalid TOML: {}", message.join("; ")),
    }
}

/// 1-based line and column (in characters) of a byte offset.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{AovKind, CameraModel, Spot};

    const CORNELL: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell.toml"));
    const BOXES: &str = include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-boxes.toml"
    ));
    const FURNACE: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/furnace.toml"));
    const FILE: &str = "scenes/x.toml";

    /// A small valid scene that the error tests break one field at a time.
    const BASE: &str = r#"
[camera]
lookfrom = [0, 0, -5]
lookat = [0, 0, 0]

[render]
light_weight = 0.5

[materials.red]
type = "lambertian"
albedo = [0.5, 0.1, 0.1]

[materials.white]
type = "lambertian"
albedo = [0.7, 0.7, 0.7]

[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "red"

[[objects]]
type = "quad"
q = [-1, -1, 1]
u = [2, 0, 0]
v = [0, 2, 0]
material = "white"
"#;

    fn parse(text: &str) -> Scene {
        parse_scene(text, FILE).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Unset, roulette follows the strategy (5 for nee-mis and bsdf, off for the
    /// mixture and light), also when the command line changes the strategy;
    /// `"off"` and a depth are kept whatever the strategy.
    #[test]
    fn roulette_defaults_to_the_strategys_own() {
        let with = |render: &str| parse(&BASE.replace("light_weight = 0.5", render));
        let depth = |render: &str| with(render).render.roulette_depth();
        assert_eq!(depth(""), None);
        assert_eq!(depth("strategy = \"nee-mis\""), Some(5));
        assert_eq!(depth("strategy = \"bsdf\""), Some(5));
        assert_eq!(depth("strategy = \"light\""), None);
        assert_eq!(depth("strategy = \"nee-mis\"\nrr_depth = \"off\""), None);
        assert_eq!(depth("rr_depth = 3"), Some(3));
        let mut s = with("");
        let nee = SceneOverrides {
            strategy: Some(Strategy::NeeMis),
            ..SceneOverrides::default()
        };
        s.apply_overrides(&nee).unwrap();
        assert_eq!(s.render.roulette_depth(), Some(5));
        let off = SceneOverrides {
            rr_depth: Some(None),
            ..SceneOverrides::default()
        };
        s.apply_overrides(&off).unwrap();
        assert_eq!(s.render.roulette_depth(), None);
        let e = error("light_weight = 0.5", "rr_depth = \"never\"").to_string();
        assert!(e.contains("rr_depth") && e.contains("\"off\""), "{e}");
    }

    /// The error for `BASE` with `from` replaced by `to`.
    fn error(from: &str, to: &str) -> SceneError {
        assert!(BASE.contains(from), "{from:?} not in BASE");
        let text = BASE.replacen(from, to, 1);
        match parse_scene(&text, FILE) {
            Ok(_) => panic!("expected an error for {to:?}"),
            Err(e) => e,
        }
    }

    fn assert_error(e: &SceneError, location: &str, parts: &[&str]) {
        let shown = e.to_string();
        assert_eq!(e.file, FILE, "{shown}");
        assert_eq!(e.location, location, "{shown}");
        assert!(
            shown.starts_with(&format!("{FILE}: {location}: ")),
            "{shown}"
        );
        for part in parts {
            assert!(e.message.contains(part), "{shown:?} lacks {part:?}");
        }
    }

    fn normal(q: &Quad) -> Vec3 {
        q.u.cross(q.v).normalize()
    }

    /// A pinhole unless `aperture_radius` is above 0; the plane in focus is at
    /// `lookat` unless `focus_distance` says; `[scene] scale` scales both.
    #[test]
    fn thin_lens_keys_and_defaults() {
        let s = parse(BASE);
        assert_eq!(
            (s.camera.aperture_radius, s.camera.focus_distance),
            (0.0, None)
        );
        assert_eq!(s.camera.model(), CameraModel::Pinhole);
        let s = parse(&BASE.replace(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\naperture_radius = 0.5",
        ));
        assert_eq!(s.camera.model(), CameraModel::ThinLens);
        assert_eq!(s.camera.focus_distance(), 5.0);
        let text = BASE.replace(
            "[camera]",
            "[scene]\nscale = 2\n[camera]\naperture_radius = 0.5\nfocus_distance = 3",
        );
        let s = parse(&text);
        assert_eq!(
            (s.camera.aperture_radius, s.camera.focus_distance()),
            (1.0, 6.0)
        );
    }

    /// `projection = "orthographic"` needs `view_width`, which `[scene] scale`
    /// scales; the other projection's keys are errors.
    #[test]
    fn orthographic_projection_keys() {
        let ortho = |keys: &str| {
            BASE.replace(
                "lookat = [0, 0, 0]",
                &format!("lookat = [0, 0, 0]\nprojection = \"orthographic\"\n{keys}"),
            )
        };
        let s = parse(&ortho("view_width = 4"));
        assert_eq!(s.camera.view_width, Some(4.0));
        assert_eq!(s.camera.model(), CameraModel::Orthographic);
        let s =
            parse(&ortho("view_width = 4").replace("[camera]", "[scene]\nscale = 0.5\n[camera]"));
        assert_eq!(s.camera.view_width, Some(2.0));
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\nprojection = \"orthographic\"",
        );
        assert_error(&e, "camera", &["missing required key `view_width`"]);
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\nprojection = \"orthographic\"\nview_width = 0",
        );
        assert_error(&e, "camera.view_width", &["got 0"]);
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\nprojection = \"orthographic\"\nview_width = 1\nvfov = 30",
        );
        assert_error(
            &e,
            "camera.vfov",
            &["does not apply to `projection = \"orthographic\"`"],
        );
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nview_width = 1");
        assert_error(
            &e,
            "camera.view_width",
            &["applies only to `projection = \"orthographic\"`"],
        );
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\nprojection = \"orthografic\"",
        );
        assert_error(&e, "camera.projection", &["did you mean `orthographic`?"]);
    }

    #[test]
    fn base_parses_with_defaults() {
        let s = parse(BASE);
        assert_eq!(s.source, FILE);
        assert_eq!(s.camera.vup, Vec3::Y);
        assert_eq!(s.camera.vfov_degrees, 40.0);
        assert_eq!((s.camera.width, s.camera.height), (600, 600));
        assert_eq!(s.render, default_render());
        assert_eq!(s.materials.len(), 2);
        assert_eq!((s.shapes.quads.len(), s.shapes.spheres.len()), (1, 1));
        assert_eq!(s.importance_count(), 0);
    }

    #[test]
    fn cornell_parses() {
        let s = parse(CORNELL);
        assert_eq!(s.shapes.quads.len(), 12);
        assert_eq!(s.shapes.spheres.len(), 1);
        assert_eq!(s.importance_count(), 2);
        let names: Vec<&str> = s.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["glass", "green", "light", "red", "white"]);
        let light = s
            .shapes
            .quads
            .iter()
            .find(|q| s.materials[q.material as usize].emits())
            .unwrap();
        assert!(light.importance);
        assert_eq!(light.q, Vec3::new(213.0, 554.0, 227.0));
        assert_eq!(normal(light), Vec3::NEG_Y, "the light must face down");
        assert_eq!(s.materials[light.material as usize].emit, Vec3::splat(15.0));
        assert_eq!(s.shapes.quads.iter().filter(|q| q.importance).count(), 1);

        let sphere = s.shapes.spheres[0];
        assert!(sphere.importance);
        assert_eq!(
            (sphere.center, sphere.radius),
            (Vec3::new(190.0, 90.0, 190.0), 90.0)
        );
        let glass = &s.materials[sphere.material as usize];
        assert_eq!(glass.kind, MaterialKind::Dielectric { ior: 1.5 });
        assert_eq!((glass.albedo, glass.emit), (Vec3::ZERO, Vec3::ZERO));

        assert_eq!(s.camera.lookfrom, Vec3::new(278.0, 278.0, -800.0));
        assert_eq!(s.camera.lookat, Vec3::new(278.0, 278.0, 0.0));
        assert_eq!(s.camera.vfov_degrees, 40.0);
        assert_eq!((s.camera.width, s.camera.height), (600, 600));
        assert_eq!((s.render.spp, s.render.max_depth), (1000, 50));
        assert_eq!(s.render.strategy, Strategy::Mixture);
        assert_eq!(s.render.background, Vec3::ZERO);

        // Every wall faces into the room (towards its centre).
        let centre = Vec3::splat(277.5);
        for q in &s.shapes.quads[..5] {
            let mid = q.q + 0.5 * (q.u + q.v);
            assert!(normal(q).dot(centre - mid) > 0.0, "{q:?}");
        }
    }

    /// The book's `rotate_y` object-to-world transform of a point, then `translate`.
    fn book_rotate_translate(p: [f64; 3], degrees: f64, t: [f64; 3]) -> Vec3 {
        let (sin_theta, cos_theta) = degrees.to_radians().sin_cos();
        let x = cos_theta * p[0] + sin_theta * p[2];
        let z = -sin_theta * p[0] + cos_theta * p[2];
        Vec3::new((x + t[0]) as f32, (p[1] + t[1]) as f32, (z + t[2]) as f32)
    }

    #[test]
    fn box_rotation_matches_the_book() {
        let s = parse(CORNELL);
        let tall = &s.shapes.quads[6..12];
        // Right face: q = (max.x, min.y, max.z) = (165, 0, 165), u = -dz, v = dy.
        let right = tall[1];
        let expected = book_rotate_translate([165.0, 0.0, 165.0], 15.0, [265.0, 0.0, 295.0]);
        assert!(
            (right.q - expected).abs().max_element() < 1e-3,
            "{right:?} vs {expected}"
        );
        // By hand: x = 165 (cos 15 + sin 15) + 265, z = 165 (cos 15 - sin 15) + 295.
        assert!(
            (right.q - Vec3::new(467.0829, 0.0, 411.6726))
                .abs()
                .max_element()
                < 1e-3
        );
        // Its far corner q + u + v = object (165, 330, 0).
        let far = right.q + right.u + right.v;
        let expected = book_rotate_translate([165.0, 330.0, 0.0], 15.0, [265.0, 0.0, 295.0]);
        assert!(
            (far - expected).abs().max_element() < 1e-3,
            "{far} vs {expected}"
        );
        // All six faces point away from the box centre.
        let centre = book_rotate_translate([82.5, 165.0, 82.5], 15.0, [265.0, 0.0, 295.0]);
        for q in tall {
            let mid = q.q + 0.5 * (q.u + q.v);
            assert!(normal(q).dot(mid - centre) > 0.0, "{q:?}");
            assert_eq!(s.materials[q.material as usize].name, "white");
            assert!(!q.importance);
        }
        // Spheres: the centre is rotated about the origin too.
        let text = BASE.replace(
            "radius = 1\n",
            "radius = 1\nrotate_y = 90\ntranslate = [1, 2, 3]\n",
        );
        let text = text.replace("center = [0, 0, 0]", "center = [1, 0, 0]");
        let s = parse(&text);
        assert_eq!(s.shapes.spheres[0].center, Vec3::new(1.0, 2.0, 2.0));
    }

    #[test]
    fn cornell_boxes_parses() {
        let s = parse(BOXES);
        assert_eq!(s.shapes.quads.len(), 18, "5 walls + 1 light + 2 boxes of 6");
        assert_eq!(s.shapes.spheres.len(), 0);
        assert_eq!(s.importance_count(), 1);
        let short = &s.shapes.quads[12..18];
        let expected = book_rotate_translate([165.0, 0.0, 165.0], -18.0, [130.0, 0.0, 65.0]);
        assert!((short[1].q - expected).abs().max_element() < 1e-3);
        assert_eq!(s.camera, parse(CORNELL).camera);
        assert_eq!(s.render, parse(CORNELL).render);
    }

    #[test]
    fn furnace_parses_with_inward_normals() {
        let s = parse(FURNACE);
        assert_eq!(s.shapes.quads.len(), 6);
        assert_eq!(
            s.importance_count(),
            6,
            "emitters are always in the light density"
        );
        assert_eq!(s.camera.lookfrom, Vec3::ZERO);
        assert_eq!(
            (s.camera.width, s.camera.height, s.camera.vfov_degrees),
            (32, 32, 90.0)
        );
        assert_eq!((s.render.max_depth, s.render.spp), (4, 64));
        let m = &s.materials[0];
        assert_eq!((m.albedo, m.emit), (Vec3::splat(0.5), Vec3::ONE));
        let mut axes = Vec::new();
        for q in &s.shapes.quads {
            let n = normal(q);
            let mid = q.q + 0.5 * (q.u + q.v);
            assert_eq!(mid.abs().max_element(), 1.0, "{q:?} is not a cube face");
            assert_eq!(n, -mid, "{q:?} must face the centre");
            assert_eq!(q.u.length() * q.v.length(), 4.0);
            axes.push(mid.to_array().map(|c| c as i32));
        }
        axes.sort();
        axes.dedup();
        assert_eq!(axes.len(), 6, "one quad per face");
        // The expected pixel value quoted in the file.
        let (a, e, d) = (0.5f32, 1.0f32, 4);
        assert_eq!((0..=d).map(|k| e * a.powi(k)).sum::<f32>(), 1.9375);
    }

    #[test]
    fn syntax_error_has_line_and_column() {
        let e = parse_scene("[camera]\nlookfrom = [0, 0, 1\nlookat = 1\n", FILE).unwrap_err();
        assert!(e.location.starts_with("line "), "{e}");
        assert!(e.message.starts_with("invalid TOML: "), "{e}");
        let e = parse_scene("[camera]\nlookfrom = [0, 0, 1]\n  x = = 2\n", FILE).unwrap_err();
        assert_eq!(e.location, "line 3, column 7", "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{FILE}: line 3, column 7: invalid TOML"))
        );
        let e = parse_scene("a = 1\na = 2\n", FILE).unwrap_err();
        assert_eq!(e.location, "line 2, column 1", "{e}");
        assert!(e.message.contains("duplicate"), "{e}");
        assert_eq!(line_col("é\nαβγ", 8), (2, 3));
        assert_eq!(line_col("é", 1), (1, 1));
    }

    #[test]
    fn unknown_keys_suggest_the_closest() {
        let e = error("albedo = [0.5", "albdo = [0.5");
        assert_error(
            &e,
            "materials.red",
            &["unknown key `albdo`", "did you mean `albedo`?"],
        );
        let e = error("radius = 1", "raduis = 1");
        assert_error(&e, "objects[0]", &["`raduis`", "did you mean `radius`?"]);
        let e = error("[camera]", "[camra]");
        assert_error(&e, "top level", &["`camra`", "did you mean `camera`?"]);
        let e = error("lookat", "vfov = 30\nfov");
        assert_error(&e, "camera", &["`fov`", "did you mean `vfov`?"]);
        let e = error("light_weight", "zzzzzzz");
        assert_error(
            &e,
            "render",
            &["unknown key `zzzzzzz`", "expected one of `spp`"],
        );
        // A key of another material type.
        let e = error(
            "albedo = [0.5, 0.1, 0.1]",
            "albedo = [0.5, 0.1, 0.1]\nior = 1.5",
        );
        assert_error(&e, "materials.red", &["`ior` for a lambertian material"]);
        // A typo in `type` itself.
        let e = error("type = \"sphere\"", "tpye = \"sphere\"");
        assert_error(&e, "objects[0]", &["`tpye`", "did you mean `type`?"]);
    }

    #[test]
    fn wrong_types_say_what_was_expected() {
        let e = error("lookfrom = [0, 0, -5]", "lookfrom = \"far\"");
        assert_error(
            &e,
            "camera.lookfrom",
            &["expected an array of 3 numbers, got a string"],
        );
        let e = error("lookfrom = [0, 0, -5]", "lookfrom = [0, -5]");
        assert_error(&e, "camera.lookfrom", &["got an array of 2 elements"]);
        let e = error("lookfrom = [0, 0, -5]", "lookfrom = [0, true, -5]");
        assert_error(
            &e,
            "camera.lookfrom[1]",
            &["expected a number, got a boolean"],
        );
        let e = error("radius = 1", "radius = \"x\"");
        assert_error(
            &e,
            "objects[0].radius",
            &["expected a number, got a string"],
        );
        let e = error("light_weight = 0.5", "spp = 10.0");
        assert_error(&e, "render.spp", &["expected an integer, got a float"]);
        let e = error("material = \"red\"", "material = 3");
        assert_error(
            &e,
            "objects[0].material",
            &["expected a string, got an integer"],
        );
        let e = error("radius = 1", "radius = 1\nimportance = 1");
        assert_error(
            &e,
            "objects[0].importance",
            &["expected a boolean, got an integer"],
        );
        let camera = "[camera]\nlookfrom = [0, 0, 1]\nlookat = [0, 0, 0]\n";
        let e = parse_scene(&format!("objects = 3\n{camera}"), FILE).unwrap_err();
        assert_error(&e, "objects", &["expected an array of tables"]);
        let e = parse_scene(&format!("objects = [1]\n{camera}"), FILE).unwrap_err();
        assert_error(&e, "objects[0]", &["expected a table, got an integer"]);
        let e = parse_scene(&format!("render = 3\n{camera}"), FILE).unwrap_err();
        assert_error(&e, "render", &["expected a table, got an integer"]);
        let e = parse_scene(&format!("{camera}[materials]\nred = 3\n"), FILE).unwrap_err();
        assert_error(&e, "materials.red", &["expected a table, got an integer"]);
        // Zero objects and no materials are fine.
        let s = parse(&format!("objects = []\n{camera}"));
        assert_eq!(
            (
                s.shapes.quads.len(),
                s.shapes.spheres.len(),
                s.materials.len()
            ),
            (0, 0, 0)
        );
        // Integers are fine where floats are expected.
        let s = parse(&BASE.replace("light_weight = 0.5", "light_weight = 1"));
        assert_eq!(s.render.light_weight, 1.0);
    }

    #[test]
    fn non_finite_numbers_are_rejected() {
        let e = error("radius = 1", "radius = nan");
        assert_error(&e, "objects[0].radius", &["finite", "nan"]);
        let e = error("center = [0, 0, 0]", "center = [0, inf, 0]");
        assert_error(&e, "objects[0].center[1]", &["finite", "inf"]);
        let e = error("light_weight = 0.5", "light_weight = -inf");
        assert_error(&e, "render.light_weight", &["finite", "-inf"]);
        let e = error("center = [0, 0, 0]", "center = [0, 0, 1e39]");
        assert_error(
            &e,
            "objects[0].center[2]",
            &["too large for a 32-bit float"],
        );
        let e = error(
            "center = [0, 0, 0]",
            "center = [3e38, 0, 0]\ntranslate = [3e38, 0, 0]",
        );
        assert_error(&e, "objects[0]", &["overflow"]);
    }

    /// A sphere light too small for 32-bit float directions to aim at is refused
    /// at its radius, at any scale; as large as the bound, or not a light, it is read.
    #[test]
    fn sphere_lights_below_the_aimable_size_are_refused() {
        let scene = |radius: &str, material: &str, scale: &str| {
            format!(
                r#"
                [scene]
                scale = {scale}
                [camera]
                lookfrom = [0, 0, 10]
                lookat = [0, 0, 0]
                [materials.light]
                type = "light"
                emit = [1, 1, 1]
                [materials.white]
                type = "lambertian"
                albedo = [0.5, 0.5, 0.5]
                [[objects]]
                type = "quad"
                q = [-1, -1, -1]
                u = [2, 0, 0]
                v = [0, 2, 0]
                material = "white"
                [[objects]]
                type = "sphere"
                center = [0, 0, 0]
                radius = {radius}
                material = "{material}"
                "#
            )
        };
        // The extent is the camera's 10: the bound is 2e-4.
        for scale in ["1", "1e-3"] {
            let e = parse_scene(&scene("0.00019", "light", scale), "s.toml").unwrap_err();
            assert_eq!(e.location, "objects[1].radius", "{e}");
            assert!(
                e.message.contains("is below") && e.message.contains("point light"),
                "{e}"
            );
        }
        assert!(parse_scene(&scene("0.0002", "light", "1"), "s.toml").is_ok());
        assert!(parse_scene(&scene("0.00019", "white", "1"), "s.toml").is_ok());
    }

    #[test]
    fn geometry_errors() {
        let e = error("radius = 1", "radius = -1");
        assert_eq!(
            e.to_string(),
            format!("{FILE}: objects[0].radius: must be > 0, got -1")
        );
        let e = error("radius = 1", "radius = 0");
        assert_error(&e, "objects[0].radius", &["must be > 0, got 0"]);
        let e = error("v = [0, 2, 0]", "v = [4, 0, 0]");
        assert_error(&e, "objects[1]", &["degenerate quad"]);
        let e = error("v = [0, 2, 0]", "v = [0, 0, 0]");
        assert_error(&e, "objects[1]", &["degenerate quad"]);
        // Relative to |u||v|: a small but non-degenerate quad is fine.
        parse(&BASE.replace("u = [2, 0, 0]", "u = [1e-5, 0, 0]"));
        let e = error(
            "type = \"quad\"",
            "type = \"box\"\nmin = [0, 0, 0]\nmax = [1, 0, 1]\n#",
        );
        assert!(
            e.location == "objects[1]" && e.message.contains("unknown key"),
            "{e}"
        );
        let e = error(
            "type = \"quad\"\nq = [-1, -1, 1]\nu = [2, 0, 0]\nv = [0, 2, 0]",
            "type = \"box\"\nmin = [0, 0, 0]\nmax = [1, 0, 1]",
        );
        assert_error(&e, "objects[1].max", &["max.y = 0 <= min.y = 0"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, -5]");
        assert_error(&e, "camera.lookat", &["must differ from lookfrom"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nvup = [0, 0, 2]");
        assert_error(&e, "camera.vup", &["parallel"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nvup = [0, 0, 0]");
        assert_error(&e, "camera.vup", &["non-zero"]);
    }

    /// `BASE` with the red material's table body replaced by `body`.
    fn red(body: &str) -> String {
        BASE.replacen("type = \"lambertian\"\nalbedo = [0.5, 0.1, 0.1]", body, 1)
    }

    #[test]
    fn mitsuba_material_errors() {
        let error = |body: &str| parse_scene(&red(body), FILE).unwrap_err();
        let cases: &[(&str, &str, &[&str])] = &[
            (
                "type = \"roughconductor\"\nalpha = 0",
                "materials.red.alpha",
                &["must be in (0, 1], got 0"],
            ),
            (
                "type = \"roughconductor\"\nalpha = 1.5",
                "materials.red.alpha",
                &["must be in (0, 1], got 1.5"],
            ),
            (
                "type = \"roughdielectric\"\nalpha_u = 0.1",
                "materials.red",
                &["missing required key `alpha_v`"],
            ),
            (
                "type = \"roughconductor\"\nalpha = 0.1\nalpha_u = 0.1\nalpha_v = 0.2",
                "materials.red.alpha_u",
                &["either `alpha` or `alpha_u` and `alpha_v`"],
            ),
            (
                "type = \"conductor\"\nk = [1, -2, 1]",
                "materials.red.k[1]",
                &["must be >= 0, got -2"],
            ),
            (
                "type = \"conductor\"\neta = -1",
                "materials.red.eta",
                &["must be >= 0, got -1"],
            ),
            (
                "type = \"roughdielectric\"\nint_ior = -1.5",
                "materials.red.int_ior",
                &["must be > 0, got -1.5"],
            ),
            (
                "type = \"plastic\"\nint_ior = 1.000277",
                "materials.red",
                &["must differ"],
            ),
            (
                "type = \"plastic\"\nint_ior = \"watr\"",
                "materials.red.int_ior",
                &[
                    "unknown index of refraction `watr`",
                    "did you mean `water`?",
                ],
            ),
            (
                "type = \"roughconductor\"\ndistribution = \"gxx\"",
                "materials.red.distribution",
                &["did you mean `ggx`?"],
            ),
            (
                "type = \"roughconductor\"\nalbedo = [1, 1, 1]",
                "materials.red",
                &["unknown key `albedo` for a roughconductor material"],
            ),
            (
                "type = \"plastic\"\ndiffuse_reflectance = 1.2",
                "materials.red.diffuse_reflectance",
                &["must be in [0, 1]"],
            ),
            (
                "type = \"plastic\"\nnonlinear = 1",
                "materials.red.nonlinear",
                &["expected a boolean"],
            ),
            (
                "type = \"dielectric\"\nior = 1.5\nint_ior = 1.5",
                "materials.red.int_ior",
                &["either `ior` or `int_ior`/`ext_ior`"],
            ),
            (
                "type = \"roughplastic\"\nalpha_u = 0.1\nalpha_v = 0.2",
                "materials.red",
                &["unknown key `alpha_u` for a roughplastic material (isotropic: `alpha` only)"],
            ),
            (
                "type = \"roughplastic\"\nalpha = 0",
                "materials.red.alpha",
                &["must be in (0, 1], got 0"],
            ),
            (
                "type = \"conductor\"\nmaterial = \"Agg\"",
                "materials.red.material",
                &["unknown conductor `Agg`", "did you mean `Ag`?"],
            ),
            (
                "type = \"roughconductor\"\nmaterial = \"Au\"\neta = [0.2, 0.4, 1.4]",
                "materials.red.eta",
                &["give either `material` (here `Au`) or `eta` and `k`, not both"],
            ),
            (
                "type = \"conductor\"\nmaterial = \"none\"\nk = 2",
                "materials.red.k",
                &["not both"],
            ),
            (
                "type = \"conductor\"\nmaterial = 79",
                "materials.red.material",
                &["expected a string"],
            ),
            (
                "type = \"roughconductr\"",
                "materials.red.type",
                &["did you mean `roughconductor`?"],
            ),
        ];
        for (body, location, parts) in cases {
            assert_error(&error(body), location, parts);
        }
    }

    #[test]
    fn material_errors() {
        let e = error("material = \"red\"", "material = \"rde\"");
        assert_error(
            &e,
            "objects[0].material",
            &[
                "unknown material `rde`",
                "did you mean `red`?",
                "`red`, `white`",
            ],
        );
        let e = error("type = \"lambertian\"", "type = \"lambertain\"");
        assert_error(
            &e,
            "materials.red.type",
            &[
                "unknown material type `lambertain`",
                "did you mean `lambertian`?",
                "`dielectric`",
            ],
        );
        let e = error("type = \"lambertian\"\n", "");
        assert_error(
            &e,
            "materials.red",
            &["missing required key `type`", "`metal`"],
        );
        let e = error("type = \"sphere\"", "type = \"cube\"");
        assert_error(
            &e,
            "objects[0].type",
            &["unknown object type `cube`", "`box`"],
        );
        let e = error("[materials.red]", "[materials.\"my red\"]");
        assert_error(&e, "objects[0].material", &["unknown material `red`"]);
        let e = error("albedo = [0.5, 0.1, 0.1]", "albedo = 0.5");
        assert_error(
            &e,
            "materials.red.albedo",
            &["expected an array of 3 numbers, got a float"],
        );
        let e = error(
            "type = \"lambertian\"\nalbedo = [0.5, 0.1, 0.1]",
            "type = \"metal\"\nalbedo = [1, 1, 1]\nfuzz = 2",
        );
        assert_error(&e, "materials.red.fuzz", &["must be in [0, 1], got 2"]);
        let e = error(
            "type = \"lambertian\"\nalbedo = [0.5, 0.1, 0.1]",
            "type = \"dielectric\"\nior = 0",
        );
        assert_error(&e, "materials.red.ior", &["must be > 0"]);
        let e = error(
            "type = \"lambertian\"\nalbedo = [0.5, 0.1, 0.1]",
            "type = \"light\"\nemit = [1, -1, 1]",
        );
        assert_error(&e, "materials.red.emit[1]", &["must be >= 0, got -1"]);
        let e = error("albedo = [0.5", "albedo = [1.5");
        assert_error(
            &e,
            "materials.red.albedo[0]",
            &["must be in [0, 1], got 1.5"],
        );
        let text = BASE
            .replace("[materials.red]", "[materials.\"a b\"]")
            .replace("albedo = [0.5", "albedo = [-0.5");
        let e = parse_scene(&text, FILE).unwrap_err();
        assert_error(&e, "materials.\"a b\".albedo[0]", &["must be in [0, 1]"]);
        // Quoted names are referenced as written.
        parse(
            &BASE
                .replace("[materials.red]", "[materials.\"a b\"]")
                .replace("\"red\"", "\"a b\""),
        );
    }

    #[test]
    fn missing_required_fields() {
        let e = error("radius = 1\n", "");
        assert_error(&e, "objects[0]", &["missing required key `radius`"]);
        let e = error("lookfrom = [0, 0, -5]\n", "");
        assert_error(&e, "camera", &["missing required key `lookfrom`"]);
        let e = error("material = \"red\"\n", "");
        assert_error(&e, "objects[0]", &["missing required key `material`"]);
        let e = error("type = \"sphere\"\n", "");
        assert_error(
            &e,
            "objects[0]",
            &["missing required key `type`", "`sphere`"],
        );
        let e = error("[camera]\nlookfrom = [0, 0, -5]\nlookat = [0, 0, 0]\n", "");
        assert_error(&e, "camera", &["missing required table `[camera]`"]);
        let e = parse_scene(
            "[camera]\nlookfrom = [0, 0, 1]\nlookat = [0, 0, 0]\n[materials.l]\ntype = \"light\"\n",
            FILE,
        )
        .unwrap_err();
        assert_error(&e, "materials.l", &["missing required key `emit`"]);
    }

    #[test]
    fn out_of_range_values() {
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nvfov = 180");
        assert_error(&e, "camera.vfov", &["(0, 180)", "got 180"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nvfov = 0");
        assert_error(&e, "camera.vfov", &["got 0"]);
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\naperture_radius = -0.1",
        );
        assert_error(&e, "camera.aperture_radius", &["must be >= 0, got -0.1"]);
        let e = error(
            "lookat = [0, 0, 0]",
            "lookat = [0, 0, 0]\nfocus_distance = 0",
        );
        assert_error(&e, "camera.focus_distance", &["got 0"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nwidth = 0");
        assert_error(&e, "camera.width", &["between 1 and 65536, got 0"]);
        let e = error("lookat = [0, 0, 0]", "lookat = [0, 0, 0]\nheight = 65537");
        assert_error(&e, "camera.height", &["between 1 and 65536, got 65537"]);
        let e = error("light_weight = 0.5", "light_weight = 1.5");
        assert_error(&e, "render.light_weight", &["must be in [0, 1], got 1.5"]);
        let e = error("light_weight = 0.5", "spp = 0");
        assert_error(&e, "render.spp", &["must be >= 1, got 0"]);
        let e = error("light_weight = 0.5", "max_depth = 100001");
        assert_error(&e, "render.max_depth", &["between 0 and 100000"]);
        let e = error("light_weight = 0.5", "seed = 4294967296");
        assert_error(&e, "render.seed", &["4294967295"]);
        let e = error("light_weight = 0.5", "seed = -1");
        assert_error(&e, "render.seed", &["got -1"]);
        let e = error("light_weight = 0.5", "background = [0, -0.5, 0]");
        assert_error(&e, "render.background[1]", &["must be >= 0"]);
        let e = error("light_weight = 0.5", "strategy = \"mixtrue\"");
        assert_error(
            &e,
            "render.strategy",
            &["did you mean `mixture`?", "`bsdf`"],
        );
        let e = error("light_weight = 0.5", "strategy = \"autoo\"");
        assert_error(&e, "render.strategy", &["did you mean `auto`?"]);
        let s = parse(&BASE.replace("light_weight = 0.5", "strategy = \"auto\""));
        assert!(s.render.auto_strategy);
        let mut chosen = s.clone();
        chosen
            .apply_overrides(&SceneOverrides {
                strategy: Some(Strategy::NeeMis),
                ..SceneOverrides::default()
            })
            .unwrap();
        assert_eq!(chosen.render.strategy, Strategy::NeeMis);
        assert!(!chosen.render.auto_strategy, "a strategy set replaces auto");
        let e = error("light_weight = 0.5", "sampler = \"sobl\"");
        assert_error(
            &e,
            "render.sampler",
            &["did you mean `sobol`?", "`independent`"],
        );
        let e = error("light_weight = 0.5", "sampler = 1");
        assert_error(&e, "render.sampler", &["expected a string"]);
        let e = error("[render]", "[scene]\nscale = 0\n[render]");
        assert_error(&e, "scene.scale", &["must be > 0"]);
        let e = error("[render]", "[scene]\nscale = 1e30\n[render]");
        assert_error(&e, "scene.scale", &["scaling by 1e30"]);
        let s = parse(&BASE.replace(
            "light_weight = 0.5",
            "seed = 4294967295\nmax_depth = 0\nstrategy = \"light\"",
        ));
        assert_eq!(
            (s.render.seed, s.render.max_depth, s.render.strategy),
            (u32::MAX, 0, Strategy::Light)
        );
        assert!(
            !s.render.sides_by_shading_normal,
            "geometric sides by default"
        );
        let s = parse(&BASE.replace("light_weight = 0.5", "sides_by_shading_normal = true"));
        assert!(s.render.sides_by_shading_normal);
        let e = error("light_weight = 0.5", "sides_by_shading_normal = 1");
        assert_error(&e, "render.sides_by_shading_normal", &["boolean"]);
    }

    #[test]
    fn overrides() {
        let mut s = parse(CORNELL);
        let o = SceneOverrides {
            spp: Some(16),
            width: Some(64),
            height: Some(48),
            max_depth: Some(0),
            strategy: Some(Strategy::Bsdf),
            light_weight: Some(1.0),
            seed: Some(7),
            rr_depth: None,
            sampler: Some(Sampler::Independent),
            light_selection: Some(LightSelection::Uniform),
            adaptive_metric: Some(AdaptiveMetric::Absolute),
            reconstruction: Some(Reconstruction::Importance),
            aovs: Some(vec![Aov {
                name: "nn".into(),
                kind: AovKind::ShNormal,
            }]),
        };
        s.apply_overrides(&o).unwrap();
        assert_eq!(
            (s.render.spp, s.camera.width, s.camera.height),
            (16, 64, 48)
        );
        assert_eq!(
            (s.render.max_depth, s.render.strategy, s.render.seed),
            (0, Strategy::Bsdf, 7)
        );
        assert_eq!(s.render.light_weight, 1.0);
        assert_eq!(s.render.sampler, Sampler::Independent);
        assert_eq!(s.render.light_selection, LightSelection::Uniform);
        assert_eq!(s.render.adaptive_metric, Some(AdaptiveMetric::Absolute));
        assert_eq!(s.render.reconstruction, Some(Reconstruction::Importance));
        assert_eq!(s.render.aovs[0].spec(), "nn:sh_normal");
        s.apply_overrides(&SceneOverrides::default()).unwrap();
        assert_eq!(s.render.spp, 16);

        let before = s.clone();
        let bad = |o: SceneOverrides, field: &str, part: &str| {
            let mut t = before.clone();
            let e = t.apply_overrides(&o).unwrap_err();
            assert_eq!(e.field, field, "{e}");
            assert!(e.message.contains(part), "{e}");
            assert!(e.to_string().starts_with(&format!("{field}: ")));
            assert_eq!(t, before, "nothing changes on error");
        };
        let d = SceneOverrides::default;
        bad(
            SceneOverrides {
                width: Some(0),
                spp: Some(3),
                ..d()
            },
            "camera.width",
            "between 1 and 65536, got 0",
        );
        bad(
            SceneOverrides {
                height: Some(70000),
                ..d()
            },
            "camera.height",
            "got 70000",
        );
        bad(
            SceneOverrides {
                spp: Some(0),
                ..d()
            },
            "render.spp",
            "must be >= 1",
        );
        bad(
            SceneOverrides {
                max_depth: Some(100_001),
                ..d()
            },
            "render.max_depth",
            "100000",
        );
        bad(
            SceneOverrides {
                light_weight: Some(1.5),
                ..d()
            },
            "render.light_weight",
            "[0, 1]",
        );
        bad(
            SceneOverrides {
                light_weight: Some(f32::NAN),
                ..d()
            },
            "render.light_weight",
            "finite",
        );
    }

    #[test]
    fn scaling() {
        let s = parse(CORNELL);
        let t = s.scaled(1e-3);
        assert_eq!(t.camera.lookfrom, s.camera.lookfrom * 1e-3);
        assert_eq!(t.camera.lookat, s.camera.lookat * 1e-3);
        assert_eq!(t.camera.vup, s.camera.vup);
        assert_eq!(t.shapes.spheres[0].radius, 90.0 * 1e-3);
        assert_eq!(
            t.shapes.spheres[0].center,
            s.shapes.spheres[0].center * 1e-3
        );
        for (a, b) in s.shapes.quads.iter().zip(&t.shapes.quads) {
            assert_eq!((b.q, b.u, b.v), (a.q * 1e-3, a.u * 1e-3, a.v * 1e-3));
            assert_eq!((b.material, b.importance), (a.material, a.importance));
        }
        assert!((t.extent() - s.extent() * 1e-3).abs() < 1e-6);
        assert_eq!(
            (t.render.clone(), t.materials.clone()),
            (s.render.clone(), s.materials.clone())
        );

        let text = CORNELL.replace("[camera]", "[scene]\nscale = 1e-3\n\n[camera]");
        assert_eq!(parse(&text), t, "[scene] scale = scaled()");
        let text = CORNELL.replace("[camera]", "[scene]\nscale = 1\n\n[camera]");
        assert_eq!(parse(&text), s);
    }

    /// `[[groups]]` and `instance` objects: the group's shapes stay in its own
    /// space, each instance keeps its transform's rows, the group's materials
    /// are kept though no object of the scene uses them, and a scale moves the
    /// instances and scales the groups.
    #[test]
    fn groups_and_instances_parse() {
        let text = format!(
            "{BASE}
[[groups]]
name = \"ball\"
[[groups.objects]]
type = \"sphere\"
center = [0, 1, 0]
radius = 0.5
material = \"white\"

[[objects]]
type = \"instance\"
group = \"ball\"
translate = [2, 0, 0]
scale = [1, 2, 1]
"
        );
        let s = parse(&text);
        assert_eq!(s.instancing.groups.len(), 1);
        assert_eq!(s.instancing.groups[0].name, "ball");
        assert_eq!(s.instancing.groups[0].shapes.spheres[0].center, Vec3::Y);
        assert_eq!(
            s.shapes.spheres.len(),
            1,
            "the group's sphere is not the scene's"
        );
        let instance = &s.instancing.instances[0];
        assert_eq!(instance.group, 0);
        assert_eq!(
            instance.to_world,
            [
                [1.0, 0.0, 0.0, 2.0],
                [0.0, 2.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0]
            ]
        );
        // The instance's top, (2, 1.5 * 2 = 3, 0), is the farthest point.
        assert!(s.extent() >= 3.0);
        let scaled = s.scaled(2.0);
        assert_eq!(scaled.instancing.instances[0].to_world[0][3], 4.0);
        assert_eq!(scaled.instancing.groups[0].shapes.spheres[0].radius, 1.0);
    }

    #[test]
    fn group_and_instance_errors() {
        let group = "[[groups]]\nname = \"g\"\n[[groups.objects]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"red\"\n";
        let with = |extra: &str| parse_scene(&format!("{BASE}\n{extra}"), FILE).unwrap_err();
        let e = with(&format!(
            "{group}\n[[objects]]\ntype = \"instance\"\ngroup = \"h\"\n"
        ));
        assert_error(&e, "objects[2].group", &["unknown group `h`"]);
        let e = with("[[objects]]\ntype = \"instance\"\ngroup = \"h\"\n");
        assert_error(&e, "objects[2].group", &["no `[[groups]]` are defined"]);
        let e = with("[[objects]]\ntype = \"instance\"\n");
        assert_error(&e, "objects[2]", &["missing required key `group`"]);
        let e = with(&format!(
            "{group}\n[[objects]]\ntype = \"instance\"\ngroup = \"g\"\nmaterial = \"red\"\n"
        ));
        assert_error(
            &e,
            "objects[2]",
            &["unknown key `material` for an instance"],
        );
        let e = with(&format!(
            "{group}[[groups.objects]]\ntype = \"instance\"\ngroup = \"g\"\n"
        ));
        assert_error(
            &e,
            "groups[0].objects[1].type",
            &["nested instancing is not permitted"],
        );
        let e = with(&group.replace(
            "material = \"red\"",
            "material = \"red\"\nimportance = true",
        ));
        assert_error(
            &e,
            "groups[0].objects[0]",
            &["instancing of emitters is not supported"],
        );
        let e = with(&format!(
            "{group}{}",
            group.replace("type = \"sphere\"", "type = \"quad\"")
        ));
        assert_error(&e, "groups[1].name", &["a second group named `g`"]);
        let e = with(&group.replace("radius = 1", "radius = -1"));
        assert_error(&e, "groups[0].objects[0].radius", &["must be > 0"]);
    }

    /// A tiny deterministic RNG for the mutation test.
    struct XorShift(u64);

    impl XorShift {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    fn mutate(text: &str, rng: &mut XorShift) -> String {
        let lines: Vec<&str> = text.lines().collect();
        match rng.below(5) {
            0 => {
                let i = rng.below(lines.len());
                let mut l = lines.clone();
                l.remove(i);
                l.join("\n")
            }
            1 => {
                let i = rng.below(lines.len());
                let mut l = lines.clone();
                l.insert(i, lines[i]);
                l.join("\n")
            }
            2 => {
                // Replace a number (a run starting with a digit).
                let b = text.as_bytes();
                let starts: Vec<usize> = (0..b.len())
                    .filter(|&i| {
                        b[i].is_ascii_digit()
                            && (i == 0 || !b[i - 1].is_ascii_alphanumeric() && b[i - 1] != b'.')
                    })
                    .collect();
                if starts.is_empty() {
                    return text.to_string();
                }
                let start = starts[rng.below(starts.len())];
                let end = (start..b.len())
                    .find(|&i| {
                        !(b[i].is_ascii_digit() || b[i] == b'.' || b[i] == b'e' || b[i] == b'-')
                    })
                    .unwrap_or(b.len());
                let with = [
                    "nan", "-1", "1e39", "\"x\"", "0", "inf", "-0", "1e-40", "true", "[]",
                ];
                format!(
                    "{}{}{}",
                    &text[..start],
                    with[rng.below(with.len())],
                    &text[end..]
                )
            }
            3 => {
                let mut cut = rng.below(text.len() + 1);
                while !text.is_char_boundary(cut) {
                    cut -= 1;
                }
                text[..cut].to_string()
            }
            _ => {
                let mut chars: Vec<char> = text.chars().collect();
                if chars.len() > 1 {
                    let i = rng.below(chars.len());
                    let j = if rng.below(2) == 0 {
                        (i + 1) % chars.len()
                    } else {
                        rng.below(chars.len())
                    };
                    chars.swap(i, j);
                }
                chars.into_iter().collect()
            }
        }
    }

    #[test]
    fn mutations_never_panic() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        let (mut oks, mut errs) = (0, 0);
        for source in [CORNELL, BOXES, FURNACE] {
            for _ in 0..300 {
                let mut text = source.to_string();
                for _ in 0..1 + rng.below(3) {
                    text = mutate(&text, &mut rng);
                }
                let result = std::panic::catch_unwind(|| parse_scene(&text, FILE));
                match result {
                    Err(_) => panic!("parse_scene panicked on:\n{text}"),
                    Ok(Ok(_)) => oks += 1,
                    Ok(Err(e)) => {
                        errs += 1;
                        let shown = e.to_string();
                        assert!(shown.starts_with(&format!("{FILE}: ")), "{shown}");
                        assert!(!e.message.is_empty(), "{shown}");
                    }
                }
            }
        }
        assert!(oks > 0 && errs > 0, "oks {oks}, errs {errs}");
    }

    /// A scene file in a fresh folder with `mesh.obj` beside it, for mesh objects.
    fn scene_with_mesh(obj: &str, object_keys: &str) -> std::result::Result<Scene, SceneError> {
        let dir = tempfile::Builder::new()
            .prefix("pathmix-parse-mesh-")
            .tempdir()
            .unwrap();
        std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
        let path = dir.path().join("scene.toml");
        let text =
            format!("{BASE}\n[[objects]]\ntype = \"mesh\"\nmaterial = \"white\"\n{object_keys}\n");
        std::fs::write(&path, text).unwrap();
        Scene::load(&path)
    }

    const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    #[test]
    fn mesh_files_are_relative_to_the_scene_and_transformed() {
        let s = scene_with_mesh(
            TRIANGLE_OBJ,
            "file = \"mesh.obj\"\nscale = [2, 3, 4]\nrotate = { axis = [0, 0, 1], angle = 90 }\ntranslate = [10, 0, 0]",
        )
        .unwrap();
        assert_eq!(s.shapes.triangles.len(), 1);
        // Scale, then rotate (x -> y, y -> -x), then translate.
        assert_eq!(
            s.shapes.triangles[0].vertices,
            [
                Vec3::new(10.0, 0.0, 0.0),
                Vec3::new(10.0, 2.0, 0.0),
                Vec3::new(7.0, 0.0, 0.0)
            ]
        );
        let m = scene_with_mesh(
            TRIANGLE_OBJ,
            "file = \"mesh.obj\"\nmatrix = [0, -3, 0, 10,  2, 0, 0, 0,  0, 0, 4, 0,  0, 0, 0, 1]",
        )
        .unwrap();
        assert_eq!(
            m.shapes.triangles, s.shapes.triangles,
            "the same transform as a matrix"
        );
    }

    #[test]
    fn mirroring_keeps_the_face_side() {
        let s = scene_with_mesh(TRIANGLE_OBJ, "file = \"mesh.obj\"\nscale = [-1, 1, 1]").unwrap();
        let [a, b, c] = s.shapes.triangles[0].vertices;
        // The original faces +z; mirrored in x it still does.
        assert!((b - a).cross(c - a).z > 0.0);
    }

    /// With the file's vertex normals, a smooth face is on their side whatever
    /// its winding; with `smooth = false` the winding decides (as Mitsuba's
    /// `face_normals`).
    #[test]
    fn file_normals_choose_the_face_side() {
        let clockwise = "v 0 0 0\nv 0 1 0\nv 1 0 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
        let side = |keys: &str| {
            let s = scene_with_mesh(clockwise, &format!("file = \"mesh.obj\"\n{keys}")).unwrap();
            let [a, b, c] = s.shapes.triangles[0].vertices;
            (b - a).cross(c - a).z
        };
        assert!(side("") > 0.0);
        assert!(side("scale = [-1, 1, 1]") > 0.0);
        assert!(side("smooth = false") < 0.0);
    }

    #[test]
    fn degenerate_faces_are_dropped_and_counted() {
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n";
        let s = scene_with_mesh(obj, "file = \"mesh.obj\"").unwrap();
        assert_eq!((s.shapes.triangles.len(), s.degenerate_triangles), (1, 1));
    }

    #[test]
    fn mesh_errors_name_the_object_and_the_mesh_file() {
        let e = scene_with_mesh(TRIANGLE_OBJ, "file = \"missing.obj\"").unwrap_err();
        assert!(e.file.ends_with("scene.toml"), "{e}");
        assert_eq!(e.location, "objects[2].file", "{e}");
        assert!(e.message.contains("missing.obj"), "{e}");
        let e = scene_with_mesh("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "file = \"mesh.obj\"").unwrap_err();
        assert_eq!(e.location, "objects[2].file", "{e}");
        assert!(
            e.message.contains("mesh.obj") && e.message.contains("line 3"),
            "{e}"
        );
        let e = scene_with_mesh(TRIANGLE_OBJ, "").unwrap_err();
        assert!(e.message.contains("missing required key `file`"), "{e}");
    }

    #[test]
    fn transform_errors() {
        let sphere = "type = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1";
        let e = error(sphere, &format!("{sphere}\nscale = [1, 2, 1]"));
        assert_error(&e, "objects[0]", &["non-uniform scale"]);
        let e = error(
            sphere,
            &format!(
                "{sphere}\nscale = 2\nmatrix = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]"
            ),
        );
        assert_error(
            &e,
            "objects[0].scale",
            &["cannot be combined with `matrix`"],
        );
        let e = error(
            sphere,
            &format!("{sphere}\nmatrix = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1]"),
        );
        assert_error(&e, "objects[0].matrix", &["affine", "[0, 0, 1, 1]"]);
        let e = error(sphere, &format!("{sphere}\nmatrix = [1, 0, 0]"));
        assert_error(&e, "objects[0].matrix", &["16 numbers", "3 elements"]);
        let e = error(
            sphere,
            &format!("{sphere}\nrotate_y = 3\nrotate = {{ axis = [0, 1, 0], angle = 3 }}"),
        );
        assert_error(&e, "objects[0].rotate", &["either `rotate_y` or `rotate`"]);
        let e = error(
            sphere,
            &format!("{sphere}\nrotate = {{ axis = [0, 0, 0], angle = 3 }}"),
        );
        assert_error(&e, "objects[0].rotate.axis", &["zero vector"]);
        let e = error(sphere, &format!("{sphere}\nscale = 0"));
        assert_error(&e, "objects[0].scale", &["singular"]);
        // A uniform scale, also as a rotation matrix times a scale, is fine for a sphere.
        let ok = BASE.replacen(
            sphere,
            &format!("{sphere}\nscale = 2\nrotate = {{ axis = [1, 1, 0], angle = 30 }}"),
            1,
        );
        let s = parse(&ok);
        assert!((s.shapes.spheres[0].radius - 2.0).abs() < 1e-6);
    }

    #[test]
    fn point_and_spot_lights_parse_with_mitsuba_defaults() {
        let s = parse(&format!(
            "{BASE}\n[[lights]]\ntype = \"point\"\nposition = [1, 2, 3]\nintensity = 5\n\
             [[lights]]\ntype = \"spot\"\nposition = [0, 1, 0]\nintensity = [1, 2, 3]\n\
             direction = [0, -2, 0]\n[[lights]]\ntype = \"spot\"\nposition = [0, 0, 0]\n\
             intensity = 1\ndirection = [1, 0, 0]\ncutoff_angle = 30\nbeam_width = 10\n"
        ));
        assert_eq!(
            s.point_lights[0],
            PointLight {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Vec3::splat(5.0),
                spot: None,
                directional: None,
            }
        );
        assert_eq!(
            s.point_lights[1].spot,
            Some(Spot {
                direction: Vec3::new(0.0, -1.0, 0.0),
                cutoff_angle: 20.0,
                beam_width: 15.0,
            })
        );
        let spot = s.point_lights[2];
        assert_eq!(spot.spot.unwrap().beam_width, 10.0);
        // Scaling keeps the irradiance: intensity / d^2.
        let scaled = s.scaled(10.0);
        assert_eq!(scaled.point_lights[0].position, Vec3::new(10.0, 20.0, 30.0));
        assert_eq!(scaled.point_lights[0].intensity, Vec3::splat(500.0));
        assert!(s.extent() >= 3.0);
        // A directional light: its direction unit, its irradiance kept by a scale.
        let s = parse(&format!(
            "{BASE}\n[[lights]]\ntype = \"directional\"\ndirection = [0, -3, 0]\nirradiance = 2\n"
        ));
        assert_eq!(s.point_lights[0].directional, Some(Vec3::NEG_Y));
        let scaled = s.scaled(10.0);
        assert_eq!(scaled.point_lights[0].intensity, Vec3::splat(2.0));
        assert_eq!(scaled.point_lights[0].position, Vec3::ZERO);
    }

    #[test]
    fn light_errors() {
        let light =
            |body: &str| parse_scene(&format!("{BASE}\n[[lights]]\n{body}\n"), FILE).unwrap_err();
        let spot = "type = \"spot\"\nposition = [0, 1, 0]\nintensity = 1\ndirection = [0, -1, 0]";
        let cases: &[(String, &str, &[&str])] = &[
            (
                "type = \"point\"\nposition = [0, 1, 0]\nintensity = -1".into(),
                "lights[0].intensity",
                &["must be >= 0, got -1"],
            ),
            (
                "type = \"point\"\nposition = [0, 1, 0]\nintensity = [1, -2, 1]".into(),
                "lights[0].intensity[1]",
                &["must be >= 0, got -2"],
            ),
            (
                "type = \"point\"\nintensity = 1".into(),
                "lights[0]",
                &["missing required key `position`"],
            ),
            (
                "type = \"point\"\nposition = [0, 1, 0]".into(),
                "lights[0]",
                &["missing required key `intensity`"],
            ),
            (
                "type = \"lamp\"".into(),
                "lights[0].type",
                &["`lamp`", "point", "spot"],
            ),
            (
                "type = \"point\"\nposition = [0, 1, 0]\nintensity = 1\ncutoff_angle = 5".into(),
                "lights[0]",
                &["unknown key `cutoff_angle` for a point light"],
            ),
            (
                format!("{spot}\ncutoff_angle = 0"),
                "lights[0].cutoff_angle",
                &["must be in (0, 180) degrees", "got 0"],
            ),
            (
                format!("{spot}\ncutoff_angle = 180"),
                "lights[0].cutoff_angle",
                &["must be in (0, 180) degrees", "got 180"],
            ),
            (
                format!("{spot}\ncutoff_angle = 30\nbeam_width = 40"),
                "lights[0].beam_width",
                &["must not exceed `cutoff_angle` (30), got 40"],
            ),
            (
                format!("{spot}\nbeam_width = -1"),
                "lights[0].beam_width",
                &["must be >= 0, got -1"],
            ),
            (
                "type = \"spot\"\nposition = [0, 1, 0]\nintensity = 1\ndirection = [0, 0, 0]"
                    .into(),
                "lights[0].direction",
                &["must not be zero"],
            ),
            (
                "type = \"directional\"\nirradiance = 1\ndirection = [0, 0, 0]".into(),
                "lights[0].direction",
                &["must not be zero"],
            ),
            (
                "type = \"directional\"\ndirection = [0, -1, 0]".into(),
                "lights[0]",
                &["missing required key `irradiance`"],
            ),
            (
                "type = \"directional\"\nirradiance = 1\ndirection = [0, -1, 0]\nposition = [0, 0, 0]"
                    .into(),
                "lights[0]",
                &["unknown key `position` for a directional light"],
            ),
        ];
        for (body, location, parts) in cases {
            assert_error(&light(body), location, parts);
        }
        let not_array =
            parse_scene(&format!("{BASE}\n[lights]\ntype = \"point\"\n"), FILE).unwrap_err();
        assert_error(&not_array, "lights", &["expected an array of tables"]);
    }
}
