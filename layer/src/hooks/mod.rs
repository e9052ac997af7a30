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

pub mod device;
pub mod instance;

#[cfg(test)]
mod chain_tests;

use std::ffi::CStr;

use ash::vk;

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

/// The hook for a device-level command, if revz intercepts it.
pub fn device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetDeviceProcAddr" => {
            void_fn!(vk::PFN_vkGetDeviceProcAddr, device::get_device_proc_addr)
        }
        b"vkDestroyDevice" => void_fn!(vk::PFN_vkDestroyDevice, device::destroy_device),
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
        assert!(instance_command(c"vkCmdDraw").is_none());
        assert!(device_command(c"vkCmdDraw").is_none());
    }
}
