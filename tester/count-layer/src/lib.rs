//! A counting layer for the benchmark (issue #17: "driver calls per frame, with and without
//! revz, equal in the steady state").
//!
//! Loaded below revz (or alone, for the run without revz), it counts the command-buffer
//! commands that reach it, which are what the driver receives, and at each `vkQueueSubmit`
//! takes a snapshot of the counts. At `vkDestroyDevice` it writes the snapshots to the file
//! named by `REVZ_COUNT_OUT`, one line per submission: `name=count` pairs, space-separated,
//! cumulative (the difference of two lines is what one submission's frame recorded).
//!
//! The loader stacks explicit layers in the order it finds their manifests, the first found
//! nearest the application, whatever the order of `VK_INSTANCE_LAYERS`: its manifest lives in
//! a directory of its own (`manifests/count/`), named after revz's in `VK_ADD_LAYER_PATH`.
//!
//! It is a test instrument, not a product: one instance and one device per process (what the
//! benchmark's children create), the commands in `COUNTED` only (what the draw storm records
//! and what revz may send down in its place), and every other command handed out as the next
//! layer's own. Counting is one relaxed atomic add per command.

// The library is named as the loader looks for layers (`libVkLayer_revz_count.so`).
#![allow(non_snake_case)]

use std::ffi::{c_char, c_void, CStr};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

use ash::vk;

/// `f` as the loader's `PFN_vkVoidFunction`.
macro_rules! void_fn {
    ($pfn:ty, $f:expr) => {{
        let typed: $pfn = $f;
        // SAFETY: function pointers share one representation; the caller casts it back to
        // the type the name implies, which is `$pfn`.
        Some(unsafe { std::mem::transmute::<$pfn, unsafe extern "system" fn()>(typed) })
    }};
}

/// `VkLayerFunction_`'s `VK_LAYER_LINK_INFO` (vk_layer.h).
const LAYER_LINK_INFO: u32 = 0;

#[repr(C)]
struct InstanceLink {
    next: *mut InstanceLink,
    next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    next_get_physical_device_proc_addr: *const c_void,
}

#[repr(C)]
struct DeviceLink {
    next: *mut DeviceLink,
    next_get_instance_proc_addr: vk::PFN_vkGetInstanceProcAddr,
    next_get_device_proc_addr: vk::PFN_vkGetDeviceProcAddr,
}

/// `VkLayerInstanceCreateInfo` and `VkLayerDeviceCreateInfo`: the union's first member is
/// the link pointer for `VK_LAYER_LINK_INFO`.
#[repr(C)]
struct LayerCreateInfo<L> {
    s_type: vk::StructureType,
    p_next: *const c_void,
    function: u32,
    link: *mut L,
}

/// The next layer's entry points (one instance and one device per process).
static NEXT_GIPA: AtomicUsize = AtomicUsize::new(0);
static NEXT_GDPA: AtomicUsize = AtomicUsize::new(0);

/// Cumulative counts at each submission.
static SNAPSHOTS: Mutex<Vec<[u64; COUNTED.len()]>> = Mutex::new(Vec::new());

/// The chain link of `kind` in a create info's `pNext` chain.
///
/// # Safety
/// `p_next` must be a valid chain.
unsafe fn link<L>(
    p_next: *const c_void,
    kind: vk::StructureType,
) -> Option<*mut LayerCreateInfo<L>> {
    let mut at = p_next.cast::<LayerCreateInfo<L>>();
    while !at.is_null() {
        // SAFETY: a valid chain (the caller's contract); every structure starts with sType
        // and pNext.
        let info = unsafe { &*at };
        if info.s_type == kind && info.function == LAYER_LINK_INFO {
            return Some(at.cast_mut());
        }
        at = info.p_next.cast();
    }
    None
}

fn next_gipa() -> Option<vk::PFN_vkGetInstanceProcAddr> {
    let raw = NEXT_GIPA.load(Ordering::Acquire);
    // SAFETY: stored from a `PFN_vkGetInstanceProcAddr`.
    (raw != 0).then(|| unsafe { std::mem::transmute::<usize, vk::PFN_vkGetInstanceProcAddr>(raw) })
}

