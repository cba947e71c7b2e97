//! Mitsuba 3 XML scenes, read (with `roxmltree`, which keeps positions) into the
//! pathmix TOML document they mean, which the TOML parser then validates into a
//! [`Scene`]. `pathmix convert` writes that same document, so what a user sees is
//! exactly what renders.
//!
//! The subset: `<default>`, `$name` and `-D name=value`, `<include>`, `<path>`,
//! `id`/`<ref>`; transforms `translate`, `rotate`, `scale`, `matrix`, `lookat`;
//! shapes `obj`, `ply`, `serialized`, `rectangle`, `cube`, `disk`, `sphere`, `cylinder` with `to_world`,
//! `flip_normals`, `face_normals` and an area emitter; BSDFs through `Builder::surface`;
//! colours as `<rgb>`, `<float>` or `<spectrum>` (reduced to RGB as Mitsuba's RGB
//! variants reduce it, src/scene/spectrum.rs);
//! `constant`, `envmap`, `point` and `spot` emitters; `bitmap` and `checkerboard` textures (nested or
//! by `<ref>`) on the colour each BSDF can take one for (`Builder::texturable`); the `perspective` sensor with `hdrfilm`, its `rfilter`
//! (`box`, `gaussian`, `tent`, `mitchell`, `catmullrom`, `lanczos`) and a sampler; the `path` and `direct` integrators,
//! and `aov` around one of them (`kinds::aov`). Anything
//! else is an error naming `file:line:col` and the element; an approximation is a
//! warning.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::{DMat4, DVec3, DVec4};
use toml::{Table, Value};

mod upgrade;

use super::parse::{IMAGE_SIDE, NAMED_IORS, sin_cos_degrees};
use super::spectrum::{self, Role, Spectrum};
use super::{Aov, Sampler, SceneError, excerpt, parse_aovs};
use crate::kinds::transform::coordinate_system;
use crate::kinds::{MATERIAL_KINDS, MaterialModel, MitsubaPlugin};

type Result<T> = std::result::Result<T, SceneError>;

/// pathmix's largest `max_depth`, for Mitsuba's unbounded `max_depth = -1`.
const UNBOUNDED_DEPTH: i64 = 100_000;

/// The deepest elements may nest: far beyond any real scene (a handful of
/// levels), and shallow enough that reading them, which recurses, cannot
/// overflow the stack.
pub const MAX_NESTING: usize = 1_000;

/// The most elements a scene and the files it includes may hold in all, each
/// inclusion counted again: files that each include the next twice would
/// otherwise expand exponentially.
pub const MAX_ELEMENTS: usize = 1_000_000;

/// The most text a scene and its inclusions may read in all (256 MiB).
pub const MAX_TEXT_BYTES: usize = 256 << 20;

/// The Mitsuba versions whose format pathmix reads as it is: 2.x.y and 3.x.y
/// (older files are upgraded first, `upgrade::UPGRADED_VERSIONS`).
const VERSIONS: [u32; 2] = [2, 3];

/// The BSDF plugins read here, besides those that are material kinds (`mitsuba_kind`).
const BSDFS_READ_HERE: [&str; 6] = [
    "diffuse",
    "twosided",
    "mask",
    "bumpmap",
    "normalmap",
    "blendbsdf",
];
/// The material keys a `bumpmap` or `normalmap` sets (`kinds::Bump`).
const BUMP_KEYS: [&str; 2] = ["bump", "normal_map"];
const SUPPORTED_SHAPES: &str = "obj, ply, serialized, rectangle, cube, disk, sphere, cylinder";
const SUPPORTED_TOP: &str =
    "default, include, path, integrator, sensor, shape, bsdf, emitter, texture";

/// A `-D name=value` parameter, as `mitsuba -D`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Define {
    pub name: String,
    pub value: String,
}

impl FromStr for Define {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Define, String> {
        match s.split_once('=') {
            Some((name, value)) if is_param_name(name) => Ok(Define {
                name: name.to_string(),
                value: value.to_string(),
            }),
            _ => Err(format!(
                "expected NAME=VALUE with NAME of letters, digits and `_`, got `{s}`"
            )),
        }
    }
}

fn is_param_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether `path` holds a Mitsuba scene: a `.xml` name, or text that opens with
/// markup (which no TOML file can).
pub fn is_mitsuba(path: &Path, text: &str) -> bool {
    let xml_name = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"));
    xml_name
        || text
            .trim_start_matches('\u{feff}')
            .trim_start()
            .starts_with('<')
}

/// A Mitsuba scene as a pathmix TOML document.
#[derive(Clone, Debug)]
pub struct Converted {
    /// The pathmix scene; mesh paths are absolute.
    pub document: Table,
    /// The files the scene includes (`<include>`), each as often as included.
    pub includes: Vec<PathBuf>,
    /// Each approximation made, once.
    pub warnings: Vec<String>,
    /// The sampler the file names (or Mitsuba's default it leaves), where the
    /// scene samples with another: Mitsuba's `independent`, rendered with Sobol.
    pub file_sampler: Option<Sampler>,
    /// The element each object (`objects[i]`) and material came from, for messages.
    origins: Vec<(String, Origin)>,
    /// The `<sensor>`, for errors in `[camera]` and `[render]`.
    sensor: Origin,
}

impl Converted {
    /// Reads the scene at `path` with the `-D` parameters `defines`.
    pub fn read(path: &Path, defines: &[Define]) -> Result<Converted> {
        let top_dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut reader = Reader {
            params: defines
                .iter()
                .map(|d| (d.name.clone(), d.value.clone()))
                .collect(),
            used_params: HashSet::new(),
            search: vec![top_dir],
            includes: Vec::new(),
            files: Vec::new(),
            elements: 0,
            text_bytes: 0,
        };
        let elements = reader.read_file(path, None)?;
        let mut builder = Builder::new(path, &reader.search, &elements)?;
        for define in defines {
            if !reader.used_params.contains(&define.name) {
                builder.warn(format!(
                    "parameter `{}` given, but the scene has no `${}`",
                    define.name, define.name
                ));
            }
        }
        for element in &elements {
            builder.top_level(element)?;
        }
        let mut converted = builder.finish()?;
        converted.includes = reader.files.split_off(1);
        Ok(converted)
    }

    /// Each pathmix field (or table) the XML gives, and where: `file:line:col:
    /// <element>`.
    pub fn places(&self) -> Vec<(String, String)> {
        self.origins
            .iter()
            .map(|(field, origin)| {
                let place = format!(
                    "{}:{}:{}: {}",
                    origin.file, origin.line, origin.col, origin.element
                );
                (field.clone(), place)
            })
            .collect()
    }

    /// A parse error of the TOML document, placed at the XML element it came from.
    pub fn locate(&self, error: SceneError) -> SceneError {
        let origin = self
            .origins
            .iter()
            .find(|(prefix, _)| {
                error.location == *prefix
                    || error.location.starts_with(&format!("{prefix}."))
                    || error.location.starts_with(&format!("{prefix}["))
            })
            .map(|(_, origin)| origin)
            .or(match error.location.split('.').next() {
                Some("camera" | "render") => Some(&self.sensor),
                _ => None,
            });
        match origin {
            Some(origin) => origin.error(format!(
                "{} (pathmix field `{}`)",
                error.message, error.location
            )),
            None => error,
        }
    }

    /// The document as TOML text, mesh and map paths relative to `folder` where they can be.
    pub fn to_toml(&self, folder: &Path, source: &Path) -> String {
        let mut document = self.document.clone();
        let relative = |table: &mut Table| {
            if let Some(Value::String(file)) = table.get_mut("file") {
                let absolute = Path::new(file.as_str());
                if let Some(relative) = pathdiff::diff_paths(absolute, folder) {
                    *file = relative.to_string_lossy().into_owned();
                }
            }
        };
        if let Some(Value::Array(objects)) = document.get_mut("objects") {
            for object in objects {
                if let Value::Table(object) = object {
                    relative(object);
                }
            }
        }
        if let Some(Value::Array(groups)) = document.get_mut("groups") {
            let objects = groups.iter_mut().filter_map(|group| match group {
                Value::Table(group) => match group.get_mut("objects") {
                    Some(Value::Array(objects)) => Some(objects),
                    _ => None,
                },
                _ => None,
            });
            for object in objects.flatten() {
                if let Value::Table(object) = object {
                    relative(object);
                }
            }
        }
        if let Some(Value::Table(environment)) = document.get_mut("environment") {
            relative(environment);
        }
        if let Some(Value::Table(materials)) = document.get_mut("materials") {
            for (_, material) in materials.iter_mut() {
                if let Value::Table(material) = material {
                    for (_, texture) in material.iter_mut() {
                        if let Value::Table(texture) = texture {
                            relative(texture);
                        }
                    }
                }
            }
        }
        let mut text = format!(
            "# Converted by pathmix {} from the Mitsuba scene {}.\n",
            env!("CARGO_PKG_VERSION"),
            source.display()
        );
        for warning in &self.warnings {
            let _ = writeln!(text, "# approximated: {warning}");
        }
        if let Some(sampler) = self.file_sampler {
            let _ = writeln!(
                text,
                "# the file's {sampler} sampler is pathmix's sobol: the same expected image \
                 with less noise (render.sampler = \"{sampler}\" for the file's)"
            );
        }
        text.push('\n');
        text + &toml::to_string(&document).expect("a TOML table serializes")
    }
}

// ---------------------------------------------------------------------------------
// Reading: files, includes and parameters into one owned element tree

/// Where an element is: file, line, column, and the element as the user wrote it.
#[derive(Clone, Debug)]
struct Origin {
    file: String,
    line: u32,
    col: u32,
    element: String,
}

impl Origin {
    fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError {
            file: format!("{}:{}:{}", self.file, self.line, self.col),
            location: self.element.clone(),
            message: message.into(),
        }
    }
}

#[derive(Clone, Debug)]
struct Elem {
    tag: String,
    attrs: Vec<(String, String)>,
    children: Vec<Elem>,
    origin: Origin,
}

impl Elem {
    fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    fn require(&self, name: &str) -> Result<&str> {
        self.attr(name)
            .ok_or_else(|| self.origin.error(format!("missing attribute `{name}`")))
    }

    fn name(&self) -> Option<&str> {
        self.attr("name")
    }

    fn ty(&self) -> &str {
        self.attr("type").unwrap_or("")
    }

    /// Only these attributes are allowed (no silent drops).
    fn check_attrs(&self, allowed: &[&str]) -> Result<()> {
        match self
            .attrs
            .iter()
            .find(|(n, _)| !allowed.contains(&n.as_str()))
        {
            Some((n, _)) => Err(self.origin.error(format!(
                "unknown attribute `{n}` (expected {})",
                allowed.join(", "),
                n = excerpt(n)
            ))),
            None => Ok(()),
        }
    }
}

struct Reader {
    params: HashMap<String, String>,
    used_params: HashSet<String>,
    /// Folders relative file names resolve against, latest `<path>` first.
    search: Vec<PathBuf>,
    /// The include chain, for cycles.
    includes: Vec<PathBuf>,
    /// Every file read, the scene's own first.
    files: Vec<PathBuf>,
    /// Elements read so far, each inclusion counted again (`MAX_ELEMENTS`).
    elements: usize,
    /// Text read so far, each inclusion counted again (`MAX_TEXT_BYTES`).
    text_bytes: usize,
}

impl Reader {
    /// The top-level elements of the scene file at `path`, includes expanded in place.
    fn read_file(&mut self, path: &Path, from: Option<&Origin>) -> Result<Vec<Elem>> {
        let file = path.display().to_string();
        let whole_file = |message: String| match from {
            Some(origin) => origin.error(message),
            None => SceneError {
                file: file.clone(),
                location: String::new(),
                message,
            },
        };
        let text = crate::paths::read_input_text(path)
            .map_err(|e| whole_file(format!("cannot read `{file}`: {e}")))?;
        self.files.push(path.to_path_buf());
        self.text_bytes += text.len();
        if self.text_bytes > MAX_TEXT_BYTES {
            return Err(whole_file(format!(
                "more than {MAX_TEXT_BYTES} bytes of XML in the scene and the files it \
                 includes, each inclusion counted (are files included many times over?)"
            )));
        }
        let document = roxmltree::Document::parse(&text).map_err(|e| {
            let pos = e.pos();
            SceneError {
                file: format!("{file}:{}:{}", pos.row, pos.col),
                location: String::new(),
                message: format!("malformed XML: {e}"),
            }
        })?;
        let root = document.root_element();
        let root_origin = origin_of(&file, &document, root);
        let Some(version) = root
            .attribute("version")
            .filter(|_| root.tag_name().name() == "scene")
        else {
            return Err(root_origin
                .error("not a Mitsuba scene: the root element must be <scene version=\"...\">"));
        };
        let major = check_version(version).map_err(|message| root_origin.error(message))?;
        // Before `element` recurses into them.
        if let Some(node) = nested_too_deep(&document) {
            return Err(origin_of(&file, &document, node).error(format!(
                "elements nested more than {MAX_NESTING} deep (pathmix reads at most \
                 {MAX_NESTING} levels)"
            )));
        }
        self.count_element(&root_origin)?;
        let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        self.includes.push(canonical);
        let mut out = Vec::new();
        for node in root.children() {
            if let Some(text) = node.text().filter(|_| node.is_text()) {
                if !text.trim().is_empty() {
                    return Err(
                        root_origin.error(format!("unexpected text `{}`", excerpt(text.trim())))
                    );
                }
            }
            if !node.is_element() {
                continue;
            }
            let mut elem = self.element(&file, &document, node)?;
            if upgrade::UPGRADED_VERSIONS.contains(&major) {
                upgrade::upgrade(&mut elem)?;
            }
            match elem.tag.as_str() {
                "default" => {
                    elem.check_attrs(&["name", "value"])?;
                    let name = elem.require("name")?;
                    let value = elem.require("value")?;
                    self.params
                        .entry(name.to_string())
                        .or_insert_with(|| value.to_string());
                }
                "path" => {
                    elem.check_attrs(&["value"])?;
                    let folder = self
                        .search
                        .last()
                        .expect("the top folder")
                        .join(elem.require("value")?);
                    self.search.insert(0, folder);
                }
                "include" => {
                    elem.check_attrs(&["filename"])?;
                    let name = elem.require("filename")?;
                    let included = resolve(&self.search, name).ok_or_else(|| {
                        elem.origin.error(format!(
                            "cannot find the included file `{name}`",
                            name = excerpt(name)
                        ))
                    })?;
                    let canonical = included.canonicalize().unwrap_or_else(|_| included.clone());
                    if self.includes.contains(&canonical) {
                        return Err(elem.origin.error(format!(
                            "include cycle: `{}` is already being read",
                            included.display()
                        )));
                    }
                    out.extend(self.read_file(&included, Some(&elem.origin))?);
                }
                _ => out.push(elem),
            }
        }
        self.includes.pop();
        Ok(out)
    }

    /// An element and its children as owned values, `$name` substituted.
    fn element(
        &mut self,
        file: &str,
        document: &roxmltree::Document,
        node: roxmltree::Node,
    ) -> Result<Elem> {
        let origin = origin_of(file, document, node);
        self.count_element(&origin)?;
        let mut attrs = Vec::new();
        for a in node.attributes() {
            attrs.push((a.name().to_string(), self.substitute(a.value(), &origin)?));
        }
        let mut children = Vec::new();
        for child in node.children() {
            if child.is_text() && !child.text().unwrap_or("").trim().is_empty() {
                return Err(origin.error("unexpected text inside the element"));
            }
            if child.is_element() {
                children.push(self.element(file, document, child)?);
            }
        }
        let mut origin = origin;
        // Shown with the substituted values, as Mitsuba's own messages do.
        origin.element = describe(node.tag_name().name(), &attrs);
        Ok(Elem {
            tag: node.tag_name().name().to_string(),
            attrs,
            children,
            origin,
        })
    }

    /// Counts one more element read (`MAX_ELEMENTS`).
    fn count_element(&mut self, origin: &Origin) -> Result<()> {
        self.elements += 1;
        if self.elements > MAX_ELEMENTS {
            return Err(origin.error(format!(
                "more than {MAX_ELEMENTS} elements in the scene and the files it includes, \
                 each inclusion counted (are files included many times over?)"
            )));
        }
        Ok(())
    }

    /// `value` with every `$name` replaced by its `-D` or `<default>` value.
    fn substitute(&mut self, value: &str, origin: &Origin) -> Result<String> {
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(at) = rest.find('$') {
            out.push_str(&rest[..at]);
            let after = &rest[at + 1..];
            let end = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..end];
            if name.is_empty() {
                return Err(origin.error(format!(
                    "`$` without a parameter name in `{}`",
                    excerpt(value)
                )));
            }
            match self.params.get(name) {
                Some(v) => out.push_str(v),
                None => {
                    return Err(origin.error(format!(
                        "`${name}` has no value: give the parameter `{name}` a value, or the \
                         scene a <default name=\"{name}\" value=\"...\"/>"
                    )));
                }
            }
            self.used_params.insert(name.to_string());
            rest = &after[end..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// The major version of a `<scene version="...">` pathmix reads: `MAJOR.MINOR.PATCH`,
/// of a major version in `VERSIONS` or `upgrade::UPGRADED_VERSIONS`.
fn check_version(version: &str) -> std::result::Result<u32, String> {
    let numbers: Option<Vec<u32>> = version.trim().split('.').map(|n| n.parse().ok()).collect();
    match numbers.as_deref() {
        Some(&[major, _, _])
            if VERSIONS.contains(&major) || upgrade::UPGRADED_VERSIONS.contains(&major) =>
        {
            Ok(major)
        }
        Some(&[major, _, _]) => Err(format!(
            "version `{version}`: a Mitsuba {major} scene, whose format pathmix does not read \
             (it reads the scenes of Mitsuba 0.x to 3.x)"
        )),
        _ => Err(format!(
            "version `{}` is not MAJOR.MINOR.PATCH (such as 3.0.0)",
            excerpt(version)
        )),
    }
}

/// The first node nested more than `MAX_NESTING` deep, found without recursing.
fn nested_too_deep<'a, 'input>(
    document: &'a roxmltree::Document<'input>,
) -> Option<roxmltree::Node<'a, 'input>> {
    // Nodes come in document order, each after its parent.
    let mut depths = vec![0usize; document.descendants().count()];
    for node in document.descendants() {
        let depth = node.parent().map_or(0, |p| depths[p.id().get_usize()] + 1);
        if depth > MAX_NESTING {
            return Some(node);
        }
        depths[node.id().get_usize()] = depth;
    }
    None
}

fn origin_of(file: &str, document: &roxmltree::Document, node: roxmltree::Node) -> Origin {
    let pos = document.text_pos_at(node.range().start);
    let attrs: Vec<(String, String)> = node
        .attributes()
        .map(|a| (a.name().to_string(), a.value().to_string()))
        .collect();
    Origin {
        file: file.to_string(),
        line: pos.row,
        col: pos.col,
        element: describe(node.tag_name().name(), &attrs),
    }
}

/// `<shape type="obj">`: the element's tag with its `type`, `name` or `id`.
fn describe(tag: &str, attrs: &[(String, String)]) -> String {
    let mut s = format!("<{}", excerpt(tag));
    for key in ["type", "name", "id"] {
        if let Some((_, v)) = attrs.iter().find(|(n, _)| n == key) {
            let _ = write!(s, " {key}=\"{}\"", excerpt(v));
        }
    }
    s + ">"
}

/// A file name against the search folders (an absolute name as it is).
fn resolve(search: &[PathBuf], name: &str) -> Option<PathBuf> {
    let path = Path::new(name);
    if path.is_absolute() {
        return path.exists().then(|| path.to_path_buf());
    }
    search.iter().map(|d| d.join(path)).find(|p| p.exists())
}

// ---------------------------------------------------------------------------------
// Properties

/// An object's property and nested-object children, each of which must be used.
struct Props<'e> {
    elem: &'e Elem,
    used: Vec<bool>,
    /// Where a `<spectrum filename>` is looked for (as meshes are).
    search: &'e [PathBuf],
}

const PROPERTY_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

impl<'e> Props<'e> {
    fn new(elem: &'e Elem, search: &'e [PathBuf]) -> Props<'e> {
        Props {
            elem,
            used: vec![false; elem.children.len()],
            search,
        }
    }

    /// The property child called `name`.
    fn get(&mut self, name: &str) -> Option<&'e Elem> {
        let i = self
            .elem
            .children
            .iter()
            .position(|c| PROPERTY_TAGS.contains(&c.tag.as_str()) && c.name() == Some(name))?;
        self.used[i] = true;
        Some(&self.elem.children[i])
    }

