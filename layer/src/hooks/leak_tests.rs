//! Leak stress, as trusted layers test it: many create/destroy cycles of every kind of object
//! revz tracks, driven through revz's hooks over the fake layer (`fake_chain`), with the heap
//! measured (glibc `mallinfo2`) before and after, and revz's registries checked empty at the
//! end.
//!
//! The objects are those of an application in `complementary` mode with `compare_op =
//! variants` (every path revz keeps state for is taken): vertex modules analyzed (naga) and
//! fragment modules that write `FragDepth` rewritten at creation, pipelines that get a reversed
//! variant (made from a temporary module of the rewritten code) destroyed with them, pipeline
//! layouts with push-constant ranges, reversed D32 depth images and their views, render passes
//! (one resolving MIN, which gets a swapped twin), framebuffers, and command buffers (a primary
//! and a secondary that inherits the pass and framebuffer: begin, render pass begin, bind,
//! push of a perspective projection, draw, execute, reset, recorded again, freed), and command
//! pools destroyed with their command buffers still allocated.
//!
//! The heap is the process's: other tests of this binary run in parallel threads and allocate
//! too. So the test runs itself again as a child process (`REVZ_LEAK_CHILD=1`) with only this
//! test, and the child measures. Cycles per kind: `REVZ_STRESS_CYCLES` (default
//! [`DEFAULT_CYCLES`] = 1e5, about 6 s for all kinds in the debug test build); `docs/testing.md`
//! records the figures. The child also checks the instrument: one 1-byte allocation kept per
//! cycle must show as at least 32 bytes per cycle.
//!
//! The bound: after a warm-up (every table at the capacity the cycle needs, every lazy static
//! made), a cycle that kept even one allocation would grow the heap by at least 32 bytes (the
//! smallest glibc chunk on 64-bit) per cycle, so by at least 128 KiB over 4096 cycles. The
//! heap may grow by at most [`BOUND`] (64 KiB) over the whole run of a kind, whatever its
//! length, and runs are at least [`MIN_CYCLES`] long: a leak of one allocation per cycle
//! cannot pass. (Measured: 0 bytes for every kind over 1e5 cycles, see `docs/testing.md`.)

use std::ffi::{c_char, c_void, CStr};
use std::sync::Arc;
use std::time::Instant;

use ash::vk::{self, Handle};

use super::fake_chain::{self, hook_set, Event, Tables};
use crate::objects;
use crate::shader::test_spirv;
use crate::state::{DeviceState, DispatchKey, DEVICES};

const CHILD_ENV: &str = "REVZ_LEAK_CHILD";
const CYCLES_ENV: &str = "REVZ_STRESS_CYCLES";
/// Cycles per kind by default (CI): about 6 s for all kinds in the debug test build.
const DEFAULT_CYCLES: usize = 100_000;
/// Fewer cycles could hide a leak of one small allocation per cycle under [`BOUND`].
const MIN_CYCLES: usize = 4096;
/// The most the heap may grow over one kind's cycles (bytes).
const BOUND: i64 = 64 * 1024;

const D32: vk::Format = vk::Format::D32_SFLOAT;
const MAIN: &CStr = c"main";
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};
const LAYOUT: vk::ImageLayout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;

/// A vertex shader whose position is a pushed matrix times the vertex: the precise path.
const VERTEX: &str = "#version 450
    layout(push_constant) uniform Push { mat4 mvp; } push;
    layout(location = 0) in vec3 position;
    void main() { gl_Position = push.mvp * vec4(position, 1.0); }";

/// A fragment shader that writes `FragDepth` from `FragCoord.z`: rewritten, and its pipelines
/// get a variant.
const FRAG_DEPTH: &str = "#version 450
    layout(location = 0) out vec4 color;
    void main() {
        color = vec4(gl_FragCoord.xy, 0.0, 1.0);
        gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z;
    }";

/// The heap in use, from glibc.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod heap {
    /// glibc's `struct mallinfo2` (glibc 2.33 and later).
    #[repr(C)]
    struct MallInfo2 {
        arena: usize,
        ordblks: usize,
        smblks: usize,
        hblks: usize,
        hblkhd: usize,
        usmblks: usize,
        fsmblks: usize,
        uordblks: usize,
        fordblks: usize,
        keepcost: usize,
    }

    extern "C" {
        fn mallinfo2() -> MallInfo2;
    }

    /// Bytes allocated and not freed: in the arenas (`uordblks`) and mapped (`hblkhd`).
    pub fn in_use() -> i64 {
        // SAFETY: no preconditions; it only reads the allocator's statistics.
        let info = unsafe { mallinfo2() };
        (info.uordblks + info.hblkhd) as i64
    }
}

