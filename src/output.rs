//! Tone mapping and image files (PNG for viewing, EXR for linear radiance).
//!
//! Every file is written atomically, so an interrupted or failed write never leaves a
//! truncated image behind or destroys the previous one.

use std::ffi::OsString;
use std::fmt;
use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::SmallVec;
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, ReadChannels,
    ReadLayers, ReadSpecificChannel, SpecificChannels, Vec2, WritableImage,
};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

/// Linear radiance, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Panics if `(x, y)` lies outside the image.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        // Without this, an x past the row end would silently read the next row.
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside {}x{} image",
            self.width,
            self.height
        );
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Exr,
}

impl ImageFormat {
    /// From the path's extension (case-insensitive: png, exr).
    pub fn from_path(path: &Path) -> Result<ImageFormat, OutputError> {
        let Some(extension) = path.extension() else {
            return Err(OutputError::writing(
                path,
                "no image extension (pathmix writes .png and .exr)",
            ));
        };
        let extension = extension.to_string_lossy();
        match extension.to_ascii_lowercase().as_str() {
            "png" => Ok(ImageFormat::Png),
            "exr" => Ok(ImageFormat::Exr),
            _ => Err(OutputError::writing(
                path,
                format!("unknown image extension `.{extension}` (pathmix writes .png and .exr)"),
            )),
        }
    }

    fn name(self) -> &'static str {
        match self {
            ImageFormat::Png => "PNG",
            ImageFormat::Exr => "EXR",
        }
    }
}

/// Error naming the path and the problem. `message` is the whole sentence that `Display`
/// shows, path included (e.g. "cannot write `out.jpg`: unknown image extension ...").
#[derive(Debug)]
pub struct OutputError {
    pub path: PathBuf,
    pub message: String,
}

impl OutputError {
    fn writing(path: &Path, problem: impl fmt::Display) -> OutputError {
        OutputError {
            path: path.to_owned(),
            message: format!("cannot write `{}`: {problem}", path.display()),
        }
    }

    fn reading(path: &Path, problem: impl fmt::Display) -> OutputError {
        OutputError {
            path: path.to_owned(),
            message: format!("cannot read `{}`: {problem}", path.display()),
        }
    }
}

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for OutputError {}

/// Checks before a render starts that `path` can be written as `expected`: the extension
/// matches, the parent folder exists and is a folder, `path` is not a folder, and a file can
/// be created in that folder. This way a long render does not fail at the end.
pub fn check_output_path(path: &Path, expected: ImageFormat) -> Result<(), OutputError> {
    let format = ImageFormat::from_path(path)?;
    if format != expected {
        return Err(OutputError::writing(
            path,
            format!(
                "the extension makes it a {} file, but {} output was requested",
                format.name(),
                expected.name()
            ),
        ));
    }
    check_writable(path)
}

/// Checks that a file can be written at `path`: the parent folder exists and is a
/// folder, `path` is not a folder, an existing file there is one the user may write
/// (not read-only), and a file can be created in that folder. Also removes what
/// interrupted writes of `path` by processes no longer running left beside it.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    let name = file_name(path)?;
    let folder = parent_folder(path)?;
    if path.is_dir() {
        return Err(OutputError::writing(path, "it is a folder"));
    }
    check_not_read_only(path)?;
    remove_stale_temporaries(folder, name);
    // Creating a file is the only reliable permission check (ACLs, read-only mounts).
    tempfile::Builder::new()
        .prefix(&temporary_prefix(name, "probe"))
        .tempfile_in(folder)
        .map(drop)
        .map_err(|e| OutputError::writing(path, e))
}

/// Refuses to replace a file its owner made read-only (no write bit: root could
/// replace it, but nobody meant it to change) or one this user may not write
/// (`access(W_OK)`: permissions, ACLs, an immutable file).
fn check_not_read_only(path: &Path) -> Result<(), OutputError> {
    let Ok(metadata) = fs::metadata(path) else {
        return Ok(());
    };
    if metadata.permissions().readonly() {
        return Err(OutputError::writing(
            path,
            "the file is read-only: pathmix will not replace it (make it writable or \
             choose another path)",
        ));
    }
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let c_path = std::ffi::CString::new(path.as_os_str().as_bytes())
            .map_err(|_| OutputError::writing(path, "the path contains a NUL byte"))?;
        // SAFETY: a valid NUL-terminated string; access(2) only reads it.
        if unsafe { libc::access(c_path.as_ptr(), libc::W_OK) } != 0 {
            let error = io::Error::last_os_error();
            return Err(OutputError::writing(
                path,
                format!(
                    "you may not write the existing file ({error}); pathmix will not replace it"
                ),
            ));
        }
    }
    Ok(())
}

/// `.NAME.TAG-PID-`: how the temporaries of `NAME` begin (a random part follows).
fn temporary_prefix(name: &std::ffi::OsStr, tag: &str) -> OsString {
    let mut prefix = OsString::from(".");
    prefix.push(name);
    prefix.push(format!(".{tag}-{}-", std::process::id()));
    prefix
}

