//! The policy: decisions revz takes about depth, as functions of plain facts.
//!
//! | decision | facts it reads | where they come from |
//! |---|---|---|
//! | is a depth image reversed or native ([`DevicePolicy::classify_image`]) | format, usage, tiling, settings | `vkCreateImage` |
//! | is a depth image created in a float format ([`DevicePolicy::promoted_format`]) | format, usage, tiling, flags, external memory, the device's support of the float format, settings | `vkCreateImage` (imageless framebuffers: their attachment infos) |
//! | must a resolve's source become native ([`DepthResolve::demotes_source`]) | resolve mode, destination, swappability | framebuffer creation, pass begins |
//! | which MIN/MAX mode a reversed resolve uses ([`ResolveSupport::swapped_depth_mode`]) | the device's resolve properties | `vkCreateDevice` |
//! | does the application render reversed depth itself ([`ConventionEvidence::decide`], once per device) | the clear of the first committed reversed attachment, compare ops of pipelines and `vkCmdSetDepthCompareOp`, pushed projections | pass begins and image clears, pipeline creation, draws |
//! | where a secondary without a framebuffer draws ([`secondary_target`]) | the target its pass was last begun with for secondaries, the format's images | primary begins, `vkCreateImage` |
//! | whether such a secondary draws into a promoted attachment ([`secondary_promoted`]) | the same, for promotion | primary begins, `vkCreateImage` |
//! | is the precise path available, and where its carrier goes ([`DevicePolicy::carrier_offset`]) | the mode, `maxPushConstantsSize` | `vkCreateDevice` |
//! | where the device's dynamic compare op comes from ([`CompareOpSource::decide`]) | the API version, the application's `VK_EXT_extended_dynamic_state` and feature structure, the mode, whether revz may add the extension and the device offers it | `vkCreateDevice` |
//! | does a pipeline's vertex stage store reversed depth itself, and of which range (`crate::hooks::pipeline::plan::projection_of`, from the analysis of `crate::shader_analysis` and `crate::derived_range`) | where its projection comes from (push-constant bytes, a buffer the stage can fit from, neither), its clip convention (static or dynamic) | `vkCreateShaderModule`, `vkCreateGraphicsPipelines` |
//! | which range a derived draw stores and in which clip convention (`crate::command_state::CommandState::derived_use`) | the mode, the target, the pipeline's dynamic clip convention and its current value | draws |
//! | is a copy's depth converted, and which way ([`CopyFacts::decide`]) | which end is a reversed image, the aspect, `copy_values`, whether the command buffer can dispatch and its compute bindings can be restored, extension structures | `vkCmdCopy*`, `vkCmdBlitImage*` (image decisions from `vkCreateImage`, pool families from `vkCreateCommandPool`) |
//! | which path a draw takes | its target, its pipeline's projection and rewritten store, its matrix's camera | `crate::command_state` (per draw, from these facts) |
//!
//! An image is decided once, at creation, for its whole life: every draw into it must then
//! follow the same convention (`shared/DESIGN.md` section 2). A depth image the application can
//! observe keeps standard depth unless the `reverse_observable` setting allows it, because its
//! readers (shadow-map compares, SSAO, picking, screenshots) expect standard values.
//!
//! Where this differs from `shared/DESIGN.md`: the design notes call an application reversed
//! on "a clear to 0 with GREATER, or B > 0 projections"; one reversed-looking matrix (rounding
//! in a P*V*M far from the camera) or a clear to 0 alone is weak evidence, and deciding on it
//! mid-frame left command buffers recorded before drawing reversed and new ones not. The
//! convention is now decided once, from a clear to 0 together with GREATER compare ops or
//! reversed projections, and never changed.

use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use ash::vk;
use revz_math::Target as RewriteTarget;

use crate::command_state::{same_near_over_far, Reversing, Target};
use crate::config::{CompareOp, FarClip, Mode, Observable, Settings};
use crate::conv::{flip_depth, flip_resolve_mode, has_depth, Reversal};

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
    /// The application asked for Vulkan 1.3 or later.
    pub core: bool,
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
            .field("core", &self.core)
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
    /// How the device provides a dynamic compare op.
    pub fn decide(facts: &CompareOpFacts<'_>) -> CompareOpSource {
        if facts.core {
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
            NativeReason::LinearTiling => f.write_str("linear tiling (host-readable)"),
            NativeReason::HostCopied => {
                f.write_str("host image copies read it (HOST_TRANSFER), which are not converted")
            }
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

/// What the policy needs to know about a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DevicePolicy {
    pub mode: Mode,
    pub far_clip: FarClip,
    pub observable: Observable,
    /// Whether draws into reversed attachments get the flipped compare op from a pipeline
    /// variant rather than `vkCmdSetDepthCompareOp`: by choice (`compare_op = variants`), or
    /// because the device cannot make it dynamic (no Vulkan 1.3, no
    /// `VK_EXT_extended_dynamic_state`).
    pub compare_op_variants: bool,
    /// Where revz's carrier goes in every pipeline layout (precise modes on a device with the
    /// room: `crate::precise::carrier_offset`); `None`: the precise path is off and every draw
    /// into a reversed attachment takes the flip path.
    pub carrier_offset: Option<u32>,
    /// Whether UNORM depth images are promoted to float formats (`promote_depth_formats` in
    /// this mode).
    pub promote: bool,
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
}

/// Why a depth image in a UNORM format keeps it (logged once per reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeptFormat {
    /// Copies read or write its bytes (transfer usage): the application would get float bits
    /// where it expects UNORM values (and, for D16, twice the bytes).
    Copied,
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
}

