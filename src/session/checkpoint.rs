//! Checkpoints: a run's accumulated state in one file, so that a resumed run
//! continues bit-exactly; and the scene identity (per-part hashes) that resumes
//! and merges check.
//!
//! File layout (little-endian):
//!
//! | bytes | what |
//! | --- | --- |
//! | 8 | magic `PMXCKPT\0` |
//! | 4 | format version (u32, [`VERSION`]) |
//! | 4 | header length H (u32) |
//! | H | header: UTF-8 TOML (scene, overrides, state, the caller's `[run]` table) |
//! | 8 | number of f32 values N (u64) |
//! | 4·N | the raw accumulator texels (`AccumulatorState::texels`, rgba f32) |
//! | 8 | number of u32 values M (u64): 0, or for an adaptive run... |
//! | 4·M | ...each pixel's sample count, then the round's `[pixel, count at its start]` pairs |
//! | 4 | CRC-32 (IEEE) of every byte before it |

use crate::kinds::PRIMITIVE_KINDS;
use crate::output::{self, OutputError};
use crate::render::adaptive::Choice;
use crate::render::{AccumulatorState, AdaptiveState};
use crate::scene::{
    AdaptiveMetric, Aov, LightSelection, Reconstruction, RenderSettings, Sampler, Scene,
    SceneOverrides, Strategy, parse_aovs,
};
use serde::Serialize;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

pub const MAGIC: [u8; 8] = *b"PMXCKPT\0";
/// 2: the scene hashes come from the whole scene's `Debug` text (1: chosen fields).
/// 3: Sobol samples come from interleaved replicates (other images), whose sums
/// variance adds as layers.
/// 4: adaptive runs' per-pixel counts and round follow the texels.
/// 5: adaptive runs record the pilot's choice (adaptive, or uniform on).
/// 6: the scene hashes come from a stable encoding of the scene's parts
/// (`encoding_hash`), no longer from their `Debug` text.
/// 7: materials encode their `opacity` (Mitsuba's `mask`).
/// 8: the geometry encodes cylinders (`kinds::cylinder`).
pub const VERSION: u32 = 8;

/// FNV-1a, 64 bits: the scene identity's hash function (stable across platforms).
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    pub fn bytes(&mut self, bytes: &[u8]) -> &mut Self {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// What a run's sums depend on, by part, with the values that messages name:
/// every field of the [`Scene`], after command-line overrides, but the file's
/// path and the sample count (`spp`), which only says when to stop.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneIdentity {
    /// Position, direction, up, field of view, image size and filter.
    pub camera_hash: u64,
    /// Every material, each whole (name, kind with its parameters, colours,
    /// texture with its texels).
    pub materials_hash: u64,
    /// Every shape of every kind, each whole (with its material and importance
    /// mark), and the point lights.
    pub geometry_hash: u64,
    /// Seed, depth, strategy, light weight, background, Russian roulette depth, sampler,
    /// environment map (its settings and texels), and splatting where it splats.
    pub settings_hash: u64,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub max_depth: u32,
    pub strategy: Strategy,
    pub light_weight: f32,
    /// Russian roulette depth; `None`: off.
    pub rr_depth: Option<u32>,
    pub sampler: Sampler,
    pub materials: u32,
    /// How many shapes of each kind, in the order of `kinds::PRIMITIVE_KINDS`.
    pub shapes: Vec<u32>,
    pub point_lights: u32,
}

impl SceneIdentity {
    pub fn of(scene: &Scene) -> SceneIdentity {
        // No `..`: a new field fails to compile until it joins a part or is
        // excluded here with the reason.
        let Scene {
            // The file's path, not its content: a moved file is the same scene.
            source: _,
            camera,
            render,
            materials,
            shapes,
            instancing,
            // Follows from the mesh files, whose faces are hashed.
            degenerate_triangles: _,
            point_lights,
            // Messages only: what they describe is in the materials.
            warnings: _,
            environment,
            // Where the meshes and images came from: what they hold is hashed.
            inputs: _,
        } = scene;
        let RenderSettings {
            // Only says when to stop: a resume or a shard may ask for more.
            spp: _,
            max_depth,
            strategy,
            // A run starts only once the pilot has set the strategy it hashes.
            auto_strategy: _,
            light_weight,
            background,
            seed,
            // Hashed as resolved (`roulette_depth`): the strategy's default and
            // the same depth given are the same run.
            rr_depth: _,
            sampler,
            // How the run samples, not what it estimates: a checkpoint records
            // the pick its run made (`[run] light_selection`), which a resume keeps.
            light_selection: _,
            // How the run samples, not what it estimates; the state says whether
            // it was adaptive (its counts), and a resume must match it.
            adaptive: _,
            // Which pixels the rounds sample, not what the run estimates.
            adaptive_metric: _,
            // Hashed as resolved (`reconstruction_with`), and only where it
            // splats, so that runs drawing offsets from the filter keep the
            // hash they had before splatting was a choice.
            reconstruction: _,
            // Written beside the image, from a pass of their own.
            aovs: _,
            // Hashed only where set, so that other scenes keep their hash.
            sides_by_shading_normal,
        } = render;
        let rr_depth = render.roulette_depth();
        let splats = render.reconstruction_with(camera.filter) == Reconstruction::Splat;
        let settings = (
            max_depth,
            strategy,
            light_weight,
            background,
            seed,
            rr_depth,
            sampler,
            environment,
        );
        SceneIdentity {
            camera_hash: encoding_hash(camera),
            materials_hash: encoding_hash(materials),
            // Instancing joins the encoding only where there is some, so that
            // other scenes keep the hash they had before instances.
            geometry_hash: match instancing.is_empty() && instancing.groups.is_empty() {
                true => encoding_hash(&(shapes, point_lights)),
                false => encoding_hash(&(shapes, point_lights, instancing)),
            },
            // A tuple encodes as its elements one after another, so the
            // splatting run's encoding is the others' followed by `Splat`.
            settings_hash: match (splats, sides_by_shading_normal) {
                (false, false) => encoding_hash(&settings),
                (true, false) => encoding_hash(&(settings, Reconstruction::Splat)),
                (_, true) => encoding_hash(&(settings, splats, "sides_by_shading_normal")),
            },
            width: camera.width,
            height: camera.height,
            seed: *seed,
            max_depth: *max_depth,
            strategy: *strategy,
            light_weight: *light_weight,
            rr_depth,
            sampler: *sampler,
            materials: materials.len() as u32,
            shapes: shapes.counts().into_iter().map(|n| n as u32).collect(),
            point_lights: point_lights.len() as u32,
        }
    }

    /// One hash of every part: the "scene hash" of checkpoints and partial results.
    pub fn hash(&self) -> u64 {
        Fnv64::default()
            .u64(self.camera_hash)
            .u64(self.materials_hash)
            .u64(self.geometry_hash)
            .u64(self.settings_hash)
            .finish()
    }

