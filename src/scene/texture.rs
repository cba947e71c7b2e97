//! Textures for material colours, with Mitsuba 3's semantics: `checkerboard`
//! and `bitmap`, looked up at a hit's texture coordinates (`uv`) after the
//! texture's affine `to_uv` map.
//!
//! - checkerboard: `color0` where the fractional parts of u and v are both above
//!   one half or both not, `color1` elsewhere.
//! - bitmap: row 0 of the image at v = 0 (its top), texel `(x, y)` centred on
//!   `((x + 1/2) / W, (y + 1/2) / H)`; bilinear between the four nearest
//!   centres (or the nearest texel), the integer texel coordinates wrapped by
//!   `wrap_mode` (`repeat`, `mirror`, `clamp`). 8-bit images (PNG, JPEG) are
//!   sRGB-encoded and decoded to linear unless `raw`; EXR and HDR are linear.

use glam::{Vec2, Vec3};
use std::fmt;
use std::path::Path;
use std::sync::Arc;

/// u' = m[0] . (u, v, 1), v' = m[1] . (u, v, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform(pub [[f32; 3]; 2]);

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let [a, b] = self.0;
        Vec2::new(
            a[0] * uv.x + a[1] * uv.y + a[2],
            b[0] * uv.x + b[1] * uv.y + b[2],
        )
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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
#[derive(Clone, PartialEq)]
pub struct Bitmap {
    /// The image file as the scene names it (relative to the scene file).
    pub file: String,
    pub width: u32,
    pub height: u32,
    pub texels: Arc<Vec<[f32; 3]>>,
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

#[derive(Clone, Debug, PartialEq)]
pub enum TextureKind {
    Checkerboard { color0: Vec3, color1: Vec3 },
    Bitmap(Bitmap),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub kind: TextureKind,
    pub to_uv: UvTransform,
}

impl Texture {
    /// The mean over the texture (Mitsuba's `mean()`): what a plastic's choice
    /// between its lobes is steered by.
    pub fn mean(&self) -> Vec3 {
        match &self.kind {
            TextureKind::Checkerboard { color0, color1 } => 0.5 * (*color0 + *color1),
            TextureKind::Bitmap(b) => {
                let sum = b.texels.iter().fold([0.0f64; 3], |s, t| {
                    [s[0] + t[0] as f64, s[1] + t[1] as f64, s[2] + t[2] as f64]
                });
                let n = b.texels.len() as f64;
                Vec3::new(
                    (sum[0] / n) as f32,
                    (sum[1] / n) as f32,
                    (sum[2] / n) as f32,
                )
            }
        }
    }

    /// The texture's value at `uv`, as `shaders/textures.wgsl` computes it.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let uv = self.to_uv.apply(uv);
        match &self.kind {
            TextureKind::Checkerboard { color0, color1 } => {
                let f = uv - uv.floor();
                if (f.x > 0.5) == (f.y > 0.5) {
                    *color0
                } else {
                    *color1
                }
            }
            TextureKind::Bitmap(b) => {
                let (w, h) = (b.width as i64, b.height as i64);
                let texel = |x: i64, y: i64| {
                    let (x, y) = (b.wrap.wrap(x, w), b.wrap.wrap(y, h));
                    Vec3::from(b.texels[(y * w + x) as usize])
                };
                let p = uv * Vec2::new(b.width as f32, b.height as f32);
                match b.filter {
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
        }
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1): an 8-bit code's
/// linear value.
pub fn srgb_to_linear(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    let linear = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    linear as f32
}

/// Reads a texture image: `.exr` and `.hdr` through `envmap::load_image`
/// (linear), `.png`, `.jpg`/`.jpeg` as 8- or 16-bit RGB, sRGB-decoded unless
/// `raw` (16-bit PNGs too, as Mitsuba treats them). The error names the file.
pub fn load_texture_image(path: &Path, raw: bool) -> Result<(u32, u32, Vec<[f32; 3]>), String> {
    let shown = path.display();
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match extension.as_str() {
        "exr" | "hdr" => super::envmap::load_image(path),
        "png" | "jpg" | "jpeg" => {
            let image = image::ImageReader::open(path)
                .map_err(|e| format!("{shown}: cannot read the image file: {e}"))?
                .with_guessed_format()
                .map_err(|e| format!("{shown}: cannot read the image file: {e}"))?
                .decode()
                .map_err(|e| format!("{shown}: cannot decode the image: {e}"))?;
            let (width, height) = (image.width(), image.height());
            if width == 0 || height == 0 {
                return Err(format!(
                    "{shown}: the image has no texels ({width}x{height})"
                ));
            }
            let texels = match image {
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
                    image
                        .into_rgb16()
                        .pixels()
                        .map(|p| p.0.map(decode))
                        .collect()
                }
                _ => {
                    let table: Vec<f32> = (0..=255u8)
                        .map(|c| {
                            if raw {
                                c as f32 / 255.0
                            } else {
                                srgb_to_linear(c)
                            }
                        })
                        .collect();
                    image
                        .into_rgb8()
                        .pixels()
                        .map(|p| p.0.map(|c| table[c as usize]))
                        .collect()
                }
            };
            Ok((width, height, texels))
        }
        _ => Err(format!(
            "{shown}: unknown texture image format {extension:?} (supported: .png, .jpg, .jpeg, .exr, .hdr)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_follows_the_standard() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert_eq!(srgb_to_linear(255), 1.0);
        // The linear segment, and the curve: 0.5 encodes 0.214041.
        assert_eq!(srgb_to_linear(10), (10.0 / 255.0 / 12.92) as f32);
        assert!((srgb_to_linear(128) - 0.215_861).abs() < 1e-6);
    }

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
    }

    #[test]
    fn checkerboard_matches_mitsuba() {
        let (red, blue) = (Vec3::X, Vec3::Z);
        let t = Texture {
            kind: TextureKind::Checkerboard {
                color0: red,
                color1: blue,
            },
            to_uv: UvTransform::IDENTITY,
        };
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), red);
        assert_eq!(t.eval(Vec2::new(0.75, 0.25)), blue);
        assert_eq!(t.eval(Vec2::new(0.25, 0.75)), blue);
        assert_eq!(t.eval(Vec2::new(0.75, 0.75)), red);
        assert_eq!(t.mean(), Vec3::new(0.5, 0.0, 0.5));
        // Mitsuba's to_uv: translate(0.5, 0) after scale(2, 1): u' = 2u + 0.5.
        let shifted = Texture {
            to_uv: UvTransform([[2.0, 0.0, 0.5], [0.0, 1.0, 0.0]]),
            ..t
        };
        assert_eq!(shifted.eval(Vec2::new(0.1, 0.1)), blue);
        assert_eq!(shifted.eval(Vec2::new(0.3, 0.1)), red);
    }
}
