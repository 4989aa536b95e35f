//! The GPU core: instance, validation messenger that counts, device choice, allocator, one-shot submission.
//!
//! Device choice: discrete > integrated > virtual > CPU (lavapipe), overridden by a case-insensitive name
//! substring in `MENISCUS_DEVICE`. Validation (with synchronization validation) is on when asked for, by flag or
//! `MENISCUS_VALIDATION=1`; tests always ask. Resources hold an `Arc<Gpu>`, so the device outlives every
//! allocation and the allocator is dropped before the device (see `Drop for Gpu`).

mod access;
mod context;
pub mod executor;
mod pipeline;
pub mod queues;
mod raster;
pub mod recording;
mod resource;
pub mod schedule;
mod specialize;
mod timer;
pub mod transfer;

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use crate::error::{Error, Result, VkContext};
use queues::{choose_async_queue, AsyncQueue, QueueRef, Queues};

pub use access::{Access, AccessState};
pub use context::{FrameCtx, Measure, Use};
pub use pipeline::{groups_2d, ComputeProgram, ProgramDecl, Res, Shader, Slot};
pub use raster::{GraphicsProgram, RasterTargets};
pub use resource::{Buffer, Image};
pub use specialize::WORK_COUNTING_ID;
pub use timer::Timer;

/// Options for [`Gpu::new`].
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Pick the first device whose name contains this (case-insensitive); `MENISCUS_DEVICE` if `None`.
    pub device_filter: Option<String>,
    /// Instance extensions a window surface needs (from `ash_window::enumerate_required_extensions`); when
    /// given, the device is created with VK_KHR_swapchain.
    pub surface_extensions: Vec<&'static std::ffi::CStr>,
    /// Leave 64-bit buffer atomics off where the device has them (the iso deposit then takes two 32-bit atomics
    /// per voxel, as on devices without them): to compare the two paths.
    pub no_int64_atomics: bool,
}

/// Counts of validation messages, shared with the messenger callback.
#[derive(Default)]
pub struct ValidationLog {
    errors: AtomicU32,
    warnings: AtomicU32,
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Errors reported so far.
    pub fn errors(&self) -> u32 {
        self.errors.load(Ordering::SeqCst)
    }
    /// Warnings reported so far.
    pub fn warnings(&self) -> u32 {
        self.warnings.load(Ordering::SeqCst)
    }
    /// The first messages (errors and warnings), for test failure output.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }
}

/// What `pick_device` found: the physical and logical device, the main family, the async queue choice and the
/// device description.
type PickedDevice = (vk::PhysicalDevice, ash::Device, u32, (u32, u32, AsyncQueue), DeviceInfo);

/// What the user and the benchmark want to know about the device.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    /// Device name.
    pub name: String,
    /// Driver name and version.
    pub driver: String,
    /// Vulkan API version, as "1.3.x".
    pub api_version: String,
    /// Discrete, integrated, virtual or CPU.
    pub device_type: String,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period: f32,
    /// Valid bits of a timestamp on the queue used.
    pub timestamp_valid_bits: u32,
    /// The queues chosen (families and indices).
    pub queues: Option<Queues>,
    /// VK_KHR/EXT_calibrated_timestamps enabled: the device time domain is defined and shared by every queue's
    /// timestamps (without it, spans of two queues compare only as far as the driver keeps one clock).
    pub calibrated_timestamps: bool,
    /// Subgroup size.
    pub subgroup_size: u32,
    /// Compute shaders may shuffle within a subgroup (`GL_KHR_shader_subgroup_shuffle`) and the subgroup size is
    /// 8 … 64 and divides 64: the iso cast's queued rays are marched by 8 lanes each (`[iso] rest_lanes`).
    pub subgroup_shuffle: bool,
    /// Largest storage buffer range in bytes.
    pub max_storage_buffer_range: u64,
    /// maxTexelBufferElements: the most texels a texel view (`Buffer::with_texel_view`) may cover.
    pub max_texel_buffer_elements: u64,
    /// shaderInt64 and shaderBufferInt64Atomics enabled: the iso deposit adds both of a voxel's sums with one
    /// 64-bit atomic.
    pub int64_atomics: bool,
    /// pipelineStatisticsQuery enabled: `bench` counts each pass's compute invocations.
    pub pipeline_statistics: bool,
    /// The device offers VK_EXT_mesh_shader (not enabled: reported by `meniscus info --device`, for a mesh
    /// surface drawn by mesh shaders straight from the field).
    pub mesh_shader: bool,
}

