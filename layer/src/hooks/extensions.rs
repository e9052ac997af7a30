//! The extensions revz enables beyond what the application asked for, with what they require,
//! and the commands it then hides from the application.
//!
//! revz needs a dynamic depth compare op. Below Vulkan 1.3 it enables
//! `VK_EXT_extended_dynamic_state` at device creation, which requires
//! `VK_KHR_get_physical_device_properties2` (or Vulkan 1.1) at instance creation: an application
//! that asks for Vulkan 1.0 gets that instance extension added too
//! (VUID-vkCreateDevice-ppEnabledExtensionNames-01387); whether each is added is the policy's
//! (`crate::policy::instance_needs_properties2`, `crate::policy::extended_dynamic_state_allowed`).
//! What revz adds is revz's, not the application's: the commands of an added extension are not
//! handed to the application through `vkGetInstanceProcAddr` or `vkGetDeviceProcAddr` (it did
//! not enable them, and would get null without revz; `crate::policy::hides_instance_command`,
//! `crate::policy::hides_device_command`). Enumeration
//! (`vkEnumerate*ExtensionProperties`) reports what the implementation offers, which enabling
//! does not change, so it passes through untouched.

use std::ffi::{c_char, CStr};

use crate::ffi;

/// The instance extension `VK_EXT_extended_dynamic_state` requires below Vulkan 1.1.
pub const GET_PHYSICAL_DEVICE_PROPERTIES2: &CStr = c"VK_KHR_get_physical_device_properties2";
/// The device extension that makes the depth compare op dynamic below Vulkan 1.3.
pub const EXTENDED_DYNAMIC_STATE: &CStr = c"VK_EXT_extended_dynamic_state";
/// Depth outside [0, 1] in viewports, clears and float depth images
/// (`crate::policy::DevicePolicy::depth_range_unrestricted`).
pub const DEPTH_RANGE_UNRESTRICTED: &CStr = c"VK_EXT_depth_range_unrestricted";
/// `VK_EXT_descriptor_heap`: descriptors revz does not follow (`DevicePolicy::descriptor_heap`).
pub const DESCRIPTOR_HEAP: &CStr = c"VK_EXT_descriptor_heap";

/// The extension names of a create info.
///
/// # Safety
/// `names` must point at `count` NUL-terminated strings (or be null with `count` 0).
pub unsafe fn names<'a>(names: *const *const c_char, count: u32) -> Vec<&'a CStr> {
    // SAFETY: the caller's contract.
    let pointers = unsafe { super::resources::slice(names, count) };
    pointers
        .iter()
        // SAFETY: each pointer is a NUL-terminated string (the caller's contract).
        .filter_map(|&name| unsafe { ffi::c_str(name) })
        .collect()
}

/// The application's extension list with `added` appended, for the create info passed down.
///
/// # Safety
/// As [`names`].
pub unsafe fn with_added(
    names: *const *const c_char,
    count: u32,
    added: &'static CStr,
) -> Vec<*const c_char> {
    // SAFETY: the caller's contract.
    let mut list = unsafe { super::resources::slice(names, count) }.to_vec();
    list.push(added.as_ptr());
    list
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_added_name_follows_the_application_names() {
        let app = [c"VK_EXT_debug_utils".as_ptr()];
        // SAFETY: one valid name.
        let list = unsafe { with_added(app.as_ptr(), 1, EXTENDED_DYNAMIC_STATE) };
        // SAFETY: the list holds valid names.
        let seen = unsafe { names(list.as_ptr(), list.len() as u32) };
        assert_eq!(seen, [c"VK_EXT_debug_utils", EXTENDED_DYNAMIC_STATE]);
        // SAFETY: null with count 0.
        let only = unsafe { with_added(std::ptr::null(), 0, EXTENDED_DYNAMIC_STATE) };
        assert_eq!(only.len(), 1);
    }
}
