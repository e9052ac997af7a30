//! Vulkan bring-up and teardown: the loader entry, the instance (optionally with the Khronos
//! validation layer and a `VK_EXT_debug_utils` messenger that counts what it reports), physical
//! device selection, the logical device (with the optional features a scene needs and the
//! device has, and `VK_EXT_depth_clip_control` or `VK_EXT_graphics_pipeline_library` when a
//! scene asks for it) and its graphics queue, the memory-type helper and host-visible buffers.
//!
//! Everything created here is destroyed by `Drop`, in reverse order of creation, so that the
//! validation layer has nothing to report as leaked at `vkDestroyDevice` / `vkDestroyInstance`.

use std::ffi::{c_void, CStr};
use std::fmt;
use std::io::Write as _;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, bail, Context, Result};
use ash::vk;

use crate::target::ResolveSupport;

/// The Khronos validation layer, enabled through `ppEnabledLayerNames` by `--validation`.
pub const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Counts the validation messages that make a run fail, shared with the debug messenger
/// callback through its `pUserData`.
#[derive(Debug, Default)]
pub struct ValidationLog {
    counted: AtomicU32,
}

impl ValidationLog {
    /// Number of counted messages so far: every ERROR, and every WARNING of type VALIDATION or
    /// PERFORMANCE.
    pub fn count(&self) -> u32 {
        self.counted.load(Ordering::SeqCst)
    }
}

/// The debug-utils callback: counts ERROR messages (any type) and WARNING messages of type
/// VALIDATION or PERFORMANCE, printing each counted one to stderr; everything else is ignored.
unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    let counted = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        Some("ERROR")
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING)
        && types.intersects(
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
    {
        Some("WARNING")
    } else {
        None
    };
    let Some(severity_name) = counted else {
        return vk::FALSE;
    };
    if !user_data.is_null() {
        // SAFETY: `user_data` is `Arc::as_ptr` of the `ValidationLog` that `InstanceCtx` keeps
        // alive until after the instance (and with it every messenger) is destroyed.
        let log = unsafe { &*(user_data as *const ValidationLog) };
        log.counted.fetch_add(1, Ordering::SeqCst);
    }
    // SAFETY: the implementation passes a valid callback-data structure (or null) for the
    // duration of the call; its strings are null or NUL-terminated.
    let (id_name, message) = unsafe {
        match data.as_ref() {
            Some(data) => (
                data.message_id_name_as_c_str()
                    .map_or_else(|| "(no id)".into(), CStr::to_string_lossy),
                data.message_as_c_str()
                    .map_or_else(|| "(no message)".into(), CStr::to_string_lossy),
            ),
            None => ("(no id)".into(), "(no message)".into()),
        }
    };
    // Never panic inside a callback called from C: ignore a failed write to stderr.
    let _ = writeln!(
        std::io::stderr(),
        "validation: {severity_name} {id_name}: {message}"
    );
    vk::FALSE
}

/// What the tester prints and records about the physical device it renders on.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    /// `VkPhysicalDeviceProperties::deviceName`.
    pub name: String,
    /// `VkPhysicalDeviceDriverProperties::driverName` ("unknown" before Vulkan 1.2).
    pub driver_name: String,
    /// `VkPhysicalDeviceDriverProperties::driverInfo`.
    pub driver_info: String,
    /// `VkPhysicalDeviceProperties::apiVersion`.
    pub api_version: u32,
}

impl DeviceInfo {
    /// `<driverName> <driverInfo>`.
    pub fn driver(&self) -> String {
        if self.driver_info.is_empty() {
            self.driver_name.clone()
        } else {
            format!("{} {}", self.driver_name, self.driver_info)
        }
    }

    /// The device's Vulkan version as `major.minor.patch`.
    pub fn api_version_string(&self) -> String {
        let v = self.api_version;
        format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        )
    }
}

/// How to bring the GPU up.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Case-insensitive substring of the device name; `None` prefers lavapipe ("llvmpipe").
    pub device: Option<String>,
    /// Enable `VK_LAYER_KHRONOS_validation` and count its messages.
    pub validation: bool,
    /// With `validation`: enable its synchronization validation too
    /// (`VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT`).
    pub sync_validation: bool,
    /// Optional features to enable where the device has them.
    pub features: Features,
    /// The highest Vulkan version to ask for (default: 1.3 where the loader has it, else 1.2).
    /// Below 1.1 the tester enables `VK_KHR_get_physical_device_properties2` only where a
    /// requested feature needs it (`depthClipControl`, `graphicsPipelineLibrary`), as a
    /// Vulkan 1.0 application would.
    pub max_api_version: Option<u32>,
}

