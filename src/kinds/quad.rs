//! Quads (parallelograms): `q + a u + b v` for `a, b` in [0, 1], normal `normalize(u x v)`.

use super::{ErasedLayout, PackedPrimitive, PrimitiveKind, Shape, Shapes};
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
    uv_tangents: true,
    grouped_lights: false,
    // Its hit point (the ray meets it by a plane or sphere equation) errs by a
    // few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: false,
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