/// Temporaries of `name` in `folder` (`.NAME.tmp-PID...`, `.NAME.probe-PID...`)
/// whose process is gone: a write cut short by SIGKILL or a crash. Best effort:
/// a file that cannot be removed stays, and is nothing but hidden clutter.
fn remove_stale_temporaries(folder: &Path, name: &std::ffi::OsStr) {
    let Ok(entries) = fs::read_dir(folder) else {
        return;
    };
    let mut stem = OsString::from(".");
    stem.push(name);
    stem.push(".");
    let stem = stem.to_string_lossy().into_owned();
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&stem)) else {
            continue;
        };
        let Some(pid) = ["tmp-", "probe-"].iter().find_map(|tag| {
            let digits: String = rest
                .strip_prefix(tag)?
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            digits.parse::<u32>().ok()
        }) else {
            continue;
        };
        if !process_is_running(pid) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Whether process `pid` exists (on other platforms than Unix: assumed so).
pub fn process_is_running(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else {
            return false;
        };
        // SAFETY: signal 0 only checks that the process exists.
        if unsafe { libc::kill(pid, 0) } == 0 {
            return true;
        }
        io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// The temporaries being written now, so that a second Ctrl-C can remove them
/// before the process exits ([`remove_temporaries_for_exit`]).
static LIVE_TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn live_temporaries() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMPORARIES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Marks `path` as removable by [`remove_temporaries_for_exit`] (a lock file).
pub fn register_temporary(path: &Path) {
    live_temporaries().push(path.to_owned());
}

pub fn unregister_temporary(path: &Path) {
    live_temporaries().retain(|p| p != path);
}

/// For an exit that cannot wait for the writes in flight (a second signal):
/// removes every temporary being written and keeps any new one from being
/// made or renamed until the process is gone. Call, then exit.
pub fn remove_temporaries_for_exit() {
    let live = live_temporaries();
    for path in live.iter() {
        let _ = fs::remove_file(path);
    }
    // Held until exit: a write now waiting to create or rename its file never does.
    std::mem::forget(live);
}

/// Linear → 8-bit sRGB: multiply by 2^exposure, clamp to [0, 1] (NaN → 0), apply the sRGB
/// transfer function (IEC 61966-2-1 piecewise curve), round to nearest. RGB, 3 bytes per pixel.
pub fn to_srgb8(image: &Image, exposure: f32) -> Vec<u8> {
    let scale = f64::from(exposure).exp2();
    image
        .pixels
        .iter()
        .flatten()
        .map(|&v| srgb8(f64::from(v) * scale))
        .collect()
}

fn srgb8(linear: f64) -> u8 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    let encoded = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

/// 8-bit sRGB PNG of `image` tone-mapped by [`to_srgb8`].
pub fn write_png(path: &Path, image: &Image, exposure: f32) -> Result<(), OutputError> {
    check_pixel_count(path, image)?;
    let bytes = to_srgb8(image, exposure);
    write_atomically(path, |writer| {
        PngEncoder::new(writer)
            .write_image(&bytes, image.width, image.height, ExtendedColorType::Rgb8)
            .map_err(io::Error::other)
    })
}

/// Linear float RGB EXR (f32 channels R, G, B, ZIP-compressed), with extra string attributes
/// stored as EXR header attributes of type `string`. Names of standard EXR text attributes
/// (`software`, `comments`, `owner`, `capDate`, ...) fill those; other standard names are
/// rejected by the exr crate. Names and values must be Latin-1, as EXR text is bytes.
pub fn write_exr(
    path: &Path,
    image: &Image,
    attributes: &[(&str, String)],
) -> Result<(), OutputError> {
    check_pixel_count(path, image)?;
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in attributes {
        let (Some(name_text), Some(value_text)) =
            (Text::new_or_none(name), Text::new_or_none(value))
        else {
            return Err(OutputError::writing(
                path,
                format!("EXR attribute `{name}` is not Latin-1 text"),
            ));
        };
        if let Some(field) = standard_text_attribute(&mut layer_attributes, name) {
            *field = Some(value_text);
        } else {
            layer_attributes
                .other
                .insert(name_text, AttributeValue::Text(value_text));
        }
    }
    let width = image.width as usize;
    let channels = SpecificChannels::rgb(|position: Vec2<usize>| {
        let [r, g, b] = image.pixels[position.y() * width + position.x()];
        (r, g, b)
    });
    let layer = Layer::new(
        (width, image.height as usize),
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let exr_image = exr::prelude::Image::from_layer(layer);
    write_atomically(path, |writer| {
        exr_image
            .write()
            .to_buffered(writer)
            .map_err(io::Error::other)
    })
}

/// As [`write_exr`], with `extra` channels beside R, G and B: each a name
/// (Latin-1, as EXR names are bytes) and one value per pixel, row by row (the
/// AOVs of `kinds::aov`, named `NAME.SUFFIX`). The file lists its channels
/// sorted by name, as EXR requires.
pub fn write_exr_with_channels(
    path: &Path,
    image: &Image,
    extra: &[(String, Vec<f32>)],
) -> Result<(), OutputError> {
    if extra.is_empty() {
        return write_exr(path, image, &[]);
    }
    check_pixel_count(path, image)?;
    let rgb = (0..3).map(|c| {
        let values = image.pixels.iter().map(|p| p[c]).collect();
        (["R", "G", "B"][c].to_string(), values)
    });
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (name, values) in rgb.chain(extra.iter().cloned()) {
        let Some(text) = Text::new_or_none(&name) else {
            return Err(OutputError::writing(
                path,
                format!("EXR channel `{name}` is not Latin-1 text"),
            ));
        };
        assert_eq!(values.len(), image.pixels.len(), "one value per pixel");
        channels.push(AnyChannel::new(text, FlatSamples::F32(values)));
    }
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let exr_image = exr::prelude::Image::from_layer(layer);
    write_atomically(path, |writer| {
        exr_image
            .write()
            .to_buffered(writer)
            .map_err(io::Error::other)
    })
}

/// The most texels pathmix reads from one image file (16384 x 16384, the
/// largest texture side of common adapters, squared): an image's size is read
/// from its header and checked against this before any texel is allocated, so
/// that a small file claiming a huge size is refused instead of exhausting
/// memory.
pub const MAX_IMAGE_TEXELS: u64 = 1 << 28;

/// An image file opened to be read: a regular file (`paths::open_input`) whose
/// header says a size within [`MAX_IMAGE_TEXELS`]. Every image pathmix reads
/// (environment maps, textures, `compare`'s and `converge`'s EXRs) is opened
/// by [`open_image`], its one checked way in.
pub struct ImageInput {
    file: File,
    exr: bool,
}

/// Why an image could not be read; the caller names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageReadError {
    /// The file could not be opened, or is no regular file.
    #[error("{0}")]
    Open(io::Error),
    /// The bytes are no image of the format, or one cut short.
    #[error("{0}")]
    Format(String),
    #[error(
        "its header says {width}x{height} ({texels} texels), more than the \
         {MAX_IMAGE_TEXELS} pathmix reads from an image"
    )]
    TooLarge {
        width: u64,
        height: u64,
        texels: u64,
    },
}

