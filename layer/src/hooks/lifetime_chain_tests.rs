//! Lifetimes of revz's per-thread state, through the fake loader chain: a command buffer
//! looked up from a thread-local destructor (a Vulkan call while a thread exits), and a freed
//! command buffer that the freeing thread's cache must not keep alive.

use std::sync::{Arc, Mutex};

use ash::vk::{self, Handle};

use super::fake_chain::{self, hook, Tables};
use crate::objects;
use crate::state::{DispatchKey, DEVICES};

/// A flip-mode device with one primary command buffer, and the hooks to free it.
fn device_with_command_buffer() -> (
    Tables,
    vk::Instance,
    vk::PhysicalDevice,
    vk::Device,
    vk::CommandBuffer,
) {
    let tables = Tables::fresh();
    let (instance, _) = fake_chain::create_instance(&[(c"mode", c"flip")]);
    // The settings reached the fake; nothing below looks at instance events.
    fake_chain::take_events(tables.instance);
    let (physical, device, _) =
        fake_chain::create_device(tables, fake_chain::fake_get_device_proc_addr_with_passes);
    let allocate = hook!(
        device,
        c"vkAllocateCommandBuffers",
        vk::PFN_vkAllocateCommandBuffers
    );
    let info = vk::CommandBufferAllocateInfo::default()
        .command_pool(vk::CommandPool::from_raw(1))
        .level(vk::CommandBufferLevel::PRIMARY)
        .command_buffer_count(1);
    let mut buffer = vk::CommandBuffer::null();
    // SAFETY: a live device, a valid info and room for one handle.
    let result = unsafe { allocate(device, &info, &mut buffer) };
    assert_eq!(result, vk::Result::SUCCESS);
    (tables, instance, physical, device, buffer)
}

fn free(device: vk::Device, buffer: vk::CommandBuffer) {
    let free = hook!(
        device,
        c"vkFreeCommandBuffers",
        vk::PFN_vkFreeCommandBuffers
    );
    // SAFETY: a command buffer of this device's pool, not in use.
    unsafe { free(device, vk::CommandPool::from_raw(1), 1, &buffer) };
}

fn finish(
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
) {
    let destroy_pool = hook!(
        device,
        c"vkDestroyCommandPool",
        vk::PFN_vkDestroyCommandPool
    );
    // SAFETY: the pool is no longer in use; then the fixture's objects, destroyed once.
    unsafe {
        destroy_pool(device, vk::CommandPool::from_raw(1), std::ptr::null());
        fake_chain::tear_down(tables, instance, physical, device);
    }
}

/// What the destructor below saw: whether revz's cache was already destroyed, and whether
/// the lookup found the command buffer; `None` if it panicked (or never ran).
static SEEN_IN_DESTRUCTOR: Mutex<Option<(bool, bool)>> = Mutex::new(None);

struct LooksUpWhenDropped(vk::CommandBuffer);

impl Drop for LooksUpWhenDropped {
    fn drop(&mut self) {
        let buffer = self.0;
        let seen = std::panic::catch_unwind(|| {
            let cache_gone = !objects::thread_cache_alive();
            let found = objects::with_command_buffer(buffer, |_| ()).is_some()
                && objects::command_buffer(buffer).is_some();
            (cache_gone, found)
        });
        *SEEN_IN_DESTRUCTOR
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = seen.ok();
    }
}

thread_local! {
    static GUARD: std::cell::RefCell<Option<LooksUpWhenDropped>> =
        const { std::cell::RefCell::new(None) };
}

#[test]
fn a_lookup_from_a_thread_local_destructor_after_the_cache_is_gone_does_not_panic() {
    let (tables, instance, physical, device, buffer) = device_with_command_buffer();
    std::thread::spawn(move || {
        // Registered first, so destroyed last (thread-local destructors run in reverse order
        // of registration): after revz's cache, which the lookup below registers.
        GUARD.with(|guard| *guard.borrow_mut() = Some(LooksUpWhenDropped(buffer)));
        assert!(objects::with_command_buffer(buffer, |_| ()).is_some());
    })
    .join()
    .expect("the thread exits cleanly");
    let seen = SEEN_IN_DESTRUCTOR
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .take();
    assert_eq!(
        seen,
        Some((true, true)),
        "the destructor ran after the cache's, did not panic, and found the command buffer"
    );
    free(device, buffer);
    finish(tables, instance, physical, device);
}

#[test]
fn a_freed_command_buffer_is_not_kept_alive_by_the_freeing_threads_cache() {
    let (tables, instance, physical, device, buffer) = device_with_command_buffer();
    // SAFETY: the fake's live device.
    let state = DEVICES
        .get(unsafe { DispatchKey::of(device) })
        .expect("the device is registered");
    // Cached on this thread by the lookup.
    assert!(objects::with_command_buffer(buffer, |_| ()).is_some());
    let with_buffer = Arc::strong_count(&state);
    free(device, buffer);
    assert!(objects::with_command_buffer(buffer, |_| ()).is_none());
    assert_eq!(
        Arc::strong_count(&state),
        with_buffer - 1,
        "the freed command buffer's entry (and its reference to the device) is gone"
    );
    drop(state);
    finish(tables, instance, physical, device);
}