/// The commands the cycles need that the fake layer's tables lack: they do nothing (revz only
/// needs them to exist below it), and pipeline layouts get fresh handles.
mod stubs {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};

    static NEXT_LAYOUT: AtomicU64 = AtomicU64::new(0x4000_0000);

    pub unsafe extern "system" fn create_pipeline_layout(
        _: vk::Device,
        _: *const vk::PipelineLayoutCreateInfo<'_>,
        _: *const vk::AllocationCallbacks<'_>,
        p_layout: *mut vk::PipelineLayout,
    ) -> vk::Result {
        let handle = vk::PipelineLayout::from_raw(NEXT_LAYOUT.fetch_add(1, Ordering::Relaxed));
        // SAFETY: revz passes the application's output pointer through.
        unsafe { *p_layout = handle };
        vk::Result::SUCCESS
    }

    pub unsafe extern "system" fn destroy_pipeline_layout(
        _: vk::Device,
        _: vk::PipelineLayout,
        _: *const vk::AllocationCallbacks<'_>,
    ) {
    }

    pub unsafe extern "system" fn end_command_buffer(_: vk::CommandBuffer) -> vk::Result {
        vk::Result::SUCCESS
    }

    pub unsafe extern "system" fn reset_command_buffer(
        _: vk::CommandBuffer,
        _: vk::CommandBufferResetFlags,
    ) -> vk::Result {
        vk::Result::SUCCESS
    }

    pub unsafe extern "system" fn cmd_bind_pipeline(
        _: vk::CommandBuffer,
        _: vk::PipelineBindPoint,
        _: vk::Pipeline,
    ) {
    }

    pub unsafe extern "system" fn cmd_push_constants(
        _: vk::CommandBuffer,
        _: vk::PipelineLayout,
        _: vk::ShaderStageFlags,
        _: u32,
        _: u32,
        _: *const c_void,
    ) {
    }

    pub unsafe extern "system" fn cmd_set_viewport(
        _: vk::CommandBuffer,
        _: u32,
        _: u32,
        _: *const vk::Viewport,
    ) {
    }

    pub unsafe extern "system" fn cmd_set_viewport_with_count(
        _: vk::CommandBuffer,
        _: u32,
        _: *const vk::Viewport,
    ) {
    }

    pub unsafe extern "system" fn cmd_set_depth_bias(_: vk::CommandBuffer, _: f32, _: f32, _: f32) {
    }

    pub unsafe extern "system" fn cmd_set_depth_bounds(_: vk::CommandBuffer, _: f32, _: f32) {}

    pub unsafe extern "system" fn cmd_execute_commands(
        _: vk::CommandBuffer,
        _: u32,
        _: *const vk::CommandBuffer,
    ) {
    }
}

/// The fake layer's `vkGetDeviceProcAddr` with pipelines, and the commands of [`stubs`].
unsafe extern "system" fn gdpa(device: vk::Device, name: *const c_char) -> vk::PFN_vkVoidFunction {
    macro_rules! erase {
        ($pfn:ty, $f:expr) => {{
            let typed: $pfn = $f;
            // SAFETY: function pointers have one size and ABI; revz casts it back to `$pfn`.
            Some(unsafe { std::mem::transmute::<$pfn, unsafe extern "system" fn()>(typed) })
        }};
    }
    // SAFETY: revz only asks for NUL-terminated names.
    match unsafe { CStr::from_ptr(name) }.to_bytes() {
        b"vkCreatePipelineLayout" => erase!(
            vk::PFN_vkCreatePipelineLayout,
            stubs::create_pipeline_layout
        ),
        b"vkDestroyPipelineLayout" => erase!(
            vk::PFN_vkDestroyPipelineLayout,
            stubs::destroy_pipeline_layout
        ),
        b"vkEndCommandBuffer" => erase!(vk::PFN_vkEndCommandBuffer, stubs::end_command_buffer),
        b"vkResetCommandBuffer" => {
            erase!(vk::PFN_vkResetCommandBuffer, stubs::reset_command_buffer)
        }
        b"vkCmdBindPipeline" => erase!(vk::PFN_vkCmdBindPipeline, stubs::cmd_bind_pipeline),
        b"vkCmdPushConstants" => erase!(vk::PFN_vkCmdPushConstants, stubs::cmd_push_constants),
        b"vkCmdSetViewport" => erase!(vk::PFN_vkCmdSetViewport, stubs::cmd_set_viewport),
        b"vkCmdSetViewportWithCount" => erase!(
            vk::PFN_vkCmdSetViewportWithCount,
            stubs::cmd_set_viewport_with_count
        ),
        b"vkCmdSetDepthBias" => erase!(vk::PFN_vkCmdSetDepthBias, stubs::cmd_set_depth_bias),
        b"vkCmdSetDepthBounds" => {
            erase!(vk::PFN_vkCmdSetDepthBounds, stubs::cmd_set_depth_bounds)
        }
        b"vkCmdExecuteCommands" => {
            erase!(vk::PFN_vkCmdExecuteCommands, stubs::cmd_execute_commands)
        }
        // SAFETY: forwarding the caller's arguments.
        _ => unsafe { fake_chain::fake_get_device_proc_addr_with_pipelines(device, name) },
    }
}

