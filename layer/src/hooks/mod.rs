//! The Vulkan commands revz intercepts, and the tables that name them.
//!
//! `vkGetInstanceProcAddr` and `vkGetDeviceProcAddr` answer with a hook from these tables and
//! with the next layer's function for everything else, so a command revz does not intercept
//! costs nothing.

/// Erases a typed Vulkan function pointer to `PFN_vkVoidFunction`.
macro_rules! void_fn {
    ($pfn:ty, $f:expr) => {{
        let typed: $pfn = $f;
        // SAFETY: function pointers have one size and ABI; the loader casts it back to the
        // type the command name implies, which is `$pfn`.
        Some(unsafe { std::mem::transmute::<$pfn, unsafe extern "system" fn()>(typed) })
    }};
}

/// Defines a destruction hook: forget the object, then call down.
macro_rules! destroy_hook {
    ($name:ident, $entry:ident, $handle:ty, $($table:ident)|+, $next:ident) => {
        pub unsafe extern "system" fn $name(
            device: vk::Device,
            handle: $handle,
            p_allocator: *const vk::AllocationCallbacks<'_>,
        ) {
            // SAFETY: `device` is live.
            let Some(state) = (unsafe { $crate::hooks::device_state(device) }) else {
                return;
            };
            $crate::hooks::record(&$entry, || {
                $(state.objects.$table.remove(&handle);)+
            });
            // SAFETY: calling down with the application's arguments.
            unsafe { (state.next.fp_v1_0().$next)(device, handle, p_allocator) };
        }
    };
}

pub mod cameras;
pub mod command;
pub mod descriptors;
pub mod device;
pub mod extensions;
pub mod instance;
pub mod pipeline;
pub mod render_pass;
pub mod resources;
pub mod shader_object;

#[cfg(test)]
mod chain_tests;
#[cfg(test)]
mod extension_chain_tests;
#[cfg(test)]
mod fake_chain;
#[cfg(test)]
mod leak_tests;
#[cfg(test)]
mod lifetime_chain_tests;
#[cfg(test)]
mod pipeline_chain_tests;
#[cfg(test)]
mod promotion_chain_tests;
#[cfg(test)]
mod resolve_chain_tests;
#[cfg(test)]
mod secondary_chain_tests;
#[cfg(test)]
mod shader_object_chain_tests;

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;

use crate::boundary::{guarded, EntryPoint};
use crate::state::{DeviceState, DispatchKey, DEVICES};

/// Runs `record` (bookkeeping after a successful call down) so that a panic in it is logged
/// and swallowed: the object exists below either way, and the call must not be repeated.
pub(crate) fn record(entry: &'static EntryPoint, record: impl FnOnce()) {
    guarded(entry, record, || ());
}

/// The state of a device revz created (device-level object hooks; not per draw).
///
/// # Safety
/// `device` must be a live device handle.
pub(crate) unsafe fn device_state(device: vk::Device) -> Option<Arc<DeviceState>> {
    // SAFETY: the caller guarantees a live handle.
    DEVICES.get(unsafe { DispatchKey::of(device) })
}

/// The hook for an instance-level command, if revz intercepts it.
pub fn instance_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetInstanceProcAddr" => void_fn!(
            vk::PFN_vkGetInstanceProcAddr,
            instance::get_instance_proc_addr
        ),
        b"vkCreateInstance" => void_fn!(vk::PFN_vkCreateInstance, instance::create_instance),
        b"vkDestroyInstance" => void_fn!(vk::PFN_vkDestroyInstance, instance::destroy_instance),
        b"vkCreateDevice" => void_fn!(vk::PFN_vkCreateDevice, instance::create_device),
        _ => None,
    }
}

/// The hook for a device-level command that revz always intercepts.
pub fn device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetDeviceProcAddr" => {
            void_fn!(vk::PFN_vkGetDeviceProcAddr, device::get_device_proc_addr)
        }
        b"vkDestroyDevice" => void_fn!(vk::PFN_vkDestroyDevice, device::destroy_device),
        _ => None,
    }
}

