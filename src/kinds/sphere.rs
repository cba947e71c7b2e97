//! Spheres, with outward normals.

use super::{ErasedLayout, PackedPrimitive, PrimitiveKind};
use crate::abi::gpu_struct;
use crate::scene::Scene;
use crate::shader::shader_module;

pub const SPHERE: PrimitiveKind = PrimitiveKind {
    name: "sphere",
    array: "spheres",
    module: shader_module!("sphere"),
    layout: ErasedLayout::of::<Sphere>(),
    light_density: true,
    pack: |scene: &Scene| {
        scene
            .spheres
            .iter()
            .map(|s| {
                let packed = Sphere {
                    center: s.center.to_array(),
                    radius: s.radius,
                    material: s.material,
                    ..Sphere::default()
                };
                PackedPrimitive::new(&packed, s.material, s.importance)
            })
            .collect()
    },
    never_hit: || {
        let nan = Sphere {
            center: [f32::NAN; 3],
            radius: f32::NAN,
            ..Sphere::default()
        };
        bytemuck::bytes_of(&nan).to_vec()
    },
    bounds: |bytes| {
        let sphere: Sphere = bytemuck::pod_read_unaligned(bytes);
        let center = glam::Vec3::from(sphere.center);
        (center - sphere.radius, center + sphere.radius)
    },
    shading_normals: None,
    texture_uvs: None,
    grouped_lights: false,
    // Its hit point (the ray meets it by a plane or sphere equation) errs by a
    // few ulps of the extent.
    ray_offset_factor: 1.0,
};

gpu_struct! {
    pub struct Sphere {
        pub center: [f32; 3],
        pub radius: f32,
        pub material: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}
