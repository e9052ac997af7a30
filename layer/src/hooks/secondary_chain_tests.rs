//! State a primary must send before its secondaries run, through the fake loader chain: the
//! viewports the application set go down (flipped for a reversed attachment) before a rendering
//! instance of secondaries begins, where no state command may be recorded, and at
//! `vkCmdExecuteCommands` outside one; secondaries inheriting viewports
//! (`VK_NV_inherited_viewport_scissor`) would otherwise get none.

use std::ffi::{c_char, CStr};
use std::sync::Mutex;

use ash::vk::{self, Handle};

use super::fake_chain::{self, hook_set, Tables};

/// What reached the fake below revz, per command buffer (by handle: the fake's handles are
/// distinct across tests).
static CALLS: Mutex<Vec<(usize, Call)>> = Mutex::new(Vec::new());

#[derive(Clone, Debug, PartialEq)]
enum Call {
    /// `vkCmdSetViewport`: first viewport, each (minDepth, maxDepth).
    SetViewport(u32, Vec<(f32, f32)>),
    BeginRendering,
    EndRendering,
    /// `vkCmdEndRendering2KHR`.
    EndRendering2,
    ExecuteCommands,
}

fn key_of(buffer: vk::CommandBuffer) -> usize {
    buffer.as_raw() as usize
}

fn note(buffer: vk::CommandBuffer, call: Call) {
    CALLS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .push((key_of(buffer), call));
}

fn calls(buffer: vk::CommandBuffer) -> Vec<Call> {
    let key = key_of(buffer);
    let mut calls = CALLS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let (mine, others) = std::mem::take(&mut *calls)
        .into_iter()
        .partition(|(k, _)| *k == key);
    *calls = others;
    mine.into_iter().map(|(_, call)| call).collect()
}

unsafe extern "system" fn set_viewport(
    buffer: vk::CommandBuffer,
    first: u32,
    count: u32,
    viewports: *const vk::Viewport,
) {
    // SAFETY: revz passes `count` viewports.
    let viewports = unsafe { std::slice::from_raw_parts(viewports, count as usize) };
    let depths = viewports
        .iter()
        .map(|v| (v.min_depth, v.max_depth))
        .collect();
    note(buffer, Call::SetViewport(first, depths));
}

unsafe extern "system" fn begin_rendering(buffer: vk::CommandBuffer, _: *const vk::RenderingInfo) {
    note(buffer, Call::BeginRendering);
}

unsafe extern "system" fn end_rendering(buffer: vk::CommandBuffer) {
    note(buffer, Call::EndRendering);
}

unsafe extern "system" fn end_rendering2(buffer: vk::CommandBuffer, _: *const std::ffi::c_void) {
    note(buffer, Call::EndRendering2);
}

unsafe extern "system" fn execute_commands(
    buffer: vk::CommandBuffer,
    _: u32,
    _: *const vk::CommandBuffer,
) {
    note(buffer, Call::ExecuteCommands);
}

/// The fake with render passes and images, plus the commands this test records.
unsafe extern "system" fn gdpa(device: vk::Device, name: *const c_char) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let wanted = unsafe { CStr::from_ptr(name) };
    match wanted.to_bytes() {
        b"vkCmdSetViewport" => void_fn!(vk::PFN_vkCmdSetViewport, set_viewport),
        b"vkCmdBeginRendering" => void_fn!(vk::PFN_vkCmdBeginRendering, begin_rendering),
        b"vkCmdEndRendering" => void_fn!(vk::PFN_vkCmdEndRendering, end_rendering),
        b"vkCmdEndRendering2KHR" => {
            void_fn!(crate::state::PfnCmdEndRendering2, end_rendering2)
        }
        b"vkCmdExecuteCommands" => void_fn!(vk::PFN_vkCmdExecuteCommands, execute_commands),
        // SAFETY: the same arguments.
        _ => unsafe { fake_chain::fake_get_device_proc_addr_with_passes(device, name) },
    }
}

