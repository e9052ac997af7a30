//! A fake next layer for the chain tests: `extern "system"` stubs that stand below revz and
//! record what reaches them.
//!
//! Tests run in parallel threads of one process, and revz keys instances and devices by the
//! first word of their dispatchable handles (the loader's dispatch table). So every test takes
//! its own dispatch tables ([`Tables::fresh`]): the fake `vkCreateInstance` and
//! `vkCreateDevice` hand out objects whose first word is the calling test's table, command
//! buffers get their device's table, and what the fakes record is kept per table, so no test
//! sees another's calls. Non-dispatchable handles are distinct numbers from one counter.

use std::cell::Cell;
use std::ffi::{c_char, CStr};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use ash::vk::{self, Handle};

pub(super) type VoidFn = unsafe extern "system" fn();

/// revz's hook for a command, from its `vkGetDeviceProcAddr`, as the application gets it.
macro_rules! hook {
    ($device:expr, $name:expr, $pfn:ty) => {{
        // SAFETY: a live device and a NUL-terminated name.
        let found = unsafe { $crate::hooks::device::get_device_proc_addr($device, $name.as_ptr()) }
            .unwrap_or_else(|| panic!("revz hands out {:?}", $name));
        // SAFETY: the command named has this type.
        unsafe { std::mem::transmute::<$crate::hooks::fake_chain::VoidFn, $pfn>(found) }
    }};
}
pub(super) use hook;

/// Declares a struct of revz's hooks, each field the hook for one command as the application
/// gets it from `vkGetDeviceProcAddr`, with `of(device)` to look them all up.
macro_rules! hook_set {
    (struct $name:ident { $($field:ident: $command:literal => $pfn:ty),* $(,)? }) => {
        /// revz's hooks for the commands these tests call, as the application gets them.
        struct $name {
            $($field: $pfn,)*
        }

        impl $name {
            fn of(device: vk::Device) -> $name {
                $name {
                    $($field: $crate::hooks::fake_chain::hook!(device, $command, $pfn),)*
                }
            }
        }
    };
}
pub(super) use hook_set;

/// Dispatch tables: only their addresses matter (revz never reads through them), so distinct
/// elements of one static give every test addresses no other test uses.
static TABLE_SLOTS: [u8; 512] = [0; 512];
static NEXT_SLOT: AtomicUsize = AtomicUsize::new(0);

/// The dispatch tables of one test's instance (and physical devices) and device (and command
/// buffers).
#[derive(Clone, Copy, Debug)]
pub(super) struct Tables {
    pub instance: &'static u8,
    pub device: &'static u8,
}

thread_local! {
    /// The tables the fake `vkCreateInstance` and `vkCreateDevice` give the objects they make:
    /// revz calls them on the thread of the test that called revz.
    static CURRENT: Cell<Option<Tables>> = const { Cell::new(None) };
}

impl Tables {
    /// Two tables no other test (or earlier call) uses, made current for this thread's fake
    /// instance and device creations.
    pub fn fresh() -> Tables {
        let slot = || {
            let index = NEXT_SLOT.fetch_add(1, Ordering::Relaxed);
            TABLE_SLOTS
                .get(index)
                .expect("enough dispatch tables for every chain test")
        };
        let tables = Tables {
            instance: slot(),
            device: slot(),
        };
        CURRENT.with(|current| current.set(Some(tables)));
        tables
    }

    fn current() -> Tables {
        CURRENT
            .with(Cell::get)
            .expect("the test called Tables::fresh before creating through the fake chain")
    }
}

/// The key a table's events are recorded under.
pub(super) fn key(table: &'static u8) -> usize {
    table as *const u8 as usize
}

/// The dispatch table (first word) of a fake dispatchable object.
///
/// # Safety
/// `handle` must have been made by [`dispatchable`] and not yet reclaimed.
unsafe fn key_of<H: Handle>(handle: H) -> usize {
    // SAFETY: the caller guarantees a live object of one word.
    unsafe { *(handle.as_raw() as *const usize) }
}

/// A dispatchable object as the loader lays it out: its first word is the dispatch table.
pub(super) fn dispatchable<H: Handle>(table: usize) -> H {
    H::from_raw(Box::into_raw(Box::new(table)) as u64)
}

/// Destroys a device and then its instance through revz's hooks, checks that only the
/// instance's destruction reached the fake for the instance and that revz forgot both, frees
/// the fake objects, and returns what reached the fake for the device since last asked
/// (ending with its destruction).
///
/// # Safety
/// The three objects were made by the fake for `tables`, the device on the physical device of
/// the instance; nothing of theirs is in use, and none is used afterwards.
pub(super) unsafe fn tear_down(
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
) -> Vec<Event> {
    // SAFETY: the caller's contract: a live device, then a live instance.
    unsafe {
        super::device::destroy_device(device, std::ptr::null());
        super::instance::destroy_instance(instance, std::ptr::null());
    }
    let device_events = take_events(tables.device);
    assert_eq!(take_events(tables.instance), [Event::DestroyInstance]);
    // SAFETY: the keys of objects the fake made, destroyed above.
    unsafe {
        use crate::state::{DispatchKey, DEVICES, INSTANCES};
        assert!(DEVICES.get(DispatchKey::of(device)).is_none());
        assert!(INSTANCES.get(DispatchKey::of(instance)).is_none());
    }
    // SAFETY: the caller's contract.
    unsafe {
        reclaim(device);
        reclaim(physical);
        reclaim(instance);
    }
    device_events
}

/// Frees a fake dispatchable object.
///
/// # Safety
/// `handle` must have been made by [`dispatchable`], and is not used afterwards.
pub(super) unsafe fn reclaim<H: Handle>(handle: H) {
    // SAFETY: the caller guarantees a box made by `dispatchable`, freed once.
    drop(unsafe { Box::from_raw(handle.as_raw() as *mut usize) });
}

static NEXT_HANDLE: AtomicU64 = AtomicU64::new(0x1000);

/// A non-dispatchable handle no other fake object has.
fn fresh_handle<H: Handle>() -> H {
    H::from_raw(NEXT_HANDLE.fetch_add(1, Ordering::Relaxed))
}

/// A subpass's depth/stencil resolve structure as the fake `vkCreateRenderPass2` saw it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct SeenResolve {
    pub depth_mode: vk::ResolveModeFlags,
    pub stencil_mode: vk::ResolveModeFlags,
    pub attachment: u32,
}

/// The depth attachment of a `vkCmdBeginRendering` as the fake saw it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SeenDepthAttachment {
    /// Where the structure was: the application's, or a copy.
    pub address: usize,
    pub view: vk::ImageView,
    pub resolve_mode: vk::ResolveModeFlags,
    pub resolve_view: vk::ImageView,
    pub clear_depth: f32,
}

/// What reached the fake layer, recorded under the dispatch table of the object it was for.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Event {
    /// `vkCreateInstance` found `VkLayerSettingsCreateInfoEXT` first in the chain.
    SettingsPassedDown,
    DestroyInstance,
    DestroyDevice,
    CreateRenderPass2 {
        handle: vk::RenderPass,
        /// Each subpass's depth/stencil resolve structure, if it had one.
        resolves: Vec<Option<SeenResolve>>,
        allocator: bool,
    },
    DestroyRenderPass {
        handle: vk::RenderPass,
        allocator: bool,
    },
    BeginRenderPass2 {
        render_pass: vk::RenderPass,
        framebuffer: vk::Framebuffer,
        /// Where the clear values were: the application's array, or a copy.
        clear_values: usize,
        clear_depths: Vec<f32>,
    },
    EndRenderPass2,
    BeginRendering {
        depth: Option<SeenDepthAttachment>,
    },
    EndRendering,
    /// `vkCreateShaderModule` (the handle null where the fake was told to fail it).
    CreateShaderModule {
        handle: vk::ShaderModule,
        code: Vec<u32>,
        allocator: bool,
    },
    DestroyShaderModule {
        handle: vk::ShaderModule,
        allocator: bool,
    },
    /// `vkCreateGraphicsPipelines`: what it was given, what it answered.
    CreateGraphicsPipelines {
        cache: vk::PipelineCache,
        infos: Vec<SeenPipeline>,
        allocator: bool,
        result: vk::Result,
        /// The handles written (null where creation failed).
        handles: Vec<vk::Pipeline>,
    },
    DestroyPipeline {
        handle: vk::Pipeline,
        allocator: bool,
    },
    /// `vkCreateShadersEXT`: what it was given, what it answered.
    CreateShaders {
        /// Where the create info array was.
        infos_address: usize,
        infos: Vec<SeenShader>,
        allocator: bool,
        result: vk::Result,
        /// The handles written (null where creation failed).
        handles: Vec<vk::ShaderEXT>,
    },
    DestroyShader {
        handle: vk::ShaderEXT,
        allocator: bool,
    },
    /// `vkCmdBindShadersEXT` (null shaders where `pShaders` was null).
    BindShaders {
        stages: Vec<vk::ShaderStageFlags>,
        shaders: Vec<vk::ShaderEXT>,
    },
    /// `vkCreatePipelineLayout` (shader-object devices): its push-constant ranges as
    /// `(stages, offset, size)`.
    CreatePipelineLayout {
        handle: vk::PipelineLayout,
        ranges: Vec<(vk::ShaderStageFlags, u32, u32)>,
    },
    DestroyPipelineLayout {
        handle: vk::PipelineLayout,
    },
    /// `vkCmdSetDepthClampEnableEXT` and `vkCmdSetDepthClipEnableEXT` (shader-object devices).
    SetDepthClampEnable(bool),
    SetDepthClipEnable(bool),
    /// `vkCmdPushConstants` (shader-object devices).
    PushConstants {
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        bytes: Vec<u8>,
    },
    /// `vkCreateRenderPass` (the first version): its attachments' formats.
    CreateRenderPass {
        handle: vk::RenderPass,
        formats: Vec<vk::Format>,
        allocator: bool,
    },
    /// `vkCmdBeginRenderPass` (the first version).
    BeginRenderPass {
        render_pass: vk::RenderPass,
        framebuffer: vk::Framebuffer,
    },
    EndRenderPass,
    /// `vkCmdBindPipeline`.
    BindPipeline {
        bind_point: vk::PipelineBindPoint,
        pipeline: vk::Pipeline,
    },
    /// `vkCmdSetDepthBias`.
    SetDepthBias {
        constant: f32,
        clamp: f32,
        slope: f32,
    },
    /// `vkCmdSetDepthBias2EXT`, with the representation of a
    /// `VkDepthBiasRepresentationInfoEXT` in its chain.
    SetDepthBias2 {
        constant: f32,
        clamp: f32,
        slope: f32,
        representation: Option<vk::DepthBiasRepresentationEXT>,
    },
    /// `vkCmdSetDepthClampRangeEXT`: the mode, and the range where it is user-defined.
    SetDepthClampRange {
        mode: i32,
        range: Option<(f32, f32)>,
    },
    /// `vkCmdNextSubpass2`.
    NextSubpass2,
    /// `vkGetDeviceImageMemoryRequirements`: the format of the image asked about.
    GetDeviceImageMemoryRequirements {
        format: vk::Format,
    },
    // The detail events: recorded only for the devices of the tables that asked for them
    // ([`record_details`]), so that the tests written before them see what they always saw.
    /// `vkCreateImage` (details).
    CreateImage {
        handle: vk::Image,
        info: SeenImage,
    },
    /// `vkDestroyImage` (details).
    DestroyImage {
        handle: vk::Image,
    },
    /// `vkUpdateDescriptorSets` (details): each write's image infos (view and layout).
    UpdateDescriptorSets {
        image_infos: Vec<Vec<(vk::ImageView, vk::ImageLayout)>>,
    },
    /// `vkCmdCopyImage` (details): its images and each region's source and destination
    /// aspects.
    CopyImage {
        src: vk::Image,
        dst: vk::Image,
        aspects: Vec<(vk::ImageAspectFlags, vk::ImageAspectFlags)>,
    },
    /// `vkCmdPushDescriptorSet2KHR` (details): its set and each write's image infos.
    PushDescriptorSet2 {
        set: u32,
        image_infos: Vec<Vec<(vk::ImageView, vk::ImageLayout)>>,
    },
    /// `vkCreateImageView` (details).
    CreateImageView {
        handle: vk::ImageView,
        /// Where the create info was: the application's, or a copy.
        address: usize,
        image: vk::Image,
        format: vk::Format,
    },
    /// `vkDestroyImageView` (details).
    DestroyImageView {
        handle: vk::ImageView,
    },
    /// The attachment formats of the render pass a `vkCreateRenderPass2` created, right after
    /// its [`Event::CreateRenderPass2`] (details).
    RenderPass2Formats {
        handle: vk::RenderPass,
        formats: Vec<vk::Format>,
    },
    /// `vkCreateFramebuffer` (details).
    CreateFramebuffer {
        handle: vk::Framebuffer,
        /// Where the create info was: the application's, or a copy.
        address: usize,
        render_pass: vk::RenderPass,
        flags: vk::FramebufferCreateFlags,
        /// The views (none for an imageless framebuffer).
        attachments: Vec<vk::ImageView>,
        /// The view formats of each attachment image info of a
        /// `VkFramebufferAttachmentsCreateInfo` in the chain.
        image_view_formats: Option<Vec<Vec<vk::Format>>>,
    },
    /// `vkDestroyFramebuffer` (details).
    DestroyFramebuffer {
        handle: vk::Framebuffer,
    },
    /// `vkBeginCommandBuffer` (details).
    BeginCommandBuffer {
        /// Where the begin info was: the application's, or a copy.
        address: usize,
        /// The inheritance info, where it was not null.
        inheritance: Option<SeenInheritance>,
    },
}