/// The optional device features the tester may enable (everything else stays off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// `dynamicRendering`: Vulkan 1.3, or `VK_KHR_dynamic_rendering` below it (enabled with
    /// what it requires).
    pub dynamic_rendering: bool,
    /// `vkCmdSetDepthCompareOp`: Vulkan 1.3, or `VK_EXT_extended_dynamic_state`'s
    /// `extendedDynamicState` below it.
    pub dynamic_compare_op: bool,
    /// `vkCreateRenderPass2` with depth/stencil resolves: Vulkan 1.2, or
    /// `VK_KHR_create_renderpass2` and `VK_KHR_depth_stencil_resolve` below it (not a feature:
    /// not in [`Features::names`]).
    pub depth_stencil_resolve: bool,
    /// `depthBounds`.
    pub depth_bounds: bool,
    /// `depthBiasClamp`.
    pub depth_bias_clamp: bool,
    /// `VK_EXT_depth_clip_control`'s `depthClipControl` (the extension is enabled with it).
    pub depth_clip_control: bool,
    /// `VK_EXT_graphics_pipeline_library`'s `graphicsPipelineLibrary` (the extension and the
    /// `VK_KHR_pipeline_library` it requires are enabled with it).
    pub graphics_pipeline_library: bool,
}

impl Features {
    /// The Vulkan names of the features that are set, for reports.
    pub fn names(self) -> Vec<&'static str> {
        [
            (self.dynamic_rendering, "dynamicRendering"),
            (self.dynamic_compare_op, "extendedDynamicState"),
            (self.depth_bounds, "depthBounds"),
            (self.depth_bias_clamp, "depthBiasClamp"),
            (self.depth_clip_control, "depthClipControl"),
            (self.graphics_pipeline_library, "graphicsPipelineLibrary"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect()
    }

    /// The features set in both.
    pub fn and(self, other: Features) -> Features {
        Features {
            dynamic_rendering: self.dynamic_rendering && other.dynamic_rendering,
            dynamic_compare_op: self.dynamic_compare_op && other.dynamic_compare_op,
            depth_stencil_resolve: self.depth_stencil_resolve && other.depth_stencil_resolve,
            depth_bounds: self.depth_bounds && other.depth_bounds,
            depth_bias_clamp: self.depth_bias_clamp && other.depth_bias_clamp,
            depth_clip_control: self.depth_clip_control && other.depth_clip_control,
            graphics_pipeline_library: self.graphics_pipeline_library
                && other.graphics_pipeline_library,
        }
    }
}

/// Loader entry, instance and (optional) debug messenger; destroyed after the device.
struct InstanceCtx {
    // `Drop` below destroys the messenger and the instance explicitly; `entry` (which keeps
    // libvulkan loaded) and `log` (the messengers' user data) are dropped only after that.
    entry: ash::Entry,
    instance: ash::Instance,
    api_version: u32,
    /// `VK_KHR_get_physical_device_properties2`, where the instance is below 1.1 and enabled
    /// it (the features and properties queries beyond Vulkan 1.0 go through it).
    properties2: Option<ash::khr::get_physical_device_properties2::Instance>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    log: Arc<ValidationLog>,
}

impl Drop for InstanceCtx {
    fn drop(&mut self) {
        if let Some((loader, messenger)) = self.debug.take() {
            // SAFETY: the messenger was created from this instance and is destroyed once.
            unsafe { loader.destroy_debug_utils_messenger(messenger, None) };
        }
        // SAFETY: every child object (the device, the messenger) is already destroyed.
        unsafe { self.instance.destroy_instance(None) };
    }
}

fn debug_messenger_info(log: &Arc<ValidationLog>) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(Arc::as_ptr(log) as *mut c_void)
}

