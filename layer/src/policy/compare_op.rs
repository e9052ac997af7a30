//! Where a device's dynamic compare op (`vkCmdSetDepthCompareOp`) comes from: core Vulkan
//! 1.3, the application's `VK_EXT_extended_dynamic_state`, the extension revz adds, or nowhere
//! ([`CompareOpSource::decide`], from [`CompareOpFacts`] gathered at `vkCreateDevice`); and
//! whether revz adds the extensions that needs: `VK_KHR_get_physical_device_properties2` to an
//! instance ([`instance_needs_properties2`], at `vkCreateInstance`), and whether its devices may
//! have `VK_EXT_extended_dynamic_state` ([`extended_dynamic_state_allowed`]); and which
//! commands of what revz added the application does not see ([`hides_instance_command`],
//! [`hides_device_command`]: the application did not enable those extensions). The API
//! versions these read are decided here too: the instance's ([`requested_api_version`]) and a
//! device's ([`device_api_version`]).

use std::ffi::CStr;

use ash::vk;

use crate::config::Mode;

/// The API version an instance is created with, where the application asks for `requested`
/// (`VkApplicationInfo::apiVersion`; 0 where it gives no application info): 0 means 1.0 (the
/// spec's rule).
#[must_use]
pub fn requested_api_version(requested: u32) -> u32 {
    match requested {
        0 => vk::API_VERSION_1_0,
        version => version,
    }
}

/// The API version revz uses a device with: the smaller of its instance's (`instance`,
/// [`requested_api_version`]) and its physical device's (`device`): the application may use
/// no more of the device than it asked the instance for.
#[must_use]
pub fn device_api_version(instance: u32, device: u32) -> u32 {
    instance.min(device)
}

/// Whether revz must add `VK_KHR_get_physical_device_properties2` to an instance created with
/// `api`, where the application did not enable it itself (`application_enabled`): below Vulkan
/// 1.1, in any active mode (a device of it may need `VK_EXT_extended_dynamic_state`, and which
/// device is not known yet).
#[must_use]
pub fn instance_needs_properties2(mode: Mode, api: u32, application_enabled: bool) -> bool {
    mode != Mode::Off && api < vk::API_VERSION_1_1 && !application_enabled
}

/// Whether a device of an instance created with `api` (and `properties2_enabled`, by the
/// application or by revz) may enable `VK_EXT_extended_dynamic_state`: the extension's one
/// dependency.
#[must_use]
pub fn extended_dynamic_state_allowed(api: u32, properties2_enabled: bool) -> bool {
    api >= vk::API_VERSION_1_1 || properties2_enabled
}

/// Where a device's `vkCmdSetDepthCompareOp` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompareOpSource {
    /// Vulkan 1.3, which the application asked for and the device has.
    Core,
    /// `VK_EXT_extended_dynamic_state`, which the application enabled itself.
    ApplicationExtension,
    /// `VK_EXT_extended_dynamic_state`, which revz adds to the device's creation.
    AddedExtension,
    Unavailable,
}

/// What [`CompareOpSource::decide`] reads, gathered at `vkCreateDevice`.
pub struct CompareOpFacts<'a> {
    /// The API version revz uses the device with ([`crate::policy::device_api_version`]):
    /// from 1.3 the compare op is core.
    pub api: u32,
    /// The application enabled the extension and its feature.
    pub application_extension: bool,
    /// The application chained the extension's feature structure (with the feature off: it
    /// cannot be changed in place, and a second one would be invalid).
    pub application_feature_struct: bool,
    pub mode_off: bool,
    /// revz may add the extension for this API version and instance (it needs
    /// `VK_KHR_get_physical_device_properties2` below 1.1).
    pub extension_allowed: bool,
    /// Whether the device offers the extension (asked of the layers below, only if needed).
    pub device_has_extension: &'a dyn Fn() -> bool,
}

impl std::fmt::Debug for CompareOpFacts<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CompareOpFacts")
            .field("api", &self.api)
            .field("application_extension", &self.application_extension)
            .field(
                "application_feature_struct",
                &self.application_feature_struct,
            )
            .field("mode_off", &self.mode_off)
            .field("extension_allowed", &self.extension_allowed)
            .finish_non_exhaustive()
    }
}

