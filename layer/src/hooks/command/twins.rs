//! Refreshes of read twins (issue #39, `crate::depth_copy::twin`): where the application
//! makes a reversed image with a twin readable after it may have been written (an image
//! barrier or `vkCmdWaitEvents` into a layout shaders read, in either synchronization API,
//! outside a render pass; a render pass whose final layout for it is one; a render pass whose
//! first use of it reads it), revz refreshes the twin's subresources right after the command
//! (before it, for a pass's begin). What calls for one is decided in `crate::policy::twins`.

#![allow(clippy::wildcard_imports)]

use super::*;
use crate::depth_copy::plan::{TexelKind, TexelKinds};
use crate::depth_copy::twin::{record_refresh, resolved_range, Refresh};
use crate::policy::twins;

/// The refresh of `image`'s twin over `range`, now in `layout`; `None` for an image without
/// a twin, or an empty range.
fn refresh_of(
    device: &DeviceState,
    image: vk::Image,
    layout: vk::ImageLayout,
    range: vk::ImageSubresourceRange,
    recording: crate::conv::Reversal,
) -> Option<Refresh> {
    let info = device.objects.images.get(&image)?;
    let twin = info.twin?;
    let range = resolved_range(range, &twin)?;
    // A multisampled twin holds float32 depth (`R32_SFLOAT`); a single-sampled one the
    // application's format, or the stored one where the device refused that.
    let kinds = TexelKinds {
        source: TexelKind::of(info.promoted.unwrap_or(info.format))?,
        destination: if twin.multisampled() {
            TexelKind::Float32
        } else {
            TexelKind::of(twin.format)?
        },
    };
    // The image's depth is reversed where revz stores it so after the application's
    // convention; shaders read standard values (`copy_values` concerns copies only).
    let reversed = device.observed.effective(info.depth.target()) == Target::Reversed;
    let map = reversed.then(|| {
        super::copies::depth_map_with(
            device,
            crate::policy::CopyDirection::ToStandard,
            image,
            recording,
        )
    });
    Some(Refresh {
        image,
        layout,
        range,
        twin,
        kinds,
        map,
    })
}

/// Logs once that a twin could not be refreshed.
fn warn_unrefreshed(why: crate::policy::Unconverted) {
    static ONCE: crate::logging::LogOnce = crate::logging::LogOnce::new();
    ONCE.log(|| {
        log::warn!(
            "a read twin is not refreshed ({why}): shaders read what it held before (logged once)"
        )
    });
}

/// Notes that the application's `views` may be written from now on (the attachments of a
/// render pass or rendering instance begun): the next refresh of their twins in this
/// recording covers their subresources again. Nothing while the recording refreshed nothing.
pub(super) fn note_written_views(entry: &CommandBufferEntry, views: &[vk::ImageView]) {
    let mut copies = entry.copies();
    if copies.ledger.is_empty() {
        return;
    }
    let objects = &entry.device.objects;
    for view in views {
        if let Some(twin_view) = objects.twin_views.get(view) {
            copies.ledger.written(twin_view.image, twin_view.range);
        } else if let Some(image) = objects.views.get(view) {
            // A view whose twin view could not be made: all of its image.
            copies.ledger.written_all(image);
        }
    }
}

/// Notes that any subresource of `image` may be written from now on (a transfer into it).
pub(super) fn note_written_image(entry: &CommandBufferEntry, image: vk::Image) {
    let mut copies = entry.copies();
    if !copies.ledger.is_empty() {
        copies.ledger.written_all(image);
    }
}

/// Notes that anything may have been written (secondaries executed).
pub(super) fn note_written_anything(entry: &CommandBufferEntry) {
    entry.copies().ledger.forget();
}

