//! The loader-layer interface structures that `ash` does not declare.
//!
//! Mirrors `vk_layer.h` from Vulkan-Loader (interface version 2, see its
//! `LoaderLayerInterface.md`). Only what revz uses is declared; the layouts must match the C
//! header exactly because the loader hands us pointers to them.

use std::ffi::{c_char, c_void, CStr};

use ash::vk;

/// `VK_CURRENT_LOADER_LAYER_INTERFACE_VERSION` as revz implements it.
pub const LAYER_INTERFACE_VERSION: u32 = 2;

/// `VkNegotiateLayerStructType::LAYER_NEGOTIATE_INTERFACE_STRUCT`.
pub const LAYER_NEGOTIATE_INTERFACE_STRUCT: u32 = 1;

/// `VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO`.
pub const STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO: vk::StructureType =
    vk::StructureType::from_raw(47);
/// `VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO`.
pub const STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO: vk::StructureType =
    vk::StructureType::from_raw(48);

/// `VkLayerFunction::VK_LAYER_LINK_INFO`: the create info carries the next layer's link.
pub const LAYER_LINK_INFO: u32 = 0;

/// `PFN_GetPhysicalDeviceProcAddr`.
pub type PfnGetPhysicalDeviceProcAddr =
    Option<unsafe extern "system" fn(vk::Instance, *const c_char) -> vk::PFN_vkVoidFunction>;

/// `VkNegotiateLayerInterface`.
#[repr(C)]
#[derive(Debug)]
pub struct NegotiateLayerInterface {
    pub s_type: u32,
    pub p_next: *mut c_void,
    pub loader_layer_interface_version: u32,
    pub pfn_get_instance_proc_addr: Option<vk::PFN_vkGetInstanceProcAddr>,
    pub pfn_get_device_proc_addr: Option<vk::PFN_vkGetDeviceProcAddr>,
    pub pfn_get_physical_device_proc_addr: PfnGetPhysicalDeviceProcAddr,
}

/// `VkLayerInstanceLink`: one element of the loader's list of the layers below us.
#[repr(C)]
#[derive(Debug)]
pub struct LayerInstanceLink {
    pub p_next: *mut LayerInstanceLink,
    pub pfn_next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    pub pfn_next_get_physical_device_proc_addr: PfnGetPhysicalDeviceProcAddr,
}

/// `VkLayerDeviceLink`.
#[repr(C)]
#[derive(Debug)]
pub struct LayerDeviceLink {
    pub p_next: *mut LayerDeviceLink,
    pub pfn_next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    pub pfn_next_get_device_proc_addr: vk::PFN_vkGetDeviceProcAddr,
}

/// `VkLayerInstanceCreateInfo`. The C type has a union after `function`; revz reads only the
/// `pLayerInfo` member, and only when `function == VK_LAYER_LINK_INFO`. Every member of the
/// union is pointer-sized, so declaring the one we read keeps the layout.
#[repr(C)]
#[derive(Debug)]
pub struct LayerInstanceCreateInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub function: u32,
    pub p_layer_info: *mut LayerInstanceLink,
}

/// `VkLayerDeviceCreateInfo`; same union convention as [`LayerInstanceCreateInfo`].
#[repr(C)]
#[derive(Debug)]
pub struct LayerDeviceCreateInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const c_void,
    pub function: u32,
    pub p_layer_info: *mut LayerDeviceLink,
}

/// Reads a C string the application passed; `None` for a null pointer.
///
/// # Safety
/// `ptr` must be null or a NUL-terminated string that outlives `'a`.
pub unsafe fn c_str<'a>(ptr: *const c_char) -> Option<&'a CStr> {
    // SAFETY: the caller guarantees a NUL-terminated string when non-null.
    (!ptr.is_null()).then(|| unsafe { CStr::from_ptr(ptr) })
}

/// `VK_STRUCTURE_TYPE_PIPELINE_BINARY_INFO_KHR` (`VK_KHR_pipeline_binary`, newer than ash
/// 0.38's headers).
pub const STRUCTURE_TYPE_PIPELINE_BINARY_INFO_KHR: vk::StructureType =
    vk::StructureType::from_raw(1_000_483_002);

/// `VkPipelineBinaryInfoKHR`: the pipeline binaries a pipeline is created from.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PipelineBinaryInfo {
    pub s_type: vk::StructureType,
    pub p_next: *const std::ffi::c_void,
    pub binary_count: u32,
    /// `VkPipelineBinaryKHR` handles (non-dispatchable: 64-bit).
    pub p_pipeline_binaries: *const u64,
}

/// `vkCmdExecuteGeneratedCommandsEXT` (`VK_EXT_device_generated_commands`, newer than ash
/// 0.38's headers): the command buffer, `isPreprocessed`, and a `VkGeneratedCommandsInfoEXT`
/// that revz passes through unread.
pub type PfnCmdExecuteGeneratedCommandsExt = unsafe extern "system" fn(
    command_buffer: vk::CommandBuffer,
    is_preprocessed: vk::Bool32,
    p_generated_commands_info: *const std::ffi::c_void,
);

