//! The scene file format: TOML, parsed by hand into a validated [`Scene`].
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
use super::mesh::{load_mesh, vertex_normals};
use super::texture::{
    Bitmap, TextureFilter, TextureKind, UvTransform, WrapMode, load_texture_image,
};
use super::{
    Camera, Disk, Filter, Material, MaterialKind, PointLight, Quad, RenderSettings, Roulette,
    Sampler, Scene, SceneError, Shapes, Sphere, Spot, Strategy, Texture, Triangle, excerpt,
};
use crate::kinds::MAX_TEXTURES;
use crate::kinds::params::{
    Params, Result, U32_MAX, check_finite, check_int, check_nonneg, check_positive, check_unit,
    colour, fmt_num, fmt_vec, list, named, number, ok, reflectance, type_name, unknown_name,
};
use std::cell::RefCell;

// Mitsuba's reader takes its named indices from the material kinds, as the
// TOML reader does.
#[cfg(test)]
pub(super) use crate::kinds::NAMED_CONDUCTORS;
pub(super) use crate::kinds::NAMED_IORS;

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
}

/// The `render.strategy` that asks for a pilot's choice.
pub const AUTO_STRATEGY: &str = "auto";
pub(super) const IMAGE_SIDE: (i64, i64) = (1, 65536);
const SPP: (i64, i64) = (1, U32_MAX);
const MAX_DEPTH: (i64, i64) = (0, 100_000);
const SEED: (i64, i64) = (0, U32_MAX);
/// `|u x v| <= DEGENERATE |u| |v|`: a quad (or camera basis) with no area.
const DEGENERATE: f64 = 1e-6;

pub(super) const TOP_KEYS: &[&str] = &[
    "scene",
    "camera",
    "render",
    "materials",
    "objects",
    "environment",
    "lights",
];
pub(super) const ENVIRONMENT_KEYS: &[&str] = &["file", "scale", "rotate_y", "rotate", "matrix"];
pub(super) const SCENE_KEYS: &[&str] = &["scale"];
pub(super) const CAMERA_KEYS: &[&str] = &[
    "lookfrom", "lookat", "vup", "vfov", "width", "height", "filter",
];
/// Each filter type and its keys besides `type`.
pub(super) const FILTER_KEYS: &[(&str, &[&str])] = &[
    ("box", &[]),
    ("gaussian", &["stddev"]),
    ("tent", &["radius"]),
    ("mitchell", &["b", "c"]),
    ("catmullrom", &[]),
    ("lanczos", &["lobes"]),
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
    "adaptive",
];
pub(super) const LIGHT_TYPES: &[&str] = &["point", "spot"];
pub(super) const ALL_LIGHT_KEYS: &[&str] = &[
    "type",
    "position",
    "intensity",
    "direction",
    "cutoff_angle",
    "beam_width",
];
pub(super) const OBJECT_TYPES: &[&str] = &["sphere", "quad", "disk", "box", "mesh"];
pub(super) const TRANSFORM_KEYS: &[&str] = &["scale", "rotate_y", "rotate", "translate", "matrix"];
pub(super) const ALL_OBJECT_KEYS: &[&str] = &[
    "type",
    "material",
    "scale",
    "rotate_y",
    "rotate",
    "translate",
    "matrix",
    "importance",
    "center",
    "radius",
    "q",
    "u",
    "v",
    "min",
    "max",
    "file",
];

// ---------------------------------------------------------------------------------
// Entry points

