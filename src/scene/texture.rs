//! Reading textures' images (8-bit PNG and JPEG decoded from sRGB unless
//! `raw`; EXR and HDR linear). The texture kinds themselves are
//! `kinds::texture`'s.

pub use crate::kinds::{Bitmap, Texture, TextureFilter, TextureKind, UvTransform, WrapMode};
use crate::output::{self, ImageReadError};
use std::path::Path;

/// The largest texel value of a texture, which scales the light a surface
/// sends on: a reflectance, which Mitsuba lets exceed 1 (a surface that adds
/// energy), but no real texture comes near 1e6, and the product of a path's
/// few such factors then stays far inside f32 instead of overflowing to
/// infinity and NaN.
pub const MAX_TEXEL_VALUE: f32 = 1e6;

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
/// `raw` (16-bit PNGs too, as Mitsuba treats them); no texel above
/// [`MAX_TEXEL_VALUE`]. The error names the file.
pub fn load_texture_image(path: &Path, raw: bool) -> Result<(u32, u32, Vec<[f32; 3]>), String> {
    let shown = path.display();
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match extension.as_str() {
        "exr" | "hdr" => {
            let (width, height, texels) = super::envmap::load_image(path)?;
            let values = texels.iter().flatten();
            if let Some((i, value)) = values.enumerate().find(|&(_, &c)| c > MAX_TEXEL_VALUE) {
                let texel = (i / 3) as u32;
                let (x, y) = (texel % width, texel / width);
                return Err(format!(
                    "{shown}: texel ({x}, {y}) holds {value:e}: a texture's values must be at \
                     most {MAX_TEXEL_VALUE:e} (they scale the light a surface reflects)"
                ));
            }
            Ok((width, height, texels))
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
}