    /// What differs between `a` and `b`, one phrase per part ("the camera
    /// differs: ..."), naming values with the labels (`"in the checkpoint"`,
    /// `"now"`); empty when they are the same.
    pub fn differences(
        (a, a_label): (&SceneIdentity, &str),
        (b, b_label): (&SceneIdentity, &str),
    ) -> Vec<String> {
        let (saved, now) = (a, b);
        let mut out = Vec::new();
        if saved.camera_hash != now.camera_hash {
            if (saved.width, saved.height) != (now.width, now.height) {
                out.push(format!(
                    "the camera differs: image size {}x{} {a_label}, {}x{} {b_label}",
                    saved.width, saved.height, now.width, now.height
                ));
            } else {
                out.push(
                    "the camera differs (position, direction, up vector, field of view or filter)"
                        .into(),
                );
            }
        }
        if saved.materials_hash != now.materials_hash {
            out.push(if saved.materials != now.materials {
                format!(
                    "the materials differ: {} {a_label}, {} {b_label}",
                    saved.materials, now.materials
                )
            } else {
                "the materials differ (names, kinds, colours, parameters or textures)".into()
            });
        }
        if saved.geometry_hash != now.geometry_hash {
            let counts: Vec<String> = (saved.counts().zip(now.counts()))
                .filter(|((_, a), (_, b))| a != b)
                .map(|((name, a), (_, b))| format!("{name} {a} {a_label}, {b} {b_label}"))
                .collect();
            out.push(if counts.is_empty() {
                "the geometry differs (object positions, sizes, materials or importance, or \
                 point lights)"
                    .into()
            } else {
                format!("the geometry differs: {}", counts.join(", "))
            });
        }
        if saved.settings_hash != now.settings_hash {
            let mut fields = Vec::new();
            let mut field = |name: &str, a: String, b: String| {
                if a != b {
                    fields.push(format!("{name} {a} {a_label}, {b} {b_label}"));
                }
            };
            field("seed", saved.seed.to_string(), now.seed.to_string());
            field(
                "max_depth",
                saved.max_depth.to_string(),
                now.max_depth.to_string(),
            );
            field(
                "strategy",
                saved.strategy.to_string(),
                now.strategy.to_string(),
            );
            field(
                "light_weight",
                saved.light_weight.to_string(),
                now.light_weight.to_string(),
            );
            field("rr_depth", rr_text(saved.rr_depth), rr_text(now.rr_depth));
            field(
                "sampler",
                saved.sampler.to_string(),
                now.sampler.to_string(),
            );
            if fields.is_empty() {
                fields.push("background or reconstruction (splatting or not)".into());
            }
            out.push(format!("the render settings differ: {}", fields.join(", ")));
        }
        out
    }

    /// How many shapes of each kind and point lights, each with its name.
    fn counts(&self) -> impl Iterator<Item = (&'static str, u32)> {
        let names = PRIMITIVE_KINDS.iter().map(|kind| kind.array);
        (names.zip(self.shapes.iter().copied())).chain([("point lights", self.point_lights)])
    }

    /// As text pairs, for file headers (checkpoints, partial results).
    pub fn to_pairs(&self) -> Vec<(&'static str, String)> {
        vec![
            ("hash", hex(self.hash())),
            ("camera_hash", hex(self.camera_hash)),
            ("materials_hash", hex(self.materials_hash)),
            ("geometry_hash", hex(self.geometry_hash)),
            ("settings_hash", hex(self.settings_hash)),
            ("width", self.width.to_string()),
            ("height", self.height.to_string()),
            ("seed", self.seed.to_string()),
            ("max_depth", self.max_depth.to_string()),
            ("strategy", self.strategy.to_string()),
            ("light_weight", self.light_weight.to_string()),
            ("rr_depth", rr_text(self.rr_depth)),
            ("sampler", self.sampler.to_string()),
            ("materials", self.materials.to_string()),
        ]
        .into_iter()
        .chain(
            PRIMITIVE_KINDS
                .iter()
                .map(|kind| kind.array)
                .zip(self.shapes.iter().map(u32::to_string)),
        )
        .chain([("point_lights", self.point_lights.to_string())])
        .collect()
    }

    /// Reads what `to_pairs` wrote; `get` looks a key up. Checks the combined hash.
    pub fn from_pairs(
        get: impl Fn(&str) -> Option<String>,
    ) -> Result<SceneIdentity, IdentityError> {
        let text = |key: &str| get(key).ok_or_else(|| IdentityError::Missing { key: key.into() });
        fn parse<T: std::str::FromStr>(key: &str, value: String) -> Result<T, IdentityError> {
            value.parse().map_err(|_| IdentityError::Invalid {
                key: key.into(),
                value,
            })
        }
        let hash = |key: &str| -> Result<u64, IdentityError> {
            let value = text(key)?;
            u64::from_str_radix(&value, 16).map_err(|_| IdentityError::NotAHash {
                key: key.into(),
                value,
            })
        };
        let number = |key: &str| -> Result<u32, IdentityError> { parse(key, text(key)?) };
        let strategy = text("strategy")?;
        let sampler = text("sampler")?;
        let identity = SceneIdentity {
            camera_hash: hash("camera_hash")?,
            materials_hash: hash("materials_hash")?,
            geometry_hash: hash("geometry_hash")?,
            settings_hash: hash("settings_hash")?,
            width: number("width")?,
            height: number("height")?,
            seed: number("seed")?,
            max_depth: number("max_depth")?,
            strategy: Strategy::from_name(&strategy)
                .ok_or(IdentityError::UnknownStrategy { name: strategy })?,
            light_weight: parse("light_weight", text("light_weight")?)?,
            rr_depth: match text("rr_depth")?.as_str() {
                "off" => None,
                depth => Some(parse("rr_depth", depth.to_string())?),
            },
            sampler: Sampler::from_name(&sampler)
                .ok_or(IdentityError::UnknownSampler { name: sampler })?,
            materials: number("materials")?,
            shapes: (PRIMITIVE_KINDS.iter())
                .map(|kind| number(kind.array))
                .collect::<Result<_, _>>()?,
            point_lights: number("point_lights")?,
        };
        if hash("hash")? != identity.hash() {
            return Err(IdentityError::HashMismatch);
        }
        Ok(identity)
    }
}

/// FNV-1a of a value's postcard encoding: every field, nested, in declaration
/// order, with integers as varints, floats as their bits and images' texels as
/// their bytes (`kinds::serialize_texels`); field names are not encoded. Only
/// the values and the types' fields and variants (their order) shape it, and the
/// golden test below fails when the encoding changes: then [`VERSION`] goes up,
/// so that old files are refused as older, never as a different scene.
fn encoding_hash(value: &impl Serialize) -> u64 {
    postcard::serialize_with_flavor(value, Hashing(Fnv64::default()))
        .expect("the scene's types serialize (no sequence of unknown length)")
}

/// A postcard output that hashes the bytes instead of keeping them.
struct Hashing(Fnv64);

impl postcard::ser_flavors::Flavor for Hashing {
    type Output = u64;

    fn try_extend(&mut self, bytes: &[u8]) -> postcard::Result<()> {
        self.0.bytes(bytes);
        Ok(())
    }

    fn try_push(&mut self, byte: u8) -> postcard::Result<()> {
        self.0.bytes(&[byte]);
        Ok(())
    }

    fn finalize(self) -> postcard::Result<u64> {
        Ok(self.0.finish())
    }
}

/// Recorded scene identity pairs that do not make one.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum IdentityError {
    #[error("missing `{key}`")]
    Missing { key: String },
    #[error("`{key}` is not valid: `{value}`")]
    Invalid { key: String, value: String },
    #[error("`{key}` is not a hash: `{value}`")]
    NotAHash { key: String, value: String },
    #[error("unknown strategy `{name}`")]
    UnknownStrategy { name: String },
    #[error("unknown sampler `{name}`")]
    UnknownSampler { name: String },
    #[error("the scene hash does not match its parts")]
    HashMismatch,
}

pub fn hex(v: u64) -> String {
    format!("{v:016x}")
}

/// Everything needed to continue a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// The pathmix that wrote it (`CARGO_PKG_VERSION`).
    pub pathmix_version: String,
    /// The scene file, absolute.
    pub scene_path: PathBuf,
    /// Command-line settings applied over the scene file (`spp` is not kept).
    pub overrides: SceneOverrides,
    /// The scene after the overrides.
    pub identity: SceneIdentity,
    /// Samples discarded as NaN or infinite so far.
    pub discarded: u64,
    /// The caller's own settings (outputs, stopping rule), kept as they are.
    pub run: toml::Table,
    pub state: AccumulatorState,
}

