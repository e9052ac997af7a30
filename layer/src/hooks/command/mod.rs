//! Command recording hooks: where a draw's depth target is known, the application's depth
//! state is collected, clear values are flipped, and state is emitted before draws.
//!
//! Every hook looks up its command buffer (a thread-local cache hit in the common case); an
//! unknown command buffer is passed down untouched through its device's table. A hook that
//! changes what the next draw needs settles the depth state after its call has gone down
//! ([`settle`]), so draws are not intercepted (only the depth profile hooks them, to count).
//!
//! By concern: this file holds the shared plumbing (the next layer as a state sink, the lookup
//! of a command buffer's state, settling), push constants, the depth state setters, binds and
//! the profile's draw hooks;
//! [`passes`] the render pass and dynamic rendering begins, subpasses and ends; [`transfers`]
//! clears of depth images; [`copies`] copies of depth images (converted where one end
//! is reversed), and blits; [`compute_state`] the compute binds and conditional rendering
//! they restore or respect; [`secondaries`] command buffer begins
//! (what a secondary inherits) and `vkCmdExecuteCommands`.

mod compute_state;
mod copies;
mod passes;
mod secondaries;
mod transfers;
mod twins;

use std::mem::MaybeUninit;
use std::sync::{Arc, OnceLock};

use ash::vk;

use super::resources::slice;
use crate::boundary::{guarded, EntryPoint};
use crate::chain;
use crate::command_state::{CommandState, StateSink, Target, POSITION_STAGES};
use crate::conv::{BiasRepresentation, DepthBias};
use crate::objects::{self, CommandBufferEntry, PassScope, PositionShader, SecondaryPass};
use crate::precise::{FoldedPush, Outcome, PushSink, PUSH_CONSTANT_BYTES};
use crate::state::{DeviceState, DispatchKey, DEVICES};

