//! Command recording hooks: where a draw's depth target is known, the application's depth
//! state is collected, clear values are flipped, and state is emitted before draws.
//!
//! Every hook looks up its command buffer (a thread-local cache hit in the common case); an
//! unknown command buffer is passed down untouched through its device's table.

use std::sync::{Arc, OnceLock};

use ash::vk;

use super::resources::slice;
use crate::boundary::{guarded, EntryPoint};
use crate::chain;
use crate::command_state::{StateSink, Target};
use crate::config::Mode;
use crate::conv::{flip_resolve_mode, DepthBias};
use crate::objects::{self, CommandBufferEntry, PassScope, SecondaryPass};
use crate::policy::{secondary_target, Convention};
use crate::precise::{FoldedPush, Outcome, PushSink, PUSH_CONSTANT_BYTES};
use crate::state::{DeviceState, DispatchKey, DEVICES};

/// The device of a command buffer revz does not track (slow path: the global registry).
fn untracked_device(buffer: vk::CommandBuffer) -> Option<Arc<DeviceState>> {
    // SAFETY: a live command buffer's first word is its device's dispatch table.
    DEVICES.get(unsafe { DispatchKey::of(buffer) })
}

/// Sends emitted state to the next layer.
struct NextLayer<'a> {
    device: &'a DeviceState,
    buffer: vk::CommandBuffer,
}

impl PushSink for NextLayer<'_> {
    fn push_constants(
        &mut self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: &[u8],
    ) {
        // SAFETY: a recording command buffer of this device; `layout` is the one the
        // application last pushed with, and `stages` cover exactly these bytes.
        unsafe {
            (self.device.next.fp_v1_0().cmd_push_constants)(
                self.buffer,
                layout,
                stages,
                offset,
                bytes.len() as u32,
                bytes.as_ptr().cast(),
            )
        }
    }
}

impl StateSink for NextLayer<'_> {
    fn set_viewports(&mut self, first: u32, viewports: &[vk::Viewport]) {
        // SAFETY: a recording command buffer of this device.
        unsafe {
            (self.device.next.fp_v1_0().cmd_set_viewport)(
                self.buffer,
                first,
                viewports.len() as u32,
                viewports.as_ptr(),
            )
        }
    }

    fn set_viewports_with_count(&mut self, viewports: &[vk::Viewport]) {
        if let Some(set) = self.device.commands.set_viewport_with_count {
            // SAFETY: as above.
            unsafe { set(self.buffer, viewports.len() as u32, viewports.as_ptr()) }
        }
    }

    fn set_compare_op(&mut self, op: vk::CompareOp) {
        if let Some(set) = self.device.commands.set_depth_compare_op {
            // SAFETY: as above.
            unsafe { set(self.buffer, op) }
        }
    }

    fn set_bias(&mut self, bias: DepthBias) {
        // SAFETY: as above.
        unsafe {
            (self.device.next.fp_v1_0().cmd_set_depth_bias)(
                self.buffer,
                bias.constant,
                bias.clamp,
                bias.slope,
            )
        }
    }

    fn set_bounds(&mut self, min: f32, max: f32) {
        // SAFETY: as above.
        unsafe { (self.device.next.fp_v1_0().cmd_set_depth_bounds)(self.buffer, min, max) }
    }

    fn set_clip_negative_one_to_one(&mut self, negative_one_to_one: bool) {
        // Only sent where the application set it, so the device has the command.
        if let Some(set) = self.device.commands.set_depth_clip_negative_one_to_one {
            // SAFETY: as above.
            unsafe { set(self.buffer, negative_one_to_one.into()) }
        }
    }

    fn bind_pipeline(&mut self, pipeline: vk::Pipeline) {
        // SAFETY: as above; a live pipeline (the application's, or its variant, destroyed
        // with it).
        unsafe {
            (self.device.next.fp_v1_0().cmd_bind_pipeline)(
                self.buffer,
                vk::PipelineBindPoint::GRAPHICS,
                pipeline,
            )
        }
    }

    fn bind_fragment_shader(&mut self, shader: vk::ShaderEXT) {
        // Only shader objects of this device get here, so it has the command.
        if let Some(bind) = self.device.commands.bind_shaders_ext {
            // SAFETY: as above; a live shader object (the application's, or its variant,
            // destroyed with it) of the fragment stage.
            unsafe { bind(self.buffer, 1, &vk::ShaderStageFlags::FRAGMENT, &shader) }
        }
    }
}

/// Emits pending depth state before a draw.
#[inline]
fn before_draw(entry: &CommandBufferEntry, buffer: vk::CommandBuffer) {
    let mut sink = NextLayer {
        device: &entry.device,
        buffer,
    };
    let mut state = entry.state();
    let outcome = state.before_draw(&mut sink);
    drop(state);
    if let Some(outcome) = outcome {
        observe(&entry.device, &outcome);
    }
}

/// What a classified projection tells about the application.
fn observe(device: &DeviceState, outcome: &Outcome) {
    match outcome {
        Outcome::Rewritten { near_over_far, .. } => {
            device.observed.note_projection(false);
            // Only infinite mode maps clears and flip-path state with n / f.
            if device.policy.mode == Mode::Infinite {
                device.observed.note_near_over_far(*near_over_far)
            }
        }
        Outcome::AlreadyReversed => device.observed.note_projection(true),
        Outcome::Unchanged => {}
    }
}

