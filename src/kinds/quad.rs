//! Quads (parallelograms): `q + a u + b v` for `a, b` in [0, 1], normal `normalize(u x v)`.
//!
//! ```toml
//! [[objects]]
//! type = "quad"
//! q = [213, 554, 227]   # a corner
//! u = [130, 0, 0]       # the edges from it
//! v = [0, 0, 105]
//! material = "light"
//! ```
//!
//! `q`, `u`, `v` (vectors, required) with an object's common keys (`material`,
//! `importance`, the transform: `q` is moved, `u` and `v` transformed). `u x v`
//! must not be (near) zero: `|u x v| <= 1e-6 |u| |v|` is refused as degenerate,
//! as is a quad whose coordinates or area 32-bit floats cannot hold. As a light
//! it is sampled uniformly by area. Texture coordinates: `(a, b)`. A `box`
//! object (`scene`'s) is six quads; Mitsuba's `rectangle` becomes one quad and
//! its `cube` six. WGSL: `shaders/quad.wgsl`.

use super::params::{ParamTable, Result, fmt_num, fmt_vec, ok};
use super::transform::Transform;
use super::{
    DEGENERATE, ErasedLayout, ObjectType, PackedPrimitive, PrimitiveKind, Shape, Shapes,
    usable_length_squared,
};
use crate::abi::gpu_struct;
use crate::shader::shader_module;
use glam::Vec3;
use serde::Serialize;

/// Points `q + a u + b v`, `a, b` in [0, 1]; normal `normalize(u x v)`. World space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Quad {
    pub q: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Part of the light density (emitters always are; others when marked).
    pub importance: bool,
}

impl Shape for Quad {
    fn material_mut(&mut self) -> &mut u32 {
        &mut self.material
    }

    fn material(&self) -> u32 {
        self.material
    }

    fn importance(&self) -> bool {
        self.importance
    }

    fn extent(&self) -> f32 {
        [
            self.q,
            self.q + self.u,
            self.q + self.v,
            self.q + self.u + self.v,
        ]
        .into_iter()
        .fold(0.0, |extent, corner| extent.max(corner.abs().max_element()))
    }

    fn scale(&mut self, factor: f32) {
        self.q *= factor;
        self.u *= factor;
        self.v *= factor;
    }

    fn problem(&self) -> Option<String> {
        spanned_problem("quad", self.q, self.u, self.v)
    }
}

/// What is wrong with a flat shape spanned by `u` and `v` from `point` (a quad, a disk).
pub(super) fn spanned_problem(what: &str, point: Vec3, u: Vec3, v: Vec3) -> Option<String> {
    if !(point.is_finite() && u.is_finite() && v.is_finite()) {
        return Some("coordinates overflow a 32-bit float".to_string());
    }
    let area = u.as_dvec3().cross(v.as_dvec3()).length();
    if area <= DEGENERATE * u.as_dvec3().length() * v.as_dvec3().length() {
        return Some(format!(
            "degenerate {what}: u x v has (near) zero length (u = {}, v = {})",
            fmt_vec(u),
            fmt_vec(v)
        ));
    }
    if !usable_length_squared(u.cross(v).length_squared()) {
        return Some(format!(
            "{what} area {} is out of the range 32-bit float arithmetic can handle",
            fmt_num(area)
        ));
    }
    None
}

/// A flat shape's anchor point (`anchor`) and edge vectors `u`, `v` (a quad's,
/// a disk's), in world space.
pub(super) fn planar(t: &ParamTable, xf: &Transform, anchor: &str) -> Result<(Vec3, Vec3, Vec3)> {
    let point = t.require(anchor, t.vec3(anchor, ok)?)?;
    let u = t.require("u", t.vec3("u", ok)?)?;
    let v = t.require("v", t.vec3("v", ok)?)?;
    Ok((
        xf.point(point.as_dvec3()),
        xf.vector(u.as_dvec3()),
        xf.vector(v.as_dvec3()),
    ))
}

fn parse(
    t: &ParamTable,
    xf: &Transform,
    material: u32,
    importance: bool,
    shapes: &mut Shapes,
) -> Result<()> {
    let (q, u, v) = planar(t, xf, "q")?;
    let quad = Quad {
        q,
        u,
        v,
        material,
        importance,
    };
    if let Some(p) = quad.problem() {
        return Err(t.err(t.here(), p));
    }
    shapes.quads.push(quad);
    Ok(())
}

