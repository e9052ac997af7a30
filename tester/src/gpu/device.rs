//! Which optional features a scene gets (those it needs and the device has), and the logical
//! device with its queue.

use super::instance::device_info;
use super::*;

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
pub(super) fn supported_features(
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
    let mut depth_clip_enable = false;
    if has(ash::ext::depth_clip_enable::NAME) {
        let mut clip = vk::PhysicalDeviceDepthClipEnableFeaturesEXT::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut clip);
        // The device has the extension whose features structure is chained.
        depth_clip_enable = instance.features2(physical_device, &mut features2)
            && clip.depth_clip_enable == vk::TRUE;
    }
    let mut graphics_pipeline_library = false;
    if has(ash::ext::graphics_pipeline_library::NAME) && has(ash::khr::pipeline_library::NAME) {
        let mut library = vk::PhysicalDeviceGraphicsPipelineLibraryFeaturesEXT::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut library);
        // The device has the extension whose features structure is chained.
        graphics_pipeline_library = instance.features2(physical_device, &mut features2)
            && library.graphics_pipeline_library == vk::TRUE;
    }
    // Vulkan 1.2 core only (the tester does not enable VK_KHR_separate_depth_stencil_layouts).
    let mut separate_depth_stencil_layouts = false;
    if api >= vk::API_VERSION_1_2 {
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut features12);
        separate_depth_stencil_layouts = instance.features2(physical_device, &mut features2)
            && features12.separate_depth_stencil_layouts == vk::TRUE;
    }
    let multiview = (api >= vk::API_VERSION_1_1 || has(ash::khr::multiview::NAME)) && {
        let mut views = vk::PhysicalDeviceMultiviewFeatures::default();
        let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut views);
        // Core in 1.1; below it chained only where the device has the extension.
        instance.features2(physical_device, &mut features2) && views.multiview == vk::TRUE
    };
    Features {
        multiview,
        dynamic_rendering,
        dynamic_compare_op,
        depth_stencil_resolve,
        separate_depth_stencil_layouts,
        depth_bounds: core.depth_bounds == vk::TRUE,
        depth_bias_clamp: core.depth_bias_clamp == vk::TRUE,
        depth_clip_control,
        graphics_pipeline_library,
        depth_range_unrestricted: has(ash::ext::depth_range_unrestricted::NAME),
        depth_clamp: core.depth_clamp == vk::TRUE,
        depth_clip_enable,
        geometry_shader: core.geometry_shader == vk::TRUE,
        tessellation_shader: core.tessellation_shader == vk::TRUE,
        // It requires VK_KHR_get_physical_device_properties2 below 1.1 (enabled with the
        // instance where asked for).
        push_descriptor: has(ash::khr::push_descriptor::NAME),
        shader_object: vulkan_1_3 && dynamic_rendering && {
            let mut objects = vk::PhysicalDeviceShaderObjectFeaturesEXT::default();
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut objects);
            // Chained only where the device has the extension.
            has(ash::ext::shader_object::NAME)
                && instance.features2(physical_device, &mut features2)
                && objects.shader_object == vk::TRUE
        },
        mesh_shader: vulkan_1_3 && {
            let mut mesh = vk::PhysicalDeviceMeshShaderFeaturesEXT::default();
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut mesh);
            // Chained only where the device has the extension.
            has(ash::ext::mesh_shader::NAME)
                && instance.features2(physical_device, &mut features2)
                && mesh.mesh_shader == vk::TRUE
        },
        descriptor_buffer: vulkan_1_3 && {
            let mut buffers = vk::PhysicalDeviceDescriptorBufferFeaturesEXT::default();
            let mut features12 = vk::PhysicalDeviceVulkan12Features::default();
            let mut features2 = vk::PhysicalDeviceFeatures2::default()
                .push_next(&mut buffers)
                .push_next(&mut features12);
            // Chained only where the device has the extension.
            has(ash::ext::descriptor_buffer::NAME)
                && instance.features2(physical_device, &mut features2)
                && buffers.descriptor_buffer == vk::TRUE
                && features12.buffer_device_address == vk::TRUE
        },
        maintenance6: vulkan_1_3 && {
            let mut maintenance = vk::PhysicalDeviceMaintenance6FeaturesKHR::default();
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut maintenance);
            // Chained only where the device has the extension.
            has(ash::khr::maintenance6::NAME)
                && instance.features2(physical_device, &mut features2)
                && maintenance.maintenance6 == vk::TRUE
        },
        dynamic_rendering_local_read: vulkan_1_3 && dynamic_rendering && {
            let mut local_read = vk::PhysicalDeviceDynamicRenderingLocalReadFeaturesKHR::default();
            let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut local_read);
            // Chained only where the device has the extension.
            has(ash::khr::dynamic_rendering_local_read::NAME)
                && instance.features2(physical_device, &mut features2)
                && local_read.dynamic_rendering_local_read == vk::TRUE
        },
    }
}

