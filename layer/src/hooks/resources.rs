//! Object-tracking hooks: depth images and their views, render passes, framebuffers, and
//! command buffer allocation. Each calls down first and records what was created only when the
//! driver succeeded; nothing here changes what the application passes.

use std::sync::{Arc, Mutex};

use ash::vk;

use super::{device_state, record};
use crate::boundary::EntryPoint;
use crate::conv::has_depth;
use crate::objects::{self, ImageInfo, RenderPassInfo};
use crate::policy::ImageDepth;

static CREATE_IMAGE: EntryPoint = EntryPoint::new("vkCreateImage");
static DESTROY_IMAGE: EntryPoint = EntryPoint::new("vkDestroyImage");
static CREATE_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkCreateImageView");
static DESTROY_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkDestroyImageView");
static CREATE_RENDER_PASS: EntryPoint = EntryPoint::new("vkCreateRenderPass");
static CREATE_RENDER_PASS2: EntryPoint = EntryPoint::new("vkCreateRenderPass2");
static DESTROY_RENDER_PASS: EntryPoint = EntryPoint::new("vkDestroyRenderPass");
static CREATE_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkCreateFramebuffer");
static DESTROY_FRAMEBUFFER: EntryPoint = EntryPoint::new("vkDestroyFramebuffer");
static ALLOCATE_COMMAND_BUFFERS: EntryPoint = EntryPoint::new("vkAllocateCommandBuffers");
static FREE_COMMAND_BUFFERS: EntryPoint = EntryPoint::new("vkFreeCommandBuffers");
static DESTROY_COMMAND_POOL: EntryPoint = EntryPoint::new("vkDestroyCommandPool");

pub unsafe extern "system" fn create_image(
    device: vk::Device,
    p_create_info: *const vk::ImageCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_image: *mut vk::Image,
) -> vk::Result {
    // SAFETY: `device` is live (caller's contract).
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result =
        unsafe { (state.next.fp_v1_0().create_image)(device, p_create_info, p_allocator, p_image) };
    if result == vk::Result::SUCCESS {
        record(&CREATE_IMAGE, || {
            // SAFETY: valid on success.
            let (info, image) = unsafe { (&*p_create_info, *p_image) };
            let Some(depth) = state
                .policy
                .classify_image(info.format, info.usage, info.tiling)
            else {
                return;
            };
            let size = info.extent;
            let format = info.format;
            match depth {
                ImageDepth::Reversed => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): reversed",
                    size.width,
                    size.height
                ),
                ImageDepth::Native(reason) => log::info!(
                    "depth image {image:?} ({format:?}, {}x{}): native, because {reason}",
                    size.width,
                    size.height
                ),
            }
            state
                .objects
                .images
                .insert(image, ImageInfo { format, depth });
        });
    }
    result
}

pub unsafe extern "system" fn create_image_view(
    device: vk::Device,
    p_create_info: *const vk::ImageViewCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_view: *mut vk::ImageView,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_image_view)(device, p_create_info, p_allocator, p_view)
    };
    if result == vk::Result::SUCCESS {
        record(&CREATE_IMAGE_VIEW, || {
            // SAFETY: valid on success.
            let (info, view) = unsafe { (&*p_create_info, *p_view) };
            if state.objects.images.get(&info.image).is_some() {
                state.objects.views.insert(view, info.image);
            }
        });
    }
    result
}

/// Builds a [`RenderPassInfo`] from attachment formats and load ops and subpass depth refs.
fn render_pass_info(
    attachments: impl Iterator<Item = (vk::Format, vk::AttachmentLoadOp)>,
    subpass_depth: impl Iterator<Item = Option<u32>>,
) -> RenderPassInfo {
    let mut info = RenderPassInfo::default();
    for (format, load_op) in attachments {
        info.attachments.push(format);
        info.depth_cleared
            .push(has_depth(format) && load_op == vk::AttachmentLoadOp::CLEAR);
    }
    info.subpass_depth = subpass_depth
        .map(|index| index.filter(|&i| i != vk::ATTACHMENT_UNUSED))
        .collect();
    info
}

/// A slice from a Vulkan array pointer; empty for a null pointer or zero count.
///
/// # Safety
/// A non-null `ptr` must point at `count` valid elements.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, count: u32) -> &'a [T] {
    if ptr.is_null() || count == 0 {
        &[]
    } else {
        // SAFETY: the caller guarantees `count` elements.
        unsafe { std::slice::from_raw_parts(ptr, count as usize) }
    }
}