pub(crate) fn parse_scene(text: &str, file: &str) -> Result<Scene> {
    let root: Table = toml::from_str(text).map_err(|e| syntax_error(file, text, &e))?;
    let inputs = RefCell::new(Vec::new());
    let top = Params {
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
    let objects = parse_objects(&top, &materials)?;
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
        shapes: Shapes {
            quads: objects.quads,
            spheres: objects.spheres,
            triangles: objects.triangles,
            disks: objects.disks,
        },
        degenerate_triangles: objects.degenerate_triangles,
        point_lights,
        warnings: objects.warnings,
        environment,
        inputs: inputs.take(),
    };
    if scale == 1.0 {
        return Ok(scene);
    }
    let mut scene = scene.scaled(scale);
    // Re-check what the scale could break (overflow, underflow).
    let problem = camera_problem(&scene.camera)
        .map(|(_, p)| p)
        .or_else(|| scene.shapes.quads.iter().find_map(quad_problem))
        .or_else(|| scene.shapes.disks.iter().find_map(disk_problem))
        .or_else(|| scene.shapes.spheres.iter().find_map(sphere_problem))
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
        Ok(())
    }

    /// The same scene with every position and length (camera `lookfrom`/`lookat`,
    /// quad `q`/`u`/`v`, disk centre and axes, sphere centre and radius, light
    /// positions) multiplied by `factor`, and point and spot lights' intensities by
    /// `factor^2`, so that the irradiance they give, and the image, stay the same.
    pub fn scaled(&self, factor: f32) -> Scene {
        let mut s = self.clone();
        s.camera.lookfrom *= factor;
        s.camera.lookat *= factor;
        for q in &mut s.shapes.quads {
            q.q *= factor;
            q.u *= factor;
            q.v *= factor;
        }
        for d in &mut s.shapes.disks {
            d.center *= factor;
            d.u *= factor;
            d.v *= factor;
        }
        for sp in &mut s.shapes.spheres {
            sp.center *= factor;
            sp.radius *= factor;
        }
        for t in &mut s.shapes.triangles {
            for v in &mut t.vertices {
                *v *= factor;
            }
        }
        for l in &mut s.point_lights {
            l.position *= factor;
            l.intensity *= factor * factor;
        }
        s
    }
}

// ---------------------------------------------------------------------------------
// Sections

fn parse_camera(t: &Params) -> Result<Camera> {
    t.check_keys(CAMERA_KEYS, None)?;
    let camera = Camera {
        lookfrom: t.require("lookfrom", t.vec3("lookfrom", ok)?)?,
        lookat: t.require("lookat", t.vec3("lookat", ok)?)?,
        vup: t.vec3("vup", ok)?.unwrap_or(Vec3::Y),
        vfov_degrees: t.float("vfov", check_vfov)?.unwrap_or(40.0),
        width: t.int("width", IMAGE_SIDE)?.unwrap_or(600),
        height: t.int("height", IMAGE_SIDE)?.unwrap_or(600),
        filter: parse_filter(t)?,
    };
    if let Some((key, problem)) = camera_problem(&camera) {
        return Err(t.err(t.at(key), problem));
    }
    Ok(camera)
}

/// `filter = "NAME"` (with its defaults) or `filter = { type = "NAME", KEY = VALUE }`,
/// a filter's keys being those `FILTER_KEYS` names for its type.
fn parse_filter(t: &Params) -> Result<Filter> {
    let no_keys = Table::new();
    let (f, name, name_at) = match t.table.get("filter") {
        None => return Ok(Filter::Box),
        Some(Value::String(name)) => {
            let f = Params {
                file: t.file,
                table: &no_keys,
                path: t.at("filter"),
                inputs: t.inputs,
            };
            (f, name.as_str(), t.at("filter"))
        }
        Some(Value::Table(_)) => {
            let f = t.sub("filter")?.expect("key exists");
            let name = f.require("type", f.string("type")?)?;
            let name_at = f.at("type");
            (f, name, name_at)
        }
        Some(other) => {
            return Err(t.err(
                t.at("filter"),
                format!(
                    "expected a filter name (one of {}) or a table, got {}",
                    list(&filter_types()),
                    type_name(other)
                ),
            ));
        }
    };
    let Some(&(_, keys)) = FILTER_KEYS.iter().find(|(n, _)| *n == name) else {
        return Err(f.err(name_at, unknown_name("filter type", name, &filter_types())));
    };
    let known: Vec<&str> = ["type"].into_iter().chain(keys.iter().copied()).collect();
    f.check_keys(&known, Some(&format!("the {name} filter")))?;
    Ok(match name {
        "box" => Filter::Box,
        "gaussian" => Filter::Gaussian {
            stddev: f
                .float("stddev", check_positive)?
                .unwrap_or(Filter::GAUSSIAN_DEFAULT_STDDEV),
        },
        "tent" => Filter::Tent {
            radius: f
                .float("radius", check_positive)?
                .unwrap_or(Filter::TENT_DEFAULT_RADIUS),
        },
        "mitchell" => Filter::Mitchell {
            b: f.float("b", check_mitchell_parameter)?
                .unwrap_or(Filter::MITCHELL_DEFAULT_B),
            c: f.float("c", check_mitchell_parameter)?
                .unwrap_or(Filter::MITCHELL_DEFAULT_C),
        },
        "catmullrom" => Filter::CatmullRom,
        _ => Filter::Lanczos {
            lobes: f
                .int("lobes", (1, Filter::LANCZOS_MAX_LOBES.into()))?
                .unwrap_or(Filter::LANCZOS_DEFAULT_LOBES),
        },
    })
}

