//! [`Gpu`]: the wgpu instance, adapter, device and queue, and how the adapter
//! is chosen — for a window, for headless rendering, and for reproducible
//! images in tests.

use std::fmt::Write as _;

/// What a user can do when no adapter works; printed with every [`GpuError`]
/// about adapters.
pub const ADAPTER_HINT: &str = "install Mesa's drivers, which include software rasterisers that need no GPU \
     (Debian/Ubuntu: apt-get install mesa-vulkan-drivers libegl-mesa0 libgl1-mesa-dri), \
     or choose a backend with WGPU_BACKEND=vulkan|gl; `drape adapters` lists what wgpu can see";

/// Why no device could be made.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all, or none that can draw to the window.
    #[error("no usable graphics adapter ({reason}); {ADAPTER_HINT}")]
    NoAdapter {
        /// What wgpu said, or which adapters were rejected and why.
        reason: String,
    },
    /// `WGPU_ADAPTER_NAME` names no adapter that wgpu found.
    #[error("WGPU_ADAPTER_NAME={wanted:?} matches none of the adapters wgpu found ({found}); {ADAPTER_HINT}")]
    NoAdapterNamed {
        /// The variable's value.
        wanted: String,
        /// The adapters there are, one summary each.
        found: String,
    },
    /// The adapter exists but would not open a device.
    #[error("the adapter {adapter} would not create a device: {reason}")]
    RequestDevice {
        /// Summary of the adapter.
        adapter: String,
        /// wgpu's reason.
        reason: wgpu::RequestDeviceError,
    },
    /// The window system would not give wgpu a surface (for example: no
    /// backend enabled by `WGPU_BACKEND` can draw to windows here).
    #[error("cannot create a drawing surface for the window ({0}); {ADAPTER_HINT}")]
    CreateSurface(wgpu::CreateSurfaceError),
    /// The surface offers no format the renderer can use.
    #[error("the window's surface offers no 8-bit RGBA or BGRA format (it offers {0})")]
    NoSurfaceFormat(String),
}

/// Which adapter to prefer when several are present.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AdapterPreference {
    /// Hardware first (discrete, then integrated), then anything else: what
    /// a user wants for the window and for `drape render`.
    #[default]
    Hardware,
    /// Software rasterisers first (lavapipe before llvmpipe), so images are
    /// the same on every machine that has Mesa: what golden tests want.
    Software,
}

/// The GPU objects every part of the renderer needs.
#[derive(Clone, Debug)]
pub struct Gpu {
    /// The wgpu instance (creates surfaces).
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device with no window, for `drape render`, screenshots and tests.
    ///
    /// Honours `WGPU_BACKEND` (which backends to try) and
    /// `WGPU_ADAPTER_NAME` (a substring of the adapter's name).
    pub fn headless(preference: AdapterPreference) -> Result<Self, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        Self::with_instance(instance, None, preference)
    }

    /// A device on an existing instance; with `surface`, only adapters that
    /// can present to it are considered.
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
        preference: AdapterPreference,
    ) -> Result<Self, GpuError> {
        let adapter = choose_adapter(&instance, surface, preference)?;
        let (device, queue) = pollster::block_on(adapter.request_device(&device_descriptor(&adapter)))
            .map_err(|reason| GpuError::RequestDevice { adapter: summary(&adapter.get_info()), reason })?;
        Ok(Self { instance, adapter, device, queue })
    }

    /// One line about the adapter in use.
    pub fn adapter_summary(&self) -> String {
        summary(&self.adapter.get_info())
    }

    /// True when the adapter is a software rasteriser (slow, but present on
    /// any machine with Mesa).
    pub fn is_software(&self) -> bool {
        self.adapter.get_info().device_type == wgpu::DeviceType::Cpu
    }
}

/// The device the renderer asks for: WebGL2-level limits (so that old GL
/// drivers qualify) with the adapter's own texture size limits and largest
/// buffer (so a large `drape render` image can be read back).
fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    let available = adapter.limits();
    let max_buffer_size = available.max_buffer_size;
    wgpu::DeviceDescriptor {
        label: Some("drape"),
        required_features: wgpu::Features::empty(),
        required_limits: wgpu::Limits {
            max_buffer_size,
            ..wgpu::Limits::downlevel_webgl2_defaults().using_resolution(available)
        },
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    }
}

/// Every adapter wgpu finds for the backends allowed by `WGPU_BACKEND`.
pub fn enumerate_adapters(instance: &wgpu::Instance) -> Vec<wgpu::Adapter> {
    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())))
}

/// Ranks an adapter: lower is better.
fn rank(info: &wgpu::AdapterInfo, preference: AdapterPreference) -> (u8, u8) {
    rank_of(info.device_type, info.backend, preference)
}

fn rank_of(device_type: wgpu::DeviceType, backend: wgpu::Backend, preference: AdapterPreference) -> (u8, u8) {
    use wgpu::DeviceType as T;
    let kind = match (preference, device_type) {
        (AdapterPreference::Hardware, T::DiscreteGpu) => 0,
        (AdapterPreference::Hardware, T::IntegratedGpu) => 1,
        (AdapterPreference::Hardware, T::VirtualGpu) => 2,
        (AdapterPreference::Hardware, T::Cpu) => 3,
        (AdapterPreference::Software, T::Cpu) => 0,
        (AdapterPreference::Software, T::IntegratedGpu) => 1,
        (AdapterPreference::Software, T::DiscreteGpu) => 2,
        (AdapterPreference::Software, T::VirtualGpu) => 3,
        (_, T::Other) => 4,
    };
    let backend = match backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        wgpu::Backend::Gl => 1,
        _ => 2,
    };
    (kind, backend)
}