/// Defines a render pass creation hook (`vkCreateRenderPass` and `vkCreateRenderPass2` read
/// the same fields from different structures).
macro_rules! create_render_pass_hook {
    ($name:ident, $entry:ident, $info:ty, |$state:ident| $next:expr) => {
        pub unsafe extern "system" fn $name(
            device: vk::Device,
            p_create_info: *const $info,
            p_allocator: *const vk::AllocationCallbacks<'_>,
            p_render_pass: *mut vk::RenderPass,
        ) -> vk::Result {
            // SAFETY: `device` is live.
            let Some($state) = (unsafe { device_state(device) }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let Some(next) = $next else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: calling down with the application's arguments.
            let result = unsafe { next(device, p_create_info, p_allocator, p_render_pass) };
            if result == vk::Result::SUCCESS {
                record(&$entry, || {
                    // SAFETY: valid on success; arrays sized by their counts.
                    let info = unsafe { &*p_create_info };
                    // SAFETY: as above.
                    let (attachments, subpasses) = unsafe {
                        (
                            slice(info.p_attachments, info.attachment_count),
                            slice(info.p_subpasses, info.subpass_count),
                        )
                    };
                    let pass = render_pass_info(
                        attachments.iter().map(|a| (a.format, a.load_op)),
                        subpasses.iter().map(|s| {
                            // SAFETY: null or one valid reference.
                            unsafe { s.p_depth_stencil_attachment.as_ref() }.map(|r| r.attachment)
                        }),
                    );
                    // SAFETY: valid on success.
                    let handle = unsafe { *p_render_pass };
                    $state.objects.render_passes.insert(handle, Arc::new(pass));
                });
            }
            result
        }
    };
}

create_render_pass_hook!(
    create_render_pass,
    CREATE_RENDER_PASS,
    vk::RenderPassCreateInfo<'_>,
    |state| Some(state.next.fp_v1_0().create_render_pass)
);
create_render_pass_hook!(
    create_render_pass2,
    CREATE_RENDER_PASS2,
    vk::RenderPassCreateInfo2<'_>,
    |state| state.commands.create_render_pass2
);

destroy_hook!(
    destroy_image,
    DESTROY_IMAGE,
    vk::Image,
    images,
    destroy_image
);
destroy_hook!(
    destroy_image_view,
    DESTROY_IMAGE_VIEW,
    vk::ImageView,
    views,
    destroy_image_view
);
destroy_hook!(
    destroy_render_pass,
    DESTROY_RENDER_PASS,
    vk::RenderPass,
    render_passes,
    destroy_render_pass
);
destroy_hook!(
    destroy_framebuffer,
    DESTROY_FRAMEBUFFER,
    vk::Framebuffer,
    framebuffers,
    destroy_framebuffer
);

pub unsafe extern "system" fn create_framebuffer(
    device: vk::Device,
    p_create_info: *const vk::FramebufferCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_framebuffer: *mut vk::Framebuffer,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_framebuffer)(device, p_create_info, p_allocator, p_framebuffer)
    };
    if result == vk::Result::SUCCESS {
        record(&CREATE_FRAMEBUFFER, || {
            // SAFETY: valid on success.
            let info = unsafe { &*p_create_info };
            let views: Arc<[vk::ImageView]> =
                if info.flags.contains(vk::FramebufferCreateFlags::IMAGELESS) {
                    Arc::from([])
                } else {
                    // SAFETY: `attachmentCount` views.
                    Arc::from(unsafe { slice(info.p_attachments, info.attachment_count) })
                };
            // SAFETY: valid on success.
            state
                .objects
                .framebuffers
                .insert(unsafe { *p_framebuffer }, views);
        });
    }
    result
}

pub unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    p_allocate_info: *const vk::CommandBufferAllocateInfo<'_>,
    p_command_buffers: *mut vk::CommandBuffer,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().allocate_command_buffers)(device, p_allocate_info, p_command_buffers)
    };
    if result == vk::Result::SUCCESS {
        record(&ALLOCATE_COMMAND_BUFFERS, || {
            // SAFETY: valid on success: `commandBufferCount` handles were written.
            let info = unsafe { &*p_allocate_info };
            // SAFETY: as above.
            let buffers = unsafe { slice(p_command_buffers, info.command_buffer_count) };
            objects::track_command_buffers(&state, buffers, info.level);
            let pool = state
                .objects
                .pools
                .get(&info.command_pool)
                .unwrap_or_else(|| {
                    let list = Arc::new(Mutex::new(Vec::new()));
                    state
                        .objects
                        .pools
                        .insert(info.command_pool, Arc::clone(&list));
                    list
                });
            pool.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .extend_from_slice(buffers);
        });
    }
    result
}

pub unsafe extern "system" fn free_command_buffers(
    device: vk::Device,
    command_pool: vk::CommandPool,
    count: u32,
    p_command_buffers: *const vk::CommandBuffer,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&FREE_COMMAND_BUFFERS, || {
        // SAFETY: `count` handles (null entries are allowed and ignored).
        let buffers = unsafe { slice(p_command_buffers, count) };
        objects::forget_command_buffers(buffers);
        if let Some(pool) = state.objects.pools.get(&command_pool) {
            pool.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .retain(|b| !buffers.contains(b));
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe {
        (state.next.fp_v1_0().free_command_buffers)(device, command_pool, count, p_command_buffers)
    };
}

pub unsafe extern "system" fn destroy_command_pool(
    device: vk::Device,
    command_pool: vk::CommandPool,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    record(&DESTROY_COMMAND_POOL, || {
        if let Some(pool) = state.objects.pools.remove(&command_pool) {
            let buffers = pool
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            objects::forget_command_buffers(&buffers);
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { (state.next.fp_v1_0().destroy_command_pool)(device, command_pool, p_allocator) };
}
