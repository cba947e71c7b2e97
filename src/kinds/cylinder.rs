//! Open cylinders (no caps), as Mitsuba 3's `cylinder`: the points at distance
//! `radius` from the segment `p0`-`p1`, normal away from the axis.
//!
//! ```toml
//! [[objects]]
//! type = "cylinder"
//! p0 = [0, 0, 0]        # the axis' ends
//! p1 = [0, 2, 0]
//! radius = 0.5          # > 0
//! flip_normals = false  # true: the normals point toward the axis
//! material = "lamp"
//! ```
//!
//! `p0`, `p1` (vectors, required, distinct), `radius` (float > 0, required) and
//! `flip_normals` (bool, default false) with an object's common keys
//! (`material`, `importance`, the transform: the ends are moved, the radius
//! scaled; a transform that would make the cross-section an ellipse, or slant
//! it, is refused: it may scale along the axis, and across it only alike). The
//! side the normal points to is its front: an emitting cylinder emits there
//! only, and a one-sided material is black from behind, as in Mitsuba, whose
//! `twosided` makes the inside visible. As a light it is sampled uniformly by
//! area. Texture coordinates, Mitsuba's: `(phi / 2 pi, h)` of the point `p0 +
//! h (p1 - p0) + radius (cos phi s + sin phi t)`, `(s, t)` Mitsuba's
//! `coordinate_system` of the axis' direction. Bump and normal maps turn about
//! Mitsuba's tangents: `dp_du` is `2 pi` times the offset from the axis turned a
//! quarter turn from `s` toward `t`, `dp_dv` is `p1 - p0`. Mitsuba's `cylinder` becomes
//! one. WGSL: `shaders/cylinder.wgsl`.

use super::params::{ParamTable, Result, check_positive, fmt_num, fmt_vec, ok};
use super::transform::{Transform, coordinate_system};
use super::{
    ErasedLayout, ObjectType, PackedPrimitive, PrimitiveKind, Shape, Shapes, usable_length_squared,
};
use crate::abi::gpu_struct;
use crate::shader::shader_module;
use glam::Vec3;
use serde::Serialize;

/// World space; the normal points away from the axis, or toward it with
/// `flip_normals`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Cylinder {
    pub p0: Vec3,
    pub p1: Vec3,
    pub radius: f32,
    pub flip_normals: bool,
    pub material: u32,
    pub importance: bool,
}

