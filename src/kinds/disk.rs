//! Disks (ellipses under a general transform): `center + a u + b v` for
//! `a^2 + b^2 <= 1`, normal `normalize(u x v)`.
//!
//! ```toml
//! [[objects]]
//! type = "disk"
//! center = [0, 4, 0]
//! u = [1, 0, 0]     # perpendicular and as long: a disk of radius 1
//! v = [0, 0, -1]
//! material = "lamp"
//! ```
//!
//! `center`, `u`, `v` (vectors, required) with an object's common keys
//! (`material`, `importance`, the transform: the centre is moved, `u` and `v`
//! transformed). A disk of radius `r` for perpendicular `u` and `v` of length
//! `r`, an ellipse otherwise (as a transform leaves it). Degenerate `u`, `v` are
//! refused as for quads. As a light it is sampled uniformly by area. Texture
//! coordinates: `(r, phi / 2 pi)` of `center + r (cos phi u + sin phi v)`.
//! Mitsuba's `disk` becomes one. WGSL: `shaders/disk.wgsl`.

use super::params::{ParamTable, Result};
use super::quad::{PlaneTerms, planar, spanned_problem};
use super::transform::Transform;
use super::{ErasedLayout, ObjectType, PackedPrimitive, PrimitiveKind, Shape, Shapes};
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

    fn scale(&mut self, factor: f32) {
        self.center *= factor;
        self.u *= factor;
        self.v *= factor;
    }

    fn problem(&self) -> Option<String> {
        spanned_problem("disk", self.center, self.u, self.v)
    }
}

fn parse(
    t: &ParamTable,
    xf: &Transform,
    material: u32,
    importance: bool,
    shapes: &mut Shapes,
) -> Result<()> {
    let (center, u, v) = planar(t, xf, "center")?;
    let disk = Disk {
        center,
        u,
        v,
        material,
        importance,
    };
    if let Some(p) = disk.problem() {
        return Err(t.err(t.here(), p));
    }
    shapes.disks.push(disk);
    Ok(())
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
    grouped_lights: false,
    // Its hit point (the ray meets it by a plane or sphere equation) errs by a
    // few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: false,
    keeps_primitive: false,
    light_importance: true,
    constant_test: false,
    object: Some(ObjectType {
        keys: &["center", "u", "v"],
        parse,
    }),
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

#[cfg(test)]
mod tests {
    use super::super::read_object;
    use super::*;

    #[test]
    fn reads_a_placed_disk_and_refuses_one_without_area() {
        let disk = |body: &str| read_object(&DISK, body).map(|shapes| shapes.disks);
        let disks =
            disk("center = [1, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\nscale = [2, 3, 1]").unwrap();
        assert_eq!(
            (disks[0].center, disks[0].u, disks[0].v),
            (
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0)
            )
        );
        let e = disk("center = [0, 0, 0]\nu = [0, 0, 0]\nv = [0, 1, 0]").unwrap_err();
        assert_eq!(e.location, "objects[0]");
        assert!(e.message.starts_with("degenerate disk"), "{e}");
        let mut tiny = disks[0];
        tiny.scale(1e-30);
        assert!(tiny.problem().unwrap().starts_with("disk area"));
    }
}