impl fmt::Display for KeptFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            KeptFormat::Copied => {
                "it is copied from or to (transfer usage), and copies of promoted images are \
                 not converted"
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
        })
    }
}

impl DevicePolicy {
    /// The policy on a device with `maxPushConstantsSize` bytes of push constants.
    pub fn with_push_constant_space(self, max_push_constants_size: u32) -> DevicePolicy {
        DevicePolicy {
            carrier_offset: self
                .rewrite()
                .and(crate::precise::carrier_offset(max_push_constants_size)),
            ..self
        }
    }

    /// The policy of a device; `dynamic_compare_op`: whether `vkCmdSetDepthCompareOp` (core
    /// 1.3 or the EXT) can be used.
    pub fn new(settings: &Settings, dynamic_compare_op: bool) -> DevicePolicy {
        DevicePolicy {
            mode: settings.mode,
            far_clip: settings.far_clip,
            observable: settings.reverse_observable,
            compare_op_variants: settings.compare_op == CompareOp::Variants || !dynamic_compare_op,
            carrier_offset: None,
            promote: settings.promote_depth_formats.applies(settings.mode),
        }
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
        let transfer =
            vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST | HOST_TRANSFER;
        if facts.usage.intersects(transfer) {
            return Err(KeptFormat::Copied);
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
        Ok(Some(float))
    }

    /// Whether the layer acts on this device's depth at all.
    pub fn is_active(&self) -> bool {
        self.mode != Mode::Off
    }

    /// The projection rewrite of the mode, if it has one (flip mode only flips).
    pub fn rewrite(&self) -> Option<RewriteTarget> {
        match self.mode {
            Mode::Complementary => Some(RewriteTarget::Complementary),
            Mode::Infinite => Some(RewriteTarget::Infinite),
            Mode::Off | Mode::Flip => None,
        }
    }

    /// How draws into reversed attachments are made, given the n / f seen last (infinite mode).
    pub fn reversing(&self, observed: &Observed) -> Reversing {
        Reversing {
            rewrite: self.rewrite(),
            reversal: self.reversal(observed),
        }
    }

    fn reversal(&self, observed: &Observed) -> Reversal {
        match self.mode {
            Mode::Infinite => Reversal::Infinite {
                near_over_far: observed.near_over_far(),
            },
            _ => Reversal::Complementary,
        }
    }

    /// A depth clear value on a reversed attachment. Infinite reversed-Z puts the far plane at
    /// infinity (0) unless `far_clip = keep`, which clears to n / f instead so that fragments
    /// beyond the far plane lose against the clear (seed 001); a clear is recorded before the
    /// projections of its pass are pushed, so n / f is the last one seen.
    pub fn reversed_clear(&self, depth: f32, observed: &Observed) -> f32 {
        match self.mode {
            Mode::Infinite if depth == 1.0 && self.far_clip == FarClip::Remove => 0.0,
            Mode::Infinite => self.reversal(observed).depth(depth),
            _ => flip_depth(depth),
        }
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

/// One end of a copy, blit or resolve, as [`CopyFacts`] sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyEnd {
    /// A buffer: the application's bytes, in standard depth.
    Buffer,
    /// A depth image revz stores reversed (and the application renders standard depth).
    Reversed,
    /// Any other image: native depth, or not a depth image.
    Native,
}

/// The direction a copy's depth values are converted in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyDirection {
    /// Reversed values leave revz: the application receives the standard ones.
    ToStandard,
    /// Standard values enter a reversed image: revz stores them reversed.
    ToReversed,
}

/// Why a copy that should be converted is not (its values keep the source's convention;
/// logged once per reason).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unconverted {
    /// The command buffer's queue family lacks graphics or compute (the conversion is a
    /// dispatch, and copies into a depth aspect need graphics), or its pool is protected.
    NoCompute,
    /// The application bound compute descriptors revz cannot bind again after its dispatch
    /// (push descriptors, descriptor buffers, `vkCmdBindDescriptorSets2`).
    ComputeBindings,
    /// The command or a region carries an extension structure revz does not know.
    Extended,
    /// A multisampled image: copies through a buffer cannot carry its samples.
    Multisampled,
    /// Conditional rendering is active: it could discard revz's dispatch and not the copies.
    Conditional,
    /// Its regions or formats: a layer count of `VK_REMAINING_ARRAY_LAYERS`, an empty blit box,
    /// two depth formats, or more texels than one conversion holds.
    Regions,
    /// Too many texels for one conversion (past the device's `maxStorageBufferRange`), or
    /// revz could not create its conversion pipeline or scratch memory.
    Resources,
}

impl fmt::Display for Unconverted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unconverted::NoCompute => {
                "its command buffer's queue family lacks graphics or compute, or its pool is \
                 protected"
            }
            Unconverted::ComputeBindings => {
                "compute descriptors were bound in a way revz cannot restore after its \
                 dispatch (push descriptors, descriptor buffers or vkCmdBindDescriptorSets2)"
            }
            Unconverted::Extended => "it carries an extension structure revz does not know",
            Unconverted::Multisampled => {
                "an image is multisampled (a conversion goes through a buffer)"
            }
            Unconverted::Conditional => {
                "conditional rendering is active (it could discard revz's dispatch)"
            }
            Unconverted::Regions => {
                "of its regions or formats (VK_REMAINING_ARRAY_LAYERS, an empty blit box, two \
                 depth formats, or too many texels)"
            }
            Unconverted::Resources => {
                "revz could not get the scratch memory, staged image or pipeline for it (or it \
                 exceeds maxStorageBufferRange)"
            }
        })
    }
}

