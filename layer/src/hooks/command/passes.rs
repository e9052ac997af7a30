//! Render pass and dynamic rendering instances: where a draw's depth target becomes known
//! (begin, next subpass, end), the attachments' depth, promotion and resolves, and the clear
//! values of reversed attachments.

#![allow(clippy::wildcard_imports)]

use super::*;
use crate::policy::{self, PassTwin};

/// The attachments of a render pass instance: the framebuffer's views, or for an imageless
/// framebuffer those of the begin info.
pub(super) fn attachment_views(
    device: &DeviceState,
    framebuffer: vk::Framebuffer,
    begin_next: *const std::ffi::c_void,
) -> Arc<[vk::ImageView]> {
    if let Some(views) = device.objects.framebuffers.get(&framebuffer) {
        if !views.is_empty() {
            return views;
        }
    }
    // SAFETY: a valid pNext chain (the application's contract).
    match unsafe { chain::find::<vk::RenderPassAttachmentBeginInfo<'_>>(begin_next) } {
        // SAFETY: `attachmentCount` views.
        Some(info) => Arc::from(unsafe { slice(info.p_attachments, info.attachment_count) }),
        None => Arc::from([]),
    }
}

/// What a render pass begin passes down in place of the application's values.
#[derive(Default)]
struct PassBegin {
    /// The clear values, when a reversed depth attachment's was flipped.
    clears: Option<Vec<vk::ClearValue>>,
    /// The twin begun in the application's pass's place: with float depth formats over a
    /// framebuffer of promoted images, with swapped MIN/MAX depth resolves when the resolved
    /// attachment is reversed, or both.
    render_pass: Option<vk::RenderPass>,
    /// The read twins refreshed before the pass begins (`twins::pass_begin_refreshes`).
    refreshes: Vec<crate::depth_copy::twin::Refresh>,
    /// The attachment views the pass may write, noted after those refreshes
    /// (`twins::note_written_views`; only while a twin is alive).
    written: Vec<vk::ImageView>,
}

impl PassBegin {
    /// Records the refreshes before the pass, then notes its attachments as written.
    fn record_refreshes(&self, device: &Option<Down>, buffer: vk::CommandBuffer) {
        if !self.refreshes.is_empty() {
            super::twins::record_refreshes(device, buffer, &self.refreshes);
        }
        if let (false, Some(Down::Tracked(entry))) = (self.written.is_empty(), device) {
            static ENTRY: EntryPoint = EntryPoint::new("render pass writes");
            guarded(
                &ENTRY,
                || super::twins::note_written_views(entry, &self.written),
                || (),
            );
        }
    }

    /// The begin info to pass down: the application's, or a copy with revz's values.
    fn apply<'a>(&'a self, begin: &vk::RenderPassBeginInfo<'a>) -> vk::RenderPassBeginInfo<'a> {
        let mut copy = *begin;
        if let Some(clears) = &self.clears {
            copy.p_clear_values = clears.as_ptr();
        }
        if let Some(render_pass) = self.render_pass {
            copy.render_pass = render_pass;
        }
        copy
    }

    fn changes_anything(&self) -> bool {
        self.clears.is_some() || self.render_pass.is_some()
    }
}