impl DeviceInfo {
    /// The lanes per group of consecutive subgroup lanes that may shuffle among themselves for `asked` (1, 8 or
    /// 32): the widest this device allows up to it — 32 needs subgroups of 32 or 64, 8 any that shuffle, else 1
    /// (the `iso` cast's queued rays, `[iso] rest_lanes`).
    pub fn shuffle_lanes(&self, asked: u32) -> u32 {
        match asked {
            32 if self.subgroup_shuffle && self.subgroup_size >= 32 => 32,
            8 | 32 if self.subgroup_shuffle => 8,
            _ => 1,
        }
    }
}

/// The device and everything that lives as long as it.
pub struct Gpu {
    /// The Vulkan loader.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    /// The physical device chosen.
    pub physical: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The main queue (graphics + compute + transfer): `queues.main.queue`.
    pub queue: vk::Queue,
    /// Its family.
    pub queue_family: u32,
    /// Main and async compute queues.
    pub queues: Queues,
    /// VK_KHR_push_descriptor entry points.
    pub push_descriptor: ash::khr::push_descriptor::Device,
    /// VK_EXT_debug_utils entry points (labels, object names), when present.
    pub debug_device: Option<ash::ext::debug_utils::Device>,
    /// The memory allocator (dropped before the device).
    pub allocator: ManuallyDrop<Mutex<Allocator>>,
    /// What the device is (for reports).
    pub info: DeviceInfo,
    /// Linear-filtering, clamp-to-edge sampler.
    pub linear_sampler: vk::Sampler,
    /// Nearest-filtering, clamp-to-edge sampler.
    pub nearest_sampler: vk::Sampler,
    command_pool: vk::CommandPool,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    validation: Arc<ValidationLog>,
    /// Keeps the pointer handed to the messenger alive.
    #[allow(clippy::redundant_allocation)] // the Box gives the callback a stable address for the Arc
    _validation_ptr: Option<Box<Arc<ValidationLog>>>,
}

unsafe extern "system" fn messenger_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    let log = &*(user as *const Arc<ValidationLog>);
    let msg = if data.is_null() || (*data).p_message.is_null() {
        String::from("(no message)")
    } else {
        CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
    };
    let kind = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        log.errors.fetch_add(1, Ordering::SeqCst);
        "error"
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log.warnings.fetch_add(1, Ordering::SeqCst);
        "warning"
    } else {
        return vk::FALSE;
    };
    eprintln!("[vulkan {kind}] {msg}");
    if let Ok(mut m) = log.messages.lock() {
        if m.len() < 64 {
            m.push(format!("{kind}: {msg}"));
        }
    }
    vk::FALSE
}

fn device_type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 4,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 3,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 1,
        _ => 0,
    }
}

fn cstr_of(raw: &[std::ffi::c_char]) -> String {
    // SAFETY: Vulkan guarantees NUL-terminated fixed arrays.
    unsafe { CStr::from_ptr(raw.as_ptr()) }.to_string_lossy().into_owned()
}

/// Every live GPU allocation of a device, by name (the name each buffer and image was created with: `iso_volume_acc`,
/// `sim_positions`, `depth`, …), from the allocator's own report.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MemoryReport {
    /// (name, bytes) summed over allocations of the same name, largest first.
    pub allocations: Vec<(String, u64)>,
    /// Bytes of all live allocations.
    pub allocated_bytes: u64,
    /// Bytes of the device memory blocks they live in (what the driver holds).
    pub reserved_bytes: u64,
}

impl MemoryReport {
    /// A table: one row per name, then the totals (MB = 10⁶ bytes).
    pub fn table(&self) -> String {
        let mut s = String::from("| allocation | MB |\n|---|---:|\n");
        for (n, b) in &self.allocations {
            s.push_str(&format!("| {n} | {:.2} |\n", *b as f64 / 1e6));
        }
        s.push_str(&format!("| **total allocated** | **{:.2}** |\n", self.allocated_bytes as f64 / 1e6));
        s.push_str(&format!("| device memory blocks | {:.2} |\n", self.reserved_bytes as f64 / 1e6));
        s
    }
}

