//! Textures as the kernel reads them (`shaders/textures.wgsl`): one
//! `TextureInfo` per texture and one array of every bitmap's texels. A
//! textured material names its texture in the high bits of its flags
//! (index + 1 above [`MATERIAL_TEXTURE_SHIFT`]; 0: none), so materials pack as
//! before and untextured scenes are unchanged.

use crate::abi::gpu_struct;
use crate::scene::Texture;
use crate::scene::texture::{TextureFilter, TextureKind, WrapMode};

/// Where a material's texture index + 1 starts in `Material::flags`.
pub const MATERIAL_TEXTURE_SHIFT: u32 = 8;

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
    /// floats a texel, row-major from the top row).
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
        pub _pad0: u32,
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