/// Begins a render pass instance: settles its depth resolves, flips the clear values of
/// reversed depth attachments, picks the swapped-resolve twin where its resolved attachment is
/// reversed, records the scope, and enters its first subpass's `contents`.
fn begin_pass(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    begin: &vk::RenderPassBeginInfo<'_>,
    contents: vk::SubpassContents,
) -> PassBegin {
    let device = &entry.device;
    let pass = device.objects.render_passes.get(&begin.render_pass);
    let views = attachment_views(device, begin.framebuffer, begin.p_next);
    let mut out = PassBegin::default();
    // What the pass may write, known or not (noted after its begin refreshes).
    if crate::hooks::descriptors::any_twin(device) {
        out.written = views.to_vec();
    }
    let mut targets = Vec::new();
    let mut reversed_images = Vec::new();
    let mut promoted = false;
    if let Some(pass) = &pass {
        // Ordinary framebuffers were settled at creation; imageless ones only now.
        device.objects.settle_pass_resolves(pass, &views);
        // After the settle: an image it made native is refreshed as native.
        out.refreshes = super::twins::pass_begin_refreshes(entry, pass, &views);
        super::twins::warn_reads_inside(entry, pass, &views);
        let images: Vec<Target> = views
            .iter()
            .map(|&v| device.objects.view_target(v))
            .collect();
        let mut clears: Vec<vk::ClearValue> =
            // SAFETY: `clearValueCount` values.
            unsafe { slice(begin.p_clear_values, begin.clear_value_count) }.to_vec();
        let cleared = |index: usize| pass.depth_cleared.get(index).copied().unwrap_or(false);
        // The first reversed attachment cleared here settles the convention with its value.
        let reversed_clear = clears.iter().enumerate().find_map(|(index, clear)| {
            // SAFETY: a depth attachment's clear value is the depthStencil member.
            let depth = unsafe { clear.depth_stencil.depth };
            policy::clears_reversed(cleared(index), images.get(index).copied()).then_some(depth)
        });
        // The pass commits its reversed attachments (if any) at once.
        device
            .observed
            .committed(policy::pass_committed(&images), reversed_clear);
        targets = images
            .into_iter()
            .map(|target| device.observed.effective(target))
            .collect();
        let remembers = device.remembers_cameras();
        let image_of = |index: usize| {
            views
                .get(index)
                .filter(|_| remembers)
                .and_then(|view| device.objects.views.get(view))
        };
        reversed_images = (0..targets.len())
            .filter(|&index| targets[index] == Target::Reversed)
            .filter_map(image_of)
            .collect();
        let mut changed = false;
        for (index, clear) in clears.iter_mut().enumerate() {
            if policy::clears_reversed(cleared(index), targets.get(index).copied()) {
                // SAFETY: a depth attachment's clear value is the depthStencil member.
                unsafe {
                    clear.depth_stencil.depth =
                        device.reversed_clear_of(image_of(index), clear.depth_stencil.depth)
                };
                changed = true;
            }
        }
        out.clears = changed.then_some(clears);
        // A twin exists only for passes of one subpass; its resolve source was settled above,
        // so a reversed source here resolves into a reversed image.
        let resolved_reversed =
            policy::resolves_reversed(pass.depth_resolves().map(|(source, _)| source), &targets);
        promoted = device
            .objects
            .promoted_framebuffers
            .get(&begin.framebuffer)
            .is_some();
        out.render_pass = pass.twin(PassTwin::choose(
            promoted,
            resolved_reversed,
            pass.swapped_resolve_twin.is_some(),
        ));
    }
    let scope = PassScope {
        handle: begin.render_pass,
        render_pass: pass,
        attachment_targets: targets,
        attachment_views: Some(views),
        subpass: 0,
        promoted,
        reversed_images,
    };
    {
        let mut state = entry.state();
        enter_cameras(device, &mut state, &scope.reversed_images);
        state.set_target(scope.target());
        state.set_complementary_target(complementary_target(device, scope.depth_view()));
        state.set_promoted(scope.promoted_from());
        state.set_reversed_inputs(reads_reversed_inputs(&scope));
        tally_image(entry, &mut state, scope.depth_view());
    }
    let key = subpass_key(&scope);
    *entry.scope() = scope;
    let secondary = contents == vk::SubpassContents::SECONDARY_COMMAND_BUFFERS;
    enter_contents(entry, buffer, secondary, key);
    out
}

pub unsafe extern "system" fn cmd_begin_render_pass(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::RenderPassBeginInfo<'_>,
    contents: vk::SubpassContents,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBeginRenderPass");
    let mut pass_begin = PassBegin::default();
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid begin info (the application's contract).
        pass_begin = begin_pass(entry, buffer, unsafe { &*p_begin }, contents);
    });
    pass_begin.record_refreshes(&device, buffer);
    let Some(down) = device else { return };
    // SAFETY: a valid begin info.
    let replaced = pass_begin.apply(unsafe { &*p_begin });
    let p_begin = if pass_begin.changes_anything() {
        &replaced
    } else {
        p_begin
    };
    // SAFETY: calling down with the application's arguments (clear values flipped, twin pass).
    unsafe { (down.next.fp_v1_0().cmd_begin_render_pass)(buffer, p_begin, contents) };
    settle_down(&Some(down), buffer);
}