// The commands the cycles call, as the application gets them from revz.
hook_set! {
    struct Hooks {
        create_shader_module: c"vkCreateShaderModule" => vk::PFN_vkCreateShaderModule,
        destroy_shader_module: c"vkDestroyShaderModule" => vk::PFN_vkDestroyShaderModule,
        create_graphics_pipelines: c"vkCreateGraphicsPipelines" => vk::PFN_vkCreateGraphicsPipelines,
        destroy_pipeline: c"vkDestroyPipeline" => vk::PFN_vkDestroyPipeline,
        create_pipeline_layout: c"vkCreatePipelineLayout" => vk::PFN_vkCreatePipelineLayout,
        destroy_pipeline_layout: c"vkDestroyPipelineLayout" => vk::PFN_vkDestroyPipelineLayout,
        create_image: c"vkCreateImage" => vk::PFN_vkCreateImage,
        destroy_image: c"vkDestroyImage" => vk::PFN_vkDestroyImage,
        create_image_view: c"vkCreateImageView" => vk::PFN_vkCreateImageView,
        destroy_image_view: c"vkDestroyImageView" => vk::PFN_vkDestroyImageView,
        create_render_pass2: c"vkCreateRenderPass2" => vk::PFN_vkCreateRenderPass2,
        destroy_render_pass: c"vkDestroyRenderPass" => vk::PFN_vkDestroyRenderPass,
        create_framebuffer: c"vkCreateFramebuffer" => vk::PFN_vkCreateFramebuffer,
        destroy_framebuffer: c"vkDestroyFramebuffer" => vk::PFN_vkDestroyFramebuffer,
        allocate_command_buffers: c"vkAllocateCommandBuffers" => vk::PFN_vkAllocateCommandBuffers,
        free_command_buffers: c"vkFreeCommandBuffers" => vk::PFN_vkFreeCommandBuffers,
        destroy_command_pool: c"vkDestroyCommandPool" => vk::PFN_vkDestroyCommandPool,
        begin_command_buffer: c"vkBeginCommandBuffer" => vk::PFN_vkBeginCommandBuffer,
        end_command_buffer: c"vkEndCommandBuffer" => vk::PFN_vkEndCommandBuffer,
        reset_command_buffer: c"vkResetCommandBuffer" => vk::PFN_vkResetCommandBuffer,
        cmd_begin_render_pass2: c"vkCmdBeginRenderPass2" => vk::PFN_vkCmdBeginRenderPass2,
        cmd_end_render_pass2: c"vkCmdEndRenderPass2" => vk::PFN_vkCmdEndRenderPass2,
        cmd_bind_pipeline: c"vkCmdBindPipeline" => vk::PFN_vkCmdBindPipeline,
        cmd_push_constants: c"vkCmdPushConstants" => vk::PFN_vkCmdPushConstants,
        cmd_draw: c"vkCmdDraw" => vk::PFN_vkCmdDraw,
        cmd_execute_commands: c"vkCmdExecuteCommands" => vk::PFN_vkCmdExecuteCommands,
    }
}

/// What each kind's cycle creates and destroys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// A vertex module (analyzed) and a `FragDepth` fragment module (rewritten).
    ShaderModules,
    /// A pipeline of those modules: revz makes its reversed variant (and a temporary module).
    Pipelines,
    PipelineLayouts,
    /// A reversed D32 depth image.
    Images,
    /// A view of a depth image.
    ImageViews,
    /// A depth render pass, and a multisampled one resolving MIN (revz makes a twin).
    RenderPasses,
    Framebuffers,
    /// A primary and a secondary: recorded, reset, recorded again, freed.
    CommandBuffers,
    /// A pool destroyed with a primary and a secondary still allocated from it.
    CommandPools,
}