pub use compute_state::*;
pub use copies::*;
pub use passes::*;
pub use secondaries::*;
pub use transfers::*;
pub use twins::{cmd_pipeline_barrier, cmd_pipeline_barrier2, cmd_wait_events, cmd_wait_events2};

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
        let set2 = self.device.commands.set_depth_bias2;
        if let (Some(representation), Some(set2)) = (bias.representation, set2) {
            // With the representation the application gave (only biases that came with one
            // have it, so the device has the extension).
            let mut represented = vk::DepthBiasRepresentationInfoEXT::default()
                .depth_bias_representation(representation.representation)
                .depth_bias_exact(representation.exact);
            let info = vk::DepthBiasInfoEXT::default()
                .depth_bias_constant_factor(bias.constant)
                .depth_bias_clamp(bias.clamp)
                .depth_bias_slope_factor(bias.slope)
                .push_next(&mut represented);
            // SAFETY: as above; a valid info and chain.
            unsafe { set2(self.buffer, &info) };
            return;
        }
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

    fn set_clamp_range(&mut self, range: Option<(f32, f32)>) {
        use crate::vk_ext::{
            DepthClampRange, DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, DEPTH_CLAMP_MODE_VIEWPORT_RANGE,
        };
        // Only sent where the application set a clamp range or created a pipeline with one,
        // so the device has the command.
        if let Some(set) = self.device.commands.set_depth_clamp_range {
            let range = range.map(|(min, max)| DepthClampRange {
                min_depth_clamp: min,
                max_depth_clamp: max,
            });
            let (mode, pointer) = match &range {
                Some(range) => (DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, range as *const _),
                None => (DEPTH_CLAMP_MODE_VIEWPORT_RANGE, std::ptr::null()),
            };
            // SAFETY: as above; a range that lives through the call.
            unsafe { set(self.buffer, mode, pointer) }
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

    fn bind_shader(&mut self, stage: vk::ShaderStageFlags, shader: vk::ShaderEXT) {
        // Only shader objects of this device get here, so it has the command.
        if let Some(bind) = self.device.commands.bind_shaders_ext {
            // SAFETY: as above; a live shader object (the application's, or its variant,
            // destroyed with it) of `stage`.
            unsafe { bind(self.buffer, 1, &stage, &shader) }
        }
    }
}

/// Sends the depth state the next draw needs, if it changed (`counted`: for a draw, which the
/// depth profile counts), and reports what a classification made for it tells.
#[inline]
fn send_pending(entry: &CommandBufferEntry, buffer: vk::CommandBuffer, counted: bool) {
    let mut sink = NextLayer {
        device: &entry.device,
        buffer,
    };
    let mut state = entry.state();
    let outcome = if counted {
        state.before_draw(&mut sink)
    } else {
        state.settle(&mut sink)
    };
    drop(state);
    if let Some(outcome) = outcome {
        observe(&entry.device, &outcome);
    }
}

/// A draw (hooked only with the depth profile, which counts it): every other hook already
/// settled the state, so this sends nothing but what a caught panic left pending.
#[inline]
fn before_draw(entry: &CommandBufferEntry, buffer: vk::CommandBuffer) {
    send_pending(entry, buffer, true);
}

/// After a hook that may change what the next draw needs has gone down: the depth state for
/// it goes down now ([`crate::command_state::CommandState::settle`]), so that draws reach the
/// driver without passing through revz. A panic here is caught and logged; the next hook
/// settles again.
#[inline]
fn settle(entry: &CommandBufferEntry, buffer: vk::CommandBuffer) {
    static ENTRY: EntryPoint = EntryPoint::new("depth state after a command");
    // The common case (a push of the same camera, a bind that changes nothing revz sends):
    // nothing pending, one load and no lock.
    if !entry.settle_wanted() {
        return;
    }
    guarded(&ENTRY, || send_pending(entry, buffer, false), || ());
}

/// [`settle`] after a hook that called down through `down`, when the command buffer is
/// tracked.
pub(super) fn settle_down(down: &Option<Down>, buffer: vk::CommandBuffer) {
    if let Some(Down::Tracked(entry)) = down {
        settle(entry, buffer);
    }
}

/// What a classified projection tells about the application goes to the device's evidence.
fn observe(device: &DeviceState, outcome: &Outcome) {
    device.observed.note_outcome(device.policy.mode, outcome);
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
    let tracked = objects::with_command_buffer(
        buffer,
        #[inline(always)]
        |entry| {
            // Most pushes change nothing revz sends (the same camera's next matrix, bytes
            // beside the projection): a few compares, and the push goes down as it came. Inline
            // here, the full path in its own function: the hook's arguments stay in registers
            // on this path (the closure, not inlined, took 25 instructions a push to pass
            // them; micro child, callgrind).
            // Without a shortcut (a new camera each push), not even the guarded call.
            let shortcut = entry.has_push_shortcut().then(|| {
                guarded(
                    &PUSH_CONSTANTS,
                    // By value: the arguments go into the closure, not pointers to their copies.
                    move || {
                        // SAFETY: `size` bytes of values (the application's contract).
                        let values = unsafe { slice(p_values.cast::<u8>(), size) };
                        entry.push_shortcut(layout, stages, offset, values)
                    },
                    || None,
                )
            });
            match shortcut.flatten() {
                // SAFETY: calling down with the application's arguments (and the stages of a
                // vertex range revz extended over the bytes it writes).
                Some(stages) => unsafe {
                    (entry.device.next.fp_v1_0().cmd_push_constants)(
                        buffer, layout, stages, offset, size, p_values,
                    )
                },
                // SAFETY: the hook's arguments.
                None => unsafe {
                    push_constants_in_full(
                        entry,
                        AppPush {
                            buffer,
                            layout,
                            stages,
                            offset,
                            size,
                            p_values,
                        },
                    )
                },
            }
        },
    );
    if tracked.is_none() {
        if let Some(device) = untracked_device(buffer) {
            // The stages of a vertex range revz extended over the bytes, as for tracked ones.
            let stages = patched_stages(&device, layout, offset, size, stages);
            // SAFETY: calling down with the application's arguments (and those stages).
            unsafe {
                (device.next.fp_v1_0().cmd_push_constants)(
                    buffer, layout, stages, offset, size, p_values,
                )
            }
        }
    }
}

static PUSH_CONSTANTS: EntryPoint = EntryPoint::new("vkCmdPushConstants");

/// The arguments of an application's `vkCmdPushConstants`.
#[derive(Clone, Copy)]
struct AppPush {
    buffer: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    stages: vk::ShaderStageFlags,
    offset: u32,
    size: u32,
    p_values: *const std::ffi::c_void,
}

/// [`cmd_push_constants`] of a tracked command buffer where the push shortcut did not answer:
/// the push is followed ([`follow_push`]), goes down (extended to the carrier where its value
/// changes with this push), and the state settles.
///
/// # Safety
/// `push` holds the arguments of the application's `vkCmdPushConstants`.
#[inline(never)]
unsafe fn push_constants_in_full(entry: &CommandBufferEntry, push: AppPush) {
    let (buffer, layout, offset, size) = (push.buffer, push.layout, push.offset, push.size);
    let (stages, p_values) = (push.stages, push.p_values);
    // The extended push's bytes, written only where the carrier goes with this push (left
    // uninitialized otherwise: most pushes send the application's own bytes).
    let mut folded_bytes = [MaybeUninit::<u8>::uninit(); PUSH_CONSTANT_BYTES];
    let mut followed = stages;
    let failed = std::cell::Cell::new(false);
    let folded = guarded(
        &PUSH_CONSTANTS,
        || {
            // SAFETY: `size` bytes of values (the application's contract).
            let values = unsafe { slice(p_values.cast::<u8>(), size) };
            follow_push(
                entry,
                layout,
                &mut followed,
                offset,
                values,
                &mut folded_bytes,
            )
        },
        || {
            failed.set(true);
            None
        },
    );
    // A push whose following failed (its stages possibly not patched): from the device's
    // tables.
    let stages = if failed.get() {
        patched_stages(&entry.device, layout, offset, size, stages)
    } else {
        followed
    };
    let (offset, size, p_sent) = match folded {
        Some(f) => (f.offset, f.size, folded_bytes.as_ptr().cast()),
        None => (offset, size, p_values),
    };
    // SAFETY: calling down with the application's arguments (its values extended to the
    // carrier's bytes, which the layout's range of `stages` holds).
    unsafe {
        (entry.device.next.fp_v1_0().cmd_push_constants)(
            buffer, layout, stages, offset, size, p_sent,
        )
    };
    settle(entry, buffer);
}

/// The stages an application's push with `layout` goes down with where revz's layout
/// extended a vertex range over the bytes it writes (`crate::precise::PushPatch`), looked up
/// in the device's tables: the path of untracked command buffers and of a push whose
/// following failed (tracked pushes take it from the command buffer's state).
fn patched_stages(
    device: &DeviceState,
    layout: vk::PipelineLayout,
    offset: u32,
    size: u32,
    stages: vk::ShaderStageFlags,
) -> vk::ShaderStageFlags {
    device
        .objects
        .layout_carriers
        .get(&layout)
        .and_then(|carrier| carrier.push_patch)
        .map_or(stages, |patch| patch.stages_of(offset, size, stages))
}

/// Follows a push of the application's: the shadow copy and the outcome for the bound
/// pipeline's projection; returns the push to send in its place, if the carrier goes with it,
/// with its bytes written into `out`; `stages` become those to send it with (the application's,
/// and those of a vertex range revz extended over the bytes it writes:
/// `crate::precise::PushPatch`).
fn follow_push(
    entry: &CommandBufferEntry,
    layout: vk::PipelineLayout,
    stages: &mut vk::ShaderStageFlags,
    offset: u32,
    values: &[u8],
    out: &mut [MaybeUninit<u8>; PUSH_CONSTANT_BYTES],
) -> Option<FoldedPush> {
    let mut state = entry.state();
    if layout != state.push_layout() {
        // Whether this layout is push-compatible with the bound pipeline's, and the stages
        // its pushes must name (one lookup per change of layout, not per push).
        let objects = &entry.device.objects;
        let pusher = objects.layout_pushers.get(&layout).unwrap_or_default();
        let patch = objects
            .layout_carriers
            .get(&layout)
            .and_then(|carrier| carrier.push_patch);
        state.note_push_pusher(pusher, patch);
    }
    *stages = state.push_stages(offset, values.len() as u32, *stages);
    let (outcome, folded) = state.push_constants(layout, *stages, offset, values);
    if let Some(folded) = &folded {
        state.folded_bytes(folded, out);
    }
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
    let mut sent_stages = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: `size` bytes of values.
        let values = unsafe { slice(info.p_values.cast::<u8>(), info.size) };
        if info.layout == vk::PipelineLayout::null() || values.len() > PUSH_CONSTANT_BYTES {
            // A layout given through pNext, or an unusually large push: not followed; the
            // push constants are forgotten so that no carrier is assumed to survive it (the
            // bound pipeline, a variant revz bound included, is unchanged).
            entry.state().forget_push_constants();
            return;
        }
        // Followed, never extended (the draw sends the carrier): this command is rare.
        let mut unused = [MaybeUninit::<u8>::uninit(); PUSH_CONSTANT_BYTES];
        let mut stages = info.stage_flags;
        let folded = follow_push(
            entry,
            info.layout,
            &mut stages,
            info.offset,
            values,
            &mut unused,
        );
        if folded.is_some() {
            entry.state().unfold();
        }
        sent_stages = Some(stages);
    });
    let Some(next) = device.as_ref().and_then(|d| d.commands.push_constants2) else {
        return;
    };
    // Untracked, a layout in pNext (the application's own ranges: unpatched), or a push whose
    // following failed: from the device's tables.
    let stages = sent_stages.unwrap_or_else(|| {
        device.as_ref().map_or(info.stage_flags, |d| {
            patched_stages(d, info.layout, info.offset, info.size, info.stage_flags)
        })
    });
    let patched = vk::PushConstantsInfoKHR {
        stage_flags: stages,
        ..info
    };
    // SAFETY: calling down with the application's arguments (its stages, and those of a
    // vertex range revz extended over the bytes it writes).
    unsafe { next(buffer, &patched) };
    settle_down(&device, buffer);
}

