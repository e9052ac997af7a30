//! Clears of depth images: clear values of reversed images are flipped. Copies and blits are
//! converted in [`super::copies`]. Resolves go down as they are, their destinations noted as
//! written for read twin refreshes.

#![allow(clippy::wildcard_imports)]

use super::*;
use crate::policy;

pub unsafe extern "system" fn cmd_clear_attachments(
    buffer: vk::CommandBuffer,
    count: u32,
    p_attachments: *const vk::ClearAttachment,
    rect_count: u32,
    p_rects: *const vk::ClearRect,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdClearAttachments");
    let mut copies = Vec::new();
    let device = with_entry(buffer, &ENTRY, |entry| {
        let (target, reversal) = {
            let state = entry.state();
            (state.target(), state.reversal())
        };
        if !policy::attachment_clears_flip(target) {
            return;
        }
        // Inside the pass: the camera its draws use now.
        let near_over_far = match reversal {
            crate::conv::Reversal::Infinite { near_over_far } => near_over_far,
            crate::conv::Reversal::Complementary => 0.0,
        };
        // SAFETY: `count` attachments.
        copies.extend_from_slice(unsafe { slice(p_attachments, count) });
        for clear in &mut copies {
            if policy::flips_attachment_clear(target, clear.aspect_mask) {
                // SAFETY: a depth clear's value is the depthStencil member.
                unsafe {
                    clear.clear_value.depth_stencil.depth = entry
                        .device
                        .policy
                        .reversed_clear_at(clear.clear_value.depth_stencil.depth, near_over_far)
                };
            }
        }
    });
    let Some(device) = device else { return };
    let p_attachments = if copies.is_empty() {
        p_attachments
    } else {
        copies.as_ptr()
    };
    // SAFETY: calling down with the application's arguments (depth values flipped).
    unsafe {
        (device.next.fp_v1_0().cmd_clear_attachments)(
            buffer,
            count,
            p_attachments,
            rect_count,
            p_rects,
        )
    }
}

pub unsafe extern "system" fn cmd_clear_depth_stencil_image(
    buffer: vk::CommandBuffer,
    image: vk::Image,
    layout: vk::ImageLayout,
    p_value: *const vk::ClearDepthStencilValue,
    range_count: u32,
    p_ranges: *const vk::ImageSubresourceRange,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdClearDepthStencilImage");
    let mut flipped: Option<vk::ClearDepthStencilValue> = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        super::twins::note_written_image(entry, image);
        let device = &entry.device;
        if policy::image_clear_considered(device.objects.image_reversed(image)) {
            // SAFETY: a valid value (the application's contract).
            let mut value = unsafe { *p_value };
            // SAFETY: `rangeCount` ranges.
            let ranges = unsafe { slice(p_ranges, range_count) };
            let clear = policy::clears_depth(ranges).then_some(value.depth);
            if device.observed.committed(Target::Reversed, clear) == Target::Reversed {
                value.depth = device.reversed_clear_of(Some(image), value.depth);
                flipped = Some(value);
            }
        }
    });
    let Some(device) = device else { return };
    let p_value = flipped.as_ref().map_or(p_value, |v| v as *const _);
    // SAFETY: calling down with the application's arguments (depth value flipped).
    unsafe {
        (device.next.fp_v1_0().cmd_clear_depth_stencil_image)(
            buffer,
            image,
            layout,
            p_value,
            range_count,
            p_ranges,
        )
    }
}

/// `vkCmdResolveImage`: goes down as it is; its destination is noted as written for read twin
/// refreshes (a depth resolve of `VK_KHR_maintenance10` may write a depth image with one).
pub unsafe extern "system" fn cmd_resolve_image(
    buffer: vk::CommandBuffer,
    src: vk::Image,
    src_layout: vk::ImageLayout,
    dst: vk::Image,
    dst_layout: vk::ImageLayout,
    count: u32,
    p_regions: *const vk::ImageResolve,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdResolveImage");
    let device = with_entry(buffer, &ENTRY, |entry| {
        super::twins::note_written_image(entry, dst);
    });
    let Some(device) = device else { return };
    // SAFETY: calling down with the application's arguments.
    unsafe {
        (device.next.fp_v1_0().cmd_resolve_image)(
            buffer, src, src_layout, dst, dst_layout, count, p_regions,
        )
    }
}

/// `vkCmdResolveImage2`: as [`cmd_resolve_image`].
pub unsafe extern "system" fn cmd_resolve_image2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::ResolveImageInfo2<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdResolveImage2");
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let dst = unsafe { (*p_info).dst_image };
        super::twins::note_written_image(entry, dst);
    });
    let Some(next) = device.and_then(|d| d.commands.resolve_image2) else {
        return;
    };
    // SAFETY: calling down with the application's arguments.
    unsafe { next(buffer, p_info) }
}
