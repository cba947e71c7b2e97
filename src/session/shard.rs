//! Shards: runs that each render a disjoint range of sample indices of one
//! image, their partial results, and merging those into the image.
//!
//! A partial result is an OpenEXR file with one f32 channel per running sum and
//! per compensation (`sum.R`, `sum_compensation.R`, ..., with variance
//! `squares.R`, `squares_compensation.R`, ..., and with variance under the Sobol
//! sampler `replicate1.R`, `replicate1_compensation.R`, ... for the replicates
//! 1 to `REPLICATES - 1`), so a merge rebuilds every sum in
//! f64, and text attributes `pathmix.*`: the scene hash and its parts, seed,
//! sample range, size, pathmix version and a CRC-32 of the other attributes and
//! the pixel data.

use crate::abi::{
    LAYER_REPLICATES, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, LAYER_SUM, LAYER_SUM_COMPENSATION,
    REPLICATES, replicate_layer,
};
use crate::gpu::accumulator::compensated_sums;
use crate::kernel::accumulator_layers;
use crate::output::{self, OutputError};
use crate::render::AccumulatorState;
use crate::scene::Sampler;
use crate::session::checkpoint::{IdentityError, SceneIdentity};
use crate::stats::{Accumulation, Replicates};
use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SmallVec, WritableImage,
};
use std::collections::BTreeMap;
use std::fmt::{self, Write as _};
use std::io;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Channel groups of the first layers (`abi::LAYER_*`); the
/// replicates' follow (`layer_name`).
const LAYER_NAMES: [&str; 4] = ["sum", "sum_compensation", "squares", "squares_compensation"];
const CHANNELS: [&str; 3] = ["R", "G", "B"];
/// `pathmix.requested` of a run whose end a time budget or error target decided.
const OPEN_ENDED: &str = "open";
const PREFIX: &str = "pathmix.";
/// `pathmix.format`. 2: the scene hashes come from the whole scene's `Debug` text.
/// 3: the range asked for and whether the run was interrupted (`pathmix.requested`,
/// `pathmix.interrupted`), so that a merge can tell a part cut short.
/// 4: Sobol samples come from interleaved replicates (other images), whose sums
/// variance adds (`replicate1.R`, ...).
/// 5: the scene hashes come from a stable encoding of the scene's parts (as
/// checkpoints' version 6), no longer from their `Debug` text.
/// 6: materials encode their `opacity` (as checkpoints' version 7).
/// 7: the geometry encodes cylinders (as checkpoints' version 8).
const FORMAT: u32 = 7;

/// A sample range or shard given as text that does not make one.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParseError {
    #[error("`{text}` is not a range like 0..250")]
    NotARange { text: String },
    #[error("`{text}`: `{part}` is not a sample index")]
    NotASampleIndex { text: String, part: String },
    #[error("`{text}`: the range is empty (end must be > start)")]
    EmptyRange { text: String },
    #[error("`{text}` is not INDEX/COUNT like 2/4")]
    NotAShard { text: String },
    #[error("`{text}`: bad index")]
    BadShardIndex { text: String },
    #[error("`{text}`: bad count")]
    BadShardCount { text: String },
    #[error("`{text}`: the index must be below the count (0..{count})")]
    ShardIndexNotBelowCount { text: String, count: u32 },
}

/// `A..B`: sample indices A (included) to B (excluded).
pub fn parse_range(text: &str) -> Result<Range<u32>, ParseError> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| ParseError::NotARange { text: text.into() })?;
    let number = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| ParseError::NotASampleIndex {
                text: text.into(),
                part: s.into(),
            })
    };
    let range = number(a)?..number(b)?;
    if range.start >= range.end {
        return Err(ParseError::EmptyRange { text: text.into() });
    }
    Ok(range)
}

/// `I/N`: shard I (from 0) of N.
pub fn parse_shard(text: &str) -> Result<(u32, u32), ParseError> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| ParseError::NotAShard { text: text.into() })?;
    let index: u32 = i
        .trim()
        .parse()
        .map_err(|_| ParseError::BadShardIndex { text: text.into() })?;
    let count: u32 = n
        .trim()
        .parse()
        .map_err(|_| ParseError::BadShardCount { text: text.into() })?;
    if count == 0 || index >= count {
        return Err(ParseError::ShardIndexNotBelowCount {
            text: text.into(),
            count,
        });
    }
    Ok((index, count))
}

/// The sample range of shard `index` of `count` over `total` samples: shards
/// cover `0..total` exactly, in order, with sizes differing by at most one.
/// This is the one rule every launcher (Slurm, Kubernetes, a shell loop) uses
/// through `pathmix render --shard INDEX/COUNT`.
pub fn shard_range(index: u32, count: u32, total: u32) -> Range<u32> {
    assert!(index < count, "shard {index} of {count}");
    let bound = |i: u32| (total as u64 * i as u64 / count as u64) as u32;
    bound(index)..bound(index + 1)
}