pub unsafe extern "system" fn cmd_begin_render_pass2(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::RenderPassBeginInfo<'_>,
    p_subpass_begin: *const vk::SubpassBeginInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBeginRenderPass2");
    let mut pass_begin = PassBegin::default();
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid subpass begin info (the application's contract).
        let contents = unsafe { (*p_subpass_begin).contents };
        // SAFETY: a valid begin info (the application's contract).
        pass_begin = begin_pass(entry, buffer, unsafe { &*p_begin }, contents);
    });
    let Some(next) = device.as_ref().and_then(|d| d.commands.begin_render_pass2) else {
        return;
    };
    pass_begin.record_refreshes(&device, buffer);
    // SAFETY: a valid begin info.
    let replaced = pass_begin.apply(unsafe { &*p_begin });
    let p_begin = if pass_begin.changes_anything() {
        &replaced
    } else {
        p_begin
    };
    // SAFETY: calling down with the application's arguments (clear values flipped, twin pass).
    unsafe { next(buffer, p_begin, p_subpass_begin) };
    settle_down(&device, buffer);
}

/// A subpass or rendering instance begins whose draws are (`secondary`) or are not recorded
/// in secondaries; called before its begin goes down. Where they are, the viewports the
/// application set go down first (secondaries may inherit them, and nothing may be recorded
/// inside such a subpass), unless the subpass being left records secondaries itself; and the
/// depth target is remembered for `pass` (what secondaries without a framebuffer continue).
pub(super) fn enter_contents(
    entry: &CommandBufferEntry,
    buffer: vk::CommandBuffer,
    secondary: bool,
    pass: Option<SecondaryPass>,
) {
    let mut state = entry.state();
    if secondary && state.records_inline() {
        state.flush_viewports_for_secondaries(&mut NextLayer {
            device: &entry.device,
            buffer,
        });
    }
    state.set_secondary_contents(secondary);
    if let (true, false, Some(pass)) = (secondary, entry.secondary, pass) {
        entry
            .device
            .objects
            .remember_secondary_target(pass, state.target(), state.promoted());
    }
}

/// The key a subpass of the current render pass is remembered under.
pub(super) fn subpass_key(scope: &PassScope) -> Option<SecondaryPass> {
    (scope.handle != vk::RenderPass::null())
        .then_some(SecondaryPass::Subpass(scope.handle, scope.subpass as u32))
}

pub(super) fn next_subpass(entry: &CommandBufferEntry, buffer: vk::CommandBuffer, secondary: bool) {
    let device = &entry.device;
    let remembers = device.remembers_cameras();
    // Infinite mode: the subpass ending leaves its depth image the camera of its draws (not
    // restamped at the pass's end with a later subpass's); the next one's image brings its own.
    let leaving = remembers
        .then(|| device.objects.views.get(&entry.scope().depth_view()))
        .flatten();
    if let Some(image) = leaving {
        remember_camera_of(entry, &[image]);
        entry.scope().reversed_images.retain(|&i| i != image);
    }
    let (target, promoted, key, view, reversed_inputs) = {
        let mut scope = entry.scope();
        scope.subpass += 1;
        (
            scope.target(),
            scope.promoted_from(),
            subpass_key(&scope),
            scope.depth_view(),
            reads_reversed_inputs(&scope),
        )
    };
    let entering = remembers.then(|| device.objects.views.get(&view)).flatten();
    {
        let mut state = entry.state();
        if let Some(image) = entering {
            enter_cameras(device, &mut state, &[image]);
        }
        state.set_target(target);
        state.set_complementary_target(complementary_target(device, view));
        state.set_promoted(promoted);
        state.set_reversed_inputs(reversed_inputs);
        tally_image(entry, &mut state, view);
    }
    enter_contents(entry, buffer, secondary, key);
}

/// Infinite mode: whether the depth attachment `view` (null: none) is of an image that stores
/// complementary depth (`DeviceState::stores_complementary`); no lookup in the other modes.
pub(super) fn complementary_target(device: &DeviceState, view: vk::ImageView) -> bool {
    device.remembers_cameras()
        && view != vk::ImageView::null()
        && device
            .objects
            .views
            .get(&view)
            .is_some_and(|image| device.stores_complementary(image))
}

