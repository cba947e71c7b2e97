//! Disks (ellipses under a general transform): `center + a u + b v` for
//! `a^2 + b^2 <= 1`, normal `normalize(u x v)`.

use super::quad::PlaneTerms;
use super::{ErasedLayout, PackedPrimitive, PrimitiveKind, Shape, Shapes};
use crate::abi::gpu_struct;
use crate::shader::shader_module;
use glam::Vec3;
use serde::Serialize;

/// Points `center + a u + b v` with `a^2 + b^2 <= 1`: a disk of radius `|u|` when
/// `u` and `v` are perpendicular and as long, an ellipse otherwise (a disk under an
/// affine transform); normal `normalize(u x v)`. World space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Disk {
    pub center: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub material: u32,
    pub importance: bool,
}

impl Shape for Disk {
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
        // The parallelogram around the ellipse holds it.
        let (u, v) = (self.u, self.v);
        [u + v, u - v, v - u, -u - v]
            .into_iter()
            .fold(0.0, |extent, corner| {
                extent.max((self.center + corner).abs().max_element())
            })
    }
}

pub const DISK: PrimitiveKind = PrimitiveKind {
    name: "disk",
    array: "disks",
    module: shader_module!("disk"),
    layout: ErasedLayout::of::<PackedDisk>(),
    light_density: true,
    pack: |shapes: &Shapes| {
        shapes
            .disks
            .iter()
            .map(|d| PackedPrimitive::new(&PackedDisk::new(d), d.material, d.importance))
            .collect()
    },
    never_hit: || bytemuck::bytes_of(&PackedDisk::never_hit()).to_vec(),
    bounds: |bytes| {
        let disk: PackedDisk = bytemuck::pod_read_unaligned(bytes);
        let (c, u, v) = (
            glam::Vec3::from(disk.center),
            glam::Vec3::from(disk.u),
            glam::Vec3::from(disk.v),
        );
        // The ellipse's extent along each axis: |(u_i, v_i)|.
        let half = (u * u + v * v).powf(0.5);
        (c - half, c + half)
    },
    shading_normals: None,
    texture_uvs: None,
    uv_tangents: false,
    grouped_lights: false,
    // Its hit point (the ray meets it by a plane or sphere equation) errs by a
    // few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: false,
};

gpu_struct! {
    /// The plane and in-plane coordinate terms are precomputed here, once per disk.
    pub struct PackedDisk as Disk {
        pub center: [f32; 3],
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

impl PackedDisk {
    pub fn new(disk: &Disk) -> PackedDisk {
        let plane = PlaneTerms::new(disk.center, disk.u, disk.v);
        PackedDisk {
            center: disk.center.to_array(),
            material: disk.material,
            u: disk.u.to_array(),
            plane_d: plane.plane_d,
            v: disk.v.to_array(),
            area: std::f32::consts::PI * plane.span,
            normal: plane.normal.to_array(),
            w: plane.w.to_array(),
            ..PackedDisk::default()
        }
    }

    /// With NaN geometry every hit test fails.
    pub fn never_hit() -> PackedDisk {
        let nan = [f32::NAN; 3];
        PackedDisk {
            center: nan,
            u: nan,
            plane_d: f32::NAN,
            v: nan,
            area: f32::NAN,
            normal: nan,
            w: nan,
            ..PackedDisk::default()
        }
    }
}
