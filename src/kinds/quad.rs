//! Quads (parallelograms): `q + a u + b v` for `a, b` in [0, 1], normal `normalize(u x v)`.

use super::{ErasedLayout, PackedPrimitive, PrimitiveKind};
use crate::gpu::layout::gpu_struct;
use crate::scene::Scene;
use crate::shader::shader_module;

pub const QUAD: PrimitiveKind = PrimitiveKind {
    name: "quad",
    array: "quads",
    module: shader_module!("quad"),
    layout: ErasedLayout::of::<Quad>(),
    light_density: true,
    pack: |scene: &Scene| {
        scene
            .quads
            .iter()
            .map(|q| PackedPrimitive::new(&Quad::new(q), q.material, q.importance))
            .collect()
    },
    never_hit: || bytemuck::bytes_of(&Quad::never_hit()).to_vec(),
    bounds: |bytes| {
        let quad: Quad = bytemuck::pod_read_unaligned(bytes);
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
    grouped_lights: false,
};

gpu_struct! {
    /// Plane and barycentric terms are precomputed here, once per quad.
    pub struct Quad {
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

impl Quad {
    pub fn new(quad: &crate::scene::Quad) -> Quad {
        let n = quad.u.cross(quad.v);
        let normal = n.normalize();
        Quad {
            q: quad.q.to_array(),
            material: quad.material,
            u: quad.u.to_array(),
            plane_d: normal.dot(quad.q),
            v: quad.v.to_array(),
            area: n.length(),
            normal: normal.to_array(),
            w: (n / n.dot(n)).to_array(),
            ..Quad::default()
        }
    }

    /// With NaN geometry every hit test fails.
    pub fn never_hit() -> Quad {
        let nan = [f32::NAN; 3];
        Quad {
            q: nan,
            u: nan,
            plane_d: f32::NAN,
            v: nan,
            area: f32::NAN,
            normal: nan,
            w: nan,
            ..Quad::default()
        }
    }
}