impl CompareOpSource {
    /// Whether draws get the flipped compare op as dynamic state (else from a pipeline
    /// variant): the device provides it and the next layer gave revz the command.
    pub fn is_dynamic(self, command_loaded: bool) -> bool {
        command_loaded && self != CompareOpSource::Unavailable
    }

    /// Whether `vkCreateDevice` logs where the compare op comes from (at info): only where
    /// revz acts on the device (`mode_off`: it does not), and only where revz adds the
    /// extension or none is available (draws then get it from pipeline variants); core and the
    /// application's extension are as expected.
    #[must_use]
    pub fn logged(self, mode_off: bool) -> bool {
        !mode_off
            && matches!(
                self,
                CompareOpSource::AddedExtension | CompareOpSource::Unavailable
            )
    }

    /// How the device provides a dynamic compare op.
    pub fn decide(facts: &CompareOpFacts<'_>) -> CompareOpSource {
        if facts.api >= vk::API_VERSION_1_3 {
            return CompareOpSource::Core;
        }
        if facts.application_extension {
            return CompareOpSource::ApplicationExtension;
        }
        if facts.mode_off || facts.application_feature_struct || !facts.extension_allowed {
            return CompareOpSource::Unavailable;
        }
        if (facts.device_has_extension)() {
            CompareOpSource::AddedExtension
        } else {
            CompareOpSource::Unavailable
        }
    }
}

/// The commands of `VK_KHR_get_physical_device_properties2`.
const GET_PHYSICAL_DEVICE_PROPERTIES2_COMMANDS: [&[u8]; 7] = [
    b"vkGetPhysicalDeviceFeatures2KHR",
    b"vkGetPhysicalDeviceProperties2KHR",
    b"vkGetPhysicalDeviceFormatProperties2KHR",
    b"vkGetPhysicalDeviceImageFormatProperties2KHR",
    b"vkGetPhysicalDeviceQueueFamilyProperties2KHR",
    b"vkGetPhysicalDeviceMemoryProperties2KHR",
    b"vkGetPhysicalDeviceSparseImageFormatProperties2KHR",
];

/// The commands of `VK_EXT_extended_dynamic_state` (their EXT names; the core names are the
/// application's wherever its API version has them).
const EXTENDED_DYNAMIC_STATE_COMMANDS: [&[u8]; 12] = [
    b"vkCmdSetCullModeEXT",
    b"vkCmdSetFrontFaceEXT",
    b"vkCmdSetPrimitiveTopologyEXT",
    b"vkCmdSetViewportWithCountEXT",
    b"vkCmdSetScissorWithCountEXT",
    b"vkCmdBindVertexBuffers2EXT",
    b"vkCmdSetDepthTestEnableEXT",
    b"vkCmdSetDepthWriteEnableEXT",
    b"vkCmdSetDepthCompareOpEXT",
    b"vkCmdSetDepthBoundsTestEnableEXT",
    b"vkCmdSetStencilTestEnableEXT",
    b"vkCmdSetStencilOpEXT",
];

/// Whether `vkGetInstanceProcAddr` hides `name` from the application: a command of an instance
/// extension revz added.
pub fn hides_instance_command(name: &CStr, added_properties2: bool) -> bool {
    added_properties2 && GET_PHYSICAL_DEVICE_PROPERTIES2_COMMANDS.contains(&name.to_bytes())
}