    /// The nested objects (`<bsdf>`, `<ref>`, ...) among the children.
    fn objects(&mut self, tags: &[&str]) -> Vec<&'e Elem> {
        let mut out = Vec::new();
        for (i, c) in self.elem.children.iter().enumerate() {
            if tags.contains(&c.tag.as_str()) {
                self.used[i] = true;
                out.push(c);
            }
        }
        out
    }

    fn value(&mut self, name: &str, tag: &str) -> Result<Option<&'e Elem>> {
        match self.get(name) {
            Some(e) if e.tag == tag => Ok(Some(e)),
            Some(e) => Err(e.origin.error(format!("expected <{tag} name=\"{name}\">"))),
            None => Ok(None),
        }
    }

    fn float(&mut self, name: &str) -> Result<Option<f64>> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        if !matches!(e.tag.as_str(), "float" | "integer") {
            return Err(e.origin.error(format!("expected <float name=\"{name}\">")));
        }
        e.check_attrs(&["name", "value"])?;
        number(e, e.require("value")?).map(Some)
    }

    fn integer(&mut self, name: &str) -> Result<Option<i64>> {
        let Some(e) = self.value(name, "integer")? else {
            return Ok(None);
        };
        e.check_attrs(&["name", "value"])?;
        let v = e.require("value")?;
        v.trim().parse().map(Some).map_err(|_| {
            e.origin
                .error(format!("`value=\"{}\"` is not an integer", excerpt(v)))
        })
    }

    fn boolean(&mut self, name: &str) -> Result<Option<bool>> {
        let Some(e) = self.value(name, "boolean")? else {
            return Ok(None);
        };
        e.check_attrs(&["name", "value"])?;
        match e.require("value")?.trim() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            v => Err(e.origin.error(format!(
                "`value=\"{}\"` is not `true` or `false`",
                excerpt(v)
            ))),
        }
    }

    fn string(&mut self, name: &str) -> Result<Option<(&'e str, &'e Elem)>> {
        let Some(e) = self.value(name, "string")? else {
            return Ok(None);
        };
        e.check_attrs(&["name", "value"])?;
        Ok(Some((e.require("value")?, e)))
    }

    /// An emitter's colour: as `color`, except that a `<spectrum>` is read as
    /// Mitsuba's RGB variants read emission ([`Role::Emission`]).
    fn emitted(&mut self, name: &str) -> Result<Option<[f64; 3]>> {
        self.color_for(name, Role::Emission)
    }

    /// A colour: `<rgb>`, `<spectrum>` (read as a reflectance) or a `<float>` (grey).
    fn color(&mut self, name: &str) -> Result<Option<[f64; 3]>> {
        self.color_for(name, Role::Reflectance)
    }

    /// A colour, a `<spectrum>` read for `role`.
    fn color_for(&mut self, name: &str, role: Role) -> Result<Option<[f64; 3]>> {
        // One `Builder::texturable` took is no longer a problem.
        if let Some((_, texture)) = self.elem.children.iter().enumerate().find(|&(i, c)| {
            matches!(c.tag.as_str(), "texture" | "ref") && c.name() == Some(name) && !self.used[i]
        }) {
            return Err(texture.origin.error(
                "a texture here is not supported: pathmix textures diffuse `reflectance`, \
                 plastics' `diffuse_reflectance` and conductors' and roughdielectric's \
                 `specular_reflectance`; give a constant <rgb>",
            ));
        }
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        if e.tag == "spectrum" {
            return self.spectrum(e, role).map(Some);
        }
        e.check_attrs(&["name", "value"])?;
        let text = e.require("value")?;
        match e.tag.as_str() {
            "rgb" => {
                let values = numbers(e, text)?;
                match values[..] {
                    [g] => Ok(Some([g; 3])),
                    [r, g, b] => Ok(Some([r, g, b])),
                    _ => Err(e
                        .origin
                        .error(format!("expected 1 or 3 numbers, got {}", values.len()))),
                }
            }
            "float" => Ok(Some([number(e, text)?; 3])),
            _ => Err(e.origin.error(format!("expected <rgb name=\"{name}\">"))),
        }
    }

    /// A `<spectrum>`'s colour as Mitsuba's RGB variants read it for `role`
    /// (src/scene/spectrum.rs): a `value` (one number or `wavelength:value`
    /// pairs), a `filename` (an `.spd` file, found as meshes are) or a `type` of
    /// spectrum plugin.
    fn spectrum(&self, e: &Elem, role: Role) -> Result<[f64; 3]> {
        if e.attr("type").is_some() {
            return self.spectrum_plugin(e, role);
        }
        e.check_attrs(&["name", "value", "filename"])?;
        let spectrum = match (e.attr("value"), e.attr("filename")) {
            (Some(text), None) => Spectrum::parse(text),
            (None, Some(name)) => {
                let path = resolve(self.search, name).ok_or_else(|| {
                    e.origin.error(format!(
                        "cannot find the spectrum file `{name}`",
                        name = excerpt(name)
                    ))
                })?;
                Spectrum::read_spd(&path)
            }
            _ => {
                return Err(e
                    .origin
                    .error("give either a `value` or a `filename` (as Mitsuba)"));
            }
        };
        spectrum
            .map(|s| s.rgb(role))
            .map_err(|message| e.origin.error(message))
    }

    /// A `<spectrum type="...">`, one of Mitsuba's spectrum plugins: `uniform`,
    /// `srgb` and `d65` as Mitsuba's RGB variants evaluate them (a plugin stays
    /// itself in an emitter: a uniform one is grey there); `irregular` and
    /// `regular`, which those variants cannot evaluate, as they read the same
    /// samples written as `value="wavelength:value, ..."`; `blackbody`, which
    /// only emits, as [`spectrum::blackbody_rgb`].
    fn spectrum_plugin(&self, e: &Elem, role: Role) -> Result<[f64; 3]> {
        e.check_attrs(&["type", "name"])?;
        let mut props = Props::new(e, self.search);
        let missing =
            |tag: &str, name: &str| e.origin.error(format!("missing <{tag} name=\"{name}\">"));
        let sampled = |spectrum: std::result::Result<Spectrum, String>| {
            spectrum
                .map(|s| s.rgb(role))
                .map_err(|message| e.origin.error(message))
        };
        let rgb = match e.ty() {
            "uniform" => {
                let value = props.float("value")?;
                [value.ok_or_else(|| missing("float", "value"))?; 3]
            }
            "srgb" => {
                let color = props
                    .color("color")?
                    .ok_or_else(|| missing("rgb", "color"))?;
                let unbounded = props.boolean("unbounded")?.unwrap_or(false);
                if !unbounded && color.iter().any(|c| !(0.0..=1.0).contains(c)) {
                    return Err(e.origin.error(format!(
                        "the colour {color:?} is not in [0, 1] (Mitsuba's `srgb` takes one \
                         outside only with <boolean name=\"unbounded\" value=\"true\"/>)"
                    )));
                }
                color
            }
            "d65" => {
                let scale = props.float("scale")?.unwrap_or(1.0);
                props.color("color")?.unwrap_or([1.0; 3]).map(|c| c * scale)
            }
            "irregular" => {
                let (wavelengths, _) = props
                    .string("wavelengths")?
                    .ok_or_else(|| missing("string", "wavelengths"))?;
                let (values, _) = props
                    .string("values")?
                    .ok_or_else(|| missing("string", "values"))?;
                sampled(Spectrum::from_lists(wavelengths, values))?
            }
            "regular" => {
                let (values, _) = props
                    .string("values")?
                    .ok_or_else(|| missing("string", "values"))?;
                let min = props
                    .float("wavelength_min")?
                    .ok_or_else(|| missing("float", "wavelength_min"))?;
                let max = props
                    .float("wavelength_max")?
                    .ok_or_else(|| missing("float", "wavelength_max"))?;
                sampled(Spectrum::regular(values, min, max))?
            }
            "blackbody" => {
                if role != Role::Emission {
                    return Err(e.origin.error(
                        "a black body is an emission spectrum: it goes in an emitter's radiance \
                         or intensity",
                    ));
                }
                let temperature = props
                    .float("temperature")?
                    .ok_or_else(|| missing("float", "temperature"))?;
                if temperature <= 0.0 {
                    return Err(e
                        .origin
                        .error(format!("the temperature must be > 0 K, got {temperature}")));
                }
                let min = props.float("wavelength_min")?.unwrap_or(360.0);
                let max = props.float("wavelength_max")?.unwrap_or(830.0);
                spectrum::blackbody_rgb(temperature, [min, max])
            }
            _ => {
                return Err(e.origin.error(
                    "not supported (supported spectra: uniform, srgb, d65, irregular, regular, \
                     blackbody)",
                ));
            }
        };
        props.finish()?;
        Ok(rgb)
    }

    fn point(&mut self, name: &str) -> Result<Option<DVec3>> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        if !matches!(e.tag.as_str(), "point" | "vector") {
            return Err(e.origin.error(format!("expected <point name=\"{name}\">")));
        }
        vector_of(e, 0.0).map(Some)
    }

    fn transform(&mut self, name: &str) -> Result<DMat4> {
        match self.value(name, "transform")? {
            Some(e) => transform(e),
            None => Ok(DMat4::IDENTITY),
        }
    }

    /// The `<texture name="NAME">` or `<ref name="NAME">` child, if any.
    fn texture(&mut self, name: &str) -> Option<&'e Elem> {
        let i =
            self.elem.children.iter().position(|c| {
                matches!(c.tag.as_str(), "texture" | "ref") && c.name() == Some(name)
            })?;
        self.used[i] = true;
        Some(&self.elem.children[i])
    }

    /// Errors on the first child nothing used.
    fn finish(self) -> Result<()> {
        match self.used.iter().position(|&u| !u) {
            Some(i) => {
                let child = &self.elem.children[i];
                Err(child.origin.error(format!(
                    "not supported in {} (pathmix would have to ignore it)",
                    self.elem.origin.element
                )))
            }
            None => Ok(()),
        }
    }
}

fn number(e: &Elem, text: &str) -> Result<f64> {
    match text.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(e
            .origin
            .error(format!("`{}` is not a finite number", excerpt(text.trim())))),
    }
}

/// Numbers separated by commas and/or spaces.
fn numbers(e: &Elem, text: &str) -> Result<Vec<f64>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| number(e, s))
        .collect()
}

fn three(e: &Elem, text: &str) -> Result<DVec3> {
    match numbers(e, text)?[..] {
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        ref other => Err(e.origin.error(format!(
            "expected 3 numbers, got {} in `{}`",
            other.len(),
            excerpt(text)
        ))),
    }
}

/// `value="x, y, z"` (or one number for all three, as Mitsuba's
/// `expand_value_to_xyz` reads it) or `x=".." y=".." z=".."` (each defaulting to
/// `default`).
fn vector_of(e: &Elem, default: f64) -> Result<DVec3> {
    if let Some(v) = e.attr("value") {
        return match numbers(e, v)?[..] {
            [x] => Ok(DVec3::splat(x)),
            [x, y, z] => Ok(DVec3::new(x, y, z)),
            ref other => Err(e.origin.error(format!(
                "expected 1 or 3 numbers, got {} in `{}`",
                other.len(),
                excerpt(v)
            ))),
        };
    }
    let axis = |name: &str| e.attr(name).map_or(Ok(default), |v| number(e, v));
    Ok(DVec3::new(axis("x")?, axis("y")?, axis("z")?))
}

// ---------------------------------------------------------------------------------
// Transforms

/// A `<transform>`: its operations composed in Mitsuba's order, each applied after
/// the ones before it.
fn transform(e: &Elem) -> Result<DMat4> {
    e.check_attrs(&["name"])?;
    let mut m = DMat4::IDENTITY;
    for op in &e.children {
        let step = match op.tag.as_str() {
            "translate" => {
                op.check_attrs(&["x", "y", "z", "value"])?;
                DMat4::from_translation(vector_of(op, 0.0)?)
            }
            "scale" => {
                op.check_attrs(&["x", "y", "z", "value"])?;
                DMat4::from_scale(vector_of(op, 1.0)?)
            }
            "rotate" => {
                op.check_attrs(&["x", "y", "z", "value", "angle"])?;
                let axis = vector_of(op, 0.0)?;
                let angle = number(op, op.require("angle")?)?;
                if axis.length_squared() == 0.0 {
                    return Err(op.origin.error("the rotation axis must not be zero"));
                }
                rotation(axis.normalize(), angle)
            }
            "matrix" => {
                op.check_attrs(&["value"])?;
                let v = numbers(op, op.require("value")?)?;
                let rows: Vec<DVec4> = match v.len() {
                    16 => v
                        .chunks(4)
                        .map(|r| DVec4::new(r[0], r[1], r[2], r[3]))
                        .collect(),
                    9 => v
                        .chunks(3)
                        .map(|r| DVec4::new(r[0], r[1], r[2], 0.0))
                        .chain([DVec4::W])
                        .collect(),
                    n => {
                        return Err(op
                            .origin
                            .error(format!("expected 9 or 16 numbers, got {n}")));
                    }
                };
                if rows[3] != DVec4::W {
                    return Err(op.origin.error(
                        "a projective matrix is not supported: its last row must be 0, 0, 0, 1",
                    ));
                }
                DMat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose()
            }
            "lookat" => {
                op.check_attrs(&["origin", "target", "up"])?;
                let origin = three(op, op.require("origin")?)?;
                let target = three(op, op.require("target")?)?;
                let dir = (target - origin).normalize();
                let up = match op.attr("up") {
                    Some(v) => three(op, v)?,
                    None => DVec3::ZERO,
                };
                // Without an `up` (or a zero one), Mitsuba takes one across the view.
                let up = if up == DVec3::ZERO {
                    coordinate_system(dir).0
                } else {
                    up
                };
                let left = up.cross(dir);
                if !dir.is_finite() || left.length() <= 1e-9 * up.length() {
                    return Err(op.origin.error(
                        "origin and target must differ, and up must not be parallel to the view",
                    ));
                }
                let left = left.normalize();
                let new_up = dir.cross(left);
                DMat4::from_cols(
                    left.extend(0.0),
                    new_up.extend(0.0),
                    dir.extend(0.0),
                    origin.extend(1.0),
                )
            }
            other => {
                return Err(op.origin.error(format!(
                    "unknown transform `{other}` (supported: translate, rotate, scale, matrix, lookat)",
                    other = excerpt(other)
                )));
            }
        };
        m = step * m;
    }
    if !m.is_finite() || m.determinant() == 0.0 {
        return Err(e.origin.error("the transform is singular"));
    }
    Ok(m)
}

/// A right-handed rotation about the unit `axis` by `degrees` (Rodrigues' formula,
/// exact at multiples of 90 degrees).
fn rotation(axis: DVec3, degrees: f64) -> DMat4 {
    let (sin, cos) = sin_cos_degrees(degrees);
    let k = axis;
    let cross = glam::DMat3::from_cols(
        DVec3::new(0.0, k.z, -k.y),
        DVec3::new(-k.z, 0.0, k.x),
        DVec3::new(k.y, -k.x, 0.0),
    );
    let r = glam::DMat3::IDENTITY * cos
        + cross * sin
        + glam::DMat3::from_cols(k * k.x, k * k.y, k * k.z) * (1.0 - cos);
    DMat4::from_mat3(r)
}

/// Row-major, as `matrix` in a pathmix scene.
fn row_major(m: &DMat4) -> Value {
    let t = m.transpose().to_cols_array();
    Value::Array(t.iter().map(|&x| Value::Float(x)).collect())
}

fn vec_value(v: DVec3) -> Value {
    Value::Array(v.to_array().iter().map(|&x| Value::Float(x)).collect())
}

fn color_value(c: [f64; 3]) -> Value {
    Value::Array(c.iter().map(|&x| Value::Float(x)).collect())
}

// ---------------------------------------------------------------------------------
// Interpretation

/// A surface as pathmix can render it.
#[derive(Clone, Debug, PartialEq)]
enum Surface {
    /// `one_sided`: outside a `twosided`, black from behind (as all of these
    /// but the dielectrics, which scatter from both sides by nature).
    Lambertian {
        /// A colour or a texture table.
        albedo: Value,
        one_sided: bool,
        /// From an enclosing `bumpmap` or `normalmap`: the material key
        /// (`bump`, `normal_map`) and its value.
        bump: Option<(&'static str, Value)>,
    },
    /// One of pathmix's microfacet-era materials, named and parameterised as
    /// Mitsuba's plugin of the same name: its TOML table, `type` included.
    Mitsuba {
        table: Table,
        transmits: bool,
        one_sided: bool,
    },
    /// A material made of others (`twosided` with two BSDFs, `blendbsdf`), which are in
    /// the document's materials already: its TOML table, `type` included;
    /// `textured`: whether one of those is.
    Nested { table: Table, textured: bool },
}

/// A `twosided` of two materials (`nested_material`'s names and whether
/// each is textured): the first on the front, the second (seeing the flipped
/// frame, as one-sided as it is alone) on the back.
fn twosided_pair(
    (front, front_textured): (String, bool),
    (back, back_textured): (String, bool),
) -> (Surface, Opacity) {
    let mut table = Table::new();
    table.insert("type".into(), Value::String("twosided".into()));
    table.insert("front".into(), Value::String(front));
    table.insert("back".into(), Value::String(back));
    (
        Surface::Nested {
            table,
            textured: front_textured || back_textured,
        },
        Opacity::OPAQUE,
    )
}

/// A surface's material table, as a BSDF inside another's (no emission, no
/// opacity: those are the outer material's).
fn surface_table(surface: &Surface) -> Table {
    match surface {
        Surface::Lambertian {
            albedo,
            one_sided,
            bump,
        } => {
            let mut table = Table::new();
            table.insert("type".into(), Value::String("lambertian".into()));
            table.insert("albedo".into(), albedo.clone());
            if let Some((key, value)) = bump {
                table.insert(key.to_string(), value.clone());
            }
            if *one_sided {
                table.insert("one_sided".into(), Value::Boolean(true));
            }
            table
        }
        Surface::Mitsuba {
            table, one_sided, ..
        } => {
            let mut table = table.clone();
            if *one_sided {
                table.insert("one_sided".into(), Value::Boolean(true));
            }
            table
        }
        Surface::Nested { table, .. } => table.clone(),
    }
}

/// A surface's opacity (Mitsuba's `mask`): a number in [0, 1], or a texture
/// (the TOML texture table it is read as) whose luminance it is.
#[derive(Clone, Debug, PartialEq)]
enum Opacity {
    Constant(f64),
    Texture(Value),
}

impl Opacity {
    const OPAQUE: Opacity = Opacity::Constant(1.0);

    fn is_opaque(&self) -> bool {
        *self == Opacity::OPAQUE
    }

    /// The opacity of a mask of this opacity around a BSDF of `inner`'s: the
    /// surface is there where each of them is, independently, so constants
    /// multiply. A texture stays alone (pathmix's opacity texture has no
    /// factor): with another mask below 1 it is refused at `e`.
    fn times(self, inner: Opacity, e: &Elem) -> Result<Opacity> {
        match (self, inner) {
            (Opacity::Constant(a), Opacity::Constant(b)) => Ok(Opacity::Constant(a * b)),
            (texture, Opacity::Constant(1.0)) | (Opacity::Constant(1.0), texture) => Ok(texture),
            _ => Err(e.origin.error(
                "a mask with a textured opacity inside or around another mask is not \
                 supported (give one mask the product)",
            )),
        }
    }

    /// The material's `opacity` value, where it is not opaque.
    fn value(&self) -> Option<Value> {
        match self {
            Opacity::Constant(o) if *o >= 1.0 => None,
            Opacity::Constant(o) => Some(Value::Float(*o)),
            Opacity::Texture(table) => Some(table.clone()),
        }
    }
}

impl Surface {
    /// Whether one of its colours is a texture (a table among its values).
    fn is_textured(&self) -> bool {
        match self {
            Surface::Lambertian { albedo, bump, .. } => albedo.is_table() || bump.is_some(),
            Surface::Mitsuba { table, .. } => table.values().any(Value::is_table),
            Surface::Nested { textured, .. } => *textured,
        }
    }
}

struct Builder<'a> {
    file: String,
    search: &'a [PathBuf],
    ids: HashMap<&'a str, &'a Elem>,
    warnings: Vec<String>,
    integrator: Option<&'a Elem>,
    sensor: Option<&'a Elem>,
    /// `render.background`, from a `constant` emitter, and where it was.
    background: Option<([f64; 3], Origin)>,
    /// `[environment]`, from an `envmap` emitter, and where it was.
    environment: Option<(Table, Origin)>,
    materials: Table,
    objects: Vec<Value>,
    /// Where `objects` go in the document: `objects`, or a group's while its
    /// shapes are read (`groups[0].objects`).
    objects_path: String,
    /// `[[groups]]`, from `shapegroup`s.
    groups: Vec<Value>,
    /// A shapegroup's shapes are being read: instances and emitters are refused.
    in_group: bool,
    /// `[[lights]]`, from `point` and `spot` emitters.
    lights: Vec<Value>,
    origins: Vec<(String, Origin)>,
    anonymous: usize,
    /// `Converted::file_sampler`.
    file_sampler: Option<Sampler>,
}

