//! Copies and blits between depth images and buffers: where one end is a reversed image and
//! the other holds standard depth, or one end is a promoted image (float32 storage) and the
//! other holds the application's UNORM format, the depth regions are converted on the way
//! (`crate::depth_copy`, decided by `crate::policy::CopyFacts::decide`) and the other regions
//! (stencil) go down as the application gave them. The compute state the conversion disturbs (descriptor set binds,
//! push descriptors, conditional rendering) is followed in `compute_state.rs`.

#![allow(clippy::wildcard_imports)]

use super::*;
use crate::depth_copy::plan::{
    explicit_layers, plan_blit, plan_buffer_copy, plan_image_copy, DepthMap, ShaderHeader,
    TexelKind,
};
use crate::depth_copy::record::{record, record_blit, Conversion, Drain, Fill};
use crate::policy::{
    conversion_kinds, copied_texels, image_copy_end, single_sampled, CopyDecision, CopyDirection,
    CopyEnd, CopyFacts, Texels, Unconverted,
};

/// One image end of a copy: its convention, and how its depth texels lie in a buffer as revz
/// stores it (`stored`: float32 where promoted) and as the application made it (`own`).
#[derive(Clone, Copy, Debug)]
struct ImageEnd {
    end: CopyEnd,
    stored: Option<TexelKind>,
    own: Option<TexelKind>,
    /// The format revz created it in (`None`: an image revz does not know).
    created: Option<vk::Format>,
    /// Its array layers (`None`: an image revz does not know).
    layers: Option<u32>,
}

impl ImageEnd {
    /// Whether revz stores it in another format than the application's (promoted).
    fn promoted(self) -> bool {
        self.stored != self.own
    }
}

/// What a copy end is, and how its depth lies in a buffer.
fn image_end(device: &DeviceState, image: vk::Image) -> ImageEnd {
    let Some(info) = device.objects.images.get(&image) else {
        return ImageEnd {
            end: image_copy_end(None),
            stored: None,
            own: None,
            created: None,
            layers: None,
        };
    };
    ImageEnd {
        end: image_copy_end(Some(device.observed.effective(info.depth.target()))),
        stored: copied_texels(info.format, info.promoted),
        own: copied_texels(info.format, None),
        created: Some(info.promoted.unwrap_or(info.format)),
        layers: Some(info.array_layers),
    }
}

/// The decision for a copy between `source` and `destination` (`repack`: the depth texels
/// change format on the way, `crate::policy::CopyFacts::repack`).
fn decide(
    entry: &CommandBufferEntry,
    (source, destination): (CopyEnd, CopyEnd),
    repack: bool,
    (depth_aspect, stencil_apart): (bool, bool),
    extended: bool,
    images: &[vk::Image],
) -> CopyDecision {
    if source != CopyEnd::Reversed && destination != CopyEnd::Reversed && !repack {
        // The common case (no reversed or promoted end) takes no lock.
        return CopyDecision::Unchanged;
    }
    let (restorable, conditional) = {
        let copies = entry.copies();
        (copies.compute.restorable(), copies.conditional)
    };
    let decision = CopyFacts {
        source,
        destination,
        depth_aspect,
        stencil_apart,
        repack,
        values: entry.device.settings.copy_values,
        dispatchable: entry.dispatchable,
        restorable,
        conditional,
        extended,
        // Infinite mode: between an image of complementary depth and one of n / w.
        remaps: matches!(images, [src, dst]
            if (source, destination) == (CopyEnd::Reversed, CopyEnd::Reversed)
                && entry.device.stores_complementary(*src)
                    != entry.device.stores_complementary(*dst)),
        multisampled: !images.iter().all(|&image| {
            single_sampled(
                entry
                    .device
                    .objects
                    .images
                    .get(&image)
                    .map(|info| info.samples),
            )
        }),
    }
    .decide();
    if let (Some(profile), CopyDecision::Unconverted(_)) = (&entry.device.profile, &decision) {
        profile.copy(false);
    }
    decision
}

/// The map of a conversion in `direction` recorded into `entry`, for the reversed `image` (the
/// source of a copy to standard values, the destination of one to reversed values): its own
/// camera's where revz knows it ([`crate::objects::DeviceObjects::near_over_far`]), else the
/// recording's. (The state's lock must not be held.)
fn depth_map(entry: &CommandBufferEntry, direction: CopyDirection, image: vk::Image) -> DepthMap {
    depth_map_with(&entry.device, direction, image, entry.state().reversal())
}

