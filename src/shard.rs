//! Shards: runs that each render a disjoint range of sample indices of one
//! image, their partial results, and merging those into the image.
//!
//! A partial result is an OpenEXR file with one f32 channel per running sum and
//! per compensation (`sum.R`, `sum_compensation.R`, ..., and with variance
//! `squares.R`, `squares_compensation.R`, ...), so a merge rebuilds every sum in
//! f64, and text attributes `pathmix.*`: the scene hash and its parts, seed,
//! sample range, size, pathmix version and a CRC-32 of the other attributes and
//! the pixel data.

use crate::checkpoint::SceneIdentity;
use crate::output::{self, OutputError};
use crate::render::AccumulatorState;
use crate::stats::Accumulation;
use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SmallVec, WritableImage,
};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io;
use std::ops::Range;
use std::path::Path;

/// Channel groups in accumulator layer order.
pub const LAYER_NAMES: [&str; 4] = ["sum", "sum_compensation", "squares", "squares_compensation"];
const CHANNELS: [&str; 3] = ["R", "G", "B"];
const PREFIX: &str = "pathmix.";
/// `pathmix.format`. 2: the scene hashes come from the whole scene's `Debug` text.
const FORMAT: u32 = 2;

/// `A..B`: sample indices A (included) to B (excluded).
pub fn parse_range(text: &str) -> Result<Range<u32>, String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("`{text}` is not a range like 0..250"))?;
    let number = |s: &str| {
        s.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{text}`: `{s}` is not a sample index"))
    };
    let range = number(a)?..number(b)?;
    if range.start >= range.end {
        return Err(format!(
            "`{text}`: the range is empty (end must be > start)"
        ));
    }
    Ok(range)
}

/// `I/N`: shard I (from 0) of N.
pub fn parse_shard(text: &str) -> Result<(u32, u32), String> {
    let (i, n) = text
        .split_once('/')
        .ok_or_else(|| format!("`{text}` is not INDEX/COUNT like 2/4"))?;
    let index: u32 = i
        .trim()
        .parse()
        .map_err(|_| format!("`{text}`: bad index"))?;
    let count: u32 = n
        .trim()
        .parse()
        .map_err(|_| format!("`{text}`: bad count"))?;
    if count == 0 || index >= count {
        return Err(format!(
            "`{text}`: the index must be below the count (0..{count})"
        ));
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
            discarded,
            layers: state.layers,
            texels: state.texels,
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

    /// Each sum rebuilt in f64 (sum minus compensation).
    fn layer_f64(&self, sum: usize) -> impl Iterator<Item = [f64; 3]> + '_ {
        let pixels = self.pixels();
        let sums = &self.texels[sum * pixels..(sum + 1) * pixels];
        let compensations = &self.texels[(sum + 1) * pixels..(sum + 2) * pixels];
        sums.iter()
            .zip(compensations)
            .map(|(s, c)| std::array::from_fn(|i| s[i] as f64 - c[i] as f64))
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
                crate::checkpoint::write_f32s(&mut bytes, &self.channel(layer, c))
                    .expect("writing to memory");
                crc.update(&bytes);
            }
        }
        format!("crc32:{:08x}", crc.finalize())
    }
}

fn channel_name(layer: usize, c: usize) -> String {
    format!("{}.{}", LAYER_NAMES[layer], CHANNELS[c])
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

/// Reads and checks a partial result. The message names the file and the problem.
pub fn read_partial(path: &Path) -> Result<Partial, String> {
    let name = path.display();
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(e) if e.kind() != io::ErrorKind::UnexpectedEof => {
                format!("cannot read `{name}`: {e}")
            }
            e => format!("`{name}` is not a readable OpenEXR file (truncated or corrupted?): {e}"),
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
    let not_partial =
        || format!("`{name}` is not a pathmix partial result (made by `pathmix render --partial`)");
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
            Some(v) => format!(
                "`{name}` was written by {} pathmix (partial result format `{format}`; this \
                 one reads `partial {FORMAT}`): merge it with that pathmix, or render the part \
                 again",
                if v < FORMAT { "an older" } else { "a newer" }
            ),
            None => {
                format!("`{name}`: partial result format `{format}` is not one this pathmix reads")
            }
        });
    }
    let corrupted = |what: String| format!("`{name}` is corrupted: {what}");
    let identity = SceneIdentity::from_pairs(get).map_err(corrupted)?;
    let range = parse_samples(&get("samples").unwrap_or_default()).map_err(corrupted)?;
    let size = layer.size;
    if (size.width(), size.height()) != (identity.width as usize, identity.height as usize) {
        return Err(corrupted(
            "its pixel size differs from its attributes".into(),
        ));
    }
    let pixels = size.area();
    let find = |n: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == n)
    };
    let layers = if find("squares.R").is_some() { 4 } else { 2 };
    let mut texels = vec![[0.0f32; 4]; layers * pixels];
    for l in 0..layers {
        for c in 0..3 {
            let channel_name = channel_name(l, c);
            let channel = find(&channel_name)
                .ok_or_else(|| corrupted(format!("channel `{channel_name}` is missing")))?;
            let FlatSamples::F32(values) = &channel.sample_data else {
                return Err(corrupted(format!("channel `{channel_name}` is not f32")));
            };
            if values.len() != pixels {
                return Err(corrupted(format!(
                    "channel `{channel_name}` has the wrong size"
                )));
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
        discarded: get("discarded")
            .and_then(|d| d.parse().ok())
            .ok_or_else(|| corrupted("bad `pathmix.discarded`".into()))?,
        layers: layers as u32,
        texels,
    };
    let expected = partial.checksum(&partial.attributes());
    if expected != stored_checksum || partial.attributes() != attributes {
        return Err(corrupted("its checksum does not match its contents".into()));
    }
    Ok(partial)
}

fn parse_samples(text: &str) -> Result<Range<u32>, String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("bad sample range `{text}`"))?;
    match (a.parse::<u32>(), b.parse::<u32>()) {
        (Ok(a), Ok(b)) if a <= b => Ok(a..b),
        _ => Err(format!("bad sample range `{text}`")),
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

/// Merges partial results of one image: same scene (hash), seed and size,
/// disjoint sample ranges. Sums are added in f64. Gaps in the ranges are
/// listed, not refused: any set of sample indices gives an unbiased image.
pub fn merge(parts: &[(String, Partial)]) -> Result<Merged, String> {
    let Some((first_name, first)) = parts.first() else {
        return Err("no partial results to merge".into());
    };
    let mut warnings = Vec::new();
    for (name, part) in &parts[1..] {
        let (a, b) = (&first.identity, &part.identity);
        if (a.width, a.height) != (b.width, b.height) {
            return Err(format!(
                "`{name}` is {}x{} but `{first_name}` is {}x{}: parts must be renders of the same image size",
                b.width, b.height, a.width, a.height
            ));
        }
        if a.seed != b.seed {
            return Err(format!(
                "`{name}` has seed {} but `{first_name}` has seed {}: parts must use the same seed, \
                 or their samples repeat or do not belong together",
                b.seed, a.seed
            ));
        }
        let differences = SceneIdentity::differences(
            (a, &format!("in `{first_name}`")),
            (b, &format!("in `{name}`")),
        );
        if !differences.is_empty() {
            return Err(format!(
                "`{name}` comes from a different scene than `{first_name}` (scene hash {} vs {}): {}",
                crate::checkpoint::hex(b.hash()),
                crate::checkpoint::hex(a.hash()),
                differences.join("; ")
            ));
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
                let r = (&before.1.range, &part.1.range);
                overlaps.push(format!(
                    "`{}` (samples {}..{}) and `{}` (samples {}..{}) overlap in {}..{}",
                    before.0,
                    r.0.start,
                    r.0.end,
                    part.0,
                    r.1.start,
                    r.1.end,
                    r.1.start,
                    r.0.end.min(r.1.end)
                ));
            }
        }
        if reach.is_none_or(|b| part.1.range.end > b.1.range.end) {
            reach = Some(part);
        }
    }
    if !overlaps.is_empty() {
        return Err(format!(
            "parts overlap, so some samples would count twice: {}",
            overlaps.join("; ")
        ));
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
    let variance = parts.iter().all(|(_, p)| p.layers >= 4);
    if !variance && parts.iter().any(|(_, p)| p.layers >= 4) {
        warnings.push("some parts have no sums of squares, so the merge has no variance".into());
    }
    let pixels = first.pixels();
    let mut sum = vec![[0.0f64; 3]; pixels];
    let mut sum_sq = variance.then(|| vec![[0.0f64; 3]; pixels]);
    for (_, part) in parts {
        for (total, s) in sum.iter_mut().zip(part.layer_f64(0)) {
            (0..3).for_each(|c| total[c] += s[c]);
        }
        if let Some(sum_sq) = &mut sum_sq {
            for (total, s) in sum_sq.iter_mut().zip(part.layer_f64(2)) {
                (0..3).for_each(|c| total[c] += s[c]);
            }
        }
    }
    Ok(Merged {
        accumulation: Accumulation {
            width: first.identity.width,
            height: first.identity.height,
            samples,
            sum,
            sum_sq,
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
            },
        )
    }

    fn temp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("pathmix-shard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
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
        for layers in [2, 4] {
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
            let path = temp(&format!("p{layers}.exr"));
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
    fn partial_files_of_an_older_format_are_refused_as_older() {
        let path = temp("older.exr");
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
        let e = read_partial(&path).unwrap_err();
        assert!(
            e.contains("written by an older pathmix")
                && e.contains(&format!("`partial {}`", FORMAT - 1)),
            "{e}"
        );
    }

    fn read_partial_bytes(bytes: &[u8]) -> String {
        let path = temp("damaged.exr");
        std::fs::write(&path, bytes).unwrap();
        match read_partial(&path) {
            Ok(_) => "read without error".into(),
            Err(e) => e,
        }
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
        .unwrap_err();
        assert!(
            overlap.contains("`a` (samples 0..1000) and `b` (samples 100..200)")
                && overlap.contains("`c` (samples 900..1100) overlap in 900..1000"),
            "{overlap}"
        );

        let mut other_seed = part(500..600, 1.0, 2);
        other_seed.identity.seed += 1;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("s".into(), other_seed)]).unwrap_err();
        assert!(e.contains("seed"), "{e}");
        let mut other_size = part(500..600, 1.0, 2);
        other_size.identity.width = 4;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("w".into(), other_size)]).unwrap_err();
        assert!(e.contains("4x2") && e.contains("3x2"), "{e}");
        let mut other_scene = part(500..600, 1.0, 2);
        other_scene.identity.geometry_hash ^= 1;
        let e = merge(&[("a".into(), part(0..10, 1.0, 2)), ("g".into(), other_scene)]).unwrap_err();
        assert!(
            e.contains("different scene") && e.contains("geometry"),
            "{e}"
        );
    }
}