/// `vkCmdPushConstants`: the values go into the command buffer's shadow copy, where the bound
/// pipeline's projection is classified (`crate::precise`), and down as they are, or extended to
/// revz's carrier when its value changes with this push (one call instead of two).
pub unsafe extern "system" fn cmd_push_constants(
    buffer: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    stages: vk::ShaderStageFlags,
    offset: u32,
    size: u32,
    p_values: *const std::ffi::c_void,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushConstants");
    record_then_call(
        buffer,
        &ENTRY,
        |entry| {
            // SAFETY: `size` bytes of values (the application's contract).
            let values = unsafe { slice(p_values.cast::<u8>(), size) };
            follow_push(entry, layout, stages, offset, values)
        },
        None,
        |device, folded: Option<FoldedPush>| {
            let (offset, size, p_sent) = match &folded {
                Some(f) => (f.offset, f.size, f.bytes.as_ptr().cast()),
                None => (offset, size, p_values),
            };
            // SAFETY: calling down with the application's arguments (its values extended to
            // the carrier's bytes, which the layout's range of `stages` holds).
            unsafe {
                (device.next.fp_v1_0().cmd_push_constants)(
                    buffer, layout, stages, offset, size, p_sent,
                )
            }
        },
    );
}

/// Follows a push of the application's: the shadow copy and the outcome for the bound
/// pipeline's projection; returns the push to send in its place, if the carrier goes with it.
fn follow_push(
    entry: &CommandBufferEntry,
    layout: vk::PipelineLayout,
    stages: vk::ShaderStageFlags,
    offset: u32,
    values: &[u8],
) -> Option<FoldedPush> {
    let mut state = entry.state();
    let (outcome, folded) = state.push_constants(layout, stages, offset, values);
    drop(state);
    if let Some(outcome) = outcome {
        observe(&entry.device, &outcome);
    }
    folded
}

/// `vkCmdPushConstants2` (Vulkan 1.4) and `vkCmdPushConstants2KHR`: followed like
/// `vkCmdPushConstants` when it names a layout.
pub unsafe extern "system" fn cmd_push_constants2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::PushConstantsInfoKHR<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdPushConstants2");
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { *p_info };
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: `size` bytes of values.
        let values = unsafe { slice(info.p_values.cast::<u8>(), info.size) };
        if info.layout == vk::PipelineLayout::null() || values.len() > PUSH_CONSTANT_BYTES {
            // A layout given through pNext, or an unusually large push: not followed; the
            // state is forgotten so that no carrier is assumed to survive it.
            entry.state().invalidate();
            return;
        }
        // Followed, never extended (the draw sends the carrier): this command is rare.
        if follow_push(entry, info.layout, info.stage_flags, info.offset, values).is_some() {
            entry.state().unfold();
        }
    });
    let Some(next) = device.as_ref().and_then(|d| d.commands.push_constants2) else {
        return;
    };
    // SAFETY: calling down with the application's arguments.
    unsafe { next(buffer, p_info) }
}

/// The per-draw-rate hook shape (draws, pushes, binds): `record` runs on the command buffer's
/// entry (a thread-local cache hit, no reference count taken; a panic in it is caught and gives
/// `fallback`), then `call` goes down through the entry's device with what `record` returned.
/// An untracked command buffer is only called down, with `fallback`.
#[inline]
fn record_then_call<T: Copy>(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    record: impl FnOnce(&CommandBufferEntry) -> T,
    fallback: T,
    call: impl Fn(&DeviceState, T),
) {
    let tracked = objects::with_command_buffer(buffer, |entry| {
        let recorded = guarded(entry_point, || record(entry), || fallback);
        call(&entry.device, recorded);
    });
    if tracked.is_none() {
        if let Some(device) = untracked_device(buffer) {
            call(&device, fallback);
        }
    }
}

/// Defines a draw hook: emit pending state, then call down. A draw with no state change costs
/// a thread-local lookup, an uncontended lock and a flag check.
macro_rules! draw_hook {
    ($name:ident, $entry:literal, $($arg:ident: $ty:ty),* => |$device:ident| $next:expr) => {
        #[doc = concat!("`", $entry, "`.")]
        ///
        /// # Safety
        /// Called by the application with the arguments the Vulkan spec allows.
        pub unsafe extern "system" fn $name(buffer: vk::CommandBuffer, $($arg: $ty),*) {
            static ENTRY: EntryPoint = EntryPoint::new($entry);
            record_then_call(
                buffer,
                &ENTRY,
                |entry| before_draw(entry, buffer),
                (),
                |$device: &DeviceState, ()| {
                    let next = $next;
                    // SAFETY: calling down with the application's arguments.
                    unsafe { next(buffer, $($arg),*) }
                },
            );
        }
    };
}

draw_hook!(cmd_draw, "vkCmdDraw", a: u32, b: u32, c: u32, d: u32
    => |device| device.next.fp_v1_0().cmd_draw);
draw_hook!(cmd_draw_indexed, "vkCmdDrawIndexed", a: u32, b: u32, c: u32, d: i32, e: u32
    => |device| device.next.fp_v1_0().cmd_draw_indexed);
draw_hook!(cmd_draw_indirect, "vkCmdDrawIndirect", a: vk::Buffer, b: vk::DeviceSize, c: u32, d: u32
    => |device| device.next.fp_v1_0().cmd_draw_indirect);
draw_hook!(cmd_draw_indexed_indirect, "vkCmdDrawIndexedIndirect",
    a: vk::Buffer, b: vk::DeviceSize, c: u32, d: u32
    => |device| device.next.fp_v1_0().cmd_draw_indexed_indirect);
draw_hook!(cmd_draw_indirect_count, "vkCmdDrawIndirectCount",
    a: vk::Buffer, b: vk::DeviceSize, c: vk::Buffer, d: vk::DeviceSize, e: u32, f: u32
    => |device| match device.commands.draw_indirect_count { Some(f) => f, None => return });
draw_hook!(cmd_draw_indexed_indirect_count, "vkCmdDrawIndexedIndirectCount",
    a: vk::Buffer, b: vk::DeviceSize, c: vk::Buffer, d: vk::DeviceSize, e: u32, f: u32
    => |device| match device.commands.draw_indexed_indirect_count { Some(f) => f, None => return });

