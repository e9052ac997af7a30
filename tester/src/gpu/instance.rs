//! The loader entry, the instance (with the validation layer and its messenger when asked) and
//! what the physical devices say of themselves.

use super::*;

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

pub(super) fn debug_messenger_info(
    log: &Arc<ValidationLog>,
) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
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
    /// their queries need `VK_KHR_get_physical_device_properties2`). `newer_extensions`: the
    /// device extensions it will enable that a validation layer may predate, each with the
    /// first layer version that knows it; a validation layer older than one is then left out,
    /// and why is kept in `validation_skipped`: it rejects the extension's feature structure
    /// and hides or breaks the commands it brings (1.3.239 hides `VK_EXT_shader_object`'s
    /// dynamic state commands, and crashes on `VK_KHR_maintenance6`'s), so it could only count
    /// its own confusion.
    pub(super) fn new(
        validation: bool,
        sync_validation: bool,
        max_api_version: Option<u32>,
        extension_features: bool,
        newer_extensions: &[(&str, u32)],
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
        let mut validation = validation;
        let mut validation_skipped = None;
        let mut layers: Vec<*const std::ffi::c_char> = Vec::new();
        let mut extensions: Vec<*const std::ffi::c_char> = Vec::new();
        if validation {
            // SAFETY: plain global query.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .context("vkEnumerateInstanceLayerProperties failed")?;
            let found = available
                .iter()
                .find(|layer| layer.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
            let Some(found) = found else {
                bail!(
                    "VK_LAYER_KHRONOS_validation not found: install vulkan-validationlayers \
                     (apt-get install vulkan-validationlayers)"
                );
            };
            let version = |v: u32| {
                format!(
                    "{}.{}.{}",
                    vk::api_version_major(v),
                    vk::api_version_minor(v),
                    vk::api_version_patch(v)
                )
            };
            if let Some((name, known)) = newer_extensions
                .iter()
                .find(|(_, known)| found.spec_version < *known)
            {
                validation = false;
                validation_skipped = Some(format!(
                    "VK_LAYER_KHRONOS_validation {} predates {name} ({}): this render ran \
                     without it",
                    version(found.spec_version),
                    version(*known)
                ));
            }
        }
        if validation {
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
            validation_skipped,
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

pub(super) fn c_chars_to_string(chars: Result<&CStr, std::ffi::FromBytesUntilNulError>) -> String {
    chars.map_or_else(
        |_| "(invalid)".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    )
}

pub(super) fn device_info(
    instance: &InstanceCtx,
    physical_device: vk::PhysicalDevice,
) -> DeviceInfo {
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
    pub(super) fn properties2(
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
    pub(super) fn features2(
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
