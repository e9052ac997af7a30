//! The compute state a depth copy's conversion disturbs, followed so that it can be restored
//! after revz's dispatch: compute descriptor set binds, descriptor buffer offsets and
//! embedded samplers, and pushed descriptors (kept to bind again,
//! `crate::depth_copy::compute_bindings`; binds revz cannot replay refuse later conversions
//! in the recording), and conditional rendering (no conversion inside it). The conversions
//! themselves are in `copies.rs`.

#![allow(clippy::wildcard_imports)]

use super::*;

/// `vkCmdBindDescriptorSets`: compute binds are kept, to be bound again after a conversion's
/// dispatch; graphics binds go straight down.
pub unsafe extern "system" fn cmd_bind_descriptor_sets(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    first_set: u32,
    set_count: u32,
    p_sets: *const vk::DescriptorSet,
    dynamic_offset_count: u32,
    p_dynamic_offsets: *const u32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindDescriptorSets");
    let device = with_entry(buffer, &ENTRY, |entry| {
        if bind_point == vk::PipelineBindPoint::COMPUTE {
            // SAFETY: the counts the application gave.
            let (sets, offsets) = unsafe {
                (
                    slice(p_sets, set_count),
                    slice(p_dynamic_offsets, dynamic_offset_count),
                )
            };
            entry
                .copies()
                .compute
                .bind_sets(layout, first_set, sets, offsets);
        }
    });
    if let Some(device) = device {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            (device.next.fp_v1_0().cmd_bind_descriptor_sets)(
                buffer,
                bind_point,
                layout,
                first_set,
                set_count,
                p_sets,
                dynamic_offset_count,
                p_dynamic_offsets,
            )
        }
    }
}

/// Where a push of descriptors goes, for the compute state revz binds again after its
/// conversions.
#[derive(Clone, Copy)]
enum ComputePush {
    /// Not to the compute bind point.
    None,
    /// To compute set `set` of `layout`: kept.
    Kept(vk::PipelineLayout, u32),
    /// To the compute bind point through a layout given in a `pNext` chain: revz cannot push
    /// it again, and refuses later conversions of the recording.
    Unrestorable,
}

impl ComputePush {
    /// A push of an info (`vkCmdPushDescriptorSet2`, `...WithTemplate2`): its stages, layout,
    /// set and chain.
    fn of_info(
        stages: vk::ShaderStageFlags,
        layout: vk::PipelineLayout,
        set: u32,
        p_next: *const std::ffi::c_void,
    ) -> ComputePush {
        match replayable_compute_info(stages, layout, p_next) {
            None => ComputePush::None,
            Some(false) => ComputePush::Unrestorable,
            Some(true) => ComputePush::Kept(layout, set),
        }
    }
}

/// Whether a `*2` bind command's info (`VK_KHR_maintenance6`) binds compute descriptors
/// (`None`: it does not), and whether revz can replay it as the command's first form: it
/// names its layout and chains nothing (a layout given in the chain, `dynamicPipelineLayout`,
/// cannot be replayed).
fn replayable_compute_info(
    stages: vk::ShaderStageFlags,
    layout: vk::PipelineLayout,
    p_next: *const std::ffi::c_void,
) -> Option<bool> {
    stages
        .contains(vk::ShaderStageFlags::COMPUTE)
        .then(|| layout != vk::PipelineLayout::null() && p_next.is_null())
}

/// What the push-descriptor commands do with writes (`vkCmdPushDescriptorSet`, `...2`): a
/// push to the compute bind point is kept, to be pushed again after a conversion's dispatch
/// (as the writes went down); writes naming views of images with a read twin name the twins'
/// views.
///
/// # Safety
/// `writes` are the application's valid writes.
unsafe fn pushed_writes<'a>(
    entry: &CommandBufferEntry,
    compute: ComputePush,
    writes: &[vk::WriteDescriptorSet<'a>],
) -> Option<crate::hooks::descriptors::PatchedWrites<'a>> {
    let patched = if crate::hooks::descriptors::any_twin(&entry.device) {
        // SAFETY: the caller's contract.
        unsafe { crate::hooks::descriptors::patch_writes(&entry.device, writes) }
    } else {
        None
    };
    match compute {
        ComputePush::None => {}
        ComputePush::Unrestorable => entry.copies().compute.bound_otherwise(),
        ComputePush::Kept(layout, set) => {
            let sent = patched.as_ref().map_or(writes, |p| &p.writes[..]);
            // SAFETY: the application's writes, or revz's patched copies of them.
            unsafe { entry.copies().compute.push_writes(layout, set, sent) };
        }
    }
    patched
}

