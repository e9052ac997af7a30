//! revz: a Vulkan layer that renders unmodified applications with a reversed depth buffer.
//!
//! See `shared/DESIGN.md` for the depth math and the per-draw model, and `docs/` for each path.
//! The crate keeps its concerns apart:
//! - the Vulkan plumbing: [`ffi`] (loader structures), [`boundary`] (no panic crosses into C),
//!   [`state`] (per-instance/device state keyed by dispatch pointer), [`objects`] (tracked
//!   objects), [`chain`] (pNext chains), [`depth_copy`] (converted copies of reversed images)
//!   and `hooks` (the intercepted commands, thin and mechanical); [`shader`], the SPIR-V
//!   readers and rewriters (which push-constant bytes hold the projection, the `Position`
//!   store rewrite, the in-shader range fit for projections in buffers, the fragment depth
//!   rewrite);
//! - the policy: [`policy`], every decision revz takes, as functions of plain facts (its docs
//!   hold the table: decision, facts, where they come from: which images are reversed or
//!   promoted, resolves, the application's convention, the compare op, pipelines' dynamic
//!   state and variants, which path a pipeline takes, copies, secondaries, which hooks a device
//!   hands out); the hooks gather the facts, ask, and apply the answer; [`config`] (the
//!   settings and where they come from);
//! - the depth math: the `revz-math` crate (pure Rust, no Vulkan), with the per-draw logic in
//!   [`command_state`] (the draw's path and its depth state), [`precise`] (push-constant shadow
//!   copy, cameras, the carrier) and [`conv`];
//! - what revz tells the user: [`logging`] and [`profile`] (the depth profile, `REVZ_REPORT`).
//!
//! Only the three loader entry points below are exported from the shared library.

// The library file must be `libVkLayer_revz.so` (the name Vulkan layers conventionally use).
#![allow(non_snake_case)]

pub mod boundary;
pub mod chain;
pub mod command_state;
pub mod config;
pub mod conv;
pub mod depth_copy;
pub mod ffi;
#[cfg(test)]
mod fuzz;
mod hooks;
pub mod logging;
pub mod objects;
pub mod policy;
pub mod precise;
pub mod profile;
pub mod shader;
pub mod state;
pub mod vk_ext;

use std::ffi::c_char;

use ash::vk;

use boundary::{guarded, EntryPoint};

/// The layer name the manifests declare and applications enable.
pub const LAYER_NAME: &str = "VK_LAYER_REVZ_reverse_z";
/// The crate version, as logged at load.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

static NEGOTIATE: EntryPoint = EntryPoint::new("vkNegotiateLoaderLayerInterfaceVersion");

/// Loader entry point: agrees on interface version 2 and hands the loader our dispatch
/// functions.
///
/// # Safety
/// Called by the loader with a valid `VkNegotiateLayerInterface` (null is tolerated).
#[no_mangle]
pub unsafe extern "system" fn vkNegotiateLoaderLayerInterfaceVersion(
    p_version_struct: *mut ffi::NegotiateLayerInterface,
) -> vk::Result {
    guarded(
        &NEGOTIATE,
        || {
            // SAFETY: the loader passes a valid struct; null is rejected.
            let Some(negotiate) = (unsafe { p_version_struct.as_mut() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            if negotiate.s_type != ffi::LAYER_NEGOTIATE_INTERFACE_STRUCT
                || negotiate.loader_layer_interface_version < ffi::LAYER_INTERFACE_VERSION
            {
                // Interface versions 0 and 1 have no negotiation and different rules.
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            }
            negotiate.loader_layer_interface_version = ffi::LAYER_INTERFACE_VERSION;
            negotiate.pfn_get_instance_proc_addr = Some(hooks::instance::get_instance_proc_addr);
            negotiate.pfn_get_device_proc_addr = Some(hooks::device::get_device_proc_addr);
            negotiate.pfn_get_physical_device_proc_addr = None;
            vk::Result::SUCCESS
        },
        || vk::Result::ERROR_INITIALIZATION_FAILED,
    )
}

/// Exported `vkGetInstanceProcAddr`, for loaders and tools that look the symbol up directly.
///
/// # Safety
/// As for `hooks::instance::get_instance_proc_addr`: the loader's contract.
#[no_mangle]
pub unsafe extern "system" fn vkGetInstanceProcAddr(
    instance: vk::Instance,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: forwarded unchanged.
    unsafe { hooks::instance::get_instance_proc_addr(instance, p_name) }
}

/// Exported `vkGetDeviceProcAddr`, for loaders and tools that look the symbol up directly.
///
/// # Safety
/// As for `hooks::device::get_device_proc_addr`: the loader's contract.
#[no_mangle]
pub unsafe extern "system" fn vkGetDeviceProcAddr(
    device: vk::Device,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: forwarded unchanged.
    unsafe { hooks::device::get_device_proc_addr(device, p_name) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negotiation_settles_on_version_2() {
        let mut negotiate = ffi::NegotiateLayerInterface {
            s_type: ffi::LAYER_NEGOTIATE_INTERFACE_STRUCT,
            p_next: std::ptr::null_mut(),
            loader_layer_interface_version: 5,
            pfn_get_instance_proc_addr: None,
            pfn_get_device_proc_addr: None,
            pfn_get_physical_device_proc_addr: None,
        };
        // SAFETY: a valid struct.
        let result = unsafe { vkNegotiateLoaderLayerInterfaceVersion(&mut negotiate) };
        assert_eq!(result, vk::Result::SUCCESS);
        assert_eq!(negotiate.loader_layer_interface_version, 2);
        assert!(negotiate.pfn_get_instance_proc_addr.is_some());
        assert!(negotiate.pfn_get_device_proc_addr.is_some());
    }

    #[test]
    fn negotiation_rejects_old_loaders_and_null() {
        let mut negotiate = ffi::NegotiateLayerInterface {
            s_type: ffi::LAYER_NEGOTIATE_INTERFACE_STRUCT,
            p_next: std::ptr::null_mut(),
            loader_layer_interface_version: 1,
            pfn_get_instance_proc_addr: None,
            pfn_get_device_proc_addr: None,
            pfn_get_physical_device_proc_addr: None,
        };
        // SAFETY: a valid struct, and null.
        unsafe {
            assert_eq!(
                vkNegotiateLoaderLayerInterfaceVersion(&mut negotiate),
                vk::Result::ERROR_INITIALIZATION_FAILED
            );
            assert_eq!(
                vkNegotiateLoaderLayerInterfaceVersion(std::ptr::null_mut()),
                vk::Result::ERROR_INITIALIZATION_FAILED
            );
        }
    }
}
