//! Settings an application passes with `VK_EXT_layer_settings`: `VkLayerSettingsCreateInfoEXT`
//! chained into `VkInstanceCreateInfo`, each `VkLayerSettingEXT` naming a layer and a setting.
//!
//! Only settings whose `pLayerName` is revz's are read; the structure itself stays in the chain
//! untouched for the layers below. Strings (`VK_LAYER_SETTING_TYPE_STRING_EXT`) are accepted for
//! every setting and `BOOL32` for boolean ones; anything else is reported, not guessed at.

use std::ffi::{c_char, c_void};

use ash::vk;

use super::Value;
use crate::LAYER_NAME;

/// One setting addressed to revz.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LayerSetting {
    /// `pSettingName`.
    pub name: String,
    /// The value, or why it could not be read.
    pub value: Result<Value, String>,
}

/// Reads the settings for revz from every `VkLayerSettingsCreateInfoEXT` in a `pNext` chain.
///
/// # Safety
/// `p_next` must be null or the head of a valid Vulkan structure chain (as the spec requires of
/// `VkInstanceCreateInfo::pNext`).
pub unsafe fn read(p_next: *const c_void) -> Vec<LayerSetting> {
    let mut found = Vec::new();
    // SAFETY: the caller's contract.
    for base in unsafe { crate::chain::structures(p_next) } {
        if base.s_type != vk::StructureType::LAYER_SETTINGS_CREATE_INFO_EXT {
            continue;
        }
        // SAFETY: the sType identifies the structure.
        let info = unsafe {
            &*(base as *const vk::BaseInStructure<'_>).cast::<vk::LayerSettingsCreateInfoEXT>()
        };
        let count = info.setting_count as usize;
        if count > 0 && !info.p_settings.is_null() {
            // SAFETY: the spec requires `settingCount` valid elements.
            let settings = unsafe { std::slice::from_raw_parts(info.p_settings, count) };
            for setting in settings {
                // SAFETY: each element is a valid `VkLayerSettingEXT`.
                if let Some(setting) = unsafe { read_one(setting) } {
                    found.push(setting);
                }
            }
        }
    }
    found
}

/// # Safety
/// `setting` must be a valid `VkLayerSettingEXT`.
unsafe fn read_one(setting: &vk::LayerSettingEXT<'_>) -> Option<LayerSetting> {
    // SAFETY: the layer and setting names are null or NUL-terminated strings.
    let layer = unsafe { c_str(setting.p_layer_name) }?;
    if layer != LAYER_NAME {
        return None;
    }
    // SAFETY: as above.
    let name = unsafe { c_str(setting.p_setting_name) }?.to_owned();
    let value = if setting.value_count == 0 || setting.p_values.is_null() {
        Err("no value given".to_owned())
    } else {
        match setting.ty {
            vk::LayerSettingTypeEXT::STRING => {
                // SAFETY: for STRING, `pValues` is an array of `valueCount` C strings.
                let first = unsafe { *setting.p_values.cast::<*const c_char>() };
                // SAFETY: a NUL-terminated string or null.
                match unsafe { c_str(first) } {
                    Some(text) => Ok(Value::Text(text.to_owned())),
                    None => Err("the string value is null or not UTF-8".to_owned()),
                }
            }
            vk::LayerSettingTypeEXT::BOOL32 => {
                // SAFETY: for BOOL32, `pValues` is an array of `valueCount` VkBool32.
                let first = unsafe { *setting.p_values.cast::<vk::Bool32>() };
                Ok(Value::Bool(first != vk::FALSE))
            }
            other => Err(format!(
                "type {other:?} is not supported (use STRING, or BOOL32 for booleans)"
            )),
        }
    };
    Some(LayerSetting { name, value })
}

/// # Safety
/// `ptr` must be null or a NUL-terminated string.
unsafe fn c_str<'a>(ptr: *const c_char) -> Option<&'a str> {
    // SAFETY: the caller guarantees NUL termination.
    unsafe { crate::ffi::c_str(ptr) }?.to_str().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_only_revz_settings_of_supported_types() {
        let infinite = c"infinite";
        let strings = [infinite.as_ptr()];
        let yes: vk::Bool32 = vk::TRUE;
        let number: i32 = 3;
        let layer = c"VK_LAYER_REVZ_reverse_z";
        let other = c"VK_LAYER_KHRONOS_validation";
        let settings = [
            vk::LayerSettingEXT {
                p_layer_name: layer.as_ptr(),
                p_setting_name: c"mode".as_ptr(),
                ty: vk::LayerSettingTypeEXT::STRING,
                value_count: 1,
                p_values: strings.as_ptr().cast(),
                ..Default::default()
            },
            vk::LayerSettingEXT {
                p_layer_name: other.as_ptr(),
                p_setting_name: c"mode".as_ptr(),
                ty: vk::LayerSettingTypeEXT::STRING,
                value_count: 1,
                p_values: strings.as_ptr().cast(),
                ..Default::default()
            },
            vk::LayerSettingEXT {
                p_layer_name: layer.as_ptr(),
                p_setting_name: c"reverse_observable".as_ptr(),
                ty: vk::LayerSettingTypeEXT::BOOL32,
                value_count: 1,
                p_values: (&yes as *const vk::Bool32).cast(),
                ..Default::default()
            },
            vk::LayerSettingEXT {
                p_layer_name: layer.as_ptr(),
                p_setting_name: c"far_clip".as_ptr(),
                ty: vk::LayerSettingTypeEXT::INT32,
                value_count: 1,
                p_values: (&number as *const i32).cast(),
                ..Default::default()
            },
            vk::LayerSettingEXT {
                p_layer_name: layer.as_ptr(),
                p_setting_name: c"log".as_ptr(),
                ty: vk::LayerSettingTypeEXT::STRING,
                value_count: 0,
                p_values: std::ptr::null(),
                ..Default::default()
            },
        ];
        let info = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
        let debug = vk::DebugUtilsMessengerCreateInfoEXT {
            p_next: (&info as *const vk::LayerSettingsCreateInfoEXT).cast(),
            ..Default::default()
        };
        // SAFETY: a valid chain of two structures.
        let read = unsafe { read((&debug as *const vk::DebugUtilsMessengerCreateInfoEXT).cast()) };
        assert_eq!(
            read,
            vec![
                LayerSetting {
                    name: "mode".into(),
                    value: Ok(Value::Text("infinite".into()))
                },
                LayerSetting {
                    name: "reverse_observable".into(),
                    value: Ok(Value::Bool(true))
                },
                LayerSetting {
                    name: "far_clip".into(),
                    value: Err(
                        "type INT32 is not supported (use STRING, or BOOL32 for booleans)".into()
                    )
                },
                LayerSetting {
                    name: "log".into(),
                    value: Err("no value given".into())
                },
            ]
        );
    }

    #[test]
    fn an_empty_chain_has_no_settings() {
        // SAFETY: null is an empty chain.
        assert!(unsafe { read(std::ptr::null()) }.is_empty());
    }
}