hook_set!(struct Hooks {
    create_image: c"vkCreateImage" => vk::PFN_vkCreateImage,
    create_view: c"vkCreateImageView" => vk::PFN_vkCreateImageView,
    destroy_image: c"vkDestroyImage" => vk::PFN_vkDestroyImage,
    destroy_view: c"vkDestroyImageView" => vk::PFN_vkDestroyImageView,
    allocate: c"vkAllocateCommandBuffers" => vk::PFN_vkAllocateCommandBuffers,
    free: c"vkFreeCommandBuffers" => vk::PFN_vkFreeCommandBuffers,
    destroy_pool: c"vkDestroyCommandPool" => vk::PFN_vkDestroyCommandPool,
    begin: c"vkBeginCommandBuffer" => vk::PFN_vkBeginCommandBuffer,
    set_viewport: c"vkCmdSetViewport" => vk::PFN_vkCmdSetViewport,
    begin_rendering: c"vkCmdBeginRendering" => vk::PFN_vkCmdBeginRendering,
    end_rendering: c"vkCmdEndRendering" => vk::PFN_vkCmdEndRendering,
    end_rendering2: c"vkCmdEndRendering2KHR" => crate::state::PfnCmdEndRendering2,
    execute: c"vkCmdExecuteCommands" => vk::PFN_vkCmdExecuteCommands,
});

/// A flip-mode device with one 64 x 64 D32 depth image and its view, and `count` primaries.
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    hooks: Hooks,
    image: vk::Image,
    view: vk::ImageView,
    pool: vk::CommandPool,
    primaries: Vec<vk::CommandBuffer>,
}

impl Fixture {
    fn new(count: u32) -> Fixture {
        let tables = Tables::fresh();
        let (instance, _) = fake_chain::create_instance(&[(c"mode", c"flip")]);
        fake_chain::take_events(tables.instance);
        let (physical, device, _) = fake_chain::create_device(tables, gdpa);
        let hooks = Hooks::of(device);
        let image_info = fake_chain::depth_image_info(
            vk::Format::D32_SFLOAT,
            vk::Extent2D {
                width: 64,
                height: 64,
            },
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::SampleCountFlags::TYPE_1,
        );
        let (mut image, mut view) = (vk::Image::null(), vk::ImageView::null());
        let pool = vk::CommandPool::from_raw(1);
        let mut primaries = vec![vk::CommandBuffer::null(); count as usize];
        // SAFETY: a live device and valid create infos.
        unsafe {
            assert_eq!(
                (hooks.create_image)(device, &image_info, std::ptr::null(), &mut image),
                vk::Result::SUCCESS
            );
            let view_info = fake_chain::depth_view_info(image, vk::Format::D32_SFLOAT);
            assert_eq!(
                (hooks.create_view)(device, &view_info, std::ptr::null(), &mut view),
                vk::Result::SUCCESS
            );
            let info = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(count);
            assert_eq!(
                (hooks.allocate)(device, &info, primaries.as_mut_ptr()),
                vk::Result::SUCCESS
            );
        }
        // A freed command buffer's address may come back: forget what an earlier test
        // recorded under these handles.
        let fresh: Vec<usize> = primaries.iter().map(|&b| key_of(b)).collect();
        CALLS
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .retain(|(key, _)| !fresh.contains(key));
        Fixture {
            tables,
            instance,
            physical,
            device,
            hooks,
            image,
            view,
            pool,
            primaries,
        }
    }

    /// A rendering instance over the depth image (loaded), with `flags`.
    fn rendering<'a>(
        &self,
        depth: &'a vk::RenderingAttachmentInfo<'a>,
        flags: vk::RenderingFlags,
    ) -> vk::RenderingInfo<'a> {
        vk::RenderingInfo::default()
            .flags(flags)
            .render_area(vk::Rect2D {
                extent: vk::Extent2D {
                    width: 64,
                    height: 64,
                },
                ..Default::default()
            })
            .layer_count(1)
            .depth_attachment(depth)
    }

    fn depth(&self) -> vk::RenderingAttachmentInfo<'static> {
        vk::RenderingAttachmentInfo::default()
            .image_view(self.view)
            .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)
    }

    fn tear_down(self) {
        let (device, hooks) = (self.device, &self.hooks);
        // SAFETY: nothing is in use; each object destroyed once.
        unsafe {
            let count = self.primaries.len() as u32;
            (hooks.free)(device, self.pool, count, self.primaries.as_ptr());
            (hooks.destroy_pool)(device, self.pool, std::ptr::null());
            (hooks.destroy_view)(device, self.view, std::ptr::null());
            (hooks.destroy_image)(device, self.image, std::ptr::null());
            fake_chain::tear_down(self.tables, self.instance, self.physical, self.device);
        }
    }
}

