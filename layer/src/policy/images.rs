//! Depth images, decided once at `vkCreateImage` for their whole life: whether one is reversed
//! or native (`DevicePolicy::classify_image`, and [`NativeReason`] why it stays native;
//! [`ImageDepth::target`] the target that makes it), and whether it is created in a float
//! format (`DevicePolicy::promoted_format`, from [`ImageFacts`] (an imageless framebuffer's
//! attachments': [`ImageFacts::imageless_attachment`]), and [`KeptFormat`] why it
//! keeps its own; `DevicePolicy::may_promote` which images are considered at all), whether an
//! image may be on one end of a resolve ([`may_be_resolved`]), and the format a view of a
//! promoted image (or its format list) names ([`promoted_view_format`]).

use std::fmt;

use ash::vk;

use super::DevicePolicy;
use crate::command_state::Target;
use crate::config::{Mode, Observable};
use crate::conv::has_depth;

/// `VK_EXT_host_image_copy`'s `VK_IMAGE_USAGE_HOST_TRANSFER_BIT_EXT`.
const HOST_TRANSFER: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(0x0040_0000);

/// Why a depth image keeps standard depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NativeReason {
    /// `REVZ_MODE=off`.
    ModeOff,
    /// Shaders read it (sampled, storage, input attachment).
    ReadByShaders(vk::ImageUsageFlags),
    /// It is copied from (transfer source).
    CopiedFrom,
    /// It cannot be a depth attachment (no `DEPTH_STENCIL_ATTACHMENT` usage): no draw ever
    /// stores depth in it. Its values are the application's (uploads, clears, copies, which
    /// revz converts where the other end is reversed), and reversing them could only round
    /// them (1 - d in float32 loses d's low bits below 0.5).
    NotAnAttachment,
    /// Linear tiling: the host can read it.
    LinearTiling,
    /// Host image copies (`VK_EXT_host_image_copy`) read or write it: revz does not convert
    /// those.
    HostCopied,
    /// A render pass resolves it into a depth image that is not reversed: the resolved values
    /// must be standard ones. Decided when the resolve is first seen (framebuffer creation, or
    /// the begin of an imageless or dynamic rendering instance), or when the destination is
    /// made native later.
    ResolvedIntoNative(vk::Image),
    /// The application enabled `VK_EXT_descriptor_heap` and shaders read the image or copies
    /// reach it (`crate::policy::DevicePolicy::descriptor_heap`).
    DescriptorHeap,
    /// A render pass resolves a native depth image into it: it receives standard values. As
    /// above, also when the source is made native after the resolve was seen.
    ResolvedFromNative(vk::Image),
    /// A MIN or MAX depth resolve of it could not be swapped (a render pass of several
    /// subpasses, or a device that does not support the swapped mode or does not allow it
    /// beside the stencil resolve mode): it would resolve the other extreme.
    UnswappableResolve,
}

impl fmt::Display for NativeReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NativeReason::ModeOff => f.write_str("mode is off"),
            NativeReason::ReadByShaders(usage) => {
                write!(f, "shaders read it ({usage:?}); see reverse_observable")
            }
            NativeReason::CopiedFrom => {
                f.write_str("it is copied from (TRANSFER_SRC); see reverse_observable")
            }
            NativeReason::NotAnAttachment => f.write_str(
                "it is no depth attachment (no DEPTH_STENCIL_ATTACHMENT usage): its values are \
                 the application's",
            ),
            NativeReason::LinearTiling => f.write_str("linear tiling (host-readable)"),
            NativeReason::HostCopied => {
                f.write_str("host image copies read it (HOST_TRANSFER), which are not converted")
            }
            NativeReason::DescriptorHeap => f.write_str(
                "the application enabled VK_EXT_descriptor_heap, whose descriptors revz does not \
                 follow, and shaders or copies reach it",
            ),
            NativeReason::ResolvedIntoNative(destination) => {
                write!(f, "it is resolved into native depth image {destination:?}")
            }
            NativeReason::ResolvedFromNative(source) => {
                write!(f, "native depth image {source:?} is resolved into it")
            }
            NativeReason::UnswappableResolve => f.write_str(
                "its MIN/MAX depth resolve cannot be swapped (several subpasses, or the device \
                 lacks the swapped mode or does not allow it beside the stencil resolve mode)",
            ),
        }
    }
}

/// The decision for one depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageDepth {
    Reversed,
    Native(NativeReason),
}

impl ImageDepth {
    /// The decision an image of this one has once made native for `reason` (a resolve rule,
    /// `crate::policy::DepthResolve`): only a reversed image changes, for the rest of its life;
    /// `None`: a native image stays as it is, with its first reason.
    #[must_use]
    pub fn demoted(self, reason: NativeReason) -> Option<ImageDepth> {
        match self {
            ImageDepth::Reversed => Some(ImageDepth::Native(reason)),
            ImageDepth::Native(_) => None,
        }
    }

    /// The depth target draws into (or copies of) an image of this decision are, before the
    /// application's convention (`crate::policy::Observed::effective`).
    pub fn target(self) -> Target {
        match self {
            ImageDepth::Reversed => Target::Reversed,
            ImageDepth::Native(_) => Target::Native,
        }
    }
}

/// What decides whether a depth image can be promoted, besides its format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageFacts {
    pub usage: vk::ImageUsageFlags,
    pub tiling: vk::ImageTiling,
    pub flags: vk::ImageCreateFlags,
    /// The image's memory is shared with another API or process
    /// (`VkExternalMemoryImageCreateInfo`, DRM format modifiers): its layout is agreed on.
    pub external: bool,
    /// A live image that may be this one's resolve partner keeps its format: one of the same
    /// format and size on the other side of a resolve (multisampled for a single-sampled
    /// image, and the other way round), a depth attachment (see
    /// `DeviceObjects::resolve_partner_kept`).
    pub partner_kept: bool,
    /// Its create info lists view formats (`VkImageFormatListCreateInfo`) after a structure
    /// revz cannot copy (`crate::chain::splice_blocked`): the list, which must name the float
    /// format, cannot be replaced.
    pub format_list_fixed: bool,
}

