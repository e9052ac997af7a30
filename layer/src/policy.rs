//! The policy: the one place that decides which depth images revz reverses.
//!
//! An image is decided once, at creation, for its whole life: every draw into it must then
//! follow the same convention (`shared/DESIGN.md` section 2). A depth image the application can
//! observe keeps standard depth unless the `reverse_observable` setting allows it, because its
//! readers (shadow-map compares, SSAO, picking, screenshots) expect standard values.

use std::fmt;

use ash::vk;

use crate::config::{Mode, Observable, Settings};
use crate::conv::has_depth;

/// Why a depth image keeps standard depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NativeReason {
    /// `REVZ_MODE=off`.
    ModeOff,
    /// The device cannot make the compare op dynamic (no Vulkan 1.3, no
    /// `VK_EXT_extended_dynamic_state`), so draws could not follow a reversed attachment.
    NoDynamicCompareOp,
    /// Shaders read it (sampled, storage, input attachment).
    ReadByShaders(vk::ImageUsageFlags),
    /// It is copied from (transfer source).
    CopiedFrom,
    /// Linear tiling: the host can read it.
    LinearTiling,
}

impl fmt::Display for NativeReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NativeReason::ModeOff => f.write_str("mode is off"),
            NativeReason::NoDynamicCompareOp => f.write_str(
                "the device has neither Vulkan 1.3 nor VK_EXT_extended_dynamic_state enabled",
            ),
            NativeReason::ReadByShaders(usage) => {
                write!(f, "shaders read it ({usage:?}); see reverse_observable")
            }
            NativeReason::CopiedFrom => {
                f.write_str("it is copied from (TRANSFER_SRC); see reverse_observable")
            }
            NativeReason::LinearTiling => f.write_str("linear tiling (host-readable)"),
        }
    }
}

/// The decision for one depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageDepth {
    Reversed,
    Native(NativeReason),
}

/// What the policy needs to know about a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DevicePolicy {
    pub mode: Mode,
    pub observable: Observable,
    /// Whether `vkCmdSetDepthCompareOp` (core 1.3 or the EXT) can be used.
    pub dynamic_compare_op: bool,
}

impl DevicePolicy {
    pub fn new(settings: &Settings, dynamic_compare_op: bool) -> DevicePolicy {
        DevicePolicy {
            mode: settings.mode,
            observable: settings.reverse_observable,
            dynamic_compare_op,
        }
    }

    /// Whether the layer acts on this device's depth at all.
    pub fn is_active(&self) -> bool {
        self.mode != Mode::Off && self.dynamic_compare_op
    }

    /// Decides a depth image; `None` for images without a depth aspect (never touched).
    pub fn classify_image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        tiling: vk::ImageTiling,
    ) -> Option<ImageDepth> {
        if !has_depth(format) {
            return None;
        }
        let native = |reason| Some(ImageDepth::Native(reason));
        if self.mode == Mode::Off {
            return native(NativeReason::ModeOff);
        }
        if !self.dynamic_compare_op {
            return native(NativeReason::NoDynamicCompareOp);
        }
        let shader_reads = usage
            & (vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::INPUT_ATTACHMENT);
        let observable = self.observable;
        if !shader_reads.is_empty() && observable != Observable::All {
            return native(NativeReason::ReadByShaders(shader_reads));
        }
        if usage.contains(vk::ImageUsageFlags::TRANSFER_SRC) && observable == Observable::None {
            return native(NativeReason::CopiedFrom);
        }
        if tiling == vk::ImageTiling::LINEAR && observable == Observable::None {
            return native(NativeReason::LinearTiling);
        }
        Some(ImageDepth::Reversed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy(mode: Mode, observable: Observable) -> DevicePolicy {
        DevicePolicy {
            mode,
            observable,
            dynamic_compare_op: true,
        }
    }

    const ATTACHMENT: vk::ImageUsageFlags = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
    const OPTIMAL: vk::ImageTiling = vk::ImageTiling::OPTIMAL;
    const D32: vk::Format = vk::Format::D32_SFLOAT;

    #[test]
    fn plain_depth_attachments_are_reversed_and_color_is_never_touched() {
        let p = policy(Mode::Flip, Observable::None);
        assert_eq!(
            p.classify_image(D32, ATTACHMENT, OPTIMAL),
            Some(ImageDepth::Reversed)
        );
        let color = vk::Format::R8G8B8A8_UNORM;
        assert_eq!(p.classify_image(color, ATTACHMENT, OPTIMAL), None);
        assert_eq!(
            p.classify_image(vk::Format::S8_UINT, ATTACHMENT, OPTIMAL),
            None
        );
    }

    #[test]
    fn observable_images_follow_the_setting() {
        let sampled = ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
        let copied = ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let none = policy(Mode::Flip, Observable::None);
        let copies = policy(Mode::Flip, Observable::Copies);
        let all = policy(Mode::Flip, Observable::All);
        let shader_native = Some(ImageDepth::Native(NativeReason::ReadByShaders(
            vk::ImageUsageFlags::SAMPLED,
        )));
        assert_eq!(none.classify_image(D32, sampled, OPTIMAL), shader_native);
        assert_eq!(
            none.classify_image(D32, copied, OPTIMAL),
            Some(ImageDepth::Native(NativeReason::CopiedFrom))
        );
        assert_eq!(copies.classify_image(D32, sampled, OPTIMAL), shader_native);
        assert_eq!(
            copies.classify_image(D32, copied, OPTIMAL),
            Some(ImageDepth::Reversed)
        );
        assert_eq!(
            all.classify_image(D32, sampled | copied, OPTIMAL),
            Some(ImageDepth::Reversed)
        );
    }

    #[test]
    fn nothing_is_reversed_when_off_or_without_dynamic_compare_op() {
        let off = policy(Mode::Off, Observable::All);
        assert_eq!(
            off.classify_image(D32, ATTACHMENT, OPTIMAL),
            Some(ImageDepth::Native(NativeReason::ModeOff))
        );
        assert!(!off.is_active());
        let no_eds = DevicePolicy {
            dynamic_compare_op: false,
            ..policy(Mode::Flip, Observable::None)
        };
        assert_eq!(
            no_eds.classify_image(D32, ATTACHMENT, OPTIMAL),
            Some(ImageDepth::Native(NativeReason::NoDynamicCompareOp))
        );
    }
}
