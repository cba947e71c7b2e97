//! Triangles: the faces of meshes.

use super::{ErasedLayout, PackedPrimitive, PrimitiveKind};
use crate::gpu::layout::gpu_struct;
use crate::scene::Scene;
use crate::shader::shader_module;

pub const TRIANGLE: PrimitiveKind = PrimitiveKind {
    name: "triangle",
    array: "triangles",
    module: shader_module!("triangle"),
    layout: ErasedLayout::of::<Triangle>(),
    light_density: true,
    pack: |scene: &Scene| {
        scene
            .triangles
            .iter()
            .map(|t| PackedPrimitive::new(&Triangle::new(t), t.material, t.importance))
            .collect()
    },
    never_hit: || {
        let nan = [f32::NAN; 3];
        let never = Triangle {
            p0: nan,
            p1: nan,
            p2: nan,
            normal: nan,
            ..Triangle::default()
        };
        bytemuck::bytes_of(&never).to_vec()
    },
    bounds: |bytes| {
        let t: Triangle = bytemuck::pod_read_unaligned(bytes);
        let [a, b, c] = [t.p0, t.p1, t.p2].map(glam::Vec3::from);
        (a.min(b).min(c), a.max(b).max(c))
    },
};

gpu_struct! {
    pub struct Triangle {
        pub p0: [f32; 3],
        pub material: u32,
        pub p1: [f32; 3],
        pub area: f32,
        pub p2: [f32; 3],
        pub _pad0: u32,
        pub normal: [f32; 3],
        pub _pad1: u32,
    }
}

impl Triangle {
    pub fn new(triangle: &crate::scene::Triangle) -> Triangle {
        let [p0, p1, p2] = triangle.vertices;
        let n = (p1 - p0).cross(p2 - p0);
        Triangle {
            p0: p0.to_array(),
            material: triangle.material,
            p1: p1.to_array(),
            area: 0.5 * n.length(),
            p2: p2.to_array(),
            normal: n.normalize().to_array(),
            ..Triangle::default()
        }
    }
}