impl Gpu {
    /// Every live allocation by name, and the totals.
    pub fn memory_report(&self) -> MemoryReport {
        let Ok(al) = self.allocator.lock() else { return MemoryReport::default() };
        let r = al.generate_report();
        let mut by: Vec<(String, u64)> = vec![];
        for a in &r.allocations {
            match by.iter_mut().find(|(n, _)| *n == a.name) {
                Some(e) => e.1 += a.size,
                None => by.push((a.name.clone(), a.size)),
            }
        }
        by.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
        MemoryReport {
            allocations: by,
            allocated_bytes: r.total_allocated_bytes,
            reserved_bytes: r.total_capacity_bytes,
        }
    }

    /// Create the instance and device. Errors (never panics) when no loader or device is found.
    pub fn new(opts: &GpuOptions) -> Result<Arc<Gpu>> {
        let validation_wanted =
            opts.validation || std::env::var("MENISCUS_VALIDATION").map(|v| v != "0" && !v.is_empty()).unwrap_or(false);
        // SAFETY: loading the system Vulkan loader (or the one MENISCUS_VULKAN_LOADER names); failure is
        // reported, not assumed.
        let entry = match std::env::var_os("MENISCUS_VULKAN_LOADER").filter(|p| !p.is_empty()) {
            Some(p) => unsafe { ash::Entry::load_from(&p) }
                .map_err(|e| Error::NoLoader(format!("MENISCUS_VULKAN_LOADER={}: {e}", p.to_string_lossy())))?,
            None => unsafe { ash::Entry::load() }.map_err(|e| Error::NoLoader(e.to_string()))?,
        };

        let (instance, has_debug_utils) = Self::create_instance(&entry, opts, validation_wanted)?;

        let validation = Arc::new(ValidationLog::default());
        let mut validation_ptr = None;
        let messenger = if validation_wanted && has_debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let boxed = Box::new(validation.clone());
            let user = &*boxed as *const Arc<ValidationLog> as *mut c_void;
            // A fresh create-info for the messenger itself (push_next mutates what it chains).
            let mci = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(messenger_callback))
                .user_data(user);
            let m = unsafe { loader.create_debug_utils_messenger(&mci, None) }.vk("vkCreateDebugUtilsMessengerEXT")?;
            validation_ptr = Some(boxed);
            Some((loader, m))
        } else {
            None
        };

        let result = Self::pick_device(&entry, &instance, opts, !opts.surface_extensions.is_empty());
        let (physical, device, queue_family, compute_choice, mut info) = match result {
            Ok(v) => v,
            Err(e) => {
                unsafe {
                    if let Some((l, m)) = &messenger {
                        l.destroy_debug_utils_messenger(*m, None);
                    }
                    instance.destroy_instance(None);
                }
                return Err(e);
            }
        };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let (compute_family, compute_index, kind) = compute_choice;
        let queues = Queues {
            main: QueueRef { family: queue_family, index: 0, queue },
            compute: QueueRef {
                family: compute_family,
                index: compute_index,
                queue: unsafe { device.get_device_queue(compute_family, compute_index) },
            },
            kind,
        };
        info.queues = Some(queues);
        let push_descriptor = ash::khr::push_descriptor::Device::new(&instance, &device);
        let debug_device = has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| Error::Alloc { what: "allocator".into(), source: e })?;
        let pool_ci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let command_pool = unsafe { device.create_command_pool(&pool_ci, None) }.vk("vkCreateCommandPool")?;
        let sampler = |filter| {
            let ci = vk::SamplerCreateInfo::default()
                .mag_filter(filter)
                .min_filter(filter)
                .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                .max_lod(0.0);
            unsafe { device.create_sampler(&ci, None) }.vk("vkCreateSampler")
        };
        let linear_sampler = sampler(vk::Filter::LINEAR)?;
        let nearest_sampler = sampler(vk::Filter::NEAREST)?;
        Ok(Arc::new(Gpu {
            entry,
            instance,
            physical,
            device,
            queue,
            queue_family,
            queues,
            push_descriptor,
            debug_device,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            info,
            linear_sampler,
            nearest_sampler,
            command_pool,
            messenger,
            validation,
            _validation_ptr: validation_ptr,
        }))
    }

    /// The instance: the validation layer (with synchronisation validation) when wanted, the window's surface
    /// extensions, debug utils where the loader has them. Returns it and whether debug utils are on.
    fn create_instance(
        entry: &ash::Entry,
        opts: &GpuOptions,
        validation_wanted: bool,
    ) -> Result<(ash::Instance, bool)> {
        let layers = unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
        let has_validation = layers.iter().any(|l| cstr_of(&l.layer_name) == "VK_LAYER_KHRONOS_validation");
        if validation_wanted && !has_validation {
            return Err(Error::NoDevice(
                "validation was requested but VK_LAYER_KHRONOS_validation is not installed (apt-get install vulkan-validationlayers)".into(),
            ));
        }
        let exts = unsafe { entry.enumerate_instance_extension_properties(None) }
            .vk("vkEnumerateInstanceExtensionProperties")?;
        let has_debug_utils = exts.iter().any(|e| cstr_of(&e.extension_name) == "VK_EXT_debug_utils");

        let app_name = CString::new("meniscus").unwrap();
        let app = vk::ApplicationInfo::default()
            .application_name(&app_name)
            .engine_name(&app_name)
            .api_version(vk::API_VERSION_1_3);
        let layer_names: Vec<*const std::ffi::c_char> =
            if validation_wanted { vec![c"VK_LAYER_KHRONOS_validation".as_ptr()] } else { vec![] };
        let mut ext_names: Vec<*const std::ffi::c_char> = opts.surface_extensions.iter().map(|e| e.as_ptr()).collect();
        for e in &opts.surface_extensions {
            if !exts.iter().any(|x| cstr_of(&x.extension_name) == e.to_string_lossy()) {
                return Err(Error::NoDevice(format!(
                    "the Vulkan loader lacks the window extension {}",
                    e.to_string_lossy()
                )));
            }
        }
        if has_debug_utils {
            ext_names.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        let mut ci = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&ext_names);
        if validation_wanted {
            ci = ci.push_next(&mut features);
        }
        let instance = unsafe { entry.create_instance(&ci, None) }.map_err(|r| match r {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
                Error::NoDevice("the Vulkan loader found no driver (ERROR_INCOMPATIBLE_DRIVER)".into())
            }
            r => Error::Vulkan { call: "vkCreateInstance", result: r },
        })?;
        Ok((instance, has_debug_utils))
    }

    fn pick_device(
        entry: &ash::Entry,
        instance: &ash::Instance,
        opts: &GpuOptions,
        swapchain: bool,
    ) -> Result<PickedDevice> {
        let _ = entry;
        let physicals = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
        if physicals.is_empty() {
            return Err(Error::NoDevice("the Vulkan loader lists no physical device".into()));
        }
        let filter = opts
            .device_filter
            .clone()
            .or_else(|| std::env::var("MENISCUS_DEVICE").ok().filter(|s| !s.is_empty()))
            .map(|s| s.to_lowercase());
        let mut candidates = vec![];
        let mut names = vec![];
        for &pd in &physicals {
            let props = unsafe { instance.get_physical_device_properties(pd) };
            let name = cstr_of(&props.device_name);
            names.push(name.clone());
            if props.api_version < vk::API_VERSION_1_3 {
                continue;
            }
            if let Some(f) = &filter {
                if !name.to_lowercase().contains(f) {
                    continue;
                }
            }
            let exts = unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
            if !exts.iter().any(|e| cstr_of(&e.extension_name) == "VK_KHR_push_descriptor") {
                continue;
            }
            if swapchain && !exts.iter().any(|e| cstr_of(&e.extension_name) == "VK_KHR_swapchain") {
                continue;
            }
            let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
            let Some(qf) = families.iter().position(|f| {
                f.queue_flags.contains(vk::QueueFlags::COMPUTE | vk::QueueFlags::GRAPHICS) && f.timestamp_valid_bits > 0
            }) else {
                continue;
            };
            candidates.push((device_type_rank(props.device_type), pd, qf as u32, families[qf].timestamp_valid_bits));
        }
        // Highest rank first; among equals the loader's order.
        candidates.sort_by_key(|c| std::cmp::Reverse(c.0));
        let Some(&(_, pd, qf, valid_bits)) = candidates.first() else {
            return Err(Error::NoDevice(match filter {
                Some(f) => format!(
                    "no Vulkan 1.3 device with push descriptors matches MENISCUS_DEVICE={f:?} (devices: {names:?})"
                ),
                None => format!("no Vulkan 1.3 device with push descriptors and timestamps (devices: {names:?})"),
            }));
        };

        let mut info = device_info(instance, pd, valid_bits);

        // Features: synchronization2 and dynamic rendering (1.3), demote-to-helper (shaderc turns `discard`
        // into it), maintenance4 (quiets "output not consumed" warnings).
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13).push_next(&mut f12);
        unsafe { instance.get_physical_device_features2(pd, &mut f2) };
        let base = f2.features;
        if f13.synchronization2 == vk::FALSE {
            return Err(Error::NoDevice(format!("{} lacks synchronization2", info.name)));
        }
        let mut e13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(f13.dynamic_rendering == vk::TRUE)
            .shader_demote_to_helper_invocation(f13.shader_demote_to_helper_invocation == vk::TRUE)
            .maintenance4(f13.maintenance4 == vk::TRUE);
        if f12.timeline_semaphore == vk::FALSE {
            return Err(Error::NoDevice(format!("{} lacks timeline semaphores", info.name)));
        }
        info.int64_atomics =
            !opts.no_int64_atomics && base.shader_int64 == vk::TRUE && f12.shader_buffer_int64_atomics == vk::TRUE;
        info.pipeline_statistics = base.pipeline_statistics_query == vk::TRUE;
        let mut e12 = vk::PhysicalDeviceVulkan12Features::default()
            .host_query_reset(f12.host_query_reset == vk::TRUE)
            .shader_buffer_int64_atomics(info.int64_atomics)
            .timeline_semaphore(true);
        let base_enable = vk::PhysicalDeviceFeatures::default()
            .shader_int64(info.int64_atomics)
            .pipeline_statistics_query(info.pipeline_statistics)
            .fragment_stores_and_atomics(base.fragment_stores_and_atomics == vk::TRUE)
            .vertex_pipeline_stores_and_atomics(base.vertex_pipeline_stores_and_atomics == vk::TRUE)
            .shader_storage_image_extended_formats(base.shader_storage_image_extended_formats == vk::TRUE)
            .large_points(base.large_points == vk::TRUE);
        let mut enable2 =
            vk::PhysicalDeviceFeatures2::default().features(base_enable).push_next(&mut e13).push_next(&mut e12);
        // The async compute queue: a compute-only family with timestamps, else a second queue of the main
        // family, else the main queue itself.
        let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let compute = choose_async_queue(&families, qf);
        let prio = [1.0f32, 1.0];
        let mut qci = vec![vk::DeviceQueueCreateInfo::default()
            .queue_family_index(qf)
            .queue_priorities(if compute.2 == AsyncQueue::SecondQueue { &prio[..2] } else { &prio[..1] })];
        if compute.2 == AsyncQueue::ComputeFamily {
            qci.push(vk::DeviceQueueCreateInfo::default().queue_family_index(compute.0).queue_priorities(&prio[..1]));
        }
        let mut dev_exts = vec![ash::khr::push_descriptor::NAME.as_ptr()];
        if swapchain {
            dev_exts.push(ash::khr::swapchain::NAME.as_ptr());
        }
        // Calibrated timestamps: with them the device time domain — which every queue's timestamps are in —
        // is defined, so the per-queue spans of a split frame compare on one clock (the union, the overlap).
        let available = unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
        let has = |n: &std::ffi::CStr| available.iter().any(|e| e.extension_name_as_c_str() == Ok(n));
        info.mesh_shader = has(ash::ext::mesh_shader::NAME);
        // EXT first: the same feature, and validation layers older than the KHR promotion (Debian 12's 1.3.239)
        // warn about the KHR name ("not supported by this layer"), which fails a --validation run.
        if has(ash::ext::calibrated_timestamps::NAME) {
            dev_exts.push(ash::ext::calibrated_timestamps::NAME.as_ptr());
            info.calibrated_timestamps = true;
        } else if has(ash::khr::calibrated_timestamps::NAME) {
            dev_exts.push(ash::khr::calibrated_timestamps::NAME.as_ptr());
            info.calibrated_timestamps = true;
        }
        let dci = vk::DeviceCreateInfo::default()
            .queue_create_infos(&qci)
            .enabled_extension_names(&dev_exts)
            .push_next(&mut enable2);
        let device = unsafe { instance.create_device(pd, &dci, None) }.vk("vkCreateDevice")?;
        Ok((pd, device, qf, compute, info))
    }

    /// The queue families resources are shared between concurrently: both, when the async compute queue is of
    /// another family than the main one (then no ownership transfers are needed: the frame's semaphores are
    /// the whole cross-queue dependency); empty (exclusive sharing) otherwise.
    pub fn concurrent_families(&self) -> Vec<u32> {
        if self.queues.compute.family != self.queues.main.family {
            vec![self.queues.main.family, self.queues.compute.family]
        } else {
            vec![]
        }
    }

    /// Validation counters (all zero when validation is off).
    pub fn validation(&self) -> &ValidationLog {
        &self.validation
    }

    /// True when the validation messenger is installed.
    pub fn validation_enabled(&self) -> bool {
        self.messenger.is_some()
    }

    /// Record with `f` into a fresh command buffer, submit, wait for completion.
    pub fn one_shot<R>(&self, f: impl FnOnce(vk::CommandBuffer) -> Result<R>) -> Result<R> {
        let d = &self.device;
        let ai = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd = unsafe { d.allocate_command_buffers(&ai) }.vk("vkAllocateCommandBuffers")?[0];
        let run = || -> Result<R> {
            let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            unsafe { d.begin_command_buffer(cmd, &bi) }.vk("vkBeginCommandBuffer")?;
            let r = f(cmd)?;
            unsafe { d.end_command_buffer(cmd) }.vk("vkEndCommandBuffer")?;
            let fence = unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            let res = unsafe { d.queue_submit(self.queue, &submit, fence) }
                .vk("vkQueueSubmit")
                .and_then(|_| unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }.vk("vkWaitForFences"));
            unsafe { d.destroy_fence(fence, None) };
            res.map(|_| r)
        };
        let r = run();
        unsafe { d.free_command_buffers(self.command_pool, &[cmd]) };
        r
    }

    /// Wrap a command buffer region in a debug label (no-op without VK_EXT_debug_utils).
    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        if let Some(dd) = &self.debug_device {
            let c = CString::new(name).unwrap_or_default();
            let label = vk::DebugUtilsLabelEXT::default().label_name(&c);
            unsafe { dd.cmd_begin_debug_utils_label(cmd, &label) };
        }
    }

    /// Give a Vulkan object a debug name (no-op without VK_EXT_debug_utils).
    pub fn name_object<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(dd) = &self.debug_device {
            let c = CString::new(name).unwrap_or_default();
            let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&c);
            unsafe {
                let _ = dd.set_debug_utils_object_name(&info);
            }
        }
    }

    /// Close the label opened by [`Gpu::begin_label`].
    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(dd) = &self.debug_device {
            unsafe { dd.cmd_end_debug_utils_label(cmd) };
        }
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // Order matters: idle, then objects, then the allocator (it frees its memory blocks), then the device,
        // then the messenger and the instance. Every resource holds an Arc<Gpu>, so none is alive here.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_sampler(self.linear_sampler, None);
            self.device.destroy_sampler(self.nearest_sampler, None);
            self.device.destroy_command_pool(self.command_pool, None);
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((l, m)) = self.messenger.take() {
                l.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// What the device is (name, driver, API version, limits, subgroups) before its features are chosen; the
/// queues and the optional features are filled in by `Gpu::pick_device`.
fn device_info(instance: &ash::Instance, pd: vk::PhysicalDevice, valid_bits: u32) -> DeviceInfo {
    let props = unsafe { instance.get_physical_device_properties(pd) };
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver).push_next(&mut subgroup);
    unsafe { instance.get_physical_device_properties2(pd, &mut props2) };
    let v = props.api_version;
    DeviceInfo {
        name: cstr_of(&props.device_name),
        driver: format!("{} {}", cstr_of(&driver.driver_name), cstr_of(&driver.driver_info)),
        api_version: format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v)),
        device_type: format!("{:?}", props.device_type),
        timestamp_period: props.limits.timestamp_period,
        timestamp_valid_bits: valid_bits,
        queues: None,
        calibrated_timestamps: false,
        subgroup_size: subgroup.subgroup_size,
        subgroup_shuffle: subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(vk::SubgroupFeatureFlags::SHUFFLE)
            && (8..=64).contains(&subgroup.subgroup_size)
            && 64u32.is_multiple_of(subgroup.subgroup_size),
        max_storage_buffer_range: props.limits.max_storage_buffer_range as u64,
        max_texel_buffer_elements: props.limits.max_texel_buffer_elements as u64,
        int64_atomics: false,
        pipeline_statistics: false,
        mesh_shader: false,
    }
}