impl ImageFacts {
    /// What an imageless framebuffer's attachment info says of the image it will be (its
    /// `usage` and `flags`): optimal tiling, as for any attachment; nothing external, and no
    /// partner to keep its format (the info tells neither).
    pub fn imageless_attachment(
        usage: vk::ImageUsageFlags,
        flags: vk::ImageCreateFlags,
    ) -> ImageFacts {
        ImageFacts {
            usage,
            tiling: vk::ImageTiling::OPTIMAL,
            flags,
            external: false,
            partner_kept: false,
            format_list_fixed: false,
        }
    }
}

/// Why a depth image in a UNORM format keeps it (logged once per reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeptFormat {
    /// It cannot be a depth attachment (no `DEPTH_STENCIL_ATTACHMENT` usage): no draw stores
    /// depth in it, so float storage would gain nothing and cost a conversion at every copy.
    NotAnAttachment,
    /// Host image copies (`VK_EXT_host_image_copy`, `HOST_TRANSFER` usage) read or write its
    /// bytes without a command revz could convert: the host would get float bits where it
    /// expects UNORM values. (Copies recorded in command buffers are converted,
    /// `crate::depth_copy`.)
    HostCopied,
    /// It is copied from and `reverse_observable = none` leaves such images exactly as the
    /// application made them (native, in their own format).
    CopiedUnobserved,
    /// Linear tiling, DRM modifiers or external memory: its memory layout is seen from
    /// outside.
    LaidOutOutside,
    /// Sparse or aliased memory: the application places its memory by the format's sizes.
    PlacedMemory,
    /// The device does not support the float format with the image's usage, flags, tiling
    /// and samples.
    Unsupported,
    /// An image it may be resolved with keeps its format (a resolve needs one format at both
    /// ends).
    ResolvePartner,
    /// Its format list cannot be replaced by one naming the float format
    /// ([`ImageFacts::format_list_fixed`]).
    FormatListFixed,
    /// The application enabled `VK_EXT_depth_range_unrestricted`: depth outside [0, 1], which
    /// its UNORM format clamps, would stay outside in a float one.
    UnrestrictedDepthRange,
    /// The application enabled `VK_EXT_descriptor_heap` and shaders or copies reach the image:
    /// its bytes would need converting, which revz does not do on such a device
    /// (`crate::policy::DevicePolicy::descriptor_heap`).
    DescriptorHeap,
}

impl fmt::Display for KeptFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            KeptFormat::NotAnAttachment => {
                "it is no depth attachment (no DEPTH_STENCIL_ATTACHMENT usage): float storage \
                 would gain nothing"
            }
            KeptFormat::HostCopied => {
                "host image copies read or write it (HOST_TRANSFER), which revz cannot convert"
            }
            KeptFormat::CopiedUnobserved => {
                "it is copied from (TRANSFER_SRC) and reverse_observable = none leaves such \
                 images as the application made them"
            }
            KeptFormat::LaidOutOutside => {
                "its memory layout is seen outside (linear tiling, DRM modifier or external \
                 memory)"
            }
            KeptFormat::PlacedMemory => "its memory is sparse or aliased",
            KeptFormat::Unsupported => {
                "the device does not support the float format with its usage, flags and samples"
            }
            KeptFormat::ResolvePartner => {
                "an image of its format and size it may be resolved with (the other sample \
                 count) keeps its format, and a resolve needs one format at both ends"
            }
            KeptFormat::FormatListFixed => {
                "its format list follows a structure revz cannot copy, so it cannot name the \
                 float format"
            }
            KeptFormat::UnrestrictedDepthRange => {
                "the application enabled VK_EXT_depth_range_unrestricted: a float format would \
                 keep depth outside [0, 1] that its UNORM format clamps"
            }
            KeptFormat::DescriptorHeap => {
                "the application enabled VK_EXT_descriptor_heap, whose descriptors revz does not \
                 follow, and shaders or copies reach it: revz converts nothing on such a device"
            }
        })
    }
}

impl DevicePolicy {
    /// Whether an image of `format` is considered for promotion at all: promotion is on and
    /// the format has a float counterpart. Asked before anything else of its creation (no
    /// lock, no chain walk) so that every other image goes down as it is; those considered
    /// are decided by [`DevicePolicy::promoted_format`].
    pub fn may_promote(&self, format: vk::Format) -> bool {
        self.promote && promotable_format(format)
    }

