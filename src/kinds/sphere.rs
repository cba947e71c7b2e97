//! Spheres, with outward normals.
//!
//! ```toml
//! [[objects]]
//! type = "sphere"
//! center = [190, 90, 190]
//! radius = 90          # > 0
//! material = "glass"
//! ```
//!
//! `center` (vector, required) and `radius` (float > 0, required) with an
//! object's common keys (`material`, `importance`, the transform: the centre
//! is moved, the radius scaled; only a uniform scale, or it would be an
//! ellipsoid). A sphere whose coordinates or radius 32-bit floats cannot hold
//! is refused, and so is a sphere light smaller than 32-bit float directions
//! can aim at (docs/limits.md, "Small sphere lights"). Texture coordinates: `(phi / 2 pi, theta / pi)` about its centre,
//! theta from +z, phi from +x toward +y (world axes). Mitsuba's `sphere`
//! becomes one. WGSL: `shaders/sphere.wgsl`.

use super::params::{ParamTable, Result, check_positive, fmt_num, ok};
use super::transform::Transform;
use super::{
    ErasedLayout, ObjectType, PackedPrimitive, PrimitiveKind, Shape, Shapes, usable_length_squared,
};
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

    fn scale(&mut self, factor: f32) {
        self.center *= factor;
        self.radius *= factor;
    }

    fn problem(&self) -> Option<String> {
        if !self.center.is_finite() {
            return Some("coordinates overflow a 32-bit float".to_string());
        }
        if !(self.radius > 0.0 && usable_length_squared(self.radius * self.radius)) {
            return Some(format!(
                "radius {} is out of the range 32-bit float arithmetic can handle",
                fmt_num(self.radius)
            ));
        }
        None
    }
}

fn parse(
    t: &ParamTable,
    xf: &Transform,
    material: u32,
    importance: bool,
    shapes: &mut Shapes,
) -> Result<()> {
    let center = t.require("center", t.vec3("center", ok)?)?;
    let radius = t.require("radius", t.float("radius", check_positive)?)?;
    let Some(scale) = xf.uniform_scale() else {
        return Err(t.err(
            t.here(),
            "a sphere cannot take a non-uniform scale (it would be an ellipsoid)",
        ));
    };
    let sphere = Sphere {
        center: xf.point(center.as_dvec3()),
        radius: (f64::from(radius) * scale) as f32,
        material,
        importance,
    };
    if let Some(p) = sphere.problem() {
        return Err(t.err(t.here(), p));
    }
    shapes.spheres.push(sphere);
    Ok(())
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
    grouped_lights: false,
    // Its hit point, reprojected onto the sphere, errs by a few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: true,
    keeps_primitive: false,
    light_importance: true,
    constant_test: false,
    object: Some(ObjectType {
        keys: &["center", "radius"],
        parse,
    }),
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

#[cfg(test)]
mod tests {
    use super::super::read_object;
    use super::*;

    #[test]
    fn reads_a_placed_sphere_under_a_uniform_scale_only() {
        let sphere = |body: &str| read_object(&SPHERE, body).map(|shapes| shapes.spheres);
        // Scaled by 3, then turned a quarter about y: +x goes to -z.
        let spheres = sphere("center = [1, 0, 0]\nradius = 2\nscale = 3\nrotate_y = 90").unwrap();
        assert_eq!(
            (spheres[0].center, spheres[0].radius),
            (Vec3::new(0.0, 0.0, -3.0), 6.0)
        );
        let e = sphere("center = [0, 0, 0]\nradius = 1\nscale = [1, 2, 1]").unwrap_err();
        assert_eq!(
            e.to_string(),
            "scenes/x.toml: objects[0]: a sphere cannot take a non-uniform scale (it would be \
             an ellipsoid)"
        );
        let e = sphere("center = [0, 0, 0]\nradius = 1e-30").unwrap_err();
        assert!(
            e.message.starts_with("radius 1e-30 is out of the range"),
            "{e}"
        );
    }
}