impl<'a> Builder<'a> {
    fn new(path: &Path, search: &'a [PathBuf], elements: &'a [Elem]) -> Result<Builder<'a>> {
        let mut ids: HashMap<&str, &Elem> = HashMap::new();
        fn collect<'a>(e: &'a Elem, ids: &mut HashMap<&'a str, &'a Elem>) -> Result<()> {
            if e.tag != "ref" {
                if let Some(id) = e.attr("id") {
                    if let Some(before) = ids.insert(id, e) {
                        return Err(e.origin.error(format!(
                            "the id `{id}` is already used at {}:{}:{}",
                            before.origin.file,
                            before.origin.line,
                            before.origin.col,
                            id = excerpt(id)
                        )));
                    }
                }
            }
            e.children.iter().try_for_each(|c| collect(c, ids))
        }
        for e in elements {
            collect(e, &mut ids)?;
        }
        Ok(Builder {
            file: path.display().to_string(),
            search,
            ids,
            warnings: Vec::new(),
            integrator: None,
            sensor: None,
            background: None,
            environment: None,
            materials: Table::new(),
            objects: Vec::new(),
            objects_path: "objects".into(),
            groups: Vec::new(),
            in_group: false,
            lights: Vec::new(),
            origins: Vec::new(),
            anonymous: 0,
            file_sampler: None,
        })
    }

    fn warn(&mut self, warning: String) {
        if !self.warnings.contains(&warning) {
            self.warnings.push(warning);
        }
    }

    /// `e`, or the element a `<ref id="...">` names.
    fn resolve(&self, e: &'a Elem) -> Result<&'a Elem> {
        if e.tag != "ref" {
            return Ok(e);
        }
        e.check_attrs(&["id", "name"])?;
        let id = e.require("id")?;
        self.ids.get(id).copied().ok_or_else(|| {
            e.origin
                .error(format!("no element has the id `{id}`", id = excerpt(id)))
        })
    }

    fn top_level(&mut self, e: &'a Elem) -> Result<()> {
        match e.tag.as_str() {
            "integrator" | "sensor" => {
                let slot = if e.tag == "sensor" {
                    &mut self.sensor
                } else {
                    &mut self.integrator
                };
                if let Some(before) = slot {
                    return Err(e.origin.error(format!(
                        "a second <{}> (the first is at line {}): pathmix renders one",
                        e.tag, before.origin.line
                    )));
                }
                *slot = Some(e);
                Ok(())
            }
            "shape" => self.shape(e),
            // Definitions, used through <ref>; checked here so errors show even if
            // unused (as twosided: a one-sided use warns where a shape makes it).
            "bsdf" => self.surface(e, true).map(drop),
            "emitter" => match e.ty() {
                "area" if e.attr("id").is_some() => self.radiance(e).map(drop),
                "area" => Err(e
                    .origin
                    .error("an area emitter outside a shape needs an `id` for shapes to refer to")),
                "constant" => {
                    if self.background.is_some() || self.environment.is_some() {
                        return Err(e
                            .origin
                            .error("a second constant or envmap emitter: pathmix takes one"));
                    }
                    e.check_attrs(&["type", "id"])?;
                    let mut props = Props::new(e, self.search);
                    let radiance = props.emitted("radiance")?.unwrap_or([1.0; 3]);
                    props.finish()?;
                    // Where the value is, for the TOML parser's checks of it.
                    let at = e.children.iter().find(|c| c.name() == Some("radiance"));
                    let origin = at.map_or(&e.origin, |c| &c.origin).clone();
                    self.background = Some((radiance, origin));
                    Ok(())
                }
                "envmap" => self.envmap(e),
                "point" | "spot" => self.delta_light(e),
                "directional" => self.directional(e),
                _ => Err(e.origin.error(
                    "not supported (supported: area, constant, directional, envmap, point, spot)",
                )),
            },
            // A definition, used through <ref>; checked here as bsdfs are.
            "texture" => self.texture(e).map(drop),
            _ => Err(e.origin.error(format!(
                "not supported at the top level (supported: {SUPPORTED_TOP})"
            ))),
        }
    }

    /// `<emitter type="point">` and `"spot"`: a `[[lights]]` entry, which
    /// `kinds::PointLight` reads as it reads the TOML's. The position is
    /// `position` (point only) or `to_world`'s translation; a spot's axis is
    /// `to_world`'s z axis, its cone kept circular (Mitsuba's falloff is taken in
    /// the light's own frame, which a shear or an uneven scale would distort).
    fn delta_light(&mut self, e: &'a Elem) -> Result<()> {
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let ty = e.ty();
        let mut light = Table::new();
        light.insert("type".into(), Value::String(ty.into()));
        let intensity = props.emitted("intensity")?.unwrap_or([1.0; 3]);
        light.insert("intensity".into(), color_value(intensity));
        let position = if ty == "point" {
            props.point("position")?
        } else {
            None
        };
        let to_world = props.transform("to_world")?;
        let position = match position {
            Some(_) if to_world != DMat4::IDENTITY => {
                return Err(e
                    .origin
                    .error("give either `position` or `to_world`, not both (as Mitsuba)"));
            }
            Some(p) => p,
            None => to_world.transform_point3(DVec3::ZERO),
        };
        light.insert("position".into(), vec_value(position));
        if ty == "spot" {
            let axis = to_world.transform_vector3(DVec3::Z);
            light.insert("direction".into(), vec_value(axis));
            let linear = glam::DMat3::from_mat4(to_world);
            let gram = linear.transpose() * linear;
            let scale = gram.x_axis.x;
            let uneven = (gram - glam::DMat3::from_diagonal(DVec3::splat(scale)))
                .to_cols_array()
                .iter()
                .any(|x| x.abs() > 1e-6 * scale);
            if uneven {
                self.warn(format!(
                    "{}: the spot light's to_world shears or scales unevenly; pathmix keeps its \
                     cone circular around the transformed z axis",
                    e.origin.element
                ));
            }
            for name in ["cutoff_angle", "beam_width"] {
                if let Some(angle) = props.float(name)? {
                    light.insert(name.into(), Value::Float(angle));
                }
            }
        }
        props.finish()?;
        self.origins
            .push((format!("lights[{}]", self.lights.len()), e.origin.clone()));
        self.lights.push(Value::Table(light));
        Ok(())
    }

    /// `<emitter type="directional">`: `irradiance` (default 1) and `direction`
    /// or `to_world` (whose +z it shines along; not both, as Mitsuba) as a
    /// `[[lights]]` table of type `directional`.
    fn directional(&mut self, e: &'a Elem) -> Result<()> {
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let irradiance = props.emitted("irradiance")?.unwrap_or([1.0; 3]);
        let direction = props.point("direction")?;
        let to_world = props.transform("to_world")?;
        let direction = match direction {
            Some(_) if to_world != DMat4::IDENTITY => {
                return Err(e
                    .origin
                    .error("give either `direction` or `to_world`, not both (as Mitsuba)"));
            }
            Some(d) => d,
            None => to_world.transform_vector3(DVec3::Z),
        };
        if !(direction.length_squared() > 0.0 && direction.is_finite()) {
            let at = props.get("direction").unwrap_or(e);
            return Err(at.origin.error("the direction must not be zero"));
        }
        props.finish()?;
        let mut light = Table::new();
        light.insert("type".into(), Value::String("directional".into()));
        light.insert("direction".into(), vec_value(direction));
        light.insert("irradiance".into(), color_value(irradiance));
        self.origins
            .push((format!("lights[{}]", self.lights.len()), e.origin.clone()));
        self.lights.push(Value::Table(light));
        Ok(())
    }

    /// `<emitter type="envmap">`: `filename`, `scale` and `to_world` as
    /// `[environment]`'s `file`, `scale` and `matrix` (the same mapping onto the
    /// sphere and the same bilinear lookup).
    fn envmap(&mut self, e: &'a Elem) -> Result<()> {
        if self.background.is_some() || self.environment.is_some() {
            return Err(e
                .origin
                .error("a second constant or envmap emitter: pathmix takes one"));
        }
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let (name, at) = props
            .string("filename")?
            .ok_or_else(|| e.origin.error("missing <string name=\"filename\">"))?;
        let path = resolve(self.search, name).ok_or_else(|| {
            at.origin.error(format!(
                "cannot find the environment map `{name}`",
                name = excerpt(name)
            ))
        })?;
        let path = path.canonicalize().unwrap_or(path);
        let mut environment = Table::new();
        environment.insert(
            "file".into(),
            Value::String(path.to_string_lossy().into_owned()),
        );
        if let Some(scale) = props.float("scale")? {
            environment.insert("scale".into(), Value::Float(scale));
        }
        let to_world = props.transform("to_world")?;
        if to_world != DMat4::IDENTITY {
            environment.insert("matrix".into(), row_major(&to_world));
        }
        props.finish()?;
        self.environment = Some((environment, e.origin.clone()));
        Ok(())
    }

    /// The BSDF mapping: what each Mitsuba BSDF is in pathmix, and its opacity
    /// (below 1 inside a `mask`; masks inside masks multiply, as the surface is
    /// there where each of them is, independently). `twosided`: inside a
    /// `twosided` wrapper.
    fn surface(&mut self, e: &'a Elem, twosided: bool) -> Result<(Surface, Opacity)> {
        e.check_attrs(&["type", "id", "name"])?;
        let mut props = Props::new(e, self.search);
        let surface = match e.ty() {
            "diffuse" => {
                let albedo = self
                    .texturable(&mut props, "reflectance")?
                    .unwrap_or_else(|| color_value([0.5; 3]));
                (
                    Surface::Lambertian {
                        albedo,
                        one_sided: !twosided,
                        bump: None,
                    },
                    Opacity::OPAQUE,
                )
            }
            ty if mitsuba_kind(ty).is_some() => {
                let (model, plugin) = mitsuba_kind(ty).expect("matched");
                // A kind that cannot be one-sided has sides by nature: glass's inside.
                let transmits = !model.keys.contains(&"one_sided");
                let table = self.kind_table(model, plugin, &mut props)?;
                (
                    Surface::Mitsuba {
                        table,
                        transmits,
                        one_sided: !twosided && !transmits,
                    },
                    Opacity::OPAQUE,
                )
            }
            "twosided" => match props.objects(&["bsdf", "ref"])[..] {
                // A `principled` has its own back (the inside of what it
                // transmits; black where it transmits nothing, which is when
                // Mitsuba takes it in a `twosided`): its front on both sides.
                [inner] if self.resolve(inner)?.ty() == "principled" => {
                    let inner = self.nested_material(inner, false)?;
                    twosided_pair(inner.clone(), inner)
                }
                [inner] => {
                    let inner = self.resolve(inner)?;
                    self.surface(inner, true)?
                }
                [front, back] => {
                    let front = self.nested_material(front, false)?;
                    let back = self.nested_material(back, false)?;
                    twosided_pair(front, back)
                }
                _ => {
                    return Err(e.origin.error(
                        "a twosided BSDF with other than one or two nested BSDFs is not supported",
                    ));
                }
            },
            // Mitsuba's null lobe is two-sided whether or not its BSDF is, so a
            // `twosided` around a mask (which Mitsuba 3 refuses, as a BSDF that
            // transmits) reads as the same surface as one inside it.
            "mask" => {
                let opacity = match props.texture("opacity") {
                    // Its luminance, clamped to [0, 1] (Mitsuba's `eval_1`).
                    Some(reference) => {
                        let target = self.resolve(reference)?;
                        if target.tag != "texture" {
                            return Err(reference.origin.error(format!(
                                "`opacity` refers to a <{}>, not a <texture>",
                                target.tag
                            )));
                        }
                        Opacity::Texture(self.texture(target)?)
                    }
                    None => {
                        // Mitsuba's default.
                        let opacity = props.float("opacity")?.unwrap_or(0.5);
                        if !(0.0..=1.0).contains(&opacity) {
                            return Err(e
                                .origin
                                .error(format!("`opacity` must be in [0, 1], got {opacity}")));
                        }
                        Opacity::Constant(opacity)
                    }
                };
                // A `<ref name="opacity">` is the opacity's texture, not a BSDF.
                let inner: Vec<&Elem> = props
                    .objects(&["bsdf", "ref"])
                    .into_iter()
                    .filter(|c| c.name() != Some("opacity"))
                    .collect();
                let [inner] = inner[..] else {
                    return Err(e
                        .origin
                        .error("a mask BSDF with other than one nested BSDF is not supported"));
                };
                let inner = self.resolve(inner)?;
                let (surface, inner_opacity) = self.surface(inner, twosided)?;
                (surface, opacity.times(inner_opacity, e)?)
            }
            ty @ ("bumpmap" | "normalmap") => self.bumped(&mut props, ty, twosided)?,
            "blendbsdf" => (self.blend(&mut props, twosided)?, Opacity::OPAQUE),
            _ => {
                return Err(e
                    .origin
                    .error(format!("not supported (supported: {})", supported_bsdfs())));
            }
        };
        props.finish()?;
        Ok(surface)
    }

    /// Mitsuba's `blendbsdf`: `weight` (a float in [0, 1], default 0.5, or a
    /// texture) between two nested BSDFs, in document order (Mitsuba's, for
    /// nested BSDFs without a `name`; by name where both have one), each
    /// inside the same `twosided` as the blend.
    fn blend(&mut self, props: &mut Props<'a>, twosided: bool) -> Result<Surface> {
        let e = props.elem;
        // A `<ref name="weight">` is the weight's texture, not a BSDF.
        let mut children: Vec<&Elem> = props
            .objects(&["bsdf", "ref"])
            .into_iter()
            .filter(|c| c.name() != Some("weight"))
            .collect();
        let [_, _] = children[..] else {
            return Err(e
                .origin
                .error("a blendbsdf with other than two nested BSDFs is not supported"));
        };
        if let [Some(a), Some(b)] = [children[0].name(), children[1].name()]
            && b < a
        {
            children.swap(0, 1);
        }
        let weight = match props.texture("weight") {
            Some(reference) => {
                let target = self.resolve(reference)?;
                if target.tag != "texture" {
                    return Err(reference.origin.error(format!(
                        "`weight` refers to a <{}>, not a <texture>",
                        target.tag
                    )));
                }
                self.texture(target)?
            }
            None => {
                let weight = props.float("weight")?.unwrap_or(0.5);
                if !(0.0..=1.0).contains(&weight) {
                    return Err(e
                        .origin
                        .error(format!("`weight` must be in [0, 1], got {weight}")));
                }
                Value::Float(weight)
            }
        };
        let (first, first_textured) = self.nested_material(children[0], twosided)?;
        let (second, second_textured) = self.nested_material(children[1], twosided)?;
        let textured = weight.is_table() || first_textured || second_textured;
        let mut table = Table::new();
        table.insert("type".into(), Value::String("blend".into()));
        table.insert("weight".into(), weight);
        table.insert("first".into(), Value::String(first));
        table.insert("second".into(), Value::String(second));
        Ok(Surface::Nested { table, textured })
    }

    /// A BSDF inside one made of others (`twosided` with two, `blendbsdf`): its material,
    /// added to the document under its element's name (`~2` and on where that
    /// name holds another material already), and whether it is textured. It
    /// may not be masked: the surface's opacity is the outer material's.
    fn nested_material(&mut self, child: &'a Elem, twosided: bool) -> Result<(String, bool)> {
        let target = self.resolve(child)?;
        let (surface, opacity) = self.surface(target, twosided)?;
        if !opacity.is_opaque() {
            return Err(child.origin.error(
                "a mask inside a BSDF made of two is not supported: pathmix gives a surface one \
                 opacity, its outer material's, where this one would depend on the side hit or \
                 the BSDF the blend picks (a mask around the whole BSDF masks both alike)",
            ));
        }
        let table = surface_table(&surface);
        let base = self.name_of(target);
        let mut name = base.clone();
        for n in 2.. {
            match self.materials.get(&name) {
                Some(Value::Table(existing)) if *existing == table => {
                    return Ok((name, surface.is_textured()));
                }
                Some(_) => name = format!("{base}~{n}"),
                None => break,
            }
        }
        let origin = target.origin.clone();
        self.origins
            .push((format!("materials.{name}"), origin.clone()));
        self.origins.push((format!("materials.\"{name}\""), origin));
        self.materials.insert(name.clone(), Value::Table(table));
        Ok((name, surface.is_textured()))
    }

    /// Mitsuba's `bumpmap` (a height texture of any name, `scale`) or
    /// `normalmap` (its `normalmap` texture) around one nested BSDF: that
    /// BSDF's material with the key `bump` or `normal_map`
    /// (`kinds::Bump`). Mitsuba's defaults, `flip_invalid_normals` and
    /// `use_shadowing_function`, are pathmix's only way.
    fn bumped(
        &mut self,
        props: &mut Props<'a>,
        ty: &str,
        twosided: bool,
    ) -> Result<(Surface, Opacity)> {
        let e = props.elem;
        let mut bsdf = None;
        let mut texture = None;
        for child in props.objects(&["bsdf", "texture", "ref"]) {
            let target = self.resolve(child)?;
            let slot = match target.tag.as_str() {
                "bsdf" => &mut bsdf,
                "texture" => &mut texture,
                other => {
                    return Err(child.origin.error(format!(
                        "a {ty} takes one <bsdf> and one <texture>, not a <{other}>"
                    )));
                }
            };
            if slot.replace((child, target)).is_some() {
                return Err(child
                    .origin
                    .error(format!("a second <{}> in one {ty}", target.tag)));
            }
        }
        let (Some((_, bsdf)), Some((reference, texture))) = (bsdf, texture) else {
            return Err(e.origin.error(format!(
                "a {ty} takes exactly one nested <bsdf> and one <texture>"
            )));
        };
        if ty == "normalmap" && reference.name() != Some("normalmap") {
            return Err(reference
                .origin
                .error("a normalmap's texture is named `normalmap`"));
        }
        if texture.ty() != "bitmap" {
            return Err(texture.origin.error(format!(
                "a {ty}'s texture must be a bitmap (pathmix takes no other texture's gradient)"
            )));
        }
        let map = self.texture(texture)?;
        if props.boolean("flip_invalid_normals")? == Some(false) {
            return Err(e.origin.error(
                "flip_invalid_normals = false is not supported (pathmix always flips \
                 normals that face away from the viewer)",
            ));
        }
        if props.boolean("use_shadowing_function")? == Some(false) {
            return Err(e.origin.error(
                "use_shadowing_function = false is not supported (pathmix always applies \
                 the bump's shadowing term, Mitsuba's default)",
            ));
        }
        let bump = match ty {
            "bumpmap" => {
                let mut table = Table::new();
                table.insert("texture".into(), map);
                if let Some(scale) = props.float("scale")? {
                    table.insert("scale".into(), Value::Float(scale));
                }
                ("bump", Value::Table(table))
            }
            _ => ("normal_map", map),
        };
        let (mut surface, opacity) = self.surface(bsdf, twosided)?;
        let taken = match &mut surface {
            Surface::Lambertian { bump: slot, .. } => slot.replace(bump).is_some(),
            Surface::Mitsuba { table, .. } => {
                let taken = BUMP_KEYS.iter().any(|k| table.contains_key(*k));
                table.insert(bump.0.into(), bump.1);
                taken
            }
            Surface::Nested { .. } => {
                return Err(e.origin.error(
                    "a bumpmap or normalmap around a BSDF made of two is not supported (put \
                     it around each of them)",
                ));
            }
        };
        if taken {
            return Err(e
                .origin
                .error("a bumpmap or normalmap inside another is not supported"));
        }
        Ok((surface, opacity))
    }

    /// The colour property `name`: a constant (`[r, g, b]`), or a nested or
    /// referenced `<texture>` as the TOML texture table it means.
    fn texturable(&mut self, props: &mut Props<'a>, name: &str) -> Result<Option<Value>> {
        match props.texture(name) {
            Some(e) => self.texture_at(e, name).map(Some),
            None => Ok(props.color(name)?.map(color_value)),
        }
    }

    /// The nested or referenced `<texture>` `e` of the property `name`, as the
    /// TOML texture table it means.
    fn texture_at(&mut self, e: &'a Elem, name: &str) -> Result<Value> {
        let target = self.resolve(e)?;
        if target.tag != "texture" {
            return Err(e.origin.error(format!(
                "`{name}` refers to a <{}>, not a <texture>",
                target.tag,
                name = excerpt(name)
            )));
        }
        self.texture(target)
    }

    /// A BSDF that is a material kind (`mitsuba_kind`): the kind's table, each of
    /// its keys from the parameter of the same name as Mitsuba reads it: spectra
    /// (a conductor's `eta` and `k` unbounded, the others reflectances; the
    /// plugin's texture parameter a texture too), roughnesses, indices of
    /// refraction (numbers or Mitsuba's names), names and flags. An absent one
    /// takes the kind's default, which is Mitsuba's; a parameter the kind lacks
    /// is refused as unread (`Props::finish`).
    fn kind_table(
        &mut self,
        model: &MaterialModel,
        plugin: &MitsubaPlugin,
        props: &mut Props<'a>,
    ) -> Result<Table> {
        let mut table = Table::new();
        table.insert("type".into(), Value::String(model.name.into()));
        for &key in model.keys {
            let value = match key {
                // `one_sided` is the surface's (`twosided`); `material` below.
                "type" | "one_sided" | "material" => None,
                "alpha" | "alpha_u" | "alpha_v" => self.number(model, plugin, props, key)?,
                "distribution" => (props.string(key)?).map(|(d, _)| Value::String(d.into())),
                "nonlinear" => props.boolean(key)?.map(Value::Boolean),
                "int_ior" | "ext_ior" => ior(props, key)?.map(Value::Float),
                _ if plugin.texture == Some(key) => self.texturable(props, key)?,
                _ if plugin.numbers.contains(&key) => self.number(model, plugin, props, key)?,
                // Mitsuba reads a conductor's `eta` and `k` as unbounded textures.
                "eta" | "k" => (props.color_for(key, Role::Unbounded)?).map(color_value),
                _ => (props.color_for(key, Role::Reflectance)?).map(color_value),
            };
            if let Some(value) = value {
                table.insert(key.into(), value);
            }
        }
        if model.keys.contains(&"material") {
            conductor_preset(props, &mut table)?;
        }
        Ok(table)
    }

    /// The number `key` of a BSDF that is a material kind: a `<float>`, or a
    /// `<texture>` where Mitsuba reads it as one (the kind's
    /// `textured_numbers`), refused where Mitsuba reads a float.
    fn number(
        &mut self,
        model: &MaterialModel,
        plugin: &MitsubaPlugin,
        props: &mut Props<'a>,
        key: &str,
    ) -> Result<Option<Value>> {
        match props.texture(key) {
            Some(e) if model.textured_numbers.contains(&key) => Ok(Some(self.texture_at(e, key)?)),
            Some(e) => Err(e.origin.error(format!(
                "`{key}` of a {} is a number, not a texture (Mitsuba reads it as a float)",
                plugin.name
            ))),
            None => Ok(props.float(key)?.map(Value::Float)),
        }
    }

    /// `<texture type="bitmap">` (`filename`, `wrap_mode`, `filter_type`, `raw`,
    /// `to_uv`) or `"checkerboard"` (`color0`, `color1`, `to_uv`), as the TOML
    /// texture table of the same meaning.
    fn texture(&mut self, e: &'a Elem) -> Result<Value> {
        e.check_attrs(&["type", "id", "name"])?;
        let mut props = Props::new(e, self.search);
        let mut table = Table::new();
        table.insert("type".into(), Value::String(e.ty().into()));
        match e.ty() {
            "bitmap" => {
                let (name, at) = props
                    .string("filename")?
                    .ok_or_else(|| e.origin.error("missing <string name=\"filename\">"))?;
                let path = resolve(self.search, name).ok_or_else(|| {
                    at.origin.error(format!(
                        "cannot find the texture image `{name}`",
                        name = excerpt(name)
                    ))
                })?;
                let path = path.canonicalize().unwrap_or(path);
                table.insert(
                    "file".into(),
                    Value::String(path.to_string_lossy().into_owned()),
                );
                for key in ["wrap_mode", "filter_type"] {
                    if let Some((value, _)) = props.string(key)? {
                        table.insert(key.into(), Value::String(value.into()));
                    }
                }
                if let Some(raw) = props.boolean("raw")? {
                    table.insert("raw".into(), Value::Boolean(raw));
                }
            }
            "checkerboard" => {
                for key in ["color0", "color1"] {
                    if let Some(c) = props.color(key)? {
                        table.insert(key.into(), color_value(c));
                    }
                }
            }
            _ => {
                return Err(e
                    .origin
                    .error("not supported (supported textures: bitmap, checkerboard)"));
            }
        }
        // Mitsuba keeps the 2D affine part of a 4x4 `to_uv`: u' = m00 u + m01 v + m03.
        let m = props.transform("to_uv")?;
        if m != DMat4::IDENTITY {
            let row = |r: usize| {
                Value::Array(
                    [m.col(0)[r], m.col(1)[r], m.col(3)[r]]
                        .map(Value::Float)
                        .to_vec(),
                )
            };
            let mut to_uv = Table::new();
            to_uv.insert("matrix".into(), Value::Array(vec![row(0), row(1)]));
            table.insert("to_uv".into(), Value::Table(to_uv));
        }
        props.finish()?;
        Ok(Value::Table(table))
    }

    fn radiance(&mut self, e: &'a Elem) -> Result<[f64; 3]> {
        e.check_attrs(&["type", "id", "name"])?;
        let mut props = Props::new(e, self.search);
        let radiance = props
            .emitted("radiance")?
            .ok_or_else(|| e.origin.error("missing <rgb name=\"radiance\">"))?;
        props.finish()?;
        if radiance.iter().any(|&c| c < 0.0) {
            return Err(e.origin.error("radiance must not be negative"));
        }
        Ok(radiance)
    }

    /// A material name for `e`: its id, or a counter for anonymous elements.
    fn name_of(&mut self, e: &Elem) -> String {
        match e.attr("id") {
            Some(id) => id.to_string(),
            None => {
                self.anonymous += 1;
                format!("{}-{}", e.tag, self.anonymous)
            }
        }
    }

    /// The name of a shape's material in the document (added on first use), its
    /// surface, whether it emits, and whether it is textured (its surface, or
    /// its opacity).
    fn material(
        &mut self,
        shape: &'a Elem,
        bsdf: Option<&'a Elem>,
        emitter: Option<&'a Elem>,
    ) -> Result<(String, Surface, bool, bool)> {
        let (base, (surface, opacity)) = match bsdf {
            Some(b) => (self.name_of(b), self.surface(b, false)?),
            // Mitsuba's default: a one-sided diffuse of reflectance 0.5, or 0 on
            // an emitter (`Shape`'s constructor).
            None => {
                let (name, albedo) = match emitter {
                    Some(_) => ("default-black", 0.0),
                    None => ("default-diffuse", 0.5),
                };
                (
                    name.to_string(),
                    (
                        Surface::Lambertian {
                            albedo: color_value([albedo; 3]),
                            one_sided: true,
                            bump: None,
                        },
                        Opacity::OPAQUE,
                    ),
                )
            }
        };
        let emit = match emitter {
            Some(em) => {
                if em.ty() != "area" {
                    return Err(em.origin.error(format!(
                        "emitter `{}` inside a shape: only `area` emitters go on shapes",
                        excerpt(em.ty())
                    )));
                }
                Some((self.name_of(em), self.radiance(em)?))
            }
            None => None,
        };
        let mut table = Table::new();
        let full_name = match (&surface, &emit) {
            (
                Surface::Lambertian {
                    albedo,
                    one_sided,
                    bump,
                },
                _,
            ) => {
                table.insert("type".into(), Value::String("lambertian".into()));
                table.insert("albedo".into(), albedo.clone());
                if let Some((key, value)) = bump {
                    table.insert(key.to_string(), value.clone());
                }
                if *one_sided {
                    table.insert("one_sided".into(), Value::Boolean(true));
                }
                match &emit {
                    Some((emitter_name, radiance)) => {
                        table.insert("emit".into(), color_value(*radiance));
                        format!("{base}+{emitter_name}")
                    }
                    None => base,
                }
            }
            (
                Surface::Mitsuba {
                    table: params,
                    one_sided,
                    ..
                },
                None,
            ) => {
                table = params.clone();
                if *one_sided {
                    table.insert("one_sided".into(), Value::Boolean(true));
                }
                base
            }
            (Surface::Nested { table: params, .. }, None) => {
                table = params.clone();
                base
            }
            (Surface::Mitsuba { .. } | Surface::Nested { .. }, Some(_)) => {
                return Err(shape.origin.error(
                    "an area emitter on a non-diffuse BSDF is not supported (pathmix's \
                     emitters are diffuse)",
                ));
            }
        };
        if let Some(opacity) = opacity.value() {
            table.insert("opacity".into(), opacity);
        }
        if !self.materials.contains_key(&full_name) {
            if let Some(emitter) = emitter {
                for name in [full_name.clone(), format!("\"{full_name}\"")] {
                    self.origins
                        .push((format!("materials.{name}.emit"), emitter.origin.clone()));
                }
            }
            let origin = bsdf.unwrap_or(shape).origin.clone();
            self.origins
                .push((format!("materials.{full_name}"), origin.clone()));
            self.origins
                .push((format!("materials.\"{full_name}\""), origin));
            self.materials
                .insert(full_name.clone(), Value::Table(table));
        }
        let textured = surface.is_textured() || matches!(opacity, Opacity::Texture(_));
        Ok((full_name, surface, emit.is_some(), textured))
    }

    /// `<shape type="shapegroup" id="...">`: a `[[groups]]` table of its
    /// shapes, which Mitsuba reads as any shapes but shows only through
    /// instances; nested groups, instances and emitters inside are refused, as
    /// Mitsuba refuses them (`ShapeGroup`'s constructor).
    fn shapegroup(&mut self, e: &'a Elem) -> Result<()> {
        if self.in_group {
            return Err(e.origin.error(
                "a shapegroup inside a shapegroup: nested shape groups are not permitted \
                 (Mitsuba refuses them too)",
            ));
        }
        e.check_attrs(&["type", "id"])?;
        let name = e.attr("id").ok_or_else(|| {
            e.origin
                .error("a shapegroup needs an `id` for instances to refer to")
        })?;
        let mut props = Props::new(e, self.search);
        let shapes = props.objects(&["shape"]);
        props.finish()?;
        let index = self.groups.len();
        let outer = std::mem::take(&mut self.objects);
        self.objects_path = format!("groups[{index}].objects");
        self.in_group = true;
        let read = shapes.iter().try_for_each(|shape| self.shape(shape));
        self.in_group = false;
        self.objects_path = "objects".into();
        let objects = std::mem::replace(&mut self.objects, outer);
        read?;
        let mut group = Table::new();
        group.insert("name".into(), Value::String(name.into()));
        group.insert("objects".into(), Value::Array(objects));
        self.origins
            .push((format!("groups[{index}]"), e.origin.clone()));
        self.groups.push(Value::Table(group));
        Ok(())
    }

    /// `<shape type="instance">` with a `<ref>` to a shapegroup (or the group
    /// itself inside) and a `to_world`: an `instance` object.
    fn instance(&mut self, e: &'a Elem) -> Result<()> {
        if self.in_group {
            return Err(e.origin.error(
                "an instance inside a shapegroup: nested instancing is not permitted \
                 (Mitsuba refuses it too)",
            ));
        }
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let to_world = props.transform("to_world")?;
        let children = props.objects(&["ref", "shape", "bsdf", "emitter", "texture"]);
        props.finish()?;
        let child = match children.as_slice() {
            [] => {
                return Err(e
                    .origin
                    .error("an instance needs a shapegroup: a <ref id=\"...\"/> to one"));
            }
            [child] => *child,
            [_, second, ..] => {
                return Err(second
                    .origin
                    .error("only a single shapegroup can be specified per instance"));
            }
        };
        let group = self.resolve(child)?;
        if group.tag != "shape" || group.ty() != "shapegroup" {
            return Err(child.origin.error(format!(
                "only a shapegroup can be specified in an instance, not a <{} type=\"{}\">",
                group.tag,
                excerpt(group.ty())
            )));
        }
        // A group written inside the instance is read here (one referred to,
        // at the top level).
        if child.tag == "shape" {
            self.shapegroup(child)?;
        }
        let name = group.require("id")?;
        let mut object = Table::new();
        object.insert("type".into(), Value::String("instance".into()));
        object.insert("group".into(), Value::String(name.into()));
        if to_world != DMat4::IDENTITY {
            object.insert("matrix".into(), row_major(&to_world));
        }
        self.origins.push((
            format!("{}[{}]", self.objects_path, self.objects.len()),
            e.origin.clone(),
        ));
        self.objects.push(Value::Table(object));
        Ok(())
    }

    fn shape(&mut self, e: &'a Elem) -> Result<()> {
        match e.ty() {
            "shapegroup" => return self.shapegroup(e),
            "instance" => return self.instance(e),
            _ => {}
        }
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let to_world = props.transform("to_world")?;
        let flip = props.boolean("flip_normals")?.unwrap_or(false);
        let mut bsdf = None;
        let mut emitter = None;
        for child in props.objects(&["bsdf", "emitter", "ref"]) {
            let target = self.resolve(child)?;
            let slot = match target.tag.as_str() {
                "bsdf" => &mut bsdf,
                "emitter" => &mut emitter,
                other => {
                    return Err(child.origin.error(format!(
                        "a shape takes a <bsdf> and an <emitter>, not a <{other}>"
                    )));
                }
            };
            if slot.replace(target).is_some() {
                return Err(child
                    .origin
                    .error(format!("a second <{}> in one shape", target.tag)));
            }
        }
        if let Some(emitter) = emitter.filter(|_| self.in_group) {
            return Err(emitter.origin.error(
                "an emitter on a shape inside a shapegroup: instancing of emitters is not \
                 supported (Mitsuba refuses it too)",
            ));
        }
        let (material, surface, emits, textured) = self.material(e, bsdf, emitter)?;
        // Where pathmix's surfaces have sides: emission, the inside of glass and
        // one-sided BSDFs.
        let sided = emits
            || matches!(
                surface,
                Surface::Mitsuba {
                    transmits: true,
                    ..
                } | Surface::Lambertian {
                    one_sided: true,
                    ..
                } | Surface::Mitsuba {
                    one_sided: true,
                    ..
                } | Surface::Nested { .. }
            );
        let mirrors = to_world.determinant() < 0.0;
        let mut object = Table::new();
        object.insert("material".into(), Value::String(material));
        let push = |builder: &mut Builder, object: Table| {
            builder.origins.push((
                format!("{}[{}]", builder.objects_path, builder.objects.len()),
                e.origin.clone(),
            ));
            builder.objects.push(Value::Table(object));
        };
        match e.ty() {
            "obj" | "ply" | "serialized" => {
                // Which of a `.serialized` file's meshes (Mitsuba's default: the first).
                if e.ty() == "serialized" {
                    if let Some(index) = props.integer("shape_index")? {
                        let index = u32::try_from(index).map_err(|_| {
                            e.origin.error(format!(
                                "shape_index must be between 0 and {}, got {index}",
                                u32::MAX
                            ))
                        })?;
                        object.insert("shape_index".into(), Value::Integer(index.into()));
                    }
                }
                let (name, at) = props
                    .string("filename")?
                    .ok_or_else(|| e.origin.error("missing <string name=\"filename\">"))?;
                let path = resolve(self.search, name).ok_or_else(|| {
                    at.origin.error(format!(
                        "cannot find the mesh file `{name}`",
                        name = excerpt(name)
                    ))
                })?;
                let path = path.canonicalize().unwrap_or(path);
                // Mitsuba's meshes, like pathmix's, are smooth unless told otherwise:
                // the file's vertex normals, or angle-weighted ones.
                if props.boolean("face_normals")?.unwrap_or(false) {
                    object.insert("smooth".into(), Value::Boolean(false));
                }
                if sided && (flip || mirrors) {
                    return Err(e.origin.error(
                        "flip_normals or a mirroring to_world on an emitting, glass or \
                         one-sided mesh is not supported (wrap a reflecting BSDF in `twosided`)",
                    ));
                }
                object.insert("type".into(), Value::String("mesh".into()));
                object.insert(
                    "file".into(),
                    Value::String(path.to_string_lossy().into_owned()),
                );
                if to_world != DMat4::IDENTITY {
                    object.insert("matrix".into(), row_major(&to_world));
                }
                props.finish()?;
                push(self, object);
            }
            "rectangle" | "cube" => {
                props.finish()?;
                // Mitsuba's normals transform by the inverse transpose: a mirroring
                // transform keeps them, where u x v would turn.
                let swap = mirrors != flip;
                let faces: &[[DVec3; 3]] = if e.ty() == "rectangle" {
                    &[[
                        DVec3::new(-1.0, -1.0, 0.0),
                        DVec3::new(2.0, 0.0, 0.0),
                        DVec3::new(0.0, 2.0, 0.0),
                    ]]
                } else {
                    &CUBE_FACES
                };
                for &[q, u, v] in faces {
                    let (u, v) = if swap { (v, u) } else { (u, v) };
                    let mut quad = object.clone();
                    quad.insert("type".into(), Value::String("quad".into()));
                    quad.insert("q".into(), vec_value(to_world.transform_point3(q)));
                    quad.insert("u".into(), vec_value(to_world.transform_vector3(u)));
                    quad.insert("v".into(), vec_value(to_world.transform_vector3(v)));
                    push(self, quad);
                }
            }
            "disk" => {
                props.finish()?;
                // The unit disk in z = 0, normal +z; as for rectangles, a mirroring
                // transform keeps Mitsuba's normal, where u x v would turn.
                let (u, v) = if mirrors != flip {
                    (DVec3::Y, DVec3::X)
                } else {
                    (DVec3::X, DVec3::Y)
                };
                object.insert("type".into(), Value::String("disk".into()));
                object.insert(
                    "center".into(),
                    vec_value(to_world.transform_point3(DVec3::ZERO)),
                );
                object.insert("u".into(), vec_value(to_world.transform_vector3(u)));
                object.insert("v".into(), vec_value(to_world.transform_vector3(v)));
                push(self, object);
            }
            "sphere" => {
                let center = props.point("center")?.unwrap_or(DVec3::ZERO);
                let radius = props.float("radius")?.unwrap_or(1.0);
                props.finish()?;
                // Mitsuba turns a mirrored sphere's normals inward (a negative
                // radius out of `transform_decompose`), as flip_normals does.
                if sided && flip != mirrors {
                    return Err(e.origin.error(
                        "inward normals (flip_normals, or a mirroring to_world) on an \
                         emitting, glass or one-sided sphere are not supported (wrap a \
                         reflecting BSDF in `twosided`)",
                    ));
                }
                let columns =
                    [to_world.x_axis, to_world.y_axis, to_world.z_axis].map(|c| c.truncate());
                let scale = columns[0].length();
                let uniform = (0..3).all(|i| {
                    (columns[i].length() - scale).abs() <= 1e-6 * scale
                        && columns[i].dot(columns[(i + 1) % 3]).abs() <= 1e-6 * scale * scale
                });
                if !uniform {
                    return Err(e
                        .origin
                        .error("a sphere's to_world must scale every direction alike"));
                }
                // Its texture coordinates turn with it; pathmix's spheres keep no rotation.
                let turned =
                    (0..3).any(|i| (columns[i] - scale * DVec3::AXES[i]).length() > 1e-6 * scale);
                if turned && textured {
                    return Err(e.origin.error(
                        "a textured sphere's to_world may only scale and translate \
                         (pathmix's spheres keep no rotation for the texture to turn with)",
                    ));
                }
                object.insert("type".into(), Value::String("sphere".into()));
                object.insert(
                    "center".into(),
                    vec_value(to_world.transform_point3(center)),
                );
                object.insert("radius".into(), Value::Float(radius * scale));
                push(self, object);
            }
            "cylinder" => {
                let p0 = props.point("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = props.point("p1")?.unwrap_or(DVec3::Z);
                let radius = props.float("radius")?.unwrap_or(1.0);
                props.finish()?;
                // Mitsuba's normals point away from the axis under any to_world
                // (a mirroring one turns both its normal's cross product and,
                // through `transform_decompose`, its flip), inward with flip_normals:
                // pathmix's `flip_normals`. The TOML reader refuses a to_world
                // that makes the cylinder elliptic (Mitsuba warns and renders it
                // with a circle's area).
                if surface.is_textured() && to_world != DMat4::IDENTITY {
                    // Mitsuba's u turns with to_world; pathmix's starts from the
                    // frame of the world axis.
                    let (s, t) = coordinate_system((p1 - p0).normalize());
                    let axis = to_world.transform_vector3(p1 - p0).normalize();
                    let (world_s, world_t) = coordinate_system(axis);
                    let turned = [(s, world_s), (t, world_t)].iter().any(|&(local, world)| {
                        (to_world.transform_vector3(local).normalize() - world).length() > 1e-6
                    });
                    if turned {
                        return Err(e.origin.error(
                            "a textured cylinder's to_world may not turn it about its axis \
                             (pathmix starts its u from Mitsuba's frame about the world axis)",
                        ));
                    }
                }
                object.insert("type".into(), Value::String("cylinder".into()));
                object.insert("p0".into(), vec_value(p0));
                object.insert("p1".into(), vec_value(p1));
                object.insert("radius".into(), Value::Float(radius));
                if flip {
                    object.insert("flip_normals".into(), Value::Boolean(true));
                }
                if to_world != DMat4::IDENTITY {
                    object.insert("matrix".into(), row_major(&to_world));
                }
                push(self, object);
            }
            _ => {
                return Err(e
                    .origin
                    .error(format!("not supported (supported: {SUPPORTED_SHAPES})")));
            }
        }
        Ok(())
    }

    fn finish(mut self) -> Result<Converted> {
        let sensor = self.sensor.ok_or_else(|| SceneError {
            file: self.file.clone(),
            location: String::new(),
            message: "the scene has no <sensor>: pathmix needs a camera".into(),
        })?;
        let (camera, sensor_render) = self.camera(sensor)?;
        let mut render = self.integrator_settings()?;
        render.extend(sensor_render);
        if let Some((background, origin)) = self.background.take() {
            render.insert("background".into(), color_value(background));
            self.origins.push(("render.background".into(), origin));
        }
        if let Some(integrator) = self.integrator {
            for field in ["render.max_depth", "render.rr_depth"] {
                self.origins.push((field.into(), integrator.origin.clone()));
            }
        }
        let mut document = Table::new();
        document.insert("camera".into(), Value::Table(camera));
        document.insert("render".into(), Value::Table(render));
        document.insert(
            "materials".into(),
            Value::Table(std::mem::take(&mut self.materials)),
        );
        document.insert(
            "objects".into(),
            Value::Array(std::mem::take(&mut self.objects)),
        );
        if !self.groups.is_empty() {
            document.insert(
                "groups".into(),
                Value::Array(std::mem::take(&mut self.groups)),
            );
        }
        if !self.lights.is_empty() {
            document.insert(
                "lights".into(),
                Value::Array(std::mem::take(&mut self.lights)),
            );
        }
        if let Some((environment, origin)) = self.environment.take() {
            document.insert("environment".into(), Value::Table(environment));
            self.origins.push(("environment".into(), origin));
        }
        Ok(Converted {
            document,
            includes: Vec::new(),
            warnings: self.warnings,
            file_sampler: self.file_sampler,
            origins: self.origins,
            sensor: sensor.origin.clone(),
        })
    }

    /// Mitsuba's `aov` integrator: its AOVs, and the one integrator nested in
    /// it, which renders the image.
    fn aov_integrator(&self, e: &'a Elem) -> Result<(Vec<Aov>, &'a Elem)> {
        e.check_attrs(&["type", "id"])?;
        let mut props = Props::new(e, self.search);
        let Some((spec, at)) = props.string("aovs")? else {
            return Err(e
                .origin
                .error("the `aov` integrator needs its `aovs` string"));
        };
        let aovs = parse_aovs(spec).map_err(|message| at.origin.error(message))?;
        let nested = props.objects(&["integrator"]);
        props.finish()?;
        match nested[..] {
            [integrator] => Ok((aovs, integrator)),
            [] => Err(e.origin.error(
                "an `aov` integrator with no integrator nested in it renders AOVs alone, which \
                 pathmix does not: nest the integrator of the image (`<integrator type=\"path\"/>`)",
            )),
            [_, second, ..] => Err(second.origin.error(
                "a second integrator nested in `aov`: pathmix renders one image beside the AOVs",
            )),
        }
    }

    /// `[render]` from the integrator: Mitsuba's `max_depth` counts the camera
    /// vertex, pathmix's counts scattering events.
    fn integrator_settings(&mut self) -> Result<Table> {
        let mut render = Table::new();
        render.insert("strategy".into(), Value::String("nee-mis".into()));
        // Mitsuba's BSDFs tell a smooth surface's sides by its shading frame.
        render.insert("sides_by_shading_normal".into(), Value::Boolean(true));
        let integrator = match self.integrator {
            Some(e) if e.ty() == "aov" => {
                let (aovs, nested) = self.aov_integrator(e)?;
                let specs = aovs.iter().map(|aov| Value::String(aov.spec()));
                render.insert("aovs".into(), Value::Array(specs.collect()));
                self.origins.push(("render.aovs".into(), e.origin.clone()));
                Some(nested)
            }
            other => other,
        };
        let (max_depth, rr_depth) = match integrator {
            None => (-1, Some(5)),
            Some(e) => {
                // Mitsuba names the integrators nested in `aov`.
                e.check_attrs(&["type", "id", "name"])?;
                let mut props = Props::new(e, self.search);
                if props.boolean("hide_emitters")?.unwrap_or(false) {
                    return Err(e.origin.error("hide_emitters=\"true\" is not supported"));
                }
                let depths = match e.ty() {
                    "path" => {
                        let max_depth = props.integer("max_depth")?.unwrap_or(-1);
                        let rr_depth = props.integer("rr_depth")?.unwrap_or(5);
                        if rr_depth < 1 {
                            return Err(e
                                .origin
                                .error(format!("rr_depth must be >= 1, got {rr_depth}")));
                        }
                        (max_depth, Some(rr_depth))
                    }
                    // Mitsuba's direct: one emitter and one BSDF sample, MIS-combined, at
                    // the first vertex: pathmix's nee-mis ending after one bounce.
                    "direct" => {
                        for key in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                            if let Some(n) = props.integer(key)? {
                                if n != 1 {
                                    return Err(e.origin.error(format!(
                                        "{key} = {n} is not supported (pathmix takes one of each)"
                                    )));
                                }
                            }
                        }
                        (2, None)
                    }
                    other => {
                        return Err(e.origin.error(format!(
                            "integrator `{other}`: not supported (supported: path, direct)",
                            other = excerpt(other)
                        )));
                    }
                };
                props.finish()?;
                if depths.0 == 0 || depths.0 < -1 {
                    return Err(e.origin.error(format!(
                        "max_depth = {} is not supported (-1 for unbounded, or >= 1)",
                        depths.0
                    )));
                }
                depths
            }
        };
        let max_depth = if max_depth == -1 {
            self.warn(format!(
                "max_depth -1 (unbounded) is pathmix's largest, {UNBOUNDED_DEPTH} bounces"
            ));
            UNBOUNDED_DEPTH
        } else if max_depth - 1 > UNBOUNDED_DEPTH {
            self.warn(format!(
                "max_depth {max_depth} is more than pathmix's largest, {UNBOUNDED_DEPTH} bounces, \
                 which it renders"
            ));
            UNBOUNDED_DEPTH
        } else {
            max_depth - 1
        };
        render.insert("max_depth".into(), Value::Integer(max_depth));
        // Mitsuba's `direct` has no roulette (nor would pathmix's default at depth 1).
        render.insert(
            "rr_depth".into(),
            rr_depth.map_or(Value::String("off".into()), Value::Integer),
        );
        Ok(render)
    }

    /// The sampler for Mitsuba's `independent`, its default and the one most
    /// files name whatever their author would choose: pathmix's Sobol, the same
    /// expected image with less noise (docs/mitsuba.md); the session says so,
    /// unless the run asks for a sampler itself.
    fn independent_sampler(&mut self) -> &'static str {
        self.file_sampler = Some(Sampler::Independent);
        Sampler::Sobol.name()
    }

    /// `[camera]`, and the sampler's part of `[render]`.
    fn camera(&mut self, e: &'a Elem) -> Result<(Table, Table)> {
        e.check_attrs(&["type", "id"])?;
        if !["perspective", "thinlens", "orthographic"].contains(&e.ty()) {
            return Err(e.origin.error(format!(
                "sensor `{}`: not supported (supported: perspective, thinlens, orthographic)",
                excerpt(e.ty())
            )));
        }
        let orthographic = e.ty() == "orthographic";
        let mut props = Props::new(e, self.search);
        let to_world = props.transform("to_world")?;
        let (fov, axis) = if orthographic {
            (0.0, None)
        } else {
            let fov = props
                .float("fov")?
                .ok_or_else(|| e.origin.error("missing <float name=\"fov\">"))?;
            (fov, props.string("fov_axis")?)
        };
        let mut far_clip = None;
        for clip in ["near_clip", "far_clip"] {
            if let Some(value) = props.float(clip)? {
                self.warn(
                    "near_clip and far_clip are ignored: pathmix does not clip camera rays".into(),
                );
                if clip == "far_clip" {
                    far_clip = Some(value);
                }
            }
        }
        // A pinhole has no focal plane: Mitsuba's perspective and orthographic
        // sensors ignore it too.
        let focus_distance = props.float("focus_distance")?;
        let lens = if e.ty() == "thinlens" {
            Some(thin_lens(&mut props, e, focus_distance, far_clip)?)
        } else {
            None
        };
        let mut film = None;
        let mut sampler = None;
        for child in props.objects(&["film", "sampler", "ref"]) {
            let target = self.resolve(child)?;
            match target.tag.as_str() {
                "film" => film = Some(target),
                "sampler" => sampler = Some(target),
                other => {
                    return Err(child.origin.error(format!(
                        "a sensor takes a <film> and a <sampler>, not a <{other}>"
                    )));
                }
            }
        }
        props.finish()?;

        let mut camera = Table::new();
        let (width, height, filter) = match film {
            Some(f) => self.film(f)?,
            None => (768, 576, gaussian_filter(0.5)),
        };
        camera.insert("width".into(), Value::Integer(width));
        camera.insert("height".into(), Value::Integer(height));
        camera.insert("filter".into(), filter);
        let (w, h) = (width as f64, height as f64);
        let axis_name = axis.map_or("x", |(a, _)| a);
        let axis_name = match axis_name {
            "smaller" => {
                if w / h > 1.0 {
                    "y"
                } else {
                    "x"
                }
            }
            "larger" => {
                if w / h > 1.0 {
                    "x"
                } else {
                    "y"
                }
            }
            other => other,
        };
        // tan(vfov / 2) over tan(fov / 2).
        let ratio = match axis_name {
            "x" => h / w,
            "y" => 1.0,
            "diagonal" => h / w.hypot(h),
            other => {
                let at = axis.map_or(e, |(_, at)| at);
                return Err(at.origin.error(format!(
                    "unknown fov_axis `{other}` (expected x, y, smaller, larger or diagonal)",
                    other = excerpt(other)
                )));
            }
        };
        let vfov = if ratio == 1.0 {
            fov
        } else {
            2.0 * ((fov.to_radians() / 2.0).tan() * ratio).atan().to_degrees()
        };
        if orthographic {
            camera.insert("projection".into(), Value::String("orthographic".into()));
            camera.insert(
                "view_width".into(),
                Value::Float(orthographic_width(&to_world, e)?),
            );
        } else {
            camera.insert("vfov".into(), Value::Float(vfov));
        }
        if let Some((aperture_radius, focus_distance)) = lens {
            camera.insert("aperture_radius".into(), Value::Float(aperture_radius));
            camera.insert("focus_distance".into(), Value::Float(focus_distance));
        }
        // Mitsuba's camera looks along +z with +y up, and the image's right is -x.
        if to_world.determinant() < 0.0 {
            return Err(e.origin.error(
                "a mirroring sensor to_world is not supported (pathmix's image is never mirrored)",
            ));
        }
        let eye = to_world.transform_point3(DVec3::ZERO);
        let forward = to_world.transform_vector3(DVec3::Z).normalize();
        camera.insert("lookfrom".into(), vec_value(eye));
        camera.insert("lookat".into(), vec_value(eye + forward));
        camera.insert(
            "vup".into(),
            vec_value(to_world.transform_vector3(DVec3::Y)),
        );

        let mut render = Table::new();
        let (spp, seed, kind) = match sampler {
            Some(s) => {
                s.check_attrs(&["type", "id"])?;
                let mut props = Props::new(s, self.search);
                let spp = props.integer("sample_count")?.unwrap_or(4);
                let seed = props.integer("seed")?.unwrap_or(0);
                props.finish()?;
                let kind = match s.ty() {
                    "independent" => self.independent_sampler(),
                    "stratified" | "multijitter" | "orthogonal" | "ldsampler" => {
                        self.warn(format!(
                            "the `{}` sampler is pathmix's Owen-scrambled Sobol sampler (another \
                             stratification, the same expected image)",
                            s.ty()
                        ));
                        "sobol"
                    }
                    other => {
                        return Err(s.origin.error(format!(
                            "sampler `{other}`: not supported (supported: independent, stratified, \
                             multijitter, orthogonal, ldsampler)",
                            other = excerpt(other)
                        )));
                    }
                };
                (spp, seed, kind)
            }
            None => (4, 0, self.independent_sampler()),
        };
        render.insert("spp".into(), Value::Integer(spp));
        render.insert("seed".into(), Value::Integer(seed));
        render.insert("sampler".into(), Value::String(kind.into()));
        Ok((camera, render))
    }

    fn film(&mut self, e: &'a Elem) -> Result<(i64, i64, Value)> {
        e.check_attrs(&["type", "id"])?;
        if e.ty() != "hdrfilm" {
            return Err(e.origin.error(format!(
                "film `{}`: not supported (supported: hdrfilm)",
                excerpt(e.ty())
            )));
        }
        let mut props = Props::new(e, self.search);
        let width = props.integer("width")?.unwrap_or(768);
        let height = props.integer("height")?.unwrap_or(576);
        // Here, at the <integer>: the field of view is derived from the aspect
        // ratio, which a side of 0 would make meaningless before the TOML
        // parser saw the side itself.
        for (name, side) in [("width", width), ("height", height)] {
            let (lo, hi) = IMAGE_SIDE;
            if !(lo..=hi).contains(&side) {
                let at = e.children.iter().find(|c| c.name() == Some(name));
                return Err(at
                    .map_or(&e.origin, |c| &c.origin)
                    .error(format!("{name} must be between {lo} and {hi}, got {side}")));
            }
        }
        if let Some((format, at)) = props.string("pixel_format")? {
            if !matches!(format, "rgb" | "rgba") {
                return Err(at.origin.error(format!(
                    "pixel_format `{format}`: not supported (supported: rgb, rgba)",
                    format = excerpt(format)
                )));
            }
        }
        // Mitsuba's output file, its 0.x logo, and its sampling past the frame's
        // edge (pathmix samples each pixel's whole filter always): none changes the
        // radiance pathmix writes, in the format its output name asks for.
        let mut file_options = Vec::new();
        for (name, present) in [
            (
                "component_format",
                props.string("component_format")?.is_some(),
            ),
            ("file_format", props.string("file_format")?.is_some()),
            ("banner", props.boolean("banner")?.is_some()),
            (
                "high_quality_edges",
                props.boolean("high_quality_edges")?.is_some(),
            ),
        ] {
            if present {
                file_options.push(name);
            }
        }
        if !file_options.is_empty() {
            self.warn(format!(
                "ignored the film's {}: Mitsuba's options for its output file, which do not \
                 change the image (pathmix writes the format its output name asks for)",
                file_options.join(", ")
            ));
        }
        let filters = props.objects(&["rfilter"]);
        props.finish()?;
        let filter = match filters[..] {
            [] => gaussian_filter(0.5),
            [f] => {
                f.check_attrs(&["type", "id", "name"])?;
                let mut props = Props::new(f, self.search);
                // Parameters as Mitsuba names them; their defaults and checks are the
                // TOML reader's, whose errors point here.
                let parameters: &[(&str, &str)] = match f.ty() {
                    "box" | "catmullrom" => &[],
                    "gaussian" => &[("stddev", "stddev")],
                    "tent" => &[("radius", "radius")],
                    "mitchell" => &[("B", "b"), ("C", "c")],
                    "lanczos" => &[("lobes", "lobes")],
                    other => {
                        return Err(f.origin.error(format!(
                            "rfilter `{other}`: not supported (supported: box, gaussian, tent, \
                             mitchell, catmullrom, lanczos)",
                            other = excerpt(other)
                        )));
                    }
                };
                let mut filter = Table::new();
                filter.insert("type".into(), Value::String(f.ty().into()));
                for &(mitsuba_name, name) in parameters {
                    let value = match mitsuba_name {
                        "lobes" => props.integer(mitsuba_name)?.map(Value::Integer),
                        _ => props.float(mitsuba_name)?.map(Value::Float),
                    };
                    if let Some(value) = value {
                        filter.insert(name.into(), value);
                    }
                }
                props.finish()?;
                self.origins
                    .push(("camera.filter".into(), f.origin.clone()));
                // Mitsuba's film takes any filter of radius 0.5 (in f32) for its box
                // filter (`ReconstructionFilter::is_box_filter`).
                let radius = match (f.ty(), filter.get("radius"), filter.get("stddev")) {
                    ("tent", Some(Value::Float(radius)), _) => Some(*radius),
                    ("gaussian", _, Some(Value::Float(stddev))) => Some(4.0 * stddev),
                    _ => None,
                };
                match radius {
                    Some(radius) if radius as f32 == 0.5 => Value::String("box".into()),
                    _ => Value::Table(filter),
                }
            }
            [_, second, ..] => return Err(second.origin.error("a second <rfilter>")),
        };
        Ok((width, height, filter))
    }
}