impl InstanceCtx {
    /// `extension_features`: features of device extensions will be asked for (below Vulkan 1.1
    /// their queries need `VK_KHR_get_physical_device_properties2`).
    fn new(
        validation: bool,
        sync_validation: bool,
        max_api_version: Option<u32>,
        extension_features: bool,
    ) -> Result<Self> {
        // SAFETY: loading libvulkan.so.1 runs its initialisers; the loader is a well-behaved
        // shared library and `Entry` keeps it loaded for as long as it lives.
        let entry = unsafe { ash::Entry::load() }
            .context("cannot load the Vulkan loader libvulkan.so.1 (apt-get install libvulkan1)")?;

        // SAFETY: plain global query.
        let instance_version = unsafe { entry.try_enumerate_instance_version() }
            .context("vkEnumerateInstanceVersion failed")?
            .unwrap_or(vk::API_VERSION_1_0);
        let api_version = if instance_version >= vk::API_VERSION_1_3 {
            vk::API_VERSION_1_3
        } else {
            vk::API_VERSION_1_2
        }
        .min(max_api_version.unwrap_or(vk::API_VERSION_1_3));

        let log = Arc::new(ValidationLog::default());
        let mut layers: Vec<*const std::ffi::c_char> = Vec::new();
        let mut extensions: Vec<*const std::ffi::c_char> = Vec::new();
        if validation {
            // SAFETY: plain global query.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .context("vkEnumerateInstanceLayerProperties failed")?;
            let found = available
                .iter()
                .any(|layer| layer.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
            if !found {
                bail!(
                    "VK_LAYER_KHRONOS_validation not found: install vulkan-validationlayers \
                     (apt-get install vulkan-validationlayers)"
                );
            }
            layers.push(VALIDATION_LAYER.as_ptr());

            let debug_utils = ash::ext::debug_utils::NAME;
            // SAFETY: plain global queries (the loader's own extensions and the layer's).
            let has_debug_utils = unsafe {
                let global = entry.enumerate_instance_extension_properties(None);
                let layer = entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER));
                global
                    .into_iter()
                    .chain(layer)
                    .flatten()
                    .any(|ext| ext.extension_name_as_c_str() == Ok(debug_utils))
            };
            if !has_debug_utils {
                bail!("VK_EXT_debug_utils is not available: cannot count validation messages");
            }
            extensions.push(debug_utils.as_ptr());
        }
        let properties2 = api_version < vk::API_VERSION_1_1 && extension_features;
        if properties2 {
            extensions.push(ash::khr::get_physical_device_properties2::NAME.as_ptr());
        }

        let app_info = vk::ApplicationInfo::default()
            .application_name(c"revz-tester")
            .application_version(vk::make_api_version(0, 0, 1, 0))
            .engine_name(c"revz-tester")
            .engine_version(vk::make_api_version(0, 0, 1, 0))
            .api_version(api_version);
        // Chained so that vkCreateInstance / vkDestroyInstance are covered too.
        let mut chained_messenger = debug_messenger_info(&log);
        let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
        let mut create_info = vk::InstanceCreateInfo::default()
            .application_info(&app_info)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if validation {
            create_info = create_info.push_next(&mut chained_messenger);
            if sync_validation {
                create_info = create_info.push_next(&mut features);
            }
        }
        // SAFETY: every pointer in `create_info` refers to locals that outlive the call.
        let instance = match unsafe { entry.create_instance(&create_info, None) } {
            Ok(instance) => instance,
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => bail!(
                "no device found: vkCreateInstance found no Vulkan driver \
                 (ERROR_INCOMPATIBLE_DRIVER; apt-get install mesa-vulkan-drivers for lavapipe)"
            ),
            Err(e) => bail!("vkCreateInstance failed: {e}"),
        };

        let properties2 = properties2
            .then(|| ash::khr::get_physical_device_properties2::Instance::new(&entry, &instance));
        let mut ctx = InstanceCtx {
            entry,
            instance,
            api_version,
            properties2,
            debug: None,
            log,
        };
        if validation {
            let loader = ash::ext::debug_utils::Instance::new(&ctx.entry, &ctx.instance);
            let info = debug_messenger_info(&ctx.log);
            // SAFETY: valid instance with VK_EXT_debug_utils enabled; `info` is fully valid.
            let messenger = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .context("vkCreateDebugUtilsMessengerEXT failed")?;
            ctx.debug = Some((loader, messenger));
        }
        Ok(ctx)
    }
}

/// The instance, the chosen physical device, the logical device and its graphics queue.
pub struct Gpu {
    /// The logical device (only the optional features in `enabled`, and the extensions of
    /// `depthClipControl` and `graphicsPipelineLibrary` when they are among them).
    pub device: ash::Device,
    /// A queue of `queue_family` that supports graphics (and therefore transfer).
    pub queue: vk::Queue,
    /// The queue family index of `queue`.
    pub queue_family: u32,
    /// The chosen physical device.
    pub physical_device: vk::PhysicalDevice,
    /// What the tester reports about the device.
    pub info: DeviceInfo,
    /// The optional features the device has.
    pub supported: Features,
    /// The optional features enabled at device creation (requested and supported).
    pub enabled: Features,
    /// The extensions standing in for core commands below their version (see
    /// [`Gpu::cmd_begin_rendering`] and the methods after it).
    dynamic_rendering_khr: Option<ash::khr::dynamic_rendering::Device>,
    extended_dynamic_state: Option<ash::ext::extended_dynamic_state::Device>,
    create_renderpass2_khr: Option<ash::khr::create_renderpass2::Device>,
    memory_properties: vk::PhysicalDeviceMemoryProperties,
    // Dropped after `Drop::drop` has destroyed the device.
    instance: InstanceCtx,
}

