//! Triangles: the faces of meshes. Scene files make them by `mesh` objects,
//! which the scene reads (mesh files, their transforms and materials): no
//! object type makes one triangle. WGSL: `shaders/triangle.wgsl`.

use super::{
    DEGENERATE, ErasedLayout, NO_LIGHT, PackedPrimitive, PrimitiveKind, Shape, Shapes,
    usable_length_squared,
};
use crate::abi::gpu_struct;
use crate::shader::shader_module;
use glam::Vec3;
use serde::Serialize;

/// A mesh face, world space; normal `normalize((v1 - v0) x (v2 - v0))`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Triangle {
    pub vertices: [Vec3; 3],
    /// Unit shading normals at the vertices, interpolated across the face (a
    /// smooth mesh); `None`: shaded with the face normal.
    pub normals: Option<[Vec3; 3]>,
    /// Texture coordinates at the vertices (v down the image, as Mitsuba's);
    /// `None`: Mitsuba's default, the barycentric (b1, b2).
    pub uvs: Option<[glam::Vec2; 3]>,
    pub material: u32,
    pub importance: bool,
    /// The index of the mesh object it belongs to: its group in the light density.
    pub mesh: u32,
}

impl Triangle {
    pub fn area(&self) -> f32 {
        let [a, b, c] = self.vertices;
        0.5 * (b - a).cross(c - a).length()
    }

    /// No usable area in 32-bit floats (collinear or coincident vertices): it
    /// can be neither hit nor sampled, so the scene drops it and counts it.
    pub(crate) fn is_degenerate(&self) -> bool {
        let [a, b, c] = self.vertices;
        let (e1, e2) = ((b - a).as_dvec3(), (c - a).as_dvec3());
        let n = e1.cross(e2);
        !usable_length_squared(n.as_vec3().length_squared())
            || n.length() <= DEGENERATE * e1.length() * e2.length()
    }
}

impl Shape for Triangle {
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
        self.vertices
            .into_iter()
            .fold(0.0, |extent, v| extent.max(v.abs().max_element()))
    }

    fn scale(&mut self, factor: f32) {
        for v in &mut self.vertices {
            *v *= factor;
        }
    }

    /// None: a degenerate face is dropped (`Triangle::is_degenerate`), not refused.
    fn problem(&self) -> Option<String> {
        None
    }
}

pub const TRIANGLE: PrimitiveKind = PrimitiveKind {
    name: "triangle",
    array: "triangles",
    module: shader_module!("triangle"),
    layout: ErasedLayout::of::<PackedTriangle>(),
    light_density: true,
    pack: |shapes: &Shapes| {
        shapes
            .triangles
            .iter()
            .map(|t| PackedPrimitive {
                normals: bytemuck::bytes_of(&TriangleNormals::new(t)).to_vec(),
                smooth: t.normals.is_some(),
                uvs: bytemuck::bytes_of(&TriangleUvs::new(t)).to_vec(),
                light_group: Some((t.mesh, t.area())),
                ..PackedPrimitive::new(&PackedTriangle::new(t), t.material, t.importance)
            })
            .collect()
    },
    never_hit: || {
        let nan = [f32::NAN; 3];
        let never = PackedTriangle {
            p0: nan,
            p1: nan,
            p2: nan,
            ..PackedTriangle::default()
        };
        bytemuck::bytes_of(&never).to_vec()
    },
    bounds: |bytes| {
        let t: PackedTriangle = bytemuck::pod_read_unaligned(bytes);
        let [a, b, c] = [t.p0, t.p1, t.p2].map(Vec3::from);
        (a.min(b).min(c), a.max(b).max(c))
    },
    shading_normals: Some(ErasedLayout::of::<TriangleNormals>()),
    texture_uvs: Some(ErasedLayout::of::<TriangleUvs>()),
    grouped_lights: true,
    // The watertight test's distance errs by the triangle's length over its
    // width: under a uniform sky, slivers of 200 to 800 to one as long as the
    // scene hit themselves at 1x (up to 8% of the light lost), never at 10x.
    ray_offset_factor: 10.0,
    reprojects_hit_point: false,
    keeps_primitive: false,
    light_importance: false,
    constant_test: true,
    object: None,
};