/// [`pushed_writes`] for the template push commands (`vkCmdPushDescriptorSetWithTemplate`,
/// `...2`): the application's data, copied and patched where it names such views; a push
/// with a compute template is kept as the writes its entries read.
///
/// # Safety
/// `data` is the application's valid data for `template`.
unsafe fn pushed_template_data(
    entry: &CommandBufferEntry,
    template: vk::DescriptorUpdateTemplate,
    compute: ComputePush,
    data: *const std::ffi::c_void,
) -> Option<Vec<u64>> {
    // SAFETY: the caller's contract.
    let patched =
        unsafe { crate::hooks::descriptors::patch_template_data(&entry.device, template, data) };
    if let Some(entries) = entry.device.copies.compute_push_entries(template) {
        let mut copies = entry.copies();
        match compute {
            ComputePush::Kept(layout, set) => {
                let sent = patched
                    .as_ref()
                    .map_or(data.cast::<u8>(), |copy| copy.as_ptr().cast());
                // SAFETY: the application's data for the template, or revz's patched copy.
                unsafe { copies.compute.push_template(layout, set, &entries, sent) };
            }
            ComputePush::None | ComputePush::Unrestorable => copies.compute.bound_otherwise(),
        }
    }
    patched
}

/// `vkCmdPushDescriptorSetKHR`: a compute push is kept, to be pushed again after a
/// conversion's dispatch.
pub unsafe extern "system" fn cmd_push_descriptor_set_khr(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    set: u32,
    count: u32,
    p_writes: *const vk::WriteDescriptorSet<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushDescriptorSetKHR");
    let mut patched = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        let compute = if bind_point == vk::PipelineBindPoint::COMPUTE {
            ComputePush::Kept(layout, set)
        } else {
            ComputePush::None
        };
        // SAFETY: `count` valid writes (the application's contract).
        patched = unsafe { pushed_writes(entry, compute, slice(p_writes, count)) };
    });
    let (count, p_writes) = match &patched {
        Some(patched) => (patched.writes.len() as u32, patched.writes.as_ptr()),
        None => (count, p_writes),
    };
    if let Some(next) = device.and_then(|d| d.commands.push_descriptor_set) {
        // SAFETY: calling down with the application's arguments (its writes naming the read
        // twins' views where they name views of images with one).
        unsafe { next(buffer, bind_point, layout, set, count, p_writes) }
    }
}

/// `vkCmdBindDescriptorSets2` (`VK_KHR_maintenance6`, Vulkan 1.4): a compute bind is kept as
/// `vkCmdBindDescriptorSets`'s, where it names its layout and chains nothing (a layout given
/// in the chain, `dynamicPipelineLayout`, cannot be replayed: later conversions in this
/// recording are refused).
pub unsafe extern "system" fn cmd_bind_descriptor_sets2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::BindDescriptorSetsInfoKHR<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindDescriptorSets2");
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let info = unsafe { &*p_info };
        let Some(replayable) = replayable_compute_info(info.stage_flags, info.layout, info.p_next)
        else {
            return;
        };
        let mut copies = entry.copies();
        if !replayable {
            copies.compute.bound_otherwise();
            return;
        }
        // SAFETY: the counts the application gave.
        let (sets, offsets) = unsafe {
            (
                slice(info.p_descriptor_sets, info.descriptor_set_count),
                slice(info.p_dynamic_offsets, info.dynamic_offset_count),
            )
        };
        copies
            .compute
            .bind_sets(info.layout, info.first_set, sets, offsets);
    });
    if let Some(next) = device.and_then(|d| d.commands.bind_descriptor_sets2) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_info) }
    }
}

/// `vkCmdSetDescriptorBufferOffsetsEXT`: compute offsets are kept, to be set again after a
/// conversion's dispatch (revz's own descriptor set bind makes them invalid; the descriptor
/// buffers the application bound stay bound, as revz binds none). What Zink records for every
/// compute dispatch on a driver with `VK_EXT_descriptor_buffer`, and vkd3d-proton for every
/// dispatch.
pub unsafe extern "system" fn cmd_set_descriptor_buffer_offsets_ext(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    first_set: u32,
    count: u32,
    p_indices: *const u32,
    p_offsets: *const vk::DeviceSize,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDescriptorBufferOffsetsEXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        if bind_point == vk::PipelineBindPoint::COMPUTE {
            // SAFETY: the counts the application gave.
            let (indices, offsets) = unsafe { (slice(p_indices, count), slice(p_offsets, count)) };
            entry
                .copies()
                .compute
                .set_buffer_offsets(layout, first_set, indices, offsets);
        }
    });
    if let Some(next) = device.and_then(|d| d.commands.set_descriptor_buffer_offsets) {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            next(
                buffer, bind_point, layout, first_set, count, p_indices, p_offsets,
            )
        }
    }
}