// Extension draws: the device has them only when the application enabled the extension.
draw_hook!(cmd_draw_mesh_tasks_ext, "vkCmdDrawMeshTasksEXT", a: u32, b: u32, c: u32
    => |device| match device.commands.draw_mesh_tasks_ext { Some(f) => f, None => return });
draw_hook!(cmd_draw_mesh_tasks_indirect_ext, "vkCmdDrawMeshTasksIndirectEXT",
    a: vk::Buffer, b: vk::DeviceSize, c: u32, d: u32
    => |device| match device.commands.draw_mesh_tasks_indirect_ext { Some(f) => f, None => return });
draw_hook!(cmd_draw_mesh_tasks_indirect_count_ext, "vkCmdDrawMeshTasksIndirectCountEXT",
    a: vk::Buffer, b: vk::DeviceSize, c: vk::Buffer, d: vk::DeviceSize, e: u32, f: u32
    => |device| match device.commands.draw_mesh_tasks_indirect_count_ext { Some(f) => f, None => return });
draw_hook!(cmd_draw_mesh_tasks_nv, "vkCmdDrawMeshTasksNV", a: u32, b: u32
    => |device| match device.commands.draw_mesh_tasks_nv { Some(f) => f, None => return });
draw_hook!(cmd_draw_mesh_tasks_indirect_nv, "vkCmdDrawMeshTasksIndirectNV",
    a: vk::Buffer, b: vk::DeviceSize, c: u32, d: u32
    => |device| match device.commands.draw_mesh_tasks_indirect_nv { Some(f) => f, None => return });
draw_hook!(cmd_draw_multi_ext, "vkCmdDrawMultiEXT",
    a: u32, b: *const vk::MultiDrawInfoEXT, c: u32, d: u32, e: u32
    => |device| match device.commands.draw_multi_ext { Some(f) => f, None => return });
draw_hook!(cmd_draw_multi_indexed_ext, "vkCmdDrawMultiIndexedEXT",
    a: u32, b: *const vk::MultiDrawIndexedInfoEXT, c: u32, d: u32, e: u32, f: *const i32
    => |device| match device.commands.draw_multi_indexed_ext { Some(f) => f, None => return });
draw_hook!(cmd_draw_indirect_byte_count_ext, "vkCmdDrawIndirectByteCountEXT",
    a: u32, b: u32, c: vk::Buffer, d: vk::DeviceSize, e: u32, f: u32
    => |device| match device.commands.draw_indirect_byte_count_ext { Some(f) => f, None => return });

draw_hook!(cmd_draw_mesh_tasks_indirect_count_nv, "vkCmdDrawMeshTasksIndirectCountNV",
    a: vk::Buffer, b: vk::DeviceSize, c: vk::Buffer, d: vk::DeviceSize, e: u32, f: u32
    => |device| match device.commands.draw_mesh_tasks_indirect_count_nv { Some(f) => f, None => return });
draw_hook!(cmd_draw_cluster_huawei, "vkCmdDrawClusterHUAWEI", a: u32, b: u32, c: u32
    => |device| match device.commands.draw_cluster_huawei { Some(f) => f, None => return });
draw_hook!(cmd_draw_cluster_indirect_huawei, "vkCmdDrawClusterIndirectHUAWEI",
    a: vk::Buffer, b: vk::DeviceSize
    => |device| match device.commands.draw_cluster_indirect_huawei { Some(f) => f, None => return });
draw_hook!(cmd_execute_generated_commands_nv, "vkCmdExecuteGeneratedCommandsNV",
    a: vk::Bool32, b: *const vk::GeneratedCommandsInfoNV<'_>
    => |device| match device.commands.execute_generated_commands_nv { Some(f) => f, None => return });
// Not in ash 0.38 (Vulkan 1.3.281): declared in `crate::ffi`. Pending state is sent as for any
// draw; pipelines or shaders an indirect execution set switches to are not seen by revz.
draw_hook!(cmd_execute_generated_commands_ext, "vkCmdExecuteGeneratedCommandsEXT",
    a: vk::Bool32, b: *const std::ffi::c_void
    => |device| match device.commands.execute_generated_commands_ext { Some(f) => f, None => return });

/// The device a hook calls down to. For a tracked command buffer it is reached through the
/// command buffer's entry, whose reference count only the recording thread touches; cloning
/// the device's own `Arc` on every command would make all recording threads contend on it.
pub(super) enum Down {
    Tracked(Arc<CommandBufferEntry>),
    Untracked(Arc<DeviceState>),
}

impl std::ops::Deref for Down {
    type Target = DeviceState;

    fn deref(&self) -> &DeviceState {
        match self {
            Down::Tracked(entry) => &entry.device,
            Down::Untracked(device) => device,
        }
    }
}

/// Looks up a command buffer for a state-recording hook; returns the device to call down to.
pub(super) fn with_entry(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    record: impl FnOnce(&CommandBufferEntry),
) -> Option<Down> {
    match objects::command_buffer(buffer) {
        Some(entry) => {
            guarded(entry_point, || record(&entry), || ());
            Some(Down::Tracked(entry))
        }
        None => untracked_device(buffer).map(Down::Untracked),
    }
}

/// Whether the command buffer's state machine took the call (then it is emitted at draw time
/// and must not go down now).
fn recorded(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    record: impl FnOnce(&CommandBufferEntry),
) -> Result<(), Option<Down>> {
    match objects::command_buffer(buffer) {
        Some(entry) => {
            let taken = guarded(
                entry_point,
                || {
                    record(&entry);
                    true
                },
                || false,
            );
            if taken {
                Ok(())
            } else {
                Err(Some(Down::Tracked(entry)))
            }
        }
        None => Err(untracked_device(buffer).map(Down::Untracked)),
    }
}