impl fmt::Debug for Gpu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Gpu")
            .field("device", &self.device.handle())
            .field("queue", &self.queue)
            .field("queue_family", &self.queue_family)
            .field("physical_device", &self.physical_device)
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // SAFETY: the device is idle-waited before destruction; every object created from it
        // borrows `Gpu` and is therefore already dropped.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
        }
    }
}

fn c_chars_to_string(chars: Result<&CStr, std::ffi::FromBytesUntilNulError>) -> String {
    chars.map_or_else(
        |_| "(invalid)".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    )
}

fn device_info(instance: &InstanceCtx, physical_device: vk::PhysicalDevice) -> DeviceInfo {
    // SAFETY: `physical_device` was enumerated from this instance.
    let properties = unsafe {
        instance
            .instance
            .get_physical_device_properties(physical_device)
    };
    let mut info = DeviceInfo {
        name: c_chars_to_string(properties.device_name_as_c_str()),
        driver_name: "unknown".to_owned(),
        driver_info: String::new(),
        api_version: properties.api_version,
    };
    // VkPhysicalDeviceDriverProperties is core in Vulkan 1.2, for both the instance (requested
    // >= 1.2) and the device.
    if properties.api_version >= vk::API_VERSION_1_2 && instance.api_version >= vk::API_VERSION_1_2
    {
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut properties2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
        // SAFETY: core 1.1 entry point, the chain holds a valid driver-properties structure.
        unsafe {
            instance
                .instance
                .get_physical_device_properties2(physical_device, &mut properties2)
        };
        info.driver_name = c_chars_to_string(driver.driver_name_as_c_str());
        info.driver_info = c_chars_to_string(driver.driver_info_as_c_str());
    }
    info
}

impl InstanceCtx {
    /// `vkGetPhysicalDeviceProperties2` (core 1.1) or its KHR name below 1.1; `false` where the
    /// instance has neither.
    fn properties2(
        &self,
        physical_device: vk::PhysicalDevice,
        properties: &mut vk::PhysicalDeviceProperties2<'_>,
    ) -> bool {
        if self.api_version >= vk::API_VERSION_1_1 {
            // SAFETY: core 1.1 entry point; the caller's chain holds valid structures.
            unsafe {
                self.instance
                    .get_physical_device_properties2(physical_device, properties)
            };
            true
        } else if let Some(properties2) = &self.properties2 {
            // SAFETY: the extension is enabled; the caller's chain holds valid structures.
            unsafe { properties2.get_physical_device_properties2(physical_device, properties) };
            true
        } else {
            false
        }
    }

    /// `vkGetPhysicalDeviceFeatures2` (core 1.1) or its KHR name below 1.1; `false` where the
    /// instance has neither (a Vulkan 1.0 instance without the extension).
    fn features2(
        &self,
        physical_device: vk::PhysicalDevice,
        features: &mut vk::PhysicalDeviceFeatures2<'_>,
    ) -> bool {
        if self.api_version >= vk::API_VERSION_1_1 {
            // SAFETY: core 1.1 entry point; the caller's chain holds valid structures.
            unsafe {
                self.instance
                    .get_physical_device_features2(physical_device, features)
            };
            true
        } else if let Some(properties2) = &self.properties2 {
            // SAFETY: the extension is enabled; the caller's chain holds valid structures.
            unsafe { properties2.get_physical_device_features2(physical_device, features) };
            true
        } else {
            false
        }
    }
}

/// The device extensions that give Vulkan 1.2's depth/stencil resolves (with
/// `vkCreateRenderPass2`) below it, in the order they require each other.
const KHR_DEPTH_STENCIL_RESOLVE: [&CStr; 4] = [
    ash::khr::multiview::NAME,
    ash::khr::maintenance2::NAME,
    ash::khr::create_renderpass2::NAME,
    ash::khr::depth_stencil_resolve::NAME,
];