fn choose_adapter(
    instance: &wgpu::Instance,
    surface: Option<&wgpu::Surface<'_>>,
    preference: AdapterPreference,
) -> Result<wgpu::Adapter, GpuError> {
    let all = enumerate_adapters(instance);
    let mut candidates: Vec<_> =
        all.iter().filter(|a| surface.is_none_or(|s| a.is_surface_supported(s))).cloned().collect();
    if let Ok(wanted) = std::env::var("WGPU_ADAPTER_NAME") {
        let lower = wanted.to_lowercase();
        candidates.retain(|a| a.get_info().name.to_lowercase().contains(&lower));
        if candidates.is_empty() {
            return Err(GpuError::NoAdapterNamed { wanted, found: list_summaries(&all) });
        }
    }
    candidates.sort_by_key(|a| rank(&a.get_info(), preference));
    if let Some(best) = candidates.into_iter().next() {
        return Ok(best);
    }
    // Nothing enumerated (or nothing that fits the surface): ask wgpu, whose
    // error explains what each backend lacked.
    let options = wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
        force_fallback_adapter: false,
        compatible_surface: surface,
        apply_limit_buckets: false,
    };
    pollster::block_on(instance.request_adapter(&options)).map_err(|e| {
        let reason = if all.is_empty() {
            e.to_string()
        } else {
            format!("{e}; adapters found but unable to draw to this window: {}", list_summaries(&all))
        };
        GpuError::NoAdapter { reason }
    })
}

fn list_summaries(adapters: &[wgpu::Adapter]) -> String {
    if adapters.is_empty() {
        return "none".to_string();
    }
    adapters.iter().map(|a| summary(&a.get_info())).collect::<Vec<_>>().join("; ")
}

/// One line about an adapter: name, type, backend and driver.
pub fn summary(info: &wgpu::AdapterInfo) -> String {
    let mut s = format!("{} ({:?}, {:?}", info.name, info.device_type, info.backend);
    if !info.driver.is_empty() {
        let _ = write!(s, ", {}", info.driver);
    }
    if !info.driver_info.is_empty() {
        let _ = write!(s, " {}", info.driver_info);
    }
    s.push(')');
    s
}

/// A report of every adapter wgpu sees and which one each preference picks,
/// for `drape adapters`.
pub fn adapters_report() -> String {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapters = enumerate_adapters(&instance);
    let mut out = String::new();
    if adapters.is_empty() {
        let _ = writeln!(out, "wgpu found no adapter.");
        let options = wgpu::RequestAdapterOptions::default();
        if let Err(e) = pollster::block_on(instance.request_adapter(&options)) {
            let _ = writeln!(out, "wgpu says: {e}");
        }
        let _ = writeln!(out, "hint: {ADAPTER_HINT}");
        return out;
    }
    for (i, adapter) in adapters.iter().enumerate() {
        let info = adapter.get_info();
        let _ = writeln!(out, "[{i}] {}", info.name);
        let _ = writeln!(out, "    type     {:?}", info.device_type);
        let _ = writeln!(out, "    backend  {:?}", info.backend);
        let _ = writeln!(out, "    driver   {} {}", info.driver, info.driver_info);
        let _ = writeln!(out, "    ids      vendor {:#06x}, device {:#06x}", info.vendor, info.device);
        let limits = adapter.limits();
        let _ = writeln!(out, "    max 2-D texture {} px", limits.max_texture_dimension_2d);
        let samples = crate::render::targets::msaa_samples(adapter, wgpu::TextureFormat::Rgba8Unorm);
        let _ = writeln!(out, "    MSAA     {}", if samples > 1 { format!("{samples}×") } else { "no".into() });
    }
    for preference in [AdapterPreference::Hardware, AdapterPreference::Software] {
        let mut sorted = adapters.clone();
        sorted.sort_by_key(|a| rank(&a.get_info(), preference));
        if let Some(best) = sorted.first() {
            let who = match preference {
                AdapterPreference::Hardware => "the viewer and `drape render` use",
                AdapterPreference::Software => "golden-image tests use",
            };
            let _ = writeln!(out, "{who}: {}", summary(&best.get_info()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_preference_puts_gpus_first_and_software_puts_cpus_first() {
        use wgpu::{Backend, DeviceType};
        let (hw, sw) = (AdapterPreference::Hardware, AdapterPreference::Software);
        let gpu = |p| rank_of(DeviceType::DiscreteGpu, Backend::Vulkan, p);
        let lavapipe = |p| rank_of(DeviceType::Cpu, Backend::Vulkan, p);
        let llvmpipe = |p| rank_of(DeviceType::Cpu, Backend::Gl, p);
        assert!(gpu(hw) < lavapipe(hw));
        assert!(lavapipe(sw) < gpu(sw));
        assert!(lavapipe(sw) < llvmpipe(sw));
        assert!(lavapipe(hw) < llvmpipe(hw));
    }
}
