//! Scene model: the TOML file format, parsed and validated into world-space
//! primitives. Knows nothing of devices or runs.

pub mod envmap;
#[cfg(test)]
mod format_doc;
mod gltf_data;
pub mod mesh;
pub mod mitsuba;
mod parse;
mod prune;
mod spectrum;
mod sphere_field;

use glam::{DAffine3, DVec3, Vec3};
use serde::Serialize;
use std::fmt;
use std::path::{Path, PathBuf};

pub use crate::kinds::{
    Aov, AovKind, Cylinder, Disk, Distribution, Filter, Material, MaterialKind, PointLight, Quad,
    Reconstruction, SceneError, Shapes, Sphere, Spot, Texture, Triangle, excerpt, parse_aovs,
};
pub use envmap::EnvironmentMap;
pub use parse::{AUTO_STRATEGY, OverrideError, SceneOverrides};
pub use sphere_field::{sphere_field, sphere_field_toml};

/// How a diffuse bounce picks its direction (docs/estimator.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Strategy {
    /// `w * p_light + (1 - w) * p_bsdf`: unbiased, the default.
    Mixture,
    /// The material's own sampling only (cosine-weighted for Lambertian);
    /// `cosine`, its name before materials other than the book's, is accepted.
    Bsdf,
    /// Light density only: biased (misses indirect light), a diagnostic.
    Light,
    /// Next-event estimation: at each vertex with a smooth lobe a shadow ray to a
    /// point sampled on an emitter and a BSDF-sampled continuation, combined by the power
    /// heuristic (multiple importance sampling, Veach & Guibas 1995).
    NeeMis,
}

impl Strategy {
    pub const ALL: [Strategy; 4] = [
        Strategy::Mixture,
        Strategy::Bsdf,
        Strategy::Light,
        Strategy::NeeMis,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Mixture => "mixture",
            Strategy::Bsdf => "bsdf",
            Strategy::Light => "light",
            Strategy::NeeMis => "nee-mis",
        }
    }

    pub fn from_name(name: &str) -> Option<Strategy> {
        match name {
            "cosine" => Some(Strategy::Bsdf),
            _ => Strategy::ALL.into_iter().find(|s| s.name() == name),
        }
    }

    /// Russian roulette's start where the scene and the command line leave it
    /// unset, chosen by measured efficiency (docs/rendering.md, "Russian roulette"): from
    /// bounce 5 for `nee-mis` and `bsdf`, whose paths otherwise run to `max_depth`
    /// in a closed scene; off for the mixture and `light`, whose paths are short
    /// (half their directions aim at a light) and lose more to the roulette's
    /// noise than they save.
    pub fn default_rr_depth(self) -> Option<u32> {
        match self {
            Strategy::NeeMis | Strategy::Bsdf => Some(5),
            Strategy::Mixture | Strategy::Light => None,
        }
    }
}

/// Where Russian roulette starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Roulette {
    /// The strategy's own (`Strategy::default_rr_depth`).
    StrategyDefault,
    /// Paths end only at `max_depth`.
    Off,
    /// From this many bounces on.
    From(u32),
}

impl fmt::Display for Strategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a path's random numbers come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum Sampler {
    /// Owen-scrambled Sobol points per pixel: each pair of dimensions is stratified
    /// over the samples of each of `abi::REPLICATES` independently
    /// scrambled replicates (interleaved). Unbiased, with far less noise at edges and
    /// in direct light; the default. The replicates' spread is the error estimate.
    Sobol,
    /// Independent uniform numbers (PCG): the textbook Monte Carlo estimator, whose
    /// per-pixel sample variance is an unbiased error estimate.
    Independent,
}

/// How next-event estimation under `nee-mis` picks the light it samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum LightSelection {
    /// In proportion to a bound on what each light sends toward the shading
    /// point: its radiance, the solid angle it could subtend there and how
    /// squarely it could face it (pbrt-v4's light bounds, without their tree).
    /// Where the scene has two lights or more, each a sphere, rectangle or disk,
    /// and no environment map or emitting mesh; elsewhere uniformly. The default.
    Spatial,
    /// Uniformly, as Mitsuba does: each light once.
    Uniform,
}

impl LightSelection {
    pub const ALL: [LightSelection; 2] = [LightSelection::Spatial, LightSelection::Uniform];

