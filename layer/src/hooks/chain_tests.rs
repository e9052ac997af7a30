//! The hooks driven through a fake loader chain: a fake next layer of `extern "system"` stubs
//! stands below revz, so the chain walk, the state registration and the pass-through of
//! commands revz does not intercept are checked without a GPU or a loader.

use ash::vk;

use super::fake_chain::{
    self, fake_cmd_draw, fake_command, fake_create_device, fake_destroy_device,
    fake_get_device_proc_addr, Event, Tables, VoidFn,
};
use super::{device, instance};
use crate::state::{DispatchKey, DEVICES, INSTANCES};

#[test]
fn instance_and_device_go_through_the_chain_and_unknown_commands_pass_down() {
    // This test's own dispatch tables: other tests create instances and devices in parallel.
    let tables = Tables::fresh();
    // --- instance
    // The application asks for flip mode through VK_EXT_layer_settings.
    let (handle, advanced) = fake_chain::create_instance(&[(c"mode", c"flip")]);
    assert_ne!(handle, vk::Instance::null());
    assert!(advanced, "revz must advance the chain to the next link");
    // SAFETY: `handle` is the fake's live object.
    let instance_key = unsafe { DispatchKey::of(handle) };
    let state = INSTANCES
        .get(instance_key)
        .expect("the instance is registered");
    assert_eq!(state.settings.mode, crate::config::Mode::Flip);
    let instance_events = fake_chain::take_events(tables.instance);
    assert!(
        instance_events.contains(&Event::SettingsPassedDown),
        "the application's chain must reach the next layer untouched"
    );

    // SAFETY: valid names and a live instance.
    unsafe {
        let passed = instance::get_instance_proc_addr(handle, c"vkFakeInstanceCommand".as_ptr());
        assert_eq!(
            passed.map(|f| f as usize),
            Some(fake_command as VoidFn as usize)
        );
        let hooked = instance::get_instance_proc_addr(handle, c"vkCreateDevice".as_ptr());
        assert_ne!(hooked.map(|f| f as usize), None);
        assert_ne!(
            hooked.map(|f| f as usize),
            Some(fake_create_device as vk::PFN_vkCreateDevice as usize)
        );
        assert!(instance::get_instance_proc_addr(handle, c"vkNoSuchCommand".as_ptr()).is_none());
    }

    // --- device
    let (physical, device_handle, advanced) =
        fake_chain::create_device(tables, fake_get_device_proc_addr);
    assert_ne!(device_handle, vk::Device::null());
    assert!(advanced);
    // SAFETY: the fake's live object.
    let device_key = unsafe { DispatchKey::of(device_handle) };
    let device_state = DEVICES.get(device_key).expect("the device is registered");
    assert_eq!(device_state.handle, device_handle);
    assert_eq!(device_state.settings.mode, crate::config::Mode::Flip);

    // SAFETY: valid names and a live device.
    unsafe {
        let passed = device::get_device_proc_addr(device_handle, c"vkFakeDeviceCommand".as_ptr());
        assert_eq!(
            passed.map(|f| f as usize),
            Some(fake_command as VoidFn as usize)
        );
        let hooked = device::get_device_proc_addr(device_handle, c"vkDestroyDevice".as_ptr());
        assert!(hooked.is_some());
        assert_ne!(
            hooked.map(|f| f as usize),
            Some(fake_destroy_device as vk::PFN_vkDestroyDevice as usize)
        );
        assert!(device::get_device_proc_addr(device_handle, c"vkNoSuchCommand".as_ptr()).is_none());
        // The flip path is active on this device, and draws are still the next layer's own
        // (`draws_are_the_next_layers_own_unless_the_profile_counts_them`).
        assert!(device_state.policy.is_active());
        // A depth-path command the device below does not have is not handed out.
        assert!(
            device::get_device_proc_addr(device_handle, c"vkCmdBeginRendering".as_ptr()).is_none()
        );

        device::destroy_device(device_handle, std::ptr::null());
    }
    let destroyed_devices = fake_chain::take_events(tables.device);
    assert_eq!(destroyed_devices, [Event::DestroyDevice]);
    assert!(DEVICES.get(device_key).is_none());

    // SAFETY: a live instance.
    unsafe { instance::destroy_instance(handle, std::ptr::null()) };
    let destroyed_instances = fake_chain::take_events(tables.instance);
    assert_eq!(destroyed_instances, [Event::DestroyInstance]);
    assert!(INSTANCES.get(instance_key).is_none());

    // The fake objects are boxes; reclaim them.
    // SAFETY: each was made by `dispatchable` and is no longer used.
    unsafe {
        fake_chain::reclaim(handle);
        fake_chain::reclaim(physical);
        fake_chain::reclaim(device_handle);
    }
}