/// Records `refreshes` after the application's command (outside a render pass).
pub(super) fn record_refreshes(
    down: &Option<Down>,
    buffer: vk::CommandBuffer,
    refreshes: &[Refresh],
) {
    static ENTRY: EntryPoint = EntryPoint::new("read twin refresh");
    let Some(Down::Tracked(entry)) = down else {
        return;
    };
    guarded(
        &ENTRY,
        || {
            for refresh in refreshes {
                let mut copies = entry.copies();
                // Only what this recording has not refreshed since it may have written it.
                let Some(range) = copies.ledger.to_refresh(refresh.image, refresh.range) else {
                    continue;
                };
                let narrowed = Refresh { range, ..*refresh };
                let refresh = &narrowed;
                // What refuses a converted copy refuses a refresh (its dispatch could not be
                // recorded, or the application's compute state not bound again after it).
                let refused = if !entry.dispatchable {
                    Some(crate::policy::Unconverted::NoCompute)
                } else if !copies.compute.restorable() {
                    Some(crate::policy::Unconverted::ComputeBindings)
                } else if copies.conditional {
                    Some(crate::policy::Unconverted::Conditional)
                } else {
                    None
                };
                let recorded = match refused {
                    Some(why) => Err(why),
                    // SAFETY: a recording command buffer of this device, outside a render
                    // pass (checked by the callers); its own scratch.
                    None => unsafe { record_refresh(&entry.device, &mut copies, buffer, refresh) },
                };
                match recorded {
                    // Recorded: clean until written again.
                    Ok(true) => copies.ledger.refreshed(
                        refresh.image,
                        refresh.range,
                        (refresh.twin.mip_levels, refresh.twin.array_layers),
                    ),
                    // Nothing to record yet (a multisampled twin whose image has no view).
                    Ok(false) => continue,
                    Err(why) => warn_unrefreshed(why),
                }
                if let Some(profile) = &entry.device.profile {
                    profile.refresh(refresh.image, recorded.is_ok().then(|| refresh.bytes()));
                }
            }
        },
        || (),
    );
}

/// The refreshes `barriers` call for, given as (image, old layout, new layout, range, source
/// and destination access, queue families); none inside a render pass or while no twin is
/// alive.
fn barrier_refreshes(
    entry: &CommandBufferEntry,
    barriers: impl Iterator<
        Item = (
            vk::Image,
            vk::ImageLayout,
            vk::ImageLayout,
            vk::ImageSubresourceRange,
            u64,
            u64,
            (u32, u32),
        ),
    >,
) -> Vec<Refresh> {
    let device = &entry.device;
    // While no twin is alive: one load, no lock.
    if !crate::hooks::descriptors::any_twin(device) {
        return Vec::new();
    }
    let (in_pass, recording) = {
        let state = entry.state();
        (state.in_pass(), state.reversal())
    };
    if in_pass {
        return Vec::new();
    }
    barriers
        .filter(|&(_, old, new, _, src, dst, families)| {
            twins::barrier_refreshes(old, new, src, dst, families)
        })
        .filter_map(|(image, _, new, range, ..)| refresh_of(device, image, new, range, recording))
        .collect()
}

/// The refreshes a legacy image barrier array calls for.
///
/// # Safety
/// `count` valid barriers at `barriers`.
unsafe fn legacy_refreshes(
    entry: &CommandBufferEntry,
    count: u32,
    barriers: *const vk::ImageMemoryBarrier<'_>,
) -> Vec<Refresh> {
    // SAFETY: the caller's contract.
    let barriers = unsafe { slice(barriers, count) };
    barrier_refreshes(
        entry,
        barriers.iter().map(|b| {
            (
                b.image,
                b.old_layout,
                b.new_layout,
                b.subresource_range,
                u64::from(b.src_access_mask.as_raw()),
                u64::from(b.dst_access_mask.as_raw()),
                (b.src_queue_family_index, b.dst_queue_family_index),
            )
        }),
    )
}

/// The refreshes a dependency info (synchronization2) calls for.
///
/// # Safety
/// `info` is a valid dependency info.
unsafe fn dependency_refreshes(
    entry: &CommandBufferEntry,
    info: &vk::DependencyInfo<'_>,
) -> Vec<Refresh> {
    // SAFETY: the caller's contract.
    let barriers = unsafe {
        slice(
            info.p_image_memory_barriers,
            info.image_memory_barrier_count,
        )
    };
    barrier_refreshes(
        entry,
        barriers.iter().map(|b| {
            (
                b.image,
                b.old_layout,
                b.new_layout,
                b.subresource_range,
                b.src_access_mask.as_raw(),
                b.dst_access_mask.as_raw(),
                (b.src_queue_family_index, b.dst_queue_family_index),
            )
        }),
    )
}

