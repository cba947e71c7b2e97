//! Spheres, with outward normals.

use super::{ErasedLayout, PackedPrimitive, PrimitiveKind, Shape, Shapes};
use crate::abi::gpu_struct;
use crate::shader::shader_module;
use glam::Vec3;
use serde::Serialize;

/// World space; the normal points outwards.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
    pub importance: bool,
}

impl Shape for Sphere {
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
        self.center.abs().max_element() + self.radius
    }
}

pub const SPHERE: PrimitiveKind = PrimitiveKind {
    name: "sphere",
    array: "spheres",
    module: shader_module!("sphere"),
    layout: ErasedLayout::of::<PackedSphere>(),
    light_density: true,
    pack: |shapes: &Shapes| {
        shapes
            .spheres
            .iter()
            .map(|s| {
                let packed = PackedSphere {
                    center: s.center.to_array(),
                    radius: s.radius,
                    material: s.material,
                    ..PackedSphere::default()
                };
                PackedPrimitive::new(&packed, s.material, s.importance)
            })
            .collect()
    },
    never_hit: || {
        let nan = PackedSphere {
            center: [f32::NAN; 3],
            radius: f32::NAN,
            ..PackedSphere::default()
        };
        bytemuck::bytes_of(&nan).to_vec()
    },
    bounds: |bytes| {
        let sphere: PackedSphere = bytemuck::pod_read_unaligned(bytes);
        let center = glam::Vec3::from(sphere.center);
        (center - sphere.radius, center + sphere.radius)
    },
    shading_normals: None,
    texture_uvs: None,
    uv_tangents: false,
    grouped_lights: false,
    // Its hit point, reprojected onto the sphere, errs by a few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: true,
};

gpu_struct! {
    pub struct PackedSphere as Sphere {
        pub center: [f32; 3],
        pub radius: f32,
        pub material: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}