#[test]
fn viewports_go_down_before_secondaries_run_flipped_for_a_reversed_attachment() {
    let fx = Fixture::new(2);
    let h = &fx.hooks;
    let [primary, other] = [fx.primaries[0], fx.primaries[1]];
    let viewport = vk::Viewport {
        width: 64.0,
        height: 64.0,
        min_depth: 0.0,
        max_depth: 1.0,
        ..Default::default()
    };
    let depth = fx.depth();
    let rendering = fx.rendering(
        &depth,
        vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS,
    );
    let secondaries = [vk::CommandBuffer::from_raw(0x5EC)];
    // SAFETY: recording primaries with valid arguments (the secondary is never looked at by
    // the fake).
    unsafe {
        // Into a reversed attachment, drawn by secondaries: the viewport goes down flipped
        // before the rendering instance begins, and nothing is recorded inside it.
        assert_eq!(
            (h.begin)(primary, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        (h.set_viewport)(primary, 0, 1, &viewport);
        (h.begin_rendering)(primary, &rendering);
        (h.execute)(primary, 1, secondaries.as_ptr());
        (h.end_rendering)(primary);
        // Outside a rendering instance: at vkCmdExecuteCommands (not reversed: as set).
        assert_eq!(
            (h.begin)(other, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        (h.set_viewport)(other, 0, 1, &viewport);
        (h.execute)(other, 1, secondaries.as_ptr());
    }
    assert_eq!(
        calls(primary),
        [
            Call::SetViewport(0, vec![(1.0, 0.0)]),
            Call::BeginRendering,
            Call::ExecuteCommands,
            Call::EndRendering
        ]
    );
    assert_eq!(
        calls(other),
        [
            Call::SetViewport(0, vec![(0.0, 1.0)]),
            Call::ExecuteCommands
        ]
    );
    fx.tear_down();
}

#[test]
fn a_rendering_instance_of_inline_draws_and_secondaries_remembers_its_target_for_them() {
    let fx = Fixture::new(1);
    let h = &fx.hooks;
    let primary = fx.primaries[0];
    // SAFETY: the fake's live device.
    let key = unsafe { crate::state::DispatchKey::of(fx.device) };
    let state = crate::state::DEVICES.get(key).expect("the device");
    let remembered = crate::objects::SecondaryPass::Rendering(vk::Format::D32_SFLOAT);
    assert_eq!(state.objects.secondary_targets.get(&remembered), None);
    let depth = fx.depth();
    // VK_RENDERING_CONTENTS_INLINE_BIT_KHR with secondaries (maintenance7).
    let inline = vk::RenderingFlags::from_raw(0x10);
    let rendering = fx.rendering(
        &depth,
        vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS | inline,
    );
    // SAFETY: recording a primary with valid arguments.
    unsafe {
        assert_eq!(
            (h.begin)(primary, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        (h.begin_rendering)(primary, &rendering);
        (h.end_rendering)(primary);
    }
    // Secondaries without a framebuffer it executes draw into a reversed D32 attachment.
    assert_eq!(
        state.objects.secondary_targets.get(&remembered),
        Some(crate::command_state::Target::Reversed)
    );
    assert_eq!(calls(primary), [Call::BeginRendering, Call::EndRendering]);
    drop(state);
    fx.tear_down();
}

#[test]
fn end_rendering2_ends_the_rendering_instance_for_revz_too() {
    let fx = Fixture::new(1);
    let h = &fx.hooks;
    let primary = fx.primaries[0];
    let depth = fx.depth();
    let rendering = fx.rendering(&depth, vk::RenderingFlags::empty());
    let viewport = [vk::Viewport {
        width: 64.0,
        height: 64.0,
        min_depth: 0.0,
        max_depth: 1.0,
        ..Default::default()
    }];
    // SAFETY: recording a primary with valid arguments (a null end info is allowed).
    unsafe {
        assert_eq!(
            (h.begin)(primary, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        (h.begin_rendering)(primary, &rendering);
        (h.set_viewport)(primary, 0, 1, viewport.as_ptr());
        (h.end_rendering2)(primary, std::ptr::null());
        // Outside the rendering instance: nothing is sent for a draw until the next begin
        // (revz not knowing it ended would send this one flipped at once).
        let other = [vk::Viewport {
            min_depth: 0.25,
            ..viewport[0]
        }];
        (h.set_viewport)(primary, 0, 1, other.as_ptr());
    }
    assert_eq!(
        calls(primary),
        [
            Call::BeginRendering,
            Call::SetViewport(0, vec![(1.0, 0.0)]),
            Call::EndRendering2
        ]
    );
    fx.tear_down();
}