/// What decides whether a transfer's depth values are converted, gathered at its recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CopyFacts {
    pub source: CopyEnd,
    pub destination: CopyEnd,
    /// The transfer touches the depth aspect (stencil is never converted).
    pub depth_aspect: bool,
    /// The `copy_values` setting.
    pub values: crate::config::CopyValues,
    /// The command buffer's queue family can dispatch compute.
    pub dispatchable: bool,
    /// revz can bind the application's compute state again after its dispatch.
    pub restorable: bool,
    /// The command or one of its regions has a `pNext` chain.
    pub extended: bool,
    /// One of its images is multisampled (image copies and blits).
    pub multisampled: bool,
    /// Conditional rendering is active where it is recorded.
    pub conditional: bool,
}

/// The decision for one transfer touching a reversed depth image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyDecision {
    /// Nothing to convert: no reversed end, both ends reversed, no depth aspect, or
    /// `copy_values = stored`.
    Unchanged,
    Convert(CopyDirection),
    /// It should be converted and cannot be: it goes down as it is.
    Unconverted(Unconverted),
}

impl CopyFacts {
    /// Values change convention exactly where one end is reversed and the other is not:
    /// out of a reversed image into a buffer or a native image they become standard, into a
    /// reversed image from a buffer or a native image they become reversed.
    pub fn decide(&self) -> CopyDecision {
        use crate::config::CopyValues;
        let direction = match (self.source, self.destination) {
            (CopyEnd::Reversed, CopyEnd::Reversed) => return CopyDecision::Unchanged,
            (CopyEnd::Reversed, _) => CopyDirection::ToStandard,
            (_, CopyEnd::Reversed) => CopyDirection::ToReversed,
            _ => return CopyDecision::Unchanged,
        };
        if !self.depth_aspect || self.values == CopyValues::Stored {
            return CopyDecision::Unchanged;
        }
        let refused = if self.extended {
            Some(Unconverted::Extended)
        } else if self.multisampled {
            Some(Unconverted::Multisampled)
        } else if self.conditional {
            Some(Unconverted::Conditional)
        } else if !self.dispatchable {
            Some(Unconverted::NoCompute)
        } else if !self.restorable {
            Some(Unconverted::ComputeBindings)
        } else {
            None
        };
        match refused {
            Some(why) => CopyDecision::Unconverted(why),
            None => CopyDecision::Convert(direction),
        }
    }
}

/// A multisample depth resolve out of a reversed attachment, as the render pass or rendering
/// instance declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthResolve {
    /// The resolve mode (never NONE).
    pub mode: vk::ResolveModeFlags,
    /// What the destination image is.
    pub destination: Target,
    /// The destination image (null when revz does not track its view).
    pub destination_image: vk::Image,
    /// Whether revz can swap MIN and MAX for this resolve (a twin render pass of one subpass,
    /// or a rendering instance; either where the device allows the swapped mode beside the
    /// stencil mode, [`ResolveSupport::swapped_depth_mode`]).
    pub swappable: bool,
}

impl DepthResolve {
    /// Why the reversed source of this resolve must become native, if it must: reversed
    /// values may only be resolved into a reversed image, and MIN or MAX pick the other sample
    /// on reversed values unless they are swapped. SAMPLE_ZERO and AVERAGE commute with every
    /// reversal revz makes (d -> 1 - d, and the affine map of infinite mode).
    pub fn demotes_source(&self) -> Option<NativeReason> {
        if self.destination != Target::Reversed {
            return Some(NativeReason::ResolvedIntoNative(self.destination_image));
        }
        let extreme = matches!(
            self.mode,
            vk::ResolveModeFlags::MIN | vk::ResolveModeFlags::MAX
        );
        (extreme && !self.swappable).then_some(NativeReason::UnswappableResolve)
    }
}

/// What a device allows of depth/stencil resolves (`VkPhysicalDeviceDepthStencilResolveProperties`),
/// read at device creation: which depth modes it has, and which pairs of depth and stencil
/// modes one resolve may combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResolveSupport {
    /// The depth resolve modes the device supports (SAMPLE_ZERO always).
    pub depth_modes: vk::ResolveModeFlags,
    /// `independentResolveNone`: depth and stencil may differ when one of them is NONE.
    pub independent_resolve_none: bool,
    /// `independentResolve`: any supported depth mode may go with any supported stencil mode.
    pub independent_resolve: bool,
}

impl ResolveSupport {
    /// What revz assumes of a device it cannot ask (below Vulkan 1.2): only SAMPLE_ZERO, the
    /// mode every device with depth resolves has, and the two modes always equal.
    pub const MINIMAL: ResolveSupport = ResolveSupport {
        depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO,
        independent_resolve_none: false,
        independent_resolve: false,
    };

    /// Whether one resolve may combine these depth and stencil modes, where the spec pairs
    /// them: equal modes always; one of them NONE with `independentResolveNone`; any pair with
    /// `independentResolve` as well (VUID-VkSubpassDescriptionDepthStencilResolve-
    /// pDepthStencilResolveAttachment-03185 and -03186, VUID-VkRenderingInfo-pDepthAttachment-
    /// 06104 and -06105).
    pub fn allows_pair(&self, depth: vk::ResolveModeFlags, stencil: vk::ResolveModeFlags) -> bool {
        let one_none = depth == vk::ResolveModeFlags::NONE || stencil == vk::ResolveModeFlags::NONE;
        // 06104 asks for independentResolveNone even where independentResolve is set (which
        // implies it on a conforming device): a device reporting one without the other gets
        // equal modes only.
        depth == stencil
            || (self.independent_resolve_none && (self.independent_resolve || one_none))
    }