/// The optional features `physical_device` has (`dynamicRendering` and the dynamic compare op
/// with Vulkan 1.3 or the extensions that give them below it, `depthClipControl` and
/// `graphicsPipelineLibrary` only with their extensions).
fn supported_features(
    instance: &InstanceCtx,
    physical_device: vk::PhysicalDevice,
    device_api: u32,
    vulkan_1_3: bool,
) -> Features {
    // SAFETY: `physical_device` was enumerated from this instance.
    let core = unsafe {
        instance
            .instance
            .get_physical_device_features(physical_device)
    };
    // SAFETY: `physical_device` was enumerated from this instance.
    let extensions = unsafe {
        instance
            .instance
            .enumerate_device_extension_properties(physical_device)
    }
    .unwrap_or_default();
    let has = |name: &CStr| {
        extensions
            .iter()
            .any(|e| e.extension_name_as_c_str() == Ok(name))
    };
    let api = instance.api_version.min(device_api);
    let depth_stencil_resolve =
        api >= vk::API_VERSION_1_2 || KHR_DEPTH_STENCIL_RESOLVE.iter().all(|&name| has(name));
    let (dynamic_rendering, dynamic_compare_op) = if vulkan_1_3 {
        let mut features13 = vk::PhysicalDeviceVulkan13Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut features13);
        instance.features2(physical_device, &mut features2);
        (features13.dynamic_rendering == vk::TRUE, true)
    } else {
        let mut rendering = vk::PhysicalDeviceDynamicRenderingFeatures::default();
        let mut state = vk::PhysicalDeviceExtendedDynamicStateFeaturesEXT::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default();
        let has_rendering = depth_stencil_resolve && has(ash::khr::dynamic_rendering::NAME);
        let has_state = has(ash::ext::extended_dynamic_state::NAME);
        if has_rendering {
            features2 = features2.push_next(&mut rendering);
        }
        if has_state {
            features2 = features2.push_next(&mut state);
        }
        // The device has the extensions whose features structures are chained.
        let queried = instance.features2(physical_device, &mut features2);
        (
            queried && has_rendering && rendering.dynamic_rendering == vk::TRUE,
            queried && has_state && state.extended_dynamic_state == vk::TRUE,
        )
    };
    let has_clip_control = has(ash::ext::depth_clip_control::NAME);
    let mut depth_clip_control = false;
    if has_clip_control {
        let mut clip = vk::PhysicalDeviceDepthClipControlFeaturesEXT::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut clip);
        // The device has the extension whose features structure is chained.
        depth_clip_control = instance.features2(physical_device, &mut features2)
            && clip.depth_clip_control == vk::TRUE;
    }
    let mut graphics_pipeline_library = false;
    if has(ash::ext::graphics_pipeline_library::NAME) && has(ash::khr::pipeline_library::NAME) {
        let mut library = vk::PhysicalDeviceGraphicsPipelineLibraryFeaturesEXT::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut library);
        // The device has the extension whose features structure is chained.
        graphics_pipeline_library = instance.features2(physical_device, &mut features2)
            && library.graphics_pipeline_library == vk::TRUE;
    }
    Features {
        dynamic_rendering,
        dynamic_compare_op,
        depth_stencil_resolve,
        depth_bounds: core.depth_bounds == vk::TRUE,
        depth_bias_clamp: core.depth_bias_clamp == vk::TRUE,
        depth_clip_control,
        graphics_pipeline_library,
    }
}