/// An image create info as the fake `vkCreateImage` saw it: every field, its pointers as
/// addresses, the formats of its format list read out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct SeenImage {
    /// Where the create info was: the application's, or a copy.
    pub address: usize,
    pub p_next: usize,
    pub flags: vk::ImageCreateFlags,
    pub image_type: vk::ImageType,
    pub format: vk::Format,
    pub extent: vk::Extent3D,
    pub mip_levels: u32,
    pub array_layers: u32,
    pub samples: vk::SampleCountFlags,
    pub tiling: vk::ImageTiling,
    pub usage: vk::ImageUsageFlags,
    pub sharing_mode: vk::SharingMode,
    pub queue_family_index_count: u32,
    pub queue_family_indices: usize,
    pub initial_layout: vk::ImageLayout,
    /// The formats of a `VkImageFormatListCreateInfo` in the chain.
    pub view_formats: Option<Vec<vk::Format>>,
}

/// An image create info as the fake sees it (also for the tests to build what they expect).
///
/// # Safety
/// `info` has a valid pNext chain.
pub(super) unsafe fn seen_image(info: &vk::ImageCreateInfo<'_>) -> SeenImage {
    // SAFETY: the caller's contract.
    let list = unsafe { crate::chain::find::<vk::ImageFormatListCreateInfo<'_>>(info.p_next) };
    SeenImage {
        address: info as *const _ as usize,
        p_next: info.p_next as usize,
        flags: info.flags,
        image_type: info.image_type,
        format: info.format,
        extent: info.extent,
        mip_levels: info.mip_levels,
        array_layers: info.array_layers,
        samples: info.samples,
        tiling: info.tiling,
        usage: info.usage,
        sharing_mode: info.sharing_mode,
        queue_family_index_count: info.queue_family_index_count,
        queue_family_indices: info.p_queue_family_indices as usize,
        initial_layout: info.initial_layout,
        // SAFETY: `viewFormatCount` formats.
        view_formats: list.map(|list| unsafe {
            crate::hooks::resources::slice(list.p_view_formats, list.view_format_count).to_vec()
        }),
    }
}

/// The attachment formats of dynamic rendering, as a pipeline or a secondary's inheritance
/// names them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct SeenRendering {
    pub colors: Vec<vk::Format>,
    pub depth: vk::Format,
    pub stencil: vk::Format,
}

/// A secondary's inheritance info as the fake `vkBeginCommandBuffer` saw it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct SeenInheritance {
    /// Where the inheritance info was: the application's, or a copy.
    pub address: usize,
    pub render_pass: vk::RenderPass,
    pub subpass: u32,
    pub framebuffer: vk::Framebuffer,
    /// The formats of a `VkCommandBufferInheritanceRenderingInfo` in the chain.
    pub rendering: Option<SeenRendering>,
}

/// Tables whose devices' fakes record the detail events.
static DETAILED: Mutex<Vec<usize>> = Mutex::new(Vec::new());

/// Makes the fakes record the detail events (images, views, framebuffers, command buffer
/// begins, render pass formats) for the device of `table`.
pub(super) fn record_details(table: &'static u8) {
    DETAILED
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push(key(table));
}

/// Records a detail event, if the device of `table` asked for them.
fn note_detail(table: usize, event: impl FnOnce() -> Event) {
    let detailed = DETAILED
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .contains(&table);
    if detailed {
        note(table, event());
    }
}

/// A shader object create info as the fake `vkCreateShadersEXT` saw it: its pointers as
/// addresses, its code read out.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SeenShader {
    pub p_next: usize,
    pub flags: vk::ShaderCreateFlagsEXT,
    pub stage: vk::ShaderStageFlags,
    pub next_stage: vk::ShaderStageFlags,
    pub code_type: vk::ShaderCodeTypeEXT,
    pub code: Vec<u8>,
    pub name: usize,
    pub set_layouts: usize,
    pub push_constant_ranges: usize,
    pub specialization: usize,
}

impl SeenShader {
    /// A create info as the fake sees it (also for the tests to build what they expect).
    ///
    /// # Safety
    /// `info` holds `codeSize` bytes of code.
    pub unsafe fn of(info: &vk::ShaderCreateInfoEXT<'_>) -> SeenShader {
        SeenShader {
            p_next: info.p_next as usize,
            flags: info.flags,
            stage: info.stage,
            next_stage: info.next_stage,
            code_type: info.code_type,
            // SAFETY: the caller's contract.
            code: unsafe {
                crate::hooks::resources::slice(info.p_code.cast::<u8>(), info.code_size as u32)
            }
            .to_vec(),
            name: info.p_name as usize,
            set_layouts: info.p_set_layouts as usize,
            push_constant_ranges: info.p_push_constant_ranges as usize,
            specialization: info.p_specialization_info as usize,
        }
    }
}

/// A shader stage of a graphics pipeline create info as the fake `vkCreateGraphicsPipelines`
/// saw it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SeenStage {
    pub flags: vk::PipelineShaderStageCreateFlags,
    pub stage: vk::ShaderStageFlags,
    pub module: vk::ShaderModule,
    /// The stage's `pNext`: the address of the first structure of its chain.
    pub p_next: usize,
    /// The structure types of the stage's chain, in order.
    pub chain: Vec<vk::StructureType>,
    /// The SPIR-V of a `VkShaderModuleCreateInfo` anywhere in the stage's chain.
    pub inline_code: Option<Vec<u32>>,
    pub name: usize,
    pub specialization: usize,
}

/// A graphics pipeline create info as the fake `vkCreateGraphicsPipelines` saw it: its
/// pointers as addresses (the application's structures, or copies), and what revz may change
/// behind them (stages, dynamic states, the depth compare op) read out.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SeenPipeline {
    /// Where the create info itself was.
    pub address: usize,
    pub p_next: usize,
    /// The structure types of the create info's chain, in order.
    pub chain: Vec<vk::StructureType>,
    /// The libraries of a `VkPipelineLibraryCreateInfoKHR` in the chain.
    pub libraries: Vec<vk::Pipeline>,
    pub flags: vk::PipelineCreateFlags,
    /// The flags of a `VkPipelineCreateFlags2CreateInfoKHR` in the chain (which then replace
    /// `flags`).
    pub flags2: Option<vk::PipelineCreateFlags2KHR>,
    pub stages_address: usize,
    pub stages: Vec<SeenStage>,
    pub vertex_input: usize,
    pub input_assembly: usize,
    pub tessellation: usize,
    pub viewport: usize,
    pub rasterization: usize,
    /// The depth bias (constant, clamp, slope) of a non-null rasterization state.
    pub depth_bias: Option<(f32, f32, f32)>,
    pub multisample: usize,
    pub depth_stencil: usize,
    /// The depth compare op of a non-null depth-stencil state (the tests pass valid ones).
    pub depth_compare_op: Option<vk::CompareOp>,
    pub color_blend: usize,
    pub dynamic: usize,
    /// The dynamic states listed (none without a dynamic state).
    pub dynamic_states: Vec<vk::DynamicState>,
    pub layout: vk::PipelineLayout,
    pub render_pass: vk::RenderPass,
    pub subpass: u32,
    pub base_pipeline_handle: vk::Pipeline,
    pub base_pipeline_index: i32,
    /// The formats of a `VkPipelineRenderingCreateInfo` in the chain.
    pub rendering: Option<SeenRendering>,
}

/// The structure types of a valid `pNext` chain, in order.
fn chain_types(p_next: *const std::ffi::c_void) -> Vec<vk::StructureType> {
    // SAFETY: the fake is given valid chains.
    unsafe { crate::chain::structures(p_next) }
        .map(|base| base.s_type)
        .collect()
}

