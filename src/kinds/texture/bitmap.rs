//! Images, Mitsuba 3's `bitmap` texture: row 0 of the image at v = 0 (its
//! top), texel `(x, y)` of a `W` x `H` image centred on `((x + 1/2) / W, (y +
//! 1/2) / H)`.
//!
//! ```toml
//! diffuse_reflectance = { type = "bitmap", file = "wood.png", wrap_mode = "mirror" }
//! ```
//!
//! - `file` (required, relative to the scene file): `.png`, `.jpg` / `.jpeg`
//!   (8- or 16-bit, sRGB-decoded to linear unless `raw = true`), or `.exr` /
//!   `.hdr` (linear; texels finite and >= 0, values above 1 taken as they are,
//!   as Mitsuba takes them, up to 1e6: `MAX_TEXEL_VALUE`). At most
//!   `MAX_TEXTURE_WORDS` / 3 texels, or as many as `MAX_TEXTURE_WORDS` of an
//!   8-bit image.
//! - `filter_type`: `"bilinear"` (the default: between the four nearest texel
//!   centres) or `"nearest"`.
//! - `wrap_mode`: `"repeat"` (the default), `"mirror"` or `"clamp"`: how the
//!   integer texel coordinates are folded into the image.
//! - `raw` (bool, default false): the file's values as they are.
//! - `to_uv` as every texture.
//!
//! Bitmaps of one file read the same way share their texels in the kernel's
//! texel array. An 8-bit image's texels stay its codes there, a word each, which
//! the kernel decodes by the host's own table (`texel_byte_values`): a third of
//! the memory of three floats, the same values. Its mean is the texels'
//! average. Where a material's number is a bitmap, it reads the texels'
//! luminance, as Mitsuba's `eval_1`. Mitsuba's `bitmap` becomes one; it is the
//! texture bump and normal maps take (`kinds::Bump`).

use super::{
    TextureInfo, TextureKind, TextureModel, TextureTables, TextureValue, serialize_texels,
};
use crate::abi::LUMINANCE;
use crate::kinds::params::{ParamTable, Result, named};
use crate::output::{self, ImageReadError};
use glam::{Vec2, Vec3};
use serde::Serialize;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

pub(super) const BITMAP: TextureModel = TextureModel {
    name: "bitmap",
    keys: &["file", "wrap_mode", "filter_type", "raw"],
    parse,
};

/// Textures in device memory: one storage binding holds every texel (three
/// floats each, or one word of an 8-bit image's codes), and wgpu's default
/// limit on a binding, lavapipe's too, is 128 MiB.
const MAX_TEXTURE_WORDS: u64 = (128 << 20) / 4;

/// How the kernel reads a bitmap's texels (`TextureInfo::texel_format`, its
/// discriminant; `texture_constants`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelFormat {
    /// Three floats, linear.
    Float = 0,
    /// One word of 8-bit codes (red in the lowest byte), sRGB-decoded.
    Srgb8 = 1,
    /// The same, each code / 255.
    Raw8 = 2,
}

impl TexelFormat {
    pub const ALL: [TexelFormat; 3] = [TexelFormat::Float, TexelFormat::Srgb8, TexelFormat::Raw8];

    /// Its WGSL constant's name.
    pub fn constant(self) -> &'static str {
        match self {
            TexelFormat::Float => "TEXELS_FLOAT",
            TexelFormat::Srgb8 => "TEXELS_SRGB8",
            TexelFormat::Raw8 => "TEXELS_RAW8",
        }
    }
}

/// What each 8-bit code stands for: sRGB-decoded at `code`, raw at `256 +
/// code`. The host decodes 8-bit images by it, and the kernel the codes it
/// reads (`TEXEL_BYTE_VALUES`), so both see the same texels.
pub fn texel_byte_values() -> [f32; 512] {
    std::array::from_fn(|i| match i < 256 {
        true => srgb_to_linear(i as u8),
        false => (i - 256) as f32 / 255.0,
    })
}

/// Its discriminant is `TextureInfo::wrap` (`texture_constants`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}

impl WrapMode {
    pub const ALL: [WrapMode; 3] = [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp];