    pub fn name(self) -> &'static str {
        match self {
            LightSelection::Spatial => "spatial",
            LightSelection::Uniform => "uniform",
        }
    }

    pub fn from_name(name: &str) -> Option<LightSelection> {
        LightSelection::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// The error adaptive sampling lowers (`crate::render::adaptive`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum AdaptiveMetric {
    /// Each pixel's error relative to its brightness (floored at a tenth of the
    /// image's mean): the noise a person sees, and the relMSE papers report.
    Relative,
    /// The absolute squared error: the mean squared error of the linear image.
    /// Bright pixels (lights, their reflections) take most of the samples.
    Absolute,
}

impl AdaptiveMetric {
    pub const ALL: [AdaptiveMetric; 2] = [AdaptiveMetric::Relative, AdaptiveMetric::Absolute];

    pub fn name(self) -> &'static str {
        match self {
            AdaptiveMetric::Relative => "relative",
            AdaptiveMetric::Absolute => "absolute",
        }
    }

    pub fn from_name(name: &str) -> Option<AdaptiveMetric> {
        AdaptiveMetric::ALL.into_iter().find(|m| m.name() == name)
    }
}

impl Sampler {
    pub const ALL: [Sampler; 2] = [Sampler::Sobol, Sampler::Independent];

    pub fn name(self) -> &'static str {
        match self {
            Sampler::Sobol => "sobol",
            Sampler::Independent => "independent",
        }
    }

    pub fn from_name(name: &str) -> Option<Sampler> {
        Sampler::ALL.into_iter().find(|s| s.name() == name)
    }
}

impl fmt::Display for Sampler {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The book's pinhole camera (right-handed; `vfov` is vertical, in degrees),
/// a thin lens (Mitsuba's `thinlens`) where `aperture_radius` is above 0, or
/// an orthographic view (Mitsuba's `orthographic`) where `view_width` is set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Camera {
    pub lookfrom: Vec3,
    pub lookat: Vec3,
    pub vup: Vec3,
    pub vfov_degrees: f32,
    pub width: u32,
    pub height: u32,
    pub filter: Filter,
    /// The thin lens's radius in scene units; 0: a pinhole. Left out of the
    /// checkpoint identity's encoding at 0, so that a pinhole scene's identity
    /// is what it was before lenses.
    #[serde(skip_serializing_if = "is_zero")]
    pub aperture_radius: f32,
    /// From the lens to the plane in focus, along the view axis; `None`: the
    /// distance from `lookfrom` to `lookat` (`Camera::focus_distance`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub focus_distance: Option<f32>,
    /// The orthographic projection: the width in scene units of the view the
    /// image covers (its height follows from the image's aspect ratio);
    /// `None`: the perspective projection. Left out of the encoding when `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub view_width: Option<f32>,
}

fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

/// How camera rays leave the camera: each model's code is compiled into the
/// kernel only for the scenes that use it (its kernel flag).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraModel {
    /// Every ray from `lookfrom`.
    Pinhole,
    /// Rays from a point of the lens disk through the point in focus
    /// (`THIN_LENS`).
    ThinLens,
    /// Parallel rays along the view axis from the points of a plane through
    /// `lookfrom` (`ORTHOGRAPHIC`).
    Orthographic,
}

impl Camera {
    pub fn model(&self) -> CameraModel {
        if self.view_width.is_some() {
            CameraModel::Orthographic
        } else if self.aperture_radius > 0.0 {
            CameraModel::ThinLens
        } else {
            CameraModel::Pinhole
        }
    }

