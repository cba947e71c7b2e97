//! Adapter choice and the device.

use super::pipeline::Kernel;
use crate::kernel::KernelConfig;
use crate::shader::ComposeError;
use std::sync::Mutex;

/// Why no device could be had, in words a user can act on.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (pathmix needs Vulkan, Metal or DirectX 12). Without a GPU, \
         install Mesa's software Vulkan driver (lavapipe): \
         `sudo apt-get install mesa-vulkan-drivers libvulkan1` on Debian/Ubuntu, \
         `sudo dnf install mesa-vulkan-drivers` on Fedora"
    )]
    NoAdapter,
    #[error(
        "no adapter's name contains `{wanted}` (the adapter filter, or PATHMIX_ADAPTER); \
         available: {}",
        .available.join("; ")
    )]
    NoMatchingAdapter {
        wanted: String,
        available: Vec<String>,
    },
    #[error("could not open the GPU device: {0}")]
    Device(#[from] wgpu::RequestDeviceError),
}

/// Most kernels `GpuContext::keep_kernels` keeps: a scene's strategies and
/// variance or adaptive variants, with room for a few scenes.
const KEPT_KERNELS: usize = 16;

/// An open device and what the renderer needs to know about it.
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Read-write `rgba32float` storage textures are available (else the buffer accumulator is used).
    pub storage_texture_accumulator: bool,
    /// The kernel reads a texture faster than a storage buffer: a CPU driver
    /// (Mesa's llvmpipe) on a CPU whose code has no AVX-512, where each lane's
    /// value of a buffer load passes through memory (`kernel::ArrayMemory`).
    pub textures_read_faster: bool,
    /// Subgroup operations, which a profiling kernel counts SIMD lanes with
    /// (`KernelConfig::profile`).
    pub subgroups: bool,
    /// Kernels built on this device, kept for renderers of the same config
    /// (`keep_kernels`); `None`: every renderer builds its own.
    kernels: Option<Mutex<Vec<Kernel>>>,
}

impl GpuContext {
    /// Opens the best adapter, or the first whose name contains `name_filter`
    /// (case-insensitive; `None` reads `PATHMIX_ADAPTER`).
    pub fn new(name_filter: Option<&str>) -> Result<GpuContext, GpuError> {
        let env_filter = std::env::var("PATHMIX_ADAPTER")
            .ok()
            .filter(|s| !s.is_empty());
        let filter = name_filter.map(str::to_string).or(env_filter);
        // WGPU_BACKEND may name backends; otherwise the native ones (not GL).
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        descriptor.backends = backends;
        let instance = wgpu::Instance::new(descriptor);
        let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        // Real GPUs first, software last; the order is stable otherwise.
        adapters.sort_by_key(|a| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        });
        let adapter = match &filter {
            None => adapters.swap_remove(0),
            Some(wanted) => {
                let wanted_lower = wanted.to_lowercase();
                match adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&wanted_lower))
                {
                    Some(index) => adapters.swap_remove(index),
                    None => {
                        return Err(GpuError::NoMatchingAdapter {
                            wanted: wanted.clone(),
                            available: adapters.iter().map(|a| describe(&a.get_info())).collect(),
                        });
                    }
                }
            }
        };
        Self::open(adapter)
    }

    fn open(adapter: wgpu::Adapter) -> Result<GpuContext, GpuError> {
        let info = adapter.get_info();
        let format = adapter.get_texture_format_features(wgpu::TextureFormat::Rgba32Float);
        let adapter_specific = wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        let storage_texture_accumulator = adapter.features().contains(adapter_specific)
            && format
                .flags
                .contains(wgpu::TextureFormatFeatureFlags::STORAGE_READ_WRITE);
        let mut required_features = wgpu::Features::empty();
        if storage_texture_accumulator {
            required_features |= adapter_specific;
        }
        let subgroups = adapter.features().contains(wgpu::Features::SUBGROUP);
        if subgroups {
            required_features |= wgpu::Features::SUBGROUP;
        }
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("pathmix"),
                required_features,
                // Large images need the adapter's full buffer and texture limits.
                required_limits: adapter.limits(),
                ..Default::default()
            }))?;
        let textures_read_faster =
            info.device_type == wgpu::DeviceType::Cpu && !cpu_driver_avx512();
        Ok(GpuContext {
            adapter,
            device,
            queue,
            info,
            storage_texture_accumulator,
            textures_read_faster,
            subgroups,
            kernels: None,
        })
    }

    /// Keeps the kernels built from now on, so that a renderer whose config
    /// equals an earlier one's reuses its pipelines instead of compiling them
    /// again: for a process that renders a scene many times (the Python
    /// package). The command line renders once and times its compiles, so it
    /// keeps none.
    pub fn keep_kernels(mut self) -> GpuContext {
        self.kernels = Some(Mutex::new(Vec::new()));
        self
    }

    /// The kernel for `config`: a kept one equal to it, else a new one (kept
    /// where `keep_kernels` asked, the oldest dropped beyond `KEPT_KERNELS`).
    pub fn kernel(&self, config: KernelConfig) -> Result<Kernel, ComposeError> {
        let Some(kernels) = &self.kernels else {
            return Kernel::new(self, config);
        };
        let kept = |kernels: &Mutex<Vec<Kernel>>| {
            let kernels = kernels.lock().unwrap_or_else(|e| e.into_inner());
            kernels.iter().find(|k| k.config == config).cloned()
        };
        if let Some(kernel) = kept(kernels) {
            return Ok(kernel);
        }
        // Built unlocked: another thread's build of another config need not wait.
        let kernel = Kernel::new(self, config)?;
        let mut kernels = kernels.lock().unwrap_or_else(|e| e.into_inner());
        if kernels.len() == KEPT_KERNELS {
            kernels.remove(0);
        }
        kernels.push(kernel.clone());
        Ok(kernel)
    }

    /// "name (backend, device type, driver version)".
    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }
}

/// Whether a CPU driver's code uses AVX-512 here: the CPU has it, with the OS
/// saving its registers (as Mesa checks), and `GALLIUM_OVERRIDE_CPU_CAPS` or
/// `GALLIUM_NOSSE`, which only take features away from llvmpipe, are unset.
/// The in-register lane insert on 8-lane vectors needs the VL extension too.
fn cpu_driver_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    let avx512 = std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl");
    #[cfg(not(target_arch = "x86_64"))]
    let avx512 = false;
    avx512
        && std::env::var_os("GALLIUM_OVERRIDE_CPU_CAPS").is_none_or(|caps| caps.is_empty())
        && std::env::var_os("GALLIUM_NOSSE").is_none()
}

/// The adapter, with its driver's version where the driver reports one: the
/// same CPU runs a kernel in 0.74-1.17x the time under two Mesa releases
/// (docs/benchmarks.md), so a figure names both.
fn describe(info: &wgpu::AdapterInfo) -> String {
    let driver = match info.driver_info.as_str() {
        "" => String::new(),
        version => format!(", {version}"),
    };
    format!(
        "{} ({:?}, {:?}{driver})",
        info.name, info.backend, info.device_type
    )
}

#[cfg(test)]
mod tests {
    use super::describe;

    #[test]
    fn the_description_names_the_drivers_version() {
        let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
        info.name = "llvmpipe (LLVM 15.0.6, 256 bits)".into();
        info.driver_info = "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)".into();
        assert_eq!(
            describe(&info),
            "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6))"
        );
        info.driver_info.clear();
        assert_eq!(
            describe(&info),
            "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu)"
        );
    }
}