/// A pipeline shader stage's fields, its inline SPIR-V read out.
///
/// # Safety
/// `stage` has a valid pNext chain.
unsafe fn seen_stage(stage: &vk::PipelineShaderStageCreateInfo<'_>) -> SeenStage {
    // SAFETY: the caller's contract.
    let inline = unsafe { crate::chain::find::<vk::ShaderModuleCreateInfo<'_>>(stage.p_next) };
    SeenStage {
        flags: stage.flags,
        stage: stage.stage,
        module: stage.module,
        p_next: stage.p_next as usize,
        chain: chain_types(stage.p_next),
        // SAFETY: `codeSize` bytes of code.
        inline_code: inline.map(|inline| unsafe {
            crate::hooks::resources::slice(inline.p_code, (inline.code_size / 4) as u32).to_vec()
        }),
        name: stage.p_name as usize,
        specialization: stage.p_specialization_info as usize,
    }
}

/// A graphics pipeline create info as the fake sees it (also for the tests to build what they
/// expect from the application's create info).
///
/// # Safety
/// `info` is a valid create info whose depth-stencil state, if not null, is valid.
pub(super) unsafe fn seen_pipeline(info: &vk::GraphicsPipelineCreateInfo<'_>) -> SeenPipeline {
    // SAFETY: the caller's contract (`stageCount` valid stages, a valid chain, null or valid
    // state pointers).
    unsafe {
        let stages = crate::hooks::resources::slice(info.p_stages, info.stage_count);
        let flags2 = crate::chain::find::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(info.p_next);
        let dynamic = info.p_dynamic_state.as_ref();
        SeenPipeline {
            address: info as *const _ as usize,
            p_next: info.p_next as usize,
            chain: chain_types(info.p_next),
            libraries: crate::chain::find::<vk::PipelineLibraryCreateInfoKHR<'_>>(info.p_next)
                .map_or(Vec::new(), |links| {
                    crate::hooks::resources::slice(links.p_libraries, links.library_count).to_vec()
                }),
            flags: info.flags,
            flags2: flags2.map(|f| f.flags),
            stages_address: info.p_stages as usize,
            stages: stages.iter().map(|stage| seen_stage(stage)).collect(),
            vertex_input: info.p_vertex_input_state as usize,
            input_assembly: info.p_input_assembly_state as usize,
            tessellation: info.p_tessellation_state as usize,
            viewport: info.p_viewport_state as usize,
            rasterization: info.p_rasterization_state as usize,
            depth_bias: info.p_rasterization_state.as_ref().map(|r| {
                (
                    r.depth_bias_constant_factor,
                    r.depth_bias_clamp,
                    r.depth_bias_slope_factor,
                )
            }),
            multisample: info.p_multisample_state as usize,
            depth_stencil: info.p_depth_stencil_state as usize,
            depth_compare_op: info
                .p_depth_stencil_state
                .as_ref()
                .map(|d| d.depth_compare_op),
            color_blend: info.p_color_blend_state as usize,
            dynamic: info.p_dynamic_state as usize,
            dynamic_states: dynamic.map_or(Vec::new(), |d| {
                crate::hooks::resources::slice(d.p_dynamic_states, d.dynamic_state_count).to_vec()
            }),
            layout: info.layout,
            render_pass: info.render_pass,
            subpass: info.subpass,
            base_pipeline_handle: info.base_pipeline_handle,
            base_pipeline_index: info.base_pipeline_index,
            rendering: crate::chain::find::<vk::PipelineRenderingCreateInfo<'_>>(info.p_next).map(
                |r| SeenRendering {
                    colors: crate::hooks::resources::slice(
                        r.p_color_attachment_formats,
                        r.color_attachment_count,
                    )
                    .to_vec(),
                    depth: r.depth_attachment_format,
                    stencil: r.stencil_attachment_format,
                },
            ),
        }
    }
}

/// How the fake `vkCreateGraphicsPipelines` answers one call: its result, and which create
/// infos get a pipeline (a missing entry: created when the result is `SUCCESS`).
#[derive(Clone, Debug)]
pub(super) struct PipelineOutcome {
    pub result: vk::Result,
    pub created: Vec<bool>,
}

impl PipelineOutcome {
    /// Every pipeline created.
    pub fn success() -> PipelineOutcome {
        PipelineOutcome {
            result: vk::Result::SUCCESS,
            created: Vec::new(),
        }
    }

    /// No pipeline created.
    pub fn failure(result: vk::Result) -> PipelineOutcome {
        PipelineOutcome {
            result,
            created: Vec::new(),
        }
    }
}

/// The answers scripted for the next calls of the fake `vkCreateGraphicsPipelines` and
/// `vkCreateShaderModule`, per dispatch table; a call with none scripted succeeds.
static PIPELINE_OUTCOMES: Mutex<Vec<(usize, PipelineOutcome)>> = Mutex::new(Vec::new());
static SHADER_MODULE_RESULTS: Mutex<Vec<(usize, vk::Result)>> = Mutex::new(Vec::new());
static SHADER_OBJECT_RESULTS: Mutex<Vec<(usize, vk::Result)>> = Mutex::new(Vec::new());
static IMAGE_RESULTS: Mutex<Vec<(usize, vk::Result)>> = Mutex::new(Vec::new());

/// Scripts the results of the next calls of the fake `vkCreateImage` for the device of
/// `table`, in order (a failed call writes a null handle and notes nothing).
pub(super) fn script_image_creations(
    table: &'static u8,
    results: impl IntoIterator<Item = vk::Result>,
) {
    let key = key(table);
    IMAGE_RESULTS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .extend(results.into_iter().map(|result| (key, result)));
}

/// Scripts the results of the next calls of the fake `vkCreateShadersEXT` for the device of
/// `table`, in order (a failed call writes null handles).
pub(super) fn script_shader_object_creations(
    table: &'static u8,
    results: impl IntoIterator<Item = vk::Result>,
) {
    let key = key(table);
    SHADER_OBJECT_RESULTS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .extend(results.into_iter().map(|result| (key, result)));
}

/// Scripts the answers of the next calls of the fake `vkCreateGraphicsPipelines` for the
/// device of `table`, in order.
pub(super) fn script_pipeline_creations(
    table: &'static u8,
    outcomes: impl IntoIterator<Item = PipelineOutcome>,
) {
    let key = key(table);
    PIPELINE_OUTCOMES
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .extend(outcomes.into_iter().map(|outcome| (key, outcome)));
}

/// Scripts the results of the next calls of the fake `vkCreateShaderModule` for the device of
/// `table`, in order (a failed call writes a null handle).
pub(super) fn script_shader_module_creations(
    table: &'static u8,
    results: impl IntoIterator<Item = vk::Result>,
) {
    let key = key(table);
    SHADER_MODULE_RESULTS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .extend(results.into_iter().map(|result| (key, result)));
}

/// Takes the first scripted answer for `table`.
fn next_scripted<T>(script: &Mutex<Vec<(usize, T)>>, table: usize) -> Option<T> {
    let mut script = script.lock().unwrap_or_else(PoisonError::into_inner);
    let index = script.iter().position(|(key, _)| *key == table)?;
    Some(script.remove(index).1)
}

static EVENTS: Mutex<Vec<(usize, Event)>> = Mutex::new(Vec::new());

fn note(table: usize, event: Event) {
    EVENTS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push((table, event));
}

/// Removes and returns, in order, what the fakes recorded for `table`.
pub(super) fn take_events(table: &'static u8) -> Vec<Event> {
    let key = key(table);
    let mut events = EVENTS.lock().unwrap_or_else(PoisonError::into_inner);
    let (mine, others) = std::mem::take(&mut *events)
        .into_iter()
        .partition(|(table, _)| *table == key);
    *events = others;
    mine.into_iter().map(|(_, event)| event).collect()
}

pub(super) unsafe extern "system" fn fake_command() {}

/// The extensions each fake instance and device was created with, per dispatch table.
static CREATED_WITH: Mutex<Vec<(usize, Vec<String>)>> = Mutex::new(Vec::new());

/// Records the extension names an instance or device of `table` was created with.
///
/// # Safety
/// `names` must point at `count` NUL-terminated strings (or be null with `count` 0).
unsafe fn note_extensions(table: usize, names: *const *const c_char, count: u32) {
    // SAFETY: the caller's contract.
    let names = unsafe { super::extensions::names(names, count) };
    let names = names
        .iter()
        .map(|name| name.to_string_lossy().into_owned())
        .collect();
    CREATED_WITH
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push((table, names));
}

/// The extensions the fake's instance or device of `table` was created with (the last one).
pub(super) fn created_with(table: &'static u8) -> Vec<String> {
    let key = key(table);
    CREATED_WITH
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
        .rev()
        .find(|(table, _)| *table == key)
        .map(|(_, names)| names.clone())
        .unwrap_or_default()
}

pub(super) unsafe extern "system" fn fake_create_instance(
    create_info: *const vk::InstanceCreateInfo,
    _: *const vk::AllocationCallbacks,
    p_instance: *mut vk::Instance,
) -> vk::Result {
    let table = key(Tables::current().instance);
    // SAFETY: revz passes a valid create info.
    unsafe {
        note_extensions(
            table,
            (*create_info).pp_enabled_extension_names,
            (*create_info).enabled_extension_count,
        )
    };
    // SAFETY: revz passes the application's create info through.
    let first = unsafe { (*create_info).p_next.cast::<vk::BaseInStructure>().as_ref() };
    if first.map(|s| s.s_type) == Some(vk::StructureType::LAYER_SETTINGS_CREATE_INFO_EXT) {
        note(table, Event::SettingsPassedDown);
    }
    // SAFETY: revz passes the application's output pointer through.
    unsafe { *p_instance = dispatchable(table) };
    vk::Result::SUCCESS
}

unsafe extern "system" fn fake_destroy_instance(
    instance: vk::Instance,
    _: *const vk::AllocationCallbacks,
) {
    // SAFETY: the fake's live object.
    note(unsafe { key_of(instance) }, Event::DestroyInstance);
}

pub(super) unsafe extern "system" fn fake_create_device(
    _: vk::PhysicalDevice,
    create_info: *const vk::DeviceCreateInfo,
    _: *const vk::AllocationCallbacks,
    p_device: *mut vk::Device,
) -> vk::Result {
    // SAFETY: revz passes a valid create info.
    unsafe {
        note_extensions(
            key(Tables::current().device),
            (*create_info).pp_enabled_extension_names,
            (*create_info).enabled_extension_count,
        )
    };
    // SAFETY: revz passes the application's output pointer through.
    unsafe { *p_device = dispatchable(key(Tables::current().device)) };
    vk::Result::SUCCESS
}

pub(super) unsafe extern "system" fn fake_destroy_device(
    device: vk::Device,
    _: *const vk::AllocationCallbacks,
) {
    // SAFETY: the fake's live object.
    note(unsafe { key_of(device) }, Event::DestroyDevice);
}

