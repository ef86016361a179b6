//! The GPU context: adapter choice, optional features, validation errors,
//! timestamp profiling and read-back.

pub mod pipelines;
pub mod readback;
pub mod timing;

use std::sync::{Arc, Mutex};

/// Optional features used where the adapter has them (see DESIGN.md); each
/// pass that relies on one keeps a fallback for adapters without it.
pub const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES)
    .union(wgpu::Features::CONSERVATIVE_RASTERIZATION)
    .union(wgpu::Features::TEXTURE_ATOMIC)
    .union(wgpu::Features::SHADER_INT64)
    .union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX)
    .union(wgpu::Features::SHADER_INT64_ATOMIC_ALL_OPS)
    .union(wgpu::Features::TEXTURE_INT64_ATOMIC)
    .union(wgpu::Features::PRIMITIVE_INDEX)
    .union(wgpu::Features::SUBGROUP)
    .union(wgpu::Features::MULTIVIEW)
    .union(wgpu::Features::SHADER_BARYCENTRICS)
    .union(wgpu::Features::INDIRECT_FIRST_INSTANCE)
    .union(wgpu::Features::MULTI_DRAW_INDIRECT_COUNT)
    .union(wgpu::Features::FLOAT32_FILTERABLE)
    .union(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);

/// Environment variable that picks an adapter by name substring, like `--adapter`.
pub const ADAPTER_ENV: &str = "SHADESPACE_ADAPTER";

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (is a Vulkan driver installed? on a machine without a GPU, install Mesa's `mesa-vulkan-drivers`)"
    )]
    NoAdapter,
    #[error("no adapter matches '{wanted}'; available: {available}")]
    NoMatchingAdapter { wanted: String, available: String },
    #[error("cannot open the device on '{adapter}': {message}")]
    RequestDevice { adapter: String, message: String },
    #[error("wgpu validation error(s):\n{0}")]
    Validation(String),
    #[error("GPU read-back failed: {0}")]
    Readback(String),
}

/// The instance every context opens its adapter from: wgpu's defaults and
/// its environment variables (`WGPU_BACKEND`, `WGPU_VALIDATION`, ...), but
/// without wgpu's check of indirect call arguments, except on Windows.
///
/// That check runs a dispatch of its own, with two barriers and every bind
/// group set again, before each indirect dispatch: along Sponza's path on
/// the H100 it cost object space, which dispatches five passes indirectly,
/// 0.030 ms a frame at both 1920x1080 and 3840x2160 (BENCHMARKS.md, "Indirect
/// dispatches without wgpu's check"); `deferred-compute` dispatches none
/// there. The project's indirect arguments are written by its own shaders,
/// which bound them (`write_dispatch` in `objectspace/dispatch.wgsl`,
/// `finish` in `visibility/cull.wgsl`; draw arguments count lists
/// of the buffers they index). On D3D12 the check also supplies
/// `num_workgroups`, which indirectly dispatched passes read, so it stays on there.
/// `WGPU_VALIDATION_INDIRECT_CALL=1` turns it back on anywhere.
pub fn instance_descriptor() -> wgpu::InstanceDescriptor {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    if !cfg!(windows) {
        descriptor.flags.remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    }
    descriptor.with_env()
}

/// Which adapter to open.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Case-insensitive substring of the adapter name; `None` reads
    /// [`ADAPTER_ENV`], then prefers discrete, integrated, virtual, CPU.
    pub adapter: Option<String>,
}

/// An open device with the features that were turned on. Clones share the
/// device, its pipelines and its validation errors.
#[derive(Clone)]
pub struct GpuContext {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub features: wgpu::Features,
    pub limits: wgpu::Limits,
    /// The compute pipelines built on this device, for renderers built after.
    pub pipelines: pipelines::PipelineCache,
    errors: Arc<Mutex<Vec<String>>>,
}

impl GpuContext {
    pub fn new(options: &GpuOptions) -> Result<Self, GpuError> {
        Self::with_instance(wgpu::Instance::new(instance_descriptor()), options, None)
    }

