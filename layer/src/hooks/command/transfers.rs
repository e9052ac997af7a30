//! Clears, copies and blits that write depth images: clear values of reversed images are
//! flipped; copies and blits into reversed images are warned about (not converted yet, #21).

#![allow(clippy::wildcard_imports)]

use super::*;

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
        if entry.state().target() != Target::Reversed {
            return;
        }
        // SAFETY: `count` attachments.
        copies.extend_from_slice(unsafe { slice(p_attachments, count) });
        for clear in &mut copies {
            if clear.aspect_mask.contains(vk::ImageAspectFlags::DEPTH) {
                // SAFETY: a depth clear's value is the depthStencil member.
                unsafe {
                    clear.clear_value.depth_stencil.depth = entry
                        .device
                        .reversed_clear(clear.clear_value.depth_stencil.depth)
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
        let device = &entry.device;
        if device.objects.image_reversed(image) {
            // SAFETY: a valid value (the application's contract).
            let mut value = unsafe { *p_value };
            // SAFETY: `rangeCount` ranges.
            let ranges = unsafe { slice(p_ranges, range_count) };
            let clear = clears_depth(ranges).then_some(value.depth);
            if device.observed.settle(clear) == Convention::Standard {
                value.depth = device.reversed_clear(value.depth);
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

/// Whether an image clear writes depth: a range of the depth aspect (a stencil-only clear
/// leaves depth, and says nothing of its convention).
pub(super) fn clears_depth(ranges: &[vk::ImageSubresourceRange]) -> bool {
    ranges
        .iter()
        .any(|range| range.aspect_mask.contains(vk::ImageAspectFlags::DEPTH))
}

/// Warns once when a transfer writes into a reversed depth image: the values it writes keep
/// the standard convention (not converted yet).
pub(super) fn check_transfer_destination(entry: &CommandBufferEntry, image: vk::Image) {
    static WARNED: std::sync::Once = std::sync::Once::new();
    if entry.device.objects.image_reversed(image) {
        WARNED.call_once(|| {
            log::warn!(
                "a copy or blit writes into reversed depth image {image:?}: the values it writes \
                 keep standard depth (not converted yet)"
            )
        });
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
    if let Some(device) = with_entry(buffer, &ENTRY, |e| check_transfer_destination(e, dst)) {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            (device.next.fp_v1_0().cmd_copy_buffer_to_image)(
                buffer, src, dst, layout, count, p_regions,
            )
        }
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
    if let Some(device) = with_entry(buffer, &ENTRY, |e| check_transfer_destination(e, dst)) {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            (device.next.fp_v1_0().cmd_copy_image)(
                buffer, src, src_layout, dst, dst_layout, count, p_regions,
            )
        }
    }
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
    if let Some(device) = with_entry(buffer, &ENTRY, |e| check_transfer_destination(e, dst)) {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            (device.next.fp_v1_0().cmd_blit_image)(
                buffer, src, src_layout, dst, dst_layout, count, p_regions, filter,
            )
        }
    }
}

/// Defines a hook for a `*2` transfer command: warn when it writes into a reversed image, then
/// call down through whichever name the device has.
macro_rules! transfer2_hook {
    ($name:ident, $entry:literal, $info:ty, $command:ident) => {
        #[doc = concat!("`", $entry, "`.")]
        ///
        /// # Safety
        /// Called by the application with the arguments the Vulkan spec allows.
        pub unsafe extern "system" fn $name(buffer: vk::CommandBuffer, p_info: *const $info) {
            static ENTRY: EntryPoint = EntryPoint::new($entry);
            let device = with_entry(buffer, &ENTRY, |entry| {
                // SAFETY: a valid info (the application's contract).
                check_transfer_destination(entry, unsafe { (*p_info).dst_image })
            });
            if let Some(next) = device.and_then(|d| d.commands.$command) {
                // SAFETY: calling down with the application's arguments.
                unsafe { next(buffer, p_info) }
            }
        }
    };
}

transfer2_hook!(
    cmd_copy_buffer_to_image2,
    "vkCmdCopyBufferToImage2",
    vk::CopyBufferToImageInfo2<'_>,
    copy_buffer_to_image2
);

transfer2_hook!(
    cmd_copy_image2,
    "vkCmdCopyImage2",
    vk::CopyImageInfo2<'_>,
    copy_image2
);

transfer2_hook!(
    cmd_blit_image2,
    "vkCmdBlitImage2",
    vk::BlitImageInfo2<'_>,
    blit_image2
);