/// The per-draw-rate hook shape (draws, pushes, binds): `record` runs on the command buffer's
/// entry (a thread-local cache hit, no reference count taken; a panic in it is caught and gives
/// `fallback`), then `call` goes down through the entry's device with what `record` returned,
/// then, where `SETTLES`, the depth state the next draw needs ([`settle`]). An untracked
/// command buffer is only called down, with `fallback`.
#[inline]
fn record_then_call<const SETTLES: bool, T: Copy>(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    record: impl FnOnce(&CommandBufferEntry) -> T,
    fallback: T,
    call: impl Fn(&DeviceState, T),
) {
    let tracked = objects::with_command_buffer(buffer, |entry| {
        let recorded = guarded(entry_point, || record(entry), || fallback);
        call(&entry.device, recorded);
        if SETTLES {
            settle(entry, buffer);
        }
    });
    if tracked.is_none() {
        if let Some(device) = untracked_device(buffer) {
            call(&device, fallback);
        }
    }
}

/// Defines a draw hook (handed out only with the depth profile, `super::draw_command`): count
/// the draw and send what is pending (nothing, when every hook settled), then call down.
macro_rules! draw_hook {
    ($name:ident, $entry:literal, $($arg:ident: $ty:ty),* => |$device:ident| $next:expr) => {
        #[doc = concat!("`", $entry, "`.")]
        ///
        /// # Safety
        /// Called by the application with the arguments the Vulkan spec allows.
        pub unsafe extern "system" fn $name(buffer: vk::CommandBuffer, $($arg: $ty),*) {
            static ENTRY: EntryPoint = EntryPoint::new($entry);
            record_then_call::<false, _>(
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

/// Whether the command buffer's state machine took the call (then what it sets goes down as
/// the state machine settles, flipped where the target is reversed, and the application's
/// call must not go down).
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
                settle(&entry, buffer);
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

/// `vkCmdSetDepthClampEnableEXT`: followed, so that an infinite-mode draw that clamps takes
/// the flip path (the precise path has no far plane to clamp at); goes down as it is.
pub unsafe extern "system" fn cmd_set_depth_clamp_enable(
    buffer: vk::CommandBuffer,
    enable: vk::Bool32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthClampEnableEXT");
    // SAFETY: the application's arguments.
    unsafe {
        follow_switch(buffer, &ENTRY, enable, CommandState::set_depth_clamp, |c| {
            c.set_depth_clamp_enable
        })
    }
}

/// `vkCmdSetDepthClipEnableEXT`: followed, so that an infinite-mode draw that clamps depth
/// keeps the precise path where it clips too (D3D translators' state); goes down as it is.
pub unsafe extern "system" fn cmd_set_depth_clip_enable(
    buffer: vk::CommandBuffer,
    enable: vk::Bool32,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthClipEnableEXT");
    // SAFETY: the application's arguments.
    unsafe {
        follow_switch(buffer, &ENTRY, enable, CommandState::set_depth_clip, |c| {
            c.set_depth_clip_enable
        })
    }
}

/// A dynamic switch revz only follows (the depth clamp, depth clipping): the state machine
/// records it (`follow`), the command goes down as it is (`next` of the device's commands),
/// and the next draw's state after it, as after every state command (its path may have
/// changed).
///
/// # Safety
/// `buffer` is the application's command buffer, recording.
unsafe fn follow_switch(
    buffer: vk::CommandBuffer,
    entry_point: &'static EntryPoint,
    enable: vk::Bool32,
    follow: fn(&mut CommandState, bool),
    next: impl FnOnce(&crate::state::DeviceCommands) -> Option<vk::PFN_vkCmdSetDepthClampEnableEXT>,
) {
    let down = with_entry(buffer, entry_point, |entry| {
        follow(&mut entry.state(), enable == vk::TRUE)
    });
    let Some(down) = down else {
        return;
    };
    if let Some(next) = next(&down.commands) {
        // SAFETY: calling down with the application's arguments.
        unsafe { next(buffer, enable) }
    }
    if let Down::Tracked(entry) = &down {
        settle(entry, buffer);
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
        representation: None,
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

pub unsafe extern "system" fn cmd_set_depth_clamp_range(
    buffer: vk::CommandBuffer,
    mode: i32,
    p_range: *const crate::vk_ext::DepthClampRange,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthClampRangeEXT");
    let range = match mode {
        // SAFETY: a valid range where the mode is user-defined (the application's contract;
        // the viewport's range reads none).
        crate::vk_ext::DEPTH_CLAMP_MODE_USER_DEFINED_RANGE => unsafe { p_range.as_ref() },
        _ => None,
    };
    // Any other mode (the spec has two) or a user-defined one without its range, both
    // invalid, count as the viewport's range.
    let range = range.map(|r| (r.min_depth_clamp, r.max_depth_clamp));
    let taken = recorded(buffer, &ENTRY, |entry| entry.state().set_clamp_range(range));
    if let Err(Some(device)) = taken {
        if let Some(next) = device.commands.set_depth_clamp_range {
            // SAFETY: calling down with the application's arguments.
            unsafe { next(buffer, mode, p_range) }
        }
    }
}

pub unsafe extern "system" fn cmd_bind_pipeline(
    buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    pipeline: vk::Pipeline,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdBindPipeline");
    let bind = |device: &DeviceState, sent: vk::Pipeline| {
        // SAFETY: calling down with the application's arguments (the pipeline, or its
        // reversed or promoted variant, created with it and destroyed with it).
        unsafe { (device.next.fp_v1_0().cmd_bind_pipeline)(buffer, bind_point, sent) }
    };
    let tracked = objects::with_command_buffer(buffer, |entry| {
        if bind_point != vk::PipelineBindPoint::GRAPHICS {
            if bind_point == vk::PipelineBindPoint::COMPUTE {
                // Bound again after a converted copy's dispatch.
                guarded(
                    &ENTRY,
                    || entry.copies().compute.bind_pipeline(pipeline),
                    || (),
                );
            }
            bind(&entry.device, pipeline);
            // Nothing a draw needs changed, but what a caught panic left pending goes now.
            settle(entry, buffer);
            return;
        }
        // The bind and the settle after it under one lock of the state (binds are on every
        // frame of the application); the bind goes down once, whatever panics.
        let called = std::cell::Cell::new(false);
        guarded(
            &ENTRY,
            || {
                let objects = &entry.device.objects;
                let generation = objects.pipeline_generation();
                let mut state = entry.state();
                // Found in the device's table only the first time this recording binds it.
                state.bind_pipeline_handle(pipeline, generation, || {
                    objects.pipelines.get(&pipeline)
                });
                if entry.device.profile.is_some() {
                    state.tally_pipeline(vk::Handle::as_raw(pipeline));
                }
                // A reversed variant goes down in the application's pipeline's place.
                let sent = state.pipeline_to_bind(pipeline);
                called.set(true);
                bind(&entry.device, sent);
                let mut sink = NextLayer {
                    device: &entry.device,
                    buffer,
                };
                let outcome = state.settle(&mut sink);
                drop(state);
                if let Some(outcome) = outcome {
                    observe(&entry.device, &outcome);
                }
            },
            || {
                if !called.get() {
                    bind(&entry.device, pipeline);
                }
            },
        );
    });
    if tracked.is_none() {
        if let Some(device) = untracked_device(buffer) {
            bind(&device, pipeline);
        }
    }
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
    // The shaders sent down, where revz's baked variant takes the place of the application's
    // shader in the call (at most this many stages: a call naming more goes down as it is,
    // the variant bound by the settle after it).
    const MOST: usize = 8;
    let mut substituted: Option<[vk::ShaderEXT; MOST]> = None;
    let device = with_entry(buffer, &ENTRY, |entry| {
        // SAFETY: `count` stages, and `count` shaders unless null (then every stage is
        // unbound).
        let stages = unsafe { slice(p_stages, count) };
        // The shader the call binds to `stage`, where it names it (null: unbound).
        let bound_to = |stage: vk::ShaderStageFlags| {
            stages.iter().position(|&s| s == stage).map(|index| {
                if p_shaders.is_null() {
                    vk::ShaderEXT::null()
                } else {
                    // SAFETY: as above; `index` is below `count`.
                    unsafe { *p_shaders.add(index) }
                }
            })
        };
        let objects = &entry.device.objects;
        let fragment = bound_to(vk::ShaderStageFlags::FRAGMENT).map(|shader| {
            let depth = (shader != vk::ShaderEXT::null())
                .then(|| objects.fragment_shaders.get(&shader))
                .flatten();
            (shader, depth)
        });
        let position = POSITION_STAGES.map(|stage| {
            bound_to(stage).map(|shader| {
                let depth = (shader != vk::ShaderEXT::null())
                    .then(|| objects.position_shaders.get(&shader))
                    .flatten();
                (shader, depth)
            })
        });
        // A control shader copying the positions on (`PositionShader::PassesThrough`).
        let control = bound_to(vk::ShaderStageFlags::TESSELLATION_CONTROL).map(|shader| {
            shader != vk::ShaderEXT::null()
                && objects.position_shaders.get(&shader) == Some(PositionShader::PassesThrough)
        });
        if let Some(shader) = bound_to(vk::ShaderStageFlags::COMPUTE) {
            // A compute shader object (or none): bound again after revz's dispatch, which
            // binds a compute pipeline in its place.
            entry.copies().compute.bind_shader(shader);
        }
        // Only graphics stages replace the bound graphics pipeline.
        if stages.iter().any(|&s| s != vk::ShaderStageFlags::COMPUTE) {
            let mut state = entry.state();
            state.bind_shaders(fragment, position);
            if let Some(carries) = control {
                state.bind_control_shader(carries);
            }
            // The variant in the application's shader's place where the next draw takes the
            // precise path, instead of the application's shader and then the variant.
            let at = state
                .position_shader_to_bind()
                .and_then(|(stage, variant)| {
                    let index = stages.iter().position(|&s| s == POSITION_STAGES[stage])?;
                    (stages.len() <= MOST && !p_shaders.is_null())
                        .then_some((index, stage, variant))
                });
            if let Some((index, stage, variant)) = at {
                let mut shaders = [vk::ShaderEXT::null(); MOST];
                // SAFETY: `count` shaders (not null, checked above), at most `MOST`.
                shaders[..stages.len()].copy_from_slice(unsafe { slice(p_shaders, count) });
                shaders[index] = variant;
                substituted = Some(shaders);
                state.position_variant_sent(stage, variant);
            }
            // The depth profile files the draws under the last pre-rasterization stage's
            // shader (vertex, tessellation evaluation, geometry or mesh), as it has recorded
            // each of them at creation.
            let binds_position = stages.iter().any(|stage| POSITION_STAGES.contains(stage));
            if binds_position && entry.device.profile.is_some() {
                let shader = state.last_position_shader().map_or(0, vk::Handle::as_raw);
                state.tally_pipeline(shader);
            }
        }
    });
    if let Some(next) = device.as_ref().and_then(|d| d.commands.bind_shaders_ext) {
        let p_sent = substituted.as_ref().map_or(p_shaders, |s| s.as_ptr());
        // SAFETY: calling down with the application's arguments (with revz's variant of the
        // last pre-rasterization stage in its shader's place).
        unsafe { next(buffer, count, p_stages, p_sent) };
        settle_down(&device, buffer);
    }
}

/// `vkCmdSetDepthBias2EXT` (`VK_EXT_depth_bias_control`): recorded as the policy says
/// ([`crate::policy::BiasRecording`]): through the state machine like `vkCmdSetDepthBias`
/// (sent for each draw's target with the chained representation), or down at once for the
/// current target (logged once).
pub unsafe extern "system" fn cmd_set_depth_bias2(
    buffer: vk::CommandBuffer,
    p_info: *const vk::DepthBiasInfoEXT<'_>,
) {
    static ENTRY: EntryPoint = EntryPoint::new("vkCmdSetDepthBias2EXT");
    static UNKNOWN_CHAIN: crate::logging::LogOnce = crate::logging::LogOnce::new();
    // SAFETY: a valid info (the application's contract).
    let info = unsafe { *p_info };
    // SAFETY: a valid pNext chain (the application's contract).
    let (representation, only_it) = unsafe {
        let found = chain::find::<vk::DepthBiasRepresentationInfoEXT<'_>>(info.p_next);
        let only = match found {
            Some(r) => r.p_next.is_null() && std::ptr::eq(info.p_next.cast(), r as *const _),
            None => info.p_next.is_null(),
        };
        (found.map(BiasRepresentation::of), only)
    };
    let bias = DepthBias {
        constant: info.depth_bias_constant_factor,
        clamp: info.depth_bias_clamp,
        slope: info.depth_bias_slope_factor,
        representation,
    };
    let recording = crate::policy::BiasRecording::of(only_it);
    let mut flipped = None;
    let taken = recorded(buffer, &ENTRY, |entry| {
        let mut state = entry.state();
        if recording == crate::policy::BiasRecording::PerDraw {
            state.set_bias(bias);
            return;
        }
        state.forget_emitted_bias();
        let sent = bias.for_attachment(state.target() == Target::Reversed, state.promoted_from());
        if sent != bias {
            flipped = Some(vk::DepthBiasInfoEXT {
                depth_bias_constant_factor: sent.constant,
                depth_bias_clamp: sent.clamp,
                depth_bias_slope_factor: sent.slope,
                ..info
            });
        }
        UNKNOWN_CHAIN.log(|| {
            log::info!(
                "vkCmdSetDepthBias2EXT with structures revz does not know in its chain is \
                 negated where it is recorded, not per draw"
            )
        });
    });
    let down = match taken {
        Ok(()) if recording == crate::policy::BiasRecording::PerDraw => return,
        Ok(()) => objects::command_buffer(buffer).map(Down::Tracked),
        Err(down) => down,
    };
    if let Some(next) = down.and_then(|d| d.commands.set_depth_bias2) {
        let p_info = flipped.as_ref().map_or(p_info, |f| f as *const _);
        // SAFETY: calling down with the application's arguments (the bias negated).
        unsafe { next(buffer, p_info) }
    }
}