    pub fn name(self) -> &'static str {
        match self {
            WrapMode::Repeat => "repeat",
            WrapMode::Mirror => "mirror",
            WrapMode::Clamp => "clamp",
        }
    }

    pub fn from_name(name: &str) -> Option<WrapMode> {
        WrapMode::ALL.into_iter().find(|w| w.name() == name)
    }

    /// Texel index `i` of a row or column `n` long, wrapped into [0, n).
    pub fn wrap(self, i: i64, n: i64) -> i64 {
        match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let p = i.rem_euclid(2 * n);
                if p >= n { 2 * n - 1 - p } else { p }
            }
        }
    }
}

/// Mitsuba's `filter_type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum TextureFilter {
    Bilinear,
    Nearest,
}

impl TextureFilter {
    pub const ALL: [TextureFilter; 2] = [TextureFilter::Bilinear, TextureFilter::Nearest];

    pub fn name(self) -> &'static str {
        match self {
            TextureFilter::Bilinear => "bilinear",
            TextureFilter::Nearest => "nearest",
        }
    }

    pub fn from_name(name: &str) -> Option<TextureFilter> {
        TextureFilter::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// A decoded image: linear RGB, row-major from the top row; finite, >= 0.
#[derive(Clone, PartialEq, Serialize)]
pub struct Bitmap {
    /// The image file as the scene names it (relative to the scene file).
    pub file: String,
    pub width: u32,
    pub height: u32,
    #[serde(serialize_with = "serialize_texels")]
    pub texels: Arc<Vec<[f32; 3]>>,
    /// An 8-bit image's codes, a word a texel (red in the lowest byte): what
    /// the kernel reads, `texels` decoded.
    #[serde(skip)]
    pub codes: Option<Arc<Vec<u32>>>,
    /// The file's values as they are, without the sRGB decoding.
    pub raw: bool,
    pub wrap: WrapMode,
    pub filter: TextureFilter,
}

impl fmt::Debug for Bitmap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Bitmap")
            .field("file", &self.file)
            .field("size", &(self.width, self.height))
            .field("raw", &self.raw)
            .field("wrap", &self.wrap)
            .field("filter", &self.filter)
            .finish()
    }
}

fn parse(s: &ParamTable) -> Result<TextureKind> {
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
    let (width, height, texels, codes) =
        load_image(&path, raw).map_err(|m| s.err(s.at("file"), m))?;
    let (words_a_texel, images) = match codes {
        Some(_) => (1, "8-bit images"),
        None => (3, "16-bit and float images"),
    };
    if width as u64 * height as u64 * words_a_texel > MAX_TEXTURE_WORDS {
        return Err(s.err(
            s.at("file"),
            format!(
                "{}: {width}x{height} texels do not fit the 128 MiB storage binding \
                 that holds a scene's textures (at most {} texels of {images}): scale \
                 the image down",
                path.display(),
                MAX_TEXTURE_WORDS / words_a_texel,
            ),
        ));
    }
    Ok(TextureKind::Bitmap(Bitmap {
        file: file.to_string(),
        width,
        height,
        texels: Arc::new(texels),
        codes: codes.map(Arc::new),
        raw,
        wrap,
        filter,
    }))
}

impl TextureValue for Bitmap {
    fn mean(&self) -> Vec3 {
        let sum = self.texels.iter().fold([0.0f64; 3], |s, t| {
            [s[0] + t[0] as f64, s[1] + t[1] as f64, s[2] + t[2] as f64]
        });
        let n = self.texels.len() as f64;
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }

    fn eval(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let texel = |x: i64, y: i64| {
            let (x, y) = (self.wrap.wrap(x, w), self.wrap.wrap(y, h));
            Vec3::from(self.texels[(y * w + x) as usize])
        };
        let p = uv * Vec2::new(self.width as f32, self.height as f32);
        match self.filter {
            TextureFilter::Nearest => {
                let p = p.floor();
                texel(p.x as i64, p.y as i64)
            }
            TextureFilter::Bilinear => {
                let p = p - 0.5;
                let p0 = p.floor();
                let f = p - p0;
                let (x, y) = (p0.x as i64, p0.y as i64);
                (1.0 - f.y) * ((1.0 - f.x) * texel(x, y) + f.x * texel(x + 1, y))
                    + f.y * ((1.0 - f.x) * texel(x, y + 1) + f.x * texel(x + 1, y + 1))
            }
        }
    }