pub(super) fn filter_types() -> Vec<&'static str> {
    FILTER_KEYS.iter().map(|&(name, _)| name).collect()
}

fn check_mitchell_parameter(x: f32) -> std::result::Result<(), String> {
    let bound = Filter::MITCHELL_MAX_PARAMETER;
    if x.abs() <= bound {
        Ok(())
    } else {
        Err(format!(
            "must be in [-{bound}, {bound}], got {}",
            fmt_num(x)
        ))
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
        adaptive: false,
    }
}

fn parse_render(t: &Params) -> Result<RenderSettings> {
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
        adaptive: t.boolean("adaptive")?.unwrap_or(d.adaptive),
    })
}

/// `render.strategy`: a strategy's name, or `auto` (true: the pilot chooses).
fn parse_strategy(t: &Params) -> Result<(Option<Strategy>, bool)> {
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
fn parse_environment(t: &Params) -> Result<EnvironmentMap> {
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
fn parse_materials(top: &Params) -> Result<Vec<Material>> {
    let Some(mats) = top.sub("materials")? else {
        return Ok(Vec::new());
    };
    let mut names: Vec<&String> = mats.table.keys().collect();
    names.sort();
    let mut out = Vec::with_capacity(names.len());
    let mut textures = 0;
    for name in names {
        let t = mats.sub(name)?.expect("key exists");
        let material = Material::parse(name, &t, parse_texture)?;
        textures += material.texture.is_some() as usize + material.bump.is_some() as usize;
        if textures > MAX_TEXTURES {
            return Err(t.err(
                t.here(),
                format!(
                    "more than {MAX_TEXTURES} textures (bump and normal maps included) in one scene"
                ),
            ));
        }
        out.push(material);
    }
    Ok(out)
}

/// Textures in device memory: one storage binding holds every texel (three
/// floats each), and wgpu's default limit on a binding, lavapipe's too, is 128 MiB.
pub const MAX_TEXTURE_TEXELS: u64 = (128 << 20) / 12;

/// `{ type = "checkerboard" | "bitmap", ... }` (`scene::texture`).
pub(super) const TEXTURE_TYPES: &[&str] = &["checkerboard", "bitmap"];
pub(super) const CHECKERBOARD_KEYS: &[&str] = &["type", "color0", "color1", "to_uv"];
pub(super) const BITMAP_KEYS: &[&str] =
    &["type", "file", "wrap_mode", "filter_type", "raw", "to_uv"];

fn parse_texture(s: &Params) -> Result<Texture> {
    let Some(ty) = s.string("type")? else {
        return Err(s.err(
            s.here(),
            format!(
                "missing required key `type` for a texture (expected one of {})",
                list(TEXTURE_TYPES)
            ),
        ));
    };
    let kind = match ty {
        "checkerboard" => {
            s.check_keys(CHECKERBOARD_KEYS, Some("a checkerboard texture"))?;
            TextureKind::Checkerboard {
                color0: reflectance(s, "color0", 0.4)?,
                color1: reflectance(s, "color1", 0.2)?,
            }
        }
        "bitmap" => {
            s.check_keys(BITMAP_KEYS, Some("a bitmap texture"))?;
            let file = s.require("file", s.string("file")?)?;
            let raw = s.boolean("raw")?.unwrap_or(false);
            let wrap = named(
                s,
                "wrap_mode",
                &WrapMode::ALL,
                WrapMode::name,
                WrapMode::from_name,
            )?
            .unwrap_or(WrapMode::Repeat);
            let filter = named(
                s,
                "filter_type",
                &TextureFilter::ALL,
                TextureFilter::name,
                TextureFilter::from_name,
            )?
            .unwrap_or(TextureFilter::Bilinear);
            let path = s.input(file);
            let (width, height, texels) =
                load_texture_image(&path, raw).map_err(|m| s.err(s.at("file"), m))?;
            if width as u64 * height as u64 > MAX_TEXTURE_TEXELS {
                return Err(s.err(
                    s.at("file"),
                    format!(
                        "{}: {width}x{height} texels do not fit the 128 MiB storage binding                          that holds a scene's textures (at most {MAX_TEXTURE_TEXELS} texels):                          scale the image down",
                        path.display()
                    ),
                ));
            }
            TextureKind::Bitmap(Bitmap {
                file: file.to_string(),
                width,
                height,
                texels: std::sync::Arc::new(texels),
                raw,
                wrap,
                filter,
            })
        }
        other => {
            return Err(s.err(
                s.at("type"),
                unknown_name("texture type", other, TEXTURE_TYPES),
            ));
        }
    };
    let to_uv = match s.sub("to_uv")? {
        Some(u) => parse_to_uv(&u)?,
        None => UvTransform::IDENTITY,
    };
    Ok(Texture { kind, to_uv })
}

/// `to_uv = { scale = [su, sv], translate = [tu, tv] }` (u' = su u + tu; one
/// number scales both), or `{ matrix = [[a, b, c], [d, e, f]] }` (u' = a u + b v
/// + c, v' = d u + e v + f): Mitsuba's `to_uv` transform.
fn parse_to_uv(u: &Params) -> Result<UvTransform> {
    u.check_keys(&["scale", "translate", "matrix"], Some("to_uv"))?;
    if let Some(rows) = u.table.get("matrix") {
        if let Some(key) = ["scale", "translate"]
            .into_iter()
            .find(|k| u.table.contains_key(*k))
        {
            return Err(u.err(
                u.at(key),
                "give either `matrix` or `scale`/`translate`, not both",
            ));
        }
        let bad = || {
            u.err(
                u.at("matrix"),
                "expected two rows of three numbers, [[a, b, c], [d, e, f]]",
            )
        };
        let Value::Array(rows) = rows else {
            return Err(bad());
        };
        let mut m = [[0.0f32; 3]; 2];
        if rows.len() != 2 {
            return Err(bad());
        }
        for (r, row) in rows.iter().enumerate() {
            let Value::Array(row) = row else {
                return Err(bad());
            };
            if row.len() != 3 {
                return Err(bad());
            }
            for (c, x) in row.iter().enumerate() {
                m[r][c] =
                    number(x).map_err(|e| u.err(format!("{}[{r}][{c}]", u.at("matrix")), e))?;
            }
        }
        return Ok(UvTransform(m));
    }
    let scale = match u.table.get("scale") {
        Some(Value::Array(_)) => u.numbers::<2>("scale")?,
        Some(_) => [u.float("scale", check_finite)?.expect("present"); 2],
        None => [1.0; 2],
    };
    let translate = match u.table.get("translate") {
        Some(_) => u.numbers::<2>("translate")?,
        None => [0.0; 2],
    };
    Ok(UvTransform([
        [scale[0], 0.0, translate[0]],
        [0.0, scale[1], translate[1]],
    ]))
}

fn check_cutoff(x: f32) -> std::result::Result<(), String> {
    if x > 0.0 && x < 180.0 {
        Ok(())
    } else {
        Err(format!(
            "must be in (0, 180) degrees, exclusive, got {}",
            fmt_num(x)
        ))
    }
}

/// The tables of the top-level array `key` (`[[key]]`, none when absent), each
/// with its `type`, read one at a time as the caller walks them (so errors come
/// in file order); a table without a `type` is refused, its keys checked against
/// `all_keys` first, naming the `types` it may take.
fn typed_tables<'a, 'b>(
    top: &'b Params<'a>,
    key: &'b str,
    all_keys: &'b [&'b str],
    types: &'b [&'b str],
) -> Result<impl ExactSizeIterator<Item = Result<(Params<'a>, &'a str)>> + 'b> {
    let items: &'a [Value] = match top.table.get(key) {
        None => &[],
        Some(Value::Array(items)) => items,
        Some(value) => {
            return Err(top.err(
                key,
                format!(
                    "expected an array of tables (`[[{key}]]`), got {}",
                    type_name(value)
                ),
            ));
        }
    };
    Ok(items.iter().enumerate().map(move |(i, item)| {
        let path = format!("{key}[{i}]");
        let Value::Table(table) = item else {
            return Err(top.err(path, format!("expected a table, got {}", type_name(item))));
        };
        let t = Params {
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

/// The `[[lights]]`: point and spot lights.
fn parse_lights(top: &Params) -> Result<Vec<PointLight>> {
    let tables = typed_tables(top, "lights", ALL_LIGHT_KEYS, LIGHT_TYPES)?;
    let mut lights = Vec::with_capacity(tables.len());
    for table in tables {
        let (t, ty) = table?;
        match ty {
            "point" => t.check_keys(&["type", "position", "intensity"], Some("a point light"))?,
            "spot" => t.check_keys(ALL_LIGHT_KEYS, Some("a spot light"))?,
            other => {
                return Err(t.err(t.at("type"), unknown_name("light type", other, LIGHT_TYPES)));
            }
        }
        let position = t.require("position", t.vec3("position", ok)?)?;
        if !t.table.contains_key("intensity") {
            return Err(t.err(t.here(), "missing required key `intensity`"));
        }
        let intensity = colour(&t, "intensity", 0.0, check_nonneg)?;
        let spot = if ty == "spot" {
            let direction = t.require("direction", t.vec3("direction", ok)?)?;
            if !usable_length_squared(direction.length_squared()) {
                return Err(t.err(t.at("direction"), "must not be zero"));
            }
            let cutoff_angle = t.float("cutoff_angle", check_cutoff)?.unwrap_or(20.0);
            let beam_width = t.float("beam_width", check_nonneg)?;
            let beam_width = beam_width.unwrap_or(cutoff_angle * 3.0 / 4.0);
            if beam_width > cutoff_angle {
                return Err(t.err(
                    t.at("beam_width"),
                    format!(
                        "must not exceed `cutoff_angle` ({}), got {}",
                        fmt_num(cutoff_angle),
                        fmt_num(beam_width)
                    ),
                ));
            }
            Some(Spot {
                direction: direction.normalize(),
                cutoff_angle,
                beam_width,
            })
        } else {
            None
        };
        lights.push(PointLight {
            position,
            intensity,
            spot,
        });
    }
    Ok(lights)
}

/// The objects of a scene file, in world space.
#[derive(Default)]
struct Objects {
    quads: Vec<Quad>,
    disks: Vec<Disk>,
    spheres: Vec<Sphere>,
    triangles: Vec<Triangle>,
    degenerate_triangles: usize,
    /// Materials taken from mesh files, after the scene's own.
    extra_materials: Vec<Material>,
    warnings: Vec<String>,
}

fn parse_objects(top: &Params, materials: &[Material]) -> Result<Objects> {
    let mut objects = Objects::default();
    let Objects {
        quads,
        disks,
        spheres,
        triangles,
        degenerate_triangles,
        extra_materials,
        warnings,
    } = &mut objects;
    for (i, table) in typed_tables(top, "objects", ALL_OBJECT_KEYS, OBJECT_TYPES)?.enumerate() {
        let (t, ty) = table?;
        let (keys, what): (&[&str], &str) = match ty {
            "sphere" => (&["center", "radius"], "a sphere"),
            "quad" => (&["q", "u", "v"], "a quad"),
            "disk" => (&["center", "u", "v"], "a disk"),
            "box" => (&["min", "max"], "a box"),
            "mesh" => (&["file", "smooth"], "a mesh"),
            other => {
                return Err(t.err(
                    t.at("type"),
                    unknown_name("object type", other, OBJECT_TYPES),
                ));
            }
        };
        let known: Vec<&str> = TRANSFORM_KEYS
            .iter()
            .copied()
            .chain(["type", "material", "importance"])
            .chain(keys.iter().copied())
            .collect();
        t.check_keys(&known, Some(what))?;

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
        let xf = Transform::parse(&t)?;
        // Only a mesh has no `material`; it resolves its faces' below.
        let material = chosen.unwrap_or_default() as u32;
        // A quad's or disk's anchor point and edge vectors, in world space.
        let planar = |anchor: &str| -> Result<(Vec3, Vec3, Vec3)> {
            let point = t.require(anchor, t.vec3(anchor, ok)?)?;
            let u = t.require("u", t.vec3("u", ok)?)?;
            let v = t.require("v", t.vec3("v", ok)?)?;
            Ok((
                xf.point(point.as_dvec3()),
                xf.vector(u.as_dvec3()),
                xf.vector(v.as_dvec3()),
            ))
        };

        match ty {
            "sphere" => {
                let center = t.require("center", t.vec3("center", ok)?)?;
                let radius = t.require("radius", t.float("radius", check_positive)?)?;
                let Some(scale) = xf.uniform_scale() else {
                    return Err(t.err(
                        t.here(),
                        "a sphere cannot take a non-uniform scale (it would be an ellipsoid)",
                    ));
                };
                let sphere = Sphere {
                    center: xf.point(center.as_dvec3()),
                    radius: (f64::from(radius) * scale) as f32,
                    material,
                    importance,
                };
                if let Some(p) = sphere_problem(&sphere) {
                    return Err(t.err(t.here(), p));
                }
                spheres.push(sphere);
            }
            "quad" => {
                let (q, u, v) = planar("q")?;
                let quad = Quad {
                    q,
                    u,
                    v,
                    material,
                    importance,
                };
                if let Some(p) = quad_problem(&quad) {
                    return Err(t.err(t.here(), p));
                }
                quads.push(quad);
            }
            "disk" => {
                let (center, u, v) = planar("center")?;
                let disk = Disk {
                    center,
                    u,
                    v,
                    material,
                    importance,
                };
                if let Some(p) = disk_problem(&disk) {
                    return Err(t.err(t.here(), p));
                }
                disks.push(disk);
            }
            "mesh" => {
                let name = t.require("file", t.string("file")?)?;
                let path = t.input(name);
                let smooth = t.boolean("smooth")?.unwrap_or(true);
                let mesh = load_mesh(&path).map_err(|e| t.err(t.at("file"), e.to_string()))?;
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
                        let faces = faces.collect();
                        extra_materials.extend(mapped);
                        faces
                    }
                };
                let faces_in_file = faces.len();
                let mut dropped = 0;
                for (face, (material, importance)) in faces.into_iter().zip(face_materials) {
                    let vertices = face.map(|i| world[i as usize]);
                    if triangle_is_degenerate(vertices) {
                        dropped += 1;
                        continue;
                    }
                    triangles.push(Triangle {
                        vertices,
                        normals: normals.as_ref().map(|n| face.map(|i| n[i as usize])),
                        uvs: mesh.uvs.as_ref().map(|uvs| face.map(|i| uvs[i as usize])),
                        material,
                        importance,
                        mesh: i as u32,
                    });
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
                    if let Some(p) = quad_problem(&quad) {
                        return Err(t.err(t.here(), format!("{face} face of the box: {p}")));
                    }
                    quads.push(quad);
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
fn file_materials(t: &Params, mesh: &super::mesh::Mesh, base: u32) -> Result<Vec<Material>> {
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
                texture: None,
                bump: None,
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

/// A face with no usable area in 32-bit floats (collinear or coincident
/// vertices): it can be neither hit nor sampled, so it is dropped and counted.
fn triangle_is_degenerate([a, b, c]: [Vec3; 3]) -> bool {
    let (e1, e2) = ((b - a).as_dvec3(), (c - a).as_dvec3());
    let n = e1.cross(e2);
    !usable_length_squared(n.as_vec3().length_squared())
        || n.length() <= DEGENERATE * e1.length() * e2.length()
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

/// `rotate_y` then `translate`, object to world, evaluated in double precision.
/// Object to world: `linear` (scale, then rotation) then `translate`, in f64 so
/// that composing and applying it rounds once, to f32, at the end.
/// Drops the mesh faces a `[scene] scale` left with no usable area, with a
/// warning per object that lost some; the problem if one lost them all.
fn drop_scaled_out_faces(scene: &mut Scene, file: &str) -> Option<String> {
    // Per object (`Triangle::mesh`): faces before, and dropped.
    let mut counts: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
    scene.shapes.triangles.retain(|t| {
        let count = counts.entry(t.mesh).or_default();
        count.0 += 1;
        let degenerate = triangle_is_degenerate(t.vertices);
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

struct Transform {
    linear: DMat3,
    translate: DVec3,
}

/// `sin` and `cos` of `degrees`, exact at multiples of 90 degrees so axis-aligned
/// geometry stays exact.
pub(super) fn sin_cos_degrees(degrees: f64) -> (f64, f64) {
    match degrees.rem_euclid(360.0) {
        0.0 => (0.0, 1.0),
        90.0 => (1.0, 0.0),
        180.0 => (0.0, -1.0),
        270.0 => (-1.0, 0.0),
        r => r.to_radians().sin_cos(),
    }
}

/// `matrix` (16 numbers, row-major, affine): its linear part and translation.
/// `others` are the keys it replaces, refused alongside it.
fn matrix(t: &Params, others: &[&str]) -> Result<(DMat3, DVec3)> {
    if let Some(other) = others.iter().find(|k| t.table.contains_key(**k)) {
        return Err(t.err(
            t.at(other),
            "cannot be combined with `matrix` (the matrix is the whole transform)",
        ));
    }
    let m: [f32; 16] = t.numbers("matrix")?;
    if m[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(t.err(
            t.at("matrix"),
            format!(
                "must be affine: its last row must be [0, 0, 0, 1], got [{}]",
                m[12..]
                    .iter()
                    .map(|&x| fmt_num(x))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let m = m.map(f64::from);
    let linear = DMat3::from_cols(
        DVec3::new(m[0], m[4], m[8]),
        DVec3::new(m[1], m[5], m[9]),
        DVec3::new(m[2], m[6], m[10]),
    );
    Ok((linear, DVec3::new(m[3], m[7], m[11])))
}

/// `rotate_y` (the book's) or `rotate = { axis, angle }`; the identity without either.
fn rotation(t: &Params) -> Result<DMat3> {
    Ok(match (t.table.contains_key("rotate_y"), t.sub("rotate")?) {
        (true, Some(_)) => {
            return Err(t.err(
                t.at("rotate"),
                "give either `rotate_y` or `rotate`, not both",
            ));
        }
        (_, Some(r)) => {
            r.check_keys(&["axis", "angle"], Some("a rotation"))?;
            let axis = r.require("axis", r.vec3("axis", ok)?)?.as_dvec3();
            let angle = f64::from(r.require("angle", r.float("angle", ok)?)?);
            if axis.length_squared() == 0.0 {
                return Err(r.err(r.at("axis"), "must not be the zero vector"));
            }
            let (sin, cos) = sin_cos_degrees(angle);
            // Rodrigues' formula, with the exact sine and cosine.
            let k = axis.normalize();
            let cross = DMat3::from_cols(
                DVec3::new(0.0, k.z, -k.y),
                DVec3::new(-k.z, 0.0, k.x),
                DVec3::new(k.y, -k.x, 0.0),
            );
            DMat3::IDENTITY * cos
                + cross * sin
                + DMat3::from_cols(k * k.x, k * k.y, k * k.z) * (1.0 - cos)
        }
        (_, None) => {
            let (sin, cos) = sin_cos_degrees(t.float("rotate_y", ok)?.unwrap_or(0.0).into());
            // The book's rotate_y: (x, z) maps to (cos x + sin z, -sin x + cos z).
            DMat3::from_cols(
                DVec3::new(cos, 0.0, -sin),
                DVec3::Y,
                DVec3::new(sin, 0.0, cos),
            )
        }
    })
}

impl Transform {
    /// The object's transform keys: `scale`, `rotate_y` or `rotate`, `translate`,
    /// or `matrix` instead of all three.
    fn parse(t: &Params) -> Result<Transform> {
        if t.table.contains_key("matrix") {
            let (linear, translate) = matrix(t, &["scale", "rotate_y", "rotate", "translate"])?;
            return Transform::checked(t, "matrix", linear, translate);
        }
        let scale = match t.table.get("scale") {
            None => DVec3::ONE,
            Some(Value::Array(_)) => t.require("scale", t.vec3("scale", ok)?)?.as_dvec3(),
            Some(_) => DVec3::splat(t.require("scale", t.float("scale", ok)?)?.into()),
        };
        let rotation = rotation(t)?;
        let translate = t.vec3("translate", ok)?.unwrap_or(Vec3::ZERO).as_dvec3();
        let linear = rotation * DMat3::from_diagonal(scale);
        Transform::checked(t, "scale", linear, translate)
    }

    fn checked(t: &Params, key: &str, linear: DMat3, translate: DVec3) -> Result<Transform> {
        if !linear.is_finite() || !translate.is_finite() || linear.determinant() == 0.0 {
            return Err(t.err(
                t.at(key),
                "the transform is singular: it flattens the object",
            ));
        }
        Ok(Transform { linear, translate })
    }

    fn point(&self, p: DVec3) -> Vec3 {
        (self.linear * p + self.translate).as_vec3()
    }

    fn vector(&self, v: DVec3) -> Vec3 {
        (self.linear * v).as_vec3()
    }

    /// The factor of a transform that scales every direction alike (a rotation
    /// times a uniform scale, maybe mirrored), or `None`.
    fn uniform_scale(&self) -> Option<f64> {
        let columns = [self.linear.x_axis, self.linear.y_axis, self.linear.z_axis];
        let lengths = columns.map(DVec3::length);
        let tolerance = 1e-6 * lengths[0];
        let orthogonal =
            (0..3).all(|i| columns[i].dot(columns[(i + 1) % 3]).abs() <= tolerance * lengths[0]);
        let equal = lengths.iter().all(|&l| (l - lengths[0]).abs() <= tolerance);
        (orthogonal && equal).then_some(lengths[0])
    }

    /// Whether the transform mirrors (turns counter-clockwise windings clockwise).
    fn mirrors(&self) -> bool {
        self.linear.determinant() < 0.0
    }

    /// A surface normal carried to world space (by the inverse transpose, so it
    /// stays perpendicular under a non-uniform scale), unit length; zero where
    /// the file's normal is zero or not finite.
    fn normal(&self, n: Vec3) -> Vec3 {
        let world = self.linear.inverse().transpose() * n.as_dvec3();
        world.normalize_or_zero().as_vec3()
    }
}

// ---------------------------------------------------------------------------------
// Geometric validation (shared by the parser and the post-scale check)

/// A squared length a renderer can work with in 32-bit floats.
fn usable_length_squared(l2: f32) -> bool {
    l2.is_finite() && l2 >= f32::MIN_POSITIVE
}

fn quad_problem(q: &Quad) -> Option<String> {
    spanned_problem("quad", q.q, q.u, q.v)
}

fn disk_problem(d: &Disk) -> Option<String> {
    spanned_problem("disk", d.center, d.u, d.v)
}

/// What is wrong with a flat shape spanned by `u` and `v` from `point` (a quad, a disk).
fn spanned_problem(what: &str, point: Vec3, u: Vec3, v: Vec3) -> Option<String> {
    if !(point.is_finite() && u.is_finite() && v.is_finite()) {
        return Some("coordinates overflow a 32-bit float".to_string());
    }
    let area = u.as_dvec3().cross(v.as_dvec3()).length();
    if area <= DEGENERATE * u.as_dvec3().length() * v.as_dvec3().length() {
        return Some(format!(
            "degenerate {what}: u x v has (near) zero length (u = {}, v = {})",
            fmt_vec(u),
            fmt_vec(v)
        ));
    }
    if !usable_length_squared(u.cross(v).length_squared()) {
        return Some(format!(
            "{what} area {} is out of the range 32-bit float arithmetic can handle",
            fmt_num(area)
        ));
    }
    None
}

fn sphere_problem(s: &Sphere) -> Option<String> {
    if !s.center.is_finite() {
        return Some("coordinates overflow a 32-bit float".to_string());
    }
    if !(s.radius > 0.0 && usable_length_squared(s.radius * s.radius)) {
        return Some(format!(
            "radius {} is out of the range 32-bit float arithmetic can handle",
            fmt_num(s.radius)
        ));
    }
    None
}

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
// Value checks (the others are `kinds::params`')

fn check_vfov(x: f32) -> std::result::Result<(), String> {
    if x > 0.0 && x < 180.0 {
        Ok(())
    } else {
        Err(format!(
            "must be in (0, 180) degrees, exclusive, got {}",
            fmt_num(x)
        ))
    }
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
        ];
        for (body, location, parts) in cases {
            assert_error(&light(body), location, parts);
        }
        let not_array =
            parse_scene(&format!("{BASE}\n[lights]\ntype = \"point\"\n"), FILE).unwrap_err();
        assert_error(&not_array, "lights", &["expected an array of tables"]);
    }
}
