//! The hooks driven through a fake loader chain: a fake next layer of `extern "system"` stubs
//! stands below revz, so the chain walk, the state registration and the pass-through of
//! commands revz does not intercept are checked without a GPU or a loader.

use ash::vk;

use super::fake_chain::{
    self, fake_cmd_draw, fake_command, fake_create_device, fake_destroy_device,
    fake_get_device_proc_addr, fake_get_instance_proc_addr, Event, Tables, VoidFn,
};
use super::{device, instance};
use crate::ffi;
use crate::state::{DispatchKey, DEVICES, INSTANCES};

#[test]
fn instance_and_device_go_through_the_chain_and_unknown_commands_pass_down() {
    // This test's own dispatch tables: other tests create instances and devices in parallel.
    let tables = Tables::fresh();
    // --- instance
    let mut instance_link = ffi::LayerInstanceLink {
        p_next: std::ptr::null_mut(),
        pfn_next_get_instance_proc_addr: fake_get_instance_proc_addr,
        pfn_next_get_physical_device_proc_addr: None,
    };
    let mut instance_chain = ffi::LayerInstanceCreateInfo {
        s_type: ffi::STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO,
        p_next: std::ptr::null(),
        function: ffi::LAYER_LINK_INFO,
        p_layer_info: &mut instance_link,
    };
    // The application asks for flip mode through VK_EXT_layer_settings.
    let flip = [c"flip".as_ptr()];
    let settings = [vk::LayerSettingEXT {
        p_layer_name: c"VK_LAYER_REVZ_reverse_z".as_ptr(),
        p_setting_name: c"mode".as_ptr(),
        ty: vk::LayerSettingTypeEXT::STRING,
        value_count: 1,
        p_values: flip.as_ptr().cast(),
        ..Default::default()
    }];
    let mut layer_settings = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    layer_settings.p_next = (&mut instance_chain as *mut ffi::LayerInstanceCreateInfo).cast();
    let app_info = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let create_info = vk::InstanceCreateInfo {
        p_next: (&layer_settings as *const vk::LayerSettingsCreateInfoEXT).cast(),
        p_application_info: &app_info,
        ..Default::default()
    };
    let mut handle = vk::Instance::null();
    // SAFETY: a well-formed loader chain over the fake layer.
    let result = unsafe { instance::create_instance(&create_info, std::ptr::null(), &mut handle) };
    assert_eq!(result, vk::Result::SUCCESS);
    assert_ne!(handle, vk::Instance::null());
    assert!(
        instance_chain.p_layer_info.is_null(),
        "revz must advance the chain to the next link"
    );
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

    // --- device: the physical device shares the instance's dispatch table.
    let physical: vk::PhysicalDevice = fake_chain::dispatchable(fake_chain::key(tables.instance));
    let mut device_link = ffi::LayerDeviceLink {
        p_next: std::ptr::null_mut(),
        pfn_next_get_instance_proc_addr: fake_get_instance_proc_addr,
        pfn_next_get_device_proc_addr: fake_get_device_proc_addr,
    };
    let mut device_chain = ffi::LayerDeviceCreateInfo {
        s_type: ffi::STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO,
        p_next: std::ptr::null(),
        function: ffi::LAYER_LINK_INFO,
        p_layer_info: &mut device_link,
    };
    let device_info = vk::DeviceCreateInfo {
        p_next: (&mut device_chain as *mut ffi::LayerDeviceCreateInfo).cast(),
        ..Default::default()
    };
    let mut device_handle = vk::Device::null();
    // SAFETY: a well-formed loader chain over the fake layer.
    let result = unsafe {
        instance::create_device(physical, &device_info, std::ptr::null(), &mut device_handle)
    };
    assert_eq!(result, vk::Result::SUCCESS);
    assert!(device_chain.p_layer_info.is_null());
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