/// Opens an image (OpenEXR by the `.exr` extension; PNG, JPEG or Radiance HDR
/// by its content) and reads its size from the header alone, refusing one of
/// more than [`MAX_IMAGE_TEXELS`] texels (for an EXR, its layers' in all).
pub fn open_image(path: &Path) -> Result<ImageInput, ImageReadError> {
    let format = |e: &dyn fmt::Display| ImageReadError::Format(e.to_string());
    let (mut file, _) = crate::paths::open_input(path).map_err(ImageReadError::Open)?;
    let exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let (width, height, texels) = if exr {
        let meta = exr::meta::MetaData::read_from_buffered(io::BufReader::new(&file), false)
            .map_err(|e| format(&e))?;
        let sizes = meta.headers.iter().map(|h| h.layer_size);
        let largest = sizes.clone().max_by_key(|s| s.area()).unwrap_or_default();
        let texels = sizes.map(|s| s.area() as u64).sum();
        (largest.width() as u64, largest.height() as u64, texels)
    } else {
        let mut reader = image::ImageReader::new(io::BufReader::new(&file))
            .with_guessed_format()
            .map_err(|e| format(&e))?;
        // The header alone is read here; the decoder's own limits apply to the decoding.
        reader.no_limits();
        let (width, height) = reader.into_dimensions().map_err(|e| format(&e))?;
        let (width, height) = (u64::from(width), u64::from(height));
        (width, height, width * height)
    };
    if texels > MAX_IMAGE_TEXELS {
        return Err(ImageReadError::TooLarge {
            width,
            height,
            texels,
        });
    }
    io::Seek::rewind(&mut file).map_err(ImageReadError::Open)?;
    Ok(ImageInput { file, exr })
}

impl ImageInput {
    /// Decodes a PNG, JPEG or Radiance HDR image (an EXR is read by
    /// [`ImageInput::read_exr`]).
    pub fn decode(self) -> Result<image::DynamicImage, ImageReadError> {
        let format = |e: &dyn fmt::Display| ImageReadError::Format(e.to_string());
        if self.exr {
            return Err(format(&"an OpenEXR image is read as EXR"));
        }
        image::ImageReader::new(io::BufReader::new(self.file))
            .with_guessed_format()
            .map_err(|e| format(&e))?
            .decode()
            .map_err(|e| format(&e))
    }