    /// The distance from the lens to the plane in focus.
    pub fn focus_distance(&self) -> f32 {
        self.focus_distance
            .unwrap_or_else(|| (self.lookat - self.lookfrom).length())
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub spp: u32,
    /// Maximum number of scattering events on a path; 0 shows emission only.
    pub max_depth: u32,
    pub strategy: Strategy,
    /// `strategy = "auto"`: a pilot (`crate::session::pilot`) chooses `strategy` and
    /// `light_weight` before the run, and until then they hold the defaults; a
    /// renderer refuses the scene while this is set. Setting a strategy clears it.
    pub auto_strategy: bool,
    /// Weight `w` of the light density in the mixture, in [0, 1].
    pub light_weight: f32,
    /// Radiance of rays that escape the scene.
    pub background: Vec3,
    pub seed: u32,
    pub rr_depth: Roulette,
    pub sampler: Sampler,
    /// How `nee-mis` picks the light it samples.
    pub light_selection: LightSelection,
    /// Adaptive sampling (`crate::render::adaptive`), as the command line's `--adaptive`.
    pub adaptive: bool,
    /// The error adaptive sampling lowers; `None`: the run's, the one its
    /// stopping rule measures (absolute for a target error, else relative).
    pub adaptive_metric: Option<AdaptiveMetric>,
    /// How pixels are made of the samples around them; `None`: splatting
    /// where the filter is wider than a pixel and the run allows it
    /// (`render::plan_kernel`).
    pub reconstruction: Option<Reconstruction>,
    /// The AOVs written beside the image (`kinds::aov`), in the order asked.
    pub aovs: Vec<Aov>,
    /// Which side of a smooth surface a ray meets is decided by the shading
    /// normal, as Mitsuba decides it (its files set this), rather than by the
    /// geometric one with no light through the surface (the default).
    pub sides_by_shading_normal: bool,
}

impl RenderSettings {
    /// How pixels are made of samples with `filter`, as asked or by default:
    /// splatting for any filter but the box, by which it is the same as drawing
    /// offsets from the filter (`render::plan_kernel` may still draw them,
    /// where a run cannot splat).
    pub fn reconstruction_with(&self, filter: Filter) -> Reconstruction {
        match (self.reconstruction, filter) {
            (_, Filter::Box) => Reconstruction::Importance,
            (Some(asked), _) => asked,
            (None, _) => Reconstruction::Splat,
        }
    }

    /// Russian roulette from this many bounces on (`None`: paths end only at `max_depth`).
    pub fn roulette_depth(&self) -> Option<u32> {
        match self.rr_depth {
            Roulette::StrategyDefault => self.strategy.default_rr_depth(),
            Roulette::Off => None,
            Roulette::From(depth) => Some(depth),
        }
    }
}

/// A validated scene: world-space primitives after box expansion and transforms.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file it came from, for messages.
    pub source: String,
    pub camera: Camera,
    pub render: RenderSettings,
    pub materials: Vec<Material>,
    pub shapes: Shapes,
    /// Shape groups and their instances (`[[groups]]`, `instance` objects).
    pub instancing: Instancing,
    /// Mesh faces dropped for having no area in 32-bit floats.
    pub degenerate_triangles: usize,
    /// Point and spot lights (`[[lights]]`).
    pub point_lights: Vec<PointLight>,
    /// Radiance arriving from every direction a ray escapes in (`[environment]`);
    /// a scene with one has no `background`.
    pub environment: Option<EnvironmentMap>,
    /// What the user should know about how the file was read (glTF materials
    /// mapped to pathmix's, mesh faces dropped).
    pub warnings: Vec<String>,
    /// The files read besides the scene file (meshes, images, included XML),
    /// as they were opened: no output may replace one.
    pub inputs: Vec<PathBuf>,
}

/// Geometry defined once and placed many times (Mitsuba's `shapegroup` and
/// `instance`): each group's shapes in its own object space, and each
/// instance's group and transform. Rendered through a two-level BVH
/// (`accel::Instancing`), so memory grows with the groups, not the copies.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Instancing {
    pub groups: Vec<ShapeGroup>,
    pub instances: Vec<Instance>,
}

/// `[[groups]]`: named shapes that only instances show. None emits (as in
/// Mitsuba, which refuses emitters in groups).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ShapeGroup {
    pub name: String,
    pub shapes: Shapes,
}

/// An `instance` object: its group (index into `Instancing::groups`) and its
/// object-to-world transform, the affine matrix's three rows.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Instance {
    pub group: u32,
    pub to_world: [[f32; 4]; 3],
}

impl Instance {
    pub fn to_world(&self) -> DAffine3 {
        let [r0, r1, r2] = self.to_world.map(|r| r.map(f64::from));
        DAffine3::from_cols_array(&[
            r0[0], r1[0], r2[0], r0[1], r1[1], r2[1], r0[2], r1[2], r2[2], r0[3], r1[3], r2[3],
        ])
    }
}