const KINDS: [Kind; 9] = [
    Kind::ShaderModules,
    Kind::Pipelines,
    Kind::PipelineLayouts,
    Kind::Images,
    Kind::ImageViews,
    Kind::RenderPasses,
    Kind::Framebuffers,
    Kind::CommandBuffers,
    Kind::CommandPools,
];

/// The device the cycles run on, and the long-lived objects they use.
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    state: Arc<DeviceState>,
    hooks: Hooks,
    vertex_code: Vec<u32>,
    fragment_code: Vec<u32>,
    vertex: vk::ShaderModule,
    fragment: vk::ShaderModule,
    layout: vk::PipelineLayout,
    image: vk::Image,
    view: vk::ImageView,
    pass: vk::RenderPass,
    framebuffer: vk::Framebuffer,
    pipeline: vk::Pipeline,
    pool: vk::CommandPool,
    next_pool: u64,
}

fn ok(result: vk::Result) {
    assert_eq!(result, vk::Result::SUCCESS);
}

/// A standard perspective projection (near 0.1, far 100), column-major, as pushed.
fn projection() -> [f32; 16] {
    let (n, f) = (0.1f32, 100.0f32);
    let k = f / (f - n);
    [
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
        k,
        1.0,
        0.0,
        0.0,
        -n * k,
        0.0,
    ]
}

impl Fixture {
    fn new() -> Fixture {
        let tables = Tables::fresh();
        let (instance, _) = fake_chain::create_instance(&[
            (c"mode", c"complementary"),
            (c"compare_op", c"variants"),
        ]);
        let (physical, device, _) = fake_chain::create_device(tables, gdpa);
        // SAFETY: the fake's live device.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device) })
            .expect("the device is registered");
        assert!(state.policy.is_active() && state.policy.rewrite().is_some());
        assert!(state.policy.compare_op_variants);
        fake_chain::take_events(tables.instance);
        let hooks = Hooks::of(device);
        let mut fixture = Fixture {
            tables,
            instance,
            physical,
            device,
            state,
            hooks,
            vertex_code: test_spirv::compile_glsl(naga::ShaderStage::Vertex, VERTEX),
            fragment_code: test_spirv::compile_glsl(naga::ShaderStage::Fragment, FRAG_DEPTH),
            vertex: vk::ShaderModule::null(),
            fragment: vk::ShaderModule::null(),
            layout: vk::PipelineLayout::null(),
            image: vk::Image::null(),
            view: vk::ImageView::null(),
            pass: vk::RenderPass::null(),
            framebuffer: vk::Framebuffer::null(),
            pipeline: vk::Pipeline::null(),
            pool: vk::CommandPool::from_raw(0x7000_0000),
            next_pool: 0x7000_0001,
        };
        fixture.vertex = fixture.module(&fixture.vertex_code);
        fixture.fragment = fixture.module(&fixture.fragment_code);
        fixture.layout = fixture.pipeline_layout();
        fixture.image = fixture.depth_image(vk::SampleCountFlags::TYPE_1);
        fixture.view = fixture.depth_view(fixture.image);
        fixture.pass = fixture.render_pass();
        fixture.framebuffer = fixture.framebuffer(fixture.pass, &[fixture.view]);
        fixture.pipeline = fixture.graphics_pipeline();
        fixture.drain();
        // The shared objects are what revz made of them.
        let objects = &fixture.state.objects;
        assert!(objects.image_reversed(fixture.image));
        assert!(matches!(
            objects.vertex_modules.get(&fixture.vertex).as_deref(),
            Some(Ok(entries)) if !entries.is_empty()
        ));
        assert!(matches!(
            objects.fragment_depth_modules.get(&fixture.fragment),
            Some(Ok(_))
        ));
        let depth = objects.pipelines.get(&fixture.pipeline).expect("recorded");
        assert!(
            depth.reversed_variant.is_some(),
            "the pipeline has a variant"
        );
        fixture
    }

    /// Forgets what reached the fake (it records every call).
    fn drain(&self) {
        drop(fake_chain::take_events(self.tables.device));
    }