/// A checkpoint that cannot be used, and why.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("checkpoint `{}`: cannot read it: {source}", .path.display())]
    Read { path: PathBuf, source: io::Error },
    #[error("checkpoint `{}`: {source}", .path.display())]
    Format { path: PathBuf, source: FormatError },
}

/// What is wrong with a checkpoint file's bytes.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum FormatError {
    #[error("truncated: only {len} bytes")]
    Truncated { len: usize },
    #[error("not a pathmix checkpoint (wrong magic bytes)")]
    WrongMagic,
    /// This pathmix reads no older format, so it cannot check the scene a run
    /// was rendered from (before version 6 the scene hashes were of `Debug` text).
    #[error(
        "written by an older pathmix (checkpoint format version {version}; this pathmix ({}) \
         reads version {VERSION}), whose scene identity this pathmix cannot check: start the \
         run again (without --resume; its --checkpoint may replace this file)",
        env!("CARGO_PKG_VERSION")
    )]
    Older { version: u32 },
    #[error(
        "written by a newer pathmix (checkpoint format version {version}; this pathmix ({}) \
         reads version {VERSION}): resume with the pathmix that wrote it, or start the run again",
        env!("CARGO_PKG_VERSION")
    )]
    Newer { version: u32 },
    #[error("truncated or corrupted: the file has {len} bytes, its layout says {expected}")]
    LengthMismatch { len: usize, expected: u128 },
    #[error("corrupted: the checksum does not match the contents")]
    Checksum,
    #[error("corrupted: the header is not UTF-8")]
    HeaderNotUtf8,
    #[error("bad header: {0}")]
    Header(#[from] HeaderError),
}

/// What is wrong with a checkpoint's TOML header.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum HeaderError {
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    #[error("missing table `[{key}]`")]
    MissingTable { key: String },
    #[error("missing `{key}`")]
    Missing { key: String },
    #[error("[scene]: {0}")]
    Scene(#[from] IdentityError),
    #[error("`{table}.{key}` is not a u32")]
    NotU32 { table: String, key: String },
    #[error("`overrides.{key}` is not a {key}")]
    NotNamed { key: String },
    #[error("`overrides.light_weight` is not a number")]
    LightWeight,
    #[error("`overrides.rr_depth` is not a depth or `off`")]
    RrDepth,
    #[error("`overrides.aovs` is not a list of AOVs")]
    Aovs,
    #[error("{count} texels of data for {width}x{height} pixels and {layers} layers")]
    TexelCount {
        count: usize,
        width: u32,
        height: u32,
        layers: u32,
    },
    #[error("the sums' size differs from the scene's")]
    SizeDiffers,
    #[error("{count} adaptive counts for {width}x{height} pixels and {entries} round entries")]
    AdaptiveCount {
        count: usize,
        width: u32,
        height: u32,
        entries: u32,
    },
}

/// Writes `checkpoint` atomically (temporary file, fsync, rename).
pub fn write(path: &Path, checkpoint: &Checkpoint) -> Result<(), OutputError> {
    let header = header(checkpoint);
    output::write_atomically(path, |file| {
        let mut writer = CrcWriter {
            inner: file,
            crc: crc32fast::Hasher::new(),
        };
        encode(&mut writer, &header, &checkpoint.state)?;
        let crc = writer.crc.finalize();
        writer.inner.write_all(&crc.to_le_bytes())
    })
}