/// [`depth_map`] given the recording's map.
pub(super) fn depth_map_with(
    device: &DeviceState,
    direction: CopyDirection,
    image: vk::Image,
    recording: crate::conv::Reversal,
) -> DepthMap {
    let reversal = device.reversal_of(image, recording);
    match direction {
        CopyDirection::ToStandard => DepthMap::to_standard(reversal),
        CopyDirection::ToReversed => DepthMap::to_reversed(reversal),
        // One image has one map: a remap takes two ([`copy_map`]).
        CopyDirection::Keep | CopyDirection::Remap => DepthMap::IDENTITY,
    }
    .unrestricted(device.policy.depth_range_unrestricted)
}

/// The map of a conversion in `direction` between the images `src` and `dst`: that of its
/// reversed end (the source where values leave revz, the destination where they enter it),
/// or for a remap the source's map back to standard depth followed by the destination's.
fn copy_map(
    entry: &CommandBufferEntry,
    direction: CopyDirection,
    src: vk::Image,
    dst: vk::Image,
) -> DepthMap {
    match direction {
        CopyDirection::ToStandard => depth_map(entry, direction, src),
        CopyDirection::ToReversed | CopyDirection::Keep => depth_map(entry, direction, dst),
        CopyDirection::Remap => depth_map(entry, CopyDirection::ToStandard, src).then(depth_map(
            entry,
            CopyDirection::ToReversed,
            dst,
        )),
    }
}

/// Records `conversion`; logs why not where it cannot.
fn convert(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    conversion: &Conversion<'_>,
) -> bool {
    let mut copies = entry.copies();
    // SAFETY: a recording command buffer of this device, outside a render pass (copies are
    // only allowed there); its own scratch.
    let converted = match unsafe { record(&entry.device, &mut copies, buffer, conversion) } {
        Ok(()) => true,
        Err(why) => {
            entry.device.copies.warn_unconverted(why);
            false
        }
    };
    if let Some(profile) = &entry.device.profile {
        profile.copy(converted);
    }
    converted
}

/// What a hook sends down after planning: the application's regions untouched, or only those
/// left (by index, with the aspects left to them) after the depth was converted.
enum Sent {
    All,
    Rest(Vec<(usize, vk::ImageAspectFlags)>),
}

/// Converts the depth regions of a copy between an image and a buffer, if the policy says so.
/// (The arguments are the command's own, plus its direction and whether it is extended.)
#[allow(clippy::too_many_arguments)]
fn image_buffer_copy(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    image: vk::Image,
    layout: vk::ImageLayout,
    other: vk::Buffer,
    regions: &[vk::BufferImageCopy],
    to_buffer: bool,
    extended: bool,
) -> Sent {
    if !to_buffer {
        super::twins::note_written_image(entry, image);
    }
    let end = image_end(&entry.device, image);
    let ends = if to_buffer {
        (end.end, CopyEnd::Buffer)
    } else {
        (CopyEnd::Buffer, end.end)
    };
    let depth_aspect = regions
        .iter()
        .any(|r| r.image_subresource.aspect_mask == vk::ImageAspectFlags::DEPTH);
    let decision = decide(
        entry,
        ends,
        end.promoted(),
        (depth_aspect, false),
        extended,
        &[image],
    );
    let direction = match decision {
        CopyDecision::Unchanged => return Sent::All,
        CopyDecision::Unconverted(why) => {
            entry.device.copies.warn_unconverted(why);
            return Sent::All;
        }
        CopyDecision::Convert(direction) => direction,
    };
    let (image_texels, buffer_texels) = (Texels::Image(end.stored), Texels::Buffer(end.own));
    let kinds = if to_buffer {
        conversion_kinds(image_texels, buffer_texels)
    } else {
        conversion_kinds(buffer_texels, image_texels)
    };
    let planned = end
        .stored
        .zip(end.own)
        .zip(kinds)
        .and_then(|((stored, own), kinds)| {
            // Region for region, their layer counts explicit.
            let explicit: Vec<vk::BufferImageCopy> = regions
                .iter()
                .map(|r| vk::BufferImageCopy {
                    image_subresource: explicit_layers(r.image_subresource, end.layers),
                    ..*r
                })
                .collect();
            plan_buffer_copy(&explicit, stored, own, to_buffer).map(|plan| (kinds, plan))
        });
    let Some((kinds, plan)) = planned else {
        entry.device.copies.warn_unconverted(Unconverted::Regions);
        return Sent::All;
    };
    let header = ShaderHeader::new(kinds, depth_map(entry, direction, image), &plan.layout);
    let (fill, drain) = if to_buffer {
        (
            Fill::Image {
                image,
                layout,
                regions: &plan.image_regions,
            },
            Drain::Buffer {
                buffer: other,
                copies: &plan.buffer_copies,
            },
        )
    } else {
        (
            Fill::Buffer {
                buffer: other,
                copies: &plan.buffer_copies,
            },
            Drain::Image {
                image,
                layout,
                regions: &plan.image_regions,
            },
        )
    };
    let conversion = Conversion {
        header,
        size: plan.layout.size,
        fill,
        drain,
    };
    if !convert(entry, buffer, &conversion) {
        return Sent::All;
    }
    Sent::Rest(
        plan.rest
            .iter()
            .map(|&i| (i, regions[i].image_subresource.aspect_mask))
            .collect(),
    )
}