    fn module(&self, words: &[u32]) -> vk::ShaderModule {
        let info = vk::ShaderModuleCreateInfo::default().code(words);
        let mut module = vk::ShaderModule::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_shader_module)(self.device, &info, std::ptr::null(), &mut module)
        });
        module
    }

    fn pipeline_layout(&self) -> vk::PipelineLayout {
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX,
            offset: 0,
            size: 64,
        }];
        let info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges);
        let mut layout = vk::PipelineLayout::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_pipeline_layout)(self.device, &info, std::ptr::null(), &mut layout)
        });
        layout
    }

    fn depth_image(&self, samples: vk::SampleCountFlags) -> vk::Image {
        let info = fake_chain::depth_image_info(
            D32,
            EXTENT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            samples,
        );
        let mut image = vk::Image::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe { (self.hooks.create_image)(self.device, &info, std::ptr::null(), &mut image) });
        image
    }

    fn depth_view(&self, image: vk::Image) -> vk::ImageView {
        let info = fake_chain::depth_view_info(image, D32);
        let mut view = vk::ImageView::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_image_view)(self.device, &info, std::ptr::null(), &mut view)
        });
        view
    }

    /// One subpass drawing into a cleared D32 attachment.
    fn render_pass(&self) -> vk::RenderPass {
        let attachments = [vk::AttachmentDescription2::default()
            .format(D32)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .final_layout(LAYOUT)];
        let depth = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(LAYOUT)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let subpasses = [vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth)];
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(&subpasses);
        let mut pass = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_render_pass2)(self.device, &info, std::ptr::null(), &mut pass)
        });
        pass
    }

    /// A multisampled D32 attachment resolved with MIN into a single-sampled one: revz makes
    /// the twin that resolves MAX.
    fn resolving_render_pass(&self) -> vk::RenderPass {
        let attachment = |samples, load_op| {
            vk::AttachmentDescription2::default()
                .format(D32)
                .samples(samples)
                .load_op(load_op)
                .store_op(vk::AttachmentStoreOp::STORE)
                .final_layout(LAYOUT)
        };
        let attachments = [
            attachment(vk::SampleCountFlags::TYPE_4, vk::AttachmentLoadOp::CLEAR),
            attachment(
                vk::SampleCountFlags::TYPE_1,
                vk::AttachmentLoadOp::DONT_CARE,
            ),
        ];
        let reference = |attachment| {
            vk::AttachmentReference2::default()
                .attachment(attachment)
                .layout(LAYOUT)
                .aspect_mask(vk::ImageAspectFlags::DEPTH)
        };
        let (depth, destination) = (reference(0), reference(1));
        let mut resolve = vk::SubpassDescriptionDepthStencilResolve::default()
            .depth_resolve_mode(vk::ResolveModeFlags::MIN)
            .stencil_resolve_mode(vk::ResolveModeFlags::NONE)
            .depth_stencil_resolve_attachment(&destination);
        let subpasses = [vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth)
            .push_next(&mut resolve)];
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(&subpasses);
        let mut pass = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_render_pass2)(self.device, &info, std::ptr::null(), &mut pass)
        });
        pass
    }

    fn framebuffer(&self, pass: vk::RenderPass, views: &[vk::ImageView]) -> vk::Framebuffer {
        let info = vk::FramebufferCreateInfo::default()
            .render_pass(pass)
            .attachments(views)
            .width(EXTENT.width)
            .height(EXTENT.height)
            .layers(1);
        let mut framebuffer = vk::Framebuffer::null();
        // SAFETY: a live device and a valid create info.
        ok(unsafe {
            (self.hooks.create_framebuffer)(self.device, &info, std::ptr::null(), &mut framebuffer)
        });
        framebuffer
    }

    /// The vertex and `FragDepth` modules in the pass, LESS with a static viewport.
    fn graphics_pipeline(&self) -> vk::Pipeline {
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(self.vertex)
                .name(MAIN),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(self.fragment)
                .name(MAIN),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewports = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: EXTENT.width as f32,
            height: EXTENT.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissors = [vk::Rect2D::from(EXTENT)];
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewports(&viewports)
            .scissors(&scissors);
        let rasterization = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::BACK)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let color_blend = vk::PipelineColorBlendStateCreateInfo::default();
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&rasterization)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth_stencil)
            .color_blend_state(&color_blend)
            .layout(self.layout)
            .render_pass(self.pass)
            .subpass(0);
        let mut pipeline = vk::Pipeline::null();
        // SAFETY: a live device, a valid create info and room for one handle.
        ok(unsafe {
            (self.hooks.create_graphics_pipelines)(
                self.device,
                vk::PipelineCache::null(),
                1,
                &info,
                std::ptr::null(),
                &mut pipeline,
            )
        });
        pipeline
    }

    fn allocate(&self, pool: vk::CommandPool, level: vk::CommandBufferLevel) -> vk::CommandBuffer {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(level)
            .command_buffer_count(1);
        let mut buffer = vk::CommandBuffer::null();
        // SAFETY: a live device and room for one handle.
        ok(unsafe { (self.hooks.allocate_command_buffers)(self.device, &info, &mut buffer) });
        buffer
    }

    /// Binds the pipeline, pushes the projection (rewritten by revz) and draws.
    fn bind_push_draw(&self, buffer: vk::CommandBuffer) {
        let matrix = projection();
        // SAFETY: a recording command buffer inside a pass the pipeline is for; 64 bytes.
        unsafe {
            (self.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
            (self.hooks.cmd_push_constants)(
                buffer,
                self.layout,
                vk::ShaderStageFlags::VERTEX,
                0,
                64,
                matrix.as_ptr().cast(),
            );
            (self.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
        }
    }

    /// Records a secondary that continues the pass (inheriting its framebuffer).
    fn record_secondary(&self, secondary: vk::CommandBuffer) {
        let inheritance = vk::CommandBufferInheritanceInfo::default()
            .render_pass(self.pass)
            .subpass(0)
            .framebuffer(self.framebuffer);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE)
            .inheritance_info(&inheritance);
        // SAFETY: a fresh or reset secondary.
        ok(unsafe { (self.hooks.begin_command_buffer)(secondary, &begin) });
        self.bind_push_draw(secondary);
        // SAFETY: recording.
        ok(unsafe { (self.hooks.end_command_buffer)(secondary) });
    }

    /// Records a primary: the pass with `secondary` executed in it (if any), then the pass
    /// again with the draw inline.
    fn record_primary(&self, primary: vk::CommandBuffer, secondary: Option<vk::CommandBuffer>) {
        let clears = [vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        }];
        let begin_pass = vk::RenderPassBeginInfo::default()
            .render_pass(self.pass)
            .framebuffer(self.framebuffer)
            .render_area(EXTENT.into())
            .clear_values(&clears);
        let end = vk::SubpassEndInfo::default();
        // SAFETY: a fresh or reset primary; the pass and framebuffer are live.
        unsafe {
            ok((self.hooks.begin_command_buffer)(
                primary,
                &vk::CommandBufferBeginInfo::default(),
            ));
            if let Some(secondary) = secondary {
                let contents = vk::SubpassBeginInfo::default()
                    .contents(vk::SubpassContents::SECONDARY_COMMAND_BUFFERS);
                (self.hooks.cmd_begin_render_pass2)(primary, &begin_pass, &contents);
                (self.hooks.cmd_execute_commands)(primary, 1, &secondary);
                (self.hooks.cmd_end_render_pass2)(primary, &end);
            }
            let inline = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
            (self.hooks.cmd_begin_render_pass2)(primary, &begin_pass, &inline);
            self.bind_push_draw(primary);
            (self.hooks.cmd_end_render_pass2)(primary, &end);
            ok((self.hooks.end_command_buffer)(primary));
        }
    }

    /// One create/destroy cycle of `kind`.
    fn cycle(&mut self, kind: Kind) {
        let (device, none) = (self.device, std::ptr::null());
        let objects = &self.state.objects;
        match kind {
            Kind::ShaderModules => {
                let vertex = self.module(&self.vertex_code);
                let fragment = self.module(&self.fragment_code);
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe {
                    (self.hooks.destroy_shader_module)(device, vertex, none);
                    (self.hooks.destroy_shader_module)(device, fragment, none);
                }
                assert!(objects.vertex_modules.get(&vertex).is_none());
                assert!(objects.fragment_depth_modules.get(&fragment).is_none());
            }
            Kind::Pipelines => {
                let pipeline = self.graphics_pipeline();
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_pipeline)(device, pipeline, none) };
                assert!(objects.pipelines.get(&pipeline).is_none());
            }
            Kind::PipelineLayouts => {
                let layout = self.pipeline_layout();
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_pipeline_layout)(device, layout, none) };
                assert!(objects.pipeline_layouts.get(&layout).is_none());
            }
            Kind::Images => {
                let image = self.depth_image(vk::SampleCountFlags::TYPE_1);
                // As a pass into it would have left it: its camera's n / f remembered.
                objects.near_over_far.insert(image, 0.01);
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_image)(device, image, none) };
                assert!(objects.images.get(&image).is_none());
                assert!(objects.near_over_far.get(&image).is_none());
            }
            Kind::ImageViews => {
                let view = self.depth_view(self.image);
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_image_view)(device, view, none) };
                assert!(objects.views.get(&view).is_none());
            }
            Kind::RenderPasses => {
                let plain = self.render_pass();
                let resolving = self.resolving_render_pass();
                let twin = objects
                    .render_passes
                    .get(&resolving)
                    .and_then(|pass| pass.swapped_resolve_twin);
                assert!(twin.is_some(), "a MIN resolve gets its twin");
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe {
                    (self.hooks.destroy_render_pass)(device, plain, none);
                    (self.hooks.destroy_render_pass)(device, resolving, none);
                }
                assert!(objects.render_passes.get(&plain).is_none());
                assert!(objects.render_passes.get(&resolving).is_none());
            }
            Kind::Framebuffers => {
                let framebuffer = self.framebuffer(self.pass, &[self.view]);
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_framebuffer)(device, framebuffer, none) };
                assert!(objects.framebuffers.get(&framebuffer).is_none());
            }
            Kind::CommandBuffers => {
                let primary = self.allocate(self.pool, vk::CommandBufferLevel::PRIMARY);
                let secondary = self.allocate(self.pool, vk::CommandBufferLevel::SECONDARY);
                self.record_secondary(secondary);
                self.record_primary(primary, Some(secondary));
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe {
                    let flags = vk::CommandBufferResetFlags::empty();
                    ok((self.hooks.reset_command_buffer)(primary, flags));
                    ok((self.hooks.reset_command_buffer)(secondary, flags));
                }
                self.record_primary(primary, None);
                let buffers = [primary, secondary];
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe {
                    (self.hooks.free_command_buffers)(device, self.pool, 2, buffers.as_ptr())
                };
                // Before any new allocation: the fake may hand the same addresses out again.
                assert!(buffers
                    .iter()
                    .all(|&buffer| objects::command_buffer(buffer).is_none()));
            }
            Kind::CommandPools => {
                let pool = vk::CommandPool::from_raw(self.next_pool);
                self.next_pool += 1;
                let primary = self.allocate(pool, vk::CommandBufferLevel::PRIMARY);
                let secondary = self.allocate(pool, vk::CommandBufferLevel::SECONDARY);
                self.record_secondary(secondary);
                self.record_primary(primary, Some(secondary));
                // SAFETY: a live device, objects it created, each destroyed once and not used afterwards.
                unsafe { (self.hooks.destroy_command_pool)(device, pool, none) };
                let buffers = [primary, secondary];
                assert!(buffers
                    .iter()
                    .all(|&buffer| objects::command_buffer(buffer).is_none()));
                assert!(objects.pools.get(&pool).is_none());
                // The fake's pool destruction does not free what it allocated.
                for buffer in buffers {
                    // SAFETY: made by the fake, freed with its pool, not used again.
                    unsafe { fake_chain::reclaim(buffer) };
                }
            }
        }
        let events = fake_chain::take_events(self.tables.device);
        match kind {
            // The temporary modules of the rewritten fragment and vertex code, the variant,
            // the modules destroyed, the application's pipeline; then the variant and the
            // pipeline destroyed.
            Kind::Pipelines => assert_eq!(events.len(), 8, "{events:#?}"),
            // Each pass clears its depth to 1 - 1.0: the attachment is reversed.
            Kind::CommandBuffers | Kind::CommandPools => {
                let clears: Vec<&Vec<f32>> = events
                    .iter()
                    .filter_map(|event| match event {
                        Event::BeginRenderPass2 { clear_depths, .. } => Some(clear_depths),
                        _ => None,
                    })
                    .collect();
                let passes = if kind == Kind::CommandBuffers { 3 } else { 2 };
                assert_eq!(clears.len(), passes, "{events:#?}");
                assert!(
                    clears.iter().all(|depths| depths[..] == [0.0]),
                    "{clears:?}"
                );
            }
            _ => {}
        }
    }

    /// Destroys the long-lived objects, checks that revz's tables are empty, and tears the
    /// device and instance down.
    fn finish(self) {
        let (device, none) = (self.device, std::ptr::null());
        let hooks = &self.hooks;
        // SAFETY: a live device and objects it created, each destroyed once.
        unsafe {
            (hooks.destroy_pipeline)(device, self.pipeline, none);
            (hooks.destroy_framebuffer)(device, self.framebuffer, none);
            (hooks.destroy_render_pass)(device, self.pass, none);
            (hooks.destroy_image_view)(device, self.view, none);
            (hooks.destroy_image)(device, self.image, none);
            (hooks.destroy_pipeline_layout)(device, self.layout, none);
            (hooks.destroy_shader_module)(device, self.vertex, none);
            (hooks.destroy_shader_module)(device, self.fragment, none);
            (hooks.destroy_command_pool)(device, self.pool, none);
        }
        let objects = &self.state.objects;
        let counts = [
            ("images", objects.images.count()),
            ("image cameras", objects.near_over_far.count()),
            ("resolve pairs", objects.resolve_pairs.count()),
            ("views", objects.views.count()),
            ("render passes", objects.render_passes.count()),
            ("framebuffers", objects.framebuffers.count()),
            ("pipelines", objects.pipelines.count()),
            ("fragment modules", objects.fragment_depth_modules.count()),
            ("input modules", objects.input_modules.count()),
            ("vertex modules", objects.vertex_modules.count()),
            ("vertex module code", objects.vertex_words.count()),
            ("pipeline layouts", objects.pipeline_layouts.count()),
            ("pools", objects.pools.count()),
            ("command buffers", objects::tracked_command_buffers()),
        ];
        for (table, count) in counts {
            assert_eq!(count, 0, "revz still tracks {count} {table}");
        }
        drop(self.state);
        // SAFETY: the fake's objects, nothing of theirs in use.
        unsafe { fake_chain::tear_down(self.tables, self.instance, self.physical, device) };
    }
}

