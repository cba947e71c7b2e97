//! Host mirrors of the WGSL structs, and packing a scene into them. Every struct
//! here is checked against naga's reading of the WGSL in `kernel::tests`.

use crate::scene::{Camera, MaterialKind, Scene};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A host struct with a WGSL twin of the same name and field order.
pub trait GpuLayout: Pod {
    const WGSL_NAME: &'static str;
    /// Field names and byte offsets, for the layout test.
    fn fields() -> Vec<(&'static str, usize)>;
    /// This value as a WGSL constant expression: the struct's constructor with
    /// every field in declaration order, bit-exact (see `WgslValue`).
    fn wgsl_value(&self) -> String;
}

/// A field value written as an exact WGSL constant expression, so the kernel
/// sees exactly what a buffer would hold. Floats use Rust's shortest
/// round-trip form with the `f` suffix (parsed as f32 directly, not rounded
/// twice through an abstract float); they must be finite.
pub trait WgslValue {
    fn wgsl_value(&self) -> String;
}

impl WgslValue for u32 {
    fn wgsl_value(&self) -> String {
        format!("{self}u")
    }
}

impl WgslValue for f32 {
    fn wgsl_value(&self) -> String {
        assert!(self.is_finite(), "{self} has no WGSL literal");
        format!("{self:?}f")
    }
}

impl<T: WgslValue, const N: usize> WgslValue for [T; N] {
    fn wgsl_value(&self) -> String {
        let components: Vec<String> = self.iter().map(WgslValue::wgsl_value).collect();
        let scalar = std::any::type_name::<T>();
        format!("vec{N}<{scalar}>({})", components.join(", "))
    }
}

macro_rules! gpu_struct {
    ($(#[$meta:meta])* pub struct $name:ident { $($(#[$field_meta:meta])* pub $field:ident : $ty:ty,)* }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
        pub struct $name { $($(#[$field_meta])* pub $field: $ty,)* }

        impl GpuLayout for $name {
            const WGSL_NAME: &'static str = stringify!($name);
            fn fields() -> Vec<(&'static str, usize)> {
                vec![$((stringify!($field), std::mem::offset_of!($name, $field)),)*]
            }
            fn wgsl_value(&self) -> String {
                let fields: Vec<String> = vec![$(WgslValue::wgsl_value(&self.$field),)*];
                format!("{}({})", stringify!($name), fields.join(", "))
            }
        }
    };
}

gpu_struct! {
    /// Per-dispatch uniform: camera, image, sample range and tile.
    pub struct Params {
        pub origin: [f32; 3],
        pub width: u32,
        /// From `origin` to the centre of pixel (0, 0) (see `CameraFrame`).
        pub to_pixel00: [f32; 3],
        pub height: u32,
        pub delta_u: [f32; 3],
        pub sample_start: u32,
        pub delta_v: [f32; 3],
        pub sample_count: u32,
        pub background: [f32; 3],
        pub seed: u32,
        pub tile_origin: [u32; 2],
        pub tile_size: [u32; 2],
        pub ray_offset: f32,
        pub reset: u32,
        pub zero_bits: u32,
        pub _pad1: u32,
    }
}

gpu_struct! {
    pub struct Counters {
        pub discarded: u32,
        pub truncated: u32,
        pub segments_low: u32,
        pub segments_high: u32,
    }
}

impl Counters {
    /// Ray segments traced so far.
    pub fn segments(&self) -> u64 {
        (self.segments_high as u64) << 32 | self.segments_low as u64
    }
}

gpu_struct! {
    pub struct Material {
        pub albedo: [f32; 3],
        pub kind: u32,
        pub emit: [f32; 3],
        pub param: f32,
    }
}

gpu_struct! {
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

impl Quad {
    /// Binds where a kernel declares quads but the scene has none: with NaN
    /// geometry every hit test fails.
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

impl Sphere {
    /// As `Quad::never_hit`.
    pub fn never_hit() -> Sphere {
        Sphere {
            center: [f32::NAN; 3],
            radius: f32::NAN,
            ..Sphere::default()
        }
    }
}

/// Material kinds as the kernel numbers them (`MATERIAL_*` in materials.wgsl).
pub const MATERIAL_LAMBERTIAN: u32 = 0;
pub const MATERIAL_METAL: u32 = 1;
pub const MATERIAL_DIELECTRIC: u32 = 2;
pub const MATERIAL_LIGHT: u32 = 3;

/// Ray origins leave a surface by this fraction of the scene's extent.
pub const RAY_OFFSET_RELATIVE: f32 = 1e-5;

/// The scene as the kernel sees it: only what is present, tightly packed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneData {
    pub materials: Vec<Material>,
    pub quads: Vec<Quad>,
    pub spheres: Vec<Sphere>,
    /// Copies of the primitives in the light density.
    pub light_quads: Vec<Quad>,
    pub light_spheres: Vec<Sphere>,
}

impl SceneData {
    pub fn pack(scene: &Scene) -> SceneData {
        let materials = scene.materials.iter().map(pack_material).collect();
        // A dielectric of ior 1 bends and reflects nothing: it is left out of the
        // geometry (it may still guide sampling if marked for importance).
        let invisible = |material: u32| matches!(scene.materials[material as usize].kind, MaterialKind::Dielectric { ior } if ior == 1.0);
        let mut data = SceneData {
            materials,
            ..SceneData::default()
        };
        for quad in &scene.quads {
            let packed = pack_quad(quad.q, quad.u, quad.v, quad.material);
            if !invisible(quad.material) {
                data.quads.push(packed);
            }
            if quad.importance {
                data.light_quads.push(packed);
            }
        }
        for sphere in &scene.spheres {
            let packed = Sphere {
                center: sphere.center.to_array(),
                radius: sphere.radius,
                material: sphere.material,
                ..Sphere::default()
            };
            if !invisible(sphere.material) {
                data.spheres.push(packed);
            }
            if sphere.importance {
                data.light_spheres.push(packed);
            }
        }
        data
    }

    /// Drops non-emitting objects from the light density.
    pub fn keep_emitting_lights(&mut self) {
        let materials = &self.materials;
        let emits = |material: u32| materials[material as usize].emit.iter().any(|&e| e > 0.0);
        self.light_quads.retain(|q| emits(q.material));
        self.light_spheres.retain(|s| emits(s.material));
    }

    /// Whether every float is finite (has a WGSL literal, so it can be baked).
    pub fn is_finite(&self) -> bool {
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        let quad = |q: &Quad| {
            finite(&[q.plane_d, q.area]) && [q.q, q.u, q.v, q.normal, q.w].iter().all(|v| finite(v))
        };
        let sphere = |s: &Sphere| finite(&s.center) && s.radius.is_finite();
        self.materials
            .iter()
            .all(|m| finite(&m.albedo) && finite(&m.emit) && m.param.is_finite())
            && self.quads.iter().chain(&self.light_quads).all(quad)
            && self.spheres.iter().chain(&self.light_spheres).all(sphere)
    }

    pub fn light_count(&self) -> usize {
        self.light_quads.len() + self.light_spheres.len()
    }

    /// Whether any material of `kind` is referenced by geometry the kernel sees.
    pub fn uses_material(&self, kind: u32) -> bool {
        let used = |material: u32| self.materials[material as usize].kind == kind;
        self.quads.iter().any(|q| used(q.material)) || self.spheres.iter().any(|s| used(s.material))
    }
}

fn pack_material(material: &crate::scene::Material) -> Material {
    let (kind, param) = match material.kind {
        MaterialKind::Lambertian => (MATERIAL_LAMBERTIAN, 0.0),
        MaterialKind::Metal { fuzz } => (MATERIAL_METAL, fuzz),
        MaterialKind::Dielectric { ior } => (MATERIAL_DIELECTRIC, ior),
        MaterialKind::Light => (MATERIAL_LIGHT, 0.0),
    };
    Material {
        albedo: material.albedo.to_array(),
        kind,
        emit: material.emit.to_array(),
        param,
    }
}

fn pack_quad(q: Vec3, u: Vec3, v: Vec3, material: u32) -> Quad {
    let n = u.cross(v);
    let normal = n.normalize();
    Quad {
        q: q.to_array(),
        material,
        u: u.to_array(),
        plane_d: normal.dot(q),
        v: v.to_array(),
        area: n.length(),
        normal: normal.to_array(),
        w: (n / n.dot(n)).to_array(),
        ..Quad::default()
    }
}

/// Camera terms of `Params`: the book's camera, focus distance 1.
pub struct CameraFrame {
    pub origin: Vec3,
    /// From `origin` to the centre of pixel (0, 0) on the image plane. Relative, not
    /// a point: the image plane is 1 from the eye whatever the scene's scale, and
    /// a point there, next to a large `origin`, would lose the pixel grid to
    /// rounding (at `lookfrom` 8e6 the f32 spacing is 0.5, coarser than the pixels).
    pub to_pixel00: Vec3,
    pub delta_u: Vec3,
    pub delta_v: Vec3,
}

impl CameraFrame {
    pub fn new(camera: &Camera) -> CameraFrame {
        let viewport_height = 2.0 * (camera.vfov_degrees.to_radians() / 2.0).tan();
        let viewport_width = viewport_height * camera.width as f32 / camera.height as f32;
        let w = (camera.lookfrom - camera.lookat).normalize();
        let u = camera.vup.cross(w).normalize();
        let v = w.cross(u);
        let viewport_u = viewport_width * u;
        let viewport_v = -viewport_height * v;
        let delta_u = viewport_u / camera.width as f32;
        let delta_v = viewport_v / camera.height as f32;
        let to_upper_left = -w - viewport_u / 2.0 - viewport_v / 2.0;
        CameraFrame {
            origin: camera.lookfrom,
            to_pixel00: to_upper_left + 0.5 * (delta_u + delta_v),
            delta_u,
            delta_v,
        }
    }
}
