//! What the GPU's compiler makes of each compute shader: registers per
//! invocation, shared and local (spilled) memory and binary size, for every
//! pass shader variant the renderer composes (`render::shader_set::
//! pass_shaders`), as the driver reports them through
//! `VK_KHR_pipeline_executable_properties`.
//!
//! Registers decide how many invocations an SM keeps in flight, and so how
//! much of a pass's memory latency it hides: on NVIDIA's Hopper an SM holds
//! 65,536 registers and 64 warps, so 32 registers an invocation fill it, 64
//! half of it, 128 a quarter (BENCHMARKS.md, "Loops without naga's bound").
//!
//! The SPIR-V is written as wgpu writes it for a Vulkan device with robust
//! buffer and image access (wgpu then leaves buffer and image bounds to the
//! driver) under the project's runtime checks (`shaders::SHADER_CHECKS`).
//!
//! Run: `cargo run --release --example shader_stats [FILTER]`, FILTER a part
//! of the shader file or entry point names to keep.

use std::collections::BTreeMap;
use std::ffi::{CStr, CString, c_char};

use ash::vk;
use shadespace::render::shader_set::{library, pass_shaders};
use shadespace::shaders::SHADER_CHECKS;
use wgpu::naga;

fn main() {
    let filter = std::env::args().nth(1).unwrap_or_default();
    if let Err(e) = run(&filter) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(filter: &str) -> Result<(), String> {
    let gpu = Gpu::new()?;
    println!("{}", gpu.name);
    println!(
        "{:<24} {:<52} {:<22} {:>5} {:>7} {:>6} {:>7}",
        "shader", "definitions", "entry", "regs", "shared", "local", "binary"
    );
    let mut shaders = library().map_err(|e| e.to_string())?;
    for shader in pass_shaders() {
        let module = shaders.compose(shader).map_err(|e| e.to_string())?;
        let entries: Vec<&str> = module
            .entry_points
            .iter()
            .filter(|e| e.stage == naga::ShaderStage::Compute)
            .map(|e| e.name.as_str())
            .filter(|e| filter.is_empty() || shader.file.contains(filter) || e.contains(filter))
            .collect();
        if entries.is_empty() {
            continue;
        }
        let words = spirv(&module)?;
        let defs = shader.defs.join("+");
        for entry in entries {
            let s = gpu.statistics(&words, &bindings(&module), entry)?;
            let stat = |name: &str| s.get(name).map_or("-".to_string(), |v| v.to_string());
            println!(
                "{:<24} {:<52} {:<22} {:>5} {:>7} {:>6} {:>7}",
                shader.file,
                defs,
                entry,
                stat("Register Count"),
                stat("Shared Memory Size"),
                // NVIDIA reports local memory with a fixed offset of 2^36.
                s.get("Local Memory Size").map_or("-".to_string(), |v| (v & 0xf_ffff_ffff).to_string()),
                stat("Binary Size"),
            );
        }
    }
    Ok(())
}

/// The module as SPIR-V, with the checks wgpu compiles in on Vulkan under
/// `SHADER_CHECKS` where the device bounds buffer and image accesses itself.
fn spirv(module: &naga::Module) -> Result<Vec<u32>, String> {
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(module)
        .map_err(|e| e.to_string())?;
    let mut options = naga::back::spv::Options { lang_version: (1, 3), ..Default::default() };
    options.flags.remove(naga::back::spv::WriterFlags::DEBUG);
    options.zero_initialize_workgroup_memory = naga::back::spv::ZeroInitializeWorkgroupMemoryMode::Native;
    let unchecked = naga::proc::BoundsCheckPolicy::Unchecked;
    let index = if SHADER_CHECKS.bounds_checks { naga::proc::BoundsCheckPolicy::Restrict } else { unchecked };
    options.bounds_check_policies =
        naga::proc::BoundsCheckPolicies { index, buffer: unchecked, image_load: unchecked, binding_array: unchecked };
    options.force_loop_bounding = SHADER_CHECKS.force_loop_bounding;
    options.emit_int_div_checks = SHADER_CHECKS.int_div_checks;
    naga::back::spv::write_vec(module, &info, &options, None).map_err(|e| e.to_string())
}

/// Per bind group, the module's bindings as Vulkan descriptors.
fn bindings(module: &naga::Module) -> BTreeMap<u32, Vec<(u32, vk::DescriptorType, u32)>> {
    let mut groups: BTreeMap<u32, Vec<_>> = BTreeMap::new();
    for (_, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        let (ty, count) = match &module.types[var.ty].inner {
            naga::TypeInner::BindingArray { base, size } => {
                (&module.types[*base].inner, if let naga::ArraySize::Constant(n) = size { n.get() } else { 64 })
            }
            inner => (inner, 1),
        };
        let kind = match (var.space, ty) {
            (naga::AddressSpace::Uniform, _) => vk::DescriptorType::UNIFORM_BUFFER,
            (naga::AddressSpace::Storage { .. }, _) => vk::DescriptorType::STORAGE_BUFFER,
            (_, naga::TypeInner::Sampler { .. }) => vk::DescriptorType::SAMPLER,
            (_, naga::TypeInner::Image { class: naga::ImageClass::Storage { .. }, .. }) => {
                vk::DescriptorType::STORAGE_IMAGE
            }
            _ => vk::DescriptorType::SAMPLED_IMAGE,
        };
        groups.entry(binding.group).or_default().push((binding.binding, kind, count));
    }
    groups
}

fn text(chars: &[c_char]) -> String {
    // SAFETY: Vulkan's fixed-size strings are NUL-terminated.
    unsafe { CStr::from_ptr(chars.as_ptr()) }.to_string_lossy().into_owned()
}

/// A Vulkan device with pipeline statistics (the first discrete GPU, else
/// the first device), every feature it has enabled so that any shader
/// compiles.
struct Gpu {
    name: String,
    device: ash::Device,
    executables: ash::khr::pipeline_executable_properties::Device,
    instance: ash::Instance,
    _entry: ash::Entry,
}

impl Gpu {
    fn new() -> Result<Self, String> {
        // SAFETY: plain Vulkan setup; every pointer handed over outlives its call.
        unsafe {
            let entry = ash::Entry::load().map_err(|e| format!("no Vulkan loader: {e}"))?;
            let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
            let instance = entry
                .create_instance(&vk::InstanceCreateInfo::default().application_info(&app), None)
                .map_err(|e| format!("no Vulkan instance: {e}"))?;
            let all = instance.enumerate_physical_devices().map_err(|e| e.to_string())?;
            let discrete = |p: &&vk::PhysicalDevice| {
                instance.get_physical_device_properties(**p).device_type == vk::PhysicalDeviceType::DISCRETE_GPU
            };
            let physical = *all.iter().find(discrete).or(all.first()).ok_or("no Vulkan device")?;
            let name = text(&instance.get_physical_device_properties(physical).device_name);
            let extensions = instance.enumerate_device_extension_properties(physical).map_err(|e| e.to_string())?;
            let has = |n: &CStr| extensions.iter().any(|e| text(&e.extension_name) == n.to_string_lossy());
            let statistics = ash::khr::pipeline_executable_properties::NAME;
            if !has(statistics) {
                return Err(format!("{name} has no {}", statistics.to_string_lossy()));
            }
            let mut names = vec![statistics.as_ptr()];
            let robust = has(ash::ext::robustness2::NAME);
            if robust {
                names.push(ash::ext::robustness2::NAME.as_ptr());
            }
            let mut f11 = vk::PhysicalDeviceVulkan11Features::default();
            let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
            let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
            let mut robustness = vk::PhysicalDeviceRobustness2FeaturesEXT::default();
            let base = {
                let mut query =
                    vk::PhysicalDeviceFeatures2::default().push_next(&mut f11).push_next(&mut f12).push_next(&mut f13);
                if robust {
                    query = query.push_next(&mut robustness);
                }
                instance.get_physical_device_features2(physical, &mut query);
                query.features
            };
            // The queried chain's links, unlinked to be chained again below.
            f11.p_next = std::ptr::null_mut();
            f12.p_next = std::ptr::null_mut();
            f13.p_next = std::ptr::null_mut();
            robustness.p_next = std::ptr::null_mut();
            robustness.null_descriptor = vk::FALSE;
            let mut capture =
                vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default().pipeline_executable_info(true);
            let priorities = [1.0];
            let queues = [vk::DeviceQueueCreateInfo::default().queue_family_index(0).queue_priorities(&priorities)];
            let mut info = vk::DeviceCreateInfo::default()
                .queue_create_infos(&queues)
                .enabled_extension_names(&names)
                .enabled_features(&base)
                .push_next(&mut f11)
                .push_next(&mut f12)
                .push_next(&mut f13)
                .push_next(&mut capture);
            if robust {
                info = info.push_next(&mut robustness);
            }
            let device = instance.create_device(physical, &info, None).map_err(|e| format!("{name}: {e}"))?;
            let executables = ash::khr::pipeline_executable_properties::Device::new(&instance, &device);
            Ok(Self { name, device, executables, instance, _entry: entry })
        }
    }

    /// The driver's statistics (name, value) of compute entry point `entry`.
    fn statistics(
        &self,
        words: &[u32],
        groups: &BTreeMap<u32, Vec<(u32, vk::DescriptorType, u32)>>,
        entry: &str,
    ) -> Result<BTreeMap<String, u64>, String> {
        let d = &self.device;
        // SAFETY: every object made here is destroyed before returning.
        unsafe {
            let last = groups.keys().max().map_or(0, |g| g + 1);
            let mut set_layouts = Vec::new();
            for g in 0..last {
                let bindings: Vec<_> = groups
                    .get(&g)
                    .into_iter()
                    .flatten()
                    .map(|&(binding, kind, count)| {
                        vk::DescriptorSetLayoutBinding::default()
                            .binding(binding)
                            .descriptor_type(kind)
                            .descriptor_count(count)
                            .stage_flags(vk::ShaderStageFlags::COMPUTE)
                    })
                    .collect();
                let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
                set_layouts.push(d.create_descriptor_set_layout(&info, None).map_err(|e| e.to_string())?);
            }
            let layout = d
                .create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts), None)
                .map_err(|e| e.to_string())?;
            let module = d
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(words), None)
                .map_err(|e| e.to_string())?;
            let name = CString::new(entry).map_err(|e| e.to_string())?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(&name);
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout)
                .flags(vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR);
            let made = d.create_compute_pipelines(vk::PipelineCache::null(), &[info], None);
            let mut out = BTreeMap::new();
            let result = match made {
                Ok(pipelines) => {
                    let executable =
                        vk::PipelineExecutableInfoKHR::default().pipeline(pipelines[0]).executable_index(0);
                    let stats = self.executables.get_pipeline_executable_statistics(&executable);
                    d.destroy_pipeline(pipelines[0], None);
                    stats.map_err(|e| e.to_string()).map(|stats| {
                        for s in stats {
                            let value = match s.format {
                                vk::PipelineExecutableStatisticFormatKHR::UINT64 => s.value.u64,
                                vk::PipelineExecutableStatisticFormatKHR::INT64 => s.value.i64 as u64,
                                vk::PipelineExecutableStatisticFormatKHR::BOOL32 => s.value.b32 as u64,
                                _ => s.value.f64 as u64,
                            };
                            out.insert(text(&s.name), value);
                        }
                    })
                }
                Err((_, e)) => Err(format!("{entry}: {e}")),
            };
            d.destroy_shader_module(module, None);
            d.destroy_pipeline_layout(layout, None);
            for l in set_layouts {
                d.destroy_descriptor_set_layout(l, None);
            }
            result.map(|()| out)
        }
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // SAFETY: nothing made from them is alive.
        unsafe {
            self.device.destroy_device(None);
            self.instance.destroy_instance(None);
        }
    }
}
