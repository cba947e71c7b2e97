//! The application binary interface between the host and the WGSL kernels:
//! the host mirrors of WGSL structs (`GpuLayout`, written with `gpu_struct!`),
//! their exact WGSL constant values, and the binding numbers, layers and
//! constants both sides use. Knows nothing of scenes or devices; every layer
//! may use it. The kernel's generated constants (`kernel::glue`) are written
//! from these definitions, and every struct is checked against naga's reading
//! of the WGSL in `kernel::tests`.

use bytemuck::Pod;

/// A host struct with a WGSL twin of the same name and field order.
pub trait GpuLayout: Pod {
    const WGSL_NAME: &'static str;
    /// Field names, byte offsets and WGSL types, for the layout test and the
    /// kernel's accessors (`kernel::glue`).
    fn fields() -> Vec<(&'static str, usize, String)>;
    /// This value as a WGSL constant expression: the struct's constructor with
    /// every field in declaration order, bit-exact (see `WgslValue`).
    fn wgsl_value(&self) -> String;
    /// Whether every float field is finite (see `WgslValue`).
    fn is_finite(&self) -> bool;
}

/// A field value written as an exact WGSL constant expression, so the kernel
/// sees exactly what a buffer would hold. Floats use Rust's shortest
/// round-trip form with the `f` suffix (parsed as f32 directly, not rounded
/// twice through an abstract float); they must be finite.
pub trait WgslValue {
    /// Whether this is a scalar, so that an array of two to four is a vector.
    const SCALAR: bool;
    /// The WGSL type: a scalar's name; an array of two to four scalars is a
    /// vector, any other array a WGSL array.
    fn wgsl_type() -> String;
    fn wgsl_value(&self) -> String;
    fn is_finite(&self) -> bool;
}

impl WgslValue for u32 {
    const SCALAR: bool = true;
    fn wgsl_type() -> String {
        "u32".into()
    }
    fn wgsl_value(&self) -> String {
        format!("{self}u")
    }
    fn is_finite(&self) -> bool {
        true
    }
}

impl WgslValue for f32 {
    const SCALAR: bool = true;
    fn wgsl_type() -> String {
        "f32".into()
    }
    fn wgsl_value(&self) -> String {
        assert!(self.is_finite(), "{self} has no WGSL literal");
        format!("{self:?}f")
    }
    fn is_finite(&self) -> bool {
        f32::is_finite(*self)
    }
}

impl<T: WgslValue, const N: usize> WgslValue for [T; N] {
    const SCALAR: bool = false;
    fn wgsl_type() -> String {
        match T::SCALAR && (2..=4).contains(&N) {
            true => format!("vec{N}<{}>", T::wgsl_type()),
            false => format!("array<{}, {N}>", T::wgsl_type()),
        }
    }
    fn wgsl_value(&self) -> String {
        let components: Vec<String> = self.iter().map(WgslValue::wgsl_value).collect();
        format!("{}({})", Self::wgsl_type(), components.join(", "))
    }
    fn is_finite(&self) -> bool {
        self.iter().all(WgslValue::is_finite)
    }
}

/// A `#[repr(C)]` struct with its `GpuLayout`: `pub struct Name { ... }` is
/// the WGSL struct `Name`; `pub struct Name as Wgsl { ... }` the WGSL struct
/// `Wgsl` (a host type named for what it packs, such as `PackedQuad`).
macro_rules! gpu_struct {
    ($(#[$meta:meta])* pub struct $name:ident { $($body:tt)* }) => {
        $crate::abi::gpu_struct! { $(#[$meta])* pub struct $name as $name { $($body)* } }
    };
    ($(#[$meta:meta])* pub struct $name:ident as $wgsl:ident { $($(#[$field_meta:meta])* pub $field:ident : $ty:ty,)* }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name { $($(#[$field_meta])* pub $field: $ty,)* }

        impl $crate::abi::GpuLayout for $name {
            const WGSL_NAME: &'static str = stringify!($wgsl);
            fn fields() -> Vec<(&'static str, usize, String)> {
                vec![$((
                    stringify!($field),
                    std::mem::offset_of!($name, $field),
                    <$ty as $crate::abi::WgslValue>::wgsl_type(),
                ),)*]
            }
            fn wgsl_value(&self) -> String {
                let fields: Vec<String> = vec![$($crate::abi::WgslValue::wgsl_value(&self.$field),)*];
                format!("{}({})", stringify!($wgsl), fields.join(", "))
            }
            fn is_finite(&self) -> bool {
                true $(&& $crate::abi::WgslValue::is_finite(&self.$field))*
            }
        }
    };
}
pub(crate) use gpu_struct;

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
        /// Adaptive sampling: entries of the active-pixel list this dispatch covers.
        pub active_count: u32,
        /// The dispatch's workgroup row `r` covers the tile's row of workgroups
        /// `r × step mod rows` (`render::workgroup_row_step`).
        pub workgroup_row_step: u32,
        /// The thin lens's radius (`CameraFrame`; 0 and unread for a pinhole).
        pub lens_radius: f32,
        /// The thin lens's distance to the plane in focus (unread for a pinhole).
        pub focus_distance: f32,
        /// Adaptive sampling with a splatting filter: 1 where this dispatch's
        /// samples go to the splatting pass (a uniform round), 0 where they are
        /// added to their pixel's sums with drawn offsets (`kernel.wgsl`).
        pub splatting: u32,
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
    /// One stage's counts in a profiling kernel (`kernel::Stage`): the lanes
    /// that ran it, and the lanes of the SIMD groups (subgroups) that ran it,
    /// active or not; each a 64-bit count in two words.
    pub struct StageCounts {
        pub lanes_low: u32,
        pub lanes_high: u32,
        pub slots_low: u32,
        pub slots_high: u32,
    }
}

impl StageCounts {
    /// Times a lane ran the stage.
    pub fn lanes(&self) -> u64 {
        (self.lanes_high as u64) << 32 | self.lanes_low as u64
    }

    /// Lanes of the SIMD groups that ran it: what it cost the device.
    pub fn slots(&self) -> u64 {
        (self.slots_high as u64) << 32 | self.slots_low as u64
    }
}

gpu_struct! {
    /// Every material kind packs into this; what each field holds for each kind
    /// is said once, in its kind's file (`src/kinds/material/`).
    pub struct PackedMaterial as Material {
        pub albedo: [f32; 3],
        /// Index into `kinds::MATERIAL_KINDS`.
        pub kind: u32,
        pub emit: [f32; 3],
        pub param: f32,
        pub color2: [f32; 3],
        pub param2: f32,
        pub color3: [f32; 3],
        /// Bits of [`MATERIAL_FLAGS`].
        pub flags: u32,
    }
}

/// The bits of `Material::flags`, shared with WGSL (generated constants).
pub const MATERIAL_FLAGS: &[(&str, u32)] = &[
    // The Beckmann distribution (else GGX).
    ("MATERIAL_BECKMANN", 1),
    // Mitsuba's `nonlinear` for plastics.
    ("MATERIAL_NONLINEAR", 2),
    // Scatters only on the side its normal faces.
    ("MATERIAL_ONE_SIDED", 4),
    // Its bump texture (`kinds::Bump`) is a normal map, not a height field.
    ("MATERIAL_NORMAL_MAP", 8),
    // Its opacity is a texture, whose index + 1 the transparency's bits of
    // `kind` hold (`kinds::MATERIAL_TRANSPARENCY_SHIFT`).
    ("MATERIAL_OPACITY_TEXTURE", 16),
    // Some of its numbers are textures: `material_tables` holds, at the
    // material's index, the offset of their list
    // (`kinds::MaterialTables::with_number_directory`).
    ("MATERIAL_TEXTURED_NUMBERS", 32),
];

/// The value of the bit named `name` of [`MATERIAL_FLAGS`].
pub fn material_flag(name: &str) -> u32 {
    MATERIAL_FLAGS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|&(_, bit)| bit)
        .expect("a material flag")
}

/// Rec. 709 luminance weights, Y of linear sRGB (Mitsuba's `luminance`): how
/// bright a colour looks, wherever pathmix weighs one (a bitmap read as a
/// number, a light's or texel's share of the samples, the error metrics). The
/// kernel's `LUMINANCE`.
pub const LUMINANCE: [f32; 3] = [0.212671, 0.715160, 0.072169];

/// Ray origins leave a surface by this fraction of the scene's extent, times
/// its kind's `ray_offset_factor`.
pub const RAY_OFFSET_RELATIVE: f32 = 1e-6;

/// Frame bindings (group 0), declared in common.wgsl and accumulate_*.wgsl.
pub const BINDING_PARAMS: u32 = 0;
pub const BINDING_ACCUMULATOR: u32 = 1;
pub const BINDING_COUNTERS: u32 = 2;
/// Only in an adaptive kernel: the active-pixel list (kernel.wgsl).
pub const BINDING_ACTIVE_PIXELS: u32 = 3;
/// Only in a splatting kernel: the submission's samples (sums.wgsl).
pub const BINDING_SPLAT_SAMPLES: u32 = 4;
/// Bytes of one sample there (`SplatSample`: radiance and position, 5 × f32).
pub const SPLAT_SAMPLE_BYTES: u64 = 20;
/// Rows of the column of pixels one invocation of the splatting pass gathers
/// (`shaders/splat.wgsl`, written out for 4).
pub const SPLAT_STRIP_ROWS: u32 = 4;
/// The splatting pass's entry point (`shaders/splat.wgsl`).
pub const SPLAT_ENTRY_POINT: &str = "splat";
/// Only in a profiling kernel: its `StageCounts`, one per `kernel::Stage`
/// (profile.wgsl).
pub const BINDING_PROFILE: u32 = 5;

/// The accumulator's layers: each running sum and its Kahan compensation (the
/// sum minus the compensation is the sum without the rounding losses).
pub const LAYER_SUM: u32 = 0;
pub const LAYER_SUM_COMPENSATION: u32 = 1;
/// Only with variance on: the sum of squared samples.
pub const LAYER_SQUARES: u32 = 2;
pub const LAYER_SQUARES_COMPENSATION: u32 = 3;
/// With variance on and the Sobol sampler: from this layer on, the sums of
/// replicates 1 to `REPLICATES - 1`, each followed by its compensation (replicate
/// 0's sum is the total minus theirs).
pub const LAYER_REPLICATES: u32 = 4;
/// Independently scrambled replicates a pixel's Sobol samples are split into
/// (sample i in replicate i mod REPLICATES): their means' spread is the error
/// estimate, with REPLICATES - 1 degrees of freedom per pixel.
pub const REPLICATES: u32 = 4;

/// Layer of replicate `r`'s sum (1 <= r < REPLICATES); its compensation follows.
pub fn replicate_layer(r: u32) -> u32 {
    LAYER_REPLICATES + 2 * (r - 1)
}

/// The error estimate's kernel (`shaders/error_estimate.wgsl`): binding of the
/// strips' sums (group 0; the accumulator at its kernel binding).
pub const BINDING_ERROR_STRIPS: u32 = 2;
/// Pixels of a row one invocation sums: few enough that f32 keeps the sums to
/// about 1e-5, many enough that the strips are a small readback.
pub const ERROR_STRIP_PIXELS: u32 = 64;
/// Rows a workgroup takes, one per invocation.
pub const ERROR_WORKGROUP_SIZE: u32 = 64;

/// The error estimate kernel's entry point.
pub const ERROR_ENTRY_POINT: &str = "estimate_error";

gpu_struct! {
    pub struct EstimateParams {
        pub width: u32,
        pub height: u32,
        pub samples: u32,
        pub strips: u32,
        pub replicate_samples: [u32; REPLICATES as usize],
    }
}

gpu_struct! {
    /// One strip's sums over its pixels and channels.
    pub struct ErrorStrip {
        pub mean: f32,
        pub squared_error: f32,
        pub non_finite: u32,
    }
}

/// Texels a row of a scene array bound as a texture (`gpu::texture_array`): a
/// power of two, so the kernel finds a texel's row and column by a shift and
/// a mask.
pub const TEXTURE_ARRAY_WIDTH: u32 = 4096;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_are_wgsl_vectors_or_arrays() {
        assert_eq!(
            [1.5f32, 2.0, 0.25].wgsl_value(),
            "vec3<f32>(1.5f, 2.0f, 0.25f)"
        );
        assert_eq!(
            [[1u32, 2], [3, 4]].wgsl_value(),
            "array<vec2<u32>, 2>(vec2<u32>(1u, 2u), vec2<u32>(3u, 4u))"
        );
        assert_eq!(<[f32; 5]>::wgsl_type(), "array<f32, 5>");
    }
}