/// Sends the application's regions given as (index, aspects) down at once, narrowed to those
/// aspects ([`image_image_copy`]).
type SendFirst<'a> = &'a mut dyn FnMut(&[(usize, vk::ImageAspectFlags)]);

/// Converts the depth of an image copy between conventions, if the policy says so. (The
/// arguments are the command's own, plus whether it is extended, and `send_first`, which sends
/// the given regions down narrowed to the given aspects.)
///
/// Where a conversion is recorded, the regions' other aspects (the stencil of depth-stencil
/// images) go down through `send_first` before it: lavapipe 22.3 writes the depth aspect too
/// when it copies only the stencil of a `D24_UNORM_S8_UINT` or `D32_SFLOAT_S8_UINT` image from
/// image to image, so the converted depth must be the last write. Nothing is then left to
/// send, unless the conversion could not be recorded: its depth regions go down as they are.
#[allow(clippy::too_many_arguments)]
fn image_image_copy(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    src: vk::Image,
    src_layout: vk::ImageLayout,
    dst: vk::Image,
    dst_layout: vk::ImageLayout,
    regions: &[vk::ImageCopy],
    extended: bool,
    send_first: SendFirst<'_>,
) -> Sent {
    super::twins::note_written_image(entry, dst);
    let (source, destination) = (image_end(&entry.device, src), image_end(&entry.device, dst));
    let subresources = || regions.iter().map(|r| r.src_subresource);
    let depth_aspect = names_aspect(subresources(), vk::ImageAspectFlags::DEPTH);
    let names_stencil = names_aspect(subresources(), vk::ImageAspectFlags::STENCIL);
    // Stencil between two storage formats (one promoted) cannot go down as it is.
    let stencil_apart = stored_apart(source, destination) && names_stencil;
    let decision = decide(
        entry,
        (source.end, destination.end),
        stored_apart(source, destination),
        (depth_aspect, stencil_apart),
        extended,
        &[src, dst],
    );
    let direction = match decision {
        CopyDecision::Unchanged => {
            carry_camera(
                entry,
                (source.end, src),
                (destination.end, dst),
                depth_aspect,
            );
            return Sent::All;
        }
        CopyDecision::Unconverted(why) => {
            entry.device.copies.warn_unconverted(why);
            return Sent::All;
        }
        CopyDecision::Convert(direction) => direction,
    };
    let kinds = conversion_kinds(
        Texels::Image(source.stored),
        Texels::Image(destination.stored),
    );
    let Some((kinds, plan)) = kinds.and_then(|kinds| {
        // Region for region, their layer counts explicit.
        let explicit: Vec<vk::ImageCopy> = regions
            .iter()
            .map(|r| vk::ImageCopy {
                src_subresource: explicit_layers(r.src_subresource, source.layers),
                dst_subresource: explicit_layers(r.dst_subresource, destination.layers),
                ..*r
            })
            .collect();
        plan_image_copy(&explicit, kinds).map(|p| (kinds, p))
    }) else {
        entry.device.copies.warn_unconverted(Unconverted::Regions);
        return Sent::All;
    };
    let conversion = Conversion {
        header: ShaderHeader::new(kinds, copy_map(entry, direction, src, dst), &plan.layout),
        size: plan.layout.size,
        fill: Fill::Image {
            image: src,
            layout: src_layout,
            regions: &plan.from_source,
        },
        drain: Drain::Image {
            image: dst,
            layout: dst_layout,
            regions: &plan.to_destination,
        },
    };
    if !plan.rest.is_empty() {
        send_first(&plan.rest);
    }
    if !convert(entry, buffer, &conversion) {
        return Sent::Rest(depth_parts(regions));
    }
    if direction == CopyDirection::Keep {
        // Repacked between two reversed images (one promoted): the stored values move as
        // they are.
        carry_camera(entry, (source.end, src), (destination.end, dst), true);
    }
    Sent::Rest(Vec::new())
}