/// Sorted sample ranges as text, adjacent ones joined: `0..250, 500..750`.
pub fn describe_ranges(ranges: &[Range<u32>]) -> String {
    let mut joined: Vec<Range<u32>> = Vec::new();
    for r in ranges {
        match joined.last_mut() {
            Some(last) if last.end == r.start => last.end = r.end,
            _ => joined.push(r.clone()),
        }
    }
    joined
        .iter()
        .map(|r| format!("{}..{}", r.start, r.end))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The sums of one shard.
#[derive(Clone, Debug, PartialEq)]
pub struct Partial {
    pub identity: SceneIdentity,
    /// The scene file, for messages.
    pub scene_path: String,
    pub pathmix_version: String,
    /// The sample indices in the sums.
    pub range: Range<u32>,
    /// The sample indices the run was asked for; `None` when a time budget or
    /// an error target decided its end.
    pub requested: Option<Range<u32>>,
    /// The run was stopped (a signal) before its stopping rule ended it.
    pub interrupted: bool,
    /// Samples discarded as NaN or infinite (counted as zero).
    pub discarded: u64,
    /// The raw accumulator: `layers * width * height` texels, layer-major (w unused).
    pub layers: u32,
    pub texels: Vec<[f32; 4]>,
}

impl Partial {
    pub fn from_state(
        identity: SceneIdentity,
        scene_path: String,
        discarded: u64,
        state: AccumulatorState,
    ) -> Partial {
        Partial {
            identity,
            scene_path,
            pathmix_version: env!("CARGO_PKG_VERSION").to_string(),
            range: state.first_sample..state.first_sample + state.samples,
            requested: Some(state.first_sample..state.first_sample + state.samples),
            interrupted: false,
            discarded,
            layers: state.layers,
            texels: state.texels,
        }
    }

    /// What the run was asked for (see `requested`) and whether it was interrupted.
    pub fn asked_for(mut self, requested: Option<Range<u32>>, interrupted: bool) -> Partial {
        self.requested = requested;
        self.interrupted = interrupted;
        self
    }

    /// Why this part holds fewer samples than it was asked for, if it does.
    pub fn shortfall(&self) -> Option<String> {
        let reached = format!("{}..{}", self.range.start, self.range.end);
        match &self.requested {
            Some(r) if *r != self.range => Some(format!(
                "holds samples {reached} of the {}..{} it was asked for",
                r.start, r.end
            )),
            _ if self.interrupted => Some(format!(
                "holds samples {reached}: its run was interrupted before its stopping rule ended it"
            )),
            _ => None,
        }
    }

    fn pixels(&self) -> usize {
        self.identity.width as usize * self.identity.height as usize
    }

    /// Channel `c` of layer `layer`, row-major.
    fn channel(&self, layer: usize, c: usize) -> Vec<f32> {
        let pixels = self.pixels();
        self.texels[layer * pixels..(layer + 1) * pixels]
            .iter()
            .map(|t| t[c])
            .collect()
    }

    fn attributes(&self) -> BTreeMap<String, String> {
        let mut a: BTreeMap<String, String> = self
            .identity
            .to_pairs()
            .into_iter()
            .map(|(k, v)| (format!("{PREFIX}{k}"), v))
            .collect();
        a.insert(format!("{PREFIX}format"), format!("partial {FORMAT}"));
        a.insert(format!("{PREFIX}version"), self.pathmix_version.clone());
        a.insert(format!("{PREFIX}scene"), latin1(&self.scene_path));
        a.insert(
            format!("{PREFIX}samples"),
            format!("{}..{}", self.range.start, self.range.end),
        );
        a.insert(format!("{PREFIX}discarded"), self.discarded.to_string());
        let requested = match &self.requested {
            Some(r) => format!("{}..{}", r.start, r.end),
            None => OPEN_ENDED.to_string(),
        };
        a.insert(format!("{PREFIX}requested"), requested);
        let interrupted = if self.interrupted { "yes" } else { "no" };
        a.insert(format!("{PREFIX}interrupted"), interrupted.to_string());
        a
    }

    /// CRC-32 over the `pathmix.*` attributes (but the checksum) and every channel.
    fn checksum(&self, attributes: &BTreeMap<String, String>) -> String {
        let mut crc = crc32fast::Hasher::new();
        for (k, v) in attributes {
            crc.update(k.as_bytes());
            crc.update(&[0]);
            crc.update(v.as_bytes());
            crc.update(&[0]);
        }
        let mut bytes = Vec::new();
        for layer in 0..self.layers as usize {
            for c in 0..3 {
                bytes.clear();
                crc.update(channel_name(layer, c).as_bytes());
                crc.update(&[0]);
                crate::session::checkpoint::write_f32s(&mut bytes, &self.channel(layer, c))
                    .expect("writing to memory");
                crc.update(&bytes);
            }
        }
        format!("crc32:{:08x}", crc.finalize())
    }
}

/// The channel group of accumulator layer `layer`.
fn layer_name(layer: usize) -> String {
    match layer.checked_sub(LAYER_REPLICATES as usize) {
        None => LAYER_NAMES[layer].to_string(),
        Some(offset) if offset % 2 == 0 => format!("replicate{}", offset / 2 + 1),
        Some(offset) => format!("replicate{}_compensation", offset / 2 + 1),
    }
}

fn channel_name(layer: usize, c: usize) -> String {
    format!("{}.{}", layer_name(layer), CHANNELS[c])
}

/// EXR text is Latin-1: other characters become `?`.
fn latin1(text: &str) -> String {
    text.chars()
        .map(|c| if (c as u32) < 256 { c } else { '?' })
        .collect()
}

/// Writes a partial result atomically (temporary file and rename).
pub fn write_partial(path: &Path, partial: &Partial) -> Result<(), OutputError> {
    let mut attributes = partial.attributes();
    let checksum = partial.checksum(&attributes);
    attributes.insert(format!("{PREFIX}checksum"), checksum);
    let mut layer_attributes = LayerAttributes {
        software_name: Some(Text::from(
            format!("pathmix {}", env!("CARGO_PKG_VERSION")).as_str(),
        )),
        ..LayerAttributes::default()
    };
    for (k, v) in &attributes {
        layer_attributes.other.insert(
            Text::from(k.as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = (0..partial.layers as usize)
        .flat_map(|layer| (0..3).map(move |c| (layer, c)))
        .map(|(layer, c)| {
            AnyChannel::new(
                channel_name(layer, c).as_str(),
                FlatSamples::F32(partial.channel(layer, c)),
            )
        })
        .collect();
    let size = (
        partial.identity.width as usize,
        partial.identity.height as usize,
    );
    let layer = Layer::new(
        size,
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let image = exr::prelude::Image::from_layer(layer);
    output::write_atomically(path, |writer| {
        image.write().to_buffered(writer).map_err(io::Error::other)
    })
}

/// A partial result that cannot be used: the file and the problem.
#[derive(Debug, thiserror::Error)]
pub enum PartialError {
    #[error("cannot read `{}`: {source}", .path.display())]
    Read { path: PathBuf, source: io::Error },
    /// No regular file, or a header claiming more texels than pathmix reads:
    /// refused before anything is decoded.
    #[error("cannot read `{}`: {source}", .path.display())]
    Unreadable {
        path: PathBuf,
        source: crate::output::ImageReadError,
    },
    #[error(
        "`{}` is not a readable OpenEXR file (truncated or corrupted?): {source}",
        .path.display()
    )]
    NotExr {
        path: PathBuf,
        source: exr::error::Error,
    },
    #[error("`{}` is not a pathmix partial result", .path.display())]
    NotPartial { path: PathBuf },
    #[error(
        "`{}`: partial result format `{format}` is not one this pathmix reads",
        .path.display()
    )]
    UnknownFormat { path: PathBuf, format: String },
    /// This pathmix reads no older format, so it cannot check the part's scene
    /// against the others' (before format 5 the scene hashes were of `Debug` text).
    #[error(
        "`{}` was written by an older pathmix (partial result format `{format}`; this one \
         reads `partial {FORMAT}`), whose scene identity this pathmix cannot check: render \
         the part again, or merge every part with the pathmix that wrote them",
        .path.display()
    )]
    Older { path: PathBuf, format: String },
    #[error(
        "`{}` was written by a newer pathmix (partial result format `{format}`; this one \
         reads `partial {FORMAT}`): merge it with that pathmix, or render the part again",
        .path.display()
    )]
    Newer { path: PathBuf, format: String },
    #[error("`{}` is corrupted: {problem}", .path.display())]
    Corrupted { path: PathBuf, problem: Corruption },
}

