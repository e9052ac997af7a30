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
        // The flip path is active on this device: draws go through revz's hook.
        assert!(device_state.policy.is_active());
        let draw = device::get_device_proc_addr(device_handle, c"vkCmdDraw".as_ptr());
        assert!(draw.is_some());
        assert_ne!(
            draw.map(|f| f as usize),
            Some(fake_cmd_draw as vk::PFN_vkCmdDraw as usize)
        );
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
