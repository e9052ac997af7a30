//! Device-level hooks: device-level dispatch and device destruction.

use std::ffi::c_char;

use ash::vk;

use crate::boundary::{guarded, EntryPoint};
use crate::ffi;
use crate::state::{DispatchKey, DEVICES};

static GET_DEVICE_PROC_ADDR: EntryPoint = EntryPoint::new("vkGetDeviceProcAddr");
static DESTROY_DEVICE: EntryPoint = EntryPoint::new("vkDestroyDevice");

/// `vkGetDeviceProcAddr`: revz's device hooks first, the next layer for everything else.
///
/// # Safety
/// Called by the loader or the application with the arguments the Vulkan spec allows.
pub unsafe extern "system" fn get_device_proc_addr(
    device: vk::Device,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    guarded(
        &GET_DEVICE_PROC_ADDR,
        || {
            // SAFETY: the spec requires a NUL-terminated name; null is tolerated.
            let name = unsafe { ffi::c_str(p_name) }?;
            if device == vk::Device::null() {
                return None;
            }
            // SAFETY: a non-null device passed to vkGetDeviceProcAddr is live.
            let state = DEVICES.get(unsafe { DispatchKey::of(device) })?;
            if crate::policy::hides_device_command(name, state.added_extended_dynamic_state) {
                return None;
            }
            // SAFETY: calling down the chain with the caller's arguments.
            let next = unsafe { (state.next_get_device_proc_addr)(device, p_name) };
            // A hook is only handed out for a command the device below provides, and the
            // command hooks only where the policy says (`DevicePolicy::command_hooks`).
            let hooks = state.policy.command_hooks(state.profile.is_some());
            let hook = next.and_then(|_| {
                super::device_command(name)
                    .or_else(|| hooks.depth_path.then(|| super::depth_path_command(name))?)
                    .or_else(|| {
                        hooks
                            .precise_path
                            .then(|| super::precise_path_command(name))?
                    })
                    .or_else(|| {
                        hooks.profile.then(|| {
                            super::profile_command(name).or_else(|| super::draw_command(name))
                        })?
                    })
            });
            hook.or(next)
        },
        || None,
    )
}

/// `vkDestroyDevice`.
///
/// # Safety
/// Called by the application with the arguments the Vulkan spec allows.
pub unsafe extern "system" fn destroy_device(
    device: vk::Device,
    p_allocator: *const vk::AllocationCallbacks,
) {
    guarded(
        &DESTROY_DEVICE,
        || {
            if device == vk::Device::null() {
                return;
            }
            // SAFETY: a non-null device being destroyed is still live.
            let removed = DEVICES.remove(unsafe { DispatchKey::of(device) });
            if let Some(state) = &removed {
                if let Some(profile) = &state.profile {
                    profile.set_cameras(super::cameras::camera_list(&state.cameras.learned()));
                    for (image, reason) in state.objects.take_demotions() {
                        profile.demote(image, reason.to_string());
                    }
                    profile.write();
                }
                crate::objects::forget_device_command_buffers(&state.objects);
                state.copies.destroy(device, &state.next);
                destroy_leaked_twins(state);
                state
                    .objects
                    .destroy_own_objects(device, &state.next, &state.commands);
            }
            match removed {
                // SAFETY: calling down with the application's arguments.
                Some(state) => unsafe {
                    (state.next.fp_v1_0().destroy_device)(device, p_allocator)
                },
                None => {
                    log::error!("vkDestroyDevice: unknown device {device:?}; cannot pass it down")
                }
            }
        },
        || (),
    )
}

/// The read twins (and their views and multisampled refresh bindings) of images the
/// application never destroyed: revz's own objects, destroyed before the device so that the
/// application's leak (Zink leaves some depth images to `vkDestroyDevice`) does not become
/// revz's too (the validation layer lists every object alive there).
fn destroy_leaked_twins(state: &crate::state::DeviceState) {
    let objects = &state.objects;
    let v = state.next.fp_v1_0();
    for twin_view in objects.twin_views.take_all() {
        // SAFETY: revz's view; the device is idle (the application's contract for
        // vkDestroyDevice).
        unsafe { (v.destroy_image_view)(state.handle, twin_view.view, std::ptr::null()) };
    }
    for made in objects.multisampled_twins.take_all() {
        // SAFETY: as above.
        unsafe { crate::depth_copy::twin::destroy_multisampled_bindings(state, &made) };
    }
    for twin in objects
        .images
        .take_all()
        .iter()
        .filter_map(|image| image.twin)
    {
        // SAFETY: as above.
        unsafe { crate::depth_copy::twin::destroy(state, &twin) };
    }
}