/// What is wrong inside a damaged partial result.
#[derive(Debug, thiserror::Error)]
pub enum Corruption {
    #[error(transparent)]
    Identity(#[from] IdentityError),
    #[error("bad sample range `{text}`")]
    SampleRange { text: String },
    #[error("its pixel size differs from its attributes")]
    SizeDiffers,
    #[error("channel `{channel}` is missing")]
    MissingChannel { channel: String },
    #[error("channel `{channel}` is not f32")]
    ChannelNotF32 { channel: String },
    #[error("channel `{channel}` has the wrong size")]
    ChannelSize { channel: String },
    #[error("bad `pathmix.discarded`")]
    Discarded,
    #[error("bad `pathmix.requested` or `pathmix.interrupted`")]
    Request,
    #[error("its checksum does not match its contents")]
    Checksum,
}

/// Reads and checks a partial result.
pub fn read_partial(path: &Path) -> Result<Partial, PartialError> {
    let path_buf = || path.to_owned();
    // A FIFO, a device or a header claiming too many texels is refused before
    // the part is decoded; what is no EXR, the decoder explains below.
    if let Err(
        source @ (crate::output::ImageReadError::Open(_)
        | crate::output::ImageReadError::TooLarge { .. }),
    ) = crate::output::open_image(path)
    {
        return Err(PartialError::Unreadable {
            path: path_buf(),
            source,
        });
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(source) if source.kind() != io::ErrorKind::UnexpectedEof => {
                PartialError::Read {
                    path: path_buf(),
                    source,
                }
            }
            source => PartialError::NotExr {
                path: path_buf(),
                source,
            },
        })?;
    let layer = &image.layer_data;
    let mut attributes = BTreeMap::new();
    for (k, v) in image.attributes.other.iter().chain(&layer.attributes.other) {
        if let AttributeValue::Text(v) = v {
            let k = k.to_string();
            if k.starts_with(PREFIX) {
                attributes.insert(k, v.to_string());
            }
        }
    }
    let not_partial = || PartialError::NotPartial { path: path_buf() };
    let stored_checksum = attributes
        .remove(&format!("{PREFIX}checksum"))
        .ok_or_else(not_partial)?;
    let get = |k: &str| attributes.get(&format!("{PREFIX}{k}")).cloned();
    let format = get("format").ok_or_else(not_partial)?;
    let version = format
        .strip_prefix("partial ")
        .and_then(|v| v.parse::<u32>().ok());
    if version != Some(FORMAT) {
        return Err(match version {
            Some(version) if version < FORMAT => PartialError::Older {
                path: path_buf(),
                format,
            },
            Some(_) => PartialError::Newer {
                path: path_buf(),
                format,
            },
            None => PartialError::UnknownFormat {
                path: path_buf(),
                format,
            },
        });
    }
    let corrupted = |problem: Corruption| PartialError::Corrupted {
        path: path_buf(),
        problem,
    };
    let identity = SceneIdentity::from_pairs(get).map_err(|e| corrupted(e.into()))?;
    let range = parse_samples(&get("samples").unwrap_or_default()).map_err(corrupted)?;
    let size = layer.size;
    if (size.width(), size.height()) != (identity.width as usize, identity.height as usize) {
        return Err(corrupted(Corruption::SizeDiffers));
    }
    let pixels = size.area();
    let find = |n: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == n)
    };
    let has = |layer: u32| find(&channel_name(layer as usize, 0)).is_some();
    let layers = if has(LAYER_REPLICATES) {
        accumulator_layers(true, Sampler::Sobol)
    } else if has(LAYER_SQUARES) {
        LAYER_SQUARES_COMPENSATION + 1
    } else {
        LAYER_SUM_COMPENSATION + 1
    } as usize;
    let mut texels = vec![[0.0f32; 4]; layers * pixels];
    for l in 0..layers {
        for c in 0..3 {
            let channel = channel_name(l, c);
            let Some(found) = find(&channel) else {
                return Err(corrupted(Corruption::MissingChannel { channel }));
            };
            let FlatSamples::F32(values) = &found.sample_data else {
                return Err(corrupted(Corruption::ChannelNotF32 { channel }));
            };
            if values.len() != pixels {
                return Err(corrupted(Corruption::ChannelSize { channel }));
            }
            for (t, v) in texels[l * pixels..].iter_mut().zip(values) {
                t[c] = *v;
            }
        }
    }
    let partial = Partial {
        identity,
        scene_path: get("scene").unwrap_or_default(),
        pathmix_version: get("version").unwrap_or_default(),
        range,
        requested: match get("requested").as_deref() {
            Some(OPEN_ENDED) => None,
            Some(text) => Some(parse_samples(text).map_err(|_| corrupted(Corruption::Request))?),
            None => return Err(corrupted(Corruption::Request)),
        },
        interrupted: match get("interrupted").as_deref() {
            Some("yes") => true,
            Some("no") => false,
            _ => return Err(corrupted(Corruption::Request)),
        },
        discarded: get("discarded")
            .and_then(|d| d.parse().ok())
            .ok_or_else(|| corrupted(Corruption::Discarded))?,
        layers: layers as u32,
        texels,
    };
    let expected = partial.checksum(&partial.attributes());
    if expected != stored_checksum || partial.attributes() != attributes {
        return Err(corrupted(Corruption::Checksum));
    }
    Ok(partial)
}