/// The hook for a device-level command the depth profile needs (`crate::profile`) beyond the
/// depth path's: submissions (also in `flip` mode) and presents.
pub fn profile_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkQueueSubmit" => void_fn!(vk::PFN_vkQueueSubmit, cameras::queue_submit),
        b"vkQueueSubmit2" | b"vkQueueSubmit2KHR" => {
            void_fn!(vk::PFN_vkQueueSubmit2, cameras::queue_submit2)
        }
        b"vkQueuePresentKHR" => void_fn!(vk::PFN_vkQueuePresentKHR, cameras::queue_present),
        _ => None,
    }
}

/// The hook for a device-level command of the depth path (only for devices where the policy
/// is active: elsewhere these commands go straight to the next layer). Aliases (core, KHR,
/// EXT names) share one hook, which calls down through whichever name the device has.
pub fn depth_path_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    use command as c;
    use render_pass as rp;
    use resources as r;
    match name.to_bytes() {
        b"vkCreateImage" => void_fn!(vk::PFN_vkCreateImage, r::create_image),
        b"vkDestroyImage" => void_fn!(vk::PFN_vkDestroyImage, r::destroy_image),
        b"vkCreateImageView" => void_fn!(vk::PFN_vkCreateImageView, r::create_image_view),
        b"vkGetDeviceImageMemoryRequirements" | b"vkGetDeviceImageMemoryRequirementsKHR" => {
            void_fn!(
                vk::PFN_vkGetDeviceImageMemoryRequirements,
                r::get_device_image_memory_requirements
            )
        }
        b"vkDestroyImageView" => void_fn!(vk::PFN_vkDestroyImageView, r::destroy_image_view),
        b"vkCreateRenderPass" => void_fn!(vk::PFN_vkCreateRenderPass, rp::create_render_pass),
        b"vkCreateRenderPass2" | b"vkCreateRenderPass2KHR" => {
            void_fn!(vk::PFN_vkCreateRenderPass2, rp::create_render_pass2)
        }
        b"vkDestroyRenderPass" => void_fn!(vk::PFN_vkDestroyRenderPass, rp::destroy_render_pass),
        b"vkCreateFramebuffer" => void_fn!(vk::PFN_vkCreateFramebuffer, rp::create_framebuffer),
        b"vkDestroyFramebuffer" => {
            void_fn!(vk::PFN_vkDestroyFramebuffer, rp::destroy_framebuffer)
        }
        b"vkAllocateCommandBuffers" => {
            void_fn!(
                vk::PFN_vkAllocateCommandBuffers,
                r::allocate_command_buffers
            )
        }
        b"vkFreeCommandBuffers" => {
            void_fn!(vk::PFN_vkFreeCommandBuffers, r::free_command_buffers)
        }
        b"vkDestroyCommandPool" => {
            void_fn!(vk::PFN_vkDestroyCommandPool, r::destroy_command_pool)
        }
        b"vkCreateGraphicsPipelines" => void_fn!(
            vk::PFN_vkCreateGraphicsPipelines,
            pipeline::create_graphics_pipelines
        ),
        b"vkDestroyPipeline" => void_fn!(vk::PFN_vkDestroyPipeline, pipeline::destroy_pipeline),
        b"vkCreateShaderModule" => {
            void_fn!(vk::PFN_vkCreateShaderModule, pipeline::create_shader_module)
        }
        b"vkDestroyShaderModule" => {
            void_fn!(
                vk::PFN_vkDestroyShaderModule,
                pipeline::destroy_shader_module
            )
        }
        b"vkCreateShadersEXT" => {
            void_fn!(
                vk::PFN_vkCreateShadersEXT,
                shader_object::create_shaders_ext
            )
        }
        b"vkDestroyShaderEXT" => {
            void_fn!(
                vk::PFN_vkDestroyShaderEXT,
                shader_object::destroy_shader_ext
            )
        }
        b"vkBeginCommandBuffer" => {
            void_fn!(vk::PFN_vkBeginCommandBuffer, c::begin_command_buffer)
        }
        b"vkCmdBeginRenderPass" => {
            void_fn!(vk::PFN_vkCmdBeginRenderPass, c::cmd_begin_render_pass)
        }
        b"vkCmdBeginRenderPass2" | b"vkCmdBeginRenderPass2KHR" => {
            void_fn!(vk::PFN_vkCmdBeginRenderPass2, c::cmd_begin_render_pass2)
        }
        b"vkCmdNextSubpass" => void_fn!(vk::PFN_vkCmdNextSubpass, c::cmd_next_subpass),
        b"vkCmdNextSubpass2" | b"vkCmdNextSubpass2KHR" => {
            void_fn!(vk::PFN_vkCmdNextSubpass2, c::cmd_next_subpass2)
        }
        b"vkCmdEndRenderPass" => void_fn!(vk::PFN_vkCmdEndRenderPass, c::cmd_end_render_pass),
        b"vkCmdEndRenderPass2" | b"vkCmdEndRenderPass2KHR" => {
            void_fn!(vk::PFN_vkCmdEndRenderPass2, c::cmd_end_render_pass2)
        }
        b"vkCmdBeginRendering" | b"vkCmdBeginRenderingKHR" => {
            void_fn!(vk::PFN_vkCmdBeginRendering, c::cmd_begin_rendering)
        }
        b"vkCmdEndRendering" | b"vkCmdEndRenderingKHR" => {
            void_fn!(vk::PFN_vkCmdEndRendering, c::cmd_end_rendering)
        }
        b"vkCmdEndRendering2KHR" => {
            void_fn!(crate::state::PfnCmdEndRendering2, c::cmd_end_rendering2_khr)
        }
        b"vkCmdEndRendering2EXT" => {
            void_fn!(crate::state::PfnCmdEndRendering2, c::cmd_end_rendering2_ext)
        }
        b"vkCmdBindPipeline" => void_fn!(vk::PFN_vkCmdBindPipeline, c::cmd_bind_pipeline),
        b"vkCmdSetViewport" => void_fn!(vk::PFN_vkCmdSetViewport, c::cmd_set_viewport),
        b"vkCmdSetViewportWithCount" | b"vkCmdSetViewportWithCountEXT" => {
            void_fn!(
                vk::PFN_vkCmdSetViewportWithCount,
                c::cmd_set_viewport_with_count
            )
        }
        b"vkCmdSetDepthCompareOp" | b"vkCmdSetDepthCompareOpEXT" => {
            void_fn!(vk::PFN_vkCmdSetDepthCompareOp, c::cmd_set_depth_compare_op)
        }
        b"vkCmdSetDepthBias" => void_fn!(vk::PFN_vkCmdSetDepthBias, c::cmd_set_depth_bias),
        b"vkCmdSetDepthClipNegativeOneToOneEXT" => void_fn!(
            vk::PFN_vkCmdSetDepthClipNegativeOneToOneEXT,
            c::cmd_set_depth_clip_negative_one_to_one
        ),
        b"vkCmdSetDepthBounds" => void_fn!(vk::PFN_vkCmdSetDepthBounds, c::cmd_set_depth_bounds),
        b"vkCmdSetDepthClampRangeEXT" => void_fn!(
            crate::vk_ext::PfnCmdSetDepthClampRange,
            c::cmd_set_depth_clamp_range
        ),
        b"vkCmdClearAttachments" => {
            void_fn!(vk::PFN_vkCmdClearAttachments, c::cmd_clear_attachments)
        }
        b"vkCmdClearDepthStencilImage" => void_fn!(
            vk::PFN_vkCmdClearDepthStencilImage,
            c::cmd_clear_depth_stencil_image
        ),
        b"vkCmdCopyBufferToImage" => {
            void_fn!(vk::PFN_vkCmdCopyBufferToImage, c::cmd_copy_buffer_to_image)
        }
        b"vkCmdCopyImage" => void_fn!(vk::PFN_vkCmdCopyImage, c::cmd_copy_image),
        b"vkCmdBlitImage" => void_fn!(vk::PFN_vkCmdBlitImage, c::cmd_blit_image),
        b"vkCmdCopyBufferToImage2" | b"vkCmdCopyBufferToImage2KHR" => void_fn!(
            vk::PFN_vkCmdCopyBufferToImage2,
            c::cmd_copy_buffer_to_image2
        ),
        b"vkCmdCopyImage2" | b"vkCmdCopyImage2KHR" => {
            void_fn!(vk::PFN_vkCmdCopyImage2, c::cmd_copy_image2)
        }
        b"vkCmdBlitImage2" | b"vkCmdBlitImage2KHR" => {
            void_fn!(vk::PFN_vkCmdBlitImage2, c::cmd_blit_image2)
        }
        // Resolves go down as they are; a depth resolve (`VK_KHR_maintenance10`) writes its
        // destination, which a read twin refresh must cover again.
        b"vkCmdResolveImage" => void_fn!(vk::PFN_vkCmdResolveImage, c::cmd_resolve_image),
        b"vkCmdResolveImage2" | b"vkCmdResolveImage2KHR" => {
            void_fn!(vk::PFN_vkCmdResolveImage2, c::cmd_resolve_image2)
        }
        b"vkCmdCopyImageToBuffer" => {
            void_fn!(vk::PFN_vkCmdCopyImageToBuffer, c::cmd_copy_image_to_buffer)
        }
        b"vkCmdCopyImageToBuffer2" | b"vkCmdCopyImageToBuffer2KHR" => void_fn!(
            vk::PFN_vkCmdCopyImageToBuffer2,
            c::cmd_copy_image_to_buffer2
        ),
        // The compute state a converted copy's dispatch disturbs, bound again after it.
        b"vkCmdBindDescriptorSets" => {
            void_fn!(vk::PFN_vkCmdBindDescriptorSets, c::cmd_bind_descriptor_sets)
        }
        b"vkCmdPushDescriptorSet" | b"vkCmdPushDescriptorSetKHR" => void_fn!(
            vk::PFN_vkCmdPushDescriptorSetKHR,
            c::cmd_push_descriptor_set_khr
        ),
        b"vkCmdPushDescriptorSet2" | b"vkCmdPushDescriptorSet2KHR" => void_fn!(
            vk::PFN_vkCmdPushDescriptorSet2KHR,
            c::cmd_push_descriptor_set2
        ),
        b"vkCmdPushDescriptorSetWithTemplate2" | b"vkCmdPushDescriptorSetWithTemplate2KHR" => {
            void_fn!(
                vk::PFN_vkCmdPushDescriptorSetWithTemplate2KHR,
                c::cmd_push_descriptor_set_with_template2
            )
        }
        b"vkCmdBindDescriptorSets2" | b"vkCmdBindDescriptorSets2KHR" => void_fn!(
            vk::PFN_vkCmdBindDescriptorSets2KHR,
            c::cmd_bind_descriptor_sets2
        ),
        b"vkCmdSetDescriptorBufferOffsetsEXT" => void_fn!(
            vk::PFN_vkCmdSetDescriptorBufferOffsetsEXT,
            c::cmd_set_descriptor_buffer_offsets_ext
        ),
        b"vkCmdSetDescriptorBufferOffsets2EXT" => void_fn!(
            vk::PFN_vkCmdSetDescriptorBufferOffsets2EXT,
            c::cmd_set_descriptor_buffer_offsets2_ext
        ),
        b"vkCmdBindDescriptorBufferEmbeddedSamplersEXT" => void_fn!(
            vk::PFN_vkCmdBindDescriptorBufferEmbeddedSamplersEXT,
            c::cmd_bind_descriptor_buffer_embedded_samplers_ext
        ),
        b"vkCmdBindDescriptorBufferEmbeddedSamplers2EXT" => void_fn!(
            vk::PFN_vkCmdBindDescriptorBufferEmbeddedSamplers2EXT,
            c::cmd_bind_descriptor_buffer_embedded_samplers2_ext
        ),
        b"vkCmdBindDescriptorBuffersEXT" => void_fn!(
            vk::PFN_vkCmdBindDescriptorBuffersEXT,
            c::cmd_bind_descriptor_buffers_ext
        ),
        b"vkCmdPushDescriptorSetWithTemplate" | b"vkCmdPushDescriptorSetWithTemplateKHR" => {
            void_fn!(
                vk::PFN_vkCmdPushDescriptorSetWithTemplateKHR,
                c::cmd_push_descriptor_set_with_template
            )
        }
        b"vkCmdBeginConditionalRenderingEXT" => void_fn!(
            vk::PFN_vkCmdBeginConditionalRenderingEXT,
            c::cmd_begin_conditional_rendering
        ),
        b"vkCmdEndConditionalRenderingEXT" => void_fn!(
            vk::PFN_vkCmdEndConditionalRenderingEXT,
            c::cmd_end_conditional_rendering
        ),
        b"vkCreateDescriptorUpdateTemplate" | b"vkCreateDescriptorUpdateTemplateKHR" => void_fn!(
            vk::PFN_vkCreateDescriptorUpdateTemplate,
            r::create_descriptor_update_template
        ),
        b"vkDestroyDescriptorUpdateTemplate" | b"vkDestroyDescriptorUpdateTemplateKHR" => {
            void_fn!(
                vk::PFN_vkDestroyDescriptorUpdateTemplate,
                r::destroy_descriptor_update_template
            )
        }
        b"vkCreateCommandPool" => {
            void_fn!(vk::PFN_vkCreateCommandPool, r::create_command_pool)
        }
        b"vkCmdSetDepthBias2EXT" => void_fn!(vk::PFN_vkCmdSetDepthBias2EXT, c::cmd_set_depth_bias2),
        // Read twins (issue #39): descriptors name the twins' views, and barriers that make a
        // reversed image readable refresh its twin.
        b"vkUpdateDescriptorSets" => void_fn!(
            vk::PFN_vkUpdateDescriptorSets,
            descriptors::update_descriptor_sets
        ),
        b"vkUpdateDescriptorSetWithTemplate" | b"vkUpdateDescriptorSetWithTemplateKHR" => {
            void_fn!(
                vk::PFN_vkUpdateDescriptorSetWithTemplate,
                descriptors::update_descriptor_set_with_template
            )
        }
        b"vkGetDescriptorEXT" => {
            void_fn!(vk::PFN_vkGetDescriptorEXT, descriptors::get_descriptor_ext)
        }
        b"vkCmdPipelineBarrier" => void_fn!(vk::PFN_vkCmdPipelineBarrier, c::cmd_pipeline_barrier),
        b"vkCmdPipelineBarrier2" | b"vkCmdPipelineBarrier2KHR" => {
            void_fn!(vk::PFN_vkCmdPipelineBarrier2, c::cmd_pipeline_barrier2)
        }
        b"vkCmdWaitEvents" => void_fn!(vk::PFN_vkCmdWaitEvents, c::cmd_wait_events),
        b"vkCmdWaitEvents2" | b"vkCmdWaitEvents2KHR" => {
            void_fn!(vk::PFN_vkCmdWaitEvents2, c::cmd_wait_events2)
        }
        b"vkCmdExecuteCommands" => {
            void_fn!(vk::PFN_vkCmdExecuteCommands, c::cmd_execute_commands)
        }
        b"vkCmdBindShadersEXT" => void_fn!(vk::PFN_vkCmdBindShadersEXT, c::cmd_bind_shaders_ext),
        _ => None,
    }
}