/// One kind's figures.
#[derive(Debug)]
struct Figure {
    kind: Kind,
    cycles: usize,
    growth: i64,
    seconds: f64,
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn child(cycles: usize) {
    let mut fixture = Fixture::new();
    let warmup = (cycles / 8).clamp(64, 1024);
    let mut figures = Vec::new();
    for kind in KINDS {
        for _ in 0..warmup {
            fixture.cycle(kind);
        }
        let before = heap::in_use();
        let start = Instant::now();
        for _ in 0..cycles {
            fixture.cycle(kind);
        }
        let seconds = start.elapsed().as_secs_f64();
        let growth = heap::in_use() - before;
        figures.push(Figure {
            kind,
            cycles,
            growth,
            seconds,
        });
    }
    println!("| kind | cycles | heap growth (bytes) | per 1e5 cycles (bytes) | time (s) |");
    println!("|---|---|---|---|---|");
    for f in &figures {
        println!(
            "| {:?} | {} | {} | {:.0} | {:.2} |",
            f.kind,
            f.cycles,
            f.growth,
            f.growth as f64 * 1e5 / f.cycles as f64,
            f.seconds
        );
    }
    fixture.finish();
    // The instrument itself: one 1-byte allocation kept per cycle must show.
    let before = heap::in_use();
    for _ in 0..cycles {
        std::hint::black_box(Box::leak(Box::new(0u8)));
    }
    let control = heap::in_use() - before;
    println!("control (one 1-byte box kept per cycle): {control} bytes over {cycles} cycles");
    assert!(
        control >= 32 * cycles as i64,
        "mallinfo2 misses a leak: {control}"
    );
    for f in &figures {
        assert!(
            f.growth <= BOUND,
            "{:?}: the heap grew by {} bytes over {} cycles",
            f.kind,
            f.growth,
            f.cycles
        );
    }
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
fn create_destroy_cycles_leave_the_heap_and_the_registries_as_they_were() {
    let cycles = std::env::var(CYCLES_ENV)
        .ok()
        .map(|v| v.parse::<usize>().expect("REVZ_STRESS_CYCLES is a count"))
        .unwrap_or(DEFAULT_CYCLES);
    assert!(
        cycles >= MIN_CYCLES,
        "{CYCLES_ENV}={cycles}: at least {MIN_CYCLES} cycles, or a leak could hide under the bound"
    );
    if std::env::var_os(CHILD_ENV).is_some() {
        child(cycles);
        return;
    }
    // This test's name as the harness filters it (the module path without the crate).
    let module = module_path!();
    let module = module.split_once("::").map_or(module, |(_, rest)| rest);
    let name =
        format!("{module}::create_destroy_cycles_leave_the_heap_and_the_registries_as_they_were");
    let output = std::process::Command::new(std::env::current_exe().expect("the test binary"))
        .args([name.as_str(), "--exact", "--nocapture", "--test-threads=1"])
        .env(CHILD_ENV, "1")
        .env(CYCLES_ENV, cycles.to_string())
        .output()
        .expect("run the test binary again");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr),
    );
    // Shown with --nocapture: the figures.
    eprintln!("{stdout}");
    assert!(
        output.status.success(),
        "the measuring child failed\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
    );
    assert!(
        stdout.contains("1 passed"),
        "the child did not run the test\n{stdout}"
    );
}