/// Walks a `pNext` chain and returns the first loader link info of type `s_type`.
///
/// # Safety
/// `p_next` must be null or the head of a valid Vulkan structure chain, and any structure of
/// type `s_type` in it must have the layout of `T` (a `#[repr(C)]` struct starting with
/// `sType`, `pNext`, `function`).
unsafe fn find_link_info<T>(p_next: *const c_void, s_type: vk::StructureType) -> *mut T {
    // SAFETY: the caller's contract.
    let link = unsafe { crate::chain::structures(p_next) }
        .map(|base| (base as *const vk::BaseInStructure<'_>).cast::<u8>())
        .find(|&structure| {
            // SAFETY: the sType is checked first; the loader's create infos start with sType,
            // pNext, function (u32).
            let s_type_found = unsafe { *structure.cast::<vk::StructureType>() };
            // SAFETY: as above.
            s_type_found == s_type
                && unsafe { *structure.add(function_offset()).cast::<u32>() } == LAYER_LINK_INFO
        });
    link.map_or(std::ptr::null_mut(), |structure| {
        structure.cast_mut().cast()
    })
}

const fn function_offset() -> usize {
    std::mem::offset_of!(LayerInstanceCreateInfo, function)
}

/// The next layer's entry points for an instance being created.
#[derive(Clone, Copy, Debug)]
pub struct NextInstanceLink {
    pub get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
}

/// The next layer's entry points for a device being created.
#[derive(Clone, Copy, Debug)]
pub struct NextDeviceLink {
    pub get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    pub get_device_proc_addr: vk::PFN_vkGetDeviceProcAddr,
}

/// Takes this layer's link out of the loader's instance chain: returns the next layer's entry
/// points and advances the chain so the next layer finds its own link.
///
/// # Safety
/// `create_info` must be a valid `VkInstanceCreateInfo` as the loader passes it to a layer.
pub unsafe fn take_instance_link(create_info: &vk::InstanceCreateInfo) -> Option<NextInstanceLink> {
    // SAFETY: the caller guarantees a valid chain; loader structures have the declared layout.
    let info: *mut LayerInstanceCreateInfo = unsafe {
        find_link_info(
            create_info.p_next,
            STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO,
        )
    };
    // SAFETY: non-null pointers from `find_link_info` point at a live loader structure, which
    // the loader gives us to modify (advancing it is the documented protocol).
    let info = unsafe { info.as_mut()? };
    // SAFETY: as above, `p_layer_info` is the loader's live list.
    let link = unsafe { info.p_layer_info.as_ref()? };
    info.p_layer_info = link.p_next;
    Some(NextInstanceLink {
        get_instance_proc_addr: link.pfn_next_get_instance_proc_addr,
    })
}

/// Device counterpart of [`take_instance_link`].
///
/// # Safety
/// `create_info` must be a valid `VkDeviceCreateInfo` as the loader passes it to a layer.
pub unsafe fn take_device_link(create_info: &vk::DeviceCreateInfo) -> Option<NextDeviceLink> {
    // SAFETY: see `take_instance_link`.
    let info: *mut LayerDeviceCreateInfo =
        unsafe { find_link_info(create_info.p_next, STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO) };
    // SAFETY: see `take_instance_link`.
    let info = unsafe { info.as_mut()? };
    // SAFETY: see `take_instance_link`.
    let link = unsafe { info.p_layer_info.as_ref()? };
    info.p_layer_info = link.p_next;
    Some(NextDeviceLink {
        get_instance_proc_addr: link.pfn_next_get_instance_proc_addr,
        get_device_proc_addr: link.pfn_next_get_device_proc_addr,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn create_info_layouts_match_the_c_header() {
        // sType (4) + padding (4) + pNext (8) + function (4) + padding (4) + union (8);
        // the negotiate struct is sType, pNext, version (+ padding) and three pointers.
        assert_eq!(std::mem::offset_of!(LayerInstanceCreateInfo, function), 16);
        assert_eq!(
            std::mem::offset_of!(LayerInstanceCreateInfo, p_layer_info),
            24
        );
        assert_eq!(std::mem::offset_of!(LayerDeviceCreateInfo, function), 16);
        assert_eq!(
            std::mem::offset_of!(LayerDeviceCreateInfo, p_layer_info),
            24
        );
        assert_eq!(std::mem::size_of::<NegotiateLayerInterface>(), 48);
    }

    #[test]
    fn a_chain_without_link_info_yields_none() {
        let debug = vk::DebugUtilsMessengerCreateInfoEXT::default();
        let info = vk::InstanceCreateInfo {
            p_next: (&debug as *const vk::DebugUtilsMessengerCreateInfoEXT).cast(),
            ..Default::default()
        };
        // SAFETY: a valid (if loader-less) chain.
        assert!(unsafe { take_instance_link(&info) }.is_none());
    }
}