/// A copy or blit of depth that goes down as it is between two reversed images moves depth
/// stored with the source's n / f (infinite mode) into the destination: the destination's
/// later clears, copies and read twin refreshes map with the source's n / f from then on
/// (in recording order, as every remembered camera; the last copy into an image wins where
/// several with other cameras fill parts of it). Nothing where the source has none
/// remembered, or outside infinite mode.
fn carry_camera(
    entry: &CommandBufferEntry,
    (source_end, source): (CopyEnd, vk::Image),
    (destination_end, destination): (CopyEnd, vk::Image),
    copies_depth: bool,
) {
    let device = &entry.device;
    if !copies_depth
        || source == destination
        || (source_end, destination_end) != (CopyEnd::Reversed, CopyEnd::Reversed)
        || !device.remembers_cameras()
    {
        return;
    }
    let objects = &device.objects;
    // An image of complementary depth maps as n / f = 0 (`DeviceState::image_camera`).
    let camera = device.image_camera(source);
    if device.stores_complementary(destination) {
        if camera.is_some_and(|r| r != 0.0) {
            static MIXED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            MIXED.log(|| {
                log::warn!(
                    "depth of n / w is copied as it is into an image read as an input \
                     attachment, which stores complementary depth in infinite mode: its \
                     shaders and copies read it off by up to n / f"
                )
            });
        }
        return;
    }
    if let Some(near_over_far) = camera {
        objects.near_over_far.insert(destination, near_over_far);
    }
}

/// The depth aspect of each region that copies it, as (index, `DEPTH`).
fn depth_parts(regions: &[vk::ImageCopy]) -> Vec<(usize, vk::ImageAspectFlags)> {
    let depth = vk::ImageAspectFlags::DEPTH;
    regions
        .iter()
        .enumerate()
        .filter(|(_, r)| r.src_subresource.aspect_mask.contains(depth))
        .map(|(i, _)| (i, depth))
        .collect()
}

/// Converts the depth of a blit between conventions, if the policy says so: the source boxes
/// are converted into a staged image, which is blitted in their place. The application's
/// regions' other aspects go down first (`send_first`, as for image copies): a driver that
/// blits whole depth/stencil texels (lavapipe, D24_S8) writes the depth of a stencil blit too,
/// which must not land after the converted depth.
#[allow(clippy::too_many_arguments)]
fn image_blit(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    src: vk::Image,
    src_layout: vk::ImageLayout,
    dst: vk::Image,
    dst_layout: vk::ImageLayout,
    regions: &[vk::ImageBlit],
    extended: bool,
    send_first: SendFirst<'_>,
) -> Sent {
    super::twins::note_written_image(entry, dst);
    let (source, destination) = (image_end(&entry.device, src), image_end(&entry.device, dst));
    let subresources = || regions.iter().map(|r| r.src_subresource);
    let depth_aspect = names_aspect(subresources(), vk::ImageAspectFlags::DEPTH);
    let names_stencil = names_aspect(subresources(), vk::ImageAspectFlags::STENCIL);
    // Stencil between two storage formats (one promoted) cannot go down as it is.
    let stencil_apart = stored_apart(source, destination) && names_stencil;
    let decision = decide(
        entry,
        (source.end, destination.end),
        stored_apart(source, destination),
        (depth_aspect, stencil_apart),
        extended,
        &[src, dst],
    );
    let direction = match decision {
        CopyDecision::Unchanged => {
            carry_camera(
                entry,
                (source.end, src),
                (destination.end, dst),
                depth_aspect,
            );
            return Sent::All;
        }
        CopyDecision::Unconverted(why) => {
            entry.device.copies.warn_unconverted(why);
            return Sent::All;
        }
        CopyDecision::Convert(direction) => direction,
    };
    // The staged image has the destination's format as revz created it: a depth blit needs
    // one format at both ends.
    let kinds = conversion_kinds(
        Texels::Image(source.stored),
        Texels::Image(destination.stored),
    );
    // The stencil is staged too where the blit names it (it is then in the layout the blit
    // names, which a depth-only blit says nothing of under separate depth/stencil layouts).
    let planned = kinds.zip(destination.created).and_then(|(kinds, format)| {
        let stage_stencil = names_stencil && crate::conv::has_stencil(format);
        // Region for region, their layer counts explicit.
        let explicit: Vec<vk::ImageBlit> = regions
            .iter()
            .map(|r| vk::ImageBlit {
                src_subresource: explicit_layers(r.src_subresource, source.layers),
                dst_subresource: explicit_layers(r.dst_subresource, destination.layers),
                ..*r
            })
            .collect();
        plan_blit(&explicit, kinds, stage_stencil).map(|plan| (kinds, format, plan))
    });
    let Some((kinds, format, plan)) = planned else {
        entry.device.copies.warn_unconverted(Unconverted::Regions);
        return Sent::All;
    };
    let device = &entry.device;
    let mut copies = entry.copies();
    let Some(staged) = copies.staged_image(
        device,
        (plan.staged_type(), format),
        plan.staged_extent,
        plan.staged_layers,
    ) else {
        device.copies.warn_unconverted(Unconverted::Resources);
        return Sent::All;
    };
    let conversion = Conversion {
        header: ShaderHeader::new(kinds, copy_map(entry, direction, src, dst), &plan.layout),
        size: plan.layout.size,
        fill: Fill::Image {
            image: src,
            layout: src_layout,
            regions: &plan.from_source,
        },
        drain: Drain::Image {
            image: staged,
            layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            regions: &plan.to_staged,
        },
    };
    let aspects = if crate::conv::has_stencil(format) {
        vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
    } else {
        vk::ImageAspectFlags::DEPTH
    };
    if !plan.rest.is_empty() {
        send_first(&plan.rest);
    }
    // SAFETY: a recording command buffer of this device outside a render pass (blits are only
    // allowed there); its own scratch and a staged image made for this blit.
    let recorded = unsafe {
        record_blit(
            device,
            &mut copies,
            buffer,
            &conversion,
            staged,
            aspects,
            (dst, dst_layout),
            &plan.blits,
        )
    };
    match recorded {
        Ok(()) => Sent::Rest(Vec::new()),
        Err(why) => {
            // The other aspects went down already: what revz took goes down as it is.
            device.copies.warn_unconverted(why);
            Sent::Rest(taken_parts(regions, &plan.rest))
        }
    }
}