fn parse_samples(text: &str) -> Result<Range<u32>, Corruption> {
    let bad = || Corruption::SampleRange { text: text.into() };
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    match (a.parse::<u32>(), b.parse::<u32>()) {
        (Ok(a), Ok(b)) if a <= b => Ok(a..b),
        _ => Err(bad()),
    }
}

/// The merged sums and what the parts covered.
#[derive(Debug)]
pub struct Merged {
    pub accumulation: Accumulation,
    /// The parts' ranges, sorted.
    pub ranges: Vec<Range<u32>>,
    /// Sample indices below the highest one covered that no part holds.
    pub gaps: Vec<Range<u32>>,
    pub discarded: u64,
    /// Things to tell the user (gaps, differing versions, dropped variance).
    pub warnings: Vec<String>,
}

/// Parts that do not merge into one image. `part` names the part that differs
/// from `first`, the first one given.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum MergeError {
    #[error("no partial results to merge")]
    NoParts,
    #[error(
        "`{part}` is {}x{} but `{first}` is {}x{}: parts must be renders of the same image size",
        .size.0, .size.1, .first_size.0, .first_size.1
    )]
    SizeDiffers {
        part: String,
        first: String,
        size: (u32, u32),
        first_size: (u32, u32),
    },
    #[error(
        "`{part}` has seed {seed} but `{first}` has seed {first_seed}: parts must use the same \
         seed, or their samples repeat or do not belong together"
    )]
    SeedDiffers {
        part: String,
        first: String,
        seed: u32,
        first_seed: u32,
    },
    #[error(
        "`{part}` comes from a different scene than `{first}` (scene hash {} vs {}): {}",
        crate::session::checkpoint::hex(*.hash),
        crate::session::checkpoint::hex(*.first_hash),
        .differences.join("; ")
    )]
    SceneDiffers {
        part: String,
        first: String,
        hash: u64,
        first_hash: u64,
        differences: Vec<String>,
    },
    #[error(
        "{}; merge it when its run is complete (resume it from its checkpoint), or give \
         --allow-incomplete to merge what it holds",
        .0.join("; ")
    )]
    Incomplete(Vec<String>),
    #[error(
        "parts overlap, so some samples would count twice: {}",
        .0.iter().map(Overlap::to_string).collect::<Vec<_>>().join("; ")
    )]
    Overlaps(Vec<Overlap>),
}