/// The file's bytes, as `write` writes them.
pub fn to_bytes(checkpoint: &Checkpoint) -> Vec<u8> {
    let mut bytes = Vec::new();
    encode(&mut bytes, &header(checkpoint), &checkpoint.state).expect("writing to memory");
    let crc = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

struct CrcWriter<W> {
    inner: W,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for CrcWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

fn encode(out: &mut impl Write, header: &str, state: &AccumulatorState) -> io::Result<()> {
    out.write_all(&MAGIC)?;
    out.write_all(&VERSION.to_le_bytes())?;
    out.write_all(&(header.len() as u32).to_le_bytes())?;
    out.write_all(header.as_bytes())?;
    out.write_all(&(state.texels.len() as u64 * 4).to_le_bytes())?;
    write_f32s(out, bytemuck::cast_slice(&state.texels))?;
    let words: Vec<u32> = state.adaptive.as_ref().map_or_else(Vec::new, |a| {
        let round = a.round.iter().flatten();
        a.counts.iter().chain(round).copied().collect()
    });
    out.write_all(&(words.len() as u64).to_le_bytes())?;
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    out.write_all(&bytes)
}

/// Little-endian f32s, in chunks.
pub fn write_f32s(out: &mut impl Write, values: &[f32]) -> io::Result<()> {
    if cfg!(target_endian = "little") {
        out.write_all(bytemuck::cast_slice(values))
    } else {
        let mut buffer = Vec::with_capacity(4 * 4096);
        for chunk in values.chunks(4096) {
            buffer.clear();
            buffer.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
            out.write_all(&buffer)?;
        }
        Ok(())
    }
}

fn header(c: &Checkpoint) -> String {
    use toml::Value;
    let mut root = toml::Table::new();
    root.insert("format".into(), "pathmix checkpoint".into());
    root.insert("pathmix_version".into(), c.pathmix_version.clone().into());
    root.insert(
        "scene_path".into(),
        c.scene_path.to_string_lossy().into_owned().into(),
    );
    let scene: toml::Table = c
        .identity
        .to_pairs()
        .into_iter()
        .map(|(k, v)| (k.to_string(), Value::from(v)))
        .collect();
    root.insert("scene".into(), scene.into());
    let o = &c.overrides;
    let mut overrides = toml::Table::new();
    let mut number = |key: &str, v: Option<u32>| {
        if let Some(v) = v {
            overrides.insert(key.into(), Value::Integer(v.into()));
        }
    };
    number("width", o.width);
    number("height", o.height);
    number("max_depth", o.max_depth);
    number("seed", o.seed);
    if let Some(s) = o.strategy {
        overrides.insert("strategy".into(), s.name().into());
    }
    if let Some(w) = o.light_weight {
        overrides.insert("light_weight".into(), Value::Float(w.into()));
    }
    if let Some(rr) = o.rr_depth {
        overrides.insert("rr_depth".into(), rr_text(rr).into());
    }
    if let Some(s) = o.sampler {
        overrides.insert("sampler".into(), s.name().into());
    }
    if let Some(p) = o.light_selection {
        overrides.insert("light_selection".into(), p.name().into());
    }
    if let Some(m) = o.adaptive_metric {
        overrides.insert("adaptive_metric".into(), m.name().into());
    }
    if let Some(r) = o.reconstruction {
        overrides.insert("reconstruction".into(), r.name().into());
    }
    if let Some(aovs) = &o.aovs {
        let specs: Vec<String> = aovs.iter().map(Aov::spec).collect();
        overrides.insert("aovs".into(), specs.join(",").into());
    }
    root.insert("overrides".into(), overrides.into());
    let s = &c.state;
    let mut state = toml::Table::new();
    for (key, v) in [
        ("width", s.width),
        ("height", s.height),
        ("layers", s.layers),
        ("first_sample", s.first_sample),
        ("samples", s.samples),
    ] {
        state.insert(key.into(), Value::Integer(v.into()));
    }
    if let Some(a) = &s.adaptive {
        for (key, v) in [
            ("adaptive_round_entries", a.round.len() as u32),
            ("adaptive_round_samples", a.round_samples),
            ("adaptive_round_done", a.round_done),
        ] {
            state.insert(key.into(), Value::Integer(v.into()));
        }
        if let Some(choice) = a.choice {
            state.insert(
                "adaptive_predicted_ratio".into(),
                choice.predicted_ratio.into(),
            );
            state.insert("adaptive_uniform".into(), choice.uniform.into());
        }
    }
    // TOML integers are i64; a count past that is not a real case.
    state.insert(
        "discarded".into(),
        Value::Integer(c.discarded.min(i64::MAX as u64) as i64),
    );
    root.insert("state".into(), state.into());
    root.insert("run".into(), c.run.clone().into());
    toml::to_string(&root).expect("a TOML table serializes")
}

/// Reads and checks a checkpoint file: magic, version, length and checksum,
/// then the header. A truncated or corrupted file is refused.
pub fn read(path: &Path) -> Result<Checkpoint, CheckpointError> {
    let bytes = std::fs::read(path).map_err(|source| CheckpointError::Read {
        path: path.to_owned(),
        source,
    })?;
    from_bytes(&bytes).map_err(|source| CheckpointError::Format {
        path: path.to_owned(),
        source,
    })
}

/// Decodes what `to_bytes` made.
pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint, FormatError> {
    const FIXED: usize = 8 + 4 + 4 + 8 + 8 + 4;
    let truncated = FormatError::Truncated { len: bytes.len() };
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        if bytes.len() < 8 && MAGIC.starts_with(bytes) {
            return Err(truncated);
        }
        return Err(FormatError::WrongMagic);
    }
    if bytes.len() < 16 {
        return Err(truncated);
    }
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    let version = u32_at(8);
    if version < VERSION {
        return Err(FormatError::Older { version });
    }
    if version > VERSION {
        return Err(FormatError::Newer { version });
    }
    let header_len = u32_at(12) as usize;
    let count_at = 16 + header_len;
    let truncated = |expected: u128| FormatError::LengthMismatch {
        len: bytes.len(),
        expected,
    };
    if bytes.len() < FIXED + header_len {
        return Err(truncated((FIXED + header_len) as u128));
    }
    let count = u64::from_le_bytes(bytes[count_at..count_at + 8].try_into().unwrap());
    let words_at = count_at as u128 + 8 + 4 * count as u128;
    if (bytes.len() as u128) < words_at + 8 + 4 {
        return Err(truncated(words_at + 8 + 4));
    }
    let words_at = words_at as usize;
    let words = u64::from_le_bytes(bytes[words_at..words_at + 8].try_into().unwrap());
    let expected = FIXED as u128 + header_len as u128 + 4 * count as u128 + 4 * words as u128;
    if bytes.len() as u128 != expected {
        return Err(truncated(expected));
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if crc32fast::hash(body) != u32::from_le_bytes(crc.try_into().unwrap()) {
        return Err(FormatError::Checksum);
    }
    let header =
        std::str::from_utf8(&bytes[16..count_at]).map_err(|_| FormatError::HeaderNotUtf8)?;
    let data = &bytes[count_at + 8..words_at];
    let words: Vec<u32> = bytes[words_at + 8..bytes.len() - 4]
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
        .collect();
    let texels: Vec<[f32; 4]> = data
        .chunks_exact(16)
        .map(|t| {
            std::array::from_fn(|c| f32::from_le_bytes(t[4 * c..4 * c + 4].try_into().unwrap()))
        })
        .collect();
    Ok(parse_header(header, texels, words)?)
}

fn parse_header(
    text: &str,
    texels: Vec<[f32; 4]>,
    words: Vec<u32>,
) -> Result<Checkpoint, HeaderError> {
    let root: toml::Table = text.parse()?;
    let missing = |key: String| HeaderError::Missing { key };
    let table = |key: &str| -> Result<&toml::Table, HeaderError> {
        root.get(key)
            .and_then(|v| v.as_table())
            .ok_or_else(|| HeaderError::MissingTable { key: key.into() })
    };
    let string = |key: &str| -> Result<String, HeaderError> {
        root.get(key)
            .and_then(|v| v.as_str())
            .map(str::to_string)
            .ok_or_else(|| missing(key.into()))
    };
    fn named_in<T>(
        overrides: &toml::Table,
        key: &str,
        from_name: fn(&str) -> Option<T>,
    ) -> Result<Option<T>, HeaderError> {
        overrides
            .get(key)
            .map(|v| {
                v.as_str()
                    .and_then(from_name)
                    .ok_or_else(|| HeaderError::NotNamed { key: key.into() })
            })
            .transpose()
    }
    fn u32_in(table: &toml::Table, name: &str, key: &str) -> Result<Option<u32>, HeaderError> {
        table
            .get(key)
            .map(|v| {
                v.as_integer()
                    .and_then(|i| u32::try_from(i).ok())
                    .ok_or_else(|| HeaderError::NotU32 {
                        table: name.into(),
                        key: key.into(),
                    })
            })
            .transpose()
    }
    let scene = table("scene")?;
    let identity = SceneIdentity::from_pairs(|key| {
        scene.get(key).and_then(|v| v.as_str()).map(str::to_string)
    })?;
    let o = table("overrides")?;
    let overrides = SceneOverrides {
        spp: None,
        aovs: o
            .get("aovs")
            .map(|v| {
                v.as_str()
                    .and_then(|s| parse_aovs(s).ok())
                    .ok_or(HeaderError::Aovs)
            })
            .transpose()?,
        width: u32_in(o, "overrides", "width")?,
        height: u32_in(o, "overrides", "height")?,
        max_depth: u32_in(o, "overrides", "max_depth")?,
        seed: u32_in(o, "overrides", "seed")?,
        strategy: named_in(o, "strategy", Strategy::from_name)?,
        light_weight: match o.get("light_weight") {
            None => None,
            Some(v) => Some(v.as_float().ok_or(HeaderError::LightWeight)? as f32),
        },
        rr_depth: match o.get("rr_depth").map(|v| v.as_str()) {
            None => None,
            Some(Some("off")) => Some(None),
            Some(depth) => Some(Some(
                depth
                    .and_then(|d| d.parse().ok())
                    .ok_or(HeaderError::RrDepth)?,
            )),
        },
        sampler: named_in(o, "sampler", Sampler::from_name)?,
        light_selection: named_in(o, "light_selection", LightSelection::from_name)?,
        adaptive_metric: named_in(o, "adaptive_metric", AdaptiveMetric::from_name)?,
        reconstruction: named_in(o, "reconstruction", Reconstruction::from_name)?,
    };
    let s = table("state")?;
    let need = |key: &str| u32_in(s, "state", key)?.ok_or_else(|| missing(format!("state.{key}")));
    let state = AccumulatorState {
        width: need("width")?,
        height: need("height")?,
        layers: need("layers")?,
        first_sample: need("first_sample")?,
        samples: need("samples")?,
        texels,
        adaptive: None,
    };
    let mut state = state;
    let entries = u32_in(s, "state", "adaptive_round_entries")?;
    let pixels = state.width as usize * state.height as usize;
    let words_expected = entries.map_or(0, |e| pixels + 2 * e as usize);
    if words.len() != words_expected {
        return Err(HeaderError::AdaptiveCount {
            count: words.len(),
            width: state.width,
            height: state.height,
            entries: entries.unwrap_or(0),
        });
    }
    if entries.is_some() {
        let need =
            |key: &str| u32_in(s, "state", key)?.ok_or_else(|| missing(format!("state.{key}")));
        state.adaptive = Some(AdaptiveState {
            counts: words[..pixels].to_vec(),
            round: words[pixels..]
                .chunks_exact(2)
                .map(|w| [w[0], w[1]])
                .collect(),
            round_samples: need("adaptive_round_samples")?,
            round_done: need("adaptive_round_done")?,
            choice: match s.get("adaptive_uniform") {
                None => None,
                Some(uniform) => Some(Choice {
                    predicted_ratio: (s.get("adaptive_predicted_ratio"))
                        .and_then(|v| v.as_float())
                        .ok_or_else(|| missing("state.adaptive_predicted_ratio".into()))?,
                    uniform: (uniform.as_bool())
                        .ok_or_else(|| missing("state.adaptive_uniform".into()))?,
                }),
            },
        });
    }
    let texel_count = state.width as u64 * state.height as u64 * state.layers as u64;
    if state.texels.len() as u64 != texel_count {
        return Err(HeaderError::TexelCount {
            count: state.texels.len(),
            width: state.width,
            height: state.height,
            layers: state.layers,
        });
    }
    if (state.width, state.height) != (identity.width, identity.height) {
        return Err(HeaderError::SizeDiffers);
    }
    let discarded = s
        .get("discarded")
        .and_then(|v| v.as_integer())
        .and_then(|v| u64::try_from(v).ok())
        .ok_or_else(|| missing("state.discarded".into()))?;
    Ok(Checkpoint {
        pathmix_version: string("pathmix_version")?,
        scene_path: PathBuf::from(string("scene_path")?),
        overrides,
        identity,
        discarded,
        run: root
            .get("run")
            .and_then(|v| v.as_table())
            .cloned()
            .unwrap_or_default(),
        state,
    })
}

/// A Russian roulette depth as text: the depth, or `off`.
fn rr_text(depth: Option<u32>) -> String {
    depth.map_or_else(|| "off".to_string(), |d| d.to_string())
}

/// Refuses to let a checkpoint replace a file that is not one (a scene file, an
/// image, anything a mistyped `--checkpoint` names): only a missing file or a
/// pathmix checkpoint (by its magic bytes) may be replaced.
pub fn check_replaceable(path: &Path) -> Result<(), String> {
    let mut start = Vec::with_capacity(MAGIC.len());
    match std::fs::File::open(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("cannot read `{}`: {e}", path.display())),
        Ok(file) => {
            use std::io::Read;
            file.take(MAGIC.len() as u64)
                .read_to_end(&mut start)
                .map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
        }
    }
    if start != MAGIC {
        return Err(format!(
            "`{}` exists and is not a pathmix checkpoint: pathmix will not replace it \
             (delete it or choose another path)",
            path.display()
        ));
    }
    Ok(())
}

/// An advisory lock on a checkpoint, held while a run saves to it, so that two
/// runs (two resumes of one checkpoint) cannot both write it. The lock is on
/// `.NAME.lock` beside it (the checkpoint itself is replaced by renames), which
/// holds the owner's process id for the message the second run gets.
#[derive(Debug)]
pub struct CheckpointLock {
    /// Held open: the lock lasts as long as its descriptor.
    _file: std::fs::File,
    path: PathBuf,
}

/// Why a checkpoint could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "checkpoint `{}` is in use by another run ({owner}); wait for it to end or stop it",
        .checkpoint.display()
    )]
    InUse { checkpoint: PathBuf, owner: String },
    #[error("cannot lock checkpoint `{}` ({}): {source}", .checkpoint.display(), .lock.display())]
    Io {
        checkpoint: PathBuf,
        lock: PathBuf,
        source: io::Error,
    },
}

