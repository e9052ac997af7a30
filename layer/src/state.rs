//! Per-instance and per-device layer state, keyed by the loader's dispatch pointer.
//!
//! The first pointer-sized word of every dispatchable handle is the loader's dispatch table, so
//! an instance and its physical devices share a key, and a device, its queues and its command
//! buffers share another. A lookup clones an `Arc` and releases the registry lock before the
//! caller calls down the chain; the lock is only taken at object creation and destruction and
//! for lookups on paths that are not per-draw.

use std::collections::HashMap;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError};

use ash::vk::{self, Handle};

use crate::command_state::{Reversing, Target};
use crate::config::Settings;
use crate::objects::DeviceObjects;
use crate::policy::{DevicePolicy, Observed, ResolveSupport};

/// The loader's dispatch table pointer of a dispatchable handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DispatchKey(usize);

impl DispatchKey {
    /// Reads the key of `handle`.
    ///
    /// # Safety
    /// `handle` must be a live dispatchable Vulkan handle created through the loader.
    pub unsafe fn of<H: Handle>(handle: H) -> DispatchKey {
        // SAFETY: dispatchable handles point at an object whose first word is the loader's
        // dispatch table pointer (loader-layer interface, "Dispatchable Object Creation").
        DispatchKey(unsafe { *(handle.as_raw() as *const usize) })
    }
}

/// What the layer keeps for one `VkInstance`.
pub struct InstanceState {
    pub handle: vk::Instance,
    /// The API version the application asked for (`VkApplicationInfo::apiVersion`, 1.0 if
    /// none): core commands of later versions are not available to it.
    pub api_version: u32,
    /// `VK_KHR_get_physical_device_properties2` is enabled (by the application or by revz).
    pub properties2_enabled: bool,
    /// revz added `VK_KHR_get_physical_device_properties2` (its commands are hidden from the
    /// application, which did not enable it).
    pub added_properties2: bool,
    /// The next layer's `vkGetInstanceProcAddr`, for everything revz does not intercept.
    pub next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    /// The next layer's instance commands.
    pub next: ash::Instance,
    pub settings: Arc<Settings>,
    /// The application as its profile names it (`crate::profile`): executable,
    /// `VkApplicationInfo` names, API version.
    pub application: serde_json::Value,
    /// Where each setting not at its default got its value, for the profile.
    pub setting_origins: Vec<(crate::config::Key, String)>,
}

impl std::fmt::Debug for InstanceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("InstanceState")
            .field("handle", &self.handle)
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

/// What the layer keeps for one `VkDevice`.
pub struct DeviceState {
    pub handle: vk::Device,
    /// The next layer's `vkGetDeviceProcAddr`, for everything revz does not intercept.
    pub next_get_device_proc_addr: vk::PFN_vkGetDeviceProcAddr,
    /// The next layer's device commands.
    pub next: ash::Device,
    /// Commands ash's core tables do not cover, or that may come from an extension.
    pub commands: DeviceCommands,
    pub settings: Arc<Settings>,
    pub policy: DevicePolicy,
    /// The depth resolve modes the device supports and which depth and stencil modes it lets
    /// one resolve combine: MIN and MAX are swapped only where the device allows the result.
    pub resolve_support: ResolveSupport,
    /// revz added `VK_EXT_extended_dynamic_state` (its commands are hidden from the
    /// application, which did not enable it).
    pub added_extended_dynamic_state: bool,
    /// What revz learned about the application while it records.
    pub observed: Observed,
    /// The cameras the application's projections belong to, as recordings learn them
    /// (`crate::hooks::cameras`).
    pub cameras: crate::hooks::cameras::DeviceCameras,
    pub objects: DeviceObjects,
    /// Asks the device which image parameters a format supports (for promotion).
    pub image_formats: ImageFormatQuery,
    /// The depth profile, where the `report` setting asks for one.
    pub profile: Option<Arc<crate::profile::Profile>>,
    /// What converting copies of reversed depth images needs (`crate::depth_copy`).
    pub copies: crate::depth_copy::DeviceCopies,
}