gpu_struct! {
    /// The vertices only: the face normal and area are computed where needed
    /// (at the closest hit, in the light density), which costs less than the
    /// memory traffic of storing them. Each vertex fills a 16-byte slot, so the
    /// kernel reads a triangle in three loads: lavapipe loads a storage buffer
    /// lane by lane once per load instruction, whatever its width, and ten
    /// 4-byte loads (the 40-byte packing of `array<f32, 3>` vertices) cost more
    /// than the 8 bytes saved.
    pub struct PackedTriangle as Triangle {
        pub p0: [f32; 3],
        pub material: u32,
        pub p1: [f32; 3],
        /// Its index in the light array, or `NO_LIGHT` (`PrimitiveKind::light_field`).
        pub light: u32,
        pub p2: [f32; 3],
        pub _pad2: u32,
    }
}

impl PackedTriangle {
    pub fn new(triangle: &Triangle) -> PackedTriangle {
        let [p0, p1, p2] = triangle.vertices.map(|p| p.to_array());
        PackedTriangle {
            p0,
            p1,
            p2,
            material: triangle.material,
            light: NO_LIGHT,
            ..PackedTriangle::default()
        }
    }
}

gpu_struct! {
    /// A smooth triangle's vertex normals, octahedral-encoded (`oct_encode`).
    pub struct TriangleNormals {
        pub n0: u32,
        pub n1: u32,
        pub n2: u32,
    }
}

impl TriangleNormals {
    /// The vertex normals of `triangle`, or its face normal at every vertex if it
    /// is flat; a zero normal (a vertex of degenerate faces only, or one the file
    /// gives as zero) becomes the face normal.
    fn new(triangle: &Triangle) -> TriangleNormals {
        let [a, b, c] = triangle.vertices;
        let face = (b - a).cross(c - a).normalize();
        let normals = triangle.normals.unwrap_or([face; 3]);
        let [n0, n1, n2] = normals.map(|n| oct_encode(if n == Vec3::ZERO { face } else { n }));
        TriangleNormals { n0, n1, n2 }
    }
}

gpu_struct! {
    /// A face's texture coordinates at its vertices.
    pub struct TriangleUvs {
        pub uv0: [f32; 2],
        pub uv1: [f32; 2],
        pub uv2: [f32; 2],
    }
}

impl TriangleUvs {
    /// The face's vertex uvs, or Mitsuba's default for a mesh without: (0, 0),
    /// (1, 0), (0, 1), which interpolate to the barycentric (b1, b2).
    fn new(triangle: &Triangle) -> TriangleUvs {
        let [uv0, uv1, uv2] = triangle
            .uvs
            .unwrap_or([glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y])
            .map(|uv| uv.to_array());
        TriangleUvs { uv0, uv1, uv2 }
    }
}

/// A unit vector in 32 bits: the octahedral map (Cigolle et al. 2014) with two
/// signed 16-bit components, as WGSL's `unpack2x16snorm` reads them (x in the
/// low half). Worst-case error about 0.005 degrees.
pub fn oct_encode(n: Vec3) -> u32 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    let (x, y) = if n.z >= 0.0 {
        (n.x, n.y)
    } else {
        ((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
    };
    let snorm = |v: f32| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16 as u16 as u32;
    snorm(x) | snorm(y) << 16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inverse of [`oct_encode`], as `triangle.wgsl` decodes.
    fn oct_decode(bits: u32) -> Vec3 {
        let unorm = |v: u32| (v as u16 as i16 as f32 / 32767.0).max(-1.0);
        let (x, y) = (unorm(bits & 0xffff), unorm(bits >> 16));
        let z = 1.0 - x.abs() - y.abs();
        let t = (-z).max(0.0);
        let shift = |v: f32| if v >= 0.0 { v - t } else { v + t };
        Vec3::new(shift(x), shift(y), z).normalize()
    }

    #[test]
    fn octahedral_normals_round_trip_within_a_hundredth_of_a_degree() {
        let mut worst: f32 = 0.0;
        let mut directions = vec![
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ];
        // A Fibonacci sphere covers both hemispheres and every octant.
        let n = 20_000;
        for i in 0..n {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            directions.push(Vec3::new(r * phi.cos(), r * phi.sin(), z));
        }
        for d in directions {
            let back = oct_decode(oct_encode(d));
            // atan2 of sine and cosine keeps small angles exact, where acos does not.
            let angle = d.cross(back).length().atan2(d.dot(back));
            worst = worst.max(angle.to_degrees());
        }
        assert!(worst < 0.01, "worst error {worst} degrees");
    }
}