impl CheckpointLock {
    pub fn acquire(checkpoint: &Path) -> Result<CheckpointLock, LockError> {
        let mut name = std::ffi::OsString::from(".");
        name.push(checkpoint.file_name().unwrap_or_default());
        name.push(".lock");
        let lock = checkpoint.with_file_name(name);
        let io_error = |source| LockError::Io {
            checkpoint: checkpoint.to_owned(),
            lock: lock.clone(),
            source,
        };
        loop {
            let mut file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&lock)
                .map_err(io_error)?;
            match try_lock(&file) {
                Ok(true) => {}
                Ok(false) => {
                    let mut owner = String::new();
                    use std::io::Read;
                    let _ = file.read_to_string(&mut owner);
                    let owner = match owner.trim() {
                        "" => "a process that has not said its id yet".to_string(),
                        pid => format!("process {pid}"),
                    };
                    return Err(LockError::InUse {
                        checkpoint: checkpoint.to_owned(),
                        owner,
                    });
                }
                Err(e) => return Err(io_error(e)),
            }
            // The owner before may have removed the file between our open and lock:
            // then the lock is on a file no one else will find; take the new one.
            if !same_file(&file, &lock) {
                continue;
            }
            file.set_len(0).map_err(io_error)?;
            file.write_all(std::process::id().to_string().as_bytes())
                .map_err(io_error)?;
            output::register_temporary(&lock);
            return Ok(CheckpointLock {
                _file: file,
                path: lock,
            });
        }
    }
}

/// An exclusive advisory lock (`flock`), without waiting: false when another
/// process holds it. The lock goes with the file's descriptor, so a process that
/// dies (even by SIGKILL) releases it. On other platforms than Unix, runs are not
/// locked.
#[cfg(unix)]
fn try_lock(file: &std::fs::File) -> io::Result<bool> {
    use std::os::fd::AsRawFd;
    // SAFETY: flock(2) on a descriptor this `File` owns.
    if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } == 0 {
        return Ok(true);
    }
    let error = io::Error::last_os_error();
    match error.raw_os_error() {
        Some(libc::EWOULDBLOCK) => Ok(false),
        _ => Err(error),
    }
}

#[cfg(not(unix))]
fn try_lock(_file: &std::fs::File) -> io::Result<bool> {
    Ok(true)
}

#[cfg(unix)]
fn same_file(file: &std::fs::File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_file: &std::fs::File, path: &Path) -> bool {
    path.exists()
}

impl Drop for CheckpointLock {
    fn drop(&mut self) {
        // Removed while still locked, so a waiting run finds it gone and retries.
        let _ = std::fs::remove_file(&self.path);
        output::unregister_temporary(&self.path);
        // Closing the file (dropping it) releases the lock.
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Bitmap, Texture, TextureFilter, TextureKind, UvTransform, WrapMode};
    use crate::scene::{
        Camera, Cylinder, Disk, Distribution, EnvironmentMap, Filter, Material, MaterialKind,
        PointLight, Quad, Roulette, Shapes, Sphere, Spot, Triangle,
    };
    use glam::{Mat3, Vec2, Vec3};
    use std::sync::Arc;