    /// The float format a depth image is created in instead of its own, or why it keeps its
    /// own (`Ok(None)`: not a promotable format, or promotion is off). Every image that can be
    /// is promoted, reversed or native: a render pass resolves only between images of one
    /// format, and a multisampled image cannot know at creation whether the image it will be
    /// resolved into is reversed, so the decision may not depend on reversal. For the same
    /// reason an image whose likely resolve partner, created before it, keeps its format keeps
    /// its own (a multisampled attachment resolved into a read-back image: the order images
    /// are usually created in; the other order is logged at framebuffer creation). `supported`
    /// asks the device about the float format (`vkGetPhysicalDeviceImageFormatProperties`
    /// with the image's parameters).
    pub fn promoted_format(
        &self,
        format: vk::Format,
        facts: ImageFacts,
        supported: impl FnOnce(vk::Format) -> bool,
    ) -> Result<Option<vk::Format>, KeptFormat> {
        let Some(float) = crate::conv::float_depth_format(format).filter(|_| self.promote) else {
            return Ok(None);
        };
        if !facts
            .usage
            .contains(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
        {
            return Err(KeptFormat::NotAnAttachment);
        }
        if self.depth_range_unrestricted {
            return Err(KeptFormat::UnrestrictedDepthRange);
        }
        let reached = vk::ImageUsageFlags::TRANSFER_SRC
            | vk::ImageUsageFlags::TRANSFER_DST
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::STORAGE
            | vk::ImageUsageFlags::INPUT_ATTACHMENT;
        if self.descriptor_heap && facts.usage.intersects(reached) {
            return Err(KeptFormat::DescriptorHeap);
        }
        // Copies and blits in command buffers are converted between the float storage and
        // the application's format (`crate::depth_copy`); host image copies are not.
        if facts.usage.intersects(HOST_TRANSFER) {
            return Err(KeptFormat::HostCopied);
        }
        if facts.usage.contains(vk::ImageUsageFlags::TRANSFER_SRC)
            && self.observable == Observable::None
        {
            return Err(KeptFormat::CopiedUnobserved);
        }
        if facts.tiling != vk::ImageTiling::OPTIMAL || facts.external {
            return Err(KeptFormat::LaidOutOutside);
        }
        if facts
            .flags
            .intersects(vk::ImageCreateFlags::SPARSE_BINDING | vk::ImageCreateFlags::ALIAS)
        {
            return Err(KeptFormat::PlacedMemory);
        }
        if facts.partner_kept {
            return Err(KeptFormat::ResolvePartner);
        }
        if !supported(float) {
            return Err(KeptFormat::Unsupported);
        }
        if facts.format_list_fixed {
            return Err(KeptFormat::FormatListFixed);
        }
        Ok(Some(float))
    }

    /// Whether shaders read an image of this usage through a *read twin* (issue #39): a native
    /// image revz keeps beside the reversed one, refreshed with standard values whenever the
    /// application makes the image readable, whose views replace the image's in descriptors.
    /// Under the default `reverse_observable = copies`, for images shaders sample: optimal
    /// tiling, one sample (the refresh converts through a buffer) or a sample count whose
    /// twin the device can write per sample ([`DevicePolicy::multisampled_twin_samples`]),
    /// and no storage usage (a shader writing the image would write the twin). Input
    /// attachment reads of such an image are converted in the reading shader instead
    /// ([`Self::converts_input_reads`]).
    pub fn reads_through_twin(
        &self,
        usage: vk::ImageUsageFlags,
        samples: vk::SampleCountFlags,
        tiling: vk::ImageTiling,
    ) -> bool {
        self.mode != Mode::Off
            && self.observable == Observable::Copies
            && usage.contains(vk::ImageUsageFlags::SAMPLED)
            && !usage.intersects(vk::ImageUsageFlags::STORAGE | HOST_TRANSFER)
            && (samples == vk::SampleCountFlags::TYPE_1
                || self.multisampled_twin_samples.contains(samples))
            && tiling == vk::ImageTiling::OPTIMAL
    }

    /// Whether reads of reversed depth through input attachments (`subpassLoad`, inside the
    /// render pass that may write it, where no twin can be refreshed) are converted in the
    /// reading fragment shader (`crate::shader::input_depth`): under `reverse_observable =
    /// copies`, in every mode. The shader undoes `1 - D` without knowing the camera; in
    /// infinite mode such images store complementary depth for that
    /// ([`Self::stores_complementary`]).
    pub fn converts_input_reads(&self) -> bool {
        self.observable == Observable::Copies && self.mode != Mode::Off
    }

    /// Infinite mode: whether an image of this usage stores complementary depth (`1 - D`, with
    /// the far plane) instead of `n / w`: images read as input attachments, whose reading
    /// shader can only undo `1 - D` (`n / w = 1 - (1 - n/f) D` needs the camera's n/f, known
    /// only at draw time). Their draws, clears, copies and refreshes map as complementary
    /// mode does.
    pub fn stores_complementary(&self, usage: vk::ImageUsageFlags) -> bool {
        self.mode == Mode::Infinite
            && self.converts_input_reads()
            && usage.contains(vk::ImageUsageFlags::INPUT_ATTACHMENT)
    }

    /// Infinite mode: whether a secondary command buffer continuing a subpass without naming
    /// its framebuffer draws into complementary depth, where all revz knows of the image is
    /// whether its render pass references that subpass's depth attachment as an input
    /// attachment (`depth_read_as_input`, in any subpass, of any aspect). Where it does, the
    /// image has `INPUT_ATTACHMENT` usage (the spec requires it of an input attachment's
    /// image), so it stores complementary depth wherever such images do; where it does not,
    /// the image may still have that usage (read as an input in another pass): `None`, unknown
    /// (the secondary then assumes `n / w`, logged by the caller).
    pub fn secondary_stores_complementary(&self, depth_read_as_input: bool) -> Option<bool> {
        if !self.stores_complementary(vk::ImageUsageFlags::INPUT_ATTACHMENT) {
            return Some(false);
        }
        depth_read_as_input.then_some(true)
    }

    /// Whether shaders can read an image of this usage and remain correct once it is reversed:
    /// sampled through a twin ([`Self::reads_through_twin`]), read as an input attachment
    /// converted in the shader ([`Self::converts_input_reads`]), and never as a storage image.
    fn shader_reads_follow(
        &self,
        usage: vk::ImageUsageFlags,
        samples: vk::SampleCountFlags,
        tiling: vk::ImageTiling,
    ) -> bool {
        !usage.contains(vk::ImageUsageFlags::STORAGE)
            && (!usage.contains(vk::ImageUsageFlags::SAMPLED)
                || self.reads_through_twin(usage, samples, tiling))
            && (!usage.contains(vk::ImageUsageFlags::INPUT_ATTACHMENT)
                || self.converts_input_reads())
    }

    /// Decides a depth image; `None` for images without a depth aspect (never touched). An
    /// image shaders read is reversed where every way they read it follows
    /// ([`Self::shader_reads_follow`]), native otherwise (unless `reverse_observable = all`).
    pub fn classify_image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        tiling: vk::ImageTiling,
        samples: vk::SampleCountFlags,
    ) -> Option<ImageDepth> {
        if !has_depth(format) {
            return None;
        }
        let native = |reason| Some(ImageDepth::Native(reason));
        if self.mode == Mode::Off {
            return native(NativeReason::ModeOff);
        }
        let shader_reads = usage
            & (vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::INPUT_ATTACHMENT);
        let observable = self.observable;
        if !usage.contains(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
            && observable != Observable::All
        {
            return native(NativeReason::NotAnAttachment);
        }
        let transfers = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
        if self.descriptor_heap
            && (usage.intersects(transfers)
                || (!shader_reads.is_empty() && observable != Observable::All))
        {
            return native(NativeReason::DescriptorHeap);
        }
        if !shader_reads.is_empty()
            && observable != Observable::All
            && !self.shader_reads_follow(usage, samples, tiling)
        {
            return native(NativeReason::ReadByShaders(shader_reads));
        }
        if usage.contains(vk::ImageUsageFlags::TRANSFER_SRC) && observable == Observable::None {
            return native(NativeReason::CopiedFrom);
        }
        // The host reads these without a copy revz sees: linear images through mapped
        // memory, host image copies (`VK_EXT_host_image_copy`, not converted).
        if tiling == vk::ImageTiling::LINEAR && observable != Observable::All {
            return native(NativeReason::LinearTiling);
        }
        if usage.contains(HOST_TRANSFER) && observable != Observable::All {
            return native(NativeReason::HostCopied);
        }
        Some(ImageDepth::Reversed)
    }
}

/// Whether an image of `usage` may be on either end of a render pass's depth resolve (a depth
/// attachment): only such an image's resolve partner can keep it from being promoted
/// ([`ImageFacts::partner_kept`]).
pub fn may_be_resolved(usage: vk::ImageUsageFlags) -> bool {
    usage.contains(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
}

/// What [`kept_resolve_partner`] compares of two depth images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolvePartner {
    pub format: vk::Format,
    pub extent: vk::Extent3D,
    pub samples: vk::SampleCountFlags,
}

/// Whether a live depth image (`other`, promoted or not: `other_promoted`) may be the resolve
/// partner of an image being created (`image`) and keeps its format, so that the new image
/// must keep its own ([`ImageFacts::partner_kept`]): the same format and size, on the other
/// side of a resolve (multisampled where the new one is single-sampled, and the other way
/// round), and not promoted.
#[must_use]
pub fn kept_resolve_partner(
    image: ResolvePartner,
    other: ResolvePartner,
    other_promoted: bool,
) -> bool {
    let multisampled = |samples| samples != vk::SampleCountFlags::TYPE_1;
    other.format == image.format
        && other.extent == image.extent
        && multisampled(other.samples) != multisampled(image.samples)
        && !other_promoted
}

/// The format a view is made in of an image created in `image_format` and promoted to
/// `promoted` (`None`: not promoted), where the application asks for `view_format`: a view in
/// the image's own UNORM format is made in the float one (the only format a depth image's
/// views can have); `None`: the view is made as asked. A promoted image's format list
/// (`VkImageFormatListCreateInfo`) names its formats by the same rule.
pub fn promoted_view_format(
    view_format: vk::Format,
    image_format: vk::Format,
    promoted: Option<vk::Format>,
) -> Option<vk::Format> {
    promoted.filter(|_| view_format == image_format)
}

/// Whether revz promotes depth attachments of `format` (where promotion is on): the UNORM
/// depth formats, which have a float counterpart (`crate::conv::float_depth_format`). The one
/// rule behind every "promotable" below and in the render pass, secondary and pipeline
/// decisions.
pub fn promotable_format(format: vk::Format) -> bool {
    crate::conv::float_depth_format(format).is_some()
}

/// The first of a rendering's depth and stencil formats that revz promotes (has a float
/// format for): what a secondary continuing dynamic rendering may draw promoted in, and
/// whether a pipeline's rendering formats are promotable; `None`: neither is.
pub fn first_promoted_format(depth: vk::Format, stencil: vk::Format) -> Option<vk::Format> {
    [depth, stencil]
        .into_iter()
        .find(|&format| promotable_format(format))
}

/// The depth or stencil format of promoted dynamic rendering in place of the application's
/// (a secondary's inheritance, a promoted pipeline variant's rendering formats): its float
/// format, else the format itself (`UNDEFINED`, or one revz does not promote).
pub fn promoted_attachment_format(format: vk::Format) -> vk::Format {
    crate::conv::float_depth_format(format).unwrap_or(format)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{CompareOp, Settings};
    use crate::policy::tests::policy;

    const ONE: vk::SampleCountFlags = vk::SampleCountFlags::TYPE_1;

    #[test]
    fn a_reversed_image_is_a_reversed_target_and_a_native_one_native() {
        assert_eq!(ImageDepth::Reversed.target(), Target::Reversed);
        assert_eq!(
            ImageDepth::Native(NativeReason::CopiedFrom).target(),
            Target::Native
        );
    }

    #[test]
    fn only_promotable_formats_are_considered_where_promotion_is_on() {
        let on = policy(Mode::Complementary, Observable::None);
        assert!(on.promote);
        let off = DevicePolicy {
            promote: false,
            ..on
        };
        assert!(on.may_promote(vk::Format::D16_UNORM));
        assert!(on.may_promote(vk::Format::D24_UNORM_S8_UINT));
        assert!(!on.may_promote(vk::Format::D32_SFLOAT));
        assert!(!on.may_promote(vk::Format::R8G8B8A8_UNORM));
        assert!(!off.may_promote(vk::Format::D16_UNORM));
    }

    #[test]
    fn a_view_or_format_list_naming_the_unorm_format_names_the_float_one() {
        use vk::Format as F;
        let float = Some(F::D32_SFLOAT);
        assert_eq!(
            promoted_view_format(F::D16_UNORM, F::D16_UNORM, float),
            float
        );
        assert_eq!(
            promoted_view_format(F::R16_UNORM, F::D16_UNORM, float),
            None
        );
        assert_eq!(promoted_view_format(F::D16_UNORM, F::D16_UNORM, None), None);
    }

    #[test]
    fn an_imageless_attachment_is_an_optimal_image_with_nothing_outside() {
        let usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let flags = vk::ImageCreateFlags::MUTABLE_FORMAT;
        assert_eq!(
            ImageFacts::imageless_attachment(usage, flags),
            ImageFacts {
                usage,
                tiling: vk::ImageTiling::OPTIMAL,
                flags,
                external: false,
                partner_kept: false,
                format_list_fixed: false,
            }
        );
    }

    const ATTACHMENT_IMAGE: ImageFacts = ImageFacts {
        usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        tiling: vk::ImageTiling::OPTIMAL,
        flags: vk::ImageCreateFlags::empty(),
        external: false,
        partner_kept: false,
        format_list_fixed: false,
    };

    #[test]
    fn unorm_depth_images_are_promoted_unless_their_bytes_are_seen() {
        let p = policy(Mode::Infinite, Observable::None);
        let yes = |_| true;
        let d24 = vk::Format::D24_UNORM_S8_UINT;
        assert_eq!(
            p.promoted_format(d24, ATTACHMENT_IMAGE, yes),
            Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
        );
        assert_eq!(
            p.promoted_format(vk::Format::D16_UNORM, ATTACHMENT_IMAGE, yes),
            Ok(Some(vk::Format::D32_SFLOAT))
        );
        // An image that is no depth attachment gains nothing from float storage: uploaded
        // textures, transfer-only images.
        for usage in [
            vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST,
            vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
        ] {
            let facts = ImageFacts {
                usage,
                ..ATTACHMENT_IMAGE
            };
            assert_eq!(
                p.promoted_format(d24, facts, yes),
                Err(KeptFormat::NotAnAttachment)
            );
        }
        // Sampled images too (native ones): a resolve needs one format at both ends.
        let sampled = ImageFacts {
            usage: ATTACHMENT_IMAGE.usage | vk::ImageUsageFlags::SAMPLED,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, sampled, yes),
            Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
        );
        // Images copied from and to as well (copies convert between the formats), but not
        // those host image copies read: revz never sees those.
        let copies = policy(Mode::Infinite, Observable::Copies);
        for transfer in [
            vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageUsageFlags::TRANSFER_DST,
            vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST,
        ] {
            let copied = ImageFacts {
                usage: ATTACHMENT_IMAGE.usage | transfer,
                ..ATTACHMENT_IMAGE
            };
            assert_eq!(
                copies.promoted_format(d24, copied, yes),
                Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
            );
        }
        // Where the application enabled VK_EXT_depth_range_unrestricted, no image is: a float
        // format would keep depth outside [0, 1] that the UNORM one clamps.
        let unrestricted = copies.with_depth_range_unrestricted(true);
        assert_eq!(
            unrestricted.promoted_format(d24, ATTACHMENT_IMAGE, yes),
            Err(KeptFormat::UnrestrictedDepthRange)
        );
        assert_eq!(
            copies
                .with_depth_range_unrestricted(false)
                .promoted_format(d24, ATTACHMENT_IMAGE, yes),
            Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
        );
        // ... unless reverse_observable = none leaves images copied from as they are.
        let unobserved = policy(Mode::Infinite, Observable::None);
        let copied_from = ImageFacts {
            usage: ATTACHMENT_IMAGE.usage | vk::ImageUsageFlags::TRANSFER_SRC,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            unobserved.promoted_format(d24, copied_from, yes),
            Err(KeptFormat::CopiedUnobserved)
        );
        let host_copied = ImageFacts {
            usage: ATTACHMENT_IMAGE.usage | HOST_TRANSFER,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, host_copied, yes),
            Err(KeptFormat::HostCopied)
        );
        let linear = ImageFacts {
            tiling: vk::ImageTiling::LINEAR,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, linear, yes),
            Err(KeptFormat::LaidOutOutside)
        );
        let external = ImageFacts {
            external: true,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, external, yes),
            Err(KeptFormat::LaidOutOutside)
        );
        let aliased = ImageFacts {
            flags: vk::ImageCreateFlags::ALIAS,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, aliased, yes),
            Err(KeptFormat::PlacedMemory)
        );
        let partner = ImageFacts {
            partner_kept: true,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, partner, yes),
            Err(KeptFormat::ResolvePartner)
        );
        let mut asked = None;
        assert_eq!(
            p.promoted_format(d24, ATTACHMENT_IMAGE, |f| {
                asked = Some(f);
                false
            }),
            Err(KeptFormat::Unsupported)
        );
        assert_eq!(asked, Some(vk::Format::D32_SFLOAT_S8_UINT));
        let fixed_list = ImageFacts {
            format_list_fixed: true,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, fixed_list, yes),
            Err(KeptFormat::FormatListFixed)
        );
        // Float formats and color formats are not promoted, and the device is not asked.
        let never = |_| -> bool { panic!("asked") };
        assert_eq!(
            p.promoted_format(vk::Format::D32_SFLOAT, ATTACHMENT_IMAGE, never),
            Ok(None)
        );
        assert_eq!(
            p.promoted_format(vk::Format::R8_UNORM, ATTACHMENT_IMAGE, never),
            Ok(None)
        );
    }

    #[test]
    fn promotion_follows_the_setting_of_the_mode() {
        let d16 = vk::Format::D16_UNORM;
        let yes = |_| true;
        for (mode, promoted) in [
            (Mode::Complementary, true),
            (Mode::Infinite, true),
            (Mode::Flip, false),
            (Mode::Off, false),
        ] {
            let settings = Settings {
                mode,
                ..Settings::default()
            };
            let p = DevicePolicy::new(&settings, true);
            assert_eq!(
                p.promoted_format(d16, ATTACHMENT_IMAGE, yes)
                    .unwrap()
                    .is_some(),
                promoted,
                "{mode:?}"
            );
        }
        let never = Settings {
            mode: Mode::Infinite,
            promote_depth_formats: crate::config::Promote::Never,
            ..Settings::default()
        };
        let p = DevicePolicy::new(&never, true);
        assert_eq!(p.promoted_format(d16, ATTACHMENT_IMAGE, yes), Ok(None));
    }

    const ATTACHMENT: vk::ImageUsageFlags = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
    const OPTIMAL: vk::ImageTiling = vk::ImageTiling::OPTIMAL;
    const D32: vk::Format = vk::Format::D32_SFLOAT;

    #[test]
    fn plain_depth_attachments_are_reversed_and_color_is_never_touched() {
        let p = policy(Mode::Flip, Observable::None);
        assert_eq!(
            p.classify_image(D32, ATTACHMENT, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
        let color = vk::Format::R8G8B8A8_UNORM;
        assert_eq!(p.classify_image(color, ATTACHMENT, OPTIMAL, ONE), None);
        assert_eq!(
            p.classify_image(vk::Format::S8_UINT, ATTACHMENT, OPTIMAL, ONE),
            None
        );
    }

    /// An image that cannot be a depth attachment keeps the application's values (copies into
    /// and out of it convert where the other end is reversed): transfer-only images as a
    /// conformance suite's copies make them, and depth textures uploaded for sampling. Only
    /// `reverse_observable = all` reverses them still.
    #[test]
    fn images_that_are_no_depth_attachment_stay_native() {
        let transfer = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
        let texture = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        for mode in [Mode::Flip, Mode::Complementary, Mode::Infinite] {
            for observable in [Observable::Copies, Observable::None] {
                let p = policy(mode, observable);
                for usage in [transfer, texture] {
                    assert_eq!(
                        p.classify_image(D32, usage, OPTIMAL, ONE),
                        Some(ImageDepth::Native(NativeReason::NotAnAttachment)),
                        "{mode:?} {observable:?} {usage:?}"
                    );
                }
                assert_eq!(
                    p.classify_image(D32, transfer | ATTACHMENT, OPTIMAL, ONE),
                    Some(ImageDepth::Reversed)
                        .filter(|_| observable == Observable::Copies)
                        .or(Some(ImageDepth::Native(NativeReason::CopiedFrom))),
                    "{mode:?} {observable:?}"
                );
            }
            let all = policy(mode, Observable::All);
            assert_eq!(
                all.classify_image(D32, transfer, OPTIMAL, ONE),
                Some(ImageDepth::Reversed)
            );
        }
        let off = policy(Mode::Off, Observable::Copies);
        assert_eq!(
            off.classify_image(D32, transfer, OPTIMAL, ONE),
            Some(ImageDepth::Native(NativeReason::ModeOff))
        );
    }

    #[test]
    fn unrestricted_depth_reverses_every_image_and_makes_infinite_mode_complementary() {
        let d24 = vk::Format::D24_UNORM_S8_UINT;
        for mode in [Mode::Flip, Mode::Complementary, Mode::Infinite] {
            let p = policy(mode, Observable::Copies).with_depth_range_unrestricted(true);
            for format in [D32, d24] {
                assert_eq!(
                    p.classify_image(format, ATTACHMENT, OPTIMAL, ONE),
                    Some(ImageDepth::Reversed),
                    "{mode:?} {format:?}"
                );
            }
            // Infinite mode's n / w does not commute with depth beyond 1 (a clamp at 1, a
            // clear of 1 that fragments beyond the far plane fail): 1 - D does.
            let expected = match mode {
                Mode::Infinite => Mode::Complementary,
                mode => mode,
            };
            assert_eq!(p.mode, expected);
            let restricted = policy(mode, Observable::Copies);
            assert_eq!(restricted.mode, mode);
            assert_eq!(
                restricted.classify_image(d24, ATTACHMENT, OPTIMAL, ONE),
                Some(ImageDepth::Reversed)
            );
        }
    }

    #[test]
    fn with_descriptor_heaps_only_images_no_shader_or_copy_reaches_are_reversed_or_promoted() {
        let d24 = vk::Format::D24_UNORM_S8_UINT;
        let reached = [
            vk::ImageUsageFlags::SAMPLED,
            vk::ImageUsageFlags::INPUT_ATTACHMENT,
            vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageUsageFlags::TRANSFER_DST,
        ];
        for mode in [Mode::Flip, Mode::Complementary, Mode::Infinite] {
            let p = policy(mode, Observable::Copies).with_descriptor_heap(true);
            assert_eq!(
                p.classify_image(D32, ATTACHMENT, OPTIMAL, ONE),
                Some(ImageDepth::Reversed),
                "{mode:?}: a pure attachment"
            );
            for usage in reached {
                assert_eq!(
                    p.classify_image(D32, ATTACHMENT | usage, OPTIMAL, ONE),
                    Some(ImageDepth::Native(NativeReason::DescriptorHeap)),
                    "{mode:?} {usage:?}"
                );
                if p.promote {
                    let facts = ImageFacts {
                        usage: ATTACHMENT | usage,
                        ..ATTACHMENT_IMAGE
                    };
                    assert_eq!(
                        p.promoted_format(d24, facts, |_| true),
                        Err(KeptFormat::DescriptorHeap),
                        "{mode:?} {usage:?}"
                    );
                }
            }
            if p.promote {
                assert_eq!(
                    p.promoted_format(d24, ATTACHMENT_IMAGE, |_| true),
                    Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
                );
            }
            // The same images reversed without the extension.
            let without = policy(mode, Observable::Copies);
            assert_eq!(
                without.classify_image(
                    D32,
                    ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                    OPTIMAL,
                    ONE
                ),
                Some(ImageDepth::Reversed)
            );
            // `reverse_observable = all` hands shaders the reversed values (no twin, nothing
            // converted for them); copies would still convert.
            let all = policy(mode, Observable::All).with_descriptor_heap(true);
            assert_eq!(
                all.classify_image(D32, ATTACHMENT | vk::ImageUsageFlags::SAMPLED, OPTIMAL, ONE),
                Some(ImageDepth::Reversed)
            );
            assert_eq!(
                all.classify_image(
                    D32,
                    ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                    OPTIMAL,
                    ONE
                ),
                Some(ImageDepth::Native(NativeReason::DescriptorHeap))
            );
        }
    }

    #[test]
    fn multisampled_sampled_images_get_a_twin_where_the_device_can_write_one_per_sample() {
        let sampled = ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
        let four = vk::SampleCountFlags::TYPE_4;
        let eight = vk::SampleCountFlags::TYPE_8;
        let p = policy(Mode::Complementary, Observable::Copies)
            .with_multisampled_twins(four | vk::SampleCountFlags::TYPE_1);
        assert_eq!(
            p.multisampled_twin_samples, four,
            "one sample is not a multisampled twin"
        );
        assert!(p.reads_through_twin(sampled, four, OPTIMAL));
        assert_eq!(
            p.classify_image(D32, sampled, OPTIMAL, four),
            Some(ImageDepth::Reversed)
        );
        // A count the device cannot write per sample: native, as on a device without the
        // feature.
        assert!(!p.reads_through_twin(sampled, eight, OPTIMAL));
        assert!(matches!(
            p.classify_image(D32, sampled, OPTIMAL, eight),
            Some(ImageDepth::Native(NativeReason::ReadByShaders(_)))
        ));
        // Storage usage still keeps it native; `none` and `all` make no twin.
        assert!(!p.reads_through_twin(sampled | vk::ImageUsageFlags::STORAGE, four, OPTIMAL));
        let none = policy(Mode::Complementary, Observable::None).with_multisampled_twins(four);
        assert!(!none.reads_through_twin(sampled, four, OPTIMAL));
    }

    #[test]
    fn input_attachments_are_reversed_where_the_reading_shader_converts() {
        let input = ATTACHMENT | vk::ImageUsageFlags::INPUT_ATTACHMENT;
        let both = input | vk::ImageUsageFlags::SAMPLED;
        let four = vk::SampleCountFlags::TYPE_4;
        for mode in [Mode::Flip, Mode::Complementary] {
            let p = policy(mode, Observable::Copies);
            assert!(p.converts_input_reads());
            // Multisampled input attachments too: nothing is refreshed for them.
            for samples in [ONE, four] {
                assert_eq!(
                    p.classify_image(D32, input, OPTIMAL, samples),
                    Some(ImageDepth::Reversed),
                    "{mode:?}"
                );
            }
            // Sampled as well: the twin serves the samples, the shader the input reads.
            assert_eq!(
                p.classify_image(D32, both, OPTIMAL, ONE),
                Some(ImageDepth::Reversed)
            );
            assert!(p.reads_through_twin(both, ONE, OPTIMAL));
            // Multisampled and sampled: no twin can serve the samples.
            assert!(matches!(
                p.classify_image(D32, both, OPTIMAL, four),
                Some(ImageDepth::Native(NativeReason::ReadByShaders(_)))
            ));
            // Storage images are written by shaders: native whatever else.
            assert!(matches!(
                p.classify_image(D32, input | vk::ImageUsageFlags::STORAGE, OPTIMAL, ONE),
                Some(ImageDepth::Native(NativeReason::ReadByShaders(_)))
            ));
        }
        // Infinite mode stores n / w, which a shader cannot undo without the camera's n/f:
        // images read as input attachments store complementary depth there.
        let infinite = policy(Mode::Infinite, Observable::Copies);
        assert!(infinite.converts_input_reads());
        assert_eq!(
            infinite.classify_image(D32, input, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
        assert!(infinite.stores_complementary(input));
        assert!(!infinite.stores_complementary(ATTACHMENT | vk::ImageUsageFlags::SAMPLED));
        assert!(!policy(Mode::Complementary, Observable::Copies).stores_complementary(input));
        // A secondary without its framebuffer: complementary where its pass reads the depth
        // attachment as an input (its image has the usage), unknown elsewhere, and never
        // outside infinite mode.
        assert_eq!(infinite.secondary_stores_complementary(true), Some(true));
        assert_eq!(infinite.secondary_stores_complementary(false), None);
        for other in [
            policy(Mode::Complementary, Observable::Copies),
            policy(Mode::Infinite, Observable::None),
            policy(Mode::Infinite, Observable::All),
        ] {
            assert_eq!(other.secondary_stores_complementary(true), Some(false));
            assert_eq!(other.secondary_stores_complementary(false), Some(false));
        }
        // `none` keeps them native, `all` reverses them raw.
        assert!(!policy(Mode::Flip, Observable::None).converts_input_reads());
        assert!(!policy(Mode::Flip, Observable::All).converts_input_reads());
        assert_eq!(
            policy(Mode::Infinite, Observable::All).classify_image(D32, input, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
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
        assert_eq!(
            none.classify_image(D32, sampled, OPTIMAL, ONE),
            shader_native
        );
        assert_eq!(
            none.classify_image(D32, copied, OPTIMAL, ONE),
            Some(ImageDepth::Native(NativeReason::CopiedFrom))
        );
        // Sampled images are reversed, read through their twin; what a twin cannot serve stays
        // native: storage (shaders write it), several samples.
        assert_eq!(
            copies.classify_image(D32, sampled, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
        assert!(copies.reads_through_twin(sampled, ONE, OPTIMAL));
        assert!(!none.reads_through_twin(sampled, ONE, OPTIMAL));
        assert!(!all.reads_through_twin(sampled, ONE, OPTIMAL));
        assert!(!copies.reads_through_twin(ATTACHMENT, ONE, OPTIMAL));
        for (usage, samples) in [
            (sampled | vk::ImageUsageFlags::STORAGE, ONE),
            (sampled, vk::SampleCountFlags::TYPE_4),
        ] {
            assert!(!copies.reads_through_twin(usage, samples, OPTIMAL));
            assert!(matches!(
                copies.classify_image(D32, usage, OPTIMAL, samples),
                Some(ImageDepth::Native(NativeReason::ReadByShaders(_)))
            ));
        }
        assert_eq!(
            copies.classify_image(D32, copied, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
        assert_eq!(
            all.classify_image(D32, sampled | copied, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
    }

    #[test]
    fn images_the_host_reads_stay_native_unless_every_image_is_reversed() {
        let host_copied = ATTACHMENT | HOST_TRANSFER;
        for observable in [Observable::None, Observable::Copies] {
            let p = policy(Mode::Flip, observable);
            assert_eq!(
                p.classify_image(D32, ATTACHMENT, vk::ImageTiling::LINEAR, ONE),
                Some(ImageDepth::Native(NativeReason::LinearTiling))
            );
            assert_eq!(
                p.classify_image(D32, host_copied, OPTIMAL, ONE),
                Some(ImageDepth::Native(NativeReason::HostCopied))
            );
        }
        let all = policy(Mode::Flip, Observable::All);
        assert_eq!(
            all.classify_image(D32, host_copied, vk::ImageTiling::LINEAR, ONE),
            Some(ImageDepth::Reversed)
        );
        assert_eq!(
            crate::config::Settings::default().reverse_observable,
            Observable::Copies,
            "copies are converted, so images only copied from are reversed by default"
        );
    }

    #[test]
    fn nothing_is_reversed_when_off_and_variants_stand_in_for_the_dynamic_compare_op() {
        let off = policy(Mode::Off, Observable::All);
        assert_eq!(
            off.classify_image(D32, ATTACHMENT, OPTIMAL, ONE),
            Some(ImageDepth::Native(NativeReason::ModeOff))
        );
        assert!(!off.is_active());
        let settings = Settings {
            mode: Mode::Flip,
            ..Settings::default()
        };
        let no_eds = DevicePolicy::new(&settings, false);
        assert!(no_eds.compare_op_variants && no_eds.is_active());
        assert_eq!(
            no_eds.classify_image(D32, ATTACHMENT, OPTIMAL, ONE),
            Some(ImageDepth::Reversed)
        );
        assert!(!DevicePolicy::new(&settings, true).compare_op_variants);
        let chosen = Settings {
            compare_op: CompareOp::Variants,
            ..settings
        };
        assert!(DevicePolicy::new(&chosen, true).compare_op_variants);
    }

    #[test]
    fn views_of_promoted_images_in_their_format_are_made_in_the_float_one() {
        let (d24, float) = (
            vk::Format::D24_UNORM_S8_UINT,
            vk::Format::D32_SFLOAT_S8_UINT,
        );
        assert_eq!(promoted_view_format(d24, d24, Some(float)), Some(float));
        assert_eq!(promoted_view_format(D32, d24, Some(float)), None);
        assert_eq!(promoted_view_format(d24, d24, None), None);
    }

    #[test]
    fn a_kept_partner_has_the_format_and_size_on_the_other_side_of_a_resolve() {
        let extent = vk::Extent3D {
            width: 64,
            height: 32,
            depth: 1,
        };
        let single = ResolvePartner {
            format: vk::Format::D16_UNORM,
            extent,
            samples: vk::SampleCountFlags::TYPE_1,
        };
        let multi = ResolvePartner {
            samples: vk::SampleCountFlags::TYPE_4,
            ..single
        };
        assert!(kept_resolve_partner(single, multi, false));
        assert!(kept_resolve_partner(multi, single, false));
        // A promoted partner does not keep the new image's format.
        assert!(!kept_resolve_partner(single, multi, true));
        // Both on the same side of a resolve.
        assert!(!kept_resolve_partner(single, single, false));
        let eight = ResolvePartner {
            samples: vk::SampleCountFlags::TYPE_8,
            ..multi
        };
        assert!(!kept_resolve_partner(multi, eight, false));
        // Another format or size.
        let d24 = ResolvePartner {
            format: vk::Format::D24_UNORM_S8_UINT,
            ..multi
        };
        assert!(!kept_resolve_partner(single, d24, false));
        let larger = ResolvePartner {
            extent: vk::Extent3D {
                width: 128,
                ..extent
            },
            ..multi
        };
        assert!(!kept_resolve_partner(single, larger, false));
    }

    #[test]
    fn only_reversed_images_are_demoted() {
        let reason = NativeReason::UnswappableResolve;
        assert_eq!(
            ImageDepth::Reversed.demoted(reason),
            Some(ImageDepth::Native(reason))
        );
        let native = ImageDepth::Native(NativeReason::HostCopied);
        assert_eq!(native.demoted(reason), None);
    }

    #[test]
    fn only_depth_attachments_may_be_resolved() {
        assert!(may_be_resolved(ATTACHMENT));
        assert!(may_be_resolved(ATTACHMENT | vk::ImageUsageFlags::SAMPLED));
        assert!(!may_be_resolved(vk::ImageUsageFlags::SAMPLED));
        assert!(!may_be_resolved(vk::ImageUsageFlags::TRANSFER_DST));
    }

    #[test]
    fn a_rendering_inheritance_draws_promoted_in_its_first_promotable_format() {
        use vk::Format as F;
        assert_eq!(
            first_promoted_format(F::D16_UNORM, F::UNDEFINED),
            Some(F::D16_UNORM)
        );
        assert_eq!(
            first_promoted_format(F::UNDEFINED, F::D24_UNORM_S8_UINT),
            Some(F::D24_UNORM_S8_UINT)
        );
        assert_eq!(
            first_promoted_format(F::D24_UNORM_S8_UINT, F::D24_UNORM_S8_UINT),
            Some(F::D24_UNORM_S8_UINT)
        );
        assert_eq!(first_promoted_format(F::D32_SFLOAT, F::UNDEFINED), None);
        assert_eq!(first_promoted_format(F::UNDEFINED, F::UNDEFINED), None);
    }

    #[test]
    fn a_promoted_inheritance_names_the_float_formats() {
        use vk::Format as F;
        assert_eq!(promoted_attachment_format(F::D16_UNORM), F::D32_SFLOAT);
        assert_eq!(
            promoted_attachment_format(F::D24_UNORM_S8_UINT),
            F::D32_SFLOAT_S8_UINT
        );
        assert_eq!(promoted_attachment_format(F::UNDEFINED), F::UNDEFINED);
        assert_eq!(promoted_attachment_format(F::D32_SFLOAT), F::D32_SFLOAT);
        assert_eq!(promoted_attachment_format(F::S8_UINT), F::S8_UINT);
    }

    #[test]
    fn only_unorm_depth_formats_are_promotable() {
        use vk::Format as F;
        for format in [
            F::D16_UNORM,
            F::X8_D24_UNORM_PACK32,
            F::D24_UNORM_S8_UINT,
            F::D16_UNORM_S8_UINT,
        ] {
            assert!(promotable_format(format), "{format:?}");
        }
        for format in [
            F::D32_SFLOAT,
            F::D32_SFLOAT_S8_UINT,
            F::S8_UINT,
            F::UNDEFINED,
        ] {
            assert!(!promotable_format(format), "{format:?}");
        }
    }
}