/// `vkCmdSetDescriptorBufferOffsets2EXT` (`VK_KHR_maintenance6`): compute offsets kept as
/// [`cmd_set_descriptor_buffer_offsets_ext`]'s, where the info names its layout and chains
/// nothing (otherwise later conversions in this recording are refused).
pub unsafe extern "system" fn cmd_set_descriptor_buffer_offsets2_ext(
    buffer: vk::CommandBuffer,
    p_info: *const vk::SetDescriptorBufferOffsetsInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDescriptorBufferOffsets2EXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let info = unsafe { &*p_info };
        let Some(replayable) = replayable_compute_info(info.stage_flags, info.layout, info.p_next)
        else {
            return;
        };
        let mut copies = entry.copies();
        // Replayed in the first form, which the device has where it has this one.
        let commands = &entry.device.commands;
        let replayable = replayable && commands.set_descriptor_buffer_offsets.is_some();
        if !replayable {
            copies.compute.bound_otherwise();
            return;
        }
        // SAFETY: the counts the application gave.
        let (indices, offsets) = unsafe {
            (
                slice(info.p_buffer_indices, info.set_count),
                slice(info.p_offsets, info.set_count),
            )
        };
        copies
            .compute
            .set_buffer_offsets(info.layout, info.first_set, indices, offsets);
    });
    if let Some(next) = device.and_then(|d| d.commands.set_descriptor_buffer_offsets2) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_info) }
    }
}

/// `vkCmdBindDescriptorBufferEmbeddedSamplersEXT`: a compute bind is kept, to be bound again
/// after a conversion's dispatch.
pub unsafe extern "system" fn cmd_bind_descriptor_buffer_embedded_samplers_ext(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    set: u32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindDescriptorBufferEmbeddedSamplersEXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        if bind_point == vk::PipelineBindPoint::COMPUTE {
            entry.copies().compute.bind_embedded_samplers(layout, set);
        }
    });
    if let Some(next) = device.and_then(|d| d.commands.bind_embedded_samplers) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, bind_point, layout, set) }
    }
}

/// `vkCmdBindDescriptorBufferEmbeddedSamplers2EXT` (`VK_KHR_maintenance6`): kept as
/// [`cmd_bind_descriptor_buffer_embedded_samplers_ext`]'s where the info names its layout and
/// chains nothing (otherwise later conversions in this recording are refused).
pub unsafe extern "system" fn cmd_bind_descriptor_buffer_embedded_samplers2_ext(
    buffer: vk::CommandBuffer,
    p_info: *const vk::BindDescriptorBufferEmbeddedSamplersInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindDescriptorBufferEmbeddedSamplers2EXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let info = unsafe { &*p_info };
        let Some(replayable) = replayable_compute_info(info.stage_flags, info.layout, info.p_next)
        else {
            return;
        };
        let mut copies = entry.copies();
        // Replayed in the first form, which the device has where it has this one.
        let replayable = replayable && entry.device.commands.bind_embedded_samplers.is_some();
        if replayable {
            copies.compute.bind_embedded_samplers(info.layout, info.set);
        } else {
            copies.compute.bound_otherwise();
        }
    });
    if let Some(next) = device.and_then(|d| d.commands.bind_embedded_samplers2) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_info) }
    }
}

/// `vkCmdBindDescriptorBuffersEXT`: the offsets set into the buffers bound before are no
/// longer valid, and are not set again after a conversion's dispatch.
pub unsafe extern "system" fn cmd_bind_descriptor_buffers_ext(
    buffer: vk::CommandBuffer,
    count: u32,
    p_infos: *const vk::DescriptorBufferBindingInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindDescriptorBuffersEXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        entry.copies().compute.bind_descriptor_buffers();
    });
    if let Some(next) = device.and_then(|d| d.commands.bind_descriptor_buffers) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, count, p_infos) }
    }
}