/// `vkGetPhysicalDeviceImageFormatProperties` of the device's physical device.
#[derive(Clone, Copy)]
pub struct ImageFormatQuery {
    pub physical_device: vk::PhysicalDevice,
    pub get: vk::PFN_vkGetPhysicalDeviceImageFormatProperties,
}

impl std::fmt::Debug for ImageFormatQuery {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImageFormatQuery")
            .field("physical_device", &self.physical_device)
            .finish_non_exhaustive()
    }
}

impl ImageFormatQuery {
    /// Whether an image of `info`'s type, tiling, usage, flags, size, mip levels, layers and
    /// samples can be created in `format`.
    pub fn supports(&self, info: &vk::ImageCreateInfo<'_>, format: vk::Format) -> bool {
        let mut properties = vk::ImageFormatProperties::default();
        // SAFETY: a live physical device and a valid output structure.
        let result = unsafe {
            (self.get)(
                self.physical_device,
                format,
                info.image_type,
                info.tiling,
                info.usage,
                info.flags,
                &mut properties,
            )
        };
        let extent = properties.max_extent;
        result == vk::Result::SUCCESS
            && properties.sample_counts.contains(info.samples)
            && info.mip_levels <= properties.max_mip_levels
            && info.array_layers <= properties.max_array_layers
            && info.extent.width <= extent.width
            && info.extent.height <= extent.height
            && info.extent.depth <= extent.depth
    }
}

impl DeviceState {
    /// The depth target revz acts on when `view` is the depth attachment.
    pub fn view_target(&self, view: vk::ImageView) -> Target {
        self.observed.effective(self.objects.view_target(view))
    }

    /// How this device's command buffers reverse their draws now.
    pub fn reversing(&self) -> Reversing {
        self.policy.reversing(&self.observed)
    }

    /// A depth clear value on a reversed attachment.
    pub fn reversed_clear(&self, depth: f32) -> f32 {
        self.policy.reversed_clear(depth, &self.observed)
    }

    /// A depth clear value on the reversed `image`: with the n / f of the camera that last
    /// drew into it where revz knows one, else with n / f = 0 (no far plane). Never another
    /// camera's: with `far_clip = keep`, a main view cleared to its shadow light's n / f (0.08
    /// against the camera's 0.01) lost every fragment (the `shadow-map-perspective` scene).
    pub fn reversed_clear_of(&self, image: Option<vk::Image>, depth: f32) -> f32 {
        let near_over_far = image
            .and_then(|image| self.image_camera(image))
            .unwrap_or(0.0);
        self.policy.reversed_clear_at(depth, near_over_far)
    }

    /// The map of standard depth onto the reversed `image`: its camera's where revz remembers
    /// one, else `recording`'s (the map the draws of the recording that copies or refreshes
    /// it use; another thread may have moved the device's last seen since).
    pub fn reversal_of(
        &self,
        image: vk::Image,
        recording: crate::conv::Reversal,
    ) -> crate::conv::Reversal {
        match self.image_camera(image) {
            Some(near_over_far) => self.policy.reversal_of(Some(near_over_far), &self.observed),
            None => recording,
        }
    }

    /// Infinite mode: the n / f of the camera whose draws last went into `image`, where revz
    /// remembers one ([`DeviceObjects::near_over_far`]). In the other modes nothing is
    /// remembered, and nothing is looked up (no lock).
    pub fn image_camera(&self, image: vk::Image) -> Option<f32> {
        if !self.remembers_cameras() {
            return None;
        }
        if self.stores_complementary(image) {
            // Complementary depth: the map of n / f = 0, whatever camera drew it.
            return Some(0.0);
        }
        self.objects.near_over_far.get(&image)
    }