    /// The R, G, B channels (f32, f16 or u32, converted to f32) of the first
    /// layer of an EXR, and the file's text attributes (custom and standard
    /// ones such as `software`), sorted by name.
    pub fn read_exr(self) -> Result<(Image, Vec<(String, String)>), ImageReadError> {
        let mut exr_image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .specific_channels()
            .required("R")
            .required("G")
            .required("B")
            .collect_pixels(
                // EXR sizes come from i32 bounds, so they fit in u32.
                |size: Vec2<usize>, _| Image::new(size.width() as u32, size.height() as u32),
                |image: &mut Image, position: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                    let index = position.y() * image.width as usize + position.x();
                    image.pixels[index] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(io::BufReader::new(&self.file))
            .map_err(|e| {
                ImageReadError::Format(match exr_file_is_truncated(&self.file) {
                    true => "the file is truncated (shorter than its EXR header says)".into(),
                    false => e.to_string(),
                })
            })?;

        let layer = &mut exr_image.layer_data;
        let mut attributes: Vec<(String, String)> = STANDARD_TEXT_ATTRIBUTES
            .iter()
            .filter_map(|&name| {
                let value = standard_text_attribute(&mut layer.attributes, name)?.take()?;
                Some((name.to_owned(), value.to_string()))
            })
            .collect();
        for (name, value) in exr_image
            .attributes
            .other
            .iter()
            .chain(&layer.attributes.other)
        {
            if let AttributeValue::Text(value) = value {
                attributes.push((name.to_string(), value.to_string()));
            }
        }
        attributes.sort();
        let image = std::mem::replace(&mut layer.channel_data.pixels, Image::new(0, 0));
        Ok((image, attributes))
    }
}

/// Reads `path` (`.exr`: the R, G, B channels of the first layer; `.hdr`:
/// Radiance RGBE) into linear RGB texels, row-major from the top row, each
/// finite and >= 0: an environment map, or a texture's linear image. The error
/// names the image file and the problem; `what` the image, where the extension
/// is neither.
pub fn read_linear_image(path: &Path, what: &str) -> Result<(u32, u32, Vec<[f32; 3]>), String> {
    let shown = path.display();
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let format_name = match extension.as_str() {
        "exr" => "OpenEXR",
        "hdr" => "Radiance HDR",
        _ => {
            return Err(format!(
                "{shown}: unknown {what} format {extension:?} (supported: .exr, .hdr)"
            ));
        }
    };
    let unreadable = |e: ImageReadError| match e {
        ImageReadError::Open(e) => format!("{shown}: cannot read the image file: {e}"),
        ImageReadError::Format(e) => format!("{shown}: cannot read the {format_name} image: {e}"),
        e => format!("{shown}: {e}"),
    };
    let input = open_image(path).map_err(unreadable)?;
    let (width, height, texels) = if extension == "exr" {
        let (image, _) = input.read_exr().map_err(unreadable)?;
        (image.width, image.height, image.pixels)
    } else {
        let image = input.decode().map_err(unreadable)?.into_rgb32f();
        let (width, height) = image.dimensions();
        (width, height, image.pixels().map(|p| p.0).collect())
    };
    if width == 0 || height == 0 {
        return Err(format!(
            "{shown}: the image has no texels ({width}x{height})"
        ));
    }
    if let Some((i, texel)) = texels
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        let (x, y) = (i as u32 % width, i as u32 / width);
        return Err(format!(
            "{shown}: texel ({x}, {y}) is [{}, {}, {}]: texel values must be finite and >= 0",
            texel[0], texel[1], texel[2]
        ));
    }
    Ok((width, height, texels))
}

/// Reads the R, G, B channels (f32, f16 or u32, converted to f32) of the first layer.
pub fn read_exr(path: &Path) -> Result<Image, OutputError> {
    read_exr_with_attributes(path).map(|(image, _)| image)
}

/// Like [`read_exr`], also returning the file's text attributes (custom and standard ones
/// such as `software`), sorted by name.
pub fn read_exr_with_attributes(
    path: &Path,
) -> Result<(Image, Vec<(String, String)>), OutputError> {
    open_image(path)
        .and_then(ImageInput::read_exr)
        .map_err(|e| OutputError::reading(path, e))
}

/// Whether an EXR file ends before its header or one of its chunks does (the
/// exr crate reports that as missing bytes, or as no layer matching).
fn exr_file_is_truncated(mut file: &File) -> bool {
    let missing = |e: &exr::error::Error| matches!(e, exr::error::Error::Invalid(message) if message.contains("missing bytes"));
    if io::Seek::rewind(&mut file).is_err() {
        return false;
    }
    let chunks = match exr::block::read(io::BufReader::new(file), false)
        .and_then(|reader| reader.all_chunks(false))
    {
        Ok(chunks) => chunks,
        Err(e) => return missing(&e),
    };
    for chunk in chunks {
        if let Err(e) = chunk {
            return missing(&e);
        }
    }
    false
}

/// Text attributes that the exr crate reads into dedicated `LayerAttributes` fields instead
/// of `other`; they must be written there too or the crate rejects them as reserved.
const STANDARD_TEXT_ATTRIBUTES: [&str; 9] = [
    "name",
    "software",
    "comments",
    "owner",
    "capDate",
    "view",
    "wrapmodes",
    "renderingTransform",
    "lookModTransform",
];

fn standard_text_attribute<'a>(
    attributes: &'a mut LayerAttributes,
    name: &str,
) -> Option<&'a mut Option<Text>> {
    Some(match name {
        "name" => &mut attributes.layer_name,
        "software" => &mut attributes.software_name,
        "comments" => &mut attributes.comments,
        "owner" => &mut attributes.owner,
        "capDate" => &mut attributes.capture_date,
        "view" => &mut attributes.view_name,
        "wrapmodes" => &mut attributes.wrap_mode_name,
        "renderingTransform" => &mut attributes.rendering_transform_name,
        "lookModTransform" => &mut attributes.look_modification_transform_name,
        _ => return None,
    })
}

/// Writes by extension: PNG at exposure 0, or EXR without attributes.
pub fn write_image(path: &Path, image: &Image) -> Result<(), OutputError> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => write_png(path, image, 0.0),
        ImageFormat::Exr => write_exr(path, image, &[]),
    }
}

/// How two images of the same size differ, value by value (every channel of every pixel).
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Values compared: pixels × 3.
    pub values: usize,
    /// Values whose relative difference exceeds the tolerance.
    pub beyond: usize,
    /// The largest relative difference, where any value differs.
    pub largest: Option<ValueDifference>,
}

/// One value's difference: `relative` is |a − b| / max(|a|, |b|); infinite where exactly
/// one of them is NaN or the two are infinities of opposite sign.
#[derive(Clone, Debug, PartialEq)]
pub struct ValueDifference {
    pub relative: f64,
    pub x: u32,
    pub y: u32,
    pub channel: usize,
    pub a: f32,
    pub b: f32,
}

