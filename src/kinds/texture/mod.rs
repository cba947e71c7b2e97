//! Textures for material colours, with Mitsuba 3's semantics, looked up at a
//! hit's texture coordinates (`uv`) after the texture's affine `to_uv` map.
//!
//! A texture is an inline table, `{ type = "NAME", ..., to_uv = ... }`, in the
//! place of a material's colour (`kinds::material`) or in its bump or normal
//! map. Its kind, one file each (`checkerboard.rs`, `bitmap.rs`), has its
//! manual (the file's doc comment), its type, how it reads and checks its keys,
//! its value ([`TextureValue`]: mean, lookup, packing) and its test; one line of
//! `texture_kinds!` below registers it, which makes its `TextureKind` variant
//! and its place in `TEXTURE_KINDS` (and so the scene files' type names and
//! keys). Read here: `type`, and `to_uv`, which every kind takes:
//!
//! - `to_uv = { scale = [su, sv], translate = [tu, tv] }`: u' = su u + tu, v' =
//!   sv v + tv (one number scales both; defaults 1 and 0);
//! - or `to_uv = { matrix = [[a, b, c], [d, e, f]] }`: u' = a u + b v + c, v' =
//!   d u + e v + f (Mitsuba's `to_uv`, its 2D affine part).
//!
//! Textures as the kernel reads them (`shaders/textures.wgsl`): one
//! `TextureInfo` per texture and one array of every bitmap's texels. A
//! textured material names its texture in the high bits of its flags
//! (index + 1 in the [`MATERIAL_TEXTURE_BITS`] above [`MATERIAL_TEXTURE_SHIFT`];
//! 0: none), and its bump or normal map the same way above
//! [`MATERIAL_BUMP_SHIFT`], so materials pack as before and untextured scenes
//! are unchanged.

mod bitmap;
mod checkerboard;

pub use bitmap::{Bitmap, TexelFormat, TextureFilter, WrapMode, texel_byte_values};
pub use checkerboard::Checkerboard;

use super::params::{ParamTable, Result, check_finite, list, number, unknown_name};
use crate::abi::gpu_struct;
use glam::{Vec2, Vec3};
use serde::{Serialize, Serializer};
use toml::Value;

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

    /// The table `to_uv` (the module's doc comment).
    fn parse(u: &ParamTable) -> Result<UvTransform> {
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
}

/// Texels as one run of bytes (each f32 little-endian), for an encoding that
/// keeps every bit of an image without a number per texel (the scene identity
/// hashes it).
pub fn serialize_texels<S: Serializer>(
    texels: &[[f32; 3]],
    serializer: S,
) -> std::result::Result<S::Ok, S::Error> {
    let values: &[f32] = bytemuck::cast_slice(texels);
    if cfg!(target_endian = "little") {
        serializer.serialize_bytes(bytemuck::cast_slice(values))
    } else {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        serializer.serialize_bytes(&bytes)
    }
}

/// A texture kind, as scene files name it.
pub(crate) struct TextureModel {
    /// Its `type`.
    pub name: &'static str,
    /// Its own keys (besides `type` and `to_uv`), in the order an unknown
    /// key's message lists them.
    pub keys: &'static [&'static str],
    /// Reads its parameters from its table, whose keys are checked.
    pub parse: fn(&ParamTable) -> Result<TextureKind>,
}

impl TextureModel {
    /// Every key of its table: `type`, its own, `to_uv`.
    pub fn all_keys(&self) -> Vec<&'static str> {
        let mut keys = vec!["type"];
        keys.extend(self.keys);
        keys.push("to_uv");
        keys
    }
}

/// What a texture kind's parameters give: its value over the surface, and
/// what the kernel reads of it.
trait TextureValue {
    /// [`Texture::mean`].
    fn mean(&self) -> Vec3;
    /// [`Texture::eval`] at `uv` after `to_uv`.
    fn eval(&self, uv: Vec2) -> Vec3;
    /// [`Texture::eval_number`] at `uv` after `to_uv`.
    fn eval_number(&self, uv: Vec2) -> f32;
    /// [`Texture::mean_number`].
    fn mean_number(&self) -> f32;
    /// Fills its parameters in `info`, its texels in `tables`.
    fn pack(&self, info: &mut TextureInfo, tables: &mut TextureTables);
}

/// Registers the texture kinds, each as `Variant = module::MODEL`, the variant
/// holding the kind's type of the same name: `TextureKind` has the variant, and
/// `TEXTURE_KINDS` the description, in this order (the variants' order shapes
/// the checkpoint identity's encoding).
macro_rules! texture_kinds {
    ($($variant:ident = $model:path,)*) => {
        /// A texture's kind and its parameters.
        #[derive(Clone, Debug, PartialEq, Serialize)]
        pub enum TextureKind {
            $($variant($variant),)*
        }

        /// Every texture kind, in the order of `TextureKind`'s variants.
        pub(crate) const TEXTURE_KINDS: &[&TextureModel] = &[$(&$model,)*];

        impl TextureKind {
            fn value(&self) -> &dyn TextureValue {
                match self {
                    $(TextureKind::$variant(kind) => kind,)*
                }
            }

            /// Its index in `TEXTURE_KINDS`: `TextureInfo::kind`, and in WGSL
            /// the constant `TEXTURE_NAME` ([`texture_constants`]).
            fn id(&self) -> u32 {
                enum Id {
                    $($variant,)*
                }
                match self {
                    $(TextureKind::$variant(_) => Id::$variant as u32,)*
                }
            }
        }
    };
}