    /// Infinite mode: whether `image` stores complementary depth
    /// (`crate::policy::DevicePolicy::stores_complementary`).
    pub fn stores_complementary(&self, image: vk::Image) -> bool {
        self.remembers_cameras() && self.objects.complementary_images.get(&image).is_some()
    }

    /// Whether images remember their camera's n / f (infinite mode only): elsewhere the hooks
    /// look nothing up for it.
    pub fn remembers_cameras(&self) -> bool {
        self.policy.mode == crate::config::Mode::Infinite
    }
}

/// `vkCmdEndRendering2KHR` / `vkCmdEndRendering2EXT`: the command buffer and a
/// `VkRenderingEndInfoKHR` (null allowed), which revz passes down untouched.
pub type PfnCmdEndRendering2 =
    unsafe extern "system" fn(vk::CommandBuffer, *const std::ffi::c_void);

/// Next-layer commands that exist under a core or an extension name, whichever the device has.
#[derive(Clone, Copy, Debug, Default)]
pub struct DeviceCommands {
    pub set_depth_compare_op: Option<vk::PFN_vkCmdSetDepthCompareOp>,
    /// `VK_EXT_extended_dynamic_state3` (Zink's clip convention).
    pub set_depth_clip_negative_one_to_one: Option<vk::PFN_vkCmdSetDepthClipNegativeOneToOneEXT>,
    /// `VK_EXT_depth_clamp_control`.
    pub set_depth_clamp_range: Option<crate::vk_ext::PfnCmdSetDepthClampRange>,
    /// `VK_EXT_extended_dynamic_state3` or shader objects (Zink makes the clamp dynamic).
    pub set_depth_clamp_enable: Option<vk::PFN_vkCmdSetDepthClampEnableEXT>,
    /// `VK_EXT_extended_dynamic_state3` or shader objects (with `VK_EXT_depth_clip_enable`).
    pub set_depth_clip_enable: Option<vk::PFN_vkCmdSetDepthClipEnableEXT>,
    pub set_viewport_with_count: Option<vk::PFN_vkCmdSetViewportWithCount>,
    pub begin_render_pass2: Option<vk::PFN_vkCmdBeginRenderPass2>,
    pub next_subpass2: Option<vk::PFN_vkCmdNextSubpass2>,
    pub end_render_pass2: Option<vk::PFN_vkCmdEndRenderPass2>,
    pub create_render_pass2: Option<vk::PFN_vkCreateRenderPass2>,
    pub begin_rendering: Option<vk::PFN_vkCmdBeginRendering>,
    pub get_device_image_memory_requirements: Option<vk::PFN_vkGetDeviceImageMemoryRequirements>,
    pub end_rendering: Option<vk::PFN_vkCmdEndRendering>,
    /// `vkCmdEndRendering2KHR` (`VK_KHR_maintenance10`) and `vkCmdEndRendering2EXT`
    /// (`VK_EXT_fragment_density_map_offset`): not in ash 0.38.
    pub end_rendering2_khr: Option<PfnCmdEndRendering2>,
    pub end_rendering2_ext: Option<PfnCmdEndRendering2>,
    pub draw_indirect_count: Option<vk::PFN_vkCmdDrawIndirectCount>,
    pub draw_indexed_indirect_count: Option<vk::PFN_vkCmdDrawIndexedIndirectCount>,
    pub draw_mesh_tasks_ext: Option<vk::PFN_vkCmdDrawMeshTasksEXT>,
    pub draw_mesh_tasks_indirect_ext: Option<vk::PFN_vkCmdDrawMeshTasksIndirectEXT>,
    pub draw_mesh_tasks_indirect_count_ext: Option<vk::PFN_vkCmdDrawMeshTasksIndirectCountEXT>,
    pub draw_mesh_tasks_nv: Option<vk::PFN_vkCmdDrawMeshTasksNV>,
    pub draw_mesh_tasks_indirect_nv: Option<vk::PFN_vkCmdDrawMeshTasksIndirectNV>,
    pub draw_multi_ext: Option<vk::PFN_vkCmdDrawMultiEXT>,
    pub draw_multi_indexed_ext: Option<vk::PFN_vkCmdDrawMultiIndexedEXT>,
    pub draw_indirect_byte_count_ext: Option<vk::PFN_vkCmdDrawIndirectByteCountEXT>,
    pub draw_mesh_tasks_indirect_count_nv: Option<vk::PFN_vkCmdDrawMeshTasksIndirectCountNV>,
    pub draw_cluster_huawei: Option<vk::PFN_vkCmdDrawClusterHUAWEI>,
    pub draw_cluster_indirect_huawei: Option<vk::PFN_vkCmdDrawClusterIndirectHUAWEI>,
    pub execute_generated_commands_nv: Option<vk::PFN_vkCmdExecuteGeneratedCommandsNV>,
    pub execute_generated_commands_ext: Option<crate::ffi::PfnCmdExecuteGeneratedCommandsExt>,
    pub bind_shaders_ext: Option<vk::PFN_vkCmdBindShadersEXT>,
    /// `VK_EXT_shader_object`: revz makes reversed variants of fragment shader objects.
    pub create_shaders_ext: Option<vk::PFN_vkCreateShadersEXT>,
    pub destroy_shader_ext: Option<vk::PFN_vkDestroyShaderEXT>,
    pub push_constants2: Option<vk::PFN_vkCmdPushConstants2KHR>,
    pub queue_submit2: Option<vk::PFN_vkQueueSubmit2>,
    pub queue_present: Option<vk::PFN_vkQueuePresentKHR>,
    pub copy_buffer_to_image2: Option<vk::PFN_vkCmdCopyBufferToImage2>,
    pub copy_image2: Option<vk::PFN_vkCmdCopyImage2>,
    pub copy_image_to_buffer2: Option<vk::PFN_vkCmdCopyImageToBuffer2>,
    pub push_descriptor_set: Option<vk::PFN_vkCmdPushDescriptorSetKHR>,
    pub bind_descriptor_sets2: Option<vk::PFN_vkCmdBindDescriptorSets2KHR>,
    pub set_descriptor_buffer_offsets: Option<vk::PFN_vkCmdSetDescriptorBufferOffsetsEXT>,
    /// `VK_EXT_descriptor_buffer`'s other commands that bind compute descriptors (followed,
    /// and replayed in their first form after a conversion's dispatch).
    pub set_descriptor_buffer_offsets2: Option<vk::PFN_vkCmdSetDescriptorBufferOffsets2EXT>,
    pub bind_embedded_samplers: Option<vk::PFN_vkCmdBindDescriptorBufferEmbeddedSamplersEXT>,
    pub bind_embedded_samplers2: Option<vk::PFN_vkCmdBindDescriptorBufferEmbeddedSamplers2EXT>,
    pub bind_descriptor_buffers: Option<vk::PFN_vkCmdBindDescriptorBuffersEXT>,
    pub push_descriptor_set_with_template: Option<vk::PFN_vkCmdPushDescriptorSetWithTemplateKHR>,
    /// `VK_KHR_maintenance6` (Vulkan 1.4): the push-descriptor commands taking an info.
    pub push_descriptor_set2: Option<vk::PFN_vkCmdPushDescriptorSet2KHR>,
    pub push_descriptor_set_with_template2: Option<vk::PFN_vkCmdPushDescriptorSetWithTemplate2KHR>,
    pub create_descriptor_update_template: Option<vk::PFN_vkCreateDescriptorUpdateTemplate>,
    pub destroy_descriptor_update_template: Option<vk::PFN_vkDestroyDescriptorUpdateTemplate>,
    pub begin_conditional_rendering: Option<vk::PFN_vkCmdBeginConditionalRenderingEXT>,
    pub end_conditional_rendering: Option<vk::PFN_vkCmdEndConditionalRenderingEXT>,
    pub blit_image2: Option<vk::PFN_vkCmdBlitImage2>,
    pub resolve_image2: Option<vk::PFN_vkCmdResolveImage2>,
    pub set_depth_bias2: Option<vk::PFN_vkCmdSetDepthBias2EXT>,
    /// Read twins (issue #39): descriptor writes through templates and descriptor buffers,
    /// and the synchronization2 barriers that make an image readable.
    pub update_descriptor_set_with_template: Option<vk::PFN_vkUpdateDescriptorSetWithTemplate>,
    pub get_descriptor_ext: Option<vk::PFN_vkGetDescriptorEXT>,
    pub pipeline_barrier2: Option<vk::PFN_vkCmdPipelineBarrier2>,
    pub wait_events2: Option<vk::PFN_vkCmdWaitEvents2>,
}