/// The extensions `features` enable that an installed validation layer may predate, with the
/// first layer version that knows each (the instance leaves an older layer out).
fn newer_extensions(features: &Features) -> Vec<(&'static str, u32)> {
    [
        (
            features.shader_object,
            ("VK_EXT_shader_object", vk::make_api_version(0, 1, 3, 246)),
        ),
        (
            features.maintenance6,
            ("VK_KHR_maintenance6", vk::make_api_version(0, 1, 3, 280)),
        ),
        // Released with the Vulkan 1.3.276 headers (January 2024).
        (
            features.dynamic_rendering_local_read,
            (
                "VK_KHR_dynamic_rendering_local_read",
                vk::make_api_version(0, 1, 3, 276),
            ),
        ),
    ]
    .into_iter()
    .filter_map(|(on, extension)| on.then_some(extension))
    .collect()
}

impl Gpu {
    /// Creates the instance, picks the physical device, creates the device and its queue.
    pub fn new(options: &GpuOptions) -> Result<Self> {
        // Below 1.1, extension features and properties are queried through
        // VK_KHR_get_physical_device_properties2, which the extensions also require.
        let f = &options.features;
        let extension_features = f.depth_clip_control
            || f.depth_clip_enable
            || f.graphics_pipeline_library
            || f.dynamic_rendering
            || f.dynamic_compare_op
            || f.depth_stencil_resolve
            || f.push_descriptor
            || f.multiview;
        let instance = InstanceCtx::new(
            options.validation,
            options.sync_validation,
            options.max_api_version,
            extension_features,
            &newer_extensions(&options.features),
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
        let mut enabled = options.features.and(supported);
        // Shader objects and local reads need dynamic rendering enabled (their extensions'
        // dependency).
        enabled.dynamic_rendering |= enabled.shader_object || enabled.dynamic_rendering_local_read;

        let priorities = [1.0f32];
        let queue_infos = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // Only the optional features the scene asked for and the device has, and no extension
        // but VK_EXT_depth_clip_control, VK_EXT_depth_clip_enable and
        // VK_EXT_graphics_pipeline_library (with the
        // VK_KHR_pipeline_library it requires) for the scenes that need them.
        let core_features = vk::PhysicalDeviceFeatures::default()
            .depth_bounds(enabled.depth_bounds)
            .depth_bias_clamp(enabled.depth_bias_clamp)
            .depth_clamp(enabled.depth_clamp)
            .geometry_shader(enabled.geometry_shader)
            .tessellation_shader(enabled.tessellation_shader);
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
        let mut clip_enable =
            vk::PhysicalDeviceDepthClipEnableFeaturesEXT::default().depth_clip_enable(true);
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
        if enabled.depth_clip_enable {
            extensions.push(ash::ext::depth_clip_enable::NAME.as_ptr());
        }
        if enabled.graphics_pipeline_library {
            extensions.push(ash::khr::pipeline_library::NAME.as_ptr());
            extensions.push(ash::ext::graphics_pipeline_library::NAME.as_ptr());
        }
        if enabled.depth_range_unrestricted {
            extensions.push(ash::ext::depth_range_unrestricted::NAME.as_ptr());
        }
        if enabled.push_descriptor {
            extensions.push(ash::khr::push_descriptor::NAME.as_ptr());
        }
        if enabled.shader_object {
            extensions.push(ash::ext::shader_object::NAME.as_ptr());
        }
        let mut shader_object =
            vk::PhysicalDeviceShaderObjectFeaturesEXT::default().shader_object(true);
        if enabled.mesh_shader {
            extensions.push(ash::ext::mesh_shader::NAME.as_ptr());
        }
        let mut mesh_shader = vk::PhysicalDeviceMeshShaderFeaturesEXT::default().mesh_shader(true);
        if enabled.descriptor_buffer {
            extensions.push(ash::ext::descriptor_buffer::NAME.as_ptr());
        }
        let mut descriptor_buffer =
            vk::PhysicalDeviceDescriptorBufferFeaturesEXT::default().descriptor_buffer(true);
        if enabled.maintenance6 {
            extensions.push(ash::khr::maintenance6::NAME.as_ptr());
        }
        // Below 1.1 the extension (unless the resolves' extensions brought it already).
        if enabled.multiview && api < vk::API_VERSION_1_1 && !resolve_extensions {
            extensions.push(ash::khr::multiview::NAME.as_ptr());
        }
        let mut multiview = vk::PhysicalDeviceMultiviewFeatures::default().multiview(true);
        let mut maintenance6 =
            vk::PhysicalDeviceMaintenance6FeaturesKHR::default().maintenance6(true);
        if enabled.dynamic_rendering_local_read {
            extensions.push(ash::khr::dynamic_rendering_local_read::NAME.as_ptr());
        }
        let mut local_read = vk::PhysicalDeviceDynamicRenderingLocalReadFeaturesKHR::default()
            .dynamic_rendering_local_read(true);
        let mut device_create_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_infos)
            .enabled_features(&core_features)
            .enabled_extension_names(&extensions);
        if enabled.dynamic_rendering && vulkan_1_3 {
            device_create_info = device_create_info.push_next(&mut features13);
        }
        let mut features12 = vk::PhysicalDeviceVulkan12Features::default()
            .separate_depth_stencil_layouts(enabled.separate_depth_stencil_layouts)
            .buffer_device_address(enabled.descriptor_buffer);
        if enabled.separate_depth_stencil_layouts || enabled.descriptor_buffer {
            device_create_info = device_create_info.push_next(&mut features12);
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
        if enabled.depth_clip_enable {
            device_create_info = device_create_info.push_next(&mut clip_enable);
        }
        if enabled.graphics_pipeline_library {
            device_create_info = device_create_info.push_next(&mut library);
        }
        if enabled.shader_object {
            device_create_info = device_create_info.push_next(&mut shader_object);
        }
        if enabled.mesh_shader {
            device_create_info = device_create_info.push_next(&mut mesh_shader);
        }
        if enabled.descriptor_buffer {
            device_create_info = device_create_info.push_next(&mut descriptor_buffer);
        }
        if enabled.maintenance6 {
            device_create_info = device_create_info.push_next(&mut maintenance6);
        }
        if enabled.dynamic_rendering_local_read {
            device_create_info = device_create_info.push_next(&mut local_read);
        }
        if enabled.multiview {
            device_create_info = device_create_info.push_next(&mut multiview);
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
        let push_descriptor_khr = enabled
            .push_descriptor
            .then(|| ash::khr::push_descriptor::Device::new(&instance.instance, &device));
        let shader_object = enabled
            .shader_object
            .then(|| ash::ext::shader_object::Device::new(&instance.instance, &device));
        let mesh_shader = enabled
            .mesh_shader
            .then(|| ash::ext::mesh_shader::Device::new(&instance.instance, &device));
        let descriptor_buffer = enabled.descriptor_buffer.then(|| {
            let mut properties = vk::PhysicalDeviceDescriptorBufferPropertiesEXT::default();
            let mut properties2 =
                vk::PhysicalDeviceProperties2::default().push_next(&mut properties);
            // SAFETY: a Vulkan 1.3 instance and device that has the extension.
            unsafe {
                instance
                    .instance
                    .get_physical_device_properties2(physical_device, &mut properties2)
            };
            properties.p_next = std::ptr::null_mut();
            (
                ash::ext::descriptor_buffer::Device::new(&instance.instance, &device),
                properties,
            )
        });
        let maintenance6 = enabled
            .maintenance6
            .then(|| ash::khr::maintenance6::Device::new(&instance.instance, &device));
        let dynamic_rendering_local_read = enabled.dynamic_rendering_local_read.then(|| {
            ash::khr::dynamic_rendering_local_read::Device::new(&instance.instance, &device)
        });
        Ok(Gpu {
            maintenance6,
            dynamic_rendering_local_read,
            descriptor_buffer,
            shader_object,
            mesh_shader,
            push_descriptor_khr,
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

    /// `vkCmdPushDescriptorSetKHR`; `false` where `VK_KHR_push_descriptor` is not enabled
    /// (nothing recorded).
    ///
    /// # Safety
    /// As `vkCmdPushDescriptorSetKHR`.
    pub unsafe fn cmd_push_descriptor_set(
        &self,
        cmd: vk::CommandBuffer,
        bind_point: vk::PipelineBindPoint,
        layout: vk::PipelineLayout,
        writes: &[vk::WriteDescriptorSet<'_>],
    ) -> bool {
        let Some(khr) = &self.push_descriptor_khr else {
            return false;
        };
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe { khr.cmd_push_descriptor_set(cmd, bind_point, layout, 0, writes) };
        true
    }

    /// `vkCmdPushDescriptorSetWithTemplateKHR` into set 0; `false` where
    /// `VK_KHR_push_descriptor` is not enabled (nothing recorded).
    ///
    /// # Safety
    /// As `vkCmdPushDescriptorSetWithTemplateKHR`.
    pub unsafe fn cmd_push_descriptor_set_with_template(
        &self,
        cmd: vk::CommandBuffer,
        template: vk::DescriptorUpdateTemplate,
        layout: vk::PipelineLayout,
        data: *const std::ffi::c_void,
    ) -> bool {
        let Some(khr) = &self.push_descriptor_khr else {
            return false;
        };
        // SAFETY: the caller's contract; the extension is enabled where it is loaded.
        unsafe { khr.cmd_push_descriptor_set_with_template(cmd, template, layout, 0, data) };
        true
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
    /// Why validation, asked for, was left out of this instance (a validation layer older
    /// than an extension the device enables); `None` where it runs or was not asked for.
    pub fn validation_skipped(&self) -> Option<&str> {
        self.instance.validation_skipped.as_deref()
    }

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
        self.allocate_with(
            requirements,
            required,
            preferred,
            vk::MemoryAllocateFlags::empty(),
        )
    }

    /// [`Self::allocate`] with `VkMemoryAllocateFlagsInfo`'s `flags` (none: no structure).
    pub fn allocate_with(
        &self,
        requirements: vk::MemoryRequirements,
        required: vk::MemoryPropertyFlags,
        preferred: vk::MemoryPropertyFlags,
        flags: vk::MemoryAllocateFlags,
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
        let mut flags_info = vk::MemoryAllocateFlagsInfo::default().flags(flags);
        let mut info = vk::MemoryAllocateInfo::default()
            .allocation_size(requirements.size)
            .memory_type_index(type_index);
        if !flags.is_empty() {
            info = info.push_next(&mut flags_info);
        }
        // SAFETY: valid device, a memory type index reported by the device.
        unsafe { self.device.allocate_memory(&info, None) }
            .with_context(|| format!("vkAllocateMemory of {} bytes failed", requirements.size))
    }
}