    /// Mitsuba's `eval_1` reads an RGB image as its luminance.
    fn eval_number(&self, uv: Vec2) -> f32 {
        self.eval(uv).dot(Vec3::from_array(LUMINANCE))
    }

    fn mean_number(&self) -> f32 {
        self.mean().dot(Vec3::from_array(LUMINANCE))
    }

    fn pack(&self, info: &mut TextureInfo, tables: &mut TextureTables) {
        let key = (self.file.clone(), self.raw);
        let offset = match tables.bitmaps.iter().find(|(k, _)| *k == key) {
            Some(&(_, offset)) => offset,
            None => {
                let offset = tables.texels.len() as u32;
                match &self.codes {
                    Some(codes) => tables.texels.extend(codes.iter()),
                    None => tables
                        .texels
                        .extend(self.texels.iter().flatten().map(|c| c.to_bits())),
                }
                tables.bitmaps.push((key, offset));
                offset
            }
        };
        let format = match (&self.codes, self.raw) {
            (None, _) => TexelFormat::Float,
            (Some(_), false) => TexelFormat::Srgb8,
            (Some(_), true) => TexelFormat::Raw8,
        };
        info.texel_format = format as u32;
        tables.texel_formats |= 1 << format as u32;
        info.wrap = self.wrap as u32;
        info.width = self.width;
        info.height = self.height;
        info.offset = offset;
        info.nearest = (self.filter == TextureFilter::Nearest) as u32;
    }
}

/// The largest texel value of a texture, which scales the light a surface
/// sends on: a reflectance, which Mitsuba lets exceed 1 (a surface that adds
/// energy), but no real texture comes near 1e6, and the product of a path's
/// few such factors then stays far inside f32 instead of overflowing to
/// infinity and NaN.
const MAX_TEXEL_VALUE: f32 = 1e6;

/// The sRGB transfer function's inverse (IEC 61966-2-1): an 8-bit code's
/// linear value.
fn srgb_to_linear(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    let linear = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    linear as f32
}

/// A decoded image: its size, linear texels and, of an 8-bit image, its codes
/// (`Bitmap::codes`).
type Image = (u32, u32, Vec<[f32; 3]>, Option<Vec<u32>>);