/// The aspects of each region that revz took from the application's blit (all but those in
/// `rest`, which went down first): what is left to send where the conversion failed.
fn taken_parts(
    regions: &[vk::ImageBlit],
    rest: &[(usize, vk::ImageAspectFlags)],
) -> Vec<(usize, vk::ImageAspectFlags)> {
    regions
        .iter()
        .enumerate()
        .filter_map(|(i, region)| {
            let sent = rest
                .iter()
                .filter(|&&(j, _)| j == i)
                .fold(vk::ImageAspectFlags::empty(), |all, &(_, aspects)| {
                    all | aspects
                });
            let taken = region.src_subresource.aspect_mask & !sent;
            (!taken.is_empty()).then_some((i, taken))
        })
        .collect()
}

/// Whether any of `subresources` names `aspect`.
fn names_aspect(
    mut subresources: impl Iterator<Item = vk::ImageSubresourceLayers>,
    aspect: vk::ImageAspectFlags,
) -> bool {
    subresources.any(|subresource| subresource.aspect_mask.contains(aspect))
}

/// Whether two images' depth is stored in different formats (one promoted, one not): a copy
/// or blit between them cannot go down as it is.
fn stored_apart(source: ImageEnd, destination: ImageEnd) -> bool {
    source.stored.is_some() && destination.stored.is_some() && source.stored != destination.stored
}

/// The region count and pointer a hook sends down: the application's, or those of the regions
/// left after a conversion; `None` when none is left (nothing to send).
fn to_send<R>(left: &Option<Vec<R>>, count: u32, p_regions: *const R) -> Option<(u32, *const R)> {
    match left {
        Some(rest) if rest.is_empty() => None,
        Some(rest) => Some((rest.len() as u32, rest.as_ptr())),
        None => Some((count, p_regions)),
    }
}

/// The regions a hook sends down: all of them, or those left with their aspects narrowed.
fn regions_left<R: Copy>(
    regions: &[R],
    sent: &Sent,
    narrow: impl Fn(R, vk::ImageAspectFlags) -> R,
) -> Option<Vec<R>> {
    match sent {
        Sent::All => None,
        Sent::Rest(rest) => Some(narrowed(regions, rest, narrow)),
    }
}

/// The application's regions `parts` names, each narrowed to its aspects.
fn narrowed<R: Copy>(
    regions: &[R],
    parts: &[(usize, vk::ImageAspectFlags)],
    narrow: impl Fn(R, vk::ImageAspectFlags) -> R,
) -> Vec<R> {
    parts
        .iter()
        .map(|&(i, aspect)| narrow(regions[i], aspect))
        .collect()
}

fn narrow_buffer_image(
    region: vk::BufferImageCopy,
    aspect: vk::ImageAspectFlags,
) -> vk::BufferImageCopy {
    let mut region = region;
    region.image_subresource.aspect_mask = aspect;
    region
}

fn narrow_image(region: vk::ImageCopy, aspect: vk::ImageAspectFlags) -> vk::ImageCopy {
    let mut region = region;
    region.src_subresource.aspect_mask = aspect;
    region.dst_subresource.aspect_mask = aspect;
    region
}