pub unsafe extern "system" fn cmd_set_viewport(
    buffer: vk::CommandBuffer,
    first: u32,
    count: u32,
    p_viewports: *const vk::Viewport,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetViewport");
    let taken = recorded(buffer, &ENTRY, |entry| {
        // SAFETY: `count` viewports.
        entry
            .state()
            .set_viewports(first, unsafe { slice(p_viewports, count) });
    });
    if let Err(Some(device)) = taken {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_set_viewport)(buffer, first, count, p_viewports) }
    }
}

pub unsafe extern "system" fn cmd_set_viewport_with_count(
    buffer: vk::CommandBuffer,
    count: u32,
    p_viewports: *const vk::Viewport,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetViewportWithCount");
    let taken = recorded(buffer, &ENTRY, |entry| {
        // SAFETY: `count` viewports.
        entry
            .state()
            .set_viewports_with_count(unsafe { slice(p_viewports, count) });
    });
    if let Err(Some(device)) = taken {
        if let Some(next) = device.commands.set_viewport_with_count {
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, count, p_viewports) }
        }
    }
}

pub unsafe extern "system" fn cmd_set_depth_compare_op(
    buffer: vk::CommandBuffer,
    op: vk::CompareOp,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthCompareOp");
    let taken = recorded(buffer, &ENTRY, |entry| {
        entry.device.observed.note_dynamic_compare_op(op);
        entry.state().set_compare_op(op)
    });
    if let Err(Some(device)) = taken {
        if let Some(next) = device.commands.set_depth_compare_op {
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, op) }
        }
    }
}

/// `vkCmdSetDepthClipNegativeOneToOneEXT`: followed like the other depth states, and sent at
/// the draw (a draw whose vertex stage converts a [-1, 1] line gets [0, 1]).
pub unsafe extern "system" fn cmd_set_depth_clip_negative_one_to_one(
    buffer: vk::CommandBuffer,
    negative_one_to_one: vk::Bool32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthClipNegativeOneToOneEXT");
    let taken = recorded(buffer, &ENTRY, |entry| {
        entry
            .state()
            .set_clip_negative_one_to_one(negative_one_to_one == vk::TRUE)
    });
    if let Err(Some(device)) = taken {
        if let Some(next) = device.commands.set_depth_clip_negative_one_to_one {
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, negative_one_to_one) }
        }
    }
}

pub unsafe extern "system" fn cmd_set_depth_bias(
    buffer: vk::CommandBuffer,
    constant: f32,
    clamp: f32,
    slope: f32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthBias");
    let bias = DepthBias {
        constant,
        clamp,
        slope,
    };
    let taken = recorded(buffer, &ENTRY, |entry| entry.state().set_bias(bias));
    if let Err(Some(device)) = taken {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_set_depth_bias)(buffer, constant, clamp, slope) }
    }
}

pub unsafe extern "system" fn cmd_set_depth_bounds(buffer: vk::CommandBuffer, min: f32, max: f32) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthBounds");
    let taken = recorded(buffer, &ENTRY, |entry| entry.state().set_bounds(min, max));
    if let Err(Some(device)) = taken {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_set_depth_bounds)(buffer, min, max) }
    }
}

pub unsafe extern "system" fn cmd_bind_pipeline(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    pipeline: vk::Pipeline,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindPipeline");
    record_then_call(
        buffer,
        &ENTRY,
        |entry| {
            if bind_point == vk::PipelineBindPoint::GRAPHICS {
                let depth = entry.device.objects.pipelines.get(&pipeline);
                entry.state().bind_pipeline(depth);
            }
        },
        (),
        |device, ()| {
            // SAFETY: calling down with the application's arguments.
            unsafe { (device.next.fp_v1_0().cmd_bind_pipeline)(buffer, bind_point, pipeline) }
        },
    );
}

/// `vkCmdBindShadersEXT`: with shader objects every piece of state is dynamic, so revz emits
/// whatever the application set. The shader bound to the fragment stage is recorded, so that
/// draws into reversed attachments bind its reversed variant (`super::shader_object`).
pub unsafe extern "system" fn cmd_bind_shaders_ext(
    buffer: vk::CommandBuffer,
    count: u32,
    p_stages: *const vk::ShaderStageFlags,
    p_shaders: *const vk::ShaderEXT,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindShadersEXT");
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: `count` stages, and `count` shaders unless null (then every stage is
        // unbound).
        let stages = unsafe { slice(p_stages, count) };
        let fragment = stages
            .iter()
            .position(|&stage| stage == vk::ShaderStageFlags::FRAGMENT)
            .map(|index| {
                let shader = if p_shaders.is_null() {
                    vk::ShaderEXT::null()
                } else {
                    // SAFETY: as above; `index` is below `count`.
                    unsafe { *p_shaders.add(index) }
                };
                let depth = (shader != vk::ShaderEXT::null())
                    .then(|| entry.device.objects.fragment_shaders.get(&shader))
                    .flatten();
                (shader, depth)
            });
        entry.state().bind_shaders(fragment)
    });
    if let Some(next) = device.and_then(|d| d.commands.bind_shaders_ext) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, count, p_stages, p_shaders) }
    }
}

/// The attachments of a render pass instance: the framebuffer's views, or for an imageless
/// framebuffer those of the begin info.
fn attachment_views(
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
}