/// A Vulkan 1.3 device with 128 bytes of push constants: the application above also asks for
/// 1.3, so the flip path is active.
unsafe extern "system" fn fake_get_physical_device_properties(
    _: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties,
) {
    // SAFETY: revz passes a valid output.
    unsafe {
        (*properties).api_version = vk::API_VERSION_1_3;
        // The push-constant space Vulkan guarantees (lavapipe's too).
        (*properties).limits.max_push_constants_size = 128;
    }
}

/// The `independentResolveNone` and `independentResolve` the fake reports, per instance
/// dispatch table (neither where none was set).
static RESOLVE_INDEPENDENCE: Mutex<Vec<(usize, (bool, bool))>> = Mutex::new(Vec::new());

/// Makes the fake report `independentResolveNone` and `independentResolve` for the physical
/// devices of the instance of `table` (revz reads them at device creation).
pub(super) fn set_resolve_independence(table: &'static u8, none: bool, all: bool) {
    RESOLVE_INDEPENDENCE
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push((key(table), (none, all)));
}

/// Every depth resolve mode (a device with MIN and MAX, which revz needs to swap them), the
/// stencil modes a stencil resolve may share with them, and the independence the test set.
unsafe extern "system" fn fake_get_physical_device_properties2(
    physical_device: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties2,
) {
    // SAFETY: the fake's physical device.
    let table = unsafe { key_of(physical_device) };
    let (none, all) = RESOLVE_INDEPENDENCE
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .iter()
        .find(|(key, _)| *key == table)
        .map_or((false, false), |(_, independence)| *independence);
    // SAFETY: revz passes a valid output chain.
    let mut next = unsafe { (*properties).p_next }.cast::<vk::BaseOutStructure>();
    // SAFETY: as above.
    while let Some(base) = unsafe { next.as_mut() } {
        if base.s_type == vk::StructureType::PHYSICAL_DEVICE_DEPTH_STENCIL_RESOLVE_PROPERTIES {
            // SAFETY: the sType identifies the structure.
            let resolve = unsafe {
                &mut *(base as *mut vk::BaseOutStructure)
                    .cast::<vk::PhysicalDeviceDepthStencilResolveProperties>()
            };
            resolve.supported_depth_resolve_modes = vk::ResolveModeFlags::SAMPLE_ZERO
                | vk::ResolveModeFlags::AVERAGE
                | vk::ResolveModeFlags::MIN
                | vk::ResolveModeFlags::MAX;
            resolve.supported_stencil_resolve_modes = vk::ResolveModeFlags::SAMPLE_ZERO
                | vk::ResolveModeFlags::MIN
                | vk::ResolveModeFlags::MAX;
            resolve.independent_resolve_none = none.into();
            resolve.independent_resolve = all.into();
        }
        next = base.p_next;
    }
}

pub(super) unsafe extern "system" fn fake_cmd_draw(
    _: vk::CommandBuffer,
    _: u32,
    _: u32,
    _: u32,
    _: u32,
) {
}

pub(super) unsafe extern "system" fn fake_cmd_set_depth_compare_op(
    _: vk::CommandBuffer,
    _: vk::CompareOp,
) {
}

/// Instances (dispatch tables) whose physical devices report one device-local memory type (for
/// the read twin tests); the others report none, so revz allocates nothing.
static WITH_MEMORY: Mutex<Vec<usize>> = Mutex::new(Vec::new());

/// Makes the physical devices of the instance of `table` report one device-local memory type.
pub(super) fn give_memory(table: &'static u8) {
    WITH_MEMORY
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push(key(table));
}

unsafe extern "system" fn fake_get_physical_device_memory_properties(
    physical_device: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceMemoryProperties,
) {
    // SAFETY: the fake's physical device.
    let table = unsafe { key_of(physical_device) };
    let mut memory = vk::PhysicalDeviceMemoryProperties::default();
    if WITH_MEMORY
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .contains(&table)
    {
        memory.memory_type_count = 1;
        memory.memory_types[0].property_flags = vk::MemoryPropertyFlags::DEVICE_LOCAL;
        memory.memory_heap_count = 1;
    }
    // SAFETY: revz passes a valid output.
    unsafe { *properties = memory };
}

/// Formats the fake's physical devices do not support as images (for the promotion tests),
/// per instance dispatch table.
static UNSUPPORTED_IMAGE_FORMATS: Mutex<Vec<(usize, vk::Format)>> = Mutex::new(Vec::new());

/// Makes the physical devices of the instance of `table` refuse images of `format` (revz asks
/// when it would promote an image to it).
pub(super) fn refuse_image_format(table: &'static u8, format: vk::Format) {
    UNSUPPORTED_IMAGE_FORMATS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push((key(table), format));
}

/// Every image the fake is asked about is supported (up to 4096 texels a side, every sample
/// count), but for the formats [`refuse_image_format`] named for the physical device's
/// instance.
unsafe extern "system" fn fake_get_physical_device_image_format_properties(
    physical_device: vk::PhysicalDevice,
    format: vk::Format,
    _: vk::ImageType,
    _: vk::ImageTiling,
    _: vk::ImageUsageFlags,
    _: vk::ImageCreateFlags,
    properties: *mut vk::ImageFormatProperties,
) -> vk::Result {
    // SAFETY: the fake's physical device.
    let table = unsafe { key_of(physical_device) };
    let unsupported = UNSUPPORTED_IMAGE_FORMATS
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .contains(&(table, format));
    if unsupported {
        return vk::Result::ERROR_FORMAT_NOT_SUPPORTED;
    }
    // SAFETY: revz passes a valid output.
    unsafe {
        *properties = vk::ImageFormatProperties {
            max_extent: vk::Extent3D {
                width: 4096,
                height: 4096,
                depth: 1,
            },
            max_mip_levels: 13,
            max_array_layers: 256,
            sample_counts: vk::SampleCountFlags::from_raw(0x7f),
            max_resource_size: 1 << 32,
        }
    };
    vk::Result::SUCCESS
}

/// The fake's physical devices have no optional core feature (so revz enables none).
unsafe extern "system" fn fake_get_physical_device_features(
    _: vk::PhysicalDevice,
    features: *mut vk::PhysicalDeviceFeatures,
) {
    // SAFETY: revz passes a valid output.
    unsafe { *features = vk::PhysicalDeviceFeatures::default() };
}

/// The fake layer's `vkGetInstanceProcAddr`.
pub(super) unsafe extern "system" fn fake_get_instance_proc_addr(
    _: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let name = unsafe { CStr::from_ptr(name) };
    match name.to_bytes() {
        b"vkCreateInstance" => void_fn!(vk::PFN_vkCreateInstance, fake_create_instance),
        b"vkDestroyInstance" => void_fn!(vk::PFN_vkDestroyInstance, fake_destroy_instance),
        b"vkCreateDevice" => void_fn!(vk::PFN_vkCreateDevice, fake_create_device),
        b"vkGetPhysicalDeviceProperties" => void_fn!(
            vk::PFN_vkGetPhysicalDeviceProperties,
            fake_get_physical_device_properties
        ),
        b"vkGetPhysicalDeviceProperties2" => void_fn!(
            vk::PFN_vkGetPhysicalDeviceProperties2,
            fake_get_physical_device_properties2
        ),
        b"vkEnumerateDeviceExtensionProperties" => void_fn!(
            vk::PFN_vkEnumerateDeviceExtensionProperties,
            fake_enumerate_device_extension_properties
        ),
        b"vkGetPhysicalDeviceImageFormatProperties" => void_fn!(
            vk::PFN_vkGetPhysicalDeviceImageFormatProperties,
            fake_get_physical_device_image_format_properties
        ),
        b"vkGetPhysicalDeviceMemoryProperties" => void_fn!(
            vk::PFN_vkGetPhysicalDeviceMemoryProperties,
            fake_get_physical_device_memory_properties
        ),
        b"vkGetPhysicalDeviceFeatures" => void_fn!(
            vk::PFN_vkGetPhysicalDeviceFeatures,
            fake_get_physical_device_features
        ),
        b"vkFakeInstanceCommand" => Some(fake_command),
        b"vkGetPhysicalDeviceFeatures2KHR" => Some(fake_command),
        _ => None,
    }
}

/// The fake's physical devices offer one extension: `VK_EXT_extended_dynamic_state`.
unsafe extern "system" fn fake_enumerate_device_extension_properties(
    _: vk::PhysicalDevice,
    _: *const c_char,
    count: *mut u32,
    properties: *mut vk::ExtensionProperties,
) -> vk::Result {
    let mut offered = vk::ExtensionProperties::default();
    for (to, from) in offered
        .extension_name
        .iter_mut()
        .zip(super::extensions::EXTENDED_DYNAMIC_STATE.to_bytes_with_nul())
    {
        *to = *from as c_char;
    }
    // SAFETY: revz passes a valid count, and room for it where `properties` is not null.
    unsafe {
        if !properties.is_null() && *count >= 1 {
            *properties = offered;
        }
        *count = 1;
    }
    vk::Result::SUCCESS
}

/// The fake layer's `vkGetDeviceProcAddr` for a device with only a few commands (no render
/// passes, no dynamic rendering).
pub(super) unsafe extern "system" fn fake_get_device_proc_addr(
    _: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let name = unsafe { CStr::from_ptr(name) };
    match name.to_bytes() {
        b"vkDestroyDevice" => void_fn!(vk::PFN_vkDestroyDevice, fake_destroy_device),
        b"vkFakeDeviceCommand" => Some(fake_command),
        b"vkCmdDraw" => void_fn!(vk::PFN_vkCmdDraw, fake_cmd_draw),
        b"vkCmdSetDepthCompareOp" | b"vkCmdSetDepthCompareOpEXT" => {
            void_fn!(
                vk::PFN_vkCmdSetDepthCompareOp,
                fake_cmd_set_depth_compare_op
            )
        }
        _ => None,
    }
}