/// The hook for a draw command: handed out only where the depth profile counts draws
/// (`crate::profile`). Everywhere else draws go straight to the next layer: every hook that
/// changes what a draw needs sends it down as it goes
/// ([`crate::command_state::CommandState::settle`]).
pub fn draw_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    use command as c;
    match name.to_bytes() {
        b"vkCmdDraw" => void_fn!(vk::PFN_vkCmdDraw, c::cmd_draw),
        b"vkCmdDrawIndexed" => void_fn!(vk::PFN_vkCmdDrawIndexed, c::cmd_draw_indexed),
        b"vkCmdDrawIndirect" => void_fn!(vk::PFN_vkCmdDrawIndirect, c::cmd_draw_indirect),
        b"vkCmdDrawIndexedIndirect" => {
            void_fn!(
                vk::PFN_vkCmdDrawIndexedIndirect,
                c::cmd_draw_indexed_indirect
            )
        }
        b"vkCmdDrawIndirectCount" | b"vkCmdDrawIndirectCountKHR" | b"vkCmdDrawIndirectCountAMD" => {
            void_fn!(vk::PFN_vkCmdDrawIndirectCount, c::cmd_draw_indirect_count)
        }
        b"vkCmdDrawIndexedIndirectCount"
        | b"vkCmdDrawIndexedIndirectCountKHR"
        | b"vkCmdDrawIndexedIndirectCountAMD" => void_fn!(
            vk::PFN_vkCmdDrawIndexedIndirectCount,
            c::cmd_draw_indexed_indirect_count
        ),
        b"vkCmdDrawMeshTasksEXT" => {
            void_fn!(vk::PFN_vkCmdDrawMeshTasksEXT, c::cmd_draw_mesh_tasks_ext)
        }
        b"vkCmdDrawMeshTasksIndirectEXT" => void_fn!(
            vk::PFN_vkCmdDrawMeshTasksIndirectEXT,
            c::cmd_draw_mesh_tasks_indirect_ext
        ),
        b"vkCmdDrawMeshTasksIndirectCountEXT" => void_fn!(
            vk::PFN_vkCmdDrawMeshTasksIndirectCountEXT,
            c::cmd_draw_mesh_tasks_indirect_count_ext
        ),
        b"vkCmdDrawMeshTasksNV" => {
            void_fn!(vk::PFN_vkCmdDrawMeshTasksNV, c::cmd_draw_mesh_tasks_nv)
        }
        b"vkCmdDrawMeshTasksIndirectNV" => void_fn!(
            vk::PFN_vkCmdDrawMeshTasksIndirectNV,
            c::cmd_draw_mesh_tasks_indirect_nv
        ),
        b"vkCmdDrawMultiEXT" => void_fn!(vk::PFN_vkCmdDrawMultiEXT, c::cmd_draw_multi_ext),
        b"vkCmdDrawMultiIndexedEXT" => {
            void_fn!(
                vk::PFN_vkCmdDrawMultiIndexedEXT,
                c::cmd_draw_multi_indexed_ext
            )
        }
        b"vkCmdDrawMeshTasksIndirectCountNV" => void_fn!(
            vk::PFN_vkCmdDrawMeshTasksIndirectCountNV,
            c::cmd_draw_mesh_tasks_indirect_count_nv
        ),
        b"vkCmdDrawClusterHUAWEI" => {
            void_fn!(vk::PFN_vkCmdDrawClusterHUAWEI, c::cmd_draw_cluster_huawei)
        }
        b"vkCmdDrawClusterIndirectHUAWEI" => void_fn!(
            vk::PFN_vkCmdDrawClusterIndirectHUAWEI,
            c::cmd_draw_cluster_indirect_huawei
        ),
        b"vkCmdExecuteGeneratedCommandsNV" => void_fn!(
            vk::PFN_vkCmdExecuteGeneratedCommandsNV,
            c::cmd_execute_generated_commands_nv
        ),
        b"vkCmdExecuteGeneratedCommandsEXT" => void_fn!(
            crate::ffi::PfnCmdExecuteGeneratedCommandsExt,
            c::cmd_execute_generated_commands_ext
        ),
        b"vkCmdDrawIndirectByteCountEXT" => void_fn!(
            vk::PFN_vkCmdDrawIndirectByteCountEXT,
            c::cmd_draw_indirect_byte_count_ext
        ),
        _ => None,
    }
}