/// Issue #17: revz needs nothing at draws (every hook that changes what a draw needs sends it
/// down as it goes), so in every mode the draw commands a device hands out are the next
/// layer's own functions: a draw costs what it costs without revz. Only the depth profile,
/// which counts draws, hooks them.
#[test]
fn draws_are_the_next_layers_own_unless_the_profile_counts_them() {
    let report = std::env::temp_dir().join(format!("revz-draws-{}.json", std::process::id()));
    let report_value =
        std::ffi::CString::new(report.to_str().expect("a UTF-8 temporary path")).expect("no NUL");
    // Leaked: the settings table takes `'static` strings.
    let report_value: &'static std::ffi::CStr = Box::leak(report_value.into_boxed_c_str());
    for (mode, profiled) in [
        (c"off", false),
        (c"flip", false),
        (c"complementary", false),
        (c"infinite", false),
        (c"flip", true),
        (c"infinite", true),
    ] {
        let tables = Tables::fresh();
        let mut settings = vec![(c"mode", mode)];
        if profiled {
            settings.push((c"report", report_value));
        }
        let (instance_handle, _) = fake_chain::create_instance(&settings);
        let (physical, device_handle, _) =
            fake_chain::create_device(tables, fake_get_device_proc_addr);
        // SAFETY: the fake's live object.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device_handle) })
            .expect("the device is registered");
        // SAFETY: a valid name and a live device.
        let draw = unsafe { device::get_device_proc_addr(device_handle, c"vkCmdDraw".as_ptr()) };
        let own = Some(fake_cmd_draw as vk::PFN_vkCmdDraw as usize);
        if profiled {
            assert!(state.profile.is_some(), "{mode:?}: the profile is on");
            assert_ne!(
                draw.map(|f| f as usize),
                own,
                "{mode:?} with the profile: revz counts draws"
            );
        } else {
            assert_eq!(
                draw.map(|f| f as usize),
                own,
                "{mode:?}: vkCmdDraw is the next layer's own"
            );
        }
        // The commands that change what a draw needs are revz's where it acts.
        // SAFETY: as above.
        let compare_op = unsafe {
            device::get_device_proc_addr(device_handle, c"vkCmdSetDepthCompareOp".as_ptr())
        };
        assert!(compare_op.is_some());
        assert_eq!(
            state.policy.is_active(),
            compare_op.map(|f| f as usize)
                != Some(
                    fake_chain::fake_cmd_set_depth_compare_op as vk::PFN_vkCmdSetDepthCompareOp
                        as usize
                ),
            "{mode:?}"
        );
        // SAFETY: live objects, destroyed once; the fake objects are boxes.
        unsafe {
            device::destroy_device(device_handle, std::ptr::null());
            instance::destroy_instance(instance_handle, std::ptr::null());
            fake_chain::reclaim(instance_handle);
            fake_chain::reclaim(physical);
            fake_chain::reclaim(device_handle);
        }
    }
    // The files the profiled devices wrote (named apart after the process's first).
    let prefix = format!("revz-draws-{}", std::process::id());
    for entry in std::fs::read_dir(std::env::temp_dir())
        .into_iter()
        .flatten()
        .flatten()
    {
        if entry.file_name().to_string_lossy().starts_with(&prefix) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