fn next_gdpa() -> Option<vk::PFN_vkGetDeviceProcAddr> {
    let raw = NEXT_GDPA.load(Ordering::Acquire);
    // SAFETY: stored from a `PFN_vkGetDeviceProcAddr`.
    (raw != 0).then(|| unsafe { std::mem::transmute::<usize, vk::PFN_vkGetDeviceProcAddr>(raw) })
}

unsafe extern "system" fn create_instance(
    p_info: *const vk::InstanceCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_instance: *mut vk::Instance,
) -> vk::Result {
    // SAFETY: the loader's valid create info and chain.
    let Some(info) = (unsafe {
        link::<InstanceLink>(
            (*p_info).p_next,
            vk::StructureType::LOADER_INSTANCE_CREATE_INFO,
        )
    }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: the loader's link; advanced for the next layer, as the loader requires.
    let gipa = unsafe {
        let link = &*(*info).link;
        (*info).link = link.next;
        link.next_get_instance_proc_addr
    };
    NEXT_GIPA.store(gipa as usize, Ordering::Release);
    // SAFETY: a global command of the next layer.
    let Some(create) = (unsafe { gipa(vk::Instance::null(), c"vkCreateInstance".as_ptr()) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: the type the name implies; calling down with the application's arguments.
    unsafe {
        let create: vk::PFN_vkCreateInstance = std::mem::transmute(create);
        create(p_info, p_allocator, p_instance)
    }
}

unsafe extern "system" fn create_device(
    physical: vk::PhysicalDevice,
    p_info: *const vk::DeviceCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_device: *mut vk::Device,
) -> vk::Result {
    // SAFETY: the loader's valid create info and chain.
    let Some(info) = (unsafe {
        link::<DeviceLink>(
            (*p_info).p_next,
            vk::StructureType::LOADER_DEVICE_CREATE_INFO,
        )
    }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: the loader's link; advanced for the next layer.
    let (gipa, gdpa) = unsafe {
        let link = &*(*info).link;
        (*info).link = link.next;
        (
            link.next_get_instance_proc_addr,
            link.next_get_device_proc_addr,
        )
    };
    NEXT_GDPA.store(gdpa as usize, Ordering::Release);
    // SAFETY: `vkCreateDevice` of the next layer, with the type its name implies.
    unsafe {
        let Some(create) = gipa(vk::Instance::null(), c"vkCreateDevice".as_ptr()) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        let create: vk::PFN_vkCreateDevice = std::mem::transmute(create);
        create(physical, p_info, p_allocator, p_device)
    }
}

/// Defines the counted commands: a counter, the next layer's function and a wrapper each.
macro_rules! counted {
    ($($index:literal $name:literal $hook:ident $pfn:ty => ($($arg:ident: $ty:ty),*);)*) => {
        /// The commands counted, in the order of the written counts.
        const COUNTED: [&str; [$($index),*].len()] = [$($name),*];
        static COUNTS: [AtomicU64; COUNTED.len()] = [const { AtomicU64::new(0) }; COUNTED.len()];
        static NEXT: [AtomicUsize; COUNTED.len()] = [const { AtomicUsize::new(0) }; COUNTED.len()];
        $(
            unsafe extern "system" fn $hook($($arg: $ty),*) {
                COUNTS[$index].fetch_add(1, Ordering::Relaxed);
                // SAFETY: stored from the next layer's function of this name before the
                // wrapper was handed out.
                let next: $pfn = unsafe { std::mem::transmute(NEXT[$index].load(Ordering::Relaxed)) };
                // SAFETY: calling down with the caller's arguments.
                unsafe { next($($arg),*) }
            }
        )*
        /// The wrapper for `name`, recording the next layer's function `next`.
        fn counted_hook(name: &[u8], next: unsafe extern "system" fn()) -> vk::PFN_vkVoidFunction {
            $(
                if name == $name.as_bytes() {
                    NEXT[$index].store(next as usize, Ordering::Release);
                    return void_fn!($pfn, $hook);
                }
            )*
            None
        }
    };
}

type Cb = vk::CommandBuffer;

counted! {
    0 "vkCmdDraw" draw vk::PFN_vkCmdDraw => (c: Cb, a: u32, b: u32, d: u32, e: u32);
    1 "vkCmdDrawIndexed" draw_indexed vk::PFN_vkCmdDrawIndexed => (c: Cb, a: u32, b: u32, d: u32, e: i32, f: u32);
    2 "vkCmdPushConstants" push_constants vk::PFN_vkCmdPushConstants
        => (c: Cb, l: vk::PipelineLayout, s: vk::ShaderStageFlags, o: u32, n: u32, p: *const c_void);
    3 "vkCmdBindPipeline" bind_pipeline vk::PFN_vkCmdBindPipeline
        => (c: Cb, b: vk::PipelineBindPoint, p: vk::Pipeline);
    4 "vkCmdBindVertexBuffers" bind_vertex_buffers vk::PFN_vkCmdBindVertexBuffers
        => (c: Cb, f: u32, n: u32, b: *const vk::Buffer, o: *const vk::DeviceSize);
    5 "vkCmdSetViewport" set_viewport vk::PFN_vkCmdSetViewport
        => (c: Cb, f: u32, n: u32, v: *const vk::Viewport);
    6 "vkCmdSetViewportWithCount" set_viewport_with_count vk::PFN_vkCmdSetViewportWithCount
        => (c: Cb, n: u32, v: *const vk::Viewport);
    7 "vkCmdSetDepthCompareOp" set_depth_compare_op vk::PFN_vkCmdSetDepthCompareOp
        => (c: Cb, o: vk::CompareOp);
    8 "vkCmdSetDepthBias" set_depth_bias vk::PFN_vkCmdSetDepthBias => (c: Cb, a: f32, b: f32, d: f32);
    9 "vkCmdSetDepthBounds" set_depth_bounds vk::PFN_vkCmdSetDepthBounds => (c: Cb, a: f32, b: f32);
    10 "vkCmdBeginRenderPass" begin_render_pass vk::PFN_vkCmdBeginRenderPass
        => (c: Cb, b: *const vk::RenderPassBeginInfo<'_>, s: vk::SubpassContents);
    11 "vkCmdEndRenderPass" end_render_pass vk::PFN_vkCmdEndRenderPass => (c: Cb);
}

static NEXT_SUBMIT: AtomicUsize = AtomicUsize::new(0);
static NEXT_DESTROY_DEVICE: AtomicUsize = AtomicUsize::new(0);

unsafe extern "system" fn queue_submit(
    queue: vk::Queue,
    count: u32,
    p_submits: *const vk::SubmitInfo<'_>,
    fence: vk::Fence,
) -> vk::Result {
    let snapshot: [u64; COUNTED.len()] = std::array::from_fn(|i| COUNTS[i].load(Ordering::Relaxed));
    SNAPSHOTS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push(snapshot);
    // SAFETY: stored from the next layer's `vkQueueSubmit`.
    let next: vk::PFN_vkQueueSubmit =
        unsafe { std::mem::transmute(NEXT_SUBMIT.load(Ordering::Acquire)) };
    // SAFETY: calling down with the caller's arguments.
    unsafe { next(queue, count, p_submits, fence) }
}

unsafe extern "system" fn destroy_device(
    device: vk::Device,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    if let Some(path) = std::env::var_os("REVZ_COUNT_OUT") {
        let snapshots = SNAPSHOTS.lock().unwrap_or_else(|e| e.into_inner());
        let text: String = snapshots
            .iter()
            .map(|snapshot| {
                let pairs: Vec<String> = COUNTED
                    .iter()
                    .zip(snapshot)
                    .map(|(name, count)| format!("{name}={count}"))
                    .collect();
                pairs.join(" ") + "\n"
            })
            .collect();
        // A test instrument: a failure to write shows as a missing file to the benchmark.
        let _ = std::fs::write(path, text);
    }
    // SAFETY: stored from the next layer's `vkDestroyDevice`.
    let next: vk::PFN_vkDestroyDevice =
        unsafe { std::mem::transmute(NEXT_DESTROY_DEVICE.load(Ordering::Acquire)) };
    // SAFETY: calling down with the caller's arguments.
    unsafe { next(device, p_allocator) }
}

/// This layer's hook for `name`, given the next layer's function `next`.
fn hook(name: &[u8], next: unsafe extern "system" fn()) -> vk::PFN_vkVoidFunction {
    match name {
        b"vkQueueSubmit" => {
            NEXT_SUBMIT.store(next as usize, Ordering::Release);
            void_fn!(vk::PFN_vkQueueSubmit, queue_submit)
        }
        b"vkDestroyDevice" => {
            NEXT_DESTROY_DEVICE.store(next as usize, Ordering::Release);
            void_fn!(vk::PFN_vkDestroyDevice, destroy_device)
        }
        _ => counted_hook(name, next),
    }
}

/// `vkGetDeviceProcAddr`.
///
/// # Safety
/// Called by the loader or the layer above with a live device and a NUL-terminated name.
#[no_mangle]
pub unsafe extern "system" fn count_get_device_proc_addr(
    device: vk::Device,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: a NUL-terminated name (the caller's contract).
    let name = unsafe { CStr::from_ptr(p_name) }.to_bytes();
    if name == b"vkGetDeviceProcAddr" {
        return void_fn!(vk::PFN_vkGetDeviceProcAddr, count_get_device_proc_addr);
    }
    // SAFETY: calling down with the caller's arguments.
    let next = unsafe { next_gdpa()?(device, p_name) }?;
    hook(name, next).or(Some(next))
}

/// `vkGetInstanceProcAddr`.
///
/// # Safety
/// Called by the loader or the layer above with a NUL-terminated name.
#[no_mangle]
pub unsafe extern "system" fn count_get_instance_proc_addr(
    instance: vk::Instance,
    p_name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: a NUL-terminated name (the caller's contract).
    let name = unsafe { CStr::from_ptr(p_name) }.to_bytes();
    match name {
        b"vkGetInstanceProcAddr" => {
            void_fn!(vk::PFN_vkGetInstanceProcAddr, count_get_instance_proc_addr)
        }
        b"vkCreateInstance" => void_fn!(vk::PFN_vkCreateInstance, create_instance),
        b"vkCreateDevice" => void_fn!(vk::PFN_vkCreateDevice, create_device),
        b"vkGetDeviceProcAddr" => {
            void_fn!(vk::PFN_vkGetDeviceProcAddr, count_get_device_proc_addr)
        }
        // SAFETY: calling down with the caller's arguments.
        _ => unsafe { next_gipa()?(instance, p_name) },
    }
}

/// The loader-layer interface negotiation (`VkNegotiateLayerInterface`, version 2).
#[repr(C)]
#[derive(Debug)]
pub struct NegotiateLayerInterface {
    s_type: u32,
    p_next: *mut c_void,
    loader_layer_interface_version: u32,
    get_instance_proc_addr: Option<vk::PFN_vkGetInstanceProcAddr>,
    get_device_proc_addr: Option<vk::PFN_vkGetDeviceProcAddr>,
    get_physical_device_proc_addr: *const c_void,
}

/// `vkNegotiateLoaderLayerInterfaceVersion`.
///
/// # Safety
/// Called by the loader with a valid structure.
#[no_mangle]
pub unsafe extern "system" fn vkNegotiateLoaderLayerInterfaceVersion(
    interface: *mut NegotiateLayerInterface,
) -> vk::Result {
    // SAFETY: the loader's valid structure.
    let interface = unsafe { &mut *interface };
    interface.loader_layer_interface_version = interface.loader_layer_interface_version.min(2);
    interface.get_instance_proc_addr = Some(count_get_instance_proc_addr);
    interface.get_device_proc_addr = Some(count_get_device_proc_addr);
    interface.get_physical_device_proc_addr = std::ptr::null();
    vk::Result::SUCCESS
}