/// Compares `a` with `b` value by value: a value is within `tolerance` when
/// |a − b| ≤ tolerance · max(|a|, |b|) (equal values, zeros and NaN against NaN included).
/// `None` when the sizes differ.
pub fn compare(a: &Image, b: &Image, tolerance: f64) -> Option<Comparison> {
    if (a.width, a.height) != (b.width, b.height) {
        return None;
    }
    let mut comparison = Comparison {
        values: a.pixels.len() * 3,
        beyond: 0,
        largest: None,
    };
    for (i, (pa, pb)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for channel in 0..3 {
            let (va, vb) = (pa[channel], pb[channel]);
            let relative = if va == vb || (va.is_nan() && vb.is_nan()) {
                0.0
            } else {
                let (x, y) = (va as f64, vb as f64);
                let relative = (x - y).abs() / x.abs().max(y.abs());
                if relative.is_nan() {
                    f64::INFINITY
                } else {
                    relative
                }
            };
            if relative > tolerance {
                comparison.beyond += 1;
            }
            if relative > 0.0
                && comparison
                    .largest
                    .as_ref()
                    .is_none_or(|largest| relative > largest.relative)
            {
                comparison.largest = Some(ValueDifference {
                    relative,
                    x: (i % a.width as usize) as u32,
                    y: (i / a.width as usize) as u32,
                    channel,
                    a: va,
                    b: vb,
                });
            }
        }
    }
    Some(comparison)
}

/// Atomic write: writes to a temporary file `.NAME.tmp-PID-RANDOM` (unique, made by
/// `tempfile`) in the same folder, fsyncs it and renames it over `path`. On any error the
/// temporary is removed and `path` is untouched (a previous file stays intact; no partial
/// file appears).
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), OutputError> {
    let name = file_name(path)?;
    let folder = parent_folder(path)?;
    // Same folder, so the rename cannot cross file systems.
    let (file, temporary) = {
        let mut live = live_temporaries();
        let prefix = temporary_prefix(name, "tmp");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix);
        // What `File::create` gives (0666 less the umask), not a temporary's owner-only
        // mode: the result is an ordinary file.
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        let (file, temporary) = builder
            .tempfile_in(folder)
            .map_err(|e| OutputError::writing(path, e))?
            .into_parts();
        live.push(temporary.to_path_buf());
        (file, temporary)
    };
    let temporary_path = temporary.to_path_buf();
    let written = write_and_rename(file, temporary, path, write);
    unregister_temporary(&temporary_path);
    // On error the temporary is gone already (dropped); the write error is the one to report.
    written.map_err(|e| OutputError::writing(path, e))?;
    // Makes the rename itself durable; best effort, as not every platform can open folders.
    if let Ok(folder) = File::open(folder) {
        let _ = folder.sync_all();
    }
    Ok(())
}