/// The fake layer's `vkGetDeviceProcAddr` for a device that also has images, render passes,
/// framebuffers, command buffers and dynamic rendering (core 1.3 names).
pub(super) unsafe extern "system" fn fake_get_device_proc_addr_with_passes(
    device: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let bytes = unsafe { CStr::from_ptr(name) }.to_bytes();
    match bytes {
        b"vkCreateImage" => void_fn!(vk::PFN_vkCreateImage, passes::create_image),
        b"vkDestroyImage" => void_fn!(vk::PFN_vkDestroyImage, passes::destroy_image),
        b"vkCreateImageView" => void_fn!(vk::PFN_vkCreateImageView, passes::create_image_view),
        b"vkDestroyImageView" => {
            void_fn!(vk::PFN_vkDestroyImageView, passes::destroy_image_view)
        }
        b"vkGetDeviceImageMemoryRequirements" => void_fn!(
            vk::PFN_vkGetDeviceImageMemoryRequirements,
            passes::get_device_image_memory_requirements
        ),
        b"vkGetImageMemoryRequirements" => void_fn!(
            vk::PFN_vkGetImageMemoryRequirements,
            passes::get_image_memory_requirements
        ),
        b"vkAllocateMemory" => void_fn!(vk::PFN_vkAllocateMemory, passes::allocate_memory),
        b"vkFreeMemory" => void_fn!(vk::PFN_vkFreeMemory, passes::free_memory),
        b"vkBindImageMemory" => void_fn!(vk::PFN_vkBindImageMemory, passes::bind_image_memory),
        b"vkCmdPushDescriptorSet2KHR" => void_fn!(
            vk::PFN_vkCmdPushDescriptorSet2KHR,
            passes::cmd_push_descriptor_set2
        ),
        b"vkCmdCopyImage" => void_fn!(vk::PFN_vkCmdCopyImage, passes::cmd_copy_image),
        b"vkUpdateDescriptorSets" => void_fn!(
            vk::PFN_vkUpdateDescriptorSets,
            passes::update_descriptor_sets
        ),
        b"vkCreateRenderPass" => {
            void_fn!(vk::PFN_vkCreateRenderPass, passes::create_render_pass)
        }
        b"vkCreateRenderPass2" => {
            void_fn!(vk::PFN_vkCreateRenderPass2, passes::create_render_pass2)
        }
        b"vkDestroyRenderPass" => {
            void_fn!(vk::PFN_vkDestroyRenderPass, passes::destroy_render_pass)
        }
        b"vkCreateFramebuffer" => {
            void_fn!(vk::PFN_vkCreateFramebuffer, passes::create_framebuffer)
        }
        b"vkDestroyFramebuffer" => {
            void_fn!(vk::PFN_vkDestroyFramebuffer, passes::destroy_framebuffer)
        }
        b"vkAllocateCommandBuffers" => void_fn!(
            vk::PFN_vkAllocateCommandBuffers,
            passes::allocate_command_buffers
        ),
        b"vkFreeCommandBuffers" => {
            void_fn!(vk::PFN_vkFreeCommandBuffers, passes::free_command_buffers)
        }
        b"vkDestroyCommandPool" => {
            void_fn!(vk::PFN_vkDestroyCommandPool, passes::destroy_command_pool)
        }
        b"vkBeginCommandBuffer" => {
            void_fn!(vk::PFN_vkBeginCommandBuffer, passes::begin_command_buffer)
        }
        b"vkCmdBeginRenderPass" => {
            void_fn!(vk::PFN_vkCmdBeginRenderPass, passes::cmd_begin_render_pass)
        }
        b"vkCmdEndRenderPass" => {
            void_fn!(vk::PFN_vkCmdEndRenderPass, passes::cmd_end_render_pass)
        }
        b"vkCmdBeginRenderPass2" => void_fn!(
            vk::PFN_vkCmdBeginRenderPass2,
            passes::cmd_begin_render_pass2
        ),
        b"vkCmdEndRenderPass2" => {
            void_fn!(vk::PFN_vkCmdEndRenderPass2, passes::cmd_end_render_pass2)
        }
        b"vkCmdNextSubpass2" => {
            void_fn!(vk::PFN_vkCmdNextSubpass2, passes::cmd_next_subpass2)
        }
        b"vkCmdBeginRendering" => {
            void_fn!(vk::PFN_vkCmdBeginRendering, passes::cmd_begin_rendering)
        }
        b"vkCmdEndRendering" => {
            void_fn!(vk::PFN_vkCmdEndRendering, passes::cmd_end_rendering)
        }
        // SAFETY: forwarding the caller's arguments.
        _ => unsafe { fake_get_device_proc_addr(device, name) },
    }
}

/// The fake layer's `vkGetDeviceProcAddr` for a device that also has shader modules, graphics
/// pipelines, their binding and the state revz sends before their draws (besides everything of
/// [`fake_get_device_proc_addr_with_passes`]).
pub(super) unsafe extern "system" fn fake_get_device_proc_addr_with_pipelines(
    device: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let bytes = unsafe { CStr::from_ptr(name) }.to_bytes();
    match bytes {
        b"vkCreateShaderModule" => {
            void_fn!(
                vk::PFN_vkCreateShaderModule,
                pipelines::create_shader_module
            )
        }
        b"vkDestroyShaderModule" => {
            void_fn!(
                vk::PFN_vkDestroyShaderModule,
                pipelines::destroy_shader_module
            )
        }
        b"vkCreateGraphicsPipelines" => void_fn!(
            vk::PFN_vkCreateGraphicsPipelines,
            pipelines::create_graphics_pipelines
        ),
        b"vkDestroyPipeline" => void_fn!(vk::PFN_vkDestroyPipeline, pipelines::destroy_pipeline),
        b"vkCmdBindPipeline" => void_fn!(vk::PFN_vkCmdBindPipeline, pipelines::cmd_bind_pipeline),
        b"vkCmdSetDepthBias" => {
            void_fn!(vk::PFN_vkCmdSetDepthBias, pipelines::cmd_set_depth_bias)
        }
        b"vkCmdSetDepthBias2EXT" => {
            void_fn!(
                vk::PFN_vkCmdSetDepthBias2EXT,
                pipelines::cmd_set_depth_bias2
            )
        }
        b"vkCmdSetDepthClampRangeEXT" => void_fn!(
            crate::vk_ext::PfnCmdSetDepthClampRange,
            pipelines::cmd_set_depth_clamp_range
        ),
        b"vkCmdSetViewport" => void_fn!(vk::PFN_vkCmdSetViewport, pipelines::cmd_set_viewport),
        b"vkCmdSetDepthBounds" => {
            void_fn!(vk::PFN_vkCmdSetDepthBounds, pipelines::cmd_set_depth_bounds)
        }
        // SAFETY: forwarding the caller's arguments.
        _ => unsafe { fake_get_device_proc_addr_with_passes(device, name) },
    }
}

/// The fake layer's `vkGetDeviceProcAddr` for a device that also has shader objects
/// (`VK_EXT_shader_object`; besides everything of [`fake_get_device_proc_addr_with_pipelines`]).
pub(super) unsafe extern "system" fn fake_get_device_proc_addr_with_shader_objects(
    device: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    // SAFETY: revz only asks for NUL-terminated names.
    let bytes = unsafe { CStr::from_ptr(name) }.to_bytes();
    match bytes {
        b"vkCreateShadersEXT" => {
            void_fn!(vk::PFN_vkCreateShadersEXT, shader_objects::create_shaders)
        }
        b"vkDestroyShaderEXT" => {
            void_fn!(vk::PFN_vkDestroyShaderEXT, shader_objects::destroy_shader)
        }
        b"vkCmdBindShadersEXT" => {
            void_fn!(
                vk::PFN_vkCmdBindShadersEXT,
                shader_objects::cmd_bind_shaders
            )
        }
        b"vkCreatePipelineLayout" => void_fn!(
            vk::PFN_vkCreatePipelineLayout,
            shader_objects::create_pipeline_layout
        ),
        b"vkDestroyPipelineLayout" => void_fn!(
            vk::PFN_vkDestroyPipelineLayout,
            shader_objects::destroy_pipeline_layout
        ),
        b"vkCmdPushConstants" => void_fn!(
            vk::PFN_vkCmdPushConstants,
            shader_objects::cmd_push_constants
        ),
        b"vkCmdSetDepthClampEnableEXT" => void_fn!(
            vk::PFN_vkCmdSetDepthClampEnableEXT,
            shader_objects::cmd_set_depth_clamp_enable
        ),
        b"vkCmdSetDepthClipEnableEXT" => void_fn!(
            vk::PFN_vkCmdSetDepthClipEnableEXT,
            shader_objects::cmd_set_depth_clip_enable
        ),
        // SAFETY: forwarding the caller's arguments.
        _ => unsafe { fake_get_device_proc_addr_with_pipelines(device, name) },
    }
}

/// The commands of [`fake_get_device_proc_addr_with_shader_objects`].
pub(super) mod shader_objects {
    use super::*;

    pub(in crate::hooks) unsafe extern "system" fn create_shaders(
        device: vk::Device,
        count: u32,
        p_create_infos: *const vk::ShaderCreateInfoEXT,
        p_allocator: *const vk::AllocationCallbacks,
        p_shaders: *mut vk::ShaderEXT,
    ) -> vk::Result {
        // SAFETY: the fake's live device.
        let table = unsafe { key_of(device) };
        let result = next_scripted(&SHADER_OBJECT_RESULTS, table).unwrap_or(vk::Result::SUCCESS);
        // SAFETY: `count` valid create infos.
        let infos = unsafe { crate::hooks::resources::slice(p_create_infos, count) };
        // SAFETY: as above.
        let seen = infos
            .iter()
            .map(|info| unsafe { SeenShader::of(info) })
            .collect();
        let handles: Vec<vk::ShaderEXT> = (0..count)
            .map(|_| {
                if result == vk::Result::SUCCESS {
                    fresh_handle()
                } else {
                    vk::ShaderEXT::null()
                }
            })
            .collect();
        for (index, &handle) in handles.iter().enumerate() {
            // SAFETY: room for `count` handles.
            unsafe { *p_shaders.add(index) = handle };
        }
        let event = Event::CreateShaders {
            infos_address: p_create_infos as usize,
            infos: seen,
            allocator: !p_allocator.is_null(),
            result,
            handles,
        };
        note(table, event);
        result
    }

    pub(in crate::hooks) unsafe extern "system" fn create_pipeline_layout(
        device: vk::Device,
        p_create_info: *const vk::PipelineLayoutCreateInfo,
        _: *const vk::AllocationCallbacks,
        p_layout: *mut vk::PipelineLayout,
    ) -> vk::Result {
        // SAFETY: a valid create info and its `pushConstantRangeCount` ranges.
        let ranges = unsafe {
            let info = &*p_create_info;
            crate::hooks::resources::slice(
                info.p_push_constant_ranges,
                info.push_constant_range_count,
            )
        }
        .iter()
        .map(|r| (r.stage_flags, r.offset, r.size))
        .collect();
        let handle = fresh_handle();
        // SAFETY: room for the handle.
        unsafe { *p_layout = handle };
        // SAFETY: the fake's live device.
        note(
            unsafe { key_of(device) },
            Event::CreatePipelineLayout { handle, ranges },
        );
        vk::Result::SUCCESS
    }

    pub(in crate::hooks) unsafe extern "system" fn destroy_pipeline_layout(
        device: vk::Device,
        handle: vk::PipelineLayout,
        _: *const vk::AllocationCallbacks,
    ) {
        // SAFETY: the fake's live device.
        note(
            unsafe { key_of(device) },
            Event::DestroyPipelineLayout { handle },
        );
    }

