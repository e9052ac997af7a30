//! What revz enables beyond the application's request, through the fake loader chain: the
//! instance extension a Vulkan 1.0 application needs for the device extension revz adds, and
//! the commands of both hidden from the application.

use std::ffi::CStr;

use ash::vk;

use super::extensions::{EXTENDED_DYNAMIC_STATE, GET_PHYSICAL_DEVICE_PROPERTIES2};
use super::fake_chain::{self, fake_get_device_proc_addr, Tables};
use super::{device, instance};
use crate::state::{DispatchKey, DEVICES};

fn names(list: &[&CStr]) -> Vec<String> {
    list.iter()
        .map(|name| name.to_string_lossy().into_owned())
        .collect()
}

/// Creates an instance and a device as an application asking for `api` with `extensions` in
/// `mode`; returns what the instance and the device were created with below revz, whether the
/// application sees `vkGetPhysicalDeviceFeatures2KHR` and `vkCmdSetDepthCompareOpEXT`, and
/// whether revz itself has a dynamic compare op.
fn created(
    api: u32,
    extensions: &[&'static CStr],
    mode: &'static CStr,
) -> (Vec<String>, Vec<String>, bool, bool, bool) {
    let tables = Tables::fresh();
    let (instance, _) = fake_chain::create_instance_at(api, extensions, &[(c"mode", mode)]);
    assert_eq!(
        fake_chain::take_events(tables.instance),
        [fake_chain::Event::SettingsPassedDown]
    );
    let (physical, device, _) = fake_chain::create_device(tables, fake_get_device_proc_addr);
    // SAFETY: a live instance and device, NUL-terminated names.
    let (features2, compare_op) = unsafe {
        (
            instance::get_instance_proc_addr(instance, c"vkGetPhysicalDeviceFeatures2KHR".as_ptr())
                .is_some(),
            device::get_device_proc_addr(device, c"vkCmdSetDepthCompareOpEXT".as_ptr()).is_some(),
        )
    };
    // SAFETY: the fake's live device.
    let state = DEVICES
        .get(unsafe { DispatchKey::of(device) })
        .expect("the device is registered");
    let dynamic =
        !state.policy.compare_op_variants && state.commands.set_depth_compare_op.is_some();
    drop(state);
    let instance_extensions = fake_chain::created_with(tables.instance);
    let device_extensions = fake_chain::created_with(tables.device);
    // SAFETY: the objects made above, destroyed once.
    unsafe { fake_chain::tear_down(tables, instance, physical, device) };
    (
        instance_extensions,
        device_extensions,
        features2,
        compare_op,
        dynamic,
    )
}

#[test]
fn a_vulkan_1_0_application_gets_the_instance_extension_the_added_device_extension_requires() {
    for mode in [c"flip", c"complementary", c"infinite"] {
        let (instance, device, features2, compare_op, dynamic) =
            created(vk::API_VERSION_1_0, &[], mode);
        assert_eq!(
            instance,
            names(&[GET_PHYSICAL_DEVICE_PROPERTIES2]),
            "{mode:?}"
        );
        assert_eq!(device, names(&[EXTENDED_DYNAMIC_STATE]), "{mode:?}");
        assert!(dynamic, "{mode:?}: revz itself uses the dynamic compare op");
        assert!(
            !features2,
            "{mode:?}: the added instance extension's commands are revz's"
        );
        assert!(
            !compare_op,
            "{mode:?}: the added device extension's commands are revz's"
        );
    }
}

#[test]
fn an_application_that_enabled_the_instance_extension_keeps_it_and_its_commands() {
    let (instance, device, features2, compare_op, dynamic) = created(
        vk::API_VERSION_1_0,
        &[c"VK_EXT_debug_utils", GET_PHYSICAL_DEVICE_PROPERTIES2],
        c"flip",
    );
    assert_eq!(
        instance,
        names(&[c"VK_EXT_debug_utils", GET_PHYSICAL_DEVICE_PROPERTIES2])
    );
    assert_eq!(device, names(&[EXTENDED_DYNAMIC_STATE]));
    assert!(dynamic && features2 && !compare_op);
}

#[test]
fn nothing_is_added_at_vulkan_1_1_and_1_3_or_when_off() {
    // 1.1 has properties2 in core: only the device extension is added.
    let (instance, device, features2, compare_op, dynamic) =
        created(vk::API_VERSION_1_1, &[], c"flip");
    assert!(instance.is_empty());
    assert_eq!(device, names(&[EXTENDED_DYNAMIC_STATE]));
    assert!(dynamic && features2 && !compare_op);
    // 1.3 has the compare op in core: nothing is added.
    let (instance, device, _, compare_op, dynamic) = created(vk::API_VERSION_1_3, &[], c"flip");
    assert!(instance.is_empty() && device.is_empty());
    assert!(dynamic && compare_op);
    // Off: the application's requests pass through as they are.
    let (instance, device, features2, compare_op, _) = created(vk::API_VERSION_1_0, &[], c"off");
    assert!(instance.is_empty() && device.is_empty());
    assert!(features2 && compare_op);
}