/// `vkCmdPushDescriptorSetWithTemplate(KHR)`: a push with a template of the compute bind
/// point is kept as the writes it makes, to be pushed again after a conversion's dispatch.
pub unsafe extern "system" fn cmd_push_descriptor_set_with_template(
    buffer: vk::CommandBuffer,
    template: vk::DescriptorUpdateTemplate,
    layout: vk::PipelineLayout,
    set: u32,
    p_data: *const std::ffi::c_void,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushDescriptorSetWithTemplateKHR");
    let mut patched = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // The template names its bind point (compute or not); the command its layout and set.
        let compute = ComputePush::Kept(layout, set);
        // SAFETY: the application's data for its template.
        patched = unsafe { pushed_template_data(entry, template, compute, p_data) };
    });
    let p_data = patched.as_ref().map_or(p_data, |copy| copy.as_ptr().cast());
    if let Some(next) = device.and_then(|d| d.commands.push_descriptor_set_with_template) {
        // SAFETY: calling down with the application's arguments (its data naming the read
        // twins' views where it names views of images with one).
        unsafe { next(buffer, template, layout, set, p_data) }
    }
}

/// `vkCmdPushDescriptorSet2` (`VK_KHR_maintenance6`): [`cmd_push_descriptor_set_khr`] with its
/// arguments in an info (whose chain goes down as it is).
pub unsafe extern "system" fn cmd_push_descriptor_set2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::PushDescriptorSetInfoKHR<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushDescriptorSet2");
    let mut patched = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let info = unsafe { &*p_info };
        let compute = ComputePush::of_info(info.stage_flags, info.layout, info.set, info.p_next);
        // SAFETY: `descriptorWriteCount` valid writes (the application's contract).
        let writes = unsafe { slice(info.p_descriptor_writes, info.descriptor_write_count) };
        // SAFETY: as above.
        patched = unsafe { pushed_writes(entry, compute, writes) };
    });
    let Some(next) = device.and_then(|d| d.commands.push_descriptor_set2) else {
        return;
    };
    match &patched {
        Some(patched) => {
            // SAFETY: a valid info (the application's contract).
            let info = vk::PushDescriptorSetInfoKHR {
                descriptor_write_count: patched.writes.len() as u32,
                p_descriptor_writes: patched.writes.as_ptr(),
                ..unsafe { *p_info }
            };
            // SAFETY: the application's info, its writes naming the read twins' views where
            // they name views of images with one.
            unsafe { next(buffer, &info) }
        }
        // SAFETY: calling down with the application's arguments.
        None => unsafe { next(buffer, p_info) },
    }
}

/// `vkCmdPushDescriptorSetWithTemplate2` (`VK_KHR_maintenance6`):
/// [`cmd_push_descriptor_set_with_template`] with its arguments in an info.
pub unsafe extern "system" fn cmd_push_descriptor_set_with_template2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::PushDescriptorSetWithTemplateInfoKHR<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushDescriptorSetWithTemplate2");
    let mut patched = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid info (the application's contract).
        let info = unsafe { &*p_info };
        // The template names its bind point; the info its layout and set (or a chain).
        let compute = ComputePush::of_info(
            vk::ShaderStageFlags::COMPUTE,
            info.layout,
            info.set,
            info.p_next,
        );
        let template = info.descriptor_update_template;
        // SAFETY: the application's data for its template.
        patched = unsafe { pushed_template_data(entry, template, compute, info.p_data) };
    });
    let Some(next) = device.and_then(|d| d.commands.push_descriptor_set_with_template2) else {
        return;
    };
    match &patched {
        Some(copy) => {
            // SAFETY: a valid info (the application's contract).
            let info = vk::PushDescriptorSetWithTemplateInfoKHR {
                p_data: copy.as_ptr().cast(),
                ..unsafe { *p_info }
            };
            // SAFETY: the application's info, its data naming the read twins' views where it
            // names views of images with one.
            unsafe { next(buffer, &info) }
        }
        // SAFETY: calling down with the application's arguments.
        None => unsafe { next(buffer, p_info) },
    }
}

/// `vkCmdBeginConditionalRenderingEXT`: conversions are refused until it ends.
pub unsafe extern "system" fn cmd_begin_conditional_rendering(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::ConditionalRenderingBeginInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBeginConditionalRenderingEXT");
    let device = with_entry(buffer, &ENTRY, |entry| entry.copies().conditional = true);
    if let Some(next) = device.and_then(|d| d.commands.begin_conditional_rendering) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_begin) }
    }
}

pub unsafe extern "system" fn cmd_end_conditional_rendering(buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndConditionalRenderingEXT");
    let device = with_entry(buffer, &ENTRY, |entry| entry.copies().conditional = false);
    if let Some(next) = device.and_then(|d| d.commands.end_conditional_rendering) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer) }
    }
}