impl DeviceCommands {
    /// Loads every command under its core name when the application's API version `api` has
    /// it, else under its extension names: the validation layer holds an application to the
    /// version it asked for, so revz must not use core names beyond it either.
    ///
    /// # Safety
    /// `gdpa` must be the next layer's `vkGetDeviceProcAddr` and `device` live.
    pub unsafe fn load(
        gdpa: vk::PFN_vkGetDeviceProcAddr,
        device: vk::Device,
        api: u32,
    ) -> DeviceCommands {
        let find = |core_since: u32, core: &std::ffi::CStr, extensions: &[&std::ffi::CStr]| {
            let core = (api >= core_since).then_some(core);
            core.into_iter()
                .chain(extensions.iter().copied())
                // SAFETY: the caller guarantees a live device and the next layer's GDPA.
                .find_map(|name| unsafe { gdpa(device, name.as_ptr()) })
        };
        macro_rules! load {
            ($since:expr, $core:expr $(, $ext:expr)*) => {
                // SAFETY: the loader returns a function of the type the name implies.
                find($since, $core, &[$($ext),*]).map(|f| unsafe { std::mem::transmute(f) })
            };
        }
        use vk::{API_VERSION_1_2 as V12, API_VERSION_1_3 as V13};
        // Not in ash 0.38.
        const V14: u32 = vk::make_api_version(0, 1, 4, 0);
        DeviceCommands {
            set_depth_compare_op: load!(
                V13,
                c"vkCmdSetDepthCompareOp",
                c"vkCmdSetDepthCompareOpEXT"
            ),
            set_viewport_with_count: load!(
                V13,
                c"vkCmdSetViewportWithCount",
                c"vkCmdSetViewportWithCountEXT"
            ),
            begin_render_pass2: load!(V12, c"vkCmdBeginRenderPass2", c"vkCmdBeginRenderPass2KHR"),
            next_subpass2: load!(V12, c"vkCmdNextSubpass2", c"vkCmdNextSubpass2KHR"),
            end_render_pass2: load!(V12, c"vkCmdEndRenderPass2", c"vkCmdEndRenderPass2KHR"),
            create_render_pass2: load!(V12, c"vkCreateRenderPass2", c"vkCreateRenderPass2KHR"),
            begin_rendering: load!(V13, c"vkCmdBeginRendering", c"vkCmdBeginRenderingKHR"),
            get_device_image_memory_requirements: load!(
                V13,
                c"vkGetDeviceImageMemoryRequirements",
                c"vkGetDeviceImageMemoryRequirementsKHR"
            ),
            end_rendering: load!(V13, c"vkCmdEndRendering", c"vkCmdEndRenderingKHR"),
            end_rendering2_khr: load!(0, c"vkCmdEndRendering2KHR"),
            end_rendering2_ext: load!(0, c"vkCmdEndRendering2EXT"),
            draw_indirect_count: load!(
                V12,
                c"vkCmdDrawIndirectCount",
                c"vkCmdDrawIndirectCountKHR",
                c"vkCmdDrawIndirectCountAMD"
            ),
            draw_indexed_indirect_count: load!(
                V12,
                c"vkCmdDrawIndexedIndirectCount",
                c"vkCmdDrawIndexedIndirectCountKHR",
                c"vkCmdDrawIndexedIndirectCountAMD"
            ),
            // Extension-only draws: their one name is always allowed (version 0).
            draw_mesh_tasks_ext: load!(0, c"vkCmdDrawMeshTasksEXT"),
            set_depth_clip_negative_one_to_one: load!(0, c"vkCmdSetDepthClipNegativeOneToOneEXT"),
            set_depth_clamp_range: load!(0, c"vkCmdSetDepthClampRangeEXT"),
            set_depth_clamp_enable: load!(0, c"vkCmdSetDepthClampEnableEXT"),
            set_depth_clip_enable: load!(0, c"vkCmdSetDepthClipEnableEXT"),
            draw_mesh_tasks_indirect_ext: load!(0, c"vkCmdDrawMeshTasksIndirectEXT"),
            draw_mesh_tasks_indirect_count_ext: load!(0, c"vkCmdDrawMeshTasksIndirectCountEXT"),
            draw_mesh_tasks_nv: load!(0, c"vkCmdDrawMeshTasksNV"),
            draw_mesh_tasks_indirect_nv: load!(0, c"vkCmdDrawMeshTasksIndirectNV"),
            draw_multi_ext: load!(0, c"vkCmdDrawMultiEXT"),
            draw_multi_indexed_ext: load!(0, c"vkCmdDrawMultiIndexedEXT"),
            draw_indirect_byte_count_ext: load!(0, c"vkCmdDrawIndirectByteCountEXT"),
            draw_mesh_tasks_indirect_count_nv: load!(0, c"vkCmdDrawMeshTasksIndirectCountNV"),
            draw_cluster_huawei: load!(0, c"vkCmdDrawClusterHUAWEI"),
            draw_cluster_indirect_huawei: load!(0, c"vkCmdDrawClusterIndirectHUAWEI"),
            execute_generated_commands_nv: load!(0, c"vkCmdExecuteGeneratedCommandsNV"),
            execute_generated_commands_ext: load!(0, c"vkCmdExecuteGeneratedCommandsEXT"),
            bind_shaders_ext: load!(0, c"vkCmdBindShadersEXT"),
            create_shaders_ext: load!(0, c"vkCreateShadersEXT"),
            destroy_shader_ext: load!(0, c"vkDestroyShaderEXT"),
            push_constants2: load!(V14, c"vkCmdPushConstants2", c"vkCmdPushConstants2KHR"),
            queue_submit2: load!(V13, c"vkQueueSubmit2", c"vkQueueSubmit2KHR"),
            queue_present: load!(0, c"vkQueuePresentKHR"),
            copy_buffer_to_image2: load!(
                V13,
                c"vkCmdCopyBufferToImage2",
                c"vkCmdCopyBufferToImage2KHR"
            ),
            copy_image2: load!(V13, c"vkCmdCopyImage2", c"vkCmdCopyImage2KHR"),
            copy_image_to_buffer2: load!(
                V13,
                c"vkCmdCopyImageToBuffer2",
                c"vkCmdCopyImageToBuffer2KHR"
            ),
            push_descriptor_set: load!(
                V14,
                c"vkCmdPushDescriptorSet",
                c"vkCmdPushDescriptorSetKHR"
            ),
            bind_descriptor_sets2: load!(
                V14,
                c"vkCmdBindDescriptorSets2",
                c"vkCmdBindDescriptorSets2KHR"
            ),
            set_descriptor_buffer_offsets: load!(0, c"vkCmdSetDescriptorBufferOffsetsEXT"),
            set_descriptor_buffer_offsets2: load!(0, c"vkCmdSetDescriptorBufferOffsets2EXT"),
            bind_embedded_samplers: load!(0, c"vkCmdBindDescriptorBufferEmbeddedSamplersEXT"),
            bind_embedded_samplers2: load!(0, c"vkCmdBindDescriptorBufferEmbeddedSamplers2EXT"),
            bind_descriptor_buffers: load!(0, c"vkCmdBindDescriptorBuffersEXT"),
            push_descriptor_set_with_template: load!(
                V14,
                c"vkCmdPushDescriptorSetWithTemplate",
                c"vkCmdPushDescriptorSetWithTemplateKHR"
            ),
            push_descriptor_set2: load!(
                V14,
                c"vkCmdPushDescriptorSet2",
                c"vkCmdPushDescriptorSet2KHR"
            ),
            push_descriptor_set_with_template2: load!(
                V14,
                c"vkCmdPushDescriptorSetWithTemplate2",
                c"vkCmdPushDescriptorSetWithTemplate2KHR"
            ),
            create_descriptor_update_template: load!(
                vk::API_VERSION_1_1,
                c"vkCreateDescriptorUpdateTemplate",
                c"vkCreateDescriptorUpdateTemplateKHR"
            ),
            destroy_descriptor_update_template: load!(
                vk::API_VERSION_1_1,
                c"vkDestroyDescriptorUpdateTemplate",
                c"vkDestroyDescriptorUpdateTemplateKHR"
            ),
            begin_conditional_rendering: load!(0, c"vkCmdBeginConditionalRenderingEXT"),
            end_conditional_rendering: load!(0, c"vkCmdEndConditionalRenderingEXT"),
            blit_image2: load!(V13, c"vkCmdBlitImage2", c"vkCmdBlitImage2KHR"),
            resolve_image2: load!(V13, c"vkCmdResolveImage2", c"vkCmdResolveImage2KHR"),
            set_depth_bias2: load!(0, c"vkCmdSetDepthBias2EXT"),
            update_descriptor_set_with_template: load!(
                vk::API_VERSION_1_1,
                c"vkUpdateDescriptorSetWithTemplate",
                c"vkUpdateDescriptorSetWithTemplateKHR"
            ),
            get_descriptor_ext: load!(0, c"vkGetDescriptorEXT"),
            pipeline_barrier2: load!(V13, c"vkCmdPipelineBarrier2", c"vkCmdPipelineBarrier2KHR"),
            wait_events2: load!(V13, c"vkCmdWaitEvents2", c"vkCmdWaitEvents2KHR"),
        }
    }
}