impl Gpu {
    /// Creates the instance, picks the physical device, creates the device and its queue.
    pub fn new(options: &GpuOptions) -> Result<Self> {
        // Below 1.1, extension features and properties are queried through
        // VK_KHR_get_physical_device_properties2, which the extensions also require.
        let f = &options.features;
        let extension_features = f.depth_clip_control
            || f.graphics_pipeline_library
            || f.dynamic_rendering
            || f.dynamic_compare_op
            || f.depth_stencil_resolve;
        let instance = InstanceCtx::new(
            options.validation,
            options.sync_validation,
            options.max_api_version,
            extension_features,
        )?;

        // SAFETY: valid instance.
        let physical_devices = unsafe { instance.instance.enumerate_physical_devices() }
            .context("vkEnumeratePhysicalDevices failed")?;
        if physical_devices.is_empty() {
            bail!(
                "no device found: the Vulkan loader lists no physical device \
                 (apt-get install mesa-vulkan-drivers for lavapipe)"
            );
        }
        let candidates: Vec<(vk::PhysicalDevice, DeviceInfo)> = physical_devices
            .iter()
            .map(|&pd| (pd, device_info(&instance, pd)))
            .collect();
        let chosen = match &options.device {
            Some(wanted) => {
                let wanted_lower = wanted.to_lowercase();
                candidates
                    .iter()
                    .find(|(_, info)| info.name.to_lowercase().contains(&wanted_lower))
                    .ok_or_else(|| {
                        let names: Vec<String> = candidates
                            .iter()
                            .map(|(_, i)| format!("'{}'", i.name))
                            .collect();
                        anyhow!(
                            "no device name contains '{wanted}' (case-insensitive); \
                             available devices: {}",
                            names.join(", ")
                        )
                    })?
            }
            None => candidates
                .iter()
                .find(|(_, info)| info.name.contains("llvmpipe"))
                .unwrap_or(&candidates[0]),
        };
        let (physical_device, info) = chosen.clone();

        // SAFETY: `physical_device` belongs to this instance.
        let families = unsafe {
            instance
                .instance
                .get_physical_device_queue_family_properties(physical_device)
        };
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS) && f.queue_count > 0)
            .ok_or_else(|| anyhow!("device '{}' has no graphics queue", info.name))?;
        let queue_family = u32::try_from(queue_family).context("queue family index")?;

        let vulkan_1_3 =
            info.api_version >= vk::API_VERSION_1_3 && instance.api_version >= vk::API_VERSION_1_3;
        let supported =
            supported_features(&instance, physical_device, info.api_version, vulkan_1_3);
        let enabled = options.features.and(supported);

        let priorities = [1.0f32];
        let queue_infos = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // Only the optional features the scene asked for and the device has, and no extension
        // but VK_EXT_depth_clip_control and VK_EXT_graphics_pipeline_library (with the
        // VK_KHR_pipeline_library it requires) for the scenes that need them.
        let core_features = vk::PhysicalDeviceFeatures::default()
            .depth_bounds(enabled.depth_bounds)
            .depth_bias_clamp(enabled.depth_bias_clamp);
        let mut features13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(enabled.dynamic_rendering);
        // Below 1.3 (and 1.2), the extensions that stand in for the core commands, as an older
        // application enables them.
        let api = instance.api_version.min(info.api_version);
        let mut rendering_khr =
            vk::PhysicalDeviceDynamicRenderingFeatures::default().dynamic_rendering(true);
        let mut dynamic_state = vk::PhysicalDeviceExtendedDynamicStateFeaturesEXT::default()
            .extended_dynamic_state(true);
        let rendering_extension = !vulkan_1_3 && enabled.dynamic_rendering;
        let state_extension = !vulkan_1_3 && enabled.dynamic_compare_op;
        let resolve_extensions =
            api < vk::API_VERSION_1_2 && (enabled.depth_stencil_resolve || rendering_extension);
        let mut clip_control =
            vk::PhysicalDeviceDepthClipControlFeaturesEXT::default().depth_clip_control(true);
        let mut library = vk::PhysicalDeviceGraphicsPipelineLibraryFeaturesEXT::default()
            .graphics_pipeline_library(true);
        let mut extensions = Vec::new();
        if resolve_extensions {
            extensions.extend(KHR_DEPTH_STENCIL_RESOLVE.iter().map(|name| name.as_ptr()));
        }
        if rendering_extension {
            extensions.push(ash::khr::dynamic_rendering::NAME.as_ptr());
        }
        if state_extension {
            extensions.push(ash::ext::extended_dynamic_state::NAME.as_ptr());
        }
        if enabled.depth_clip_control {
            extensions.push(ash::ext::depth_clip_control::NAME.as_ptr());
        }
        if enabled.graphics_pipeline_library {
            extensions.push(ash::khr::pipeline_library::NAME.as_ptr());
            extensions.push(ash::ext::graphics_pipeline_library::NAME.as_ptr());
        }
        let mut device_create_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_features(&core_features)
            .enabled_extension_names(&extensions);
        if enabled.dynamic_rendering && vulkan_1_3 {
            device_create_info = device_create_info.push_next(&mut features13);
        }
        if rendering_extension {
            device_create_info = device_create_info.push_next(&mut rendering_khr);
        }
        if state_extension {
            device_create_info = device_create_info.push_next(&mut dynamic_state);
        }
        if enabled.depth_clip_control {
            device_create_info = device_create_info.push_next(&mut clip_control);
        }
        if enabled.graphics_pipeline_library {
            device_create_info = device_create_info.push_next(&mut library);
        }
        // SAFETY: valid physical device and create info referring to live locals.
        let device = unsafe {
            instance
                .instance
                .create_device(physical_device, &device_create_info, None)
        }
        .with_context(|| format!("vkCreateDevice failed on '{}'", info.name))?;
        // SAFETY: queue 0 of a family requested at device creation.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        // SAFETY: valid physical device.
        let memory_properties = unsafe {
            instance
                .instance
                .get_physical_device_memory_properties(physical_device)
        };

        let dynamic_rendering_khr = rendering_extension
            .then(|| ash::khr::dynamic_rendering::Device::new(&instance.instance, &device));
        let extended_dynamic_state = state_extension
            .then(|| ash::ext::extended_dynamic_state::Device::new(&instance.instance, &device));
        let create_renderpass2_khr = resolve_extensions
            .then(|| ash::khr::create_renderpass2::Device::new(&instance.instance, &device));
        Ok(Gpu {
            dynamic_rendering_khr,
            extended_dynamic_state,
            create_renderpass2_khr,
            device,
            queue,
            queue_family,
            physical_device,
            info,
            supported,
            enabled,
            memory_properties,
            instance,
        })
    }

    /// The Vulkan instance.
    pub fn instance(&self) -> &ash::Instance {
        &self.instance.instance
    }

    /// `vkCmdBeginRendering`, or its KHR name below Vulkan 1.3.
    ///
    /// # Safety
    /// As `vkCmdBeginRendering`.
    pub unsafe fn cmd_begin_rendering(&self, cmd: vk::CommandBuffer, info: &vk::RenderingInfo<'_>) {
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe {
            match &self.dynamic_rendering_khr {
                Some(khr) => khr.cmd_begin_rendering(cmd, info),
                None => self.device.cmd_begin_rendering(cmd, info),
            }
        }
    }

    /// `vkCmdEndRendering`, or its KHR name below Vulkan 1.3.
    ///
    /// # Safety
    /// As `vkCmdEndRendering`.
    pub unsafe fn cmd_end_rendering(&self, cmd: vk::CommandBuffer) {
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe {
            match &self.dynamic_rendering_khr {
                Some(khr) => khr.cmd_end_rendering(cmd),
                None => self.device.cmd_end_rendering(cmd),
            }
        }
    }

    /// `vkCmdSetDepthCompareOp`, or `VK_EXT_extended_dynamic_state`'s below Vulkan 1.3.
    ///
    /// # Safety
    /// As `vkCmdSetDepthCompareOp`.
    pub unsafe fn cmd_set_depth_compare_op(&self, cmd: vk::CommandBuffer, op: vk::CompareOp) {
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe {
            match &self.extended_dynamic_state {
                Some(ext) => ext.cmd_set_depth_compare_op(cmd, op),
                None => self.device.cmd_set_depth_compare_op(cmd, op),
            }
        }
    }

    /// `vkCreateRenderPass2`, or its KHR name below Vulkan 1.2.
    ///
    /// # Safety
    /// As `vkCreateRenderPass2`.
    pub unsafe fn create_render_pass2(
        &self,
        info: &vk::RenderPassCreateInfo2<'_>,
    ) -> ash::prelude::VkResult<vk::RenderPass> {
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe {
            match &self.create_renderpass2_khr {
                Some(khr) => khr.create_render_pass2(info, None),
                None => self.device.create_render_pass2(info, None),
            }
        }
    }

    /// The Vulkan version the tester uses: what it asked for, capped by the device's.
    pub fn api_version(&self) -> u32 {
        self.instance.api_version.min(self.info.api_version)
    }

    /// The device's limits.
    pub fn limits(&self) -> vk::PhysicalDeviceLimits {
        // SAFETY: the physical device belongs to this instance.
        unsafe {
            self.instance()
                .get_physical_device_properties(self.physical_device)
        }
        .limits
    }

    /// The device's depth/stencil resolve modes
    /// (`VkPhysicalDeviceDepthStencilResolveProperties`; the device and the instance are at
    /// Vulkan 1.2 or later, which the caller checks).
    pub fn resolve_support(&self) -> ResolveSupport {
        let mut resolve = vk::PhysicalDeviceDepthStencilResolveProperties::default();
        let mut properties2 = vk::PhysicalDeviceProperties2::default().push_next(&mut resolve);
        self.instance
            .properties2(self.physical_device, &mut properties2);
        ResolveSupport {
            depth_modes: resolve.supported_depth_resolve_modes,
            stencil_modes: resolve.supported_stencil_resolve_modes,
            independent_none: resolve.independent_resolve_none == vk::TRUE,
        }
    }

    /// The counter of validation messages (shared: still readable after `Gpu` is dropped,
    /// which is when the messages about leaks would come).
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        Arc::clone(&self.instance.log)
    }

    /// Index of a memory type allowed by `type_bits` that has all of `flags`.
    pub fn memory_type(&self, type_bits: u32, flags: vk::MemoryPropertyFlags) -> Option<u32> {
        let props = &self.memory_properties;
        (0..props.memory_type_count).find(|&i| {
            type_bits & (1 << i) != 0
                && props.memory_types[i as usize]
                    .property_flags
                    .contains(flags)
        })
    }

    /// Allocates memory for `requirements`, preferring `preferred` property flags and
    /// requiring `required` ones.
    pub fn allocate(
        &self,
        requirements: vk::MemoryRequirements,
        required: vk::MemoryPropertyFlags,
        preferred: vk::MemoryPropertyFlags,
    ) -> Result<vk::DeviceMemory> {
        let type_index = self
            .memory_type(requirements.memory_type_bits, required | preferred)
            .or_else(|| self.memory_type(requirements.memory_type_bits, required))
            .ok_or_else(|| {
                anyhow!(
                    "no memory type with {required:?} among types {:#b}",
                    requirements.memory_type_bits
                )
            })?;
        let info = vk::MemoryAllocateInfo::default()
            .allocation_size(requirements.size)
            .memory_type_index(type_index);
        // SAFETY: valid device, a memory type index reported by the device.
        unsafe { self.device.allocate_memory(&info, None) }
            .with_context(|| format!("vkAllocateMemory of {} bytes failed", requirements.size))
    }
}

