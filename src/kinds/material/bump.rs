//! A material's shading normal from a texture: Mitsuba 3's `bumpmap` and
//! `normalmap` BSDFs, which wrap any BSDF and hand it a perturbed shading
//! frame. In pathmix they are keys of any scattering material's table:
//!
//! - `bump = { texture = { type = "bitmap", ... }, scale = 1 }`: the texture
//!   is a height field (its luminance) over the surface's `(u, v)`; the
//!   surface is moved along its normal by `scale` times the height, and the
//!   shading normal is the moved surface's: `normalize(dp_du' x dp_dv')`
//!   with `dp_du' = dp_du + n (scale dh/du - n . dp_du)` (and so for v), the
//!   gradient `(dh/du, dh/dv)` analytic on the bilinear patch between the four
//!   texels a lookup reads (zero for `filter_type = "nearest"`), as Mitsuba's
//!   `eval_1_grad`. The texture must be a `bitmap`.
//! - `normal_map = { type = "bitmap", file = ..., raw = true }`: the texel
//!   `c` gives the normal `2 c - 1` in the tangent frame (`s` along
//!   `dp_du`, `t = n x s`, `n`). As in Mitsuba, an 8-bit normal map wants
//!   `raw = true` (its texels are not sRGB colours).
//!
//! `dp_du` and `dp_dv` are the surface's tangents along its texture
//! coordinates, Mitsuba's: a triangle's from its vertex uvs (Mitsuba's mesh),
//! a quad's edges, a sphere's and a disk's from their parameterisations
//! (`sphere.cpp`, `disk.cpp`: along phi and theta, along the radius and
//! around). Where they are degenerate (a triangle whose uvs have no area, a
//! sphere's poles, a disk's centre), any frame about the normal stands in, so
//! a bump map never makes a NaN.
//!
//! The corrections are Mitsuba's: a normal that turns away from the side the
//! ray came from is mirrored about the unperturbed one (`flip_invalid_normals`:
//! shading stays lit where the texture tilts the normal past the viewer), and
//! light that arrives on the other side of the true surface than of the
//! shading normal carries nothing (`materials.wgsl`'s `bsdf_leaks`, pbrt-v3's
//! rule, against the geometric normal), and the map shadows itself: the BSDF's
//! value toward a direction is scaled by Estevez et al.'s microfacet
//! shadowing term, whose roughness is the normal's tilt (Mitsuba's default
//! `use_shadowing_function`, `materials.wgsl`'s `bump_shadowing`), so light
//! does not reach the bump's terminator where the true geometry would shadow it.

use crate::kinds::Texture;
use crate::kinds::TextureKind;
use crate::kinds::params::{ParamTable, Result, check_finite};
use serde::Serialize;

/// What perturbs a material's shading normal (`Material::bump`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub enum Bump {
    /// Mitsuba's `bumpmap`: a height field, its heights times `scale`.
    Height { texture: Texture, scale: f32 },
    /// Mitsuba's `normalmap`: tangent-space normals, `2 c - 1`.
    NormalMap { texture: Texture },
}

impl Bump {
    /// The texture that is looked up.
    pub fn texture(&self) -> &Texture {
        match self {
            Bump::Height { texture, .. } | Bump::NormalMap { texture } => texture,
        }
    }

    /// What the height field is multiplied by (zero for a normal map, whose
    /// texels are normals).
    pub fn scale(&self) -> f32 {
        match self {
            Bump::Height { scale, .. } => *scale,
            Bump::NormalMap { .. } => 0.0,
        }
    }
}

/// The keys every scattering material takes for its shading normal.
pub(crate) const BUMP_KEYS: &[&str] = &["bump", "normal_map"];

/// The material's `bump` or `normal_map` (not both).
pub(crate) fn parse_bump(t: &ParamTable) -> Result<Option<Bump>> {
    if t.table.contains_key("bump") && t.table.contains_key("normal_map") {
        return Err(t.err(
            t.at("normal_map"),
            "give either `bump` or `normal_map`, not both",
        ));
    }
    if let Some(b) = t.sub("bump")? {
        b.check_keys(&["texture", "scale"], Some("a bump map"))?;
        let Some(s) = b.sub("texture")? else {
            return Err(b.err(b.here(), "missing required key `texture`"));
        };
        let texture = Texture::parse(&s)?;
        if !matches!(texture.kind, TextureKind::Bitmap(_)) {
            return Err(s.err(
                s.at("type"),
                "a bump map's height texture must be a `bitmap` (a checkerboard has no gradient)",
            ));
        }
        let scale = b.float("scale", check_finite)?.unwrap_or(1.0);
        return Ok(Some(Bump::Height { texture, scale }));
    }
    if let Some(s) = t.sub("normal_map")? {
        let texture = Texture::parse(&s)?;
        if !matches!(texture.kind, TextureKind::Bitmap(_)) {
            return Err(s.err(s.at("type"), "a normal map must be a `bitmap`"));
        }
        return Ok(Some(Bump::NormalMap { texture }));
    }
    Ok(None)
}