fn write_and_rename(
    file: File,
    temporary: tempfile::TempPath,
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let mut writer = BufWriter::new(file);
    write(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(io::IntoInnerError::into_error)?;
    // Without fsync a crash after the rename could leave an empty file under the final name.
    file.sync_all()?;
    drop(file);
    // Under the registry's lock, so that a second signal's cleanup sees it either
    // renamed or still a temporary.
    let _live = live_temporaries();
    temporary.persist(path).map_err(|e| e.error)
}

fn file_name(path: &Path) -> Result<&std::ffi::OsStr, OutputError> {
    path.file_name()
        .ok_or_else(|| OutputError::writing(path, "the path does not name a file"))
}

/// The folder that `path` goes into (`.` for a bare file name), which must exist.
fn parent_folder(path: &Path) -> Result<&Path, OutputError> {
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    if !folder.exists() {
        return Err(OutputError::writing(
            path,
            format!("folder `{}` does not exist", folder.display()),
        ));
    }
    if !folder.is_dir() {
        return Err(OutputError::writing(
            path,
            format!("`{}` is not a folder", folder.display()),
        ));
    }
    Ok(folder)
}

fn check_pixel_count(path: &Path, image: &Image) -> Result<(), OutputError> {
    let expected = image.width as usize * image.height as usize;
    if image.pixels.len() != expected {
        return Err(OutputError::writing(
            path,
            format!(
                "a {}x{} image needs {expected} pixels but has {}",
                image.width,
                image.height,
                image.pixels.len()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A fresh folder under the system temp folder, removed on drop.
    struct TestDir(tempfile::TempDir);

    impl TestDir {
        fn new(name: &str) -> TestDir {
            let dir = tempfile::Builder::new()
                .prefix(&format!("pathmix-output-{name}-"))
                .tempdir()
                .unwrap();
            TestDir(dir)
        }

        fn join(&self, name: impl AsRef<Path>) -> PathBuf {
            self.0.path().join(name)
        }

        fn entries(&self) -> Vec<String> {
            let mut names: Vec<String> = fs::read_dir(self.0.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        }
    }

    fn gray(value: f32) -> Image {
        Image {
            width: 1,
            height: 1,
            pixels: vec![[value; 3]],
        }
    }

    fn srgb_of(value: f32, exposure: f32) -> u8 {
        to_srgb8(&gray(value), exposure)[0]
    }

    /// A 3x2 image with values a tone mapper or codec could mangle.
    fn test_image() -> Image {
        Image {
            width: 3,
            height: 2,
            pixels: vec![
                [0.0, 0.25, 1.0],
                [0.5, 2.0, 1e-3],
                [1e30, 1e-40, -0.0],
                [0.1, 0.2, 0.3],
                [f32::MAX, f32::MIN_POSITIVE, 7.0],
                [0.999, 0.001, 0.0031308],
            ],
        }
    }

    #[test]
    fn compare_measures_the_largest_relative_difference() {
        let image = |pixels: Vec<[f32; 3]>| Image {
            width: 2,
            height: 1,
            pixels,
        };
        let a = image(vec![[0.0, 1.0, f32::NAN], [2.0, 4.0, 1.0]]);
        let same = compare(&a, &a.clone(), 0.0).unwrap();
        assert_eq!((same.values, same.beyond, same.largest), (6, 0, None));

        let b = image(vec![
            [0.0, 1.0 + 1e-7, f32::NAN],
            [2.0, 4.0 * (1.0 + 1e-5), 1.0],
        ]);
        let close = compare(&a, &b, 1e-6).unwrap();
        assert_eq!(close.beyond, 1);
        let largest = close.largest.unwrap();
        assert_eq!((largest.x, largest.y, largest.channel), (1, 0, 1));
        assert!(
            (largest.relative - 1e-5).abs() < 1e-7,
            "{}",
            largest.relative
        );
        assert_eq!(compare(&a, &b, 1e-4).unwrap().beyond, 0);

        // NaN against a number, and a value against zero, are as far apart as can be.
        let c = image(vec![[1e-30, 1.0, 0.5], [2.0, 4.0, 1.0]]);
        let far = compare(&a, &c, 1e-6).unwrap();
        assert_eq!(far.beyond, 2);
        assert_eq!(far.largest.unwrap().relative, f64::INFINITY);
        assert!(compare(&a, &Image::new(1, 2), 1.0).is_none());
    }
    #[test]
    fn image_get_is_row_major() {
        let image = test_image();
        assert_eq!(image.get(0, 0), [0.0, 0.25, 1.0]);
        assert_eq!(image.get(2, 0), [1e30, 1e-40, -0.0]);
        assert_eq!(image.get(0, 1), [0.1, 0.2, 0.3]);
        assert_eq!(Image::new(4, 3).pixels, vec![[0.0; 3]; 12]);
    }

    #[test]
    #[should_panic(expected = "outside 3x2 image")]
    fn image_get_rejects_x_past_row_end() {
        test_image().get(3, 0);
    }

    #[test]
    fn srgb_end_points_and_midpoint() {
        assert_eq!(srgb_of(0.0, 0.0), 0);
        assert_eq!(srgb_of(1.0, 0.0), 255);
        // 1.055 * 0.5^(1/2.4) - 0.055 = 0.73536 → 187.52; a plain gamma 2.2 would give 186.
        assert_eq!(srgb_of(0.5, 0.0), 188);
    }

    #[test]
    fn srgb_linear_segment_below_boundary() {
        // 12.92 * 0.0031308 * 255 = 10.31, and both pieces meet there.
        assert_eq!(srgb_of(0.003_130_8, 0.0), 10);
        assert_eq!(srgb_of(0.003_13, 0.0), 10);
        assert_eq!(srgb_of(0.003_132, 0.0), 10);
        // Linear piece: 12.92 * 0.001 * 255 = 3.29; the power piece would give 1.
        assert_eq!(srgb_of(0.001, 0.0), 3);
    }

    #[test]
    fn srgb_clamps_and_maps_nan_to_black() {
        assert_eq!(srgb_of(f32::NAN, 0.0), 0);
        assert_eq!(srgb_of(f32::NAN, 3.0), 0);
        assert_eq!(srgb_of(-1.0, 0.0), 0);
        assert_eq!(srgb_of(1.5, 0.0), 255);
        assert_eq!(srgb_of(f32::INFINITY, 0.0), 255);
    }

    #[test]
    fn srgb_exposure_scales_by_powers_of_two() {
        assert_eq!(srgb_of(0.25, 1.0), srgb_of(0.5, 0.0));
        assert_eq!(srgb_of(1.0, -1.0), srgb_of(0.5, 0.0));
        assert_eq!(srgb_of(0.125, 2.0), srgb_of(0.5, 0.0));
        assert_ne!(srgb_of(0.25, 0.0), srgb_of(0.5, 0.0));
    }

    #[test]
    fn srgb_bytes_are_rgb_in_pixel_order() {
        let image = Image {
            width: 2,
            height: 1,
            pixels: vec![[0.0, 1.0, 0.5], [1.0, 0.0, 0.0]],
        };
        assert_eq!(to_srgb8(&image, 0.0), vec![0, 255, 188, 255, 0, 0]);
    }

    #[test]
    fn format_from_extension_ignores_case() {
        assert_eq!(
            ImageFormat::from_path(Path::new("a/b.png")).unwrap(),
            ImageFormat::Png
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("b.PNG")).unwrap(),
            ImageFormat::Png
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("b.Exr")).unwrap(),
            ImageFormat::Exr
        );
    }

    #[test]
    fn format_rejects_unknown_or_missing_extension() {
        let error = ImageFormat::from_path(Path::new("out/render.jpg")).unwrap_err();
        assert_eq!(
            error.to_string(),
            "cannot write `out/render.jpg`: unknown image extension `.jpg` (pathmix writes .png and .exr)"
        );
        assert_eq!(error.path, Path::new("out/render.jpg"));
        let error = ImageFormat::from_path(Path::new("render")).unwrap_err();
        assert_eq!(
            error.to_string(),
            "cannot write `render`: no image extension (pathmix writes .png and .exr)"
        );
    }

    #[test]
    fn png_round_trip_matches_tone_mapping() {
        let dir = TestDir::new("png");
        let path = dir.join("out.png");
        let image = test_image();
        write_png(&path, &image, 0.5).unwrap();
        let read = image::open(&path).unwrap().to_rgb8();
        assert_eq!(read.dimensions(), (3, 2));
        assert_eq!(read.into_raw(), to_srgb8(&image, 0.5));
        assert_eq!(dir.entries(), ["out.png"]);
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = TestDir::new("exr");
        let path = dir.join("out.exr");
        let mut image = test_image();
        image.pixels[3] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        write_exr(&path, &image, &[]).unwrap();
        let read = read_exr(&path).unwrap();
        assert_eq!((read.width, read.height), (3, 2));
        let bits = |image: &Image| {
            image
                .pixels
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&read), bits(&image));
        assert_eq!(dir.entries(), ["out.exr"]);
    }

    #[test]
    fn exr_attributes_round_trip() {
        let dir = TestDir::new("exr-attributes");
        let path = dir.join("out.exr");
        let attributes = [
            ("pathmix.samples", "1024".to_owned()),
            ("pathmix.scene", "scenes/cornell box.toml".to_owned()),
            ("software", "pathmix 0.1.0".to_owned()),
            ("comments", "Latin-1 is fine: café".to_owned()),
        ];
        write_exr(&path, &test_image(), &attributes).unwrap();
        let (image, read) = read_exr_with_attributes(&path).unwrap();
        assert_eq!(image, test_image());
        let mut expected: Vec<(String, String)> = attributes
            .iter()
            .map(|(n, v)| (n.to_string(), v.clone()))
            .collect();
        expected.sort();
        assert_eq!(read, expected);
    }

    #[test]
    fn exr_rejects_non_latin1_attribute_without_writing() {
        let dir = TestDir::new("exr-bad-attribute");
        let path = dir.join("out.exr");
        let error = write_exr(&path, &test_image(), &[("note", "雪".to_owned())]).unwrap_err();
        assert!(error.to_string().contains("out.exr"), "{error}");
        assert!(
            error.to_string().contains("`note` is not Latin-1"),
            "{error}"
        );
        assert!(dir.entries().is_empty());
    }

    #[test]
    fn exr_rejects_reserved_attribute_without_writing() {
        let dir = TestDir::new("exr-reserved-attribute");
        let path = dir.join("out.exr");
        let error =
            write_exr(&path, &test_image(), &[("compression", "none".to_owned())]).unwrap_err();
        assert!(
            error.message.contains("`compression` is reserved"),
            "{error}"
        );
        assert!(dir.entries().is_empty());
    }

    #[test]
    fn read_exr_errors_name_the_path() {
        let dir = TestDir::new("exr-read-errors");
        let missing = dir.join("missing.exr");
        let error = read_exr(&missing).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with(&format!("cannot read `{}`: ", missing.display())),
            "{error}"
        );

        let png = dir.join("not-exr.exr");
        write_atomically(&png, |w| w.write_all(b"\x89PNG\r\n\x1a\n")).unwrap();
        let error = read_exr(&png).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with(&format!("cannot read `{}`: ", png.display())),
            "{error}"
        );
    }

    #[test]
    fn write_image_picks_format_by_extension() {
        let dir = TestDir::new("write-image");
        let image = test_image();
        write_image(&dir.join("a.PNG"), &image).unwrap();
        write_image(&dir.join("b.exr"), &image).unwrap();
        assert_eq!(
            image::open(dir.join("a.PNG")).unwrap().to_rgb8().into_raw(),
            to_srgb8(&image, 0.0)
        );
        assert_eq!(read_exr(&dir.join("b.exr")).unwrap(), image);
        assert!(
            write_image(&dir.join("c.jpg"), &image)
                .unwrap_err()
                .message
                .contains("unknown image extension")
        );
        assert_eq!(dir.entries(), ["a.PNG", "b.exr"]);
    }

    #[test]
    fn writers_reject_inconsistent_pixel_count() {
        let dir = TestDir::new("pixel-count");
        let image = Image {
            width: 2,
            height: 2,
            pixels: vec![[0.0; 3]; 3],
        };
        let error = write_image(&dir.join("a.png"), &image).unwrap_err();
        assert!(
            error
                .message
                .ends_with("a 2x2 image needs 4 pixels but has 3"),
            "{error}"
        );
        assert!(write_image(&dir.join("a.exr"), &image).is_err());
        assert!(dir.entries().is_empty());
    }

    #[test]
    fn atomic_write_replaces_file_and_leaves_no_temporary() {
        let dir = TestDir::new("atomic-ok");
        let path = dir.join("out.txt");
        fs::write(&path, "old").unwrap();
        write_atomically(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(dir.entries(), ["out.txt"]);
    }

    #[test]
    fn failed_atomic_write_keeps_previous_file() {
        let dir = TestDir::new("atomic-fail");
        let path = dir.join("out.png");
        fs::write(&path, "old").unwrap();
        let error = write_atomically(&path, |w| {
            // Enough to spill past BufWriter's buffer into the temporary file.
            w.write_all(&[7; 100_000])?;
            let prefix = format!(".out.png.tmp-{}-", std::process::id());
            assert!(dir.entries().iter().any(|e| e.starts_with(&prefix)));
            Err(io::Error::other("encoder exploded"))
        })
        .unwrap_err();
        assert_eq!(
            error.to_string(),
            format!("cannot write `{}`: encoder exploded", path.display())
        );
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(dir.entries(), ["out.png"]);
    }

    #[test]
    fn failed_atomic_write_creates_no_file() {
        let dir = TestDir::new("atomic-fail-new");
        let path = dir.join("out.png");
        assert!(write_atomically(&path, |_| Err(io::Error::other("no"))).is_err());
        assert!(dir.entries().is_empty());
    }

    #[test]
    fn atomic_write_into_missing_folder_names_the_path() {
        let dir = TestDir::new("atomic-missing");
        let path = dir.join("nowhere/out.png");
        let error = write_atomically(&path, |w| w.write_all(b"x")).unwrap_err();
        assert_eq!(error.path, path);
        assert_eq!(
            error.to_string(),
            format!(
                "cannot write `{}`: folder `{}` does not exist",
                path.display(),
                dir.join("nowhere").display()
            )
        );
    }

    #[test]
    fn check_output_path_accepts_writable_paths() {
        let dir = TestDir::new("check-ok");
        check_output_path(&dir.join("a.png"), ImageFormat::Png).unwrap();
        check_output_path(&dir.join("a.EXR"), ImageFormat::Exr).unwrap();
        fs::write(dir.join("old.png"), "previous render").unwrap();
        check_output_path(&dir.join("old.png"), ImageFormat::Png).unwrap();
        // The probe file is gone and nothing was created or changed.
        assert_eq!(dir.entries(), ["old.png"]);
        assert_eq!(
            fs::read_to_string(dir.join("old.png")).unwrap(),
            "previous render"
        );
    }

    #[test]
    fn check_output_path_rejects_bad_paths() {
        let dir = TestDir::new("check-bad");
        let jpg = dir.join("a.jpg");
        assert_eq!(
            check_output_path(&jpg, ImageFormat::Png)
                .unwrap_err()
                .to_string(),
            format!(
                "cannot write `{}`: unknown image extension `.jpg` (pathmix writes .png and .exr)",
                jpg.display()
            )
        );

        let png = dir.join("a.png");
        assert_eq!(
            check_output_path(&png, ImageFormat::Exr)
                .unwrap_err()
                .to_string(),
            format!(
                "cannot write `{}`: the extension makes it a PNG file, but EXR output was requested",
                png.display()
            )
        );

        let missing = dir.join("missing/a.png");
        assert_eq!(
            check_output_path(&missing, ImageFormat::Png)
                .unwrap_err()
                .to_string(),
            format!(
                "cannot write `{}`: folder `{}` does not exist",
                missing.display(),
                dir.join("missing").display()
            )
        );

        fs::write(dir.join("file"), "").unwrap();
        let under_file = dir.join("file/a.png");
        let error = check_output_path(&under_file, ImageFormat::Png).unwrap_err();
        assert!(error.message.ends_with("is not a folder"), "{error}");

        fs::create_dir(dir.join("folder.png")).unwrap();
        let error = check_output_path(&dir.join("folder.png"), ImageFormat::Png).unwrap_err();
        assert!(error.message.ends_with("it is a folder"), "{error}");
    }

    #[test]
    fn read_only_files_are_refused_before_anything_is_written() {
        let dir = TestDir::new("read-only");
        let path = dir.join("kept.png");
        fs::write(&path, "precious").unwrap();
        let mut permissions = fs::metadata(&path).unwrap().permissions();
        permissions.set_readonly(true);
        fs::set_permissions(&path, permissions).unwrap();
        let error = check_output_path(&path, ImageFormat::Png).unwrap_err();
        assert!(error.to_string().contains("read-only"), "{error}");
        assert_eq!(fs::read_to_string(&path).unwrap(), "precious");
        assert_eq!(dir.entries(), ["kept.png"]);
    }

    #[test]
    fn temporaries_of_dead_processes_are_removed_and_live_ones_kept() {
        let dir = TestDir::new("stale");
        // A pid above Linux's largest (2^22) never runs; this process does.
        let dead = dir.join(".out.exr.tmp-4999999-abc123");
        let dead_old_form = dir.join(".out.exr.tmp-4999998");
        let alive = dir
            .0
            .path()
            .join(format!(".out.exr.tmp-{}-xyz", std::process::id()));
        let other = dir.join(".other.exr.tmp-4999999-abc");
        for path in [&dead, &dead_old_form, &alive, &other] {
            fs::write(path, "x").unwrap();
        }
        check_output_path(&dir.join("out.exr"), ImageFormat::Exr).unwrap();
        let mut expected = vec![
            format!(".out.exr.tmp-{}-xyz", std::process::id()),
            ".other.exr.tmp-4999999-abc".to_string(),
        ];
        expected.sort();
        assert_eq!(dir.entries(), expected);
    }

    #[test]
    fn temporaries_have_unique_names() {
        let dir = TestDir::new("unique");
        let path = dir.join("out.txt");
        // Two writes of one path in flight at once, as two renders would make.
        write_atomically(&path, |outer| {
            outer.write_all(b"first")?;
            outer.flush()?;
            write_atomically(&path, |inner| inner.write_all(b"second")).map_err(io::Error::other)
        })
        .unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "first");
        assert_eq!(dir.entries(), ["out.txt"]);
    }
}