impl PassBegin {
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
    let mut targets = Vec::new();
    let mut promoted = false;
    if let Some(pass) = &pass {
        // Ordinary framebuffers were settled at creation; imageless ones only now.
        device.objects.settle_pass_resolves(pass, &views);
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
            (cleared(index) && images.get(index) == Some(&Target::Reversed)).then_some(depth)
        });
        if images.contains(&Target::Reversed) {
            device.observed.settle(reversed_clear);
        }
        targets = images
            .into_iter()
            .map(|target| device.observed.effective(target))
            .collect();
        let mut changed = false;
        for (index, clear) in clears.iter_mut().enumerate() {
            if cleared(index) && targets.get(index) == Some(&Target::Reversed) {
                // SAFETY: a depth attachment's clear value is the depthStencil member.
                unsafe {
                    clear.depth_stencil.depth = device.reversed_clear(clear.depth_stencil.depth)
                };
                changed = true;
            }
        }
        out.clears = changed.then_some(clears);
        // A twin exists only for passes of one subpass; its resolve source was settled above,
        // so a reversed source here resolves into a reversed image.
        let resolved_reversed = pass
            .depth_resolves()
            .any(|(source, _)| targets.get(source as usize) == Some(&Target::Reversed));
        promoted = device
            .objects
            .promoted_framebuffers
            .get(&begin.framebuffer)
            .is_some();
        out.render_pass = pass.twin(promoted, resolved_reversed);
    }
    let scope = PassScope {
        handle: begin.render_pass,
        render_pass: pass,
        attachment_targets: targets,
        subpass: 0,
        promoted,
    };
    {
        let mut state = entry.state();
        state.set_target(scope.target());
        state.set_promoted(scope.promoted_from());
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
    let Some(device) = device else { return };
    // SAFETY: a valid begin info.
    let replaced = pass_begin.apply(unsafe { &*p_begin });
    let p_begin = if pass_begin.changes_anything() {
        &replaced
    } else {
        p_begin
    };
    // SAFETY: calling down with the application's arguments (clear values flipped, twin pass).
    unsafe { (device.next.fp_v1_0().cmd_begin_render_pass)(buffer, p_begin, contents) }
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
    let Some(next) = device.and_then(|d| d.commands.begin_render_pass2) else {
        return;
    };
    // SAFETY: a valid begin info.
    let replaced = pass_begin.apply(unsafe { &*p_begin });
    let p_begin = if pass_begin.changes_anything() {
        &replaced
    } else {
        p_begin
    };
    // SAFETY: calling down with the application's arguments (clear values flipped, twin pass).
    unsafe { next(buffer, p_begin, p_subpass_begin) }
}

/// A subpass or rendering instance begins whose draws are (`secondary`) or are not recorded
/// in secondaries; called before its begin goes down. Where they are, the viewports the
/// application set go down first (secondaries may inherit them, and nothing may be recorded
/// inside such a subpass), unless the subpass being left records secondaries itself; and the
/// depth target is remembered for `pass` (what secondaries without a framebuffer continue).
fn enter_contents(
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
fn subpass_key(scope: &PassScope) -> Option<SecondaryPass> {
    (scope.handle != vk::RenderPass::null())
        .then_some(SecondaryPass::Subpass(scope.handle, scope.subpass as u32))
}

fn next_subpass(entry: &CommandBufferEntry, buffer: vk::CommandBuffer, secondary: bool) {
    let (target, promoted, key) = {
        let mut scope = entry.scope();
        scope.subpass += 1;
        (scope.target(), scope.promoted_from(), subpass_key(&scope))
    };
    {
        let mut state = entry.state();
        state.set_target(target);
        state.set_promoted(promoted);
    }
    enter_contents(entry, buffer, secondary, key);
}

fn end_pass(entry: &CommandBufferEntry) {
    *entry.scope() = PassScope::default();
    let mut state = entry.state();
    state.set_target(Target::None);
    state.set_promoted(None);
    state.set_secondary_contents(false);
}

pub unsafe extern "system" fn cmd_next_subpass(
    buffer: vk::CommandBuffer,
    contents: vk::SubpassContents,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdNextSubpass");
    let secondary = contents == vk::SubpassContents::SECONDARY_COMMAND_BUFFERS;
    if let Some(device) = with_entry(buffer, &ENTRY, |entry| {
        next_subpass(entry, buffer, secondary)
    }) {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_next_subpass)(buffer, contents) }
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
    if let Some(next) = with_entry(buffer, &ENTRY, |entry| {
        next_subpass(entry, buffer, secondary)
    })
    .and_then(|d| d.commands.next_subpass2)
    {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_begin, p_end) }
    }
}

pub unsafe extern "system" fn cmd_end_render_pass(buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRenderPass");
    if let Some(device) = with_entry(buffer, &ENTRY, end_pass) {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_end_render_pass)(buffer) }
    }
}