/// Whether the scope's subpass reads a reversed depth image through an input attachment
/// ([`PassScope::depth_inputs`]). A native one read beside a reversed depth attachment is
/// logged once: the reversed variant bound for that attachment converts every depth input
/// read, so that one reads `1 - d`.
pub(super) fn reads_reversed_inputs(scope: &PassScope) -> bool {
    let (reversed, native_beside_reversed) = scope.depth_inputs();
    if native_beside_reversed {
        static MIXED: crate::logging::LogOnce = crate::logging::LogOnce::new();
        MIXED.log(|| {
            log::warn!(
                "a subpass reads a native depth image through an input attachment beside a \
                 reversed depth attachment: its shaders read 1 - d from it (make both images \
                 alike: e.g. neither a storage image)"
            )
        });
    }
    reversed
}

/// Where the device keeps a depth profile: draws from now on are counted as into `view`'s
/// image.
fn tally_image(
    entry: &CommandBufferEntry,
    state: &mut crate::command_state::CommandState,
    view: vk::ImageView,
) {
    if entry.device.profile.is_some() {
        state.tally_image(entry.device.objects.view_image_raw(view));
    }
}

/// Infinite mode: a pass (or a secondary continuing one) begins into reversed images whose
/// draws' camera revz remembers.
pub(super) fn enter_cameras(
    device: &DeviceState,
    state: &mut crate::command_state::CommandState,
    images: &[vk::Image],
) {
    // An image of complementary depth has no camera to enter (its draws map as complementary
    // mode does: `CommandState::set_complementary_target`).
    let camera = images
        .iter()
        .filter(|&&image| !device.stores_complementary(image))
        .find_map(|&image| device.image_camera(image));
    if let Some(near_over_far) = camera {
        state.enter_camera(near_over_far);
    }
}

/// Infinite mode: the n / f the command buffer's draws into the pass's reversed images used
/// (the last projection it learned), remembered for their later clears, copies and refreshes
/// ([`crate::objects::DeviceObjects::near_over_far`]). Nothing where it learned none.
fn remember_cameras(entry: &CommandBufferEntry) {
    if !entry.device.remembers_cameras() {
        return;
    }
    let (mut images, view) = {
        let mut scope = entry.scope();
        (
            std::mem::take(&mut scope.reversed_images),
            scope.depth_view(),
        )
    };
    // The last subpass's depth image (an earlier subpass's stamp was taken at its end).
    if let Some(image) = entry.device.objects.views.get(&view) {
        if !images.contains(&image) {
            images.push(image);
        }
    }
    remember_camera_of(entry, &images);
}

/// [`remember_cameras`] for `images`: only a camera this recording's draws use (learned from
/// a pushed projection, entered from an image, or taken from executed secondaries), never
/// the device's last seen at the begin, which may be another camera's.
fn remember_camera_of(entry: &CommandBufferEntry, images: &[vk::Image]) {
    // Only infinite mode remembers (and the other modes take no lock here).
    if images.is_empty() || !entry.device.remembers_cameras() {
        return;
    }
    let Some(near_over_far) = entry.state().camera() else {
        return;
    };
    let objects = &entry.device.objects;
    for image in images
        .iter()
        .filter(|&&i| !entry.device.stores_complementary(i))
    {
        let known = objects.near_over_far.get(image);
        if !known.is_some_and(|r| crate::command_state::same_near_over_far(r, near_over_far)) {
            objects.near_over_far.insert(*image, near_over_far);
        }
    }
}

pub(super) fn end_pass(entry: &CommandBufferEntry) {
    remember_cameras(entry);
    *entry.scope() = PassScope::default();
    let mut state = entry.state();
    tally_image(entry, &mut state, vk::ImageView::null());
    state.leave_pass();
    state.set_promoted(None);
    state.set_secondary_contents(false);
}

pub unsafe extern "system" fn cmd_next_subpass(
    buffer: vk::CommandBuffer,
    contents: vk::SubpassContents,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdNextSubpass");
    let secondary = contents == vk::SubpassContents::SECONDARY_COMMAND_BUFFERS;
    let down = with_entry(buffer, &ENTRY, |entry| {
        next_subpass(entry, buffer, secondary)
    });
    if let Some(device) = &down {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_next_subpass)(buffer, contents) };
        settle_down(&down, buffer);
    }
}