/// The refreshes the end of the current render pass calls for: each attachment with a twin
/// the pass leaves readable after it may have written it ([`twins::PassRefresh::at_end`]).
/// Called before the pass's scope is cleared.
pub(super) fn pass_end_refreshes(entry: &CommandBufferEntry) -> Vec<Refresh> {
    let device = &entry.device;
    if !crate::hooks::descriptors::any_twin(device) {
        return Vec::new();
    }
    // Before the scope's lock (the state's is never taken under it).
    let recording = entry.state().reversal();
    let scope = entry.scope();
    let (Some(pass), Some(views)) = (&scope.render_pass, &scope.attachment_views) else {
        return Vec::new();
    };
    attachment_refreshes(device, views, pass, recording, twins::PassMoment::End)
}

/// The refreshes a render pass begin calls for before it goes down: each attachment with a
/// twin that the pass's first use of reads, in a layout it enters from one it may have been
/// written in ([`twins::PassRefresh::at_begin`]): the read-only depth attachment of soft
/// particles, sampled while it is tested. `views`: the begin's attachment views.
pub(super) fn pass_begin_refreshes(
    entry: &CommandBufferEntry,
    pass: &crate::objects::RenderPassInfo,
    views: &[vk::ImageView],
) -> Vec<Refresh> {
    let device = &entry.device;
    // Most passes read no attachment first: no lock then.
    if !crate::hooks::descriptors::any_twin(device)
        || pass
            .twin_refreshes
            .iter()
            .all(|r| r.at(twins::PassMoment::Begin) == [None, None])
    {
        return Vec::new();
    }
    let recording = entry.state().reversal();
    attachment_refreshes(device, views, pass, recording, twins::PassMoment::Begin)
}

/// Logs once where a render pass begins over an image with a twin that a subpass may sample
/// after an earlier subpass wrote it: no refresh can be recorded inside a pass, so such reads
/// see the image as it was when the pass began.
pub(super) fn warn_reads_inside(
    entry: &CommandBufferEntry,
    pass: &crate::objects::RenderPassInfo,
    views: &[vk::ImageView],
) {
    let device = &entry.device;
    if !crate::hooks::descriptors::any_twin(device) {
        return;
    }
    let stale = views
        .iter()
        .zip(&pass.read_after_written_inside)
        .any(|(view, &inside)| inside && device.objects.twin_views.get(view).is_some());
    if stale {
        static ONCE: crate::logging::LogOnce = crate::logging::LogOnce::new();
        ONCE.log(|| {
            log::warn!(
                "a render pass writes a depth image shaders sample in one subpass and may read \
                 it in a later one: shaders sampling it there read its read twin as it was when \
                 the pass began (no refresh can be recorded inside a pass; logged once)"
            )
        });
    }
}

/// The refreshes of the attachments of `pass` (begun over `views`) at `moment`: each view's
/// subresources, in the layout its image is in then (its aspects apart where the stencil has
/// layouts of its own).
fn attachment_refreshes(
    device: &DeviceState,
    views: &[vk::ImageView],
    pass: &crate::objects::RenderPassInfo,
    recording: crate::conv::Reversal,
    moment: twins::PassMoment,
) -> Vec<Refresh> {
    let mut out = Vec::new();
    for (view, refresh) in views.iter().zip(&pass.twin_refreshes) {
        let parts = refresh.at(moment);
        if parts == [None, None] {
            continue;
        }
        let Some(twin_view) = device.objects.twin_views.get(view) else {
            continue;
        };
        for (aspects, layout) in parts.into_iter().flatten() {
            let range = vk::ImageSubresourceRange {
                aspect_mask: twin_view.range.aspect_mask & aspects,
                ..twin_view.range
            };
            if range.aspect_mask.is_empty() {
                continue;
            }
            out.extend(refresh_of(
                device,
                twin_view.image,
                layout,
                range,
                recording,
            ));
        }
    }
    out
}