    #[test]
    fn fnv64_matches_published_vectors() {
        let hash = |bytes: &[u8]| Fnv64::default().bytes(bytes).finish();
        assert_eq!(hash(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(hash(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(hash(b"foobar"), 0x8594_4171_f739_67e8);
    }

    fn scene(text_change: impl Fn(String) -> String) -> Scene {
        let text = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml"),
        )
        .unwrap();
        Scene::parse(&text_change(text), "cornell.toml").unwrap()
    }

    fn sample() -> Checkpoint {
        let mut run = toml::Table::new();
        run.insert("output".into(), "/tmp/out.png".into());
        run.insert("spp".into(), toml::Value::Integer(100));
        let (width, height, layers) = (3, 2, 4);
        Checkpoint {
            pathmix_version: "0.1.0".into(),
            scene_path: "/scenes/cornell.toml".into(),
            overrides: SceneOverrides {
                width: Some(3),
                height: Some(2),
                strategy: Some(Strategy::Bsdf),
                light_weight: Some(0.3),
                sampler: Some(Sampler::Independent),
                ..Default::default()
            },
            identity: SceneIdentity {
                width,
                height,
                ..SceneIdentity::of(&scene(|t| t))
            },
            discarded: 2,
            run,
            state: AccumulatorState {
                width,
                height,
                layers,
                first_sample: 250,
                samples: 17,
                texels: (0..width * height * layers)
                    .map(|i| [i as f32 * 0.1, -1e-9 * i as f32, f32::MIN_POSITIVE, 0.0])
                    .collect(),
                adaptive: None,
            },
        }
    }

    #[test]
    fn round_trip_is_exact() {
        let c = sample();
        let bytes = to_bytes(&c);
        assert_eq!(from_bytes(&bytes).unwrap(), c);
    }

    #[test]
    fn adaptive_state_round_trips() {
        let mut c = sample();
        c.state.adaptive = Some(AdaptiveState {
            counts: vec![16, 24, 16, 28, 16, 16],
            round: vec![[1, 16], [3, 20]],
            round_samples: 8,
            round_done: 8,
            choice: None,
        });
        let bytes = to_bytes(&c);
        assert_eq!(from_bytes(&bytes).unwrap(), c);
        // The pilot's choice, either way (an infinite ratio too: no spread seen).
        for (predicted_ratio, uniform) in [(0.3125, false), (f64::INFINITY, true)] {
            let adaptive = c.state.adaptive.as_mut().unwrap();
            adaptive.choice = Some(Choice {
                predicted_ratio,
                uniform,
            });
            let bytes = to_bytes(&c);
            assert_eq!(from_bytes(&bytes).unwrap(), c);
        }
    }

    #[test]
    fn truncated_and_flipped_files_are_refused() {
        let bytes = to_bytes(&sample());
        for len in [0, 5, 8, 15, 16, 40, bytes.len() / 2, bytes.len() - 1] {
            let e = from_bytes(&bytes[..len]).unwrap_err().to_string();
            assert!(e.contains("truncated"), "{len}: {e}");
        }
        // Every single bit flip anywhere is caught.
        for at in 0..bytes.len() {
            for bit in [0, 5] {
                let mut b = bytes.clone();
                b[at] ^= 1 << bit;
                let e = from_bytes(&b).unwrap_err().to_string();
                assert!(
                    e.contains("corrupted")
                        || e.contains("truncated")
                        || e.contains("magic")
                        || e.contains("version"),
                    "{at}: {e}"
                );
            }
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(
            from_bytes(&longer)
                .unwrap_err()
                .to_string()
                .contains("corrupted")
        );
    }

    #[test]
    fn differences_name_the_part() {
        let base = SceneIdentity::of(&scene(|t| t));
        let same = SceneIdentity::of(&scene(|t| t));
        fn differences(a: &SceneIdentity, b: &SceneIdentity) -> Vec<String> {
            SceneIdentity::differences((a, "before"), (b, "now"))
        }
        assert!(differences(&base, &same).is_empty());
        let cases: [(&str, &str, &str, &str); 5] = [
            ("vfov = 40", "vfov = 41", "camera", "field of view"),
            ("[0.73, 0.73, 0.73]", "[0.7, 0.73, 0.73]", "materials", ""),
            ("radius = 90", "radius = 91", "geometry", ""),
            (
                "max_depth = 50",
                "max_depth = 20",
                "render settings",
                "max_depth 50 before, 20 now",
            ),
            (
                "max_depth = 50",
                "max_depth = 50\nsampler = \"independent\"",
                "render settings",
                "sampler sobol before, independent now",
            ),
        ];
        for (from, to, part, detail) in cases {
            let text = std::fs::read_to_string(
                Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml"),
            )
            .unwrap();
            assert!(text.contains(from), "{from}");
            let changed = SceneIdentity::of(&scene(|t| t.replacen(from, to, 1)));
            let d = differences(&base, &changed);
            assert_eq!(d.len(), 1, "{d:?}");
            assert!(d[0].contains(part) && d[0].contains(detail), "{d:?}");
            assert_ne!(base.hash(), changed.hash());
        }
        // The sample count is not part of the identity.
        let more = SceneIdentity::of(&scene(|t| t.replacen("spp = 1000", "spp = 5", 1)));
        assert_eq!(base, more);
    }

    /// Version 5 hashed the scene's `Debug` text: its identity cannot be checked.
    #[test]
    fn older_checkpoints_are_refused_as_older_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.ckpt");
        let with_version = |version: u32| {
            let mut bytes = to_bytes(&sample());
            bytes[8..12].copy_from_slice(&version.to_le_bytes());
            std::fs::write(&path, bytes).unwrap();
            read(&path).unwrap_err().to_string()
        };
        let e = with_version(5);
        assert!(
            e.contains(&format!("checkpoint `{}`", path.display()))
                && e.contains("written by an older pathmix")
                && e.contains("version 5")
                && e.contains("scene identity this pathmix cannot check")
                && e.contains("start the run again"),
            "{e}"
        );
        let e = with_version(VERSION + 1);
        assert!(e.contains("written by a newer pathmix"), "{e}");
    }

    /// A small scene with a part of every kind the identity covers: each shape
    /// kind, a textured material, a point and a spot light, an environment map.
    fn small_scene() -> Scene {
        let material = |name: &str, kind| Material {
            name: name.into(),
            kind,
            albedo: Vec3::ZERO,
            emit: Vec3::ZERO,
            one_sided: false,
            opacity: 1.0,
            opacity_texture: None,
            number_textures: Vec::new(),
            texture: None,
            bump: None,
            nested: Vec::new(),
        };
        Scene {
            source: "small.toml".into(),
            camera: Camera {
                lookfrom: Vec3::new(0.0, 1.0, -5.0),
                lookat: Vec3::new(0.0, 0.5, 0.0),
                vup: Vec3::Y,
                vfov_degrees: 40.0,
                width: 8,
                height: 6,
                filter: Filter::Gaussian { stddev: 0.5 },
                aperture_radius: 0.0,
                focus_distance: None,
                view_width: None,
            },
            render: RenderSettings {
                spp: 16,
                max_depth: 7,
                strategy: Strategy::NeeMis,
                auto_strategy: false,
                light_weight: 0.5,
                background: Vec3::new(0.1, 0.2, 0.3),
                seed: 3,
                rr_depth: Roulette::StrategyDefault,
                sampler: Sampler::Sobol,
                light_selection: LightSelection::Spatial,
                adaptive: false,
                adaptive_metric: None,
                // Its hash from before splatting was a choice (`SceneIdentity::of`).
                reconstruction: Some(Reconstruction::Importance),
                aovs: Vec::new(),
                sides_by_shading_normal: false,
            },
            materials: vec![
                Material {
                    albedo: Vec3::splat(0.5),
                    texture: Some(Texture {
                        kind: TextureKind::Bitmap(Bitmap {
                            file: "wood.png".into(),
                            width: 2,
                            height: 1,
                            texels: Arc::new(vec![[0.25, 0.5, 0.75], [1.0, 0.0, 0.125]]),
                            codes: None,
                            raw: false,
                            wrap: WrapMode::Repeat,
                            filter: TextureFilter::Bilinear,
                        }),
                        to_uv: UvTransform::IDENTITY,
                    }),
                    ..material("wood", MaterialKind::Lambertian)
                },
                material(
                    "steel",
                    MaterialKind::RoughConductor {
                        distribution: Distribution::Ggx,
                        alpha_u: 0.2,
                        alpha_v: 0.2,
                        eta: Vec3::new(2.9, 2.9, 2.6),
                        k: Vec3::new(3.1, 2.9, 2.8),
                        specular_reflectance: Vec3::ONE,
                    },
                ),
                Material {
                    emit: Vec3::splat(4.0),
                    ..material("lamp", MaterialKind::Light)
                },
            ],
            instancing: Default::default(),
            shapes: Shapes {
                quads: vec![Quad {
                    q: Vec3::new(-1.0, 2.0, -1.0),
                    u: Vec3::X * 2.0,
                    v: Vec3::Z * 2.0,
                    material: 2,
                    importance: true,
                }],
                spheres: vec![Sphere {
                    center: Vec3::new(0.5, 0.5, 0.0),
                    radius: 0.5,
                    material: 1,
                    importance: false,
                }],
                triangles: vec![Triangle {
                    vertices: [Vec3::ZERO, Vec3::X, Vec3::Y],
                    normals: Some([Vec3::NEG_Z; 3]),
                    uvs: Some([Vec2::ZERO, Vec2::X, Vec2::Y]),
                    material: 0,
                    importance: false,
                    mesh: 0,
                }],
                disks: vec![Disk {
                    center: Vec3::new(0.0, 0.0, 1.0),
                    u: Vec3::X * 0.75,
                    v: Vec3::Y * 0.75,
                    material: 0,
                    importance: false,
                }],
                cylinders: vec![Cylinder {
                    p0: Vec3::new(0.0, -1.0, 0.0),
                    p1: Vec3::new(0.0, 1.0, 0.0),
                    radius: 0.25,
                    flip_normals: true,
                    material: 2,
                    importance: true,
                }],
            },
            degenerate_triangles: 0,
            point_lights: vec![
                PointLight {
                    position: Vec3::new(0.0, 3.0, 0.0),
                    intensity: Vec3::splat(10.0),
                    spot: None,
                    directional: None,
                },
                PointLight {
                    position: Vec3::new(2.0, 3.0, 0.0),
                    intensity: Vec3::splat(5.0),
                    spot: Some(Spot {
                        direction: Vec3::NEG_Y,
                        cutoff_angle: 30.0,
                        beam_width: 20.0,
                    }),
                    directional: None,
                },
            ],
            environment: Some(EnvironmentMap {
                file: "sky.exr".into(),
                width: 2,
                height: 2,
                texels: Arc::new(vec![
                    [1.0, 1.0, 1.0],
                    [0.5, 0.5, 0.5],
                    [0.0, 0.0, 0.0],
                    [2.0; 3],
                ]),
                scale: 1.0,
                to_world: Mat3::IDENTITY,
            }),
            warnings: Vec::new(),
            inputs: Vec::new(),
        }
    }

    /// The identity of `small_scene`, fixed: an accidental change of the encoding
    /// (a field or variant added, removed or reordered in a scene type, another
    /// postcard) fails here. Changing these values means bumping [`VERSION`] (and
    /// the partial results' `shard::FORMAT`), so that older files are refused as
    /// older rather than as another scene.
    #[test]
    fn identity_of_a_fixed_scene_is_golden() {
        let identity = SceneIdentity::of(&small_scene());
        let hashes = [
            identity.camera_hash,
            identity.materials_hash,
            identity.geometry_hash,
            identity.settings_hash,
            identity.hash(),
        ];
        assert_eq!(hashes.map(hex), GOLDEN);
        // The camera's encoding by hand: floats as their bits (little-endian),
        // integers as varints, the filter's variant index before its field.
        let mut camera = Fnv64::default();
        for v in [0.0, 1.0, -5.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 40.0f32] {
            camera.u32(v.to_bits());
        }
        camera.bytes(&[8, 6, 1]).u32(0.5f32.to_bits());
        assert_eq!(identity.camera_hash, camera.finish());
        assert_eq!((identity.shapes, identity.point_lights), (vec![1; 5], 2));
    }

    /// Camera, materials, geometry, settings, and the scene hash.
    const GOLDEN: [&str; 5] = [
        "6acd00696624b086",
        "748ee7bfced01064",
        "c7629e67c6522810",
        "e50b9993ee433292",
        "fb2ab36e0b1652e6",
    ];

    /// A change of one field of any part changes that part's hash (and the scene
    /// hash), and only that one.
    #[test]
    fn each_part_changes_with_a_field_in_it() {
        type Change = fn(&mut Scene);
        let changes: [(&str, &str, Change); 12] = [
            ("camera", "filter", |s| {
                s.camera.filter = Filter::Gaussian { stddev: 0.6 }
            }),
            ("geometry", "quad corner", |s| s.shapes.quads[0].q.x = -0.5),
            ("geometry", "sphere radius", |s| {
                s.shapes.spheres[0].radius = 0.25
            }),
            ("geometry", "disk radius", |s| {
                let disk = &mut s.shapes.disks[0];
                (disk.u, disk.v) = (disk.u * 1.5, disk.v * 1.5);
            }),
            ("geometry", "triangle vertex", |s| {
                s.shapes.triangles[0].vertices[2].z = 0.25
            }),
            ("geometry", "point light intensity", |s| {
                s.point_lights[0].intensity.y = 11.0
            }),
            ("geometry", "spot cutoff", |s| {
                s.point_lights[1].spot.as_mut().unwrap().cutoff_angle = 35.0
            }),
            ("materials", "roughness", |s| {
                let MaterialKind::RoughConductor { alpha_u, .. } = &mut s.materials[1].kind else {
                    unreachable!()
                };
                *alpha_u = 0.3;
            }),
            ("materials", "texture texel", |s| {
                let Some(TextureKind::Bitmap(bitmap)) =
                    s.materials[0].texture.as_mut().map(|t| &mut t.kind)
                else {
                    unreachable!()
                };
                Arc::make_mut(&mut bitmap.texels)[1][2] = 0.25;
            }),
            ("settings", "environment texel", |s| {
                let map = s.environment.as_mut().unwrap();
                Arc::make_mut(&mut map.texels)[3][0] = 2.5;
            }),
            ("settings", "light weight", |s| s.render.light_weight = 0.25),
            ("settings", "reconstruction", |s| {
                s.render.reconstruction = None
            }),
        ];
        let base = SceneIdentity::of(&small_scene());
        let parts = |i: &SceneIdentity| {
            [
                ("camera", i.camera_hash),
                ("materials", i.materials_hash),
                ("geometry", i.geometry_hash),
                ("settings", i.settings_hash),
            ]
        };
        for (part, what, change) in changes {
            let mut scene = small_scene();
            change(&mut scene);
            let changed = SceneIdentity::of(&scene);
            for ((name, a), (_, b)) in parts(&base).into_iter().zip(parts(&changed)) {
                assert_eq!(name == part, a != b, "{what}: the {name} hash");
            }
            assert_ne!(base.hash(), changed.hash(), "{what}");
            let d = SceneIdentity::differences((&base, "before"), (&changed, "now"));
            assert!(d.len() == 1 && d[0].contains(part), "{what}: {d:?}");
        }
    }

    #[test]
    fn geometry_differences_count_every_kind_and_the_point_lights() {
        let base = SceneIdentity::of(&small_scene());
        let mut scene = small_scene();
        scene.shapes.disks.push(scene.shapes.disks[0]);
        scene.point_lights.pop();
        let d = SceneIdentity::differences((&base, "before"), (&SceneIdentity::of(&scene), "now"));
        assert_eq!(
            d,
            ["the geometry differs: disks 1 before, 2 now, point lights 2 before, 1 now"]
        );
    }

    /// Sets every optional key, and the ones no shipped scene has (scale, seed,
    /// Russian roulette, sampler, a metal, transforms of a sphere), so that the
    /// walk below reaches them too.
    const EVERY_KEY: &str = r#"
        [scene]
        scale = 2
        [camera]
        lookfrom = [1, 2, -9]
        lookat = [0.5, 1, 0]
        vup = [0.1, 1, 0]
        vfov = 50
        width = 20
        height = 10
        [render]
        spp = 16
        max_depth = 7
        strategy = "nee-mis"
        light_weight = 0.25
        background = [0.1, 0.2, 0.3]
        seed = 7
        rr_depth = 5
        sampler = "independent"
        [materials.steel]
        type = "metal"
        albedo = [0.8, 0.7, 0.6]
        fuzz = 0.3
        one_sided = true
        [materials.glow]
        type = "lambertian"
        albedo = [0.2, 0.3, 0.4]
        emit = [0.5, 0.25, 2]
        opacity = 0.5
        [materials.glass]
        type = "dielectric"
        ior = 1.33
        [materials.lamp]
        type = "light"
        emit = [4, 5, 6]
        [[objects]]
        type = "sphere"
        center = [1, 2, 3]
        radius = 0.75
        rotate_y = 30
        translate = [-1, 0.5, 2]
        importance = true
        material = "steel"
        [[objects]]
        type = "quad"
        q = [-3, -1, 4]
        u = [6, 0, 0.5]
        v = [0, 0.25, 3]
        importance = false
        material = "glass"
        [[objects]]
        type = "box"
        min = [-1, -1, -1]
        max = [1, 2, 1.5]
        rotate_y = -20
        translate = [0.5, 0, 1]
        material = "glow"
        [[objects]]
        type = "quad"
        q = [-1, 3, -1]
        u = [2, 0, 0]
        v = [0, 0, 2]
        material = "lamp"
    "#;

    /// A key or an index into a TOML document.
    #[derive(Clone)]
    enum Step {
        Key(String),
        Index(usize),
    }

    /// The paths to every number, string and boolean in `value`.
    fn leaves(value: &toml::Value, path: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
        match value {
            toml::Value::Table(table) => {
                for (key, v) in table {
                    path.push(Step::Key(key.clone()));
                    leaves(v, path, out);
                    path.pop();
                }
            }
            toml::Value::Array(array) => {
                for (i, v) in array.iter().enumerate() {
                    path.push(Step::Index(i));
                    leaves(v, path, out);
                    path.pop();
                }
            }
            _ => out.push(path.clone()),
        }
    }

    fn leaf<'a>(value: &'a mut toml::Value, path: &[Step]) -> &'a mut toml::Value {
        path.iter().fold(value, |v, step| match step {
            Step::Key(key) => &mut v[key.as_str()],
            Step::Index(i) => &mut v[*i],
        })
    }

    fn path_text(path: &[Step]) -> String {
        let mut text = String::new();
        for step in path {
            match step {
                Step::Key(key) if text.is_empty() => text += key,
                Step::Key(key) => text += &format!(".{key}"),
                Step::Index(i) => text += &format!("[{i}]"),
            }
        }
        text
    }

    /// Other values for a leaf, to try in turn until the scene still validates.
    fn replacements(value: &toml::Value, names: &[String]) -> Vec<toml::Value> {
        use toml::Value;
        let all = match value {
            Value::Integer(i) => [i * 3 / 2 + 1, i / 2, i + 1, i - 1]
                .map(Value::Integer)
                .into(),
            Value::Float(x) => [x * 1.5 + 0.25, x * 0.5, x + 1.0, x - 1.0]
                .map(Value::Float)
                .into(),
            Value::Boolean(b) => vec![Value::Boolean(!b)],
            Value::String(_) => names.iter().cloned().map(Value::String).collect(),
            other => panic!("no scene file holds a {other:?}"),
        };
        all.into_iter().filter(|v| v != value).collect()
    }

    /// Every single value of every shipped scene (and of `EVERY_KEY`) changed in
    /// turn changes the identity, but the sample count; the file name does not.
    /// (Another name in the same folder, where its mesh files are found too.)
    #[test]
    fn identity_changes_with_every_value_of_a_scene_file_but_spp() {
        let renamed = |name: &str| {
            Path::new(name)
                .with_file_name("other.toml")
                .display()
                .to_string()
        };
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut files: Vec<(String, String)> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.extension().is_some_and(|e| e == "toml"))
            // The whole path: a mesh file is found relative to its scene.
            .map(|path| {
                let name = path.display().to_string();
                (name, std::fs::read_to_string(&path).unwrap())
            })
            .collect();
        files.sort();
        assert!(files.len() >= 3, "{files:?}");
        files.push(("every-key.toml".into(), EVERY_KEY.into()));
        let documents: Vec<(String, toml::Value)> = files
            .iter()
            .map(|(name, text)| (name.clone(), toml::Value::Table(text.parse().unwrap())))
            .collect();
        // Replacement names: every string and material name in any of the files,
        // and every strategy and sampler.
        let mut names = std::collections::BTreeSet::new();
        for (_, document) in &documents {
            let mut paths = Vec::new();
            leaves(document, &mut Vec::new(), &mut paths);
            let mut document = document.clone();
            for path in &paths {
                if let Some(s) = leaf(&mut document, path).as_str() {
                    names.insert(s.to_string());
                }
            }
            if let Some(materials) = document.get("materials").and_then(|m| m.as_table()) {
                names.extend(materials.keys().cloned());
            }
        }
        names.extend(Strategy::ALL.map(|s| s.name().to_string()));
        names.extend(Sampler::ALL.map(|s| s.name().to_string()));
        let names: Vec<String> = names.into_iter().collect();

        let (mut checked, mut changed, mut spp_leaves) = (0, 0, 0);
        let mut unchanged = Vec::new();
        for (name, document) in &documents {
            let base_scene = Scene::parse(&toml::to_string(document).unwrap(), name).unwrap();
            let base = SceneIdentity::of(&base_scene);
            let original = &files.iter().find(|(n, _)| n == name).unwrap().1;
            assert_eq!(
                SceneIdentity::of(&Scene::parse(original, name).unwrap()),
                base,
                "{name}: written back, the file is the same scene"
            );
            assert_eq!(
                SceneIdentity::of(&Scene::parse(original, &renamed(name)).unwrap()),
                base,
                "{name}: the file name is not part of the identity"
            );
            let mut paths = Vec::new();
            leaves(document, &mut Vec::new(), &mut paths);
            for path in &paths {
                checked += 1;
                let at = path_text(path);
                let mut mutated = document.clone();
                let value = leaf(&mut mutated, path).clone();
                let scene = replacements(&value, &names).into_iter().find_map(|v| {
                    *leaf(&mut mutated, path) = v;
                    Scene::parse(&toml::to_string(&mutated).unwrap(), name).ok()
                });
                let Some(scene) = scene else {
                    assert!(value.is_str(), "{name}: {at}: no other value validates");
                    unchanged.push(format!("{name}: {at}"));
                    continue;
                };
                changed += 1;
                let identity = SceneIdentity::of(&scene);
                if scene == base_scene {
                    // The same scene written another way (a rotation axis twice as
                    // long): the same identity.
                    assert_eq!(identity, base, "{name}: {at}");
                } else if at == "render.spp" {
                    spp_leaves += 1;
                    assert_eq!(identity, base, "{name}: {at}");
                } else {
                    assert_ne!(identity.hash(), base.hash(), "{name}: {at}");
                    assert!(
                        !SceneIdentity::differences((&base, "before"), (&identity, "now"))
                            .is_empty(),
                        "{name}: {at}"
                    );
                }
            }
        }
        assert_eq!(spp_leaves, documents.len());
        // Only names can be left: most `type`s (another type needs other keys), and
        // the material of an object in a scene of one material.
        assert!(
            changed * 10 >= checked * 9,
            "{changed} of {checked} values changed; not: {unchanged:#?}"
        );
    }
}