    /// Opens a device on an adapter of `instance`; with `surface`, only on
    /// one that can present to it (the viewer's window).
    pub fn with_instance(
        instance: wgpu::Instance,
        options: &GpuOptions,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, GpuError> {
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        if let Some(surface) = surface {
            adapters.retain(|a| a.is_surface_supported(surface));
        }
        let wanted = options.adapter.clone().or_else(|| std::env::var(ADAPTER_ENV).ok()).filter(|s| !s.is_empty());
        let adapter = choose_adapter(adapters, wanted.as_deref())?;
        let info = adapter.get_info();
        let features = adapter.features() & OPTIONAL_FEATURES;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("shadespace"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice { adapter: info.name.clone(), message: e.to_string() })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            sink.lock().unwrap_or_else(|p| p.into_inner()).push(e.to_string());
        }));
        Ok(Self { instance, adapter, device, queue, info, features, limits, pipelines: Default::default(), errors })
    }

    pub fn has(&self, feature: wgpu::Features) -> bool {
        self.features.contains(feature)
    }

    /// Whether samplers may filter anisotropically (Vulkan's
    /// `samplerAnisotropy`): without it wgpu creates every sampler
    /// isotropic, whatever its `anisotropy_clamp`, and reports nothing.
    pub fn has_anisotropic_filtering(&self) -> bool {
        self.adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::ANISOTROPIC_FILTERING)
    }

    /// Returns the validation errors raised since the last call, as an error.
    /// Every frame and every test calls this: errors are never swallowed.
    pub fn check_errors(&self) -> Result<(), GpuError> {
        let mut errors = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        if errors.is_empty() {
            return Ok(());
        }
        let all = errors.drain(..).collect::<Vec<_>>().join("\n");
        Err(GpuError::Validation(all))
    }

    /// Blocks until the GPU has finished all submitted work.
    pub fn wait_idle(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Readback(e.to_string()))
    }

    /// A one-line description: adapter name, backend, driver.
    pub fn adapter_summary(&self) -> String {
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            self.info.name, self.info.backend, self.info.device_type, self.info.driver, self.info.driver_info
        )
    }

    /// The report of `shadespace info`: the adapter, the optional features
    /// that are on and off, and the limits the pipelines depend on.
    pub fn report(&self) -> String {
        let mut s = format!("adapter: {}\n", self.adapter_summary());
        let on: Vec<_> =
            OPTIONAL_FEATURES.iter_names().filter(|(_, f)| self.features.contains(*f)).map(|(n, _)| n).collect();
        let off: Vec<_> =
            OPTIONAL_FEATURES.iter_names().filter(|(_, f)| !self.features.contains(*f)).map(|(n, _)| n).collect();
        s += &format!("features on:  {}\n", on.join(", "));
        s += &format!("features off: {}\n", if off.is_empty() { "(none)".to_string() } else { off.join(", ") });
        let l = &self.limits;
        s += &format!(
            "limits: max_texture_dimension_2d {}, max_texture_array_layers {}, max_storage_buffer_binding_size {} MiB, \
             max_storage_buffers_per_shader_stage {}, max_storage_textures_per_shader_stage {}, max_compute_workgroup_storage_size {} KiB, \
             max_compute_invocations_per_workgroup {}, max_buffer_size {} MiB\n",
            l.max_texture_dimension_2d,
            l.max_texture_array_layers,
            l.max_storage_buffer_binding_size >> 20,
            l.max_storage_buffers_per_shader_stage,
            l.max_storage_textures_per_shader_stage,
            l.max_compute_workgroup_storage_size >> 10,
            l.max_compute_invocations_per_workgroup,
            l.max_buffer_size >> 20,
        );
        s += &format!(
            "anisotropic filtering (--aniso): {}\n",
            if self.has_anisotropic_filtering() { "yes" } else { "no" }
        );
        s += &format!("timestamp period: {} ns/tick\n", self.queue.get_timestamp_period());
        s
    }
}

/// Lists every adapter the instance sees, one line each, for `shadespace info`.
pub fn list_adapters() -> Vec<String> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()))
        .into_iter()
        .map(|a| {
            let i = a.get_info();
            format!("{} ({:?}, {:?}, driver {} {})", i.name, i.backend, i.device_type, i.driver, i.driver_info)
        })
        .collect()
}

fn choose_adapter(adapters: Vec<wgpu::Adapter>, wanted: Option<&str>) -> Result<wgpu::Adapter, GpuError> {
    if adapters.is_empty() {
        return Err(GpuError::NoAdapter);
    }
    if let Some(wanted) = wanted {
        let needle = wanted.to_lowercase();
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        return adapters
            .into_iter()
            .find(|a| a.get_info().name.to_lowercase().contains(&needle))
            .ok_or_else(|| GpuError::NoMatchingAdapter { wanted: wanted.to_string(), available: names.join(", ") });
    }
    let rank = |a: &wgpu::Adapter| {
        let i = a.get_info();
        let ty = match i.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        // Vulkan first (the backend this project is proven on).
        (ty, if i.backend == wgpu::Backend::Vulkan { 0 } else { 1 })
    };
    adapters.into_iter().min_by_key(rank).ok_or(GpuError::NoAdapter)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indirect_calls_go_unchecked_but_validation_stays() {
        if std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_some() || std::env::var_os("WGPU_VALIDATION").is_some()
        {
            return; // the environment decides
        }
        let flags = instance_descriptor().flags;
        assert_eq!(flags.contains(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL), cfg!(windows));
        assert_eq!(flags.contains(wgpu::InstanceFlags::VALIDATION), cfg!(debug_assertions));
    }
}