    pub(in crate::hooks) unsafe extern "system" fn cmd_set_depth_clamp_enable(
        buffer: vk::CommandBuffer,
        enable: vk::Bool32,
    ) {
        // SAFETY: the fake's live command buffer.
        note(
            unsafe { key_of(buffer) },
            Event::SetDepthClampEnable(enable == vk::TRUE),
        );
    }

    pub(in crate::hooks) unsafe extern "system" fn cmd_set_depth_clip_enable(
        buffer: vk::CommandBuffer,
        enable: vk::Bool32,
    ) {
        // SAFETY: the fake's live command buffer.
        note(
            unsafe { key_of(buffer) },
            Event::SetDepthClipEnable(enable == vk::TRUE),
        );
    }

    pub(in crate::hooks) unsafe extern "system" fn cmd_push_constants(
        buffer: vk::CommandBuffer,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        offset: u32,
        size: u32,
        p_values: *const std::ffi::c_void,
    ) {
        // SAFETY: `size` bytes of values.
        let bytes = unsafe { crate::hooks::resources::slice(p_values.cast::<u8>(), size) }.to_vec();
        // SAFETY: the fake's live command buffer.
        note(
            unsafe { key_of(buffer) },
            Event::PushConstants {
                layout,
                stages,
                offset,
                bytes,
            },
        );
    }

    pub(in crate::hooks) unsafe extern "system" fn destroy_shader(
        device: vk::Device,
        handle: vk::ShaderEXT,
        p_allocator: *const vk::AllocationCallbacks,
    ) {
        let event = Event::DestroyShader {
            handle,
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        note(unsafe { key_of(device) }, event);
    }

    pub(in crate::hooks) unsafe extern "system" fn cmd_bind_shaders(
        buffer: vk::CommandBuffer,
        count: u32,
        p_stages: *const vk::ShaderStageFlags,
        p_shaders: *const vk::ShaderEXT,
    ) {
        // SAFETY: `count` stages, and `count` shaders unless null.
        let (stages, shaders) = unsafe {
            let stages = crate::hooks::resources::slice(p_stages, count).to_vec();
            let shaders = if p_shaders.is_null() {
                vec![vk::ShaderEXT::null(); count as usize]
            } else {
                crate::hooks::resources::slice(p_shaders, count).to_vec()
            };
            (stages, shaders)
        };
        // SAFETY: the fake's live command buffer.
        note(
            unsafe { key_of(buffer) },
            Event::BindShaders { stages, shaders },
        );
    }
}

/// The commands of [`fake_get_device_proc_addr_with_pipelines`].
mod pipelines {
    use super::*;

    pub(super) unsafe extern "system" fn create_shader_module(
        device: vk::Device,
        p_create_info: *const vk::ShaderModuleCreateInfo,
        p_allocator: *const vk::AllocationCallbacks,
        p_module: *mut vk::ShaderModule,
    ) -> vk::Result {
        // SAFETY: the fake's live device.
        let table = unsafe { key_of(device) };
        let result = next_scripted(&SHADER_MODULE_RESULTS, table).unwrap_or(vk::Result::SUCCESS);
        let handle = if result == vk::Result::SUCCESS {
            fresh_handle()
        } else {
            vk::ShaderModule::null()
        };
        // SAFETY: a valid create info of `codeSize` bytes, and a valid output pointer.
        let code = unsafe {
            let info = &*p_create_info;
            *p_module = handle;
            crate::hooks::resources::slice(info.p_code, (info.code_size / 4) as u32).to_vec()
        };
        let event = Event::CreateShaderModule {
            handle,
            code,
            allocator: !p_allocator.is_null(),
        };
        note(table, event);
        result
    }