/// Reads a texture image: `.exr` and `.hdr` through `output::read_linear_image`
/// (linear), `.png`, `.jpg`/`.jpeg` as 8- or 16-bit RGB, sRGB-decoded unless
/// `raw` (16-bit PNGs too, as Mitsuba treats them); no texel above
/// [`MAX_TEXEL_VALUE`]. The error names the file.
fn load_image(path: &Path, raw: bool) -> std::result::Result<Image, String> {
    let shown = path.display();
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match extension.as_str() {
        "exr" | "hdr" => {
            let (width, height, texels) = output::read_linear_image(path, "texture image")?;
            let values = texels.iter().flatten();
            if let Some((i, value)) = values.enumerate().find(|&(_, &c)| c > MAX_TEXEL_VALUE) {
                let texel = (i / 3) as u32;
                let (x, y) = (texel % width, texel / width);
                return Err(format!(
                    "{shown}: texel ({x}, {y}) holds {value:e}: a texture's values must be at \
                     most {MAX_TEXEL_VALUE:e} (they scale the light a surface reflects)"
                ));
            }
            Ok((width, height, texels, None))
        }
        "png" | "jpg" | "jpeg" => {
            let image = output::open_image(path)
                .and_then(output::ImageInput::decode)
                .map_err(|e| match e {
                    ImageReadError::Open(e) => format!("{shown}: cannot read the image file: {e}"),
                    ImageReadError::Format(e) => format!("{shown}: cannot decode the image: {e}"),
                    e => format!("{shown}: {e}"),
                })?;
            let (width, height) = (image.width(), image.height());
            if width == 0 || height == 0 {
                return Err(format!(
                    "{shown}: the image has no texels ({width}x{height})"
                ));
            }
            Ok(match image {
                image::DynamicImage::ImageLuma16(_)
                | image::DynamicImage::ImageLumaA16(_)
                | image::DynamicImage::ImageRgb16(_)
                | image::DynamicImage::ImageRgba16(_) => {
                    let decode = |c: u16| {
                        let v = c as f32 / 65535.0;
                        if raw {
                            v
                        } else if v <= 0.04045 {
                            v / 12.92
                        } else {
                            ((v + 0.055) / 1.055).powf(2.4)
                        }
                    };
                    let texels = image
                        .into_rgb16()
                        .pixels()
                        .map(|p| p.0.map(decode))
                        .collect();
                    (width, height, texels, None)
                }
                _ => {
                    let values = texel_byte_values();
                    let table = &values[if raw { 256 } else { 0 }..][..256];
                    let image = image.into_rgb8();
                    let texels = image
                        .pixels()
                        .map(|p| p.0.map(|c| table[c as usize]))
                        .collect();
                    let codes = image
                        .pixels()
                        .map(|p| u32::from_le_bytes([p[0], p[1], p[2], 0]));
                    (width, height, texels, Some(codes.collect()))
                }
            })
        }
        _ => Err(format!(
            "{shown}: unknown texture image format {extension:?} (supported: .png, .jpg, .jpeg, .exr, .hdr)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Texture, UvTransform};
    use std::sync::Arc;

    #[test]
    fn wrap_modes_fold_indices_as_mitsuba() {
        let wrapped = |mode: WrapMode| -> Vec<i64> { (-4..6).map(|i| mode.wrap(i, 3)).collect() };
        assert_eq!(wrapped(WrapMode::Repeat), [2, 0, 1, 2, 0, 1, 2, 0, 1, 2]);
        assert_eq!(wrapped(WrapMode::Clamp), [0, 0, 0, 0, 0, 1, 2, 2, 2, 2]);
        assert_eq!(wrapped(WrapMode::Mirror), [2, 2, 1, 0, 0, 1, 2, 2, 1, 0]);
    }

    fn two_by_two(wrap: WrapMode) -> Texture {
        // Row 0 (top): red, green; row 1: blue, white.
        let texels = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0; 3]];
        Texture {
            kind: TextureKind::Bitmap(Bitmap {
                file: "probe.exr".into(),
                width: 2,
                height: 2,
                texels: Arc::new(texels),
                codes: None,
                raw: false,
                wrap,
                filter: TextureFilter::Bilinear,
            }),
            to_uv: UvTransform::IDENTITY,
        }
    }

    /// Values Mitsuba 3.9 gives for the same image (`bitmap`, scalar_rgb).
    #[test]
    fn bitmap_lookups_match_mitsuba() {
        let close = |a: Vec3, b: [f32; 3]| (a - Vec3::from(b)).abs().max_element() < 1e-6;
        let repeat = two_by_two(WrapMode::Repeat);
        assert!(close(repeat.eval(Vec2::new(0.25, 0.25)), [1.0, 0.0, 0.0]));
        assert!(close(repeat.eval(Vec2::new(0.5, 0.5)), [0.5, 0.5, 0.5]));
        assert!(close(repeat.eval(Vec2::new(0.0, 0.0)), [0.5, 0.5, 0.5]));
        assert!(close(repeat.eval(Vec2::new(0.1, 0.3)), [0.66, 0.3, 0.1]));
        let clamp = two_by_two(WrapMode::Clamp);
        assert!(close(clamp.eval(Vec2::new(0.0, 0.0)), [1.0, 0.0, 0.0]));
        assert!(close(clamp.eval(Vec2::new(0.1, 0.3)), [0.9, 0.0, 0.1]));
        let mirror = two_by_two(WrapMode::Mirror);
        assert!(close(mirror.eval(Vec2::new(1.1, 0.3)), [0.1, 1.0, 0.1]));
        assert!(close(mirror.eval(Vec2::new(-0.1, 0.3)), [0.9, 0.0, 0.1]));
        // As a number (`eval_1`): the luminance.
        assert_eq!(repeat.eval_number(Vec2::new(0.25, 0.25)), LUMINANCE[0]);
        assert!((repeat.eval_number(Vec2::new(0.1, 0.3)) - 0.362128).abs() < 1e-6);
    }

    #[test]
    fn srgb_decoding_follows_the_standard() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        // The linear segment, and the curve: 0.5 encodes 0.214041.
        assert_eq!(srgb_to_linear(10), (10.0 / 255.0 / 12.92) as f32);
        assert!((srgb_to_linear(128) - 0.215_861).abs() < 1e-6);
    }
}