pub unsafe extern "system" fn cmd_end_render_pass2(
    buffer: vk::CommandBuffer,
    p_end: *const vk::SubpassEndInfo<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRenderPass2");
    if let Some(next) =
        with_entry(buffer, &ENTRY, end_pass).and_then(|d| d.commands.end_render_pass2)
    {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, p_end) }
    }
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
        if let Some(depth) = depth {
            let swappable = device
                .resolve_support
                .swapped_depth_mode(depth.resolve_mode, paired_stencil_mode)
                .is_ok();
            device.objects.settle_depth_resolve(
                depth.image_view,
                depth.resolve_image_view,
                depth.resolve_mode,
                swappable,
            );
        }
        let image = depth.map_or(Target::None, |d| device.objects.view_target(d.image_view));
        if image == Target::Reversed {
            // The clear of a reversed attachment settles the convention with its value.
            let clear = depth
                .filter(|d| d.load_op == vk::AttachmentLoadOp::CLEAR)
                // SAFETY: a depth attachment's clear value is the depthStencil member.
                .map(|d| unsafe { d.clear_value.depth_stencil.depth });
            device.observed.settle(clear);
        }
        let target = device.observed.effective(image);
        if let (Some(depth), Target::Reversed) = (depth, target) {
            let mut copy = *depth;
            if copy.load_op == vk::AttachmentLoadOp::CLEAR {
                // SAFETY: a depth attachment's clear value is the depthStencil member.
                unsafe {
                    copy.clear_value.depth_stencil.depth =
                        device.reversed_clear(copy.clear_value.depth_stencil.depth)
                };
            }
            // Settled above: a reversed attachment that still resolves resolves into a
            // reversed image, with a mode revz may swap.
            copy.resolve_mode = flip_resolve_mode(copy.resolve_mode);
            depth_copy = Some(copy);
        }
        // A promoted depth (or stencil) view: draws bind the variants made with float
        // rendering formats.
        // SAFETY: null or valid.
        let stencil = unsafe { info.p_stencil_attachment.as_ref() };
        let promoted = [depth, stencil]
            .into_iter()
            .flatten()
            .map(|a| a.image_view)
            .find(|&view| device.objects.view_promoted(view).is_some())
            .map(|view| {
                device
                    .objects
                    .view_format(view)
                    .unwrap_or(vk::Format::UNDEFINED)
            });
        {
            let mut state = entry.state();
            state.set_target(target);
            state.set_promoted(promoted);
        }
        let secondary = info
            .flags
            .contains(vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS);
        let key = depth
            .and_then(|d| device.objects.view_format(d.image_view))
            .map(SecondaryPass::Rendering);
        enter_contents(entry, buffer, secondary, key);
    });
    let Some(next) = device.and_then(|d| d.commands.begin_rendering) else {
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
    unsafe { next(buffer, p_info) }
}

pub unsafe extern "system" fn cmd_end_rendering(buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdEndRendering");
    let device = with_entry(buffer, &ENTRY, end_pass);
    if let Some(next) = device.and_then(|d| d.commands.end_rendering) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer) }
    }
}

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
fn clears_depth(ranges: &[vk::ImageSubresourceRange]) -> bool {
    ranges
        .iter()
        .any(|range| range.aspect_mask.contains(vk::ImageAspectFlags::DEPTH))
}

/// Warns once when a transfer writes into a reversed depth image: the values it writes keep
/// the standard convention (not converted yet).
fn check_transfer_destination(entry: &CommandBufferEntry, image: vk::Image) {
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

/// `vkCmdSetDepthBias2EXT` (`VK_EXT_depth_bias_control`). Without a representation in its
/// `pNext` it is `vkCmdSetDepthBias` and goes through the state machine. With one, revz cannot
/// re-send it as `vkCmdSetDepthBias`: it goes down at once, negated when the current target is
/// reversed (a target that changes before the draw is not followed: logged once).
pub unsafe extern "system" fn cmd_set_depth_bias2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::DepthBiasInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthBias2EXT");
    static REPRESENTED: std::sync::Once = std::sync::Once::new();
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { *p_info };
    let bias = DepthBias {
        constant: info.depth_bias_constant_factor,
        clamp: info.depth_bias_clamp,
        slope: info.depth_bias_slope_factor,
    };
    let mut flipped = None;
    let taken = recorded(buffer, &ENTRY, |entry| {
        let mut state = entry.state();
        if info.p_next.is_null() {
            state.set_bias(bias);
            return;
        }
        state.forget_emitted_bias();
        // A bias in the format's units on a promoted attachment is converted to the float
        // format's (`DepthBias::in_float_storage`); FLOAT and FORCE_UNORM representations
        // name units that promotion does not change.
        // SAFETY: a valid pNext chain (the application's contract).
        let representation =
            unsafe { chain::find::<vk::DepthBiasRepresentationInfoEXT<'_>>(info.p_next) }
                .map(|r| r.depth_bias_representation);
        let in_format_units = representation
            .is_none_or(|r| r == vk::DepthBiasRepresentationEXT::LEAST_REPRESENTABLE_VALUE_FORMAT);
        let scaled = match state.promoted_from() {
            Some(format) if in_format_units => bias.in_float_storage(format),
            _ => bias,
        };
        let reversed = state.target() == Target::Reversed;
        if reversed || scaled != bias {
            let sent = if reversed { scaled.flipped() } else { scaled };
            flipped = Some(vk::DepthBiasInfoEXT {
                depth_bias_constant_factor: sent.constant,
                depth_bias_clamp: sent.clamp,
                depth_bias_slope_factor: sent.slope,
                ..info
            });
        }
        REPRESENTED.call_once(|| {
            log::info!(
                "vkCmdSetDepthBias2EXT with a bias representation is negated where it is \
                 recorded, not per draw"
            )
        });
    });
    let down = match taken {
        Ok(()) if info.p_next.is_null() => return,
        Ok(()) => objects::command_buffer(buffer).map(Down::Tracked),
        Err(down) => down,
    };
    if let Some(next) = down.and_then(|d| d.commands.set_depth_bias2) {
        let p_info = flipped.as_ref().map_or(p_info, |f| f as *const _);
        // SAFETY: calling down with the application's arguments (the bias negated).
        unsafe { next(buffer, p_info) }
    }
}

/// A secondary's begin info as it goes down when it continues a promoted pass: its
/// inheritance names the promoted twin, or the float rendering formats (the copies it points
/// into live here).
struct PromotedInheritance<'a> {
    begin: vk::CommandBufferBeginInfo<'a>,
    _inheritance: Box<vk::CommandBufferInheritanceInfo<'a>>,
    _chain: Option<chain::Spliced>,
}