/// A buffer in host-visible, host-coherent memory, persistently mapped.
pub struct HostBuffer<'a> {
    device: &'a ash::Device,
    /// The buffer handle.
    pub buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    mapped: *mut u8,
    size: usize,
}

// SAFETY: `mapped` is owned by the buffer like a boxed byte slice: written only through
// `&mut self` (`write`) and read through `&self` (`contents`), so the usual borrow rules
// keep a writer from racing readers on other threads. The Vulkan handles are plain values;
// the memory stays mapped until `Drop`.
unsafe impl Send for HostBuffer<'_> {}
// SAFETY: as above: shared access only reads.
unsafe impl Sync for HostBuffer<'_> {}

impl fmt::Debug for HostBuffer<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("HostBuffer")
            .field("buffer", &self.buffer)
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl Drop for HostBuffer<'_> {
    fn drop(&mut self) {
        // SAFETY: the handles are null or were created from `device`, which outlives `self`;
        // the GPU is done with them (every submission is fenced before resources drop).
        // Destroying null handles is a no-op; freeing memory unmaps it.
        unsafe {
            self.device.destroy_buffer(self.buffer, None);
            self.device.free_memory(self.memory, None);
        }
    }
}

impl<'a> HostBuffer<'a> {
    /// Creates a mapped host-visible coherent buffer of `size` bytes.
    pub fn new(gpu: &'a Gpu, size: usize, usage: vk::BufferUsageFlags) -> Result<Self> {
        let mut this = HostBuffer {
            device: &gpu.device,
            buffer: vk::Buffer::null(),
            memory: vk::DeviceMemory::null(),
            mapped: std::ptr::null_mut(),
            size,
        };
        let info = vk::BufferCreateInfo::default()
            .size(size as vk::DeviceSize)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        this.buffer = unsafe { gpu.device.create_buffer(&info, None) }
            .with_context(|| format!("vkCreateBuffer ({size} bytes, {usage:?}) failed"))?;
        // SAFETY: valid buffer.
        let requirements = unsafe { gpu.device.get_buffer_memory_requirements(this.buffer) };
        this.memory = gpu.allocate(
            requirements,
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
            vk::MemoryPropertyFlags::empty(),
        )?;
        // SAFETY: fresh buffer and memory of a compatible type and sufficient size.
        unsafe { gpu.device.bind_buffer_memory(this.buffer, this.memory, 0) }
            .context("vkBindBufferMemory failed")?;
        // SAFETY: host-visible memory, not mapped yet; mapped for the buffer's lifetime.
        let mapped = unsafe {
            gpu.device
                .map_memory(this.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
        }
        .context("vkMapMemory failed")?;
        this.mapped = mapped.cast();
        Ok(this)
    }

    /// Copies `bytes` to the start of the buffer (visible to the device at the next submit:
    /// the memory is coherent).
    pub fn write(&mut self, bytes: &[u8]) {
        assert!(
            bytes.len() <= self.size,
            "write past the end of a host buffer"
        );
        // SAFETY: `mapped` points to at least `size` mapped bytes; no GPU work uses the buffer
        // while the host writes (writes happen before the submit).
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), self.mapped, bytes.len()) };
    }

    /// The buffer's contents (coherent memory: valid once the writing submission's fence has
    /// signalled and a TRANSFER -> HOST barrier was recorded).
    pub fn contents(&self) -> &[u8] {
        // SAFETY: `mapped` points to `size` mapped bytes that live as long as `self`; callers
        // read only after the GPU work writing them has completed.
        unsafe { std::slice::from_raw_parts(self.mapped, self.size) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feature_names_are_vulkan_names_of_the_set_features() {
        let all = Features {
            dynamic_rendering: true,
            dynamic_compare_op: true,
            depth_stencil_resolve: true,
            depth_bounds: true,
            depth_bias_clamp: true,
            depth_clip_control: true,
            graphics_pipeline_library: true,
        };
        assert_eq!(
            all.names(),
            [
                "dynamicRendering",
                "extendedDynamicState",
                "depthBounds",
                "depthBiasClamp",
                "depthClipControl",
                "graphicsPipelineLibrary"
            ]
        );
        let some = Features {
            depth_bias_clamp: true,
            ..Features::default()
        };
        assert_eq!(all.and(some), some);
        assert_eq!(some.names(), ["depthBiasClamp"]);
        assert!(Features::default().names().is_empty());
    }
}
