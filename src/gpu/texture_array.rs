//! A scene array bound as a texture (`kernel::ArrayMemory::Textures`): one
//! word of its elements a texel, in rows of `WIDTH` texels, read by
//! `textureLoad` through `NAME_word` (`kernel::glue`). Texel 0 holds the
//! element count, which a storage buffer's `arrayLength` gave; the elements'
//! words follow from texel 1, and the last row is padded with zeros.

use crate::abi::TEXTURE_ARRAY_WIDTH as WIDTH;

/// The texels of an array of `bytes`, `count` elements of `word`-byte words
/// (16: `rgba32uint`, 8: `rg32uint`).
#[derive(Debug)]
pub struct TextureArray {
    pub format: wgpu::TextureFormat,
    pub height: u32,
    pub texels: Vec<u8>,
}

impl TextureArray {
    pub fn new(bytes: &[u8], count: usize, word: usize) -> TextureArray {
        assert_eq!(bytes.len() % word, 0, "elements are whole words");
        let format = match word {
            16 => wgpu::TextureFormat::Rgba32Uint,
            8 => wgpu::TextureFormat::Rg32Uint,
            _ => unreachable!("texture arrays have 8- or 16-byte words"),
        };
        let height = rows(bytes.len(), word);
        let mut texels = Vec::with_capacity(height as usize * WIDTH as usize * word);
        texels.extend_from_slice(&u32::try_from(count).expect("counts fit u32").to_le_bytes());
        texels.resize(word, 0);
        texels.extend_from_slice(bytes);
        texels.resize(height as usize * WIDTH as usize * word, 0);
        TextureArray {
            format,
            height,
            texels,
        }
    }

    /// The texture on `device`, with its contents.
    pub fn upload(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> wgpu::Texture {
        use wgpu::util::DeviceExt;
        device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("scene array"),
                size: wgpu::Extent3d {
                    width: WIDTH,
                    height: self.height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &self.texels,
        )
    }
}

/// Rows of the texture holding `bytes` of `word`-byte words after the count's texel.
pub fn rows(bytes: usize, word: usize) -> u32 {
    let texels = 1 + bytes / word;
    u32::try_from(texels.div_ceil(WIDTH as usize)).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_count_comes_first_and_rows_are_padded() {
        // 1 024 elements of four 16-byte words: a row of texels, and the
        // count's texel before them.
        let words: Vec<u32> = (0..4 * WIDTH).collect();
        let array = TextureArray::new(bytemuck::cast_slice(&words), 1024, 16);
        assert_eq!(array.height, 2);
        assert_eq!(array.format, wgpu::TextureFormat::Rgba32Uint);
        let texels: &[u32] = bytemuck::cast_slice(&array.texels);
        assert_eq!(texels.len(), 2 * WIDTH as usize * 4);
        assert_eq!(&texels[..4], &[1024, 0, 0, 0]);
        assert_eq!(&texels[4..4 * WIDTH as usize + 4], &words[..]);
        assert!(texels[4 * WIDTH as usize + 4..].iter().all(|&t| t == 0));
        assert_eq!(rows(words.len() * 4, 16), 2);
        assert_eq!(rows(words.len() * 4 - 16, 16), 1);
        assert_eq!(rows(0, 8), 1);
        let pairs = TextureArray::new(&[7; 8 * 3], 3, 8);
        assert_eq!(pairs.format, wgpu::TextureFormat::Rg32Uint);
        assert_eq!(pairs.height, 1);
        assert_eq!(&pairs.texels[..8], &[3, 0, 0, 0, 0, 0, 0, 0]);
    }
}
