//! Object-tracking hooks: depth images and their views, render passes, framebuffers, and
//! command buffer allocation. Each calls down first and records what was created only when the
//! driver succeeded; nothing here changes what the application passes.

use std::sync::{Arc, Mutex};

use ash::vk;

use super::{device_state, record};
use crate::boundary::EntryPoint;
use crate::objects::{self, ImageInfo};
use crate::policy::ImageDepth;

static CREATE_IMAGE: EntryPoint = EntryPoint::new("vkCreateImage");
static DESTROY_IMAGE: EntryPoint = EntryPoint::new("vkDestroyImage");
static CREATE_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkCreateImageView");
static DESTROY_IMAGE_VIEW: EntryPoint = EntryPoint::new("vkDestroyImageView");
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

// A destroyed image's handle may come back: its resolve pairs go with it.
destroy_hook!(
    destroy_image,
    DESTROY_IMAGE,
    vk::Image,
    images | resolve_pairs,
    destroy_image
);
destroy_hook!(
    destroy_image_view,
    DESTROY_IMAGE_VIEW,
    vk::ImageView,
    views,
    destroy_image_view
);
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
