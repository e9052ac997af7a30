//! Recording one converted copy: header, fill, barrier, dispatch, barrier, drain, and the
//! application's compute state bound again (see the module above for why each step is there).

use ash::vk;

use super::plan::{workgroups, ShaderHeader, HEADER_BYTES};
use super::scratch::CommandCopies;
use crate::policy::Unconverted;
use crate::state::DeviceState;

/// Where the texels come from, into the scratch buffer (offsets in `regions` / `copies` are
/// the scratch buffer's where it is the destination).
#[derive(Debug)]
pub enum Fill<'a> {
    /// `vkCmdCopyImageToBuffer` from the application's image, in its layout.
    Image {
        image: vk::Image,
        layout: vk::ImageLayout,
        regions: &'a [vk::BufferImageCopy],
    },
    /// `vkCmdCopyBuffer` from the application's buffer.
    Buffer {
        buffer: vk::Buffer,
        copies: &'a [vk::BufferCopy],
    },
}

/// Where the converted texels go, out of the scratch buffer.
#[derive(Debug)]
pub enum Drain<'a> {
    /// `vkCmdCopyBufferToImage` into the application's image, in its layout.
    Image {
        image: vk::Image,
        layout: vk::ImageLayout,
        regions: &'a [vk::BufferImageCopy],
    },
    /// `vkCmdCopyBuffer` into the application's buffer.
    Buffer {
        buffer: vk::Buffer,
        copies: &'a [vk::BufferCopy],
    },
}

/// One conversion: `size` scratch bytes (header included), the shader's header, and the two
/// transfers around the dispatch.
#[derive(Debug)]
pub struct Conversion<'a> {
    pub header: ShaderHeader,
    pub size: u64,
    pub fill: Fill<'a>,
    pub drain: Drain<'a>,
}