    pub(super) unsafe extern "system" fn destroy_shader_module(
        device: vk::Device,
        handle: vk::ShaderModule,
        p_allocator: *const vk::AllocationCallbacks,
    ) {
        let event = Event::DestroyShaderModule {
            handle,
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        note(unsafe { key_of(device) }, event);
    }

    pub(super) unsafe extern "system" fn create_graphics_pipelines(
        device: vk::Device,
        cache: vk::PipelineCache,
        count: u32,
        p_create_infos: *const vk::GraphicsPipelineCreateInfo,
        p_allocator: *const vk::AllocationCallbacks,
        p_pipelines: *mut vk::Pipeline,
    ) -> vk::Result {
        // SAFETY: the fake's live device.
        let table = unsafe { key_of(device) };
        let outcome =
            next_scripted(&PIPELINE_OUTCOMES, table).unwrap_or_else(PipelineOutcome::success);
        // SAFETY: `count` valid create infos.
        let infos = unsafe { crate::hooks::resources::slice(p_create_infos, count) };
        // SAFETY: as above.
        let seen = infos.iter().map(|info| unsafe { seen_pipeline(info) });
        let seen: Vec<SeenPipeline> = seen.collect();
        let handles: Vec<vk::Pipeline> = (0..count as usize)
            .map(|index| {
                let created = outcome
                    .created
                    .get(index)
                    .copied()
                    .unwrap_or(outcome.result == vk::Result::SUCCESS);
                if created {
                    fresh_handle()
                } else {
                    vk::Pipeline::null()
                }
            })
            .collect();
        for (index, &handle) in handles.iter().enumerate() {
            // SAFETY: room for `count` handles.
            unsafe { *p_pipelines.add(index) = handle };
        }
        let event = Event::CreateGraphicsPipelines {
            cache,
            infos: seen,
            allocator: !p_allocator.is_null(),
            result: outcome.result,
            handles,
        };
        note(table, event);
        outcome.result
    }

    pub(super) unsafe extern "system" fn destroy_pipeline(
        device: vk::Device,
        handle: vk::Pipeline,
        p_allocator: *const vk::AllocationCallbacks,
    ) {
        let event = Event::DestroyPipeline {
            handle,
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        note(unsafe { key_of(device) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_bind_pipeline(
        buffer: vk::CommandBuffer,
        bind_point: vk::PipelineBindPoint,
        pipeline: vk::Pipeline,
    ) {
        let event = Event::BindPipeline {
            bind_point,
            pipeline,
        };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_set_depth_bias(
        buffer: vk::CommandBuffer,
        constant: f32,
        clamp: f32,
        slope: f32,
    ) {
        let event = Event::SetDepthBias {
            constant,
            clamp,
            slope,
        };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_set_depth_clamp_range(
        buffer: vk::CommandBuffer,
        mode: i32,
        p_range: *const crate::vk_ext::DepthClampRange,
    ) {
        // SAFETY: null or a valid range (revz passes one where the mode is user-defined).
        let range = unsafe { p_range.as_ref() }.map(|r| (r.min_depth_clamp, r.max_depth_clamp));
        let event = Event::SetDepthClampRange { mode, range };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_set_depth_bias2(
        buffer: vk::CommandBuffer,
        p_info: *const vk::DepthBiasInfoEXT,
    ) {
        // SAFETY: a valid info with a valid chain.
        let (info, representation) = unsafe {
            let info = &*p_info;
            let representation =
                crate::chain::find::<vk::DepthBiasRepresentationInfoEXT<'_>>(info.p_next);
            (info, representation.map(|r| r.depth_bias_representation))
        };
        let event = Event::SetDepthBias2 {
            constant: info.depth_bias_constant_factor,
            clamp: info.depth_bias_clamp,
            slope: info.depth_bias_slope_factor,
            representation,
        };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    /// Not recorded: revz sends the viewports of pipelines whose static viewport it made
    /// dynamic before their draws.
    pub(super) unsafe extern "system" fn cmd_set_viewport(
        _: vk::CommandBuffer,
        _: u32,
        _: u32,
        _: *const vk::Viewport,
    ) {
    }

    /// Not recorded, as above.
    pub(super) unsafe extern "system" fn cmd_set_depth_bounds(
        _: vk::CommandBuffer,
        _: f32,
        _: f32,
    ) {
    }
}

/// The commands of [`fake_get_device_proc_addr_with_passes`].
mod passes {
    use super::*;

    /// The depth/stencil resolve structure in a subpass's pNext chain.
    fn seen_resolve(subpass: &vk::SubpassDescription2<'_>) -> Option<SeenResolve> {
        let mut next = subpass.p_next.cast::<vk::BaseInStructure>();
        // SAFETY: revz passes a valid chain (the application's, or its own copy in front).
        while let Some(base) = unsafe { next.as_ref() } {
            if base.s_type == vk::StructureType::SUBPASS_DESCRIPTION_DEPTH_STENCIL_RESOLVE {
                // SAFETY: the sType identifies the structure.
                let resolve =
                    unsafe { &*next.cast::<vk::SubpassDescriptionDepthStencilResolve<'_>>() };
                // SAFETY: null or one valid reference.
                let attachment = unsafe { resolve.p_depth_stencil_resolve_attachment.as_ref() };
                return Some(SeenResolve {
                    depth_mode: resolve.depth_resolve_mode,
                    stencil_mode: resolve.stencil_resolve_mode,
                    attachment: attachment.map_or(vk::ATTACHMENT_UNUSED, |a| a.attachment),
                });
            }
            next = base.p_next;
        }
        None
    }

    pub(super) unsafe extern "system" fn create_image(
        device: vk::Device,
        p_create_info: *const vk::ImageCreateInfo,
        _: *const vk::AllocationCallbacks,
        p_image: *mut vk::Image,
    ) -> vk::Result {
        // SAFETY: the fake's live device.
        let table = unsafe { key_of(device) };
        let result = next_scripted(&IMAGE_RESULTS, table).unwrap_or(vk::Result::SUCCESS);
        if result != vk::Result::SUCCESS {
            // SAFETY: revz passes the application's output pointer through.
            unsafe { *p_image = vk::Image::null() };
            return result;
        }
        let handle = fresh_handle();
        // SAFETY: revz passes the application's output pointer through.
        unsafe { *p_image = handle };
        note_detail(table, || Event::CreateImage {
            handle,
            // SAFETY: a valid create info with a valid chain.
            info: unsafe { seen_image(&*p_create_info) },
        });
        vk::Result::SUCCESS
    }

    /// `vkCmdCopyImage`: notes its images and regions' aspects.
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe extern "system" fn cmd_copy_image(
        buffer: vk::CommandBuffer,
        src: vk::Image,
        _src_layout: vk::ImageLayout,
        dst: vk::Image,
        _dst_layout: vk::ImageLayout,
        count: u32,
        p_regions: *const vk::ImageCopy,
    ) {
        // SAFETY: `count` regions.
        let regions = unsafe { std::slice::from_raw_parts(p_regions, count as usize) };
        let aspects = regions
            .iter()
            .map(|r| (r.src_subresource.aspect_mask, r.dst_subresource.aspect_mask))
            .collect();
        // SAFETY: a live command buffer of the fake.
        note_detail(unsafe { key_of(buffer) }, || Event::CopyImage {
            src,
            dst,
            aspects,
        });
    }

    /// `vkCmdPushDescriptorSet2KHR`: notes its set and image infos.
    pub(super) unsafe extern "system" fn cmd_push_descriptor_set2(
        buffer: vk::CommandBuffer,
        p_info: *const vk::PushDescriptorSetInfoKHR<'_>,
    ) {
        // SAFETY: a valid info.
        let info = unsafe { &*p_info };
        // SAFETY: its writes.
        let image_infos =
            unsafe { image_infos(info.descriptor_write_count, info.p_descriptor_writes) };
        // SAFETY: a live command buffer of the fake.
        note_detail(unsafe { key_of(buffer) }, || Event::PushDescriptorSet2 {
            set: info.set,
            image_infos,
        });
    }

    /// Each write's image infos (view and layout).
    ///
    /// # Safety
    /// `count` valid writes, each with `descriptorCount` image infos or none.
    unsafe fn image_infos(
        count: u32,
        p_writes: *const vk::WriteDescriptorSet,
    ) -> Vec<Vec<(vk::ImageView, vk::ImageLayout)>> {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts(p_writes, count as usize) }
            .iter()
            .map(|write| {
                if write.p_image_info.is_null() {
                    return Vec::new();
                }
                // SAFETY: as above.
                unsafe {
                    std::slice::from_raw_parts(write.p_image_info, write.descriptor_count as usize)
                }
                .iter()
                .map(|info| (info.image_view, info.image_layout))
                .collect()
            })
            .collect()
    }

    pub(super) unsafe extern "system" fn update_descriptor_sets(
        device: vk::Device,
        write_count: u32,
        p_writes: *const vk::WriteDescriptorSet,
        _: u32,
        _: *const vk::CopyDescriptorSet,
    ) {
        // SAFETY: `writeCount` valid writes, each with `descriptorCount` image infos or none.
        let image_infos = unsafe { image_infos(write_count, p_writes) };
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || Event::UpdateDescriptorSets {
            image_infos,
        });
    }

    /// `vkGetImageMemoryRequirements`: 256 bytes of any memory type.
    pub(super) unsafe extern "system" fn get_image_memory_requirements(
        _: vk::Device,
        _: vk::Image,
        p_requirements: *mut vk::MemoryRequirements,
    ) {
        // SAFETY: revz's output pointer.
        unsafe {
            *p_requirements = vk::MemoryRequirements {
                size: 256,
                alignment: 16,
                memory_type_bits: u32::MAX,
            }
        };
    }

    pub(super) unsafe extern "system" fn allocate_memory(
        _: vk::Device,
        _: *const vk::MemoryAllocateInfo,
        _: *const vk::AllocationCallbacks,
        p_memory: *mut vk::DeviceMemory,
    ) -> vk::Result {
        // SAFETY: revz's output pointer.
        unsafe { *p_memory = fresh_handle() };
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn free_memory(
        _: vk::Device,
        _: vk::DeviceMemory,
        _: *const vk::AllocationCallbacks,
    ) {
    }

    pub(super) unsafe extern "system" fn bind_image_memory(
        _: vk::Device,
        _: vk::Image,
        _: vk::DeviceMemory,
        _: vk::DeviceSize,
    ) -> vk::Result {
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn destroy_image(
        device: vk::Device,
        handle: vk::Image,
        _: *const vk::AllocationCallbacks,
    ) {
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || Event::DestroyImage { handle });
    }

    pub(super) unsafe extern "system" fn create_image_view(
        device: vk::Device,
        p_create_info: *const vk::ImageViewCreateInfo,
        _: *const vk::AllocationCallbacks,
        p_view: *mut vk::ImageView,
    ) -> vk::Result {
        let handle = fresh_handle();
        // SAFETY: as above.
        unsafe { *p_view = handle };
        // SAFETY: a valid create info.
        let info = unsafe { &*p_create_info };
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || Event::CreateImageView {
            handle,
            address: p_create_info as usize,
            image: info.image,
            format: info.format,
        });
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn destroy_image_view(
        device: vk::Device,
        handle: vk::ImageView,
        _: *const vk::AllocationCallbacks,
    ) {
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || Event::DestroyImageView {
            handle,
        });
    }

    /// Answers the bytes of the image's texels as copies count them (one level, layer and
    /// sample).
    pub(super) unsafe extern "system" fn get_device_image_memory_requirements(
        device: vk::Device,
        p_info: *const vk::DeviceImageMemoryRequirements,
        p_requirements: *mut vk::MemoryRequirements2,
    ) {
        // SAFETY: a valid info whose create info is valid, and a valid output.
        let format = unsafe {
            let image = &*(*p_info).p_create_info;
            (*p_requirements).memory_requirements.size =
                crate::conv::depth_texel_bytes(image.format)
                    * u64::from(image.extent.width)
                    * u64::from(image.extent.height);
            image.format
        };
        // SAFETY: the fake's live device.
        note(
            unsafe { key_of(device) },
            Event::GetDeviceImageMemoryRequirements { format },
        );
    }

    pub(super) unsafe extern "system" fn create_render_pass(
        device: vk::Device,
        p_create_info: *const vk::RenderPassCreateInfo,
        p_allocator: *const vk::AllocationCallbacks,
        p_render_pass: *mut vk::RenderPass,
    ) -> vk::Result {
        // SAFETY: a valid create info with `attachmentCount` attachments.
        let attachments = unsafe {
            let info = &*p_create_info;
            crate::hooks::resources::slice(info.p_attachments, info.attachment_count)
        };
        let handle = fresh_handle();
        // SAFETY: a valid output pointer.
        unsafe { *p_render_pass = handle };
        let event = Event::CreateRenderPass {
            handle,
            formats: attachments.iter().map(|a| a.format).collect(),
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        note(unsafe { key_of(device) }, event);
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn create_render_pass2(
        device: vk::Device,
        p_create_info: *const vk::RenderPassCreateInfo2,
        p_allocator: *const vk::AllocationCallbacks,
        p_render_pass: *mut vk::RenderPass,
    ) -> vk::Result {
        // SAFETY: a valid create info with `subpassCount` subpasses.
        let subpasses = unsafe {
            let info = &*p_create_info;
            crate::hooks::resources::slice(info.p_subpasses, info.subpass_count)
        };
        // SAFETY: as above, `attachmentCount` attachments.
        let attachments = unsafe {
            let info = &*p_create_info;
            crate::hooks::resources::slice(info.p_attachments, info.attachment_count)
        };
        let handle = fresh_handle();
        // SAFETY: a valid output pointer.
        unsafe { *p_render_pass = handle };
        let event = Event::CreateRenderPass2 {
            handle,
            resolves: subpasses.iter().map(seen_resolve).collect(),
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        let table = unsafe { key_of(device) };
        note(table, event);
        note_detail(table, || Event::RenderPass2Formats {
            handle,
            formats: attachments.iter().map(|a| a.format).collect(),
        });
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn destroy_render_pass(
        device: vk::Device,
        handle: vk::RenderPass,
        p_allocator: *const vk::AllocationCallbacks,
    ) {
        let event = Event::DestroyRenderPass {
            handle,
            allocator: !p_allocator.is_null(),
        };
        // SAFETY: the fake's live device.
        note(unsafe { key_of(device) }, event);
    }

    pub(super) unsafe extern "system" fn create_framebuffer(
        device: vk::Device,
        p_create_info: *const vk::FramebufferCreateInfo,
        _: *const vk::AllocationCallbacks,
        p_framebuffer: *mut vk::Framebuffer,
    ) -> vk::Result {
        let handle = fresh_handle();
        // SAFETY: a valid output pointer.
        unsafe { *p_framebuffer = handle };
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || {
            // SAFETY: a valid create info: `attachmentCount` views unless imageless, and a
            // valid chain whose attachment image infos have `viewFormatCount` formats each.
            unsafe {
                let info = &*p_create_info;
                let imageless = info.flags.contains(vk::FramebufferCreateFlags::IMAGELESS);
                let images =
                    crate::chain::find::<vk::FramebufferAttachmentsCreateInfo<'_>>(info.p_next);
                Event::CreateFramebuffer {
                    handle,
                    address: p_create_info as usize,
                    render_pass: info.render_pass,
                    flags: info.flags,
                    attachments: if imageless {
                        Vec::new()
                    } else {
                        crate::hooks::resources::slice(info.p_attachments, info.attachment_count)
                            .to_vec()
                    },
                    image_view_formats: images.map(|images| {
                        crate::hooks::resources::slice(
                            images.p_attachment_image_infos,
                            images.attachment_image_info_count,
                        )
                        .iter()
                        .map(|image| {
                            crate::hooks::resources::slice(
                                image.p_view_formats,
                                image.view_format_count,
                            )
                            .to_vec()
                        })
                        .collect()
                    }),
                }
            }
        });
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn destroy_framebuffer(
        device: vk::Device,
        handle: vk::Framebuffer,
        _: *const vk::AllocationCallbacks,
    ) {
        // SAFETY: the fake's live device.
        note_detail(unsafe { key_of(device) }, || Event::DestroyFramebuffer {
            handle,
        });
    }

    /// Command buffers are dispatchable: their first word is their device's table.
    pub(super) unsafe extern "system" fn allocate_command_buffers(
        device: vk::Device,
        p_allocate_info: *const vk::CommandBufferAllocateInfo,
        p_command_buffers: *mut vk::CommandBuffer,
    ) -> vk::Result {
        // SAFETY: the fake's live device; a valid info and room for its count.
        unsafe {
            let table = key_of(device);
            for index in 0..(*p_allocate_info).command_buffer_count as usize {
                *p_command_buffers.add(index) = dispatchable(table);
            }
        }
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn free_command_buffers(
        _: vk::Device,
        _: vk::CommandPool,
        count: u32,
        p_command_buffers: *const vk::CommandBuffer,
    ) {
        // SAFETY: `count` handles made by `allocate_command_buffers` (or null), freed once.
        for &buffer in unsafe { crate::hooks::resources::slice(p_command_buffers, count) } {
            if buffer != vk::CommandBuffer::null() {
                // SAFETY: as above.
                unsafe { reclaim(buffer) };
            }
        }
    }

    pub(super) unsafe extern "system" fn destroy_command_pool(
        _: vk::Device,
        _: vk::CommandPool,
        _: *const vk::AllocationCallbacks,
    ) {
    }

    pub(super) unsafe extern "system" fn begin_command_buffer(
        buffer: vk::CommandBuffer,
        p_begin: *const vk::CommandBufferBeginInfo,
    ) -> vk::Result {
        // SAFETY: the fake's live command buffer.
        note_detail(unsafe { key_of(buffer) }, || {
            // SAFETY: a valid begin info; the tests pass a null or valid inheritance info
            // (with a valid chain).
            let inheritance = unsafe { (*p_begin).p_inheritance_info.as_ref() };
            Event::BeginCommandBuffer {
                address: p_begin as usize,
                inheritance: inheritance.map(|i| SeenInheritance {
                    address: i as *const _ as usize,
                    render_pass: i.render_pass,
                    subpass: i.subpass,
                    framebuffer: i.framebuffer,
                    // SAFETY: as above; `colorAttachmentCount` formats.
                    rendering: unsafe {
                        crate::chain::find::<vk::CommandBufferInheritanceRenderingInfo<'_>>(
                            i.p_next,
                        )
                    }
                    .map(|r| SeenRendering {
                        // SAFETY: as above.
                        colors: unsafe {
                            crate::hooks::resources::slice(
                                r.p_color_attachment_formats,
                                r.color_attachment_count,
                            )
                        }
                        .to_vec(),
                        depth: r.depth_attachment_format,
                        stencil: r.stencil_attachment_format,
                    }),
                }),
            }
        });
        vk::Result::SUCCESS
    }

    pub(super) unsafe extern "system" fn cmd_begin_render_pass(
        buffer: vk::CommandBuffer,
        p_begin: *const vk::RenderPassBeginInfo,
        _: vk::SubpassContents,
    ) {
        // SAFETY: a valid begin info.
        let begin = unsafe { &*p_begin };
        let event = Event::BeginRenderPass {
            render_pass: begin.render_pass,
            framebuffer: begin.framebuffer,
        };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_end_render_pass(buffer: vk::CommandBuffer) {
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, Event::EndRenderPass);
    }

    pub(super) unsafe extern "system" fn cmd_begin_render_pass2(
        buffer: vk::CommandBuffer,
        p_begin: *const vk::RenderPassBeginInfo,
        _: *const vk::SubpassBeginInfo,
    ) {
        // SAFETY: a valid begin info with `clearValueCount` values.
        let (begin, clears) = unsafe {
            let begin = &*p_begin;
            let clears =
                crate::hooks::resources::slice(begin.p_clear_values, begin.clear_value_count);
            (begin, clears)
        };
        let event = Event::BeginRenderPass2 {
            render_pass: begin.render_pass,
            framebuffer: begin.framebuffer,
            clear_values: begin.p_clear_values as usize,
            // SAFETY: the tests' clear values are all depth/stencil values.
            clear_depths: clears
                .iter()
                .map(|c| unsafe { c.depth_stencil.depth })
                .collect(),
        };
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, event);
    }

    pub(super) unsafe extern "system" fn cmd_next_subpass2(
        buffer: vk::CommandBuffer,
        _: *const vk::SubpassBeginInfo,
        _: *const vk::SubpassEndInfo,
    ) {
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, Event::NextSubpass2);
    }

    pub(super) unsafe extern "system" fn cmd_end_render_pass2(
        buffer: vk::CommandBuffer,
        _: *const vk::SubpassEndInfo,
    ) {
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, Event::EndRenderPass2);
    }

    pub(super) unsafe extern "system" fn cmd_begin_rendering(
        buffer: vk::CommandBuffer,
        p_info: *const vk::RenderingInfo,
    ) {
        // SAFETY: a valid rendering info; its depth attachment null or valid.
        let depth = unsafe { (*p_info).p_depth_attachment };
        // SAFETY: as above.
        let seen = unsafe { depth.as_ref() }.map(|d| SeenDepthAttachment {
            address: depth as usize,
            view: d.image_view,
            resolve_mode: d.resolve_mode,
            resolve_view: d.resolve_image_view,
            // SAFETY: a depth attachment's clear value is the depthStencil member.
            clear_depth: unsafe { d.clear_value.depth_stencil.depth },
        });
        // SAFETY: the fake's live command buffer.
        note(
            unsafe { key_of(buffer) },
            Event::BeginRendering { depth: seen },
        );
    }

    pub(super) unsafe extern "system" fn cmd_end_rendering(buffer: vk::CommandBuffer) {
        // SAFETY: the fake's live command buffer.
        note(unsafe { key_of(buffer) }, Event::EndRendering);
    }
}

/// Creates an instance through revz over the fake layer, as a Vulkan 1.3 application that
/// passes `settings` (name, string value) through `VK_EXT_layer_settings`. Returns the
/// instance and whether revz advanced the loader chain to the next link.
pub(super) fn create_instance(settings: &[(&'static CStr, &'static CStr)]) -> (vk::Instance, bool) {
    create_instance_at(vk::API_VERSION_1_3, &[], settings)
}

/// [`create_instance`] for an application that asks for Vulkan `api` and enables the instance
/// extensions `extensions`.
pub(super) fn create_instance_at(
    api: u32,
    extensions: &[&'static CStr],
    settings: &[(&'static CStr, &'static CStr)],
) -> (vk::Instance, bool) {
    let mut instance_link = crate::ffi::LayerInstanceLink {
        p_next: std::ptr::null_mut(),
        pfn_next_get_instance_proc_addr: fake_get_instance_proc_addr,
        pfn_next_get_physical_device_proc_addr: None,
    };
    let mut instance_chain = crate::ffi::LayerInstanceCreateInfo {
        s_type: crate::ffi::STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO,
        p_next: std::ptr::null(),
        function: crate::ffi::LAYER_LINK_INFO,
        p_layer_info: &mut instance_link,
    };
    let values: Vec<[*const c_char; 1]> = settings.iter().map(|(_, v)| [v.as_ptr()]).collect();
    let settings: Vec<vk::LayerSettingEXT<'_>> = settings
        .iter()
        .zip(&values)
        .map(|((name, _), value)| vk::LayerSettingEXT {
            p_layer_name: c"VK_LAYER_REVZ_reverse_z".as_ptr(),
            p_setting_name: name.as_ptr(),
            ty: vk::LayerSettingTypeEXT::STRING,
            value_count: 1,
            p_values: value.as_ptr().cast(),
            ..Default::default()
        })
        .collect();
    let mut layer_settings = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);
    layer_settings.p_next =
        (&mut instance_chain as *mut crate::ffi::LayerInstanceCreateInfo).cast();
    let app_info = vk::ApplicationInfo::default().api_version(api);
    let extensions: Vec<*const c_char> = extensions.iter().map(|name| name.as_ptr()).collect();
    let create_info = vk::InstanceCreateInfo {
        p_next: (&layer_settings as *const vk::LayerSettingsCreateInfoEXT).cast(),
        p_application_info: &app_info,
        enabled_extension_count: extensions.len() as u32,
        pp_enabled_extension_names: extensions.as_ptr(),
        ..Default::default()
    };
    let mut instance = vk::Instance::null();
    // SAFETY: a well-formed loader chain over the fake layer.
    let result =
        unsafe { super::instance::create_instance(&create_info, std::ptr::null(), &mut instance) };
    assert_eq!(result, vk::Result::SUCCESS);
    (instance, instance_chain.p_layer_info.is_null())
}

/// Creates a device through revz over the fake layer whose `vkGetDeviceProcAddr` is `gdpa`,
/// on a physical device of the instance made with `tables`. Returns the physical device, the
/// device and whether revz advanced the loader chain to the next link.
pub(super) fn create_device(
    tables: Tables,
    gdpa: vk::PFN_vkGetDeviceProcAddr,
) -> (vk::PhysicalDevice, vk::Device, bool) {
    create_device_with_extensions(tables, gdpa, &[])
}

/// [`create_device`], the application enabling the device extensions `extensions`.
pub(super) fn create_device_with_extensions(
    tables: Tables,
    gdpa: vk::PFN_vkGetDeviceProcAddr,
    extensions: &[&CStr],
) -> (vk::PhysicalDevice, vk::Device, bool) {
    create_device_with(
        tables,
        gdpa,
        extensions,
        vk::PhysicalDeviceFeatures::default(),
    )
}

/// [`create_device`], the application enabling the device extensions `extensions` and the
/// core `features`.
pub(super) fn create_device_with(
    tables: Tables,
    gdpa: vk::PFN_vkGetDeviceProcAddr,
    extensions: &[&CStr],
    features: vk::PhysicalDeviceFeatures,
) -> (vk::PhysicalDevice, vk::Device, bool) {
    // The physical device shares the instance's dispatch table.
    let physical: vk::PhysicalDevice = dispatchable(key(tables.instance));
    let mut device_link = crate::ffi::LayerDeviceLink {
        p_next: std::ptr::null_mut(),
        pfn_next_get_instance_proc_addr: fake_get_instance_proc_addr,
        pfn_next_get_device_proc_addr: gdpa,
    };
    let mut device_chain = crate::ffi::LayerDeviceCreateInfo {
        s_type: crate::ffi::STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO,
        p_next: std::ptr::null(),
        function: crate::ffi::LAYER_LINK_INFO,
        p_layer_info: &mut device_link,
    };
    let names: Vec<*const c_char> = extensions.iter().map(|name| name.as_ptr()).collect();
    let device_info = vk::DeviceCreateInfo {
        p_next: (&mut device_chain as *mut crate::ffi::LayerDeviceCreateInfo).cast(),
        enabled_extension_count: names.len() as u32,
        pp_enabled_extension_names: names.as_ptr(),
        p_enabled_features: &features,
        ..Default::default()
    };
    let mut device = vk::Device::null();
    // SAFETY: a well-formed loader chain over the fake layer.
    let result = unsafe {
        super::instance::create_device(physical, &device_info, std::ptr::null(), &mut device)
    };
    assert_eq!(result, vk::Result::SUCCESS);
    (physical, device, device_chain.p_layer_info.is_null())
}

/// The create info of a 2D, single-level depth image of `format`, `extent`, `usage` and
/// `samples`, optimally tiled: the depth images the chain tests create through revz.
pub(super) fn depth_image_info(
    format: vk::Format,
    extent: vk::Extent2D,
    usage: vk::ImageUsageFlags,
    samples: vk::SampleCountFlags,
) -> vk::ImageCreateInfo<'static> {
    vk::ImageCreateInfo::default()
        .image_type(vk::ImageType::TYPE_2D)
        .format(format)
        .extent(extent.into())
        .mip_levels(1)
        .array_layers(1)
        .samples(samples)
        .tiling(vk::ImageTiling::OPTIMAL)
        .usage(usage)
}

/// The create info of a 2D view of the depth aspect of `image` (of `format`).
pub(super) fn depth_view_info(
    image: vk::Image,
    format: vk::Format,
) -> vk::ImageViewCreateInfo<'static> {
    vk::ImageViewCreateInfo::default()
        .image(image)
        .view_type(vk::ImageViewType::TYPE_2D)
        .format(format)
        .subresource_range(vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            level_count: 1,
            layer_count: 1,
            ..Default::default()
        })
}