/// The begin info of a secondary continuing a promoted pass (`None`: the application's is
/// right as it is, or cannot be changed: logged).
fn promoted_inheritance<'a>(
    device: &DeviceState,
    begin: &vk::CommandBufferBeginInfo<'a>,
    inheritance: &vk::CommandBufferInheritanceInfo<'a>,
) -> Option<PromotedInheritance<'a>> {
    let mut copy = *inheritance;
    let mut spliced = None;
    if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass)?;
        copy.render_pass = pass.promoted_twin?;
    } else {
        // SAFETY: a valid pNext chain (the application's contract).
        let rendering = unsafe {
            chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next)
        }?;
        let float = |format: vk::Format| crate::conv::float_depth_format(format).unwrap_or(format);
        let replacement = vk::CommandBufferInheritanceRenderingInfo {
            depth_attachment_format: float(rendering.depth_attachment_format),
            stencil_attachment_format: float(rendering.stencil_attachment_format),
            ..*rendering
        };
        // SAFETY: as above; the copies live in the result.
        let Some(chain) = (unsafe { chain::splice(inheritance.p_next, Some(&replacement)) }) else {
            log::error!(
                "a secondary continuing rendering into a promoted depth image has a structure \
                 revz cannot copy before its inheritance rendering info: it keeps the UNORM \
                 format, and the driver may reject it"
            );
            return None;
        };
        copy.p_next = chain.head();
        spliced = Some(chain);
    }
    let inheritance = Box::new(copy);
    Some(PromotedInheritance {
        begin: vk::CommandBufferBeginInfo {
            p_inheritance_info: &*inheritance,
            ..*begin
        },
        _inheritance: inheritance,
        _chain: spliced,
    })
}

pub unsafe extern "system" fn begin_command_buffer(
    buffer: vk::CommandBuffer,
    p_begin: *const vk::CommandBufferBeginInfo<'_>,
) -> vk::Result {
    static ENTRY: EntryPoint = EntryPoint::new("vkBeginCommandBuffer");
    let mut promoted_begin = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: a valid begin info (the application's contract).
        let begin = unsafe { &*p_begin };
        // The inheritance info is ignored (and may be garbage) for primaries.
        let continues = entry.secondary
            && begin
                .flags
                .contains(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE);
        // SAFETY: null or valid; only read for secondaries continuing a render pass.
        let inheritance = unsafe { begin.p_inheritance_info.as_ref() }.filter(|_| continues);
        let target = inheritance.map_or(Target::None, |i| inherited_target(entry, i));
        let promoted = inheritance.and_then(|i| inherited_promotion(entry, i));
        if let (Some(_), Some(inheritance)) = (promoted, inheritance) {
            promoted_begin = promoted_inheritance(&entry.device, begin, inheritance);
        }
        *entry.scope() = PassScope::default();
        let mut state = entry.state();
        // Cameras matter to the precise path only (no lock in flip mode).
        let cameras = match entry.device.policy.rewrite() {
            Some(_) => entry.device.cameras.learned(),
            None => revz_math::Cameras::default(),
        };
        state.begin(target, entry.device.reversing().reversal, cameras);
        state.set_promoted(promoted);
        if entry.secondary && inherits_viewports(begin) {
            state.inherit_viewports();
        }
    });
    let p_begin = promoted_begin
        .as_ref()
        .map_or(p_begin, |promoted| &promoted.begin as *const _);
    match device {
        // SAFETY: calling down with the application's arguments (a promoted pass's
        // inheritance naming its twin or its float formats).
        Some(device) => unsafe { (device.next.fp_v1_0().begin_command_buffer)(buffer, p_begin) },
        None => vk::Result::ERROR_INITIALIZATION_FAILED,
    }
}

/// Whether a secondary continues a promoted pass, and the UNORM format of its depth
/// attachment (as [`PassScope::promoted_from`]): from the inherited framebuffer when there is
/// one; otherwise from how its pass was last begun for secondaries, or the format's images.
fn inherited_promotion(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> Option<vk::Format> {
    let device = &entry.device;
    if !device.policy.promote {
        return None;
    }
    let (key, format) = if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass)?;
        if !(0..pass.attachments.len()).any(|i| pass.promotable(i)) {
            return None;
        }
        let framebuffer = inheritance.framebuffer;
        let views = device.objects.framebuffers.get(&framebuffer);
        let format = pass
            .subpass_depth
            .get(inheritance.subpass as usize)
            .copied()
            .flatten()
            .and_then(|index| pass.attachments.get(index as usize).copied());
        // Any tracked framebuffer (imageless ones too) says how it was created.
        if views.is_some() {
            let promoted = device
                .objects
                .promoted_framebuffers
                .get(&framebuffer)
                .is_some();
            let scope = PassScope {
                render_pass: Some(pass),
                subpass: inheritance.subpass as usize,
                promoted,
                ..PassScope::default()
            };
            return scope.promoted_from();
        }
        (
            SecondaryPass::Subpass(inheritance.render_pass, inheritance.subpass),
            format,
        )
    } else {
        // SAFETY: a valid pNext chain (the application's contract).
        let rendering = unsafe {
            chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next)
        }?;
        let format = [
            rendering.depth_attachment_format,
            rendering.stencil_attachment_format,
        ]
        .into_iter()
        .find(|&f| crate::conv::float_depth_format(f).is_some())?;
        (SecondaryPass::Rendering(format), Some(format))
    };
    let remembered = device.objects.secondary_promoted.get(&key);
    let (promoted, kept) = match (remembered, format) {
        (None, Some(format)) => device.objects.count_promoted(format),
        _ => (0, 0),
    };
    let (promoted, guessed) = crate::policy::secondary_promoted(remembered, promoted, kept);
    if guessed {
        static MIXED: OnceLock<()> = OnceLock::new();
        MIXED.get_or_init(|| {
            log::warn!(
                "a secondary command buffer without a framebuffer draws into {format:?}, which \
                 has both promoted and unpromoted images, in a pass not yet begun for \
                 secondaries: assuming promoted"
            )
        });
    }
    promoted.then(|| {
        format
            .filter(|&f| crate::conv::float_depth_format(f).is_some())
            .unwrap_or(vk::Format::UNDEFINED)
    })
}