/// The pathmix material of Mitsuba's `conductor`, `roughconductor`,
/// `dielectric` (as `smoothdielectric`), `roughdielectric`, `thindielectric`, `plastic` or
/// `roughplastic`: the same parameter names (the TOML parser
/// validates them and fills Mitsuba's defaults), IORs given by name turned into
/// numbers; a conductor's named `material` stays a name.
/// Every BSDF plugin pathmix reads, for messages.
fn supported_bsdfs() -> String {
    let mut kinds: Vec<&str> = (MATERIAL_KINDS.iter())
        .filter_map(|m| Some(m.mitsuba?.name))
        .collect();
    kinds.sort_unstable();
    let mut names = vec![BSDFS_READ_HERE[0]];
    names.extend(kinds);
    names.extend(&BSDFS_READ_HERE[1..]);
    names.join(", ")
}

/// The material kind that Mitsuba's BSDF plugin `ty` is (`MaterialModel::mitsuba`).
fn mitsuba_kind(ty: &str) -> Option<(&'static MaterialModel, &'static MitsubaPlugin)> {
    MATERIAL_KINDS
        .iter()
        .find_map(|model| match &model.mitsuba {
            Some(plugin) if plugin.name == ty => Some((model, plugin)),
            _ => None,
        })
}

fn gaussian_filter(stddev: f64) -> Value {
    let mut t = BTreeMap::new();
    t.insert("type".to_string(), Value::String("gaussian".into()));
    t.insert("stddev".to_string(), Value::Float(stddev));
    Value::Table(t.into_iter().collect())
}