pub const QUAD: PrimitiveKind = PrimitiveKind {
    name: "quad",
    array: "quads",
    module: shader_module!("quad"),
    layout: ErasedLayout::of::<PackedQuad>(),
    light_density: true,
    pack: |shapes: &Shapes| {
        shapes
            .quads
            .iter()
            .map(|q| PackedPrimitive::new(&PackedQuad::new(q), q.material, q.importance))
            .collect()
    },
    never_hit: || bytemuck::bytes_of(&PackedQuad::never_hit()).to_vec(),
    bounds: |bytes| {
        let quad: PackedQuad = bytemuck::pod_read_unaligned(bytes);
        let (q, u, v) = (
            quad.q.into(),
            glam::Vec3::from(quad.u),
            glam::Vec3::from(quad.v),
        );
        let corners = [q, q + u, q + v, q + u + v];
        let min = corners.iter().fold(glam::Vec3::INFINITY, |m, &c| m.min(c));
        let max = corners
            .iter()
            .fold(glam::Vec3::NEG_INFINITY, |m, &c| m.max(c));
        (min, max)
    },
    shading_normals: None,
    texture_uvs: None,
    grouped_lights: false,
    // Its hit point (the ray meets it by a plane or sphere equation) errs by a
    // few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: false,
    keeps_primitive: false,
    light_importance: true,
    constant_test: false,
    object: Some(ObjectType {
        keys: &["q", "u", "v"],
        parse,
    }),
};

gpu_struct! {
    /// Plane and barycentric terms are precomputed here, once per quad.
    pub struct PackedQuad as Quad {
        pub q: [f32; 3],
        pub material: u32,
        pub u: [f32; 3],
        pub plane_d: f32,
        pub v: [f32; 3],
        pub area: f32,
        pub normal: [f32; 3],
        pub _pad0: u32,
        pub w: [f32; 3],
        pub _pad1: u32,
    }
}

/// The terms a flat shape spanned by `u` and `v` from `point` (a quad, a disk)
/// precomputes for its hit test: the unit normal, the plane offset, the vector
/// `w = (u x v) / |u x v|^2` giving the in-plane coordinates, and `|u x v|`.
pub(super) struct PlaneTerms {
    pub normal: glam::Vec3,
    pub plane_d: f32,
    pub w: glam::Vec3,
    pub span: f32,
}

impl PlaneTerms {
    pub fn new(point: glam::Vec3, u: glam::Vec3, v: glam::Vec3) -> PlaneTerms {
        let n = u.cross(v);
        let normal = n.normalize();
        PlaneTerms {
            normal,
            plane_d: normal.dot(point),
            w: n / n.dot(n),
            span: n.length(),
        }
    }
}

impl PackedQuad {
    pub fn new(quad: &Quad) -> PackedQuad {
        let plane = PlaneTerms::new(quad.q, quad.u, quad.v);
        PackedQuad {
            q: quad.q.to_array(),
            material: quad.material,
            u: quad.u.to_array(),
            plane_d: plane.plane_d,
            v: quad.v.to_array(),
            area: plane.span,
            normal: plane.normal.to_array(),
            w: plane.w.to_array(),
            ..PackedQuad::default()
        }
    }

    /// With NaN geometry every hit test fails.
    pub fn never_hit() -> PackedQuad {
        let nan = [f32::NAN; 3];
        PackedQuad {
            q: nan,
            u: nan,
            plane_d: f32::NAN,
            v: nan,
            area: f32::NAN,
            normal: nan,
            w: nan,
            ..PackedQuad::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::read_object;
    use super::*;

    #[test]
    fn reads_a_placed_quad_and_refuses_one_without_area() {
        let quad = |body: &str| read_object(&QUAD, body).map(|shapes| shapes.quads);
        let placed =
            "q = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\nscale = 2\ntranslate = [1, 2, 3]";
        let quads = quad(placed).unwrap();
        assert_eq!(
            quads,
            [Quad {
                q: Vec3::new(1.0, 2.0, 3.0),
                u: Vec3::new(2.0, 0.0, 0.0),
                v: Vec3::new(0.0, 2.0, 0.0),
                material: 0,
                importance: false,
            }]
        );
        let e = quad("q = [0, 0, 0]\nu = [1, 0, 0]\nv = [2, 0, 0]").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: objects[0]: degenerate quad: u x v has (near) zero length \
             (u = [1, 0, 0], v = [2, 0, 0])"
        );
        let mut huge = quads[0];
        huge.scale(f32::MAX);
        assert_eq!(
            huge.problem().as_deref(),
            Some("coordinates overflow a 32-bit float")
        );
    }
}