/// Whether a secondary inherits its viewports from the primary that executes it
/// (`VK_NV_inherited_viewport_scissor`).
fn inherits_viewports(begin: &vk::CommandBufferBeginInfo<'_>) -> bool {
    // SAFETY: null or valid (only read for secondaries, where the spec reads it too).
    let Some(inheritance) = (unsafe { begin.p_inheritance_info.as_ref() }) else {
        return false;
    };
    // SAFETY: a valid pNext chain (the application's contract).
    unsafe {
        chain::find::<vk::CommandBufferInheritanceViewportScissorInfoNV<'_>>(inheritance.p_next)
    }
    .is_some_and(|info| info.viewport_scissor2_d == vk::TRUE)
}

/// The depth target a secondary command buffer continues: from the inherited framebuffer when
/// there is one; otherwise from what the device's depth images of that format are.
fn inherited_target(
    entry: &CommandBufferEntry,
    inheritance: &vk::CommandBufferInheritanceInfo<'_>,
) -> Target {
    let device = &entry.device;
    if inheritance.render_pass != vk::RenderPass::null() {
        let pass = device.objects.render_passes.get(&inheritance.render_pass);
        // An imageless framebuffer names no views: the format decides, as without one.
        let targets: Vec<Target> =
            attachment_views(device, inheritance.framebuffer, std::ptr::null())
                .iter()
                .map(|&view| device.view_target(view))
                .collect();
        if !targets.is_empty() {
            let scope = PassScope {
                handle: inheritance.render_pass,
                render_pass: pass,
                attachment_targets: targets,
                subpass: inheritance.subpass as usize,
                promoted: false,
            };
            return scope.target();
        }
        let format = pass.and_then(|p| {
            let index = p
                .subpass_depth
                .get(inheritance.subpass as usize)
                .copied()
                .flatten()?;
            p.attachments.get(index as usize).copied()
        });
        let key = SecondaryPass::Subpass(inheritance.render_pass, inheritance.subpass);
        return format.map_or(Target::None, |f| format_target(device, key, f));
    }
    // Dynamic rendering inheritance names only the formats.
    // SAFETY: a valid pNext chain (the application's contract).
    unsafe { chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(inheritance.p_next) }
        .map(|info| info.depth_attachment_format)
        .filter(|&format| format != vk::Format::UNDEFINED)
        .map_or(Target::None, |format| {
            format_target(device, SecondaryPass::Rendering(format), format)
        })
}

/// Without a framebuffer, a secondary knows its pass and depth format: it follows the target
/// that pass was last begun with for secondaries, else the device's live depth images of that
/// format (`crate::policy::secondary_target`; a guess between both kinds is logged once).
fn format_target(device: &DeviceState, pass: SecondaryPass, format: vk::Format) -> Target {
    static MIXED: OnceLock<()> = OnceLock::new();
    let remembered = device.objects.secondary_targets.get(&pass);
    let (reversed, native) = match remembered {
        Some(_) => (0, 0),
        None => device.objects.count_images(format),
    };
    let (images, guessed) = secondary_target(remembered, reversed, native);
    if guessed {
        MIXED.get_or_init(|| {
            log::warn!(
                "a secondary command buffer without a framebuffer draws into {format:?}, which \
                 has both reversed and native images, in a pass not yet begun for secondaries: \
                 assuming reversed"
            )
        });
    }
    device.observed.effective(images)
}

pub unsafe extern "system" fn cmd_execute_commands(
    buffer: vk::CommandBuffer,
    count: u32,
    p_buffers: *const vk::CommandBuffer,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdExecuteCommands");
    static MISMATCH: std::sync::Once = std::sync::Once::new();
    let device = with_entry(buffer, &ENTRY, |entry| {
        let mut state = entry.state();
        let target = state.target();
        // A secondary decided its depth target at its begin; it can only be checked here.
        // SAFETY: `count` command buffers.
        for &secondary in unsafe { slice(p_buffers, count) } {
            if entry.device.profile.is_some() {
                if let Some(recorded) =
                    objects::command_buffer(secondary).map(|s| s.state().draws())
                {
                    state.add_executed_draws(&recorded);
                }
            }
            let assumed = objects::command_buffer(secondary).map(|s| s.state().inherited());
            if matches!(assumed, Some(a) if a != target && a != Target::None && target != Target::None)
            {
                MISMATCH.call_once(|| {
                    log::warn!(
                        "a secondary command buffer recorded for a {:?} depth attachment runs \
                         where the depth attachment is {target:?}: its depth state does not \
                         match (give secondaries their framebuffer in the inheritance info)",
                        assumed.unwrap_or_default()
                    )
                });
            }
        }
        // Secondaries may inherit the viewports set here; inside a subpass of secondaries
        // they went down at its begin, and nothing may be recorded there.
        if state.records_inline() {
            state.flush_viewports_for_secondaries(&mut NextLayer {
                device: &entry.device,
                buffer,
            });
        }
        state.invalidate();
    });
    if let Some(device) = device {
        // SAFETY: calling down with the application's arguments.
        unsafe { (device.next.fp_v1_0().cmd_execute_commands)(buffer, count, p_buffers) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_clears_of_the_depth_aspect_say_anything_about_depth() {
        let range = |aspect_mask| vk::ImageSubresourceRange {
            aspect_mask,
            level_count: 1,
            layer_count: 1,
            ..Default::default()
        };
        use vk::ImageAspectFlags as A;
        assert!(!clears_depth(&[range(A::STENCIL)]));
        assert!(!clears_depth(&[]));
        assert!(clears_depth(&[range(A::DEPTH)]));
        assert!(clears_depth(&[
            range(A::STENCIL),
            range(A::DEPTH | A::STENCIL)
        ]));
    }
}
