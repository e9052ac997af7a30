//! State a primary must send before its secondaries run, through the fake loader chain: the
//! viewports the application set go down (flipped for a reversed attachment) before a rendering
//! instance of secondaries begins, where no state command may be recorded, and at
//! `vkCmdExecuteCommands` outside one; secondaries inheriting viewports
//! (`VK_NV_inherited_viewport_scissor`) would otherwise get none.

use std::ffi::{c_char, CStr};
use std::sync::Mutex;

use ash::vk::{self, Handle};

use super::fake_chain::{self, hook, Tables};

/// What reached the fake below revz, per command buffer (by handle: the fake's handles are
/// distinct across tests).
static CALLS: Mutex<Vec<(usize, Call)>> = Mutex::new(Vec::new());

#[derive(Clone, Debug, PartialEq)]
enum Call {
    /// `vkCmdSetViewport`: first viewport, each (minDepth, maxDepth).
    SetViewport(u32, Vec<(f32, f32)>),
    BeginRendering,
    EndRendering,
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
        b"vkCmdExecuteCommands" => void_fn!(vk::PFN_vkCmdExecuteCommands, execute_commands),
        // SAFETY: the same arguments.
        _ => unsafe { fake_chain::fake_get_device_proc_addr_with_passes(device, name) },
    }
}

