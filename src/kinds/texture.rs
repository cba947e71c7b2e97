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
//!
//! Textures as the kernel reads them (`shaders/textures.wgsl`): one
//! `TextureInfo` per texture and one array of every bitmap's texels. A
//! textured material names its texture in the high bits of its flags
//! (index + 1 in the [`MATERIAL_TEXTURE_BITS`] above [`MATERIAL_TEXTURE_SHIFT`];
//! 0: none), and its bump or normal map the same way above
//! [`MATERIAL_BUMP_SHIFT`], so materials pack as before and untextured scenes
//! are unchanged.

use crate::abi::gpu_struct;
use glam::{Vec2, Vec3};
use serde::{Serialize, Serializer};
use std::fmt;
use std::sync::Arc;

/// u' = m[0] . (u, v, 1), v' = m[1] . (u, v, 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
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

/// Texels as one run of bytes (each f32 little-endian), for an encoding that
/// keeps every bit of an image without a number per texel (the scene identity
/// hashes it).
pub fn serialize_texels<S: Serializer>(
    texels: &[[f32; 3]],
    serializer: S,
) -> Result<S::Ok, S::Error> {
    let values: &[f32] = bytemuck::cast_slice(texels);
    if cfg!(target_endian = "little") {
        serializer.serialize_bytes(bytemuck::cast_slice(values))
    } else {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        serializer.serialize_bytes(&bytes)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum TextureKind {
    Checkerboard { color0: Vec3, color1: Vec3 },
    Bitmap(Bitmap),
}

#[derive(Clone, Debug, PartialEq, Serialize)]
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

/// Where a material's texture index + 1 starts in `Material::flags`.
pub const MATERIAL_TEXTURE_SHIFT: u32 = 8;
/// How many bits it has, and its bump texture's index + 1 those above it.
pub const MATERIAL_TEXTURE_BITS: u32 = 12;
pub const MATERIAL_BUMP_SHIFT: u32 = MATERIAL_TEXTURE_SHIFT + MATERIAL_TEXTURE_BITS;
/// The most textures a scene's materials may have, bump maps included: each
/// index + 1 fits [`MATERIAL_TEXTURE_BITS`].
pub const MAX_TEXTURES: usize = (1 << MATERIAL_TEXTURE_BITS) - 1;

/// The constants `TextureInfo::kind` and `wrap` take, shared with WGSL.
pub const TEXTURE_CONSTANTS: &[(&str, u32)] = &[
    ("TEXTURE_CHECKERBOARD", 0),
    ("TEXTURE_BITMAP", 1),
    ("TEXTURE_WRAP_REPEAT", 0),
    ("TEXTURE_WRAP_MIRROR", 1),
    ("TEXTURE_WRAP_CLAMP", 2),
];

fn constant(name: &str) -> u32 {
    TEXTURE_CONSTANTS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, v)| v)
        .expect("a texture constant")
}

gpu_struct! {
    /// One texture: its `to_uv` rows, and the checkerboard's colours or the
    /// bitmap's size and first texel (an index into the texel array, three
    /// floats a texel, row-major from the top row). `bump_scale`: a bump
    /// map's `scale` (`kinds::Bump`), 0 for other textures.
    pub struct TextureInfo {
        pub to_uv_u: [f32; 3],
        pub kind: u32,
        pub to_uv_v: [f32; 3],
        pub wrap: u32,
        pub color0: [f32; 3],
        pub width: u32,
        pub color1: [f32; 3],
        pub height: u32,
        pub offset: u32,
        pub nearest: u32,
        pub bump_scale: f32,
        pub _pad1: u32,
    }
}

/// A scene's textures, packed. Bitmaps of the same file read the same way
/// share their texels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TextureTables {
    pub infos: Vec<TextureInfo>,
    pub texels: Vec<f32>,
    /// The bitmaps packed so far (file, raw) and their texels' offsets.
    bitmaps: Vec<((String, bool), u32)>,
}

impl TextureTables {
    /// Packs `texture`; its index in `infos`.
    pub fn add(&mut self, texture: &Texture) -> u32 {
        let [u, v] = texture.to_uv.0;
        let mut info = TextureInfo {
            to_uv_u: u,
            to_uv_v: v,
            ..TextureInfo::default()
        };
        match &texture.kind {
            TextureKind::Checkerboard { color0, color1 } => {
                info.kind = constant("TEXTURE_CHECKERBOARD");
                info.color0 = color0.to_array();
                info.color1 = color1.to_array();
            }
            TextureKind::Bitmap(b) => {
                let key = (b.file.clone(), b.raw);
                let offset = match self.bitmaps.iter().find(|(k, _)| *k == key) {
                    Some(&(_, offset)) => offset,
                    None => {
                        let offset = self.texels.len() as u32;
                        self.texels.extend(b.texels.iter().flatten());
                        self.bitmaps.push((key, offset));
                        offset
                    }
                };
                info.kind = constant("TEXTURE_BITMAP");
                info.wrap = constant(match b.wrap {
                    WrapMode::Repeat => "TEXTURE_WRAP_REPEAT",
                    WrapMode::Mirror => "TEXTURE_WRAP_MIRROR",
                    WrapMode::Clamp => "TEXTURE_WRAP_CLAMP",
                });
                info.width = b.width;
                info.height = b.height;
                info.offset = offset;
                info.nearest = (b.filter == TextureFilter::Nearest) as u32;
            }
        }
        self.infos.push(info);
        (self.infos.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