/// A conductor's `material`: `none` is Mitsuba's default, which `eta` and `k` may
/// go with; the presets the TOML format does not name become their `eta` and `k`.
fn conductor_preset(props: &mut Props, table: &mut Table) -> Result<()> {
    let Some((name, at)) = props.string("material")? else {
        return Ok(());
    };
    let unlisted = (spectrum::UNLISTED_CONDUCTORS.iter()).find(|(n, _, _)| *n == name);
    match unlisted {
        Some(&(_, eta, k)) => {
            if table.contains_key("eta") || table.contains_key("k") {
                return Err(at.origin.error(format!(
                    "give either `material` (here `{name}`) or `eta` and `k`, not both"
                )));
            }
            table.insert("eta".into(), color_value(eta.map(f64::from)));
            table.insert("k".into(), color_value(k.map(f64::from)));
        }
        None if name != "none" => {
            table.insert("material".into(), Value::String(name.into()));
        }
        None => {}
    }
    Ok(())
}

/// An `int_ior`/`ext_ior`: a number or one of Mitsuba's named materials.
fn ior(props: &mut Props, name: &str) -> Result<Option<f64>> {
    if let Some(e) = props.get(name) {
        e.check_attrs(&["name", "value"])?;
        let value = e.require("value")?;
        let ior = match e.tag.as_str() {
            "float" => number(e, value)?,
            "string" => match NAMED_IORS
                .iter()
                .find(|(n, _)| n.eq_ignore_ascii_case(value))
            {
                Some(&(_, ior)) => ior,
                None => {
                    let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
                    return Err(e.origin.error(format!(
                        "unknown material `{value}` (Mitsuba's names: {})",
                        names.join(", "),
                        value = excerpt(value)
                    )));
                }
            },
            _ => return Err(e.origin.error("expected a <float> or a named <string>")),
        };
        if ior <= 0.0 {
            return Err(e.origin.error(format!("must be > 0, got {ior}")));
        }
        return Ok(Some(ior));
    }
    Ok(None)
}