pub unsafe extern "system" fn cmd_next_subpass2(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::SubpassBeginInfo<'_>,
    p_end: *const vk::SubpassEndInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdNextSubpass2");
    // SAFETY: a valid subpass begin info (the application's contract).
    let contents = unsafe { (*p_begin).contents };
    let secondary = contents == vk::SubpassContents::SECONDARY_COMMAND_BUFFERS;
    let down = with_entry(buffer, &ENTRY, |entry| {
        next_subpass(entry, buffer, secondary)
    });
    if let Some(next) = down.as_ref().and_then(|d| d.commands.next_subpass2) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_begin, p_end) };
        settle_down(&down, buffer);
    }
}

/// The end of a render pass: the read twins of attachments it leaves readable are refreshed
/// right after it (`twins.rs`).
fn ending_pass(entry: &CommandBufferEntry) -> Vec<crate::depth_copy::twin::Refresh> {
    // The refreshes map with the camera of the pass's draws.
    remember_cameras(entry);
    let refreshes = super::twins::pass_end_refreshes(entry);
    end_pass(entry);
    refreshes
}

pub unsafe extern "system" fn cmd_end_render_pass(buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRenderPass");
    super::twins::refreshing(buffer, &ENTRY, ending_pass, |device| {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_end_render_pass)(buffer) };
        true
    });
}

pub unsafe extern "system" fn cmd_end_render_pass2(
    buffer: vk::CommandBuffer,
    p_end: *const vk::SubpassEndInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRenderPass2");
    super::twins::refreshing(buffer, &ENTRY, ending_pass, |device| {
        let Some(next) = device.commands.end_render_pass2 else {
            return false;
        };
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_end) };
        true
    });
}

pub unsafe extern "system" fn cmd_begin_rendering(
    buffer: vk::CommandBuffer,
    p_info: *const vk::RenderingInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBeginRendering");
    // SAFETY: a valid rendering info (the application's contract).
    let info = unsafe { *p_info };
    let mut depth_copy: Option<vk::RenderingAttachmentInfo<'_>> = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: null or valid.
        let depth = unsafe { info.p_depth_attachment.as_ref() };
        let device = &entry.device;
        // The spec pairs the depth and stencil resolve modes only where both attachments have
        // a view (VUID-VkRenderingInfo-pDepthAttachment-06104, -06105); the stencil mode is
        // kept as it is, so the swapped depth mode must pair with it.
        // SAFETY: null or valid.
        let paired_stencil_mode = unsafe { info.p_stencil_attachment.as_ref() }
            .filter(|s| s.image_view != vk::ImageView::null())
            .map(|s| s.resolve_mode);
        let resolve = depth.map(|depth| {
            device
                .resolve_support
                .reversed_resolve(depth.resolve_mode, paired_stencil_mode)
        });
        if let (Some(depth), Some(resolve)) = (depth, resolve) {
            device.objects.settle_depth_resolve(
                depth.image_view,
                depth.resolve_image_view,
                depth.resolve_mode,
                resolve.swappable(),
            );
        }
        let image = depth.map_or(Target::None, |d| device.objects.view_target(d.image_view));
        // The clear of a reversed attachment settles the convention with its value.
        let clear = depth
            .filter(|d| d.load_op == vk::AttachmentLoadOp::CLEAR)
            // SAFETY: a depth attachment's clear value is the depthStencil member.
            .map(|d| unsafe { d.clear_value.depth_stencil.depth });
        let target = device.observed.committed(image, clear);
        let reversed_image = depth
            .filter(|_| target == Target::Reversed && device.remembers_cameras())
            .and_then(|d| device.objects.views.get(&d.image_view));
        if let (Some(depth), Some(resolve), Target::Reversed) = (depth, resolve, target) {
            let mut copy = *depth;
            let cleared = copy.load_op == vk::AttachmentLoadOp::CLEAR;
            if policy::clears_reversed(cleared, Some(target)) {
                // SAFETY: a depth attachment's clear value is the depthStencil member.
                unsafe {
                    copy.clear_value.depth_stencil.depth = device
                        .reversed_clear_of(reversed_image, copy.clear_value.depth_stencil.depth)
                };
            }
            // Settled above: a reversed attachment that still resolves resolves into a
            // reversed image, with a mode revz may swap.
            copy.resolve_mode = resolve.mode(copy.resolve_mode);
            depth_copy = Some(copy);
        }
        // A promoted depth (or stencil) view: draws bind the variants made with float
        // rendering formats.
        // SAFETY: null or valid.
        let stencil = unsafe { info.p_stencil_attachment.as_ref() };
        let promoted = policy::rendering_promoted_from(
            [depth, stencil].into_iter().flatten().map(|a| a.image_view),
            |view| device.objects.view_promoted(view).is_some(),
            |view| device.objects.view_format(view),
        );
        entry.scope().reversed_images = reversed_image.into_iter().collect();
        if crate::hooks::descriptors::any_twin(device) {
            let written: Vec<vk::ImageView> = [depth, stencil]
                .into_iter()
                .flatten()
                .flat_map(|a| [a.image_view, a.resolve_image_view])
                .filter(|&view| view != vk::ImageView::null())
                .collect();
            super::twins::note_written_views(entry, &written);
        }
        {
            let mut state = entry.state();
            if let Some(image) = reversed_image {
                enter_cameras(device, &mut state, &[image]);
            }
            state.set_target(target);
            state.set_complementary_target(
                reversed_image.is_some_and(|image| device.stores_complementary(image)),
            );
            state.set_promoted(promoted);
            tally_image(
                entry,
                &mut state,
                depth.map_or_else(vk::ImageView::null, |d| d.image_view),
            );
        }
        // `VK_RENDERING_CONTENTS_INLINE_BIT_KHR` (maintenance7, nested command buffers):
        // secondaries and inline draws mixed, so state may and must be recorded.
        const CONTENTS_INLINE: vk::RenderingFlags = vk::RenderingFlags::from_raw(0x10);
        let executes = info
            .flags
            .contains(vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS);
        let secondary = executes && !info.flags.contains(CONTENTS_INLINE);
        let key = depth
            .and_then(|d| device.objects.view_format(d.image_view))
            .map(SecondaryPass::Rendering);
        enter_contents(entry, buffer, secondary, key);
        if executes && !secondary && !entry.secondary {
            // Inline draws and secondaries mixed: the secondaries it executes still look up
            // the target by format ([`enter_contents`] remembers it only for secondary-only
            // contents, where nothing else may be recorded).
            if let Some(key) = key {
                let state = entry.state();
                device
                    .objects
                    .remember_secondary_target(key, state.target(), state.promoted());
            }
        }
    });
    let Some(next) = device.as_ref().and_then(|d| d.commands.begin_rendering) else {
        return;
    };
    let flipped;
    let p_info = match &depth_copy {
        Some(depth) => {
            flipped = vk::RenderingInfo {
                p_depth_attachment: depth,
                ..info
            };
            &flipped
        }
        None => p_info,
    };
    // SAFETY: calling down with the application's arguments (depth clear flipped).
    unsafe { next(buffer, p_info) };
    settle_down(&device, buffer);
}