/// Whether `vkGetDeviceProcAddr` hides `name` from the application: a command of a device
/// extension revz added.
pub fn hides_device_command(name: &CStr, added_extended_dynamic_state: bool) -> bool {
    added_extended_dynamic_state && EXTENDED_DYNAMIC_STATE_COMMANDS.contains(&name.to_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compare_op_is_dynamic_only_where_the_device_has_it_and_the_command_was_loaded() {
        use CompareOpSource as S;
        for source in [S::Core, S::ApplicationExtension, S::AddedExtension] {
            assert!(source.is_dynamic(true));
            assert!(!source.is_dynamic(false));
        }
        assert!(!S::Unavailable.is_dynamic(true));
    }

    #[test]
    fn the_compare_op_comes_from_core_the_application_or_revz_in_that_order() {
        let asked = std::cell::Cell::new(false);
        let has = || {
            asked.set(true);
            true
        };
        let facts = |core: bool, app, feature_struct, off, allowed| CompareOpFacts {
            api: if core {
                vk::API_VERSION_1_3
            } else {
                vk::API_VERSION_1_2
            },
            application_extension: app,
            application_feature_struct: feature_struct,
            mode_off: off,
            extension_allowed: allowed,
            device_has_extension: &has,
        };
        use CompareOpSource as S;
        assert_eq!(S::decide(&facts(true, false, false, false, true)), S::Core);
        assert_eq!(
            S::decide(&facts(false, true, true, true, false)),
            S::ApplicationExtension
        );
        assert!(!asked.get(), "the device is asked only where it decides");
        assert_eq!(
            S::decide(&facts(false, false, true, false, true)),
            S::Unavailable
        );
        assert_eq!(
            S::decide(&facts(false, false, false, true, true)),
            S::Unavailable
        );
        assert_eq!(
            S::decide(&facts(false, false, false, false, false)),
            S::Unavailable
        );
        assert_eq!(
            S::decide(&facts(false, false, false, false, true)),
            S::AddedExtension
        );
        let none = || false;
        let without = CompareOpFacts {
            device_has_extension: &none,
            ..facts(false, false, false, false, true)
        };
        assert_eq!(S::decide(&without), S::Unavailable);
        let later = CompareOpFacts {
            api: vk::make_api_version(0, 1, 4, 0),
            ..facts(false, false, false, false, true)
        };
        assert_eq!(S::decide(&later), S::Core);
    }

    #[test]
    fn only_an_added_or_missing_compare_op_is_logged_in_active_modes() {
        use CompareOpSource as S;
        for source in [S::AddedExtension, S::Unavailable] {
            assert!(source.logged(false));
            assert!(!source.logged(true));
        }
        for source in [S::Core, S::ApplicationExtension] {
            assert!(!source.logged(false));
            assert!(!source.logged(true));
        }
    }

    #[test]
    fn no_api_version_means_1_0_and_a_device_is_used_at_the_smaller_version() {
        use vk::{API_VERSION_1_0 as V10, API_VERSION_1_2 as V12, API_VERSION_1_3 as V13};
        assert_eq!(requested_api_version(0), V10);
        assert_eq!(requested_api_version(V12), V12);
        assert_eq!(requested_api_version(V10), V10);
        assert_eq!(device_api_version(V12, V13), V12);
        assert_eq!(device_api_version(V13, V12), V12);
        assert_eq!(device_api_version(V13, V13), V13);
    }

    #[test]
    fn properties2_is_added_only_below_vulkan_1_1_in_active_modes_where_missing() {
        use vk::{API_VERSION_1_0 as V10, API_VERSION_1_1 as V11, API_VERSION_1_3 as V13};
        for mode in [Mode::Flip, Mode::Complementary, Mode::Infinite] {
            assert!(instance_needs_properties2(mode, V10, false));
            assert!(!instance_needs_properties2(mode, V10, true));
            assert!(!instance_needs_properties2(mode, V11, false));
            assert!(!instance_needs_properties2(mode, V13, false));
        }
        assert!(!instance_needs_properties2(Mode::Off, V10, false));
        assert!(extended_dynamic_state_allowed(V11, false));
        assert!(extended_dynamic_state_allowed(V10, true));
        assert!(!extended_dynamic_state_allowed(V10, false));
    }

    #[test]
    fn only_the_commands_of_added_extensions_are_hidden() {
        assert!(hides_instance_command(
            c"vkGetPhysicalDeviceFeatures2KHR",
            true
        ));
        assert!(!hides_instance_command(
            c"vkGetPhysicalDeviceFeatures2KHR",
            false
        ));
        // The core name is the application's at 1.1 and above; at 1.0 the loader answers it.
        assert!(!hides_instance_command(
            c"vkGetPhysicalDeviceFeatures2",
            true
        ));
        assert!(hides_device_command(c"vkCmdSetDepthCompareOpEXT", true));
        assert!(hides_device_command(c"vkCmdSetStencilOpEXT", true));
        assert!(!hides_device_command(c"vkCmdSetDepthCompareOpEXT", false));
        assert!(!hides_device_command(c"vkCmdSetDepthCompareOp", true));
        assert!(!hides_device_command(c"vkCmdDraw", true));
    }
}