/// The hook for a command only the precise path needs (complementary and infinite modes):
/// push constants, and the pipeline layouts that say how to push them.
pub fn precise_path_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkCmdPushConstants" => void_fn!(vk::PFN_vkCmdPushConstants, command::cmd_push_constants),
        // Only infinite mode's path depends on it (`CommandState::clamps_at_far`).
        b"vkCmdSetDepthClampEnableEXT" => void_fn!(
            vk::PFN_vkCmdSetDepthClampEnableEXT,
            command::cmd_set_depth_clamp_enable
        ),
        b"vkCmdSetDepthClipEnableEXT" => void_fn!(
            vk::PFN_vkCmdSetDepthClipEnableEXT,
            command::cmd_set_depth_clip_enable
        ),
        // Vulkan 1.4 core, and VK_KHR_maintenance6 before it.
        b"vkCmdPushConstants2" | b"vkCmdPushConstants2KHR" => {
            void_fn!(vk::PFN_vkCmdPushConstants2KHR, command::cmd_push_constants2)
        }
        b"vkCreatePipelineLayout" => void_fn!(
            vk::PFN_vkCreatePipelineLayout,
            pipeline::create_pipeline_layout
        ),
        b"vkDestroyPipelineLayout" => void_fn!(
            vk::PFN_vkDestroyPipelineLayout,
            pipeline::destroy_pipeline_layout
        ),
        b"vkEndCommandBuffer" => {
            void_fn!(vk::PFN_vkEndCommandBuffer, cameras::end_command_buffer)
        }
        b"vkQueueSubmit" => void_fn!(vk::PFN_vkQueueSubmit, cameras::queue_submit),
        b"vkQueueSubmit2" | b"vkQueueSubmit2KHR" => {
            void_fn!(vk::PFN_vkQueueSubmit2, cameras::queue_submit2)
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_name_exactly_the_hooks() {
        for name in [
            c"vkGetInstanceProcAddr",
            c"vkCreateInstance",
            c"vkDestroyInstance",
            c"vkCreateDevice",
        ] {
            assert!(instance_command(name).is_some(), "{name:?}");
            assert!(device_command(name).is_none(), "{name:?}");
        }
        for name in [c"vkGetDeviceProcAddr", c"vkDestroyDevice"] {
            assert!(device_command(name).is_some(), "{name:?}");
        }
        assert!(precise_path_command(c"vkCmdPushConstants").is_some());
        // Every name of a command revz must see, core or extension.
        for name in [c"vkCmdPushConstants2", c"vkCmdPushConstants2KHR"] {
            assert!(precise_path_command(name).is_some(), "{name:?}");
        }
        for name in [
            c"vkCmdDraw",
            c"vkCmdDrawIndexedIndirectCountKHR",
            c"vkCmdDrawMultiEXT",
            c"vkCmdExecuteGeneratedCommandsNV",
            c"vkCmdExecuteGeneratedCommandsEXT",
            c"vkCmdDrawIndirectByteCountEXT",
        ] {
            assert!(draw_command(name).is_some(), "{name:?}");
            assert!(depth_path_command(name).is_none(), "{name:?}");
        }
        for name in [
            c"vkCmdExecuteCommands",
            c"vkCreateShadersEXT",
            c"vkDestroyShaderEXT",
            c"vkCmdBindShadersEXT",
        ] {
            assert!(depth_path_command(name).is_some(), "{name:?}");
        }
        assert!(depth_path_command(c"vkCmdPushConstants").is_none());
        assert!(instance_command(c"vkCmdDraw").is_none());
        assert!(device_command(c"vkCmdDraw").is_none());
    }
}