/// What every refreshing hook does: collects the refreshes `collect` finds (before the
/// command, while the command buffer's state is the one the command meets), sends the
/// command down (`send`; `false` where the device lacks it), then records the refreshes.
pub(super) fn refreshing(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    collect: impl FnOnce(&CommandBufferEntry) -> Vec<Refresh>,
    send: impl FnOnce(&DeviceState) -> bool,
) {
    let mut refreshes = Vec::new();
    let down = with_entry(buffer, entry_point, |entry| refreshes = collect(entry));
    if let Some(device) = &down {
        if send(device) && !refreshes.is_empty() {
            record_refreshes(&down, buffer, &refreshes);
        }
    }
}

#[allow(clippy::too_many_arguments)]
pub unsafe extern "system" fn cmd_pipeline_barrier(
    buffer: vk::CommandBuffer,
    src_stage: vk::PipelineStageFlags,
    dst_stage: vk::PipelineStageFlags,
    dependency: vk::DependencyFlags,
    memory_count: u32,
    p_memory: *const vk::MemoryBarrier<'_>,
    buffer_count: u32,
    p_buffer: *const vk::BufferMemoryBarrier<'_>,
    image_count: u32,
    p_image: *const vk::ImageMemoryBarrier<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPipelineBarrier");
    refreshing(
        buffer,
        &ENTRY,
        // SAFETY: the application's `imageMemoryBarrierCount` barriers.
        |entry| unsafe { legacy_refreshes(entry, image_count, p_image) },
        |device| {
            // SAFETY: calling down with the application's arguments.
            unsafe {
                (device.next.fp_v1_0().cmd_pipeline_barrier)(
                    buffer,
                    src_stage,
                    dst_stage,
                    dependency,
                    memory_count,
                    p_memory,
                    buffer_count,
                    p_buffer,
                    image_count,
                    p_image,
                )
            };
            true
        },
    );
}

pub unsafe extern "system" fn cmd_pipeline_barrier2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::DependencyInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPipelineBarrier2");
    refreshing(
        buffer,
        &ENTRY,
        // SAFETY: a valid dependency info (the application's contract).
        |entry| unsafe { dependency_refreshes(entry, &*p_info) },
        |device| {
            let Some(next) = device.commands.pipeline_barrier2 else {
                return false;
            };
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, p_info) };
            true
        },
    );
}

#[allow(clippy::too_many_arguments)]
pub unsafe extern "system" fn cmd_wait_events(
    buffer: vk::CommandBuffer,
    event_count: u32,
    p_events: *const vk::Event,
    src_stage: vk::PipelineStageFlags,
    dst_stage: vk::PipelineStageFlags,
    memory_count: u32,
    p_memory: *const vk::MemoryBarrier<'_>,
    buffer_count: u32,
    p_buffer: *const vk::BufferMemoryBarrier<'_>,
    image_count: u32,
    p_image: *const vk::ImageMemoryBarrier<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdWaitEvents");
    refreshing(
        buffer,
        &ENTRY,
        // SAFETY: the application's `imageMemoryBarrierCount` barriers.
        |entry| unsafe { legacy_refreshes(entry, image_count, p_image) },
        |device| {
            // SAFETY: calling down with the application's arguments.
            unsafe {
                (device.next.fp_v1_0().cmd_wait_events)(
                    buffer,
                    event_count,
                    p_events,
                    src_stage,
                    dst_stage,
                    memory_count,
                    p_memory,
                    buffer_count,
                    p_buffer,
                    image_count,
                    p_image,
                )
            };
            true
        },
    );
}

pub unsafe extern "system" fn cmd_wait_events2(
    buffer: vk::CommandBuffer,
    event_count: u32,
    p_events: *const vk::Event,
    p_infos: *const vk::DependencyInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdWaitEvents2");
    refreshing(
        buffer,
        &ENTRY,
        |entry| {
            // SAFETY: `eventCount` valid dependency infos (the application's contract).
            let infos = unsafe { slice(p_infos, event_count) };
            infos
                .iter()
                // SAFETY: as above.
                .flat_map(|info| unsafe { dependency_refreshes(entry, info) })
                .collect()
        },
        |device| {
            let Some(next) = device.commands.wait_events2 else {
                return false;
            };
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, event_count, p_events, p_infos) };
            true
        },
    );
}