    /// The depth mode a reversed attachment is resolved with in place of `depth` (MIN <-> MAX,
    /// others kept), or why the device does not allow it. Only the depth mode changes: stencil
    /// is never reversed, so `stencil` is kept, and the swapped depth mode must still pair with
    /// it. `stencil` is `None` where the spec does not pair the two (a render pass's resolve
    /// attachment without a stencil component, or a rendering instance without a stencil
    /// attachment view): then the stencil mode is ignored and cannot block the swap.
    pub fn swapped_depth_mode(
        &self,
        depth: vk::ResolveModeFlags,
        stencil: Option<vk::ResolveModeFlags>,
    ) -> Result<vk::ResolveModeFlags, &'static str> {
        let swapped = flip_resolve_mode(depth);
        if !self.depth_modes.contains(swapped) {
            return Err("the device does not support the swapped depth mode");
        }
        match stencil {
            Some(stencil) if !self.allows_pair(swapped, stencil) => {
                Err("the device does not allow the swapped depth mode beside the stencil mode")
            }
            _ => Ok(swapped),
        }
    }
}

/// Where a secondary command buffer without a framebuffer in its inheritance info draws: the
/// target a primary last began that subpass or rendering format with for secondaries
/// (`remembered`), else what the device's live depth images of the format are (`reversed`
/// and `native` counts). Returns the target and whether it is a guess between images of both
/// kinds (then reversed, since non-observable attachments, the ones secondaries usually draw
/// into, are reversed; logged once by the caller).
pub fn secondary_target(
    remembered: Option<Target>,
    reversed: usize,
    native: usize,
) -> (Target, bool) {
    if let Some(target) = remembered {
        return (target, false);
    }
    match (reversed, native) {
        (0, 0) => (Target::None, false),
        (_, 0) => (Target::Reversed, false),
        (0, _) => (Target::Native, false),
        _ => (Target::Reversed, true),
    }
}

/// Whether a secondary without a framebuffer draws into a promoted attachment: as its pass was
/// last begun for secondaries, else as the device's live images of its depth format are
/// (`promoted` of them promoted, `kept` not). Returns whether it is, and whether that was a
/// guess between both kinds (promoted is assumed: in a promoting mode, the images that keep
/// their format are the ones copied from, rarely drawn by secondaries).
pub fn secondary_promoted(remembered: Option<bool>, promoted: usize, kept: usize) -> (bool, bool) {
    match (remembered, promoted, kept) {
        (Some(remembered), _, _) => (remembered, false),
        (None, 0, _) => (false, false),
        (None, _, 0) => (true, false),
        (None, _, _) => (true, true),
    }
}

/// The depth convention an application renders with, as revz decides it for a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convention {
    /// Standard depth (near 0, far 1, LESS): revz reverses it.
    Standard,
    /// The application renders reversed depth itself: revz leaves its depth alone (pitfall 7
    /// of `shared/DESIGN.md`).
    AppReversed,
}

/// What revz has seen of the application before it decides the convention: the compare ops
/// of the depth-testing pipelines it created (static ones, counted) and of
/// `vkCmdSetDepthCompareOp` (seen or not), and whether the projections it pushed were
/// reversed or standard.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConventionEvidence {
    pub greater_compare_ops: u32,
    pub less_compare_ops: u32,
    pub reversed_projection: bool,
    pub standard_projection: bool,
}

impl ConventionEvidence {
    /// Decides the convention at the first event that commits a reversed attachment to one
    /// (a render pass or rendering begin, an image clear, a secondary's begin); `clear`: the
    /// depth that event clears the attachment to, if it clears it.
    ///
    /// Reversed only on strong evidence, never on one signal alone: a clear to 0, and at least
    /// one of "more GREATER than LESS compare ops" and "reversed projections pushed", and
    /// neither contradicted (more LESS than GREATER, or only standard projections). One
    /// reversed-looking matrix (rounding in a P*V*M far from the camera), a clear to 0 alone
    /// (a shadow map cleared to 0 for a MAX reduction) or an application that clears to 0 but
    /// tests LESS stay standard.
    pub fn decide(&self, clear: Option<f32>) -> Convention {
        use std::cmp::Ordering::{Greater, Less};
        let compare = self.greater_compare_ops.cmp(&self.less_compare_ops);
        let camera = match (self.reversed_projection, self.standard_projection) {
            (true, false) => Greater,
            (false, true) => Less,
            _ => std::cmp::Ordering::Equal,
        };
        let supported = compare == Greater || camera == Greater;
        let contradicted = compare == Less || camera == Less;
        if clear == Some(0.0) && supported && !contradicted {
            Convention::AppReversed
        } else {
            Convention::Standard
        }
    }
}

const UNDECIDED: u8 = 0;
const STANDARD: u8 = 1;
const APP_REVERSED: u8 = 2;

/// What revz learns about a device's application while it records: its depth convention
/// (decided once, [`Observed::settle`]), and (infinite mode) n / f of the projections it
/// pushes. Shared by every recording thread: the evidence is written only until the
/// convention is decided, and then only read (one load).
#[derive(Debug, Default)]
pub struct Observed {
    convention: AtomicU8,
    greater_compare_ops: AtomicU32,
    less_compare_ops: AtomicU32,
    dynamic_greater: AtomicBool,
    dynamic_less: AtomicBool,
    reversed_projection: AtomicBool,
    standard_projection: AtomicBool,
    near_over_far: AtomicU32,
}

