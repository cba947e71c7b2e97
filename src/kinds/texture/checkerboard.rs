//! Checkerboards, Mitsuba 3's `checkerboard` texture: `color0` where the
//! fractional parts of u and v are both above one half or both not, `color1`
//! elsewhere.
//!
//! ```toml
//! albedo = { type = "checkerboard", color0 = [0.8, 0.8, 0.75], color1 = 0.1, to_uv = { scale = 10 } }
//! ```
//!
//! `color0` (default 0.4) and `color1` (default 0.2): reflectances, a vector
//! or one number for grey, in [0, 1]; `to_uv` as every texture. Its mean is
//! the two colours' average. Where a material's number is a checkerboard, it
//! reads as Mitsuba's `eval_1` reads it: the colours swapped (`color1` where
//! the fractional parts are both above one half or both not), each as its
//! mean over its channels. Mitsuba's `checkerboard` becomes one.

use super::{TextureInfo, TextureKind, TextureModel, TextureTables, TextureValue};
use crate::kinds::params::{ParamTable, Result, reflectance};
use glam::{Vec2, Vec3};
use serde::Serialize;

pub(super) const CHECKERBOARD: TextureModel = TextureModel {
    name: "checkerboard",
    keys: &["color0", "color1"],
    parse,
};

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Checkerboard {
    pub color0: Vec3,
    pub color1: Vec3,
}

fn parse(s: &ParamTable) -> Result<TextureKind> {
    Ok(TextureKind::Checkerboard(Checkerboard {
        color0: reflectance(s, "color0", 0.4)?,
        color1: reflectance(s, "color1", 0.2)?,
    }))
}

impl TextureValue for Checkerboard {
    fn mean(&self) -> Vec3 {
        0.5 * (self.color0 + self.color1)
    }

    fn eval(&self, uv: Vec2) -> Vec3 {
        let f = uv - uv.floor();
        if (f.x > 0.5) == (f.y > 0.5) {
            self.color0
        } else {
            self.color1
        }
    }

    /// Mitsuba's `eval_1` takes `color1` where `eval` takes `color0` and the
    /// reverse (checkerboard.cpp), and reads a colour (`srgb`) as its
    /// channels' mean.
    fn eval_number(&self, uv: Vec2) -> f32 {
        let swapped = Checkerboard {
            color0: self.color1,
            color1: self.color0,
        };
        swapped.eval(uv).element_sum() / 3.0
    }

    fn mean_number(&self) -> f32 {
        self.mean().element_sum() / 3.0
    }

    fn pack(&self, info: &mut TextureInfo, _: &mut TextureTables) {
        info.color0 = self.color0.to_array();
        info.color1 = self.color1.to_array();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Texture, UvTransform};

    #[test]
    fn checkerboard_matches_mitsuba() {
        let (red, blue) = (Vec3::X, Vec3::Z);
        let t = Texture {
            kind: TextureKind::Checkerboard(Checkerboard {
                color0: red,
                color1: blue,
            }),
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

    /// As a number, what Mitsuba 3.9.1's `eval_1` gives (scalar_rgb, these
    /// colours): the colours' channel means, swapped against `eval`.
    #[test]
    fn its_number_is_mitsubas_eval_1() {
        let t = Texture {
            kind: TextureKind::Checkerboard(Checkerboard {
                color0: Vec3::new(0.9, 0.6, 0.3),
                color1: Vec3::new(0.0, 0.0, 0.3),
            }),
            to_uv: UvTransform::IDENTITY,
        };
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Vec3::new(0.9, 0.6, 0.3));
        assert!((t.eval_number(Vec2::new(0.25, 0.25)) - 0.1).abs() < 1e-7);
        assert!((t.eval_number(Vec2::new(0.75, 0.25)) - 0.6).abs() < 1e-7);
        assert!((t.mean_number() - 0.35).abs() < 1e-7);
    }

    /// The checkpoint identity encodes it as it did the variant's fields
    /// (`Checkerboard { color0, color1 }`): its variant index, then the six
    /// floats' bits.
    #[test]
    fn its_encoding_is_the_variant_index_and_the_colours() {
        let kind = TextureKind::Checkerboard(Checkerboard {
            color0: Vec3::new(1.0, 2.0, 3.0),
            color1: Vec3::new(4.0, 5.0, 6.0),
        });
        let mut buffer = [0u8; 64];
        let encoded = postcard::to_slice(&kind, &mut buffer).expect("it fits");
        let mut expected = vec![0u8];
        for x in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0] {
            expected.extend(x.to_le_bytes());
        }
        assert_eq!(encoded, &expected[..]);
    }
}