pub unsafe extern "system" fn cmd_copy_image_to_buffer(
    buffer: vk::CommandBuffer,
    src: vk::Image,
    layout: vk::ImageLayout,
    dst: vk::Buffer,
    count: u32,
    p_regions: *const vk::BufferImageCopy,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyImageToBuffer");
    // SAFETY: `count` regions (the application's contract).
    let regions = unsafe { slice(p_regions, count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let sent = image_buffer_copy(entry, buffer, src, layout, dst, regions, true, false);
        left = regions_left(regions, &sent, narrow_buffer_image);
    });
    let Some(device) = device else { return };
    let Some((count, p_regions)) = to_send(&left, count, p_regions) else {
        return;
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe {
        (device.next.fp_v1_0().cmd_copy_image_to_buffer)(buffer, src, layout, dst, count, p_regions)
    }
}

pub unsafe extern "system" fn cmd_copy_buffer_to_image(
    buffer: vk::CommandBuffer,
    src: vk::Buffer,
    dst: vk::Image,
    layout: vk::ImageLayout,
    count: u32,
    p_regions: *const vk::BufferImageCopy,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyBufferToImage");
    // SAFETY: `count` regions (the application's contract).
    let regions = unsafe { slice(p_regions, count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let sent = image_buffer_copy(entry, buffer, dst, layout, src, regions, false, false);
        left = regions_left(regions, &sent, narrow_buffer_image);
    });
    let Some(device) = device else { return };
    let Some((count, p_regions)) = to_send(&left, count, p_regions) else {
        return;
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe {
        (device.next.fp_v1_0().cmd_copy_buffer_to_image)(buffer, src, dst, layout, count, p_regions)
    }
}

pub unsafe extern "system" fn cmd_copy_image(
    buffer: vk::CommandBuffer,
    src: vk::Image,
    src_layout: vk::ImageLayout,
    dst: vk::Image,
    dst_layout: vk::ImageLayout,
    count: u32,
    p_regions: *const vk::ImageCopy,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyImage");
    // SAFETY: `count` regions (the application's contract).
    let regions = unsafe { slice(p_regions, count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let next = entry.device.next.fp_v1_0().cmd_copy_image;
        let mut send_first = |first: &[(usize, vk::ImageAspectFlags)]| {
            let first = narrowed(regions, first, narrow_image);
            // SAFETY: the application's command with some of its regions, narrowed to the
            // aspects they copy besides depth.
            unsafe {
                next(
                    buffer,
                    src,
                    src_layout,
                    dst,
                    dst_layout,
                    first.len() as u32,
                    first.as_ptr(),
                )
            };
        };
        let sent = image_image_copy(
            entry,
            buffer,
            src,
            src_layout,
            dst,
            dst_layout,
            regions,
            false,
            &mut send_first,
        );
        left = regions_left(regions, &sent, narrow_image);
    });
    let Some(device) = device else { return };
    let Some((count, p_regions)) = to_send(&left, count, p_regions) else {
        return;
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe {
        (device.next.fp_v1_0().cmd_copy_image)(
            buffer, src, src_layout, dst, dst_layout, count, p_regions,
        )
    }
}

/// A `*2` region as its `1.0` twin, and whether it carries a `pNext` chain.
fn buffer_image_region(region: &vk::BufferImageCopy2<'_>) -> (vk::BufferImageCopy, bool) {
    (
        vk::BufferImageCopy {
            buffer_offset: region.buffer_offset,
            buffer_row_length: region.buffer_row_length,
            buffer_image_height: region.buffer_image_height,
            image_subresource: region.image_subresource,
            image_offset: region.image_offset,
            image_extent: region.image_extent,
        },
        !region.p_next.is_null(),
    )
}

fn image_region(region: &vk::ImageCopy2<'_>) -> (vk::ImageCopy, bool) {
    (
        vk::ImageCopy {
            src_subresource: region.src_subresource,
            src_offset: region.src_offset,
            dst_subresource: region.dst_subresource,
            dst_offset: region.dst_offset,
            extent: region.extent,
        },
        !region.p_next.is_null(),
    )
}

/// The `*2` regions left after a conversion, aspects narrowed like their `1.0` twins.
fn regions2_left<R: Copy>(
    regions: &[R],
    sent: &Sent,
    narrow: impl Fn(&mut R, vk::ImageAspectFlags),
) -> Option<Vec<R>> {
    regions_left(regions, sent, |mut region, aspect| {
        narrow(&mut region, aspect);
        region
    })
}

pub unsafe extern "system" fn cmd_copy_image_to_buffer2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::CopyImageToBufferInfo2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyImageToBuffer2");
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { &*p_info };
    // SAFETY: `regionCount` regions.
    let regions2 = unsafe { slice(info.p_regions, info.region_count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let (regions, chained): (Vec<_>, Vec<_>) = regions2.iter().map(buffer_image_region).unzip();
        let extended = !info.p_next.is_null() || chained.contains(&true);
        let sent = image_buffer_copy(
            entry,
            buffer,
            info.src_image,
            info.src_image_layout,
            info.dst_buffer,
            &regions,
            true,
            extended,
        );
        left = regions2_left(regions2, &sent, |r, aspect| {
            r.image_subresource.aspect_mask = aspect
        });
    });
    let Some(next) = device.and_then(|d| d.commands.copy_image_to_buffer2) else {
        return;
    };
    let narrowed;
    let p_info = match to_send(&left, info.region_count, info.p_regions) {
        None => return,
        Some((region_count, p_regions)) => {
            narrowed = vk::CopyImageToBufferInfo2 {
                region_count,
                p_regions,
                ..*info
            };
            &narrowed as *const _
        }
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe { next(buffer, p_info) }
}

pub unsafe extern "system" fn cmd_copy_buffer_to_image2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::CopyBufferToImageInfo2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyBufferToImage2");
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { &*p_info };
    // SAFETY: `regionCount` regions.
    let regions2 = unsafe { slice(info.p_regions, info.region_count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let (regions, chained): (Vec<_>, Vec<_>) = regions2.iter().map(buffer_image_region).unzip();
        let extended = !info.p_next.is_null() || chained.contains(&true);
        let sent = image_buffer_copy(
            entry,
            buffer,
            info.dst_image,
            info.dst_image_layout,
            info.src_buffer,
            &regions,
            false,
            extended,
        );
        left = regions2_left(regions2, &sent, |r, aspect| {
            r.image_subresource.aspect_mask = aspect
        });
    });
    let Some(next) = device.and_then(|d| d.commands.copy_buffer_to_image2) else {
        return;
    };
    let narrowed;
    let p_info = match to_send(&left, info.region_count, info.p_regions) {
        None => return,
        Some((region_count, p_regions)) => {
            narrowed = vk::CopyBufferToImageInfo2 {
                region_count,
                p_regions,
                ..*info
            };
            &narrowed as *const _
        }
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe { next(buffer, p_info) }
}

pub unsafe extern "system" fn cmd_copy_image2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::CopyImageInfo2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdCopyImage2");
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { &*p_info };
    // SAFETY: `regionCount` regions.
    let regions2 = unsafe { slice(info.p_regions, info.region_count) };
    let mut left = None;
    let narrow = |r: &mut vk::ImageCopy2<'_>, aspect| {
        r.src_subresource.aspect_mask = aspect;
        r.dst_subresource.aspect_mask = aspect;
    };
    let device = with_entry(buffer, &ENTRY, |entry| {
        let (regions, chained): (Vec<_>, Vec<_>) = regions2.iter().map(image_region).unzip();
        let extended = !info.p_next.is_null() || chained.contains(&true);
        let next = entry.device.commands.copy_image2;
        let mut send_first = |first: &[(usize, vk::ImageAspectFlags)]| {
            let Some(next) = next else { return };
            let first = narrowed(regions2, first, |mut region, aspect| {
                narrow(&mut region, aspect);
                region
            });
            let first_info = vk::CopyImageInfo2 {
                region_count: first.len() as u32,
                p_regions: first.as_ptr(),
                ..*info
            };
            // SAFETY: the application's command with some of its regions, narrowed to the
            // aspects they copy besides depth.
            unsafe { next(buffer, &first_info) };
        };
        let sent = image_image_copy(
            entry,
            buffer,
            info.src_image,
            info.src_image_layout,
            info.dst_image,
            info.dst_image_layout,
            &regions,
            extended,
            &mut send_first,
        );
        left = regions2_left(regions2, &sent, narrow);
    });
    let Some(next) = device.and_then(|d| d.commands.copy_image2) else {
        return;
    };
    let narrowed;
    let p_info = match to_send(&left, info.region_count, info.p_regions) {
        None => return,
        Some((region_count, p_regions)) => {
            narrowed = vk::CopyImageInfo2 {
                region_count,
                p_regions,
                ..*info
            };
            &narrowed as *const _
        }
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe { next(buffer, p_info) }
}

fn narrow_blit2(region: &mut vk::ImageBlit2<'_>, aspect: vk::ImageAspectFlags) {
    region.src_subresource.aspect_mask = aspect;
    region.dst_subresource.aspect_mask = aspect;
}

fn narrow_blit(region: vk::ImageBlit, aspect: vk::ImageAspectFlags) -> vk::ImageBlit {
    let mut region = region;
    region.src_subresource.aspect_mask = aspect;
    region.dst_subresource.aspect_mask = aspect;
    region
}

pub unsafe extern "system" fn cmd_blit_image(
    buffer: vk::CommandBuffer,
    src: vk::Image,
    src_layout: vk::ImageLayout,
    dst: vk::Image,
    dst_layout: vk::ImageLayout,
    count: u32,
    p_regions: *const vk::ImageBlit,
    filter: vk::Filter,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBlitImage");
    // SAFETY: `count` regions (the application's contract).
    let regions = unsafe { slice(p_regions, count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let next = entry.device.next.fp_v1_0().cmd_blit_image;
        let mut send_first = |first: &[(usize, vk::ImageAspectFlags)]| {
            let first = narrowed(regions, first, narrow_blit);
            // SAFETY: the application's command with some of its regions, narrowed to the
            // aspects they blit besides depth.
            unsafe {
                next(
                    buffer,
                    src,
                    src_layout,
                    dst,
                    dst_layout,
                    first.len() as u32,
                    first.as_ptr(),
                    filter,
                )
            };
        };
        let sent = image_blit(
            entry,
            buffer,
            src,
            src_layout,
            dst,
            dst_layout,
            regions,
            false,
            &mut send_first,
        );
        left = regions_left(regions, &sent, narrow_blit);
    });
    let Some(device) = device else { return };
    let Some((count, p_regions)) = to_send(&left, count, p_regions) else {
        return;
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe {
        (device.next.fp_v1_0().cmd_blit_image)(
            buffer, src, src_layout, dst, dst_layout, count, p_regions, filter,
        )
    }
}

pub unsafe extern "system" fn cmd_blit_image2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::BlitImageInfo2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBlitImage2");
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { &*p_info };
    // SAFETY: `regionCount` regions.
    let regions2 = unsafe { slice(info.p_regions, info.region_count) };
    let mut left = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let regions: Vec<vk::ImageBlit> = regions2
            .iter()
            .map(|r| vk::ImageBlit {
                src_subresource: r.src_subresource,
                src_offsets: r.src_offsets,
                dst_subresource: r.dst_subresource,
                dst_offsets: r.dst_offsets,
            })
            .collect();
        let extended = !info.p_next.is_null() || regions2.iter().any(|r| !r.p_next.is_null());
        let next = entry.device.commands.blit_image2;
        let mut send_first = |first: &[(usize, vk::ImageAspectFlags)]| {
            let Some(next) = next else { return };
            let first = narrowed(regions2, first, |mut region, aspect| {
                narrow_blit2(&mut region, aspect);
                region
            });
            let first_info = vk::BlitImageInfo2 {
                region_count: first.len() as u32,
                p_regions: first.as_ptr(),
                ..*info
            };
            // SAFETY: the application's command with some of its regions, narrowed to the
            // aspects they blit besides depth.
            unsafe { next(buffer, &first_info) };
        };
        let sent = image_blit(
            entry,
            buffer,
            info.src_image,
            info.src_image_layout,
            info.dst_image,
            info.dst_image_layout,
            &regions,
            extended,
            &mut send_first,
        );
        left = regions2_left(regions2, &sent, narrow_blit2);
    });
    let Some(next) = device.and_then(|d| d.commands.blit_image2) else {
        return;
    };
    let narrowed;
    let p_info = match to_send(&left, info.region_count, info.p_regions) {
        None => return,
        Some((region_count, p_regions)) => {
            narrowed = vk::BlitImageInfo2 {
                region_count,
                p_regions,
                ..*info
            };
            &narrowed as *const _
        }
    };
    // SAFETY: calling down with the application's arguments (its depth regions converted).
    unsafe { next(buffer, p_info) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where a converted blit fails after the application's other aspects went down, what revz
    /// took goes down: each region's aspects but those already sent.
    #[test]
    fn a_failed_blit_sends_what_revz_took() {
        let (d, s) = (vk::ImageAspectFlags::DEPTH, vk::ImageAspectFlags::STENCIL);
        let region = |aspect_mask| vk::ImageBlit {
            src_subresource: vk::ImageSubresourceLayers {
                aspect_mask,
                ..Default::default()
            },
            ..Default::default()
        };
        let regions = [region(d | s), region(s), region(d)];
        // The stencil of the first two went down first.
        assert_eq!(taken_parts(&regions, &[(0, s), (1, s)]), [(0, d), (2, d)]);
        // Stencil taken too (between two formats): everything is left.
        assert_eq!(taken_parts(&regions, &[]), [(0, d | s), (1, s), (2, d)]);
        assert!(names_aspect(regions.iter().map(|r| r.src_subresource), s));
        assert!(!names_aspect(
            std::iter::once(regions[2].src_subresource),
            s
        ));
    }
}