/// Mitsuba's cube, `[-1, 1]^3`: each face as a corner and two edges, `u x v` outwards.
const CUBE_FACES: [[DVec3; 3]; 6] = [
    [
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(0.0, 0.0, 2.0),
    ],
    [
        DVec3::new(-1.0, -1.0, -1.0),
        DVec3::new(0.0, 0.0, 2.0),
        DVec3::new(0.0, 2.0, 0.0),
    ],
    [
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(0.0, 0.0, 2.0),
        DVec3::new(2.0, 0.0, 0.0),
    ],
    [
        DVec3::new(-1.0, -1.0, -1.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 2.0),
    ],
    [
        DVec3::new(-1.0, -1.0, 1.0),
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 2.0, 0.0),
    ],
    [
        DVec3::new(-1.0, -1.0, -1.0),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(2.0, 0.0, 0.0),
    ],
];

/// An `orthographic` sensor's view width: its view is [-1, 1] along the
/// camera's x and [-1/aspect, 1/aspect] along y, scaled by `to_world`, so
/// twice the scale along x; the scale along y must be the same (pathmix's
/// pixels are square).
fn orthographic_width(to_world: &DMat4, e: &Elem) -> Result<f64> {
    let sx = to_world.transform_vector3(DVec3::X).length();
    let sy = to_world.transform_vector3(DVec3::Y).length();
    if !(sx > 0.0 && sx.is_finite()) || (sx - sy).abs() > 1e-6 * sx {
        return Err(e.origin.error(format!(
            "an orthographic sensor's to_world must scale its x and y alike and by more than 0 \
             (pathmix's pixels are square), got {sx} and {sy}"
        )));
    }
    Ok(2.0 * sx)
}