/// `vkCmdEndRendering2KHR` (`VK_KHR_maintenance10`): `vkCmdEndRendering` with an info revz
/// passes down untouched.
pub unsafe extern "system" fn cmd_end_rendering2_khr(
    buffer: vk::CommandBuffer,
    p_info: *const std::ffi::c_void,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRendering2KHR");
    // SAFETY: the caller's arguments.
    unsafe { end_rendering2(buffer, p_info, &ENTRY, |c| c.end_rendering2_khr) }
}

/// `vkCmdEndRendering2EXT` (`VK_EXT_fragment_density_map_offset`): the same.
pub unsafe extern "system" fn cmd_end_rendering2_ext(
    buffer: vk::CommandBuffer,
    p_info: *const std::ffi::c_void,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRendering2EXT");
    // SAFETY: the caller's arguments.
    unsafe { end_rendering2(buffer, p_info, &ENTRY, |c| c.end_rendering2_ext) }
}

/// Ends the rendering instance, then calls down the command `next` names.
///
/// # Safety
/// The arguments of a `vkCmdEndRendering2*` call.
unsafe fn end_rendering2(
    buffer: vk::CommandBuffer,
    p_info: *const std::ffi::c_void,
    entry_point: &'static EntryPoint,
    next: fn(&crate::state::DeviceCommands) -> Option<crate::state::PfnCmdEndRendering2>,
) {
    let device = with_entry(buffer, entry_point, end_pass);
    if let Some(next) = device.and_then(|d| next(&d.commands)) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_info) }
    }
}

pub unsafe extern "system" fn cmd_end_rendering(buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRendering");
    let device = with_entry(buffer, &ENTRY, end_pass);
    if let Some(next) = device.and_then(|d| d.commands.end_rendering) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer) }
    }
}