impl Shape for Cylinder {
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
        self.p0.abs().max(self.p1.abs()).max_element() + self.radius
    }

    fn scale(&mut self, factor: f32) {
        self.p0 *= factor;
        self.p1 *= factor;
        self.radius *= factor;
    }

    fn problem(&self) -> Option<String> {
        if !(self.p0.is_finite() && self.p1.is_finite()) {
            return Some("coordinates overflow a 32-bit float".to_string());
        }
        if !usable_length_squared((self.p1 - self.p0).length_squared()) {
            return Some(format!(
                "degenerate cylinder: p0 = {} and p1 = {} are (nearly) the same point",
                fmt_vec(self.p0),
                fmt_vec(self.p1)
            ));
        }
        if !(self.radius > 0.0 && usable_length_squared(self.radius * self.radius)) {
            return Some(format!(
                "radius {} is out of the range 32-bit float arithmetic can handle",
                fmt_num(self.radius)
            ));
        }
        if !PackedCylinder::new(self).area.is_finite() {
            return Some("its area overflows a 32-bit float".to_string());
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
    let p0 = t.require("p0", t.vec3("p0", ok)?)?.as_dvec3();
    let p1 = t.require("p1", t.vec3("p1", ok)?)?.as_dvec3();
    let radius = t.require("radius", t.float("radius", check_positive)?)?;
    let flip_normals = t.boolean("flip_normals")?.unwrap_or(false);
    if p1 == p0 {
        return Err(t.err(t.at("p1"), "must differ from `p0` (the axis has no length)"));
    }
    let Some(scale) = xf.across(p1 - p0) else {
        return Err(t.err(
            t.here(),
            "a cylinder's transform must scale every direction across its axis alike and \
             keep them across it (a shear or an uneven scale would make it elliptic or slanted)",
        ));
    };
    let cylinder = Cylinder {
        p0: xf.point(p0),
        p1: xf.point(p1),
        radius: (f64::from(radius) * scale) as f32,
        flip_normals,
        material,
        importance,
    };
    if let Some(p) = cylinder.problem() {
        return Err(t.err(t.here(), p));
    }
    shapes.cylinders.push(cylinder);
    Ok(())
}

pub const CYLINDER: PrimitiveKind = PrimitiveKind {
    name: "cylinder",
    array: "cylinders",
    module: shader_module!("cylinder"),
    layout: ErasedLayout::of::<PackedCylinder>(),
    light_density: true,
    pack: |shapes: &Shapes| {
        shapes
            .cylinders
            .iter()
            .map(|c| PackedPrimitive::new(&PackedCylinder::new(c), c.material, c.importance))
            .collect()
    },
    never_hit: || bytemuck::bytes_of(&PackedCylinder::never_hit()).to_vec(),
    bounds: |bytes| {
        let c: PackedCylinder = bytemuck::pod_read_unaligned(bytes);
        let p0 = Vec3::from(c.p0);
        let p1 = p0 + Vec3::from(c.dir) * c.length;
        // The end circles' extent along each axis, as Mitsuba bounds it.
        let (s, t) = (Vec3::from(c.s), Vec3::from(c.t));
        let half = c.radius * (s * s + t * t).powf(0.5);
        (p0.min(p1) - half, p0.max(p1) + half)
    },
    shading_normals: None,
    texture_uvs: None,
    grouped_lights: false,
    // Its hit point, reprojected onto the cylinder, errs by a few ulps of the extent.
    ray_offset_factor: 1.0,
    reprojects_hit_point: true,
    keeps_primitive: true,
    light_importance: false,
    constant_test: false,
    object: Some(ObjectType {
        keys: &["p0", "p1", "radius", "flip_normals"],
        parse,
    }),
};

gpu_struct! {
    /// The axis as a unit direction and a length, and Mitsuba's frame about it.
    pub struct PackedCylinder as Cylinder {
        pub p0: [f32; 3],
        pub material: u32,
        pub dir: [f32; 3],
        pub radius: f32,
        pub s: [f32; 3],
        pub length: f32,
        pub t: [f32; 3],
        pub area: f32,
        pub side: f32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

impl PackedCylinder {
    pub fn new(c: &Cylinder) -> PackedCylinder {
        let axis = (c.p1 - c.p0).as_dvec3();
        let length = axis.length();
        let dir = axis / length;
        let (s, t) = coordinate_system(dir);
        PackedCylinder {
            p0: c.p0.to_array(),
            material: c.material,
            dir: dir.as_vec3().to_array(),
            radius: c.radius,
            s: s.as_vec3().to_array(),
            length: length as f32,
            t: t.as_vec3().to_array(),
            area: (2.0 * std::f64::consts::PI * f64::from(c.radius) * length) as f32,
            side: if c.flip_normals { -1.0 } else { 1.0 },
            ..PackedCylinder::default()
        }
    }

    /// With NaN geometry every hit test fails.
    pub fn never_hit() -> PackedCylinder {
        let nan = [f32::NAN; 3];
        PackedCylinder {
            p0: nan,
            dir: nan,
            radius: f32::NAN,
            s: nan,
            length: f32::NAN,
            t: nan,
            area: f32::NAN,
            side: 1.0,
            ..PackedCylinder::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::read_object;
    use super::*;

    #[test]
    fn reads_a_placed_cylinder_and_refuses_an_elliptic_one() {
        let cylinder = |body: &str| read_object(&CYLINDER, body).map(|shapes| shapes.cylinders);
        let body = "p0 = [0, 0, 0]\np1 = [0, 0, 1]\nradius = 2";
        // Scaled along the axis by 5 and across it by 3, then moved.
        let c = cylinder(&format!("{body}\nscale = [3, 3, 5]\ntranslate = [1, 0, 0]")).unwrap();
        assert_eq!(
            (c[0].p0, c[0].p1, c[0].radius, c[0].flip_normals),
            (Vec3::X, Vec3::new(1.0, 0.0, 5.0), 6.0, false)
        );
        let c = cylinder(&format!("{body}\nflip_normals = true\nrotate_y = 90")).unwrap();
        assert_eq!((c[0].p1, c[0].flip_normals), (Vec3::X, true));
        assert_eq!(PackedCylinder::new(&c[0]).side, -1.0);
        let e = cylinder(&format!("{body}\nscale = [1, 2, 1]")).unwrap_err();
        assert_eq!(e.location, "objects[0]");
        assert!(
            e.message.starts_with("a cylinder's transform must scale"),
            "{e}"
        );
        let e = cylinder("p0 = [1, 2, 3]\np1 = [1, 2, 3]\nradius = 1").unwrap_err();
        assert_eq!(e.location, "objects[0].p1");
        let e = cylinder("p0 = [0, 0, 0]\np1 = [0, 0, 1]\nradius = 1e-30").unwrap_err();
        assert!(
            e.message.starts_with("radius 1e-30 is out of the range"),
            "{e}"
        );
        let e = cylinder("p0 = [0, 0, 0]\np1 = [0, 0, 1]\nradius = 0").unwrap_err();
        assert_eq!(e.location, "objects[0].radius");
    }

    #[test]
    fn packs_mitsubas_frame_and_area() {
        let c = Cylinder {
            p0: Vec3::new(1.0, 2.0, 3.0),
            p1: Vec3::new(1.0, 2.0, 7.0),
            radius: 0.5,
            flip_normals: false,
            material: 0,
            importance: true,
        };
        let packed = PackedCylinder::new(&c);
        // Mitsuba's coordinate_system of +z is (+x, +y).
        assert_eq!(
            (packed.dir, packed.s, packed.t),
            ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        );
        assert_eq!((packed.length, packed.side), (4.0, 1.0));
        assert!((packed.area - 4.0 * std::f32::consts::PI).abs() < 1e-6);
        let (lo, hi) = (CYLINDER.bounds)(bytemuck::bytes_of(&packed));
        assert_eq!(
            (lo, hi),
            (Vec3::new(0.5, 1.5, 3.0), Vec3::new(1.5, 2.5, 7.0))
        );
    }
}