/// Sets a flag without writing its cache line when it is already set.
fn raise(flag: &AtomicBool) {
    if !flag.load(Ordering::Relaxed) {
        flag.store(true, Ordering::Relaxed);
    }
}

/// Which way a compare op orders depth: `Some(true)` for GREATER-like, `Some(false)` for
/// LESS-like, `None` for the others (EQUAL, ALWAYS, ...).
fn orders_greater(op: vk::CompareOp) -> Option<bool> {
    match op {
        vk::CompareOp::GREATER | vk::CompareOp::GREATER_OR_EQUAL => Some(true),
        vk::CompareOp::LESS | vk::CompareOp::LESS_OR_EQUAL => Some(false),
        _ => None,
    }
}

impl Observed {
    fn decided(&self) -> u8 {
        self.convention.load(Ordering::Relaxed)
    }

    /// The convention, if decided.
    pub fn convention(&self) -> Option<Convention> {
        match self.decided() {
            STANDARD => Some(Convention::Standard),
            APP_REVERSED => Some(Convention::AppReversed),
            _ => None,
        }
    }

    /// Evidence: a depth-testing pipeline with this static compare op was created.
    pub fn note_pipeline_compare_op(&self, op: vk::CompareOp) {
        if self.decided() != UNDECIDED {
            return;
        }
        match orders_greater(op) {
            Some(true) => self.greater_compare_ops.fetch_add(1, Ordering::Relaxed),
            Some(false) => self.less_compare_ops.fetch_add(1, Ordering::Relaxed),
            None => return,
        };
    }

    /// Evidence: the application set this dynamic compare op.
    pub fn note_dynamic_compare_op(&self, op: vk::CompareOp) {
        if self.decided() != UNDECIDED {
            return;
        }
        match orders_greater(op) {
            Some(true) => raise(&self.dynamic_greater),
            Some(false) => raise(&self.dynamic_less),
            None => {}
        }
    }

    /// Evidence: the application pushed a projection, reversed or standard.
    pub fn note_projection(&self, reversed: bool) {
        if self.decided() != UNDECIDED {
            return;
        }
        raise(if reversed {
            &self.reversed_projection
        } else {
            &self.standard_projection
        });
    }

    /// What was seen so far.
    pub fn evidence(&self) -> ConventionEvidence {
        let flag = |f: &AtomicBool| u32::from(f.load(Ordering::Relaxed));
        ConventionEvidence {
            greater_compare_ops: self.greater_compare_ops.load(Ordering::Relaxed)
                + flag(&self.dynamic_greater),
            less_compare_ops: self.less_compare_ops.load(Ordering::Relaxed)
                + flag(&self.dynamic_less),
            reversed_projection: self.reversed_projection.load(Ordering::Relaxed),
            standard_projection: self.standard_projection.load(Ordering::Relaxed),
        }
    }

    /// The convention, decided now from the evidence if it is not yet: called where a
    /// reversed attachment is first committed to one (`clear`: the depth it is cleared to
    /// there, if it is). Decided once for the device and never changed, so every command
    /// buffer, recorded before or after, draws into its attachments the same way. Logged
    /// once.
    pub fn settle(&self, clear: Option<f32>) -> Convention {
        if let Some(decided) = self.convention() {
            return decided;
        }
        let evidence = self.evidence();
        let convention = evidence.decide(clear);
        let value = match convention {
            Convention::Standard => STANDARD,
            Convention::AppReversed => APP_REVERSED,
        };
        match self.convention.compare_exchange(
            UNDECIDED,
            value,
            Ordering::Relaxed,
            Ordering::Relaxed,
        ) {
            Ok(_) if convention == Convention::AppReversed => log::info!(
                "the application already uses reversed depth (a depth attachment cleared to 0, \
                 {} GREATER and {} LESS compare ops, {} projections): revz leaves its depth \
                 alone",
                evidence.greater_compare_ops,
                evidence.less_compare_ops,
                match (evidence.reversed_projection, evidence.standard_projection) {
                    (true, false) => "reversed",
                    (false, true) => "standard",
                    (true, true) => "reversed and standard",
                    (false, false) => "no pushed",
                }
            ),
            Ok(_) => log::debug!("the application renders standard depth ({evidence:?})"),
            // Another thread decided first: its decision stands.
            Err(_) => return self.convention().unwrap_or(Convention::Standard),
        }
        convention
    }

    /// The depth target revz acts on for an attachment whose image is `target` (settling
    /// the convention, without a clear, where it is not yet decided).
    pub fn effective(&self, target: Target) -> Target {
        match target {
            Target::Reversed if self.settle(None) == Convention::AppReversed => Target::Native,
            other => other,
        }
    }

    /// n / f of the last projection rewritten (0 before any).
    pub fn near_over_far(&self) -> f32 {
        f32::from_bits(self.near_over_far.load(Ordering::Relaxed))
    }