#[test]
fn viewports_go_down_before_secondaries_run_flipped_for_a_reversed_attachment() {
    let tables = Tables::fresh();
    let (instance, _) = fake_chain::create_instance(&[(c"mode", c"flip")]);
    fake_chain::take_events(tables.instance);
    let (physical, device, _) = fake_chain::create_device(tables, gdpa);
    let create_image = hook!(device, c"vkCreateImage", vk::PFN_vkCreateImage);
    let create_view = hook!(device, c"vkCreateImageView", vk::PFN_vkCreateImageView);
    let destroy_image = hook!(device, c"vkDestroyImage", vk::PFN_vkDestroyImage);
    let destroy_view = hook!(device, c"vkDestroyImageView", vk::PFN_vkDestroyImageView);
    let allocate = hook!(
        device,
        c"vkAllocateCommandBuffers",
        vk::PFN_vkAllocateCommandBuffers
    );
    let free = hook!(
        device,
        c"vkFreeCommandBuffers",
        vk::PFN_vkFreeCommandBuffers
    );
    let destroy_pool = hook!(
        device,
        c"vkDestroyCommandPool",
        vk::PFN_vkDestroyCommandPool
    );
    let begin = hook!(
        device,
        c"vkBeginCommandBuffer",
        vk::PFN_vkBeginCommandBuffer
    );
    let set_viewport = hook!(device, c"vkCmdSetViewport", vk::PFN_vkCmdSetViewport);
    let begin_rendering = hook!(device, c"vkCmdBeginRendering", vk::PFN_vkCmdBeginRendering);
    let end_rendering = hook!(device, c"vkCmdEndRendering", vk::PFN_vkCmdEndRendering);
    let execute = hook!(
        device,
        c"vkCmdExecuteCommands",
        vk::PFN_vkCmdExecuteCommands
    );

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
    let mut buffers = [vk::CommandBuffer::null(); 2];
    // SAFETY: a live device and valid create infos.
    unsafe {
        assert_eq!(
            create_image(device, &image_info, std::ptr::null(), &mut image),
            vk::Result::SUCCESS
        );
        let view_info = fake_chain::depth_view_info(image, vk::Format::D32_SFLOAT);
        assert_eq!(
            create_view(device, &view_info, std::ptr::null(), &mut view),
            vk::Result::SUCCESS
        );
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(2);
        assert_eq!(
            allocate(device, &info, buffers.as_mut_ptr()),
            vk::Result::SUCCESS
        );
    }
    let [primary, other] = buffers;
    let viewport = vk::Viewport {
        width: 64.0,
        height: 64.0,
        min_depth: 0.0,
        max_depth: 1.0,
        ..Default::default()
    };
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::LOAD)
        .store_op(vk::AttachmentStoreOp::STORE);
    let rendering = vk::RenderingInfo::default()
        .flags(vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS)
        .render_area(vk::Rect2D {
            extent: vk::Extent2D {
                width: 64,
                height: 64,
            },
            ..Default::default()
        })
        .layer_count(1)
        .depth_attachment(&depth);
    let secondaries = [vk::CommandBuffer::from_raw(0x5EC)];
    // SAFETY: recording primaries with valid arguments (the secondary is never looked at by
    // the fake).
    unsafe {
        // Into a reversed attachment, drawn by secondaries: the viewport goes down flipped
        // before the rendering instance begins, and nothing is recorded inside it.
        assert_eq!(
            begin(primary, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        set_viewport(primary, 0, 1, &viewport);
        begin_rendering(primary, &rendering);
        execute(primary, 1, secondaries.as_ptr());
        end_rendering(primary);
        // Outside a rendering instance: at vkCmdExecuteCommands (not reversed: as set).
        assert_eq!(
            begin(other, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        set_viewport(other, 0, 1, &viewport);
        execute(other, 1, secondaries.as_ptr());
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
    // SAFETY: nothing is in use; each object destroyed once.
    unsafe {
        free(device, pool, 2, buffers.as_ptr());
        destroy_pool(device, pool, std::ptr::null());
        destroy_view(device, view, std::ptr::null());
        destroy_image(device, image, std::ptr::null());
        fake_chain::tear_down(tables, instance, physical, device);
    }
}

#[test]
fn a_rendering_instance_of_inline_draws_and_secondaries_remembers_its_target_for_them() {
    let tables = Tables::fresh();
    let (instance, _) = fake_chain::create_instance(&[(c"mode", c"flip")]);
    fake_chain::take_events(tables.instance);
    let (physical, device, _) = fake_chain::create_device(tables, gdpa);
    let create_image = hook!(device, c"vkCreateImage", vk::PFN_vkCreateImage);
    let create_view = hook!(device, c"vkCreateImageView", vk::PFN_vkCreateImageView);
    let destroy_image = hook!(device, c"vkDestroyImage", vk::PFN_vkDestroyImage);
    let destroy_view = hook!(device, c"vkDestroyImageView", vk::PFN_vkDestroyImageView);
    let allocate = hook!(
        device,
        c"vkAllocateCommandBuffers",
        vk::PFN_vkAllocateCommandBuffers
    );
    let free = hook!(
        device,
        c"vkFreeCommandBuffers",
        vk::PFN_vkFreeCommandBuffers
    );
    let begin = hook!(
        device,
        c"vkBeginCommandBuffer",
        vk::PFN_vkBeginCommandBuffer
    );
    let begin_rendering = hook!(device, c"vkCmdBeginRendering", vk::PFN_vkCmdBeginRendering);
    let end_rendering = hook!(device, c"vkCmdEndRendering", vk::PFN_vkCmdEndRendering);
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
    let mut primary = vk::CommandBuffer::null();
    // SAFETY: a live device and valid create infos.
    unsafe {
        assert_eq!(
            create_image(device, &image_info, std::ptr::null(), &mut image),
            vk::Result::SUCCESS
        );
        let view_info = fake_chain::depth_view_info(image, vk::Format::D32_SFLOAT);
        assert_eq!(
            create_view(device, &view_info, std::ptr::null(), &mut view),
            vk::Result::SUCCESS
        );
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        assert_eq!(allocate(device, &info, &mut primary), vk::Result::SUCCESS);
    }
    // SAFETY: the fake's live device.
    let key = unsafe { crate::state::DispatchKey::of(device) };
    let state = crate::state::DEVICES.get(key).expect("the device");
    let remembered = crate::objects::SecondaryPass::Rendering(vk::Format::D32_SFLOAT);
    assert_eq!(state.objects.secondary_targets.get(&remembered), None);
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::LOAD)
        .store_op(vk::AttachmentStoreOp::STORE);
    // VK_RENDERING_CONTENTS_INLINE_BIT_KHR with secondaries (maintenance7).
    let inline = vk::RenderingFlags::from_raw(0x10);
    let rendering = vk::RenderingInfo::default()
        .flags(vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS | inline)
        .render_area(vk::Rect2D {
            extent: vk::Extent2D {
                width: 64,
                height: 64,
            },
            ..Default::default()
        })
        .layer_count(1)
        .depth_attachment(&depth);
    // SAFETY: recording a primary with valid arguments.
    unsafe {
        assert_eq!(
            begin(primary, &vk::CommandBufferBeginInfo::default()),
            vk::Result::SUCCESS
        );
        begin_rendering(primary, &rendering);
        end_rendering(primary);
    }
    // Secondaries without a framebuffer it executes draw into a reversed D32 attachment.
    assert_eq!(
        state.objects.secondary_targets.get(&remembered),
        Some(crate::command_state::Target::Reversed)
    );
    drop(state);
    // SAFETY: nothing is in use; each object destroyed once.
    unsafe {
        free(device, pool, 1, &primary);
        destroy_view(device, view, std::ptr::null());
        destroy_image(device, image, std::ptr::null());
        fake_chain::tear_down(tables, instance, physical, device);
    }
}