/// `vkCmdPipelineBarrier` of revz's own barriers (no dependency flags).
///
/// # Safety
/// `buffer` is a command buffer of `device` in the recording state, outside a render pass;
/// the barriers name revz's objects, or the application's image in the layout it is in.
pub(super) unsafe fn pipeline_barrier(
    device: &DeviceState,
    buffer: vk::CommandBuffer,
    (src_stage, dst_stage): (vk::PipelineStageFlags, vk::PipelineStageFlags),
    memory: &[vk::MemoryBarrier<'_>],
    buffers: &[vk::BufferMemoryBarrier<'_>],
    images: &[vk::ImageMemoryBarrier<'_>],
) {
    // SAFETY: the caller's contract; the counts are the slices'.
    unsafe {
        (device.next.fp_v1_0().cmd_pipeline_barrier)(
            buffer,
            src_stage,
            dst_stage,
            vk::DependencyFlags::empty(),
            memory.len() as u32,
            memory.as_ptr(),
            buffers.len() as u32,
            buffers.as_ptr(),
            images.len() as u32,
            images.as_ptr(),
        )
    }
}

/// A layout transition of `range` of `image` on one queue family: the image barriers revz
/// records around its copies, blits and refreshes.
pub(super) fn image_barrier(
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    (old_layout, new_layout): (vk::ImageLayout, vk::ImageLayout),
    (src_access_mask, dst_access_mask): (vk::AccessFlags, vk::AccessFlags),
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier {
        src_access_mask,
        dst_access_mask,
        old_layout,
        new_layout,
        src_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
        dst_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
        image,
        subresource_range: range,
        ..Default::default()
    }
}

/// Records `conversion` into `buffer`; on `Err` nothing was recorded (the caller sends the
/// application's command down as it is).
///
/// # Safety
/// `buffer` must be a command buffer of `device` in the recording state, outside a render
/// pass, and `copies` its scratch.
pub unsafe fn record(
    device: &DeviceState,
    copies: &mut CommandCopies,
    buffer: vk::CommandBuffer,
    conversion: &Conversion<'_>,
) -> Result<(), Unconverted> {
    if !device.copies.fits(conversion.size) {
        return Err(Unconverted::Resources);
    }
    let (layouts, pipeline) = device
        .copies
        .pipeline(
            device.handle,
            &device.next,
            conversion.header.specialization,
        )
        .ok_or(Unconverted::Resources)?;
    let slot = copies
        .slot(device, conversion.size)
        .ok_or(Unconverted::Resources)?;
    let (scratch, set) = (slot.buffer, slot.set);
    let v = device.next.fp_v1_0();
    let scratch_barrier = |src_access, dst_access| vk::BufferMemoryBarrier {
        src_access_mask: src_access,
        dst_access_mask: dst_access,
        src_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
        dst_queue_family_index: vk::QUEUE_FAMILY_IGNORED,
        buffer: scratch,
        offset: 0,
        size: vk::WHOLE_SIZE,
        ..Default::default()
    };
    let barrier = |src_stage, dst_stage, barriers: &[vk::BufferMemoryBarrier<'_>]| {
        // SAFETY: a recording command buffer outside a render pass (the caller's contract);
        // barriers on revz's own buffer.
        unsafe { pipeline_barrier(device, buffer, (src_stage, dst_stage), &[], barriers, &[]) }
    };
    let transfer = vk::PipelineStageFlags::TRANSFER;
    let compute = vk::PipelineStageFlags::COMPUTE_SHADER;
    // Before the first transfer: a command buffer executed again (a secondary run twice, a
    // primary resubmitted) must have read and written the scratch in its last dispatch and
    // drain before this header and fill overwrite it; and the application's barrier before
    // its command may have named only its own stage (`VK_PIPELINE_STAGE_2_BLIT_BIT` before a
    // blit), which the fill's copy is not in: chained from there, the writes it made visible
    // are made visible to the fill.
    let before = vk::MemoryBarrier {
        src_access_mask: vk::AccessFlags::TRANSFER_WRITE | vk::AccessFlags::SHADER_WRITE,
        dst_access_mask: vk::AccessFlags::TRANSFER_READ | vk::AccessFlags::TRANSFER_WRITE,
        ..Default::default()
    };
    // SAFETY: as `barrier` above.
    unsafe {
        pipeline_barrier(
            device,
            buffer,
            (transfer | compute, transfer),
            &[before],
            &[],
            &[],
        )
    };
    let header = conversion.header.to_bytes();
    // SAFETY: as above; the header fits the scratch buffer (`size` includes it).
    unsafe { (v.cmd_update_buffer)(buffer, scratch, 0, HEADER_BYTES, header.as_ptr().cast()) };
    match conversion.fill {
        Fill::Image {
            image,
            layout,
            regions,
        } => {
            // SAFETY: the application's image in the layout it named, regions into the scratch.
            unsafe {
                (v.cmd_copy_image_to_buffer)(
                    buffer,
                    image,
                    layout,
                    scratch,
                    regions.len() as u32,
                    regions.as_ptr(),
                )
            }
        }
        Fill::Buffer {
            buffer: source,
            copies,
        } => {
            // SAFETY: the application's buffer, copies into the scratch.
            unsafe {
                (v.cmd_copy_buffer)(
                    buffer,
                    source,
                    scratch,
                    copies.len() as u32,
                    copies.as_ptr(),
                )
            }
        }
    }
    barrier(
        transfer,
        compute,
        &[scratch_barrier(
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
        )],
    );
    let (x, y) = workgroups(conversion.header.blocks);
    // SAFETY: revz's pipeline and its set; the application's compute state is bound again
    // below.
    unsafe {
        (v.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::COMPUTE, pipeline);
        (v.cmd_bind_descriptor_sets)(
            buffer,
            vk::PipelineBindPoint::COMPUTE,
            layouts.layout,
            0,
            1,
            &set,
            0,
            std::ptr::null(),
        );
        (v.cmd_dispatch)(buffer, x, y, 1);
    }
    barrier(
        compute,
        transfer,
        &[scratch_barrier(
            vk::AccessFlags::SHADER_WRITE,
            vk::AccessFlags::TRANSFER_READ,
        )],
    );
    match conversion.drain {
        Drain::Image {
            image,
            layout,
            regions,
        } => {
            // SAFETY: regions out of the scratch into the application's image, in its layout.
            unsafe {
                (v.cmd_copy_buffer_to_image)(
                    buffer,
                    scratch,
                    image,
                    layout,
                    regions.len() as u32,
                    regions.as_ptr(),
                )
            }
        }
        Drain::Buffer {
            buffer: destination,
            copies,
        } => {
            // SAFETY: copies out of the scratch into the application's buffer.
            unsafe {
                (v.cmd_copy_buffer)(
                    buffer,
                    scratch,
                    destination,
                    copies.len() as u32,
                    copies.as_ptr(),
                )
            }
        }
    }
    // SAFETY: the application's own bindings of this command buffer.
    unsafe { copies.compute.restore(device, buffer) };
    Ok(())
}

/// Records a converted blit: `conversion` (which drains into `staged`, in
/// TRANSFER_DST_OPTIMAL), then the blits from `staged` into the application's destination.
/// `staged_aspects`: every aspect of the staged image's format (its layout transitions name
/// them all).
///
/// # Safety
/// As [`record`]; `staged` is revz's image of the current recording, never used before.
#[allow(clippy::too_many_arguments)]
pub unsafe fn record_blit(
    device: &DeviceState,
    copies: &mut CommandCopies,
    buffer: vk::CommandBuffer,
    conversion: &Conversion<'_>,
    staged: vk::Image,
    staged_aspects: vk::ImageAspectFlags,
    destination: (vk::Image, vk::ImageLayout),
    blits: &[vk::ImageBlit],
) -> Result<(), Unconverted> {
    let v = device.next.fp_v1_0();
    let range = vk::ImageSubresourceRange {
        aspect_mask: staged_aspects,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: vk::REMAINING_ARRAY_LAYERS,
    };
    let transition = |old, new, src_access, dst_access| {
        image_barrier(staged, range, (old, new), (src_access, dst_access))
    };
    let barrier = |image_barrier: vk::ImageMemoryBarrier<'_>| {
        let transfer = vk::PipelineStageFlags::TRANSFER;
        // SAFETY: a recording command buffer outside a render pass; revz's own image.
        unsafe {
            pipeline_barrier(
                device,
                buffer,
                (transfer, transfer),
                &[],
                &[],
                &[image_barrier],
            )
        }
    };
    barrier(transition(
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::AccessFlags::empty(),
        vk::AccessFlags::TRANSFER_WRITE,
    ));
    // SAFETY: the caller's contract.
    unsafe { record(device, copies, buffer, conversion) }?;
    barrier(transition(
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        vk::AccessFlags::TRANSFER_WRITE,
        vk::AccessFlags::TRANSFER_READ,
    ));
    let (image, layout) = destination;
    // SAFETY: the staged image (source format, TRANSFER_SRC) into the application's
    // destination in the layout it named; depth blits are NEAREST.
    unsafe {
        (v.cmd_blit_image)(
            buffer,
            staged,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            image,
            layout,
            blits.len() as u32,
            blits.as_ptr(),
            vk::Filter::NEAREST,
        )
    };
    Ok(())
}