/// Two parts that hold some of the same sample indices.
#[derive(Clone, Debug, PartialEq)]
pub struct Overlap {
    pub earlier: (String, Range<u32>),
    pub later: (String, Range<u32>),
}

impl fmt::Display for Overlap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ((a, r0), (b, r1)) = (&self.earlier, &self.later);
        write!(
            f,
            "`{a}` (samples {}..{}) and `{b}` (samples {}..{}) overlap in {}..{}",
            r0.start,
            r0.end,
            r1.start,
            r1.end,
            r1.start,
            r0.end.min(r1.end)
        )
    }
}

/// Merges partial results of one image: same scene (hash), seed and size,
/// disjoint sample ranges. Sums are added in f64. Gaps in the ranges are
/// listed, not refused: any set of sample indices gives an unbiased image.
/// A part short of what its run was asked for (interrupted) is refused.
pub fn merge(parts: &[(String, Partial)]) -> Result<Merged, MergeError> {
    merge_with(parts, false)
}

/// [`merge`], with `allow_incomplete` turning a part cut short into a warning.
pub fn merge_with(
    parts: &[(String, Partial)],
    allow_incomplete: bool,
) -> Result<Merged, MergeError> {
    let Some((first_name, first)) = parts.first() else {
        return Err(MergeError::NoParts);
    };
    let mut warnings = Vec::new();
    let short: Vec<String> = parts
        .iter()
        .filter_map(|(name, part)| Some(format!("`{name}` {}", part.shortfall()?)))
        .collect();
    if !short.is_empty() {
        if !allow_incomplete {
            return Err(MergeError::Incomplete(short));
        }
        warnings.extend(
            short
                .into_iter()
                .map(|s| format!("{s}; merged what it holds")),
        );
    }
    for (name, part) in &parts[1..] {
        let (a, b) = (&first.identity, &part.identity);
        if (a.width, a.height) != (b.width, b.height) {
            return Err(MergeError::SizeDiffers {
                part: name.clone(),
                first: first_name.clone(),
                size: (b.width, b.height),
                first_size: (a.width, a.height),
            });
        }
        if a.seed != b.seed {
            return Err(MergeError::SeedDiffers {
                part: name.clone(),
                first: first_name.clone(),
                seed: b.seed,
                first_seed: a.seed,
            });
        }
        let differences = SceneIdentity::differences(
            (a, &format!("in `{first_name}`")),
            (b, &format!("in `{name}`")),
        );
        if !differences.is_empty() {
            return Err(MergeError::SceneDiffers {
                part: name.clone(),
                first: first_name.clone(),
                hash: b.hash(),
                first_hash: a.hash(),
                differences,
            });
        }
        if part.pathmix_version != first.pathmix_version {
            warnings.push(format!(
                "`{name}` was made by pathmix {} and `{first_name}` by {}",
                part.pathmix_version, first.pathmix_version
            ));
        }
    }
    let mut order: Vec<&(String, Partial)> = parts.iter().collect();
    order.sort_by_key(|(_, p)| (p.range.start, p.range.end));
    let mut overlaps = Vec::new();
    let mut reach: Option<&(String, Partial)> = None;
    for part in &order {
        if part.1.range.is_empty() {
            continue;
        }
        if let Some(before) = reach {
            if part.1.range.start < before.1.range.end {
                overlaps.push(Overlap {
                    earlier: (before.0.clone(), before.1.range.clone()),
                    later: (part.0.clone(), part.1.range.clone()),
                });
            }
        }
        if reach.is_none_or(|b| part.1.range.end > b.1.range.end) {
            reach = Some(part);
        }
    }
    if !overlaps.is_empty() {
        return Err(MergeError::Overlaps(overlaps));
    }
    let ranges: Vec<Range<u32>> = order.iter().map(|(_, p)| p.range.clone()).collect();
    let mut gaps = Vec::new();
    let mut covered_to = 0;
    for r in ranges.iter().filter(|r| !r.is_empty()) {
        if r.start > covered_to {
            gaps.push(covered_to..r.start);
        }
        covered_to = covered_to.max(r.end);
    }
    let samples: u64 = ranges.iter().map(|r| r.len() as u64).sum();
    if !gaps.is_empty() {
        let mut text = String::new();
        let _ = write!(
            text,
            "no part holds sample indices {}; merged the {samples} samples per pixel that are there",
            describe_ranges(&gaps)
        );
        warnings.push(text);
    }
    let has_squares = |p: &Partial| p.layers > LAYER_SQUARES_COMPENSATION;
    let variance = parts.iter().all(|(_, p)| has_squares(p));
    if !variance && parts.iter().any(|(_, p)| has_squares(p)) {
        warnings.push("some parts have no sums of squares, so the merge has no variance".into());
    }
    let pixels = first.pixels();
    // The sampler is part of the scene's identity, so the parts agree on replicates.
    let has_replicates = |p: &Partial| p.layers == accumulator_layers(true, Sampler::Sobol);
    let replicated = variance && parts.iter().all(|(_, p)| has_replicates(p));
    let add = |total: &mut [[f64; 3]], part: &[[f64; 3]]| {
        for (t, s) in total.iter_mut().zip(part) {
            (0..3).for_each(|c| t[c] += s[c]);
        }
    };
    let mut sum = vec![[0.0f64; 3]; pixels];
    let mut sum_sq = variance.then(|| vec![[0.0f64; 3]; pixels]);
    let mut replicates = replicated.then(|| Replicates {
        samples: vec![0; REPLICATES as usize],
        sums: vec![vec![[0.0f64; 3]; pixels]; REPLICATES as usize],
    });
    for (_, part) in parts {
        let layer = |sum| compensated_sums(&part.texels, pixels, sum, sum + 1).collect::<Vec<_>>();
        let part_sum = layer(LAYER_SUM);
        add(&mut sum, &part_sum);
        if let Some(sum_sq) = &mut sum_sq {
            add(sum_sq, &layer(LAYER_SQUARES));
        }
        if let Some(replicates) = &mut replicates {
            let range = part.range.start as u64..part.range.end as u64;
            let others = (1..REPLICATES).map(|r| layer(replicate_layer(r))).collect();
            let part = Replicates::from_others(range, &part_sum, others);
            for (r, (samples, sums)) in part.samples.iter().zip(&part.sums).enumerate() {
                replicates.samples[r] += samples;
                add(&mut replicates.sums[r], sums);
            }
        }
    }
    Ok(Merged {
        accumulation: Accumulation {
            width: first.identity.width,
            height: first.identity.height,
            samples,
            counts: None,
            sum,
            sum_sq,
            replicates,
        },
        ranges,
        gaps,
        discarded: parts.iter().map(|(_, p)| p.discarded).sum(),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    fn identity(width: u32, height: u32) -> SceneIdentity {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/furnace.toml");
        let mut scene = Scene::load(&path).unwrap();
        scene.camera.width = width;
        scene.camera.height = height;
        SceneIdentity::of(&scene)
    }

    /// A 3x2 part whose sums make the mean `value` in channel R.
    fn part(range: Range<u32>, value: f32, layers: u32) -> Partial {
        let n = range.len() as f32;
        let texels = (0..6 * layers)
            .map(|i| match i / 6 {
                0 => [value * n, 2.0 * value * n, i as f32, 0.0],
                1 => [1e-7, -1e-7, 0.0, 0.0],
                _ => [value * value * n, 0.0, 0.0, 0.0],
            })
            .collect();
        sized_part(range, 3, 2, layers, texels)
    }

    fn sized_part(
        range: Range<u32>,
        width: u32,
        height: u32,
        layers: u32,
        texels: Vec<[f32; 4]>,
    ) -> Partial {
        Partial::from_state(
            identity(width, height),
            "furnace.toml".into(),
            0,
            AccumulatorState {
                width,
                height,
                layers,
                first_sample: range.start,
                samples: range.len() as u32,
                texels,
                adaptive: None,
            },
        )
    }

    /// A path `name` in a fresh folder, removed when the first value is dropped.
    fn temp(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::Builder::new()
            .prefix("pathmix-shard-")
            .tempdir()
            .unwrap();
        let path = dir.path().join(name);
        (dir, path)
    }

    #[test]
    fn shard_ranges_cover_everything_once() {
        for (count, total) in [(4, 1000), (3, 10), (7, 3), (1, 5), (5, 5)] {
            let ranges: Vec<_> = (0..count).map(|i| shard_range(i, count, total)).collect();
            assert_eq!(ranges[0].start, 0);
            assert_eq!(ranges.last().unwrap().end, total);
            for w in ranges.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
        }
        assert_eq!(shard_range(1, 4, 1000), 250..500);
        assert_eq!(parse_shard("2/4"), Ok((2, 4)));
        assert!(parse_shard("4/4").is_err() && parse_shard("1-4").is_err());
        assert_eq!(parse_range("0..250"), Ok(0..250));
        assert!(parse_range("250..250").is_err() && parse_range("5").is_err());
    }

    #[test]
    fn partial_files_round_trip_and_refuse_corruption() {
        // Sums; and squares; and squares and the Sobol replicates' sums.
        for layers in [2, 4, accumulator_layers(true, Sampler::Sobol)] {
            // Noise-like sums, so that compression leaves most of the file to the data.
            let mut x = 1u32;
            let texels = (0..40 * 30 * layers)
                .map(|_| {
                    std::array::from_fn(|c| {
                        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                        if c == 3 { 0.0 } else { (x >> 8) as f32 * 1e-3 }
                    })
                })
                .collect();
            let p = sized_part(250..500, 40, 30, layers, texels);
            let (_dir, path) = temp(&format!("p{layers}.exr"));
            write_partial(&path, &p).unwrap();
            assert_eq!(read_partial(&path).unwrap(), p);
            let bytes = std::fs::read(&path).unwrap();
            let e = read_partial_bytes(&bytes[..bytes.len() - 10]);
            assert!(e.contains("truncated or corrupted"), "{e}");
            // A flip in the pixel data is refused, never merged.
            for at in (bytes.len() / 4..bytes.len()).step_by(97) {
                let mut b = bytes.clone();
                b[at] ^= 0x10;
                let e = read_partial_bytes(&b);
                assert!(e.contains("corrupted"), "byte {at}: {e}");
            }
            // So is a changed attribute: seed 0 becomes 1.
            let key = b"pathmix.seed\0string\0";
            let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
            let mut b = bytes.clone();
            assert_eq!(b[at], b'0');
            b[at] = b'1';
            let e = read_partial_bytes(&b);
            assert!(e.contains("checksum"), "{e}");
        }
    }

    #[test]
    fn parts_short_of_their_request_are_refused_unless_allowed() {
        let cut = part(10..15, 1.0, 2).asked_for(Some(10..20), true);
        let (_dir, path) = temp("short.exr");
        write_partial(&path, &cut).unwrap();
        let read = read_partial(&path).unwrap();
        assert_eq!(
            (read.requested.clone(), read.interrupted),
            (Some(10..20), true)
        );
        let parts = [
            ("a".to_string(), part(0..10, 1.0, 2)),
            ("b".to_string(), read),
        ];
        let e = merge(&parts).unwrap_err().to_string();
        assert!(
            e.contains("`b` holds samples 10..15 of the 10..20 it was asked for")
                && e.contains("--allow-incomplete"),
            "{e}"
        );
        let merged = merge_with(&parts, true).unwrap();
        assert_eq!(merged.accumulation.samples, 15);
        assert!(
            merged
                .warnings
                .iter()
                .any(|w| w.contains("`b` holds samples 10..15"))
        );
        // An open-ended run (a time budget) is short only when interrupted.
        let timed = part(10..15, 1.0, 2).asked_for(None, false);
        assert_eq!(timed.shortfall(), None);
        assert!(timed.asked_for(None, true).shortfall().is_some());
    }

    #[test]
    fn partial_files_of_an_older_format_are_refused_as_older() {
        let (_dir, path) = temp("older.exr");
        write_partial(&path, &part(0..10, 1.0, 2)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let ours = format!("partial {FORMAT}");
        let at = bytes
            .windows(ours.len())
            .position(|w| w == ours.as_bytes())
            .unwrap();
        let mut b = bytes.clone();
        b[at + ours.len() - 1] = b'0' + (FORMAT - 1) as u8;
        // Its own file: `read_partial_bytes` shares one with tests running alongside.
        std::fs::write(&path, b).unwrap();
        let e = read_partial(&path).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "`{}` was written by an older pathmix",
                path.display()
            )) && e.contains(&format!("`partial {}`", FORMAT - 1))
                && e.contains("scene identity this pathmix cannot check")
                && e.contains("render the part again"),
            "{e}"
        );
    }

    /// What is no regular file is refused before anything is read from it (a
    /// FIFO would block, a device never end).
    #[test]
    fn a_part_that_is_no_regular_file_is_refused_unread() {
        let (dir, _) = temp("part.exr");
        let folder = dir.path().join("folder.exr");
        std::fs::create_dir(&folder).unwrap();
        let e = read_partial(&folder).unwrap_err();
        assert!(matches!(e, PartialError::Unreadable { .. }), "{e:?}");
        assert!(e.to_string().contains("not a regular file"), "{e}");
    }

    fn read_partial_bytes(bytes: &[u8]) -> String {
        let (_dir, path) = temp("damaged.exr");
        std::fs::write(&path, bytes).unwrap();
        match read_partial(&path) {
            Ok(_) => "read without error".into(),
            Err(e) => e.to_string(),
        }
    }

    /// Parts of any ranges merge the Sobol replicates: each sample of replicate r
    /// (index mod 4) is r + 1, so the merged replicates' means are 1, 2, 3, 4 and the
    /// standard error sqrt(Σ (m_r − 2.5)² / 12) = sqrt(5/12), as one run of 0..16 gives.
    #[test]
    fn merge_adds_the_replicates_of_parts_of_any_ranges() {
        let layers = accumulator_layers(true, Sampler::Sobol);
        let replicate_part = |range: Range<u32>| {
            let counts = Replicates::samples_in(range.start as u64..range.end as u64, REPLICATES);
            let sums: Vec<f32> = (0..REPLICATES as usize)
                .map(|r| counts[r] as f32 * (r + 1) as f32)
                .collect();
            let texels = (0..layers)
                .flat_map(|layer| {
                    let value = match layer {
                        LAYER_SUM => sums.iter().sum(),
                        LAYER_SQUARES => 1.0,
                        l if l >= LAYER_REPLICATES && (l - LAYER_REPLICATES) % 2 == 0 => {
                            sums[((l - LAYER_REPLICATES) / 2 + 1) as usize]
                        }
                        _ => 0.0,
                    };
                    [[value; 4]; 6]
                })
                .collect();
            sized_part(range, 3, 2, layers, texels)
        };
        let merged = merge(&[
            ("b".into(), replicate_part(6..16)),
            ("a".into(), replicate_part(0..6)),
        ])
        .unwrap();
        let replicates = merged.accumulation.replicates.as_ref().unwrap();
        assert_eq!(replicates.samples, [4, 4, 4, 4]);
        let se = merged.accumulation.standard_error().unwrap();
        let expected = (5.0f64 / 12.0).sqrt();
        assert!(
            se.pixels
                .iter()
                .flatten()
                .all(|&v| (v as f64 - expected).abs() < 1e-6),
            "{:?}",
            se.pixels
        );
    }

    #[test]
    fn merge_adds_sums_and_checks_the_parts() {
        let parts = vec![
            ("b".to_string(), part(250..500, 0.25, 4)),
            ("a".to_string(), part(0..250, 0.75, 4)),
        ];
        let merged = merge(&parts).unwrap();
        assert_eq!(merged.accumulation.samples, 500);
        assert!(merged.gaps.is_empty() && merged.warnings.is_empty());
        let mean = merged.accumulation.mean();
        assert!(
            (mean.pixels[0][0] - 0.5).abs() < 1e-6,
            "{:?}",
            mean.pixels[0]
        );
        assert!(merged.accumulation.sum_sq.is_some());

        let gaps = merge(&[
            ("a".into(), part(0..100, 1.0, 2)),
            ("c".into(), part(300..400, 1.0, 2)),
            ("b".into(), part(150..200, 1.0, 2)),
        ])
        .unwrap();
        assert_eq!(gaps.gaps, vec![100..150, 200..300]);
        assert!(
            gaps.warnings[0].contains("100..150, 200..300"),
            "{:?}",
            gaps.warnings
        );

        let overlap = merge(&[
            ("a".into(), part(0..1000, 1.0, 2)),
            ("b".into(), part(100..200, 1.0, 2)),
            ("c".into(), part(900..1100, 1.0, 2)),
        ])
        .unwrap_err()
        .to_string();
        assert!(
            overlap.contains("`a` (samples 0..1000) and `b` (samples 100..200)")
                && overlap.contains("`c` (samples 900..1100) overlap in 900..1000"),
            "{overlap}"
        );

        let mut other_seed = part(500..600, 1.0, 2);
        other_seed.identity.seed += 1;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("s".into(), other_seed)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("seed"), "{e}");
        let mut other_size = part(500..600, 1.0, 2);
        other_size.identity.width = 4;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("w".into(), other_size)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("4x2") && e.contains("3x2"), "{e}");
        let mut other_scene = part(500..600, 1.0, 2);
        other_scene.identity.geometry_hash ^= 1;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("g".into(), other_scene)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("different scene") && e.contains("geometry"),
            "{e}"
        );
    }
}