/// A `thinlens` sensor's `aperture_radius` (required, as in Mitsuba; 0 makes
/// the pinhole Mitsuba approximates by an epsilon) and `focus_distance`
/// (Mitsuba's default: `far_clip`, itself 1e4 by default).
fn thin_lens<'e>(
    props: &mut Props<'e>,
    e: &'e Elem,
    focus_distance: Option<f64>,
    far_clip: Option<f64>,
) -> Result<(f64, f64)> {
    let aperture = props
        .float("aperture_radius")?
        .ok_or_else(|| e.origin.error("missing <float name=\"aperture_radius\">"))?;
    let at = |props: &mut Props<'e>, name: &str| props.get(name).unwrap_or(e).origin.clone();
    if !(aperture >= 0.0 && aperture.is_finite()) {
        return Err(at(props, "aperture_radius").error(format!(
            "aperture_radius must be a finite length >= 0, got {aperture}"
        )));
    }
    if let Some(d) = focus_distance
        && !(d > 0.0 && d.is_finite())
    {
        return Err(at(props, "focus_distance").error(format!(
            "focus_distance must be a finite distance > 0, got {d}"
        )));
    }
    Ok((aperture, focus_distance.or(far_clip).unwrap_or(1e4)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Disk, Filter, MaterialKind, Roulette, Scene, Strategy};
    use glam::Vec3;

    /// `files` written into a fresh folder (removed when the first value is
    /// dropped), and the path of the first, the scene.
    fn folder(name: &str, files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::Builder::new()
            .prefix(&format!("pathmix-mitsuba-{name}-"))
            .tempdir()
            .unwrap();
        for (file, text) in files {
            std::fs::write(dir.path().join(file), text).unwrap();
        }
        let scene = dir.path().join(files[0].0);
        (dir, scene)
    }

    const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

    /// A scene with `body` inside, a sensor unless `body` has one.
    fn scene_text(body: &str) -> String {
        let sensor = if body.contains("<sensor") {
            ""
        } else {
            r#"<sensor type="perspective"><float name="fov" value="45"/>
               <transform name="to_world"><lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
               <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/>
               <rfilter type="box"/></film></sensor>"#
        };
        format!("<scene version=\"3.0.0\">\n{body}\n{sensor}\n</scene>\n")
    }

    fn read(name: &str, body: &str, defines: &[Define]) -> Result<(Scene, Converted)> {
        let (_dir, path) = folder(
            name,
            &[("scene.xml", &scene_text(body)), ("quad.obj", QUAD_OBJ)],
        );
        let converted = Converted::read(&path, defines)?;
        let loaded = Scene::load_with(&path, defines)?;
        Ok((loaded.scene, converted))
    }

    fn scene(name: &str, body: &str) -> Scene {
        read(name, body, &[]).unwrap_or_else(|e| panic!("{e}")).0
    }

    fn error(name: &str, body: &str) -> String {
        match read(name, body, &[]) {
            Ok(_) => panic!("{name}: expected an error"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn camera_follows_mitsubas_conventions() {
        let s = scene("camera", "");
        // lookat: +z is the view direction; the image's right is -x of the camera frame.
        assert_eq!(s.camera.lookfrom, Vec3::new(0.0, 0.0, -5.0));
        assert_eq!(s.camera.lookat, Vec3::new(0.0, 0.0, -4.0));
        assert_eq!(s.camera.vup, Vec3::Y);
        assert_eq!((s.camera.width, s.camera.height), (32, 16));
        assert_eq!(s.camera.filter, Filter::Box);
        // fov_axis defaults to x: at 2:1, tan(vfov / 2) = tan(45 deg / 2) / 2.
        let expected = 2.0 * ((22.5f64).to_radians().tan() / 2.0).atan().to_degrees();
        assert_eq!(s.camera.vfov_degrees, expected as f32);
        // Mitsuba's default sampler and film filter.
        let s = scene(
            "camera-defaults",
            r#"<sensor type="perspective"><float name="fov" value="30"/>
               <string name="fov_axis" value="y"/></sensor>"#,
        );
        assert_eq!((s.camera.width, s.camera.height), (768, 576));
        assert_eq!(s.camera.vfov_degrees, 30.0);
        assert_eq!(s.camera.filter, Filter::Gaussian { stddev: 0.5 });
        assert_eq!((s.render.spp, s.render.seed), (4, 0));
    }

    /// A `thinlens` sensor is a perspective one with a lens: its aperture radius
    /// and focus distance (by default Mitsuba's `far_clip`, 1e4 by default);
    /// bad values are errors at their element.
    #[test]
    fn thinlens_sensor_becomes_a_thin_lens_camera() {
        let sensor = |props: &str| {
            format!(
                r#"<sensor type="thinlens"><float name="fov" value="30"/>
                   <string name="fov_axis" value="y"/>{props}</sensor>"#
            )
        };
        let s = scene(
            "thinlens",
            &sensor(
                r#"<float name="aperture_radius" value="0.25"/><float name="focus_distance" value="3"/>"#,
            ),
        );
        assert_eq!(s.camera.vfov_degrees, 30.0);
        assert_eq!(s.camera.aperture_radius, 0.25);
        assert_eq!(s.camera.focus_distance, Some(3.0));
        assert_eq!(s.camera.model(), crate::scene::CameraModel::ThinLens);
        let s = scene(
            "thinlens-far",
            &sensor(
                r#"<float name="aperture_radius" value="0.1"/><float name="far_clip" value="50"/>"#,
            ),
        );
        assert_eq!(s.camera.focus_distance, Some(50.0));
        let s = scene(
            "thinlens-default",
            &sensor(r#"<float name="aperture_radius" value="0"/>"#),
        );
        assert_eq!(s.camera.focus_distance, Some(1e4));
        assert_eq!(s.camera.model(), crate::scene::CameraModel::Pinhole);
        // A perspective sensor ignores focus_distance, as Mitsuba's does.
        let s = scene(
            "perspective-focus",
            r#"<sensor type="perspective"><float name="fov" value="30"/>
               <float name="focus_distance" value="3"/></sensor>"#,
        );
        assert_eq!(
            (s.camera.aperture_radius, s.camera.focus_distance),
            (0.0, None)
        );

        let e = error("no-aperture", &sensor(""));
        assert!(
            e.contains("missing <float name=\"aperture_radius\">"),
            "{e}"
        );
        let e = error(
            "negative-aperture",
            &sensor("\n<float name=\"aperture_radius\" value=\"-1\"/>"),
        );
        assert!(
            e.contains(":4:1: <float name=\"aperture_radius\">: aperture_radius must be a finite length >= 0, got -1"),
            "{e}"
        );
        let e = error(
            "zero-focus",
            &sensor(
                r#"<float name="aperture_radius" value="1"/><float name="focus_distance" value="0"/>"#,
            ),
        );
        assert!(
            e.contains("<float name=\"focus_distance\">: focus_distance must be a finite distance > 0, got 0"),
            "{e}"
        );
    }

    /// An `orthographic` sensor's view is twice its `to_world`'s scale along x
    /// wide; an uneven x and y scale is an error at the sensor.
    #[test]
    fn orthographic_sensor_takes_its_width_from_the_scale() {
        let sensor = |scale: &str| {
            format!(
                r#"<sensor type="orthographic"><transform name="to_world">
                   <scale {scale}/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>
                   </transform></sensor>"#
            )
        };
        let s = scene("orthographic", &sensor(r#"x="3" y="3""#));
        assert_eq!(s.camera.view_width, Some(6.0));
        assert_eq!(s.camera.model(), crate::scene::CameraModel::Orthographic);
        assert_eq!(s.camera.lookfrom, Vec3::new(0.0, 0.0, 5.0));
        assert_eq!(s.camera.lookat, Vec3::new(0.0, 0.0, 4.0));
        let e = error("orthographic-uneven", &sensor(r#"x="3" y="2""#));
        assert!(
            e.contains("<sensor type=\"orthographic\">: an orthographic sensor's to_world must scale its x and y alike"),
            "{e}"
        );
    }

    /// A `directional` emitter: its irradiance and the way it shines, given
    /// as `direction` or as `to_world`'s +z.
    #[test]
    fn directional_emitter_becomes_a_directional_light() {
        let s = scene(
            "directional",
            r#"<emitter type="directional"><vector name="direction" value="0, -2, 0"/>
                 <rgb name="irradiance" value="1, 2, 3"/></emitter>
               <emitter type="directional"><transform name="to_world">
                 <lookat origin="0, 0, 0" target="1, 0, 0" up="0, 1, 0"/></transform></emitter>"#,
        );
        assert_eq!(s.point_lights[0].directional, Some(Vec3::NEG_Y));
        assert_eq!(s.point_lights[0].intensity, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(s.point_lights[1].directional, Some(Vec3::X));
        assert_eq!(s.point_lights[1].intensity, Vec3::ONE);
        let e = error(
            "directional-both",
            r#"<emitter type="directional"><vector name="direction" value="0, -1, 0"/>
                 <transform name="to_world"><translate x="1"/></transform></emitter>"#,
        );
        assert!(e.contains("give either `direction` or `to_world`"), "{e}");
    }

    /// Without `up` (or with a zero one) Mitsuba's lookat takes the first axis of
    /// its `coordinate_system` of the view direction: +x looking down -z, and a
    /// view straight down is no error.
    #[test]
    fn lookat_without_up_is_mitsubas() {
        let sensor = |name: &str, lookat: &str| {
            scene(
                name,
                &format!(
                    r#"<sensor type="perspective"><float name="fov" value="45"/>
                       <transform name="to_world"><lookat {lookat}/></transform></sensor>"#
                ),
            )
            .camera
        };
        let camera = sensor("no-up", r#"origin="0, 0, 5" target="0, 0, 0""#);
        assert_eq!(camera.vup, Vec3::X);
        let zero = sensor(
            "zero-up",
            r#"origin="0, 0, 5" target="0, 0, 0" up="0, 0, 0""#,
        );
        assert_eq!(zero.vup, Vec3::X);
        let down = sensor("down", r#"origin="0, 5, 0" target="0, 0, 0""#);
        assert!(down.vup.is_finite() && down.vup.dot(Vec3::NEG_Y).abs() < 1e-6);
        assert_eq!(down.lookat - down.lookfrom, Vec3::NEG_Y);
    }

    #[test]
    fn fov_axes() {
        let vfov = |axis: &str, w: u32, h: u32| {
            let s = scene(
                &format!("fov-{axis}-{w}"),
                &format!(
                    r#"<sensor type="perspective"><float name="fov" value="60"/>
                       <string name="fov_axis" value="{axis}"/>
                       <film type="hdrfilm"><integer name="width" value="{w}"/>
                       <integer name="height" value="{h}"/></film></sensor>"#
                ),
            );
            f64::from(s.camera.vfov_degrees)
        };
        let half = 30f64.to_radians().tan();
        let deg = |t: f64| 2.0 * t.atan().to_degrees();
        let close = |a: f64, b: f64| assert!((a - b).abs() < 1e-4, "{a} vs {b}");
        close(vfov("y", 200, 100), 60.0);
        close(vfov("x", 200, 100), deg(half / 2.0));
        close(vfov("smaller", 200, 100), 60.0);
        close(vfov("larger", 200, 100), deg(half / 2.0));
        close(vfov("smaller", 100, 200), deg(half * 2.0));
        close(vfov("diagonal", 300, 400), deg(half * 400.0 / 500.0));
    }

    #[test]
    fn transforms_compose_in_mitsubas_order() {
        // Scale, then rotate 90 degrees about z, then translate: (1, 0, 0) -> (0, 2, 0) -> (3, 2, 0).
        let s = scene(
            "order",
            r#"<shape type="sphere"><point name="center" x="1" y="0" z="0"/>
               <transform name="to_world"><scale value="2"/><rotate z="1" angle="90"/>
               <translate x="3"/></transform><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>"#,
        );
        assert_eq!(s.shapes.spheres[0].center, Vec3::new(3.0, 2.0, 0.0));
        assert_eq!(s.shapes.spheres[0].radius, 2.0);
        // A row-major matrix: translation in the last column.
        let s = scene(
            "matrix",
            r#"<shape type="obj"><string name="filename" value="quad.obj"/>
               <transform name="to_world"><matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>"#,
        );
        assert_eq!(s.shapes.triangles[0].vertices[0], Vec3::new(5.0, 6.0, 7.0));
        // One number stands for all three (Mitsuba's `expand_value_to_xyz`).
        let s = scene(
            "one-value",
            r#"<shape type="sphere"><point name="center" value="1"/>
               <transform name="to_world"><translate value="2"/></transform>
               <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>"#,
        );
        assert_eq!(s.shapes.spheres[0].center, Vec3::splat(3.0));
    }

    #[test]
    fn rectangles_and_cubes_keep_mitsubas_normals() {
        let normal =
            |s: &Scene, i: usize| s.shapes.quads[i].u.cross(s.shapes.quads[i].v).normalize();
        let rect = |name: &str, extra: &str| {
            scene(
                name,
                &format!(
                    r#"<shape type="rectangle"><transform name="to_world">{extra}</transform></shape>"#
                ),
            )
        };
        assert_eq!(normal(&rect("rect", ""), 0), Vec3::Z);
        // Mirrored in x: Mitsuba's normal (inverse transpose) stays +z.
        assert_eq!(
            normal(&rect("rect-mirror", r#"<scale x="-1"/>"#), 0),
            Vec3::Z
        );
        let flipped = scene(
            "rect-flip",
            r#"<shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>"#,
        );
        assert_eq!(normal(&flipped, 0), -Vec3::Z);
        let cube = scene("cube", r#"<shape type="cube"/>"#);
        assert_eq!(cube.shapes.quads.len(), 6);
        for (i, q) in cube.shapes.quads.iter().enumerate() {
            let centre = q.q + (q.u + q.v) / 2.0;
            assert_eq!(normal(&cube, i), centre, "face {i} faces outwards");
        }
    }

    /// A `serialized` shape is a mesh object of its file, its `shape_index`
    /// kept (the file's meshes are read by `scene::mesh`); a negative one is refused.
    #[test]
    fn serialized_shapes_keep_their_shape_index() {
        let shape = |index: &str| {
            scene_text(&format!(
                r#"<shape type="serialized"><string name="filename" value="parts.serialized"/>
                   <integer name="shape_index" value="{index}"/></shape>"#
            ))
        };
        let xml = shape("2");
        let (_dir, path) = folder(
            "serialized",
            &[("scene.xml", &xml), ("parts.serialized", "")],
        );
        let converted = Converted::read(&path, &[]).unwrap();
        let object = &converted.document["objects"][0];
        assert_eq!(object["type"].as_str(), Some("mesh"));
        assert_eq!(object["shape_index"].as_integer(), Some(2));
        assert!(
            object["file"]
                .as_str()
                .unwrap()
                .ends_with("parts.serialized")
        );
        let xml = shape("-1");
        let (_dir, path) = folder(
            "serialized-negative",
            &[("scene.xml", &xml), ("parts.serialized", "")],
        );
        let e = Converted::read(&path, &[]).unwrap_err().to_string();
        assert!(e.contains("shape_index must be between 0 and"), "{e}");
    }

    /// Mitsuba's cylinder: `p0`, `p1`, `radius` under `to_world`, which may
    /// scale along the axis and alike across it; its normals point away from
    /// the axis unless flip_normals, a mirroring to_world or not.
    #[test]
    fn cylinders_keep_mitsubas_shape_and_side() {
        let cylinder = |name: &str, body: &str| {
            let s = scene(name, &format!(r#"<shape type="cylinder">{body}</shape>"#));
            assert_eq!(s.shapes.cylinders.len(), 1);
            s.shapes.cylinders[0]
        };
        let c = cylinder("cylinder", "");
        assert_eq!(
            (c.p0, c.p1, c.radius, c.flip_normals),
            (Vec3::ZERO, Vec3::Z, 1.0, false)
        );
        let c = cylinder(
            "cylinder-placed",
            r#"<point name="p0" x="0" y="0" z="1"/><point name="p1" x="0" y="0" z="2"/>
               <float name="radius" value="0.5"/><boolean name="flip_normals" value="true"/>
               <transform name="to_world"><scale x="2" y="2" z="3"/><translate x="1"/></transform>"#,
        );
        assert_eq!(
            (c.p0, c.p1, c.radius, c.flip_normals),
            (
                Vec3::new(1.0, 0.0, 3.0),
                Vec3::new(1.0, 0.0, 6.0),
                1.0,
                true
            )
        );
        let c = cylinder(
            "cylinder-mirror",
            r#"<transform name="to_world"><scale x="-1"/></transform>"#,
        );
        assert!(!c.flip_normals);
        let e = error(
            "cylinder-elliptic",
            r#"<shape type="cylinder"><transform name="to_world"><scale x="2"/></transform></shape>"#,
        );
        assert!(
            e.contains("<shape type=\"cylinder\">") && e.contains("elliptic"),
            "{e}"
        );
        let e = error(
            "cylinder-textured",
            r#"<shape type="cylinder"><transform name="to_world"><rotate z="1" angle="30"/></transform>
               <bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>"#,
        );
        assert!(e.contains("may not turn it about its axis"), "{e}");
        // Turned about another axis, its frame is Mitsuba's about the world axis.
        let c = cylinder(
            "cylinder-textured-upright",
            r#"<transform name="to_world"><rotate x="1" angle="90"/></transform>
               <bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf>"#,
        );
        assert!(
            (c.p1 - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6,
            "{:?}",
            c.p1
        );
    }

    /// Mitsuba's disk is the unit disk in z = 0 facing +z, under `to_world`
    /// (an ellipse under a non-uniform scale), its normal kept as for rectangles.
    #[test]
    fn disks_keep_mitsubas_shape_and_normal() {
        let disk = |name: &str, body: &str| {
            let s = scene(name, &format!(r#"<shape type="disk">{body}</shape>"#));
            assert_eq!(s.shapes.disks.len(), 1);
            s.shapes.disks[0]
        };
        let d = disk(
            "disk",
            r#"<transform name="to_world"><scale x="2" y="0.5"/><translate x="1" y="2" z="3"/></transform>"#,
        );
        assert_eq!(
            (d.center, d.u, d.v),
            (Vec3::new(1.0, 2.0, 3.0), 2.0 * Vec3::X, 0.5 * Vec3::Y)
        );
        let normal = |d: Disk| d.u.cross(d.v).normalize();
        assert_eq!(normal(d), Vec3::Z);
        let mirrored = disk(
            "disk-mirror",
            r#"<transform name="to_world"><scale x="-1"/></transform>"#,
        );
        assert_eq!(normal(mirrored), Vec3::Z);
        let flipped = disk(
            "disk-flip",
            r#"<boolean name="flip_normals" value="true"/>"#,
        );
        assert_eq!(normal(flipped), -Vec3::Z);
    }

    #[test]
    fn integrators_map_onto_strategies_and_depths() {
        let render = |name: &str, integrator: &str| read(name, integrator, &[]).unwrap();
        let (s, _) = render(
            "path",
            r#"<integrator type="path"><integer name="max_depth" value="6"/></integrator>"#,
        );
        assert_eq!(s.render.strategy, Strategy::NeeMis);
        assert_eq!(
            (s.render.max_depth, s.render.roulette_depth()),
            (5, Some(5))
        );
        let (s, c) = render("direct", r#"<integrator type="direct"/>"#);
        assert_eq!((s.render.max_depth, s.render.rr_depth), (1, Roulette::Off));
        assert!(
            c.warnings.iter().all(|w| !w.contains("sided")),
            "{:?}",
            c.warnings
        );
        let (s, c) = render(
            "unbounded",
            r#"<integrator type="path"><integer name="rr_depth" value="3"/></integrator>"#,
        );
        assert_eq!(
            (s.render.max_depth, s.render.roulette_depth()),
            (100_000, Some(3))
        );
        assert!(c.warnings.iter().any(|w| w.contains("max_depth -1")));
        assert!(
            error(
                "depth-0",
                r#"<integrator type="path"><integer name="max_depth" value="0"/></integrator>"#
            )
            .contains("max_depth = 0")
        );
    }

    #[test]
    fn bsdfs_map_onto_materials() {
        let s = scene(
            "glass",
            r#"<shape type="sphere"><bsdf type="dielectric"/></shape>
               <shape type="sphere"><bsdf type="dielectric"><string name="int_ior" value="diamond"/>
               <float name="ext_ior" value="1.333"/></bsdf></shape>"#,
        );
        let iors: Vec<_> = s.materials.iter().map(|m| m.kind).collect();
        let glass = |int_ior: f64, ext_ior: f64| crate::scene::MaterialKind::SmoothDielectric {
            int_ior: int_ior as f32,
            ext_ior: ext_ior as f32,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
        };
        assert!(iors.contains(&glass(1.5046, 1.000277)));
        assert!(iors.contains(&glass(2.419, 1.333)));
        // An emitter on a diffuse shape: the same albedo, emitting; in the light density.
        let (s, c) = read(
            "emitter",
            r#"<bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf>
               <shape type="rectangle"><ref id="white"/><emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>"#,
            &[],
        )
        .unwrap();
        let m = &s.materials[s.shapes.quads[0].material as usize];
        assert_eq!(
            (m.albedo, m.emit),
            (Vec3::new(0.2, 0.4, 0.6), Vec3::splat(5.0))
        );
        assert!(s.shapes.quads[0].importance);
        // Outside a twosided, Mitsuba's diffuse is black from behind: one-sided.
        assert!(m.one_sided);
        assert!(
            c.warnings.iter().all(|w| !w.contains("sided")),
            "{:?}",
            c.warnings
        );
        // Wrapped in twosided: two-sided.
        let (s, _) = read(
            "twosided",
            r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        assert!(!s.materials[s.shapes.quads[0].material as usize].one_sided);
        // A diffuse defined at the top level and used only inside a twosided: two-sided too.
        let (s, _) = read(
            "twosided-ref",
            r#"<bsdf type="diffuse" id="d"/>
               <shape type="rectangle"><bsdf type="twosided"><ref id="d"/></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        assert!(!s.materials[s.shapes.quads[0].material as usize].one_sided);
        // Without a BSDF: Mitsuba's default, a one-sided diffuse 0.5, black on an emitter.
        let s = scene(
            "default-bsdf",
            r#"<shape type="rectangle"/>
               <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>"#,
        );
        let material = |i: usize| &s.materials[s.shapes.quads[i].material as usize];
        assert_eq!(
            (material(0).albedo, material(0).one_sided),
            (Vec3::splat(0.5), true)
        );
        assert_eq!(
            (material(1).albedo, material(1).emit),
            (Vec3::ZERO, Vec3::splat(3.0))
        );
        // A one-sided surface's side is its normal's: a flipped sphere is refused.
        let e = error(
            "one-sided-flip",
            r#"<shape type="sphere"><boolean name="flip_normals" value="true"/><bsdf type="diffuse"/></shape>"#,
        );
        assert!(e.contains("one-sided sphere"), "{e}");
        // As is a mirrored one (Mitsuba turns its normals inward), unless also flipped.
        let mirrored =
            r#"<transform name="to_world"><scale x="-1"/></transform><bsdf type="diffuse"/>"#;
        let e = error(
            "one-sided-mirror",
            &format!(r#"<shape type="sphere">{mirrored}</shape>"#),
        );
        assert!(e.contains("one-sided sphere"), "{e}");
        let s = scene(
            "one-sided-mirror-flip",
            &format!(
                r#"<shape type="sphere"><boolean name="flip_normals" value="true"/>{mirrored}</shape>"#
            ),
        );
        assert_eq!(s.shapes.spheres[0].radius, 1.0);
        let s = scene(
            "constant",
            r#"<emitter type="constant"><rgb name="radiance" value="0.5, 1, 2"/></emitter>"#,
        );
        assert_eq!(s.render.background, Vec3::new(0.5, 1.0, 2.0));
    }

    /// Within an emitter a uniform `<spectrum>` is Mitsuba's equal-energy white in
    /// sRGB (purplish); a `<float>` there, and a spectrum in a BSDF, stay grey.
    #[test]
    fn uniform_spectra_in_emitters_are_equal_energy_white() {
        let s = scene(
            "spectra",
            r#"<emitter type="constant"><spectrum name="radiance" value="2"/></emitter>
               <emitter type="point"><float name="intensity" value="3"/></emitter>
               <shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="1"/></emitter></shape>
               <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>"#,
        );
        let white = Vec3::new(1.204794, 0.948291, 0.908916);
        assert!(s.render.background.abs_diff_eq(2.0 * white, 1e-6));
        assert_eq!(s.point_lights[0].intensity, Vec3::splat(3.0));
        let material = |i: usize| &s.materials[s.shapes.quads[i].material as usize];
        assert!(material(0).emit.abs_diff_eq(white, 1e-6));
        assert_eq!(material(1).albedo, Vec3::splat(0.5));
    }

    /// Spectra by wavelength, in `.spd` files and as plugins, read as Mitsuba's RGB
    /// variants read them (the values are Mitsuba's, as src/scene/spectrum.rs checks
    /// them): a reflectance under D65, an emission unweighted, a conductor's `eta`
    /// and `k` unbounded, a file found next to the scene. A plugin stays itself in
    /// an emitter (a `uniform` one is grey there, a `d65` one its colour).
    #[test]
    fn spectra_read_as_mitsubas_rgb_variants() {
        let body = r#"<shape type="rectangle"><bsdf type="diffuse">
                 <spectrum name="reflectance" value="400:0.1, 500:0.5, 600:0.9, 700:0.3"/></bsdf>
                 <emitter type="area"><spectrum name="radiance" filename="light.spd"/></emitter></shape>
               <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" type="srgb">
                 <rgb name="color" value="0.2, 0.4, 0.6"/></spectrum></bsdf>
                 <emitter type="area"><spectrum name="radiance" type="uniform">
                 <float name="value" value="2"/></spectrum></emitter></shape>
               <shape type="rectangle"><bsdf type="diffuse"><spectrum name="reflectance" type="irregular">
                 <string name="wavelengths" value="400, 500, 600, 700"/>
                 <string name="values" value="0.1, 0.5, 0.9, 0.3"/></spectrum></bsdf>
                 <emitter type="area"><spectrum name="radiance" type="d65">
                 <rgb name="color" value="1, 2, 3"/><float name="scale" value="2"/></spectrum></emitter></shape>
               <shape type="sphere"><bsdf type="conductor">
                 <spectrum name="eta" value="400:1.5, 500:0.8, 600:0.3, 700:0.2"/>
                 <spectrum name="k" value="3"/></bsdf></shape>
               <shape type="sphere"><bsdf type="conductor"><string name="material" value="Cu_palik"/></bsdf></shape>
               <emitter type="point"><spectrum name="intensity" type="blackbody">
                 <float name="temperature" value="2700"/></spectrum></emitter>"#;
        let (_dir, path) = folder(
            "spectra",
            &[
                ("scene.xml", &scene_text(body)),
                (
                    "light.spd",
                    "# a light\n400 0.1\n500 0.5\n600 0.9\n700 0.3\n",
                ),
            ],
        );
        let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let close = |ours: Vec3, mitsuba: [f32; 3], tolerance: f32| {
            let mitsuba = Vec3::from_array(mitsuba);
            assert!(
                ours.abs_diff_eq(mitsuba, tolerance * mitsuba.max_element()),
                "{ours} vs Mitsuba's {mitsuba}"
            );
        };
        let quad = |i: usize| &s.materials[s.shapes.quads[i].material as usize];
        close(quad(0).albedo, [0.8547973, 0.6875398, 0.2650152], 1e-6);
        close(quad(0).emit, [0.999234, 0.6596998, 0.22944438], 1e-6);
        assert_eq!(quad(1).albedo, Vec3::new(0.2, 0.4, 0.6));
        assert_eq!(quad(1).emit, Vec3::splat(2.0));
        assert_eq!(quad(2).albedo, quad(0).albedo);
        assert_eq!(quad(2).emit, Vec3::new(2.0, 4.0, 6.0));
        let sphere = |i: usize| s.materials[s.shapes.spheres[i].material as usize].kind;
        let MaterialKind::Conductor { eta, k, .. } = sphere(0) else {
            panic!("{:?}", sphere(0));
        };
        close(eta, [0.17729497, 0.5709648, 1.1914738], 1e-6);
        assert_eq!(k, Vec3::splat(3.0));
        let &(_, eta, k) = spectrum::UNLISTED_CONDUCTORS
            .iter()
            .find(|(n, _, _)| *n == "Cu_palik")
            .expect("in the table");
        assert!(
            matches!(sphere(1), MaterialKind::Conductor { eta: e, k: kk, .. }
            if e == Vec3::from_array(eta) && kk == Vec3::from_array(k))
        );
        close(
            s.point_lights[0].intensity,
            [314.19116, 130.49847, 31.168295],
            1e-5,
        );
    }

    /// A spectrum Mitsuba would refuse, or that pathmix cannot read, is refused at
    /// its element; so is a `.spd` file's error, naming the file and the line.
    #[test]
    fn spectrum_errors_name_the_element() {
        let diffuse = |spectrum: &str| {
            format!(r#"<shape type="rectangle"><bsdf type="diffuse">{spectrum}</bsdf></shape>"#)
        };
        let cases = [
            (
                diffuse(r#"<spectrum name="reflectance" value="700:0.1, 400:0.5"/>"#),
                r#"scene.xml:2:46: <spectrum name="reflectance">: the wavelengths must increase, but 400 follows 700"#,
            ),
            (
                diffuse(r#"<spectrum name="reflectance" value="400:0.1; 700:0.5"/>"#),
                "`0.1;` is not a finite number",
            ),
            (
                diffuse(r#"<spectrum name="reflectance" type="cie1931"/>"#),
                r#"scene.xml:2:46: <spectrum type="cie1931" name="reflectance">: not supported (supported spectra: uniform, srgb, d65, irregular, regular, blackbody)"#,
            ),
            (
                diffuse(
                    r#"<spectrum name="reflectance" type="blackbody"><float name="temperature" value="5000"/></spectrum>"#,
                ),
                "a black body is an emission spectrum",
            ),
            (
                r#"<emitter type="point"><spectrum name="intensity" type="blackbody"><float name="temperature" value="0"/></spectrum></emitter>"#.into(),
                "the temperature must be > 0 K, got 0",
            ),
            (
                diffuse(r#"<spectrum name="reflectance" type="srgb"><rgb name="color" value="2, 0, 0"/></spectrum>"#),
                "is not in [0, 1]",
            ),
            (
                diffuse(
                    r#"<spectrum name="reflectance" type="uniform"><float name="value" value="0.5"/><float name="wavelength_min" value="400"/></spectrum>"#,
                ),
                r#"<float name="wavelength_min">: not supported in <spectrum type="uniform" name="reflectance">"#,
            ),
            (
                diffuse(r#"<spectrum name="reflectance" type="irregular"><string name="values" value="1, 2"/></spectrum>"#),
                r#"missing <string name="wavelengths">"#,
            ),
            (
                diffuse(r#"<spectrum name="reflectance" value="0.5" filename="a.spd"/>"#),
                "give either a `value` or a `filename`",
            ),
            (
                diffuse(r#"<spectrum name="reflectance" filename="gone.spd"/>"#),
                r#"scene.xml:2:46: <spectrum name="reflectance">: cannot find the spectrum file `gone.spd`"#,
            ),
            (
                r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="Cu_palik"/><rgb name="eta" value="1"/></bsdf></shape>"#.into(),
                "give either `material` (here `Cu_palik`) or `eta` and `k`, not both",
            ),
        ];
        for (body, expected) in &cases {
            let e = error("spectrum-errors", body);
            assert!(e.contains(expected), "{body}: {e}");
        }
        let body = diffuse(r#"<spectrum name="reflectance" filename="bad.spd"/>"#);
        let (_dir, path) = folder(
            "bad-spd",
            &[
                ("scene.xml", &scene_text(&body)),
                ("bad.spd", "400 0.1\n500 0.2 0.3\n"),
            ],
        );
        let e = Converted::read(&path, &[]).unwrap_err().to_string();
        assert!(
            e.contains("scene.xml:2:46: <spectrum name=\"reflectance\">: in the spectrum file `")
                && e.contains(
                    "bad.spd`, line 2: expected a wavelength and a value, got `500 0.2 0.3`"
                ),
            "{e}"
        );
    }

    /// `envmap` becomes `[environment]`: the file found like a mesh (written
    /// relative by `convert`), `scale`, `to_world` as `matrix`; one emitter of the
    /// constant or envmap kind at most.
    #[test]
    fn envmap_becomes_the_environment() {
        let body = r#"<emitter type="envmap"><string name="filename" value="sky.hdr"/>
               <float name="scale" value="2"/>
               <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#;
        let (_dir, path) = folder("envmap", &[("scene.xml", &scene_text(body))]);
        // A 2 x 1 Radiance HDR (flat RGBE): (128, 128, 128, 129) is 1.
        let mut hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
        hdr.extend([128, 128, 128, 129, 128, 128, 128, 129]);
        std::fs::write(path.with_file_name("sky.hdr"), &hdr).unwrap();
        let converted = Converted::read(&path, &[]).unwrap();
        let s = Scene::load(&path).unwrap();
        let map = s.environment.expect("an environment map");
        assert_eq!((map.width, map.height, map.scale), (2, 1, 2.0));
        assert_eq!(map.texels[0], [1.0, 1.0, 1.0]);
        // Mitsuba's rotate about +y by 90 degrees: +z goes to +x.
        assert!((map.to_world * Vec3::Z - Vec3::X).length() < 1e-6);
        assert_eq!(s.render.background, Vec3::ZERO);
        // The same lookup as Mitsuba's: nothing approximated.
        assert!(
            converted.warnings.iter().all(|w| !w.contains("envmap")),
            "{:?}",
            converted.warnings
        );
        let toml = converted.to_toml(path.parent().unwrap(), &path);
        assert!(toml.contains("[environment]\nfile = \"sky.hdr\""), "{toml}");
        let twice = format!(
            "{body}<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
        );
        let (_dir, path) = folder("envmap-twice", &[("scene.xml", &scene_text(&twice))]);
        std::fs::write(path.with_file_name("sky.hdr"), "").unwrap();
        let e = Converted::read(&path, &[]).unwrap_err().to_string();
        assert!(e.contains("a second constant or envmap emitter"), "{e}");
    }

    /// Mitsuba's microfacet-era BSDFs map onto pathmix's materials of the same
    /// names, parameter for parameter, with Mitsuba's defaults.
    #[test]
    fn microfacet_bsdfs_map_onto_materials() {
        use crate::scene::{Distribution, MaterialKind};
        let (s, c) = read(
            "microfacet",
            r#"<shape type="sphere"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
                 <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/>
                 <rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.2"/></bsdf></shape>
               <shape type="sphere"><bsdf type="twosided"><bsdf type="plastic">
                 <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/><boolean name="nonlinear" value="true"/></bsdf></bsdf></shape>
               <shape type="sphere"><bsdf type="roughdielectric"><float name="alpha" value="0.2"/>
                 <string name="int_ior" value="diamond"/></bsdf></shape>
               <shape type="sphere"><bsdf type="conductor"/></shape>"#,
            &[],
        )
        .unwrap();
        let kinds: Vec<MaterialKind> = s.materials.iter().map(|m| m.kind).collect();
        assert!(kinds.iter().any(|k| *k
            == MaterialKind::RoughConductor {
                distribution: Distribution::Ggx,
                alpha_u: 0.05,
                alpha_v: 0.3,
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.2),
                specular_reflectance: Vec3::ONE,
            }));
        assert!(kinds.iter().any(|k| matches!(k,
            MaterialKind::RoughDielectric { distribution: Distribution::Beckmann, alpha_u, int_ior, .. }
                if *alpha_u == 0.2 && *int_ior == 2.419)));
        assert!(kinds.iter().any(|k| matches!(k,
            MaterialKind::Plastic { nonlinear: true, int_ior, .. } if *int_ior == 1.49)));
        assert!(
            kinds
                .iter()
                .any(|k| matches!(k, MaterialKind::Conductor { .. }))
        );
        // The conductors outside a twosided are one-sided; the plastic inside
        // one and the (two-sided by nature) rough dielectric are not.
        let sides: Vec<(bool, bool)> = s
            .materials
            .iter()
            .map(|m| {
                let reflects_only = !matches!(
                    m.kind,
                    MaterialKind::RoughDielectric { .. } | MaterialKind::Plastic { .. }
                );
                (reflects_only, m.one_sided)
            })
            .collect();
        assert!(
            sides
                .iter()
                .all(|(reflects_only, one_sided)| reflects_only == one_sided),
            "{sides:?}"
        );
        assert!(
            c.warnings.iter().all(|w| !w.contains("sided")),
            "{:?}",
            c.warnings
        );
        let e = error(
            "rough-range",
            r#"<shape type="sphere"><bsdf type="roughconductor"><float name="alpha" value="2"/></bsdf></shape>"#,
        );
        assert!(e.contains("alpha"), "{e}");
    }

    /// A conductor's `material` preset becomes the TOML `material`, so it takes the
    /// table's RGB `eta` and `k`; `none` with `eta` is Mitsuba's own way of writing
    /// them, any other preset with `eta` is refused as Mitsuba refuses it.
    #[test]
    fn conductor_presets_map_onto_material() {
        use crate::scene::MaterialKind;
        use crate::scene::parse::NAMED_CONDUCTORS;
        let preset = |name: &str| {
            let &(_, eta, k) = NAMED_CONDUCTORS
                .iter()
                .find(|(n, _, _)| *n == name)
                .expect("in the table");
            (Vec3::from_array(eta), Vec3::from_array(k))
        };
        let (s, c) = read(
            "presets",
            r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
               <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="TiN"/>
                 <float name="alpha" value="0.2"/></bsdf></shape>
               <shape type="sphere"><bsdf type="conductor"><string name="material" value="none"/>
                 <rgb name="eta" value="0.5 0.6 0.7"/></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        let toml = c.to_toml(Path::new("."), Path::new("presets.xml"));
        assert!(toml.contains("material = \"Au\"") && toml.contains("material = \"TiN\""));
        let kinds: Vec<MaterialKind> = s.materials.iter().map(|m| m.kind).collect();
        let (eta, k) = preset("Au");
        assert!(kinds.contains(&MaterialKind::Conductor {
            eta,
            k,
            specular_reflectance: Vec3::ONE
        }));
        let (eta, k) = preset("TiN");
        assert!(kinds.iter().any(|kind| matches!(kind,
            MaterialKind::RoughConductor { eta: e, k: kk, alpha_u: 0.2, .. } if *e == eta && *kk == k)));
        assert!(kinds.contains(&MaterialKind::Conductor {
            eta: Vec3::new(0.5, 0.6, 0.7),
            k: Vec3::ONE,
            specular_reflectance: Vec3::ONE
        }));
        let e = error(
            "preset-typo",
            r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="Cu20"/></bsdf></shape>"#,
        );
        assert!(
            e.contains("unknown conductor `Cu20`") && e.contains("did you mean `Cu2O`?"),
            "{e}"
        );
        let e = error(
            "preset-and-eta",
            r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="Au"/>
                 <float name="eta" value="0.2"/></bsdf></shape>"#,
        );
        assert!(e.contains("not both") && e.contains("eta"), "{e}");
    }

    /// `roughplastic` as Veach's scene writes it, and with Mitsuba's defaults
    /// (Beckmann, alpha 0.1, polypropylene in air, diffuse 0.5); an
    /// anisotropic one is refused where it is written, as Mitsuba refuses it.
    #[test]
    fn roughplastic_maps_onto_the_material() {
        use crate::scene::{Distribution, MaterialKind};
        let (s, _) = read(
            "roughplastic",
            r#"<shape type="sphere"><bsdf type="roughplastic">
                 <rgb name="diffuse_reflectance" value="0.07 0.09 0.13"/>
                 <rgb name="specular_reflectance" value="1"/>
                 <float name="int_ior" value="2"/><float name="alpha" value="0.005"/></bsdf></shape>
               <shape type="sphere"><bsdf type="twosided"><bsdf type="roughplastic">
                 <string name="distribution" value="ggx"/><boolean name="nonlinear" value="true"/></bsdf></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        let kinds: Vec<MaterialKind> = s.materials.iter().map(|m| m.kind).collect();
        assert!(kinds.contains(&MaterialKind::RoughPlastic {
            distribution: Distribution::Beckmann,
            alpha: 0.005,
            int_ior: 2.0,
            ext_ior: 1.000277,
            diffuse_reflectance: Vec3::new(0.07, 0.09, 0.13),
            specular_reflectance: Vec3::ONE,
            nonlinear: false,
        }));
        assert!(kinds.contains(&MaterialKind::RoughPlastic {
            distribution: Distribution::Ggx,
            alpha: 0.1,
            int_ior: 1.49,
            ext_ior: 1.000277,
            diffuse_reflectance: Vec3::splat(0.5),
            specular_reflectance: Vec3::ONE,
            nonlinear: true,
        }));
        let e = error(
            "roughplastic-anisotropic",
            r#"<shape type="sphere"><bsdf type="roughplastic">
                 <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf></shape>"#,
        );
        assert!(e.contains("isotropic") && e.contains("alpha_u"), "{e}");
    }

    /// `principled` reads each number, `specular` or `eta`, and `base_color`
    /// as a texture; inside a `twosided` (which Mitsuba allows where it does not
    /// transmit) it is one material on both sides' fronts; a number Mitsuba
    /// reads as a texture may be one, and a texture on another number is
    /// refused where it is written.
    #[test]
    fn principled_maps_onto_the_material() {
        use crate::scene::MaterialKind;
        let (s, _) = read(
            "principled",
            r#"<shape type="sphere"><bsdf type="principled">
                 <rgb name="base_color" value="0.2 0.3 0.4"/><float name="metallic" value="0.25"/>
                 <float name="spec_trans" value="0.5"/><float name="eta" value="1.33"/>
                 <float name="clearcoat_gloss" value="0.9"/></bsdf></shape>
               <shape type="sphere"><bsdf type="twosided"><bsdf type="principled">
                 <texture type="checkerboard" name="base_color"/>
                 <float name="specular" value="0"/></bsdf></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        assert!(s.materials.iter().any(|m| m.kind
            == MaterialKind::Principled {
                base_color: Vec3::new(0.2, 0.3, 0.4),
                roughness: 0.5,
                anisotropic: 0.0,
                metallic: 0.25,
                spec_trans: 0.5,
                eta: 1.33,
                spec_tint: 0.0,
                sheen: 0.0,
                sheen_tint: 0.0,
                clearcoat: 0.0,
                clearcoat_gloss: 0.9,
                flatness: 0.0,
            }));
        let pair = s
            .materials
            .iter()
            .find(|m| matches!(m.kind, MaterialKind::TwoSided))
            .expect("a twosided material");
        assert_eq!(pair.nested[0], pair.nested[1]);
        let inner = s
            .materials
            .iter()
            .find(|m| m.name == pair.nested[0])
            .unwrap();
        assert!(inner.texture.is_some());
        // `specular` 0 is index 1: nothing reflects specularly.
        assert!(matches!(inner.kind, MaterialKind::Principled { eta, .. } if eta == 1.0));
        // A number Mitsuba reads as a texture is one, by its slot; `eta`,
        // which Mitsuba reads as a float, is refused as a texture.
        let (s, _) = read(
            "principled-roughness-texture",
            r#"<shape type="sphere"><bsdf type="principled">
                 <texture type="checkerboard" name="roughness"/></bsdf></shape>"#,
            &[],
        )
        .unwrap();
        let [rough] = &s.materials[..] else {
            panic!("{:?}", s.materials)
        };
        assert_eq!(rough.number_textures.len(), 1);
        assert_eq!(rough.number_textures[0].slot, 0);
        assert!(
            matches!(rough.kind, MaterialKind::Principled { roughness, .. } if roughness == 0.3)
        );
        let e = error(
            "principled-eta-texture",
            r#"<shape type="sphere"><bsdf type="principled">
                 <texture type="checkerboard" name="eta"/></bsdf></shape>"#,
        );
        assert!(
            e.contains("`eta` of a principled is a number, not a texture"),
            "{e}"
        );
    }

    #[test]
    fn parameters_defaults_and_refs() {
        let body = r#"<default name="r" value="2"/>
            <shape type="sphere"><float name="radius" value="$r"/><ref id="later"/></shape>
            <bsdf type="diffuse" id="later"/>"#;
        let (s, _) = read("params", body, &[]).unwrap();
        assert_eq!(s.shapes.spheres[0].radius, 2.0);
        let three = Define::from_str("r=3").unwrap();
        let (s, c) = read("params-d", body, &[three]).unwrap();
        assert_eq!(s.shapes.spheres[0].radius, 3.0);
        assert!(c.warnings.iter().all(|w| !w.contains("parameter")));
        let (_, c) = read("params-unused", body, &["q=1".parse().unwrap()]).unwrap();
        assert!(c.warnings.iter().any(|w| w.contains("parameter `q`")));
        assert!(Define::from_str("no-equals").is_err());
    }

    #[test]
    fn includes_resolve_against_the_top_folder() {
        let (_dir, path) = folder(
            "include",
            &[
                (
                    "scene.xml",
                    &scene_text(r#"<include filename="parts/shapes.xml"/>"#),
                ),
                (
                    "shapes.xml",
                    r#"<scene version="3.0.0"><shape type="obj"><string name="filename" value="quad.obj"/></shape></scene>"#,
                ),
                ("quad.obj", QUAD_OBJ),
            ],
        );
        let parts = path.parent().unwrap().join("parts");
        std::fs::create_dir_all(&parts).unwrap();
        std::fs::rename(path.with_file_name("shapes.xml"), parts.join("shapes.xml")).unwrap();
        let s = Scene::load(&path).unwrap();
        assert_eq!(s.shapes.triangles.len(), 2);
    }

    #[test]
    fn errors_name_the_file_line_column_and_element() {
        let e = error(
            "hair",
            "<shape type=\"sphere\">\n  <bsdf type=\"hair\"/></shape>",
        );
        assert!(
            e.contains("scene.xml:")
                && e.contains(":3:3: <bsdf type=\"hair\">: not supported (supported: diffuse,"),
            "{e}"
        );
        let e = error(
            "unused",
            r#"<shape type="sphere"><float name="alpha" value="1"/></shape>"#,
        );
        assert!(
            e.contains("<float name=\"alpha\">: not supported in <shape type=\"sphere\">"),
            "{e}"
        );
        let e = error(
            "fov",
            r#"<sensor type="perspective"><float name="fov" value="wide"/></sensor>"#,
        );
        assert!(e.contains("`wide` is not a finite number"), "{e}");
        let e = error(
            "range",
            r#"<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="2"/></bsdf></shape>"#,
        );
        assert!(
            e.contains("<bsdf type=\"diffuse\">") && e.contains("albedo"),
            "{e}"
        );
    }

    /// `mask` becomes its BSDF's material with `opacity` (Mitsuba's default 0.5,
    /// or a texture), inside or around `twosided` alike; constant masks inside
    /// masks multiply; an opacity outside [0, 1], a textured mask in another
    /// and an opacity that is no texture are refused at their elements.
    #[test]
    fn mask_becomes_the_opacity_of_its_bsdf() {
        let material = |name: &str, body: &str| {
            let s = scene(name, body);
            s.materials[s.shapes.quads[0].material as usize].clone()
        };
        let m = material(
            "mask",
            r#"<shape type="rectangle"><bsdf type="mask"><float name="opacity" value="0.3"/>
               <bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf></bsdf></shape>"#,
        );
        assert_eq!(
            (m.opacity, m.albedo, m.one_sided),
            (0.3, Vec3::splat(0.2), true)
        );
        let m = material(
            "mask-default",
            r#"<shape type="rectangle"><bsdf type="mask"><bsdf type="roughplastic"/></bsdf></shape>"#,
        );
        assert_eq!(m.opacity, 0.5);
        assert!(matches!(
            m.kind,
            crate::scene::MaterialKind::RoughPlastic { .. }
        ));
        for (name, body) in [
            (
                "mask-in-twosided",
                r#"<bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.25"/>
                   <bsdf type="diffuse"/></bsdf></bsdf>"#,
            ),
            (
                "twosided-in-mask",
                r#"<bsdf type="mask"><float name="opacity" value="0.25"/>
                   <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>"#,
            ),
        ] {
            let m = material(name, &format!("<shape type=\"rectangle\">{body}</shape>"));
            assert_eq!((m.opacity, m.one_sided), (0.25, false), "{name}");
        }
        let m = material(
            "masks",
            r#"<bsdf type="diffuse" id="leaf"/>
               <shape type="rectangle"><bsdf type="mask"><float name="opacity" value="0.5"/>
               <bsdf type="mask"><float name="opacity" value="0.5"/><ref id="leaf"/></bsdf></bsdf>
               <emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>"#,
        );
        assert_eq!((m.opacity, m.emit), (0.25, Vec3::splat(2.0)));

        let e = error(
            "opacity-range",
            "<shape type=\"rectangle\">\n<bsdf type=\"mask\"><float name=\"opacity\" value=\"1.5\"/>\
             <bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(
            e.contains("scene.xml:3:1: <bsdf type=\"mask\">: `opacity` must be in [0, 1], got 1.5"),
            "{e}"
        );
        // A textured opacity (a leaf's mask), nested or referenced: the
        // material's opacity texture, read where a ray hits (its luminance).
        let m = material(
            "opacity-texture",
            r#"<shape type="rectangle"><bsdf type="mask">
               <texture name="opacity" type="checkerboard"><float name="color0" value="0"/>
               <rgb name="color1" value="1, 1, 1"/></texture>
               <bsdf type="diffuse"/></bsdf></shape>"#,
        );
        let texture = m.opacity_texture.as_ref().expect("an opacity texture");
        assert_eq!(m.opacity, 1.0);
        assert!(m.is_masked());
        assert_eq!(texture.eval(glam::Vec2::new(0.25, 0.25)), Vec3::ZERO);
        assert_eq!(texture.eval(glam::Vec2::new(0.25, 0.75)), Vec3::ONE);
        let map = format!("{}/tests/data/textured-map.png", env!("CARGO_MANIFEST_DIR"));
        let m = material(
            "opacity-bitmap",
            &format!(
                r#"<texture type="bitmap" id="leaf-mask"><string name="filename" value="{map}"/></texture>
                   <shape type="rectangle"><bsdf type="mask"><ref name="opacity" id="leaf-mask"/>
                   <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#
            ),
        );
        let texture = m.opacity_texture.as_ref().expect("an opacity texture");
        assert!(matches!(texture.kind, crate::kinds::TextureKind::Bitmap(_)));
        assert_eq!((m.opacity, m.one_sided), (1.0, false));
        // A textured mask with a constant one below 1 around it is refused.
        let e = error(
            "opacity-texture-in-mask",
            "<shape type=\"rectangle\"><bsdf type=\"mask\"><float name=\"opacity\" value=\"0.5\"/>\n\
             <bsdf type=\"mask\"><texture name=\"opacity\" type=\"checkerboard\"/>\
             <bsdf type=\"diffuse\"/></bsdf></bsdf></shape>",
        );
        assert!(
            e.contains("scene.xml:2:25: <bsdf type=\"mask\">: a mask with a textured opacity inside or around another mask"),
            "{e}"
        );
        let e = error(
            "opacity-not-a-texture",
            "<bsdf type=\"diffuse\" id=\"d\"/><shape type=\"rectangle\"><bsdf type=\"mask\">\n\
             <ref name=\"opacity\" id=\"d\"/><bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(e.contains("scene.xml:3:1: <ref"), "{e}");
        assert!(
            e.contains("`opacity` refers to a <bsdf>, not a <texture>"),
            "{e}"
        );
        let e = error(
            "mask-empty",
            r#"<shape type="rectangle"><bsdf type="mask"/></shape>"#,
        );
        assert!(e.contains("other than one nested BSDF"), "{e}");
    }

    /// `twosided` with two BSDFs becomes a `twosided` material naming the
    /// two BSDFs' materials (each one-sided, as alone: the back one sees the
    /// flipped frame), which a mask around it makes masked; a mask inside,
    /// a third BSDF or an emitter on it are refused at their elements.
    #[test]
    fn twosided_with_two_bsdfs_names_its_front_and_back() {
        let s = scene(
            "twosided-pair",
            r#"<bsdf type="diffuse" id="top"><rgb name="reflectance" value="0.2"/></bsdf>
               <shape type="rectangle"><bsdf type="mask"><float name="opacity" value="0.5"/>
               <bsdf type="twosided" id="leaf"><ref id="top"/>
               <bsdf type="roughconductor"/></bsdf></bsdf></shape>"#,
        );
        let by_name = |name: &str| s.materials.iter().find(|m| m.name == name).unwrap();
        let leaf = &s.materials[s.shapes.quads[0].material as usize];
        assert_eq!(leaf.kind, crate::scene::MaterialKind::TwoSided);
        assert_eq!(leaf.opacity, 0.5);
        let [front, back] = [&leaf.nested[0], &leaf.nested[1]].map(|n| by_name(n));
        assert_eq!(
            (front.name.as_str(), front.albedo, front.one_sided),
            ("top", Vec3::splat(0.2), true)
        );
        assert!(matches!(
            back.kind,
            crate::scene::MaterialKind::RoughConductor { .. }
        ));
        assert!(back.one_sided);

        let e = error(
            "twosided-three",
            "<shape type=\"rectangle\">\n<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/>\
             <bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(
            e.contains("scene.xml:3:1: <bsdf type=\"twosided\">: a twosided BSDF with other than one or two"),
            "{e}"
        );
        let e = error(
            "twosided-mask-inside",
            "<shape type=\"rectangle\"><bsdf type=\"twosided\">\n<bsdf type=\"mask\">\
             <bsdf type=\"diffuse\"/></bsdf><bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(
            e.contains("scene.xml:3:1: <bsdf type=\"mask\">: a mask inside a BSDF made of two"),
            "{e}"
        );
        let e = error(
            "twosided-emitter",
            r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse"/>
               <bsdf type="diffuse"/></bsdf><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
        );
        assert!(e.contains("an area emitter on a non-diffuse BSDF"), "{e}");
    }

    /// `blendbsdf` becomes a `blend` material of its weight (a float, default
    /// 0.5, or a texture) and its two BSDFs' materials, in document order
    /// (by `name` where both have one), two-sided inside a `twosided`; a weight
    /// outside [0, 1] and other than two BSDFs are refused at the element.
    #[test]
    fn blendbsdf_becomes_a_blend_of_its_two_bsdfs() {
        use crate::scene::MaterialKind;
        let s = scene(
            "blend",
            r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="blendbsdf">
               <float name="weight" value="0.25"/>
               <bsdf type="diffuse"><rgb name="reflectance" value="0.2"/></bsdf>
               <bsdf type="roughconductor"/></bsdf></bsdf></shape>
               <shape type="rectangle"><bsdf type="blendbsdf">
               <texture name="weight" type="checkerboard"/>
               <bsdf type="conductor" name="bsdf_1"/>
               <bsdf type="diffuse" name="bsdf_0"/></bsdf></shape>"#,
        );
        let by_name = |name: &str| s.materials.iter().find(|m| m.name == name).unwrap();
        let blend = &s.materials[s.shapes.quads[0].material as usize];
        assert_eq!(blend.kind, MaterialKind::Blend { weight: 0.25 });
        let [first, second] = [&blend.nested[0], &blend.nested[1]].map(|n| by_name(n));
        assert_eq!((first.albedo, first.one_sided), (Vec3::splat(0.2), false));
        assert!(matches!(second.kind, MaterialKind::RoughConductor { .. }));
        assert!(!second.one_sided);
        let textured = &s.materials[s.shapes.quads[1].material as usize];
        assert!(textured.texture.is_some());
        let [first, second] = [&textured.nested[0], &textured.nested[1]].map(|n| by_name(n));
        assert_eq!(
            (first.kind, first.one_sided),
            (MaterialKind::Lambertian, true)
        );
        assert!(matches!(second.kind, MaterialKind::Conductor { .. }));

        let e = error(
            "blend-weight",
            "<shape type=\"rectangle\">\n<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"1.5\"/>\
             <bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(
            e.contains(
                "scene.xml:3:1: <bsdf type=\"blendbsdf\">: `weight` must be in [0, 1], got 1.5"
            ),
            "{e}"
        );
        let e = error(
            "blend-one",
            "<shape type=\"rectangle\">\n<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/></bsdf></shape>",
        );
        assert!(
            e.contains("scene.xml:3:1: <bsdf type=\"blendbsdf\">: a blendbsdf with other than two nested BSDFs"),
            "{e}"
        );
    }

    /// `point` and `spot` emitters become `[[lights]]` with Mitsuba's defaults
    /// (intensity 1; cutoff 20 degrees, beam width 3/4 of it), placed by
    /// `position` or `to_world`, a spot aimed down its `to_world`'s z axis.
    #[test]
    fn point_and_spot_emitters_become_lights() {
        use crate::scene::{PointLight, Spot};
        let s = scene(
            "delta-lights",
            r#"<emitter type="point"><point name="position" value="1, 2, 3"/>
                 <rgb name="intensity" value="4, 5, 6"/></emitter>
               <emitter type="point"><transform name="to_world"><translate x="-1"/></transform></emitter>
               <emitter type="spot"><float name="cutoff_angle" value="30"/>
                 <transform name="to_world"><lookat origin="0, 5, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
               </emitter>"#,
        );
        assert_eq!(
            s.point_lights[0],
            PointLight {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Vec3::new(4.0, 5.0, 6.0),
                spot: None,
                directional: None,
            }
        );
        assert_eq!(s.point_lights[1].position, Vec3::new(-1.0, 0.0, 0.0));
        assert_eq!(s.point_lights[1].intensity, Vec3::ONE);
        let spot = s.point_lights[2];
        assert_eq!(spot.position, Vec3::new(0.0, 5.0, 0.0));
        let Some(Spot {
            direction,
            cutoff_angle,
            beam_width,
        }) = spot.spot
        else {
            panic!("{spot:?}");
        };
        assert!((direction - Vec3::NEG_Y).length() < 1e-6, "{direction}");
        assert_eq!((cutoff_angle, beam_width), (30.0, 22.5));
        let e = error(
            "spot-beam",
            r#"<emitter type="spot"><float name="cutoff_angle" value="10"/>
                 <float name="beam_width" value="20"/></emitter>"#,
        );
        assert!(
            e.contains("scene.xml:") && e.contains("lights[0].beam_width"),
            "{e}"
        );
        let e = error(
            "point-negative",
            r#"<emitter type="point"><rgb name="intensity" value="-1"/></emitter>"#,
        );
        assert!(
            e.contains("<emitter type=\"point\">") && e.contains("must be >= 0"),
            "{e}"
        );
        let e = error(
            "point-both",
            r#"<emitter type="point"><point name="position" value="1, 2, 3"/>
                 <transform name="to_world"><translate x="1"/></transform></emitter>"#,
        );
        assert!(e.contains("either `position` or `to_world`"), "{e}");
    }

    #[test]
    fn thindielectric_is_read_with_mitsuba_defaults() {
        let s = scene(
            "thindielectric",
            r#"<shape type="rectangle"><bsdf type="thindielectric">
                 <float name="int_ior" value="1.33"/><rgb name="specular_transmittance" value="0.5"/>
               </bsdf></shape>"#,
        );
        assert_eq!(
            s.materials[s.shapes.quads[0].material as usize].kind,
            MaterialKind::ThinDielectric {
                int_ior: 1.33,
                ext_ior: 1.000277,
                specular_reflectance: Vec3::ONE,
                specular_transmittance: Vec3::splat(0.5),
            }
        );
    }
}