impl std::fmt::Debug for DeviceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceState")
            .field("handle", &self.handle)
            .field("settings", &self.settings)
            .field("policy", &self.policy)
            .finish_non_exhaustive()
    }
}

/// A map from dispatch key to shared state.
#[derive(Debug)]
pub struct Registry<T> {
    map: LazyLock<Mutex<HashMap<DispatchKey, Arc<T>>>>,
}

impl<T> Registry<T> {
    /// An empty registry, usable in a `static`.
    pub const fn new() -> Self {
        Registry {
            map: LazyLock::new(|| Mutex::new(HashMap::new())),
        }
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<DispatchKey, Arc<T>>> {
        // A panic while the lock was held (caught at the boundary) leaves a consistent map:
        // every operation on it is a single insert, remove or clone.
        self.map.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn insert(&self, key: DispatchKey, state: T) {
        self.lock().insert(key, Arc::new(state));
    }

    pub fn get(&self, key: DispatchKey) -> Option<Arc<T>> {
        self.lock().get(&key).cloned()
    }

    pub fn remove(&self, key: DispatchKey) -> Option<Arc<T>> {
        self.lock().remove(&key)
    }

    /// The only entry, if there is exactly one.
    pub fn sole(&self) -> Option<Arc<T>> {
        let map = self.lock();
        let mut values = map.values();
        match (values.next(), values.next()) {
            (Some(only), None) => Some(Arc::clone(only)),
            _ => None,
        }
    }
}

impl<T> Default for Registry<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Every live instance the layer has seen created.
pub static INSTANCES: Registry<InstanceState> = Registry::new();
/// Every live device the layer has seen created.
pub static DEVICES: Registry<DeviceState> = Registry::new();