    pub fn note_near_over_far(&self, near_over_far: f32) {
        // Load first: the common case (the same camera) must not write the shared cache line.
        if !same_near_over_far(self.near_over_far(), near_over_far) {
            self.near_over_far
                .store(near_over_far.to_bits(), Ordering::Relaxed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compare_op_comes_from_core_the_application_or_revz_in_that_order() {
        let asked = std::cell::Cell::new(false);
        let has = || {
            asked.set(true);
            true
        };
        let facts = |core, app, feature_struct, off, allowed| CompareOpFacts {
            core,
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
    }

    fn policy(mode: Mode, observable: Observable) -> DevicePolicy {
        DevicePolicy {
            mode,
            far_clip: FarClip::Remove,
            observable,
            compare_op_variants: false,
            carrier_offset: None,
            promote: matches!(mode, Mode::Complementary | Mode::Infinite),
        }
    }

    const ATTACHMENT_IMAGE: ImageFacts = ImageFacts {
        usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        tiling: vk::ImageTiling::OPTIMAL,
        flags: vk::ImageCreateFlags::empty(),
        external: false,
        partner_kept: false,
    };

    #[test]
    fn secondaries_follow_the_pass_then_the_formats_images() {
        assert_eq!(secondary_promoted(Some(false), 3, 0), (false, false));
        assert_eq!(secondary_promoted(Some(true), 0, 3), (true, false));
        assert_eq!(secondary_promoted(None, 0, 0), (false, false));
        assert_eq!(secondary_promoted(None, 0, 2), (false, false));
        assert_eq!(secondary_promoted(None, 2, 0), (true, false));
        assert_eq!(secondary_promoted(None, 2, 1), (true, true));
    }

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
        // Sampled images too (native ones): a resolve needs one format at both ends.
        let sampled = ImageFacts {
            usage: ATTACHMENT_IMAGE.usage | vk::ImageUsageFlags::SAMPLED,
            ..ATTACHMENT_IMAGE
        };
        assert_eq!(
            p.promoted_format(d24, sampled, yes),
            Ok(Some(vk::Format::D32_SFLOAT_S8_UINT))
        );
        for transfer in [
            vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageUsageFlags::TRANSFER_DST,
            vk::ImageUsageFlags::from_raw(0x0040_0000),
        ] {
            let copied = ImageFacts {
                usage: ATTACHMENT_IMAGE.usage | transfer,
                ..ATTACHMENT_IMAGE
            };
            assert_eq!(p.promoted_format(d24, copied, yes), Err(KeptFormat::Copied));
        }
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

    #[test]
    fn infinite_clears_put_the_far_plane_at_infinity_or_at_near_over_far() {
        let observed = Observed::default();
        observed.note_near_over_far(0.001);
        let remove = policy(Mode::Infinite, Observable::None);
        let keep = DevicePolicy {
            far_clip: FarClip::Keep,
            ..remove
        };
        assert_eq!(remove.reversed_clear(1.0, &observed), 0.0);
        assert_eq!(keep.reversed_clear(1.0, &observed), 0.001);
        assert_eq!(keep.reversed_clear(0.0, &observed), 1.0);
        let complementary = policy(Mode::Complementary, Observable::None);
        assert_eq!(complementary.reversed_clear(0.25, &observed), 0.75);
        assert_eq!(
            remove.reversing(&observed).reversal,
            Reversal::Infinite {
                near_over_far: 0.001
            }
        );
        assert_eq!(policy(Mode::Flip, Observable::None).rewrite(), None);
    }

    #[test]
    fn a_secondary_without_framebuffer_follows_the_pass_it_was_last_begun_for() {
        // A sampled (native) shadow map and a reversed main attachment of one format: the
        // shadow pass, once begun for secondaries, is known to be native.
        assert_eq!(
            secondary_target(Some(Target::Native), 1, 1),
            (Target::Native, false)
        );
        assert_eq!(
            secondary_target(Some(Target::Reversed), 0, 1),
            (Target::Reversed, false)
        );
        // Never begun yet: the images of the format decide, a guess only where both kinds
        // exist.
        assert_eq!(secondary_target(None, 1, 1), (Target::Reversed, true));
        assert_eq!(secondary_target(None, 0, 2), (Target::Native, false));
        assert_eq!(secondary_target(None, 3, 0), (Target::Reversed, false));
        assert_eq!(secondary_target(None, 0, 0), (Target::None, false));
    }

    #[test]
    fn strong_evidence_makes_reversed_targets_native() {
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::GREATER);
        observed.note_pipeline_compare_op(vk::CompareOp::EQUAL);
        assert_eq!(observed.settle(Some(0.0)), Convention::AppReversed);
        assert_eq!(observed.effective(Target::Reversed), Target::Native);
        assert_eq!(observed.effective(Target::None), Target::None);
    }

    #[test]
    fn the_convention_is_decided_once_and_later_evidence_changes_nothing() {
        // A standard application's first pass: decided standard.
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::LESS);
        assert_eq!(observed.effective(Target::Reversed), Target::Reversed);
        // Later, in the same frame: a matrix that looks reversed, a clear to 0, GREATER
        // pipelines. Command buffers recorded before keep drawing reversed, so new ones must
        // too.
        observed.note_projection(true);
        for _ in 0..10 {
            observed.note_pipeline_compare_op(vk::CompareOp::GREATER_OR_EQUAL);
        }
        observed.note_dynamic_compare_op(vk::CompareOp::GREATER);
        assert_eq!(observed.settle(Some(0.0)), Convention::Standard);
        assert_eq!(observed.effective(Target::Reversed), Target::Reversed);
        // The evidence stopped being gathered once decided.
        assert_eq!(observed.evidence().greater_compare_ops, 0);
    }

    #[test]
    fn one_signal_alone_is_weak_evidence() {
        let decide = |evidence: ConventionEvidence, clear| evidence.decide(clear);
        let none = ConventionEvidence::default();
        let greater = ConventionEvidence {
            greater_compare_ops: 3,
            less_compare_ops: 1,
            ..none
        };
        let camera = ConventionEvidence {
            reversed_projection: true,
            ..none
        };
        // A clear to 0 alone, GREATER alone, a reversed camera alone: standard.
        assert_eq!(decide(none, Some(0.0)), Convention::Standard);
        assert_eq!(decide(greater, Some(1.0)), Convention::Standard);
        assert_eq!(decide(greater, None), Convention::Standard);
        assert_eq!(decide(camera, None), Convention::Standard);
        // A clear to 0 with either GREATER or a reversed camera: reversed.
        assert_eq!(decide(greater, Some(0.0)), Convention::AppReversed);
        assert_eq!(decide(camera, Some(0.0)), Convention::AppReversed);
        // Contradicted by more LESS than GREATER, or by standard projections only.
        let less = ConventionEvidence {
            less_compare_ops: 4,
            ..camera
        };
        assert_eq!(decide(less, Some(0.0)), Convention::Standard);
        let standard_camera = ConventionEvidence {
            standard_projection: true,
            ..greater
        };
        assert_eq!(decide(standard_camera, Some(0.0)), Convention::Standard);
        // Both kinds of projection (a reflection, a noisy far matrix) cancel out: the compare
        // ops decide.
        let mixed = ConventionEvidence {
            reversed_projection: true,
            standard_projection: true,
            ..greater
        };
        assert_eq!(decide(mixed, Some(0.0)), Convention::AppReversed);
        // Ties are not evidence.
        let tie = ConventionEvidence {
            greater_compare_ops: 2,
            less_compare_ops: 2,
            ..none
        };
        assert_eq!(decide(tie, Some(0.0)), Convention::Standard);
    }

    #[test]
    fn racing_threads_agree_on_the_first_decision() {
        let observed = Observed::default();
        observed.note_pipeline_compare_op(vk::CompareOp::GREATER);
        let results: Vec<Convention> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..8)
                .map(|i| {
                    let observed = &observed;
                    scope.spawn(move || observed.settle((i % 2 == 0).then_some(0.0)))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("no panic"))
                .collect()
        });
        let first = observed.convention().expect("decided");
        assert!(results.iter().all(|&r| r == first), "{results:?}");
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
    fn images_the_host_reads_stay_native_unless_every_image_is_reversed() {
        let host_copied = ATTACHMENT | HOST_TRANSFER;
        for observable in [Observable::None, Observable::Copies] {
            let p = policy(Mode::Flip, observable);
            assert_eq!(
                p.classify_image(D32, ATTACHMENT, vk::ImageTiling::LINEAR),
                Some(ImageDepth::Native(NativeReason::LinearTiling))
            );
            assert_eq!(
                p.classify_image(D32, host_copied, OPTIMAL),
                Some(ImageDepth::Native(NativeReason::HostCopied))
            );
        }
        let all = policy(Mode::Flip, Observable::All);
        assert_eq!(
            all.classify_image(D32, host_copied, vk::ImageTiling::LINEAR),
            Some(ImageDepth::Reversed)
        );
        assert_eq!(
            crate::config::Settings::default().reverse_observable,
            Observable::Copies,
            "copies are converted, so images only copied from are reversed by default"
        );
    }

    #[test]
    fn copies_convert_exactly_where_one_end_is_reversed() {
        use crate::config::CopyValues;
        let facts = |source, destination| CopyFacts {
            source,
            destination,
            depth_aspect: true,
            values: CopyValues::Standard,
            dispatchable: true,
            restorable: true,
            extended: false,
            multisampled: false,
            conditional: false,
        };
        use CopyEnd::{Buffer, Native, Reversed};
        let table = [
            (
                Reversed,
                Buffer,
                CopyDecision::Convert(CopyDirection::ToStandard),
            ),
            (
                Reversed,
                Native,
                CopyDecision::Convert(CopyDirection::ToStandard),
            ),
            (
                Buffer,
                Reversed,
                CopyDecision::Convert(CopyDirection::ToReversed),
            ),
            (
                Native,
                Reversed,
                CopyDecision::Convert(CopyDirection::ToReversed),
            ),
            (Reversed, Reversed, CopyDecision::Unchanged),
            (Native, Native, CopyDecision::Unchanged),
            (Native, Buffer, CopyDecision::Unchanged),
            (Buffer, Native, CopyDecision::Unchanged),
        ];
        for (source, destination, decision) in table {
            assert_eq!(
                facts(source, destination).decide(),
                decision,
                "{source:?} -> {destination:?}"
            );
        }
        let out = facts(Reversed, Buffer);
        let stencil = CopyFacts {
            depth_aspect: false,
            ..out
        };
        assert_eq!(stencil.decide(), CopyDecision::Unchanged);
        let stored = CopyFacts {
            values: CopyValues::Stored,
            ..out
        };
        assert_eq!(stored.decide(), CopyDecision::Unchanged);
        let refusals = [
            (
                CopyFacts {
                    extended: true,
                    ..out
                },
                Unconverted::Extended,
            ),
            (
                CopyFacts {
                    multisampled: true,
                    ..out
                },
                Unconverted::Multisampled,
            ),
            (
                CopyFacts {
                    conditional: true,
                    ..out
                },
                Unconverted::Conditional,
            ),
            (
                CopyFacts {
                    dispatchable: false,
                    ..out
                },
                Unconverted::NoCompute,
            ),
            (
                CopyFacts {
                    restorable: false,
                    ..out
                },
                Unconverted::ComputeBindings,
            ),
        ];
        for (facts, why) in refusals {
            assert_eq!(facts.decide(), CopyDecision::Unconverted(why));
        }
    }

    #[test]
    fn a_reversed_resolve_source_stays_reversed_only_into_a_reversed_image() {
        let resolve = |mode, destination, swappable| DepthResolve {
            mode,
            destination,
            destination_image: vk::Image::null(),
            swappable,
        };
        use vk::ResolveModeFlags as M;
        for mode in [M::SAMPLE_ZERO, M::AVERAGE, M::MIN, M::MAX] {
            for destination in [Target::Native, Target::None] {
                assert!(matches!(
                    resolve(mode, destination, true).demotes_source(),
                    Some(NativeReason::ResolvedIntoNative(_))
                ));
            }
            assert_eq!(resolve(mode, Target::Reversed, true).demotes_source(), None);
        }
        assert_eq!(
            resolve(M::AVERAGE, Target::Reversed, false).demotes_source(),
            None
        );
        for mode in [M::MIN, M::MAX] {
            assert_eq!(
                resolve(mode, Target::Reversed, false).demotes_source(),
                Some(NativeReason::UnswappableResolve)
            );
        }
    }

    /// Every support a device can report: (independentResolveNone, independentResolve).
    fn supports() -> impl Iterator<Item = ResolveSupport> {
        [(false, false), (true, false), (true, true), (false, true)]
            .into_iter()
            .map(|(none, all)| ResolveSupport {
                depth_modes: vk::ResolveModeFlags::SAMPLE_ZERO
                    | vk::ResolveModeFlags::AVERAGE
                    | vk::ResolveModeFlags::MIN
                    | vk::ResolveModeFlags::MAX,
                independent_resolve_none: none,
                independent_resolve: all,
            })
    }

    /// The spec's pairing rules, worded as its VUIDs are, for a pair the spec pairs: render
    /// passes (VkSubpassDescriptionDepthStencilResolve 03185, 03186) and dynamic rendering
    /// (VkRenderingInfo 06104, 06105).
    fn spec_allows(
        support: ResolveSupport,
        depth: vk::ResolveModeFlags,
        stencil: vk::ResolveModeFlags,
    ) -> bool {
        use vk::ResolveModeFlags as M;
        let (none, all) = (
            support.independent_resolve_none,
            support.independent_resolve,
        );
        let either_none = depth == M::NONE || stencil == M::NONE;
        let render_pass = match (all, none) {
            (false, false) => depth == stencil,
            (false, true) => depth == stencil || either_none,
            (true, _) => true,
        };
        let rendering = (none || depth == stencil) && (all || either_none || depth == stencil);
        render_pass && rendering
    }

    #[test]
    fn the_depth_resolve_swaps_only_into_a_pair_the_spec_allows_and_keeps_the_stencil_mode() {
        use vk::ResolveModeFlags as M;
        let stencils = [
            None,
            Some(M::NONE),
            Some(M::SAMPLE_ZERO),
            Some(M::MIN),
            Some(M::MAX),
        ];
        for support in supports() {
            for depth in [M::SAMPLE_ZERO, M::AVERAGE, M::MIN, M::MAX] {
                for stencil in stencils {
                    let swapped = flip_resolve_mode(depth);
                    let allowed = stencil.is_none_or(|s| spec_allows(support, swapped, s));
                    let expected = if allowed { Ok(swapped) } else { Err(()) };
                    assert_eq!(
                        support.swapped_depth_mode(depth, stencil).map_err(|_| ()),
                        expected,
                        "{support:?} {depth:?} {stencil:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn stencil_modes_block_a_swap_only_where_the_device_pairs_them_with_depth() {
        use vk::ResolveModeFlags as M;
        let mut support = supports().next().expect("a support");
        // Neither independence: the modes must stay equal, so a MIN beside a MIN stencil stays.
        assert!(support.swapped_depth_mode(M::MIN, Some(M::MIN)).is_err());
        // ... unless the stencil mode is ignored (no stencil in the resolve attachment).
        assert_eq!(support.swapped_depth_mode(M::MIN, None), Ok(M::MAX));
        // independentResolveNone: a NONE stencil mode is fine, a resolving one is not.
        support.independent_resolve_none = true;
        assert_eq!(
            support.swapped_depth_mode(M::MAX, Some(M::NONE)),
            Ok(M::MIN)
        );
        assert!(support.swapped_depth_mode(M::MAX, Some(M::MAX)).is_err());
        // independentResolve: any pair.
        support.independent_resolve = true;
        assert_eq!(support.swapped_depth_mode(M::MIN, Some(M::MIN)), Ok(M::MAX));
        assert_eq!(
            support.swapped_depth_mode(M::MIN, Some(M::SAMPLE_ZERO)),
            Ok(M::MAX)
        );
        // The swapped mode must be one the device has.
        support.depth_modes = M::SAMPLE_ZERO | M::MIN;
        assert!(support.swapped_depth_mode(M::MIN, None).is_err());
        assert_eq!(
            ResolveSupport::MINIMAL
                .swapped_depth_mode(M::AVERAGE, None)
                .map_err(|_| ()),
            Err(())
        );
        assert_eq!(
            ResolveSupport::MINIMAL.swapped_depth_mode(M::SAMPLE_ZERO, Some(M::SAMPLE_ZERO)),
            Ok(M::SAMPLE_ZERO)
        );
    }

    #[test]
    fn nothing_is_reversed_when_off_and_variants_stand_in_for_the_dynamic_compare_op() {
        let off = policy(Mode::Off, Observable::All);
        assert_eq!(
            off.classify_image(D32, ATTACHMENT, OPTIMAL),
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
            no_eds.classify_image(D32, ATTACHMENT, OPTIMAL),
            Some(ImageDepth::Reversed)
        );
        assert!(!DevicePolicy::new(&settings, true).compare_op_variants);
        let chosen = Settings {
            compare_op: CompareOp::Variants,
            ..settings
        };
        assert!(DevicePolicy::new(&chosen, true).compare_op_variants);
    }
}
