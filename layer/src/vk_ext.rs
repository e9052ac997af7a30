//! Vulkan definitions newer than the `ash` revz builds on (0.38, Vulkan 1.3.281), written from
//! the registry: `VK_EXT_depth_clamp_control` (extension 583), whose clamp ranges are depth
//! values revz maps like depth bounds.

use std::ffi::c_void;

use ash::vk;

/// `VK_DYNAMIC_STATE_DEPTH_CLAMP_RANGE_EXT`.
pub const DYNAMIC_STATE_DEPTH_CLAMP_RANGE: vk::DynamicState =
    vk::DynamicState::from_raw(1_000_582_000);

/// `VkDepthClampModeEXT`: `VK_DEPTH_CLAMP_MODE_VIEWPORT_RANGE_EXT` (clamp to the viewport's
/// depth range, the default) and `VK_DEPTH_CLAMP_MODE_USER_DEFINED_RANGE_EXT`.
pub const DEPTH_CLAMP_MODE_VIEWPORT_RANGE: i32 = 0;
pub const DEPTH_CLAMP_MODE_USER_DEFINED_RANGE: i32 = 1;

/// `VkDepthClampRangeEXT`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DepthClampRange {
    pub min_depth_clamp: f32,
    pub max_depth_clamp: f32,
}

/// `VkPipelineViewportDepthClampControlCreateInfoEXT` (extends
/// `VkPipelineViewportStateCreateInfo`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PipelineViewportDepthClampControlCreateInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub depth_clamp_mode: i32,
    pub p_depth_clamp_range: *const DepthClampRange,
}

// SAFETY: the structure's layout begins with its sType and pNext, and this is its sType.
unsafe impl vk::TaggedStructure for PipelineViewportDepthClampControlCreateInfo {
    const STRUCTURE_TYPE: vk::StructureType = vk::StructureType::from_raw(1_000_582_001);
}

/// `vkCmdSetDepthClampRangeEXT`.
pub type PfnCmdSetDepthClampRange = unsafe extern "system" fn(
    command_buffer: vk::CommandBuffer,
    depth_clamp_mode: i32,
    p_depth_clamp_range: *const DepthClampRange,
);