texture_kinds! {
    Checkerboard = checkerboard::CHECKERBOARD,
    Bitmap = bitmap::BITMAP,
}

/// The scene files' texture types, in the order messages list them.
pub(crate) fn texture_types() -> Vec<&'static str> {
    TEXTURE_KINDS.iter().map(|kind| kind.name).collect()
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Texture {
    pub kind: TextureKind,
    pub to_uv: UvTransform,
}

impl Texture {
    /// A texture's table: `type` names its kind, which reads its own keys;
    /// `to_uv` is read here.
    pub(crate) fn parse(s: &ParamTable) -> Result<Texture> {
        let Some(ty) = s.string("type")? else {
            return Err(s.err(
                s.here(),
                format!(
                    "missing required key `type` for a texture (expected one of {})",
                    list(&texture_types())
                ),
            ));
        };
        let Some(model) = TEXTURE_KINDS.iter().find(|kind| kind.name == ty) else {
            return Err(s.err(
                s.at("type"),
                unknown_name("texture type", ty, &texture_types()),
            ));
        };
        s.check_keys(&model.all_keys(), Some(&format!("a {ty} texture")))?;
        let kind = (model.parse)(s)?;
        let to_uv = match s.sub("to_uv")? {
            Some(u) => UvTransform::parse(&u)?,
            None => UvTransform::IDENTITY,
        };
        Ok(Texture { kind, to_uv })
    }

    /// The mean over the texture (Mitsuba's `mean()`): what a plastic's choice
    /// between its lobes is steered by.
    pub fn mean(&self) -> Vec3 {
        self.kind.value().mean()
    }

    /// The texture's value at `uv`, as `shaders/textures.wgsl` computes it.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        self.kind.value().eval(self.to_uv.apply(uv))
    }

    /// Its value at `uv` where a material's parameter is a number, as
    /// Mitsuba's `eval_1` reads it (each kind's file says how), and as
    /// `shaders/textures.wgsl`'s `texture_eval_number` computes it.
    pub fn eval_number(&self, uv: Vec2) -> f32 {
        self.kind.value().eval_number(self.to_uv.apply(uv))
    }

    /// The mean of [`Texture::eval_number`] over the texture.
    pub fn mean_number(&self) -> f32 {
        self.kind.value().mean_number()
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

/// The constants `TextureInfo::kind`, `wrap` and `texel_format` take, shared
/// with WGSL: each kind's id as `TEXTURE_NAME` (its place in `texture_kinds!`),
/// the wrap modes and the texel formats.
pub fn texture_constants() -> Vec<(String, u32)> {
    let kinds = (TEXTURE_KINDS.iter().enumerate())
        .map(|(id, kind)| (format!("TEXTURE_{}", kind.name.to_uppercase()), id as u32));
    let wraps = (WrapMode::ALL.into_iter()).map(|wrap| {
        (
            format!("TEXTURE_WRAP_{}", wrap.name().to_uppercase()),
            wrap as u32,
        )
    });
    let formats = (TexelFormat::ALL.into_iter()).map(|f| (f.constant().to_string(), f as u32));
    kinds.chain(wraps).chain(formats).collect()
}

gpu_struct! {
    /// One texture: its `to_uv` rows, and the checkerboard's colours or the
    /// bitmap's size, first texel (an index into the texel words, row-major
    /// from the top row) and how its texels are stored (`TexelFormat`).
    /// `bump_scale`: a bump map's `scale` (`kinds::Bump`), 0 for other textures.
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
        pub texel_format: u32,
    }
}

/// A scene's textures, packed. Bitmaps of the same file read the same way
/// share their texels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TextureTables {
    pub infos: Vec<TextureInfo>,
    /// The bitmaps' texels, in words (`TexelFormat`).
    pub texels: Vec<u32>,
    /// The texel formats they use, a bit each (`1 << TexelFormat`).
    pub texel_formats: u32,
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
        info.kind = texture.kind.id();
        texture.kind.value().pack(&mut info, self);
        self.infos.push(info);
        (self.infos.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kind's manual (the doc comment of `NAME.rs`) names its keys and
    /// `to_uv`, which the module's own manual describes.
    #[test]
    fn each_kinds_manual_names_its_keys() {
        for kind in TEXTURE_KINDS {
            let file = format!("src/kinds/texture/{}.rs", kind.name);
            let source = std::fs::read_to_string(format!("{}/{file}", env!("CARGO_MANIFEST_DIR")))
                .expect("a texture kind's file is named as its type");
            let manual = crate::kinds::manual(&source);
            for key in &kind.all_keys()[1..] {
                assert!(manual.contains(&format!("`{key}`")), "{file}: `{key}`");
            }
        }
    }
}