impl Instancing {
    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// Each group's shapes, then every instance's box in world space, as
    /// `Scene::extent` measures the scene: the largest absolute coordinate of
    /// the corners of the group's box (from `Shape::extent`) carried to world space.
    pub fn extent(&self) -> f32 {
        let group_extents: Vec<f64> = (self.groups.iter())
            .map(|g| g.shapes.iter().map(|s| s.extent()).fold(0.0f32, f32::max) as f64)
            .collect();
        let mut extent = 0.0f32;
        for instance in &self.instances {
            let e = group_extents[instance.group as usize];
            let to_world = instance.to_world();
            for corner in 0..8 {
                let sign = |bit: usize| if corner >> bit & 1 == 1 { e } else { -e };
                let p = to_world.transform_point3(DVec3::new(sign(0), sign(1), sign(2)));
                extent = extent.max(p.abs().max_element() as f32);
            }
        }
        extent
    }
}

/// A scene as read, with the approximations made reading it (Mitsuba scenes).
#[derive(Clone, Debug)]
pub struct LoadedScene {
    pub scene: Scene,
    /// One phrase per approximation, for a warning.
    pub warnings: Vec<String>,
    /// Where a Mitsuba file gives each pathmix field, as `(field, place)` pairs
    /// (`materials.light` and `scene.xml:12:5: <emitter type="area">`), for
    /// messages made after reading ([`LoadedScene::place_of`]). Empty for a TOML
    /// file, whose messages name the field itself.
    pub places: Vec<(String, String)>,
    /// The sampler the file names where the scene samples with another
    /// (`mitsuba::Converted::file_sampler`), for the run to say so.
    pub file_sampler: Option<Sampler>,
}

impl LoadedScene {
    /// Where the file gives `field` (`materials.light.emit`), if that is not
    /// the field itself.
    pub fn place_of<'a>(places: &'a [(String, String)], field: &str) -> Option<&'a str> {
        places
            .iter()
            .find(|(prefix, _)| field == prefix || field.starts_with(&format!("{prefix}.")))
            .map(|(_, place)| place.as_str())
    }
}

/// A reading crate's message, which may quote a file's text, with each word
/// (white space between) as [`excerpt`] quotes it.
pub fn excerpt_words(message: &str) -> String {
    let words: Vec<_> = message.split_whitespace().map(excerpt).collect();
    words.join(" ")
}

impl Scene {
    /// Reads, parses and validates a scene file (TOML or Mitsuba XML).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_with(path, &[]).map(|loaded| loaded.scene)
    }

    /// Reads a scene file: pathmix TOML, or a Mitsuba 3 XML scene (a `.xml` name or
    /// a `<scene version=...>` root) with its `-D name=value` parameters.
    pub fn load_with(path: &Path, defines: &[mitsuba::Define]) -> Result<LoadedScene, SceneError> {
        let file = path.display().to_string();
        let text = crate::paths::read_input_text(path).map_err(|e| SceneError {
            file: file.clone(),
            location: String::new(),
            message: format!("cannot read the scene file: {e}"),
        })?;
        if mitsuba::is_mitsuba(path, &text) {
            let converted = mitsuba::Converted::read(path, defines)?;
            let toml = toml::to_string(&converted.document).expect("a TOML table serializes");
            let mut scene = Scene::parse(&toml, &file).map_err(|e| converted.locate(e))?;
            let places = converted.places();
            scene.inputs.extend(converted.includes);
            return Ok(LoadedScene {
                scene,
                places,
                warnings: converted.warnings,
                file_sampler: converted.file_sampler,
            });
        }
        if let Some(define) = defines.first() {
            return Err(SceneError {
                file,
                location: String::new(),
                message: format!(
                    "parameter `{}`: parameters apply to Mitsuba XML scenes only",
                    define.name
                ),
            });
        }
        Ok(LoadedScene {
            scene: Scene::parse(&text, &file)?,
            warnings: Vec::new(),
            places: Vec::new(),
            file_sampler: None,
        })
    }

    /// Parses and validates scene text; `file` names it in messages.
    pub fn parse(text: &str, file: &str) -> Result<Scene, SceneError> {
        parse::parse_scene(text, file)
    }

    /// Objects in the light density.
    pub fn importance_count(&self) -> usize {
        self.shapes.iter().filter(|s| s.importance()).count()
    }

    /// Largest absolute coordinate of any geometry or the camera: the scene's size,
    /// from which ray offsets are derived (so the scene renders the same at any scale).
    pub fn extent(&self) -> f32 {
        let mut extent = self.camera.lookfrom.abs().max_element();
        for shape in self.shapes.iter() {
            extent = extent.max(shape.extent());
        }
        extent = extent.max(self.instancing.extent());
        for l in &self.point_lights {
            extent = extent.max(l.position.abs().max_element());
        }
        extent
    }
}
