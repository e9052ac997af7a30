//! Graphics pipelines whose fragment shader computes with depth, driven through revz's hooks
//! over the fake layer (`fake_chain`): the module rewritten at `vkCreateShaderModule`, the
//! reversed variant created before the application's pipeline from a temporary module of the
//! rewritten code (destroyed once the variant exists), inline SPIR-V, the variant destroyed
//! with the application's pipeline or when that pipeline fails, modules that need no rewrite or
//! cannot be rewritten, chains spliced around the structures a variant changes, variants of
//! pipeline libraries and of the pipelines linking them, and mode off.
//!
//! Every test makes its own instance and device (Vulkan 1.3) with its own dispatch tables, gets
//! revz's hooks from `vkGetDeviceProcAddr`, and checks what reaches the fake layer below and
//! what revz recorded of the pipelines.

use std::cell::RefCell;
use std::ffi::{c_void, CStr};
use std::sync::Arc;

use ash::vk::{self, Handle};

use super::fake_chain::{self, seen_pipeline, Event, PipelineOutcome, SeenPipeline, Tables};
use super::{device, pipeline};
use crate::command_state::PipelineDepth;
use crate::shader::derived_range::MatrixSource;
use crate::shader::fragment_depth::reverse_fragment_depth;
use crate::shader::input_depth::DepthInputs;
use crate::shader::test_spirv::{
    self, fragment, refused_fragment, validate, FRAG_DEPTH, PLAIN, VERTEX,
};
use crate::state::{DeviceState, DispatchKey, DEVICES};

const D32: vk::Format = vk::Format::D32_SFLOAT;
const COLOR: vk::Format = vk::Format::R8G8B8A8_UNORM;
const MAIN: &CStr = c"main";
/// The application's pipeline layout: revz passes it through, never reads it.
fn layout() -> vk::PipelineLayout {
    vk::PipelineLayout::from_raw(0x1A10)
}

/// The application's pipeline cache: revz passes it through (to its variants too).
fn cache() -> vk::PipelineCache {
    vk::PipelineCache::from_raw(0xCAC4E)
}
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};

/// The commands of the pipeline hooks: revz's in an active mode, the next layer's in mode off.
const PIPELINE_COMMANDS: [&CStr; 4] = [
    c"vkCreateShaderModule",
    c"vkDestroyShaderModule",
    c"vkCreateGraphicsPipelines",
    c"vkDestroyPipeline",
];

use super::fake_chain::hook;

/// The commands these tests call, as the application would get them.
struct Hooks {
    create_shader_module: vk::PFN_vkCreateShaderModule,
    destroy_shader_module: vk::PFN_vkDestroyShaderModule,
    create_graphics_pipelines: vk::PFN_vkCreateGraphicsPipelines,
    destroy_pipeline: vk::PFN_vkDestroyPipeline,
    create_render_pass2: vk::PFN_vkCreateRenderPass2,
    destroy_render_pass: vk::PFN_vkDestroyRenderPass,
}

impl Hooks {
    /// From revz's `vkGetDeviceProcAddr`.
    fn of(device: vk::Device) -> Hooks {
        Hooks {
            create_shader_module: hook!(
                device,
                c"vkCreateShaderModule",
                vk::PFN_vkCreateShaderModule
            ),
            destroy_shader_module: hook!(
                device,
                c"vkDestroyShaderModule",
                vk::PFN_vkDestroyShaderModule
            ),
            create_graphics_pipelines: hook!(
                device,
                c"vkCreateGraphicsPipelines",
                vk::PFN_vkCreateGraphicsPipelines
            ),
            destroy_pipeline: hook!(device, c"vkDestroyPipeline", vk::PFN_vkDestroyPipeline),
            create_render_pass2: hook!(device, c"vkCreateRenderPass2", vk::PFN_vkCreateRenderPass2),
            destroy_render_pass: hook!(device, c"vkDestroyRenderPass", vk::PFN_vkDestroyRenderPass),
        }
    }

    /// revz's pipeline hooks themselves (where `vkGetDeviceProcAddr` does not hand them out).
    fn direct(device: vk::Device) -> Hooks {
        Hooks {
            create_shader_module: pipeline::create_shader_module,
            destroy_shader_module: pipeline::destroy_shader_module,
            create_graphics_pipelines: pipeline::create_graphics_pipelines,
            destroy_pipeline: pipeline::destroy_pipeline,
            // Mode off: the next layer's own.
            create_render_pass2: hook!(device, c"vkCreateRenderPass2", vk::PFN_vkCreateRenderPass2),
            destroy_render_pass: hook!(device, c"vkDestroyRenderPass", vk::PFN_vkDestroyRenderPass),
        }
    }
}

/// One instance and device over the fake layer, and the modules, pipelines and render passes a
/// test creates through it (destroyed through the hooks by [`Fixture::finish`]).
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    state: Arc<DeviceState>,
    hooks: Hooks,
    modules: RefCell<Vec<vk::ShaderModule>>,
    pipelines: RefCell<Vec<vk::Pipeline>>,
    passes: RefCell<Vec<vk::RenderPass>>,
}

impl Fixture {
    /// Flip mode, the compare op dynamic (the default), a Vulkan 1.3 application and device.
    fn new() -> Fixture {
        Fixture::with_settings(&[(c"mode", c"flip")])
    }

    fn with_settings(settings: &[(&'static CStr, &'static CStr)]) -> Fixture {
        let tables = Tables::fresh();
        let (instance, _) = fake_chain::create_instance(settings);
        let (physical, device, _) =
            fake_chain::create_device(tables, fake_chain::fake_get_device_proc_addr_with_pipelines);
        // SAFETY: the fake's live device.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device) })
            .expect("the device is registered");
        let hooks = if state.policy.is_active() {
            for name in PIPELINE_COMMANDS {
                // SAFETY: a live device and NUL-terminated names.
                let (revz, next) = unsafe {
                    (
                        device::get_device_proc_addr(device, name.as_ptr()),
                        fake_chain::fake_get_device_proc_addr_with_pipelines(device, name.as_ptr()),
                    )
                };
                assert!(revz.is_some() && next.is_some());
                assert_ne!(
                    revz.map(|f| f as usize),
                    next.map(|f| f as usize),
                    "{name:?} is revz's"
                );
            }
            Hooks::of(device)
        } else {
            Hooks::direct(device)
        };
        fake_chain::take_events(tables.instance);
        assert_eq!(fake_chain::take_events(tables.device), []);
        Fixture {
            tables,
            instance,
            physical,
            device,
            state,
            hooks,
            modules: RefCell::default(),
            pipelines: RefCell::default(),
            passes: RefCell::default(),
        }
    }

    /// What reached the fake layer for this device since last asked.
    fn events(&self) -> Vec<Event> {
        fake_chain::take_events(self.tables.device)
    }

    /// What revz recorded of a pipeline.
    fn recorded(&self, pipeline: vk::Pipeline) -> Arc<PipelineDepth> {
        self.state
            .objects
            .pipelines
            .get(&pipeline)
            .expect("a recorded pipeline")
    }

    /// A shader module of `words`, created through the hook: checks that exactly the
    /// application's creation reaches the fake.
    fn module(&self, words: &[u32]) -> vk::ShaderModule {
        let info = vk::ShaderModuleCreateInfo::default().code(words);
        let mut module = vk::ShaderModule::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_shader_module)(self.device, &info, std::ptr::null(), &mut module)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        assert_eq!(
            self.events(),
            [Event::CreateShaderModule {
                handle: module,
                code: words.to_vec(),
                allocator: false,
            }],
            "the application's module goes down as it is"
        );
        self.modules.borrow_mut().push(module);
        module
    }

    fn vertex_module(&self) -> vk::ShaderModule {
        self.module(&test_spirv::compile_glsl(naga::ShaderStage::Vertex, VERTEX))
    }

    /// Creates pipelines through the hook; returns the result and the handles written.
    fn create_pipelines(
        &self,
        infos: &[vk::GraphicsPipelineCreateInfo<'_>],
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) -> (vk::Result, Vec<vk::Pipeline>) {
        let p_allocator = allocator.map_or(std::ptr::null(), |a| a as *const _);
        let mut handles = vec![vk::Pipeline::from_raw(0xDEAD); infos.len()];
        // SAFETY: a live device, valid create infos and room for their handles.
        let result = unsafe {
            (self.hooks.create_graphics_pipelines)(
                self.device,
                cache(),
                infos.len() as u32,
                infos.as_ptr(),
                p_allocator,
                handles.as_mut_ptr(),
            )
        };
        self.pipelines
            .borrow_mut()
            .extend(handles.iter().filter(|h| !h.is_null()));
        (result, handles)
    }

    /// Creates one pipeline that gets a variant with a rewritten fragment stage: checks that
    /// the temporary module of the rewritten code, the variant and the temporary module's
    /// destruction reach the fake, in that order, before the application's pipeline.
    fn create_with_variant(
        &self,
        info: &vk::GraphicsPipelineCreateInfo<'_>,
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) -> WithVariant {
        let (result, handles) = self.create_pipelines(std::slice::from_ref(info), allocator);
        assert_eq!(result, vk::Result::SUCCESS);
        let events = self.events();
        let [Event::CreateShaderModule {
            handle: temporary,
            code,
            allocator: false,
        }, Event::CreateGraphicsPipelines {
            cache: variant_cache,
            infos: variant_infos,
            allocator: false,
            result: vk::Result::SUCCESS,
            handles: variant_handles,
        }, Event::DestroyShaderModule {
            handle: destroyed,
            allocator: false,
        }, Event::CreateGraphicsPipelines {
            cache: app_cache,
            infos: app_infos,
            allocator: app_allocator,
            result: vk::Result::SUCCESS,
            handles: app_handles,
        }] = events.as_slice()
        else {
            panic!(
                "a temporary module, the variant, the module destroyed, then the \
                 application's pipeline (no allocator but the application's): {events:#?}"
            );
        };
        assert_eq!(*app_allocator, allocator.is_some());
        assert_eq!(
            (*variant_cache, *app_cache),
            (cache(), cache()),
            "the application's cache"
        );
        assert_eq!(destroyed, temporary, "the temporary module is destroyed");
        assert_ne!(*temporary, vk::ShaderModule::null());
        let ([variant_info], [variant], [app_info], [app]) = (
            variant_infos.as_slice(),
            variant_handles.as_slice(),
            app_infos.as_slice(),
            app_handles.as_slice(),
        ) else {
            panic!("one pipeline per call: {events:#?}");
        };
        assert_eq!(handles, [*app], "the application gets its own pipeline");
        assert_ne!(variant, app);
        let recorded = self.recorded(*app);
        assert_eq!(recorded.handle, *app);
        assert_eq!(recorded.reversed_variant, Some(*variant));
        assert!(!recorded.unreversed_fragment);
        WithVariant {
            app: *app,
            variant: *variant,
            temporary: *temporary,
            code: code.clone(),
            app_info: app_info.clone(),
            variant_info: variant_info.clone(),
        }
    }

    /// Destroys a pipeline through the hook (not again at the end).
    fn destroy_pipeline(
        &self,
        pipeline: vk::Pipeline,
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) {
        self.pipelines.borrow_mut().retain(|&p| p != pipeline);
        let p_allocator = allocator.map_or(std::ptr::null(), |a| a as *const _);
        // SAFETY: a live device and a pipeline it created.
        unsafe { (self.hooks.destroy_pipeline)(self.device, pipeline, p_allocator) };
    }

    /// A render pass of a D32 depth attachment and a color attachment: subpass 0 renders both,
    /// subpass 1 only color.
    fn render_pass(&self) -> vk::RenderPass {
        let depth = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let color = [color_reference()];
        self.render_pass_of(&[
            vk::SubpassDescription2::default()
                .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
                .color_attachments(&color)
                .depth_stencil_attachment(&depth),
            vk::SubpassDescription2::default()
                .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
                .color_attachments(&color),
        ])
    }

    /// A render pass of `subpasses` over a D32 attachment 0 and a color attachment 1, created
    /// through the hook.
    fn render_pass_of(&self, subpasses: &[vk::SubpassDescription2<'_>]) -> vk::RenderPass {
        let attachments = [
            vk::AttachmentDescription2::default()
                .format(D32)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .final_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
            vk::AttachmentDescription2::default()
                .format(COLOR)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .final_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
        ];
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(subpasses);
        let mut pass = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_render_pass2)(self.device, &info, std::ptr::null(), &mut pass)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.passes.borrow_mut().push(pass);
        self.events();
        pass
    }

    /// A deferred render pass (D32 attachment 0, color attachment 1): subpass 0 renders both,
    /// subpass 1 reads the depth as input attachment 0 and renders color, subpass 2 the same
    /// with the depth attached read-only too.
    fn deferred_render_pass(&self) -> vk::RenderPass {
        let depth = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let read_only = vk::AttachmentReference2 {
            layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            ..depth
        };
        let input = [read_only];
        let color = [color_reference()];
        let subpass = || {
            vk::SubpassDescription2::default()
                .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
                .color_attachments(&color)
        };
        self.render_pass_of(&[
            subpass().depth_stencil_attachment(&depth),
            subpass().input_attachments(&input),
            subpass()
                .input_attachments(&input)
                .depth_stencil_attachment(&read_only),
        ])
    }

    /// Destroys everything through the hooks, checks revz forgot it and that the device's
    /// destruction sends down exactly `at_device_destruction` before the device itself (revz's
    /// own objects the application left), then destroys the device and the instance and
    /// reclaims the fake objects.
    fn finish_with(self, at_device_destruction: &[Event]) {
        let objects = &self.state.objects;
        // The variants of the pipelines left: each destroyed with its pipeline.
        let variants: Vec<vk::Pipeline> = self
            .pipelines
            .borrow()
            .iter()
            .filter_map(|p| objects.pipelines.get(p)?.reversed_variant)
            .collect();
        // SAFETY: objects of this live device, no longer in use, each destroyed once.
        unsafe {
            for &pipeline in self.pipelines.borrow().iter() {
                (self.hooks.destroy_pipeline)(self.device, pipeline, std::ptr::null());
            }
            for &module in self.modules.borrow().iter() {
                (self.hooks.destroy_shader_module)(self.device, module, std::ptr::null());
            }
            for &pass in self.passes.borrow().iter() {
                (self.hooks.destroy_render_pass)(self.device, pass, std::ptr::null());
            }
        }
        for pipeline in self.pipelines.borrow().iter() {
            assert!(objects.pipelines.get(pipeline).is_none());
        }
        for module in self.modules.borrow().iter() {
            assert!(objects.fragment_depth_modules.get(module).is_none());
        }
        let events = self.events();
        for variant in variants {
            assert!(
                events.contains(&Event::DestroyPipeline {
                    handle: variant,
                    allocator: false,
                }),
                "variant {variant:?} destroyed with its pipeline: {events:#?}"
            );
        }
        // SAFETY: the fixture's objects, no longer in use.
        let device_events = unsafe {
            fake_chain::tear_down(self.tables, self.instance, self.physical, self.device)
        };
        let mut expected = at_device_destruction.to_vec();
        expected.push(Event::DestroyDevice);
        assert_eq!(
            device_events, expected,
            "what revz destroys with the device"
        );
    }

    fn finish(self) {
        self.finish_with(&[]);
    }
}

/// The color attachment (1) of the tests' render passes.
fn color_reference() -> vk::AttachmentReference2<'static> {
    vk::AttachmentReference2::default()
        .attachment(1)
        .layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .aspect_mask(vk::ImageAspectFlags::COLOR)
}

/// A pipeline revz created a variant for, and what the fake saw of both.
struct WithVariant {
    app: vk::Pipeline,
    variant: vk::Pipeline,
    /// The temporary module of the rewritten fragment code, and that code.
    temporary: vk::ShaderModule,
    code: Vec<u32>,
    app_info: SeenPipeline,
    variant_info: SeenPipeline,
}

/// A stage of `module` (entry point `main`).
fn stage(
    stage: vk::ShaderStageFlags,
    module: vk::ShaderModule,
) -> vk::PipelineShaderStageCreateInfo<'static> {
    vk::PipelineShaderStageCreateInfo::default()
        .stage(stage)
        .module(module)
        .name(MAIN)
}

/// A fragment stage of SPIR-V chained inline (module null) with the chain `p_next`.
fn inline_stage(p_next: *const c_void) -> vk::PipelineShaderStageCreateInfo<'static> {
    vk::PipelineShaderStageCreateInfo {
        p_next,
        ..stage(vk::ShaderStageFlags::FRAGMENT, vk::ShaderModule::null())
    }
}

/// The application's graphics pipeline: its stages, a static viewport, a depth test (LESS,
/// static) and scissor as its only dynamic state, rendering into a D32 attachment with
/// dynamic rendering (or into a subpass of a render pass).
struct AppPipeline {
    stages: Vec<vk::PipelineShaderStageCreateInfo<'static>>,
    flags: vk::PipelineCreateFlags,
    base: (vk::Pipeline, i32),
    viewports: [vk::Viewport; 1],
    scissors: [vk::Rect2D; 1],
    dynamic_states: Vec<vk::DynamicState>,
    depth_stencil: vk::PipelineDepthStencilStateCreateInfo<'static>,
    rasterization: vk::PipelineRasterizationStateCreateInfo<'static>,
    vertex_input: vk::PipelineVertexInputStateCreateInfo<'static>,
    input_assembly: vk::PipelineInputAssemblyStateCreateInfo<'static>,
    multisample: vk::PipelineMultisampleStateCreateInfo<'static>,
    color_blend_attachments: [vk::PipelineColorBlendAttachmentState; 1],
    color_formats: [vk::Format; 1],
    depth_format: vk::Format,
    /// A render pass and subpass instead of dynamic rendering.
    subpass: Option<(vk::RenderPass, u32)>,
}

impl AppPipeline {
    fn new(stages: Vec<vk::PipelineShaderStageCreateInfo<'static>>) -> AppPipeline {
        AppPipeline {
            stages,
            flags: vk::PipelineCreateFlags::empty(),
            base: (vk::Pipeline::null(), -1),
            viewports: [vk::Viewport {
                x: 0.0,
                y: 0.0,
                width: EXTENT.width as f32,
                height: EXTENT.height as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            }],
            scissors: [EXTENT.into()],
            dynamic_states: vec![vk::DynamicState::SCISSOR],
            depth_stencil: vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(true)
                .depth_write_enable(true)
                .depth_compare_op(vk::CompareOp::LESS),
            rasterization: vk::PipelineRasterizationStateCreateInfo::default()
                .polygon_mode(vk::PolygonMode::FILL)
                .cull_mode(vk::CullModeFlags::BACK)
                .line_width(1.0),
            vertex_input: vk::PipelineVertexInputStateCreateInfo::default(),
            input_assembly: vk::PipelineInputAssemblyStateCreateInfo::default()
                .topology(vk::PrimitiveTopology::TRIANGLE_LIST),
            multisample: vk::PipelineMultisampleStateCreateInfo::default()
                .rasterization_samples(vk::SampleCountFlags::TYPE_1),
            color_blend_attachments: [vk::PipelineColorBlendAttachmentState::default()
                .color_write_mask(vk::ColorComponentFlags::RGBA)],
            color_formats: [COLOR],
            depth_format: D32,
            subpass: None,
        }
    }

    /// A vertex stage and a fragment stage of `fragment`.
    fn of_modules(vertex: vk::ShaderModule, fragment: vk::ShaderModule) -> AppPipeline {
        AppPipeline::new(vec![
            stage(vk::ShaderStageFlags::VERTEX, vertex),
            stage(vk::ShaderStageFlags::FRAGMENT, fragment),
        ])
    }

    fn build(&self) -> Built<'_> {
        Built {
            app: self,
            viewport: vk::PipelineViewportStateCreateInfo::default()
                .viewports(&self.viewports)
                .scissors(&self.scissors),
            dynamic: vk::PipelineDynamicStateCreateInfo::default()
                .dynamic_states(&self.dynamic_states),
            color_blend: vk::PipelineColorBlendStateCreateInfo::default()
                .attachments(&self.color_blend_attachments),
            rendering: vk::PipelineRenderingCreateInfo::default()
                .color_attachment_formats(&self.color_formats)
                .depth_attachment_format(self.depth_format),
        }
    }
}

/// The structures of an [`AppPipeline`] that point into it.
struct Built<'a> {
    app: &'a AppPipeline,
    viewport: vk::PipelineViewportStateCreateInfo<'a>,
    dynamic: vk::PipelineDynamicStateCreateInfo<'a>,
    color_blend: vk::PipelineColorBlendStateCreateInfo<'a>,
    rendering: vk::PipelineRenderingCreateInfo<'a>,
}

impl Built<'_> {
    fn info(&self) -> vk::GraphicsPipelineCreateInfo<'_> {
        let app = self.app;
        let (p_next, render_pass, subpass) = match app.subpass {
            Some((pass, subpass)) => (std::ptr::null(), pass, subpass),
            None => (
                (&self.rendering as *const vk::PipelineRenderingCreateInfo<'_>).cast(),
                vk::RenderPass::null(),
                0,
            ),
        };
        vk::GraphicsPipelineCreateInfo {
            p_next,
            flags: app.flags,
            stage_count: app.stages.len() as u32,
            p_stages: app.stages.as_ptr(),
            p_vertex_input_state: &app.vertex_input,
            p_input_assembly_state: &app.input_assembly,
            p_viewport_state: &self.viewport,
            p_rasterization_state: &app.rasterization,
            p_multisample_state: &app.multisample,
            p_depth_stencil_state: &app.depth_stencil,
            p_color_blend_state: &self.color_blend,
            p_dynamic_state: &self.dynamic,
            layout: layout(),
            render_pass,
            subpass,
            base_pipeline_handle: app.base.0,
            base_pipeline_index: app.base.1,
            ..Default::default()
        }
    }
}

/// What the fake sees of `info`.
fn seen(info: &vk::GraphicsPipelineCreateInfo<'_>) -> SeenPipeline {
    // SAFETY: the tests' create infos are valid, their depth-stencil states included.
    unsafe { seen_pipeline(info) }
}

/// The application's [`AppPipeline`] state as revz extends it: the static compare op and
/// viewport made dynamic after the application's scissor.
const EXTENDED: [vk::DynamicState; 3] = [
    vk::DynamicState::SCISSOR,
    vk::DynamicState::DEPTH_COMPARE_OP,
    vk::DynamicState::VIEWPORT,
];

/// The one creation of the application's pipeline that reaches the fake, without a variant.
fn only_app_creation(events: &[Event]) -> (SeenPipeline, vk::Pipeline) {
    match events {
        [Event::CreateGraphicsPipelines {
            infos,
            result: vk::Result::SUCCESS,
            handles,
            ..
        }] if infos.len() == 1 && handles.len() == 1 => (infos[0].clone(), handles[0]),
        other => panic!("only the application's pipeline is created: {other:#?}"),
    }
}

/// The module a `vkCreateShaderModule` event created.
fn created_module(event: &Event) -> vk::ShaderModule {
    match event {
        Event::CreateShaderModule { handle, .. } => *handle,
        other => panic!("a module creation: {other:?}"),
    }
}

/// The module a `vkDestroyShaderModule` event destroyed (revz's own: no allocator).
fn destroyed_module(event: &Event) -> vk::ShaderModule {
    match event {
        Event::DestroyShaderModule {
            handle,
            allocator: false,
        } => *handle,
        other => panic!("a module destruction without allocator: {other:?}"),
    }
}

/// The create infos and handles of a successful `vkCreateGraphicsPipelines` event.
fn created_pipelines(event: &Event) -> (&[SeenPipeline], &[vk::Pipeline]) {
    match event {
        Event::CreateGraphicsPipelines {
            infos,
            result: vk::Result::SUCCESS,
            handles,
            ..
        } => (infos, handles),
        other => panic!("a successful pipeline creation: {other:?}"),
    }
}

#[test]
fn a_frag_depth_module_is_rewritten_and_its_variant_created_before_the_app_pipeline() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let words = fragment(FRAG_DEPTH);
    let module = fx.module(&words);
    let rewrite = reverse_fragment_depth(&words)
        .expect("rewritable")
        .expect("computes with depth");
    // Rewritten once, at module creation.
    let recorded = fx.state.objects.fragment_depth_modules.get(&module);
    assert_eq!(
        recorded
            .as_ref()
            .map(|r| r.as_ref().map(|code| code.to_vec())),
        Some(Ok(rewrite.clone()))
    );
    assert!(
        fx.state
            .objects
            .fragment_depth_modules
            .get(&vertex)
            .is_none(),
        "the vertex module does not compute with depth"
    );

    let mut app = AppPipeline::of_modules(vertex, module);
    // Flags and a base the variant must not inherit, beside some it keeps.
    app.flags = vk::PipelineCreateFlags::ALLOW_DERIVATIVES
        | vk::PipelineCreateFlags::DISABLE_OPTIMIZATION
        | vk::PipelineCreateFlags::DERIVATIVE
        | vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED
        | vk::PipelineCreateFlags::EARLY_RETURN_ON_FAILURE;
    let base = vk::Pipeline::from_raw(0xBA5E);
    app.base = (base, -1);
    let built = app.build();
    let info = built.info();
    let allocator = vk::AllocationCallbacks::default();
    let created = fx.create_with_variant(&info, Some(&allocator));

    // The temporary module holds the rewritten code, which validates.
    assert_ne!(created.temporary, module);
    assert_ne!(created.code, words, "the rewritten code");
    assert_eq!(created.code, rewrite);
    validate(&created.code);

    // The application's create info goes down unchanged but for its dynamic state list.
    let app_seen = seen(&info);
    assert_eq!(
        created.app_info,
        SeenPipeline {
            address: created.app_info.address,
            dynamic: created.app_info.dynamic,
            dynamic_states: EXTENDED.to_vec(),
            ..app_seen.clone()
        }
    );
    assert_ne!(created.app_info.dynamic, app_seen.dynamic, "a copy");
    assert_eq!(app_seen.dynamic_states, [vk::DynamicState::SCISSOR], "kept");
    assert_eq!(created.app_info.base_pipeline_handle, base);

    // The variant: the same, standalone (no derivative, no early return in its batch of one,
    // from the cache only as the application asked), its fragment stage of the temporary
    // module.
    let mut stages = app_seen.stages.clone();
    stages[1].module = created.temporary;
    assert_eq!(
        created.variant_info,
        SeenPipeline {
            address: created.variant_info.address,
            flags: vk::PipelineCreateFlags::ALLOW_DERIVATIVES
                | vk::PipelineCreateFlags::DISABLE_OPTIMIZATION
                | vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED,
            stages_address: created.variant_info.stages_address,
            stages,
            dynamic: created.variant_info.dynamic,
            dynamic_states: EXTENDED.to_vec(),
            base_pipeline_handle: vk::Pipeline::null(),
            base_pipeline_index: -1,
            ..app_seen.clone()
        }
    );
    assert_ne!(
        created.variant_info.stages_address, app_seen.stages_address,
        "a copy of the stages"
    );
    assert_eq!(
        app.stages[1].module, module,
        "the application's stages are not written"
    );
    assert_eq!(
        created.variant_info.depth_compare_op,
        Some(vk::CompareOp::LESS),
        "the compare op is dynamic: the variant keeps the static one"
    );
    fx.finish();
}

#[test]
fn a_subpass_with_a_depth_attachment_gets_the_variant_and_one_without_does_not() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let pass = fx.render_pass();

    let mut app = AppPipeline::of_modules(vertex, module);
    app.subpass = Some((pass, 0));
    let built = app.build();
    let info = built.info();
    let created = fx.create_with_variant(&info, None);
    assert_eq!(created.variant_info.render_pass, pass);
    assert_eq!(created.variant_info.subpass, 0);
    assert_eq!(created.variant_info.p_next, 0);

    // Subpass 1 has no depth attachment: nothing to reverse, nothing changed.
    app.subpass = Some((pass, 1));
    let built = app.build();
    let info = built.info();
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(handles, [handle]);
    assert_eq!(
        app_info,
        seen(&info),
        "the application's create info itself"
    );
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    assert!(!fx.recorded(handle).unreversed_fragment);

    // Dynamic rendering without a depth attachment: the same.
    app.subpass = None;
    app.depth_format = vk::Format::UNDEFINED;
    let built = app.build();
    let info = built.info();
    assert_eq!(
        fx.create_pipelines(std::slice::from_ref(&info), None).0,
        vk::Result::SUCCESS
    );
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(app_info, seen(&info));
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    fx.finish();
}

#[test]
fn destroying_the_pipeline_destroys_its_variant_without_the_app_allocator() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let allocator = vk::AllocationCallbacks::default();
    let created = fx.create_with_variant(&built.info(), Some(&allocator));

    fx.destroy_pipeline(created.app, Some(&allocator));
    assert_eq!(
        fx.events(),
        [
            Event::DestroyPipeline {
                handle: created.variant,
                allocator: false,
            },
            Event::DestroyPipeline {
                handle: created.app,
                allocator: true,
            },
        ]
    );
    assert!(fx.state.objects.pipelines.get(&created.app).is_none());

    // A pipeline without a variant: only itself.
    let plain = fx.module(&fragment(PLAIN));
    let app = AppPipeline::of_modules(vertex, plain);
    let built = app.build();
    assert_eq!(
        fx.create_pipelines(&[built.info()], None).0,
        vk::Result::SUCCESS
    );
    let (_, handle) = only_app_creation(&fx.events());
    fx.destroy_pipeline(handle, None);
    assert_eq!(
        fx.events(),
        [Event::DestroyPipeline {
            handle,
            allocator: false,
        }]
    );
    fx.finish();
}

#[test]
fn destroying_a_module_forgets_its_rewrite_and_passes_the_app_allocator() {
    let fx = Fixture::new();
    let module = fx.module(&fragment(FRAG_DEPTH));
    assert!(fx
        .state
        .objects
        .fragment_depth_modules
        .get(&module)
        .is_some());
    fx.modules.borrow_mut().retain(|&m| m != module);
    let allocator = vk::AllocationCallbacks::default();
    // SAFETY: a live device and a module it created.
    unsafe { (fx.hooks.destroy_shader_module)(fx.device, module, &allocator) };
    assert_eq!(
        fx.events(),
        [Event::DestroyShaderModule {
            handle: module,
            allocator: true,
        }]
    );
    assert!(fx
        .state
        .objects
        .fragment_depth_modules
        .get(&module)
        .is_none());
    fx.finish();
}

#[test]
fn when_the_app_pipeline_fails_its_variant_is_destroyed() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let info = built.info();
    // The variant is created; the application's pipeline is not.
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [
            PipelineOutcome::success(),
            PipelineOutcome::failure(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY),
        ],
    );
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::ERROR_OUT_OF_DEVICE_MEMORY);
    assert_eq!(handles, [vk::Pipeline::null()]);
    let events = fx.events();
    let [Event::CreateShaderModule {
        handle: temporary, ..
    }, Event::CreateGraphicsPipelines {
        handles: variant_handles,
        result: vk::Result::SUCCESS,
        ..
    }, Event::DestroyShaderModule {
        handle: destroyed, ..
    }, Event::CreateGraphicsPipelines {
        result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
        ..
    }, Event::DestroyPipeline {
        handle: variant_destroyed,
        allocator: false,
    }] = events.as_slice()
    else {
        panic!("the variant is destroyed after the application's pipeline fails: {events:#?}");
    };
    assert_eq!(temporary, destroyed);
    assert_eq!(variant_handles.as_slice(), [*variant_destroyed]);
    assert!(fx.state.objects.pipelines.get(variant_destroyed).is_none());
    assert!(fx
        .state
        .objects
        .pipelines
        .get(&vk::Pipeline::null())
        .is_none());
    // Nothing left for the device's destruction to destroy.
    fx.finish();
}

#[test]
fn a_batch_gets_one_standalone_variant_per_pipeline_and_a_partial_failure_destroys_only_its_own() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let mut first = AppPipeline::of_modules(vertex, module);
    first.flags = vk::PipelineCreateFlags::ALLOW_DERIVATIVES;
    let mut second = AppPipeline::of_modules(vertex, module);
    // A derivative of the first of the batch.
    second.flags = vk::PipelineCreateFlags::DERIVATIVE;
    second.base = (vk::Pipeline::null(), 0);
    let (first_built, second_built) = (first.build(), second.build());
    let infos = [first_built.info(), second_built.info()];

    let (result, handles) = fx.create_pipelines(&infos, None);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    let [m0, v0, d0, m1, v1, d1, app_creation] = events.as_slice() else {
        panic!("each pipeline's variant (and module), then the batch: {events:#?}");
    };
    let (t0, t1) = (created_module(m0), created_module(m1));
    let (d0, d1) = (destroyed_module(d0), destroyed_module(d1));
    let ((v0_infos, v0), (v1_infos, v1)) = (created_pipelines(v0), created_pipelines(v1));
    let (app_infos, app_handles) = created_pipelines(app_creation);
    assert_eq!((t0, t1), (d0, d1));
    assert_eq!(app_handles, handles);
    assert_eq!(
        app_infos.len(),
        2,
        "the application's batch goes down as one call"
    );
    assert_eq!(
        (app_infos[1].flags, app_infos[1].base_pipeline_index),
        (vk::PipelineCreateFlags::DERIVATIVE, 0),
        "the application's derivative is kept"
    );
    assert_eq!(
        v0_infos[0].flags,
        vk::PipelineCreateFlags::ALLOW_DERIVATIVES
    );
    assert_eq!(
        (
            v1_infos[0].flags,
            v1_infos[0].base_pipeline_handle,
            v1_infos[0].base_pipeline_index
        ),
        (vk::PipelineCreateFlags::empty(), vk::Pipeline::null(), -1),
        "the variant of the derivative is standalone"
    );
    assert_eq!(fx.recorded(handles[0]).reversed_variant, Some(v0[0]));
    assert_eq!(fx.recorded(handles[1]).reversed_variant, Some(v1[0]));

    // The second fails to compile from the cache alone: its variant goes, the first's stays.
    second.flags = vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED;
    second.base = (vk::Pipeline::null(), -1);
    let second_built = second.build();
    let infos = [first_built.info(), second_built.info()];
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [
            PipelineOutcome::success(),
            PipelineOutcome::success(),
            PipelineOutcome {
                result: vk::Result::PIPELINE_COMPILE_REQUIRED,
                created: vec![true, false],
            },
        ],
    );
    let (result, handles) = fx.create_pipelines(&infos, None);
    assert_eq!(result, vk::Result::PIPELINE_COMPILE_REQUIRED);
    assert!(!handles[0].is_null() && handles[1].is_null());
    let events = fx.events();
    let variants: Vec<vk::Pipeline> = events
        .iter()
        .filter_map(|event| match event {
            Event::CreateGraphicsPipelines { infos, handles, .. } if infos.len() == 1 => {
                Some(handles[0])
            }
            _ => None,
        })
        .collect();
    assert_eq!(variants.len(), 2, "{events:#?}");
    assert_eq!(
        v1_infos[0].flags,
        vk::PipelineCreateFlags::empty(),
        "compiled even where the application only accepts cached pipelines"
    );
    assert_eq!(
        events.last(),
        Some(&Event::DestroyPipeline {
            handle: variants[1],
            allocator: false,
        }),
        "{events:#?}"
    );
    assert_eq!(fx.recorded(handles[0]).reversed_variant, Some(variants[0]));
    assert!(fx.state.objects.pipelines.get(&variants[1]).is_none());
    fx.finish();
}

#[test]
fn inline_spirv_first_in_the_stage_chain_is_skipped_by_the_variant_stage() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let words = fragment(FRAG_DEPTH);
    let subgroup =
        vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo::default().required_subgroup_size(32);
    let inline = vk::ShaderModuleCreateInfo {
        p_next: (&subgroup as *const vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo<'_>)
            .cast(),
        ..vk::ShaderModuleCreateInfo::default().code(&words)
    };
    let inline_address = &inline as *const vk::ShaderModuleCreateInfo<'_> as usize;
    let subgroup_address =
        &subgroup as *const vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo<'_> as usize;
    let app = AppPipeline::new(vec![
        stage(vk::ShaderStageFlags::VERTEX, vertex),
        inline_stage((&inline as *const vk::ShaderModuleCreateInfo<'_>).cast()),
    ]);
    let built = app.build();
    let created = fx.create_with_variant(&built.info(), None);
    assert_eq!(
        created.code,
        reverse_fragment_depth(&words).unwrap().unwrap()
    );
    validate(&created.code);

    let variant_stage = &created.variant_info.stages[1];
    assert_eq!(variant_stage.module, created.temporary);
    assert_eq!(
        variant_stage.p_next, subgroup_address,
        "the variant's stage chain starts after the inline code"
    );
    assert_eq!(variant_stage.inline_code, None);
    let app_stage = &created.app_info.stages[1];
    assert_eq!(app_stage.module, vk::ShaderModule::null());
    assert_eq!(app_stage.p_next, inline_address, "the application's chain");
    assert_eq!(app_stage.inline_code.as_deref(), Some(words.as_slice()));
    // Rewritten once for this code, kept for the next pipeline that chains it.
    assert_eq!(fx.state.objects.fragment_codes.len(), 1);
    fx.finish();
}

/// A structure of a type revz does not know (so cannot copy).
const UNKNOWN: vk::StructureType = vk::StructureType::from_raw(1_000_999_000);

#[test]
fn inline_spirv_after_another_structure_is_spliced_out_of_the_variant_stage() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let words = fragment(FRAG_DEPTH);
    let after = vk::BaseInStructure {
        s_type: UNKNOWN,
        ..Default::default()
    };
    let inline = vk::ShaderModuleCreateInfo {
        p_next: (&after as *const vk::BaseInStructure<'_>).cast(),
        ..vk::ShaderModuleCreateInfo::default().code(&words)
    };
    let subgroup = vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo {
        p_next: (&inline as *const vk::ShaderModuleCreateInfo<'_>)
            .cast_mut()
            .cast(),
        ..vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo::default()
            .required_subgroup_size(32)
    };
    let subgroup_address =
        &subgroup as *const vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo<'_> as usize;
    let app = AppPipeline::new(vec![
        stage(vk::ShaderStageFlags::VERTEX, vertex),
        inline_stage(
            (&subgroup as *const vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo<'_>).cast(),
        ),
    ]);
    let built = app.build();
    let created = fx.create_with_variant(&built.info(), None);
    assert_eq!(
        created.code,
        reverse_fragment_depth(&words).unwrap().unwrap()
    );
    let variant_stage = &created.variant_info.stages[1];
    assert_eq!(variant_stage.module, created.temporary);
    assert_eq!(variant_stage.inline_code, None);
    assert_eq!(
        variant_stage.chain,
        [subgroup.s_type, UNKNOWN],
        "the structure before the inline code copied, the one after it shared"
    );
    assert_ne!(variant_stage.p_next, subgroup_address, "a copy");
    let app_stage = &created.app_info.stages[1];
    assert_eq!(
        app_stage.p_next, subgroup_address,
        "the application's chain"
    );
    assert_eq!(
        app_stage.chain,
        [subgroup.s_type, inline.s_type, UNKNOWN],
        "left as it was"
    );
    fx.finish();
}

#[test]
fn inline_spirv_after_an_unknown_structure_gets_no_variant_and_is_marked_unreversed() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let words = fragment(FRAG_DEPTH);
    let inline = vk::ShaderModuleCreateInfo::default().code(&words);
    let unknown = vk::BaseInStructure {
        s_type: UNKNOWN,
        p_next: (&inline as *const vk::ShaderModuleCreateInfo<'_>).cast(),
        ..Default::default()
    };
    let app = AppPipeline::new(vec![
        stage(vk::ShaderStageFlags::VERTEX, vertex),
        inline_stage((&unknown as *const vk::BaseInStructure<'_>).cast()),
    ]);
    let built = app.build();
    let info = built.info();
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    // Its size unknown, the structure cannot be copied: no temporary module, no variant.
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(handles, [handle]);
    assert_eq!(app_info.stages, seen(&info).stages);
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn a_module_without_depth_gets_no_variant() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(PLAIN));
    assert!(fx
        .state
        .objects
        .fragment_depth_modules
        .get(&module)
        .is_none());
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let info = built.info();
    assert_eq!(
        fx.create_pipelines(std::slice::from_ref(&info), None).0,
        vk::Result::SUCCESS
    );
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(
        app_info,
        SeenPipeline {
            address: app_info.address,
            dynamic: app_info.dynamic,
            dynamic_states: EXTENDED.to_vec(),
            ..seen(&info)
        }
    );
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(!recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn a_module_the_rewrite_refuses_gets_no_variant_and_is_marked_unreversed() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&refused_fragment());
    assert!(matches!(
        fx.state.objects.fragment_depth_modules.get(&module),
        Some(Err(_))
    ));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    assert_eq!(
        fx.create_pipelines(&[built.info()], None).0,
        vk::Result::SUCCESS
    );
    let (_, handle) = only_app_creation(&fx.events());
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn when_the_temporary_module_or_the_variant_fails_the_app_pipeline_is_marked_unreversed() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let info = built.info();

    // The temporary module cannot be created: no variant is attempted.
    fake_chain::script_shader_module_creations(
        fx.tables.device,
        [vk::Result::ERROR_OUT_OF_HOST_MEMORY],
    );
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    let [Event::CreateShaderModule { handle, .. }, app_creation] = events.as_slice() else {
        panic!("the failed module, then the application's pipeline: {events:#?}");
    };
    assert_eq!(*handle, vk::ShaderModule::null());
    let (_, app_handle) = only_app_creation(std::slice::from_ref(app_creation));
    assert_eq!(handles, [app_handle]);
    let recorded = fx.recorded(app_handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);

    // The variant cannot be created: its module is destroyed all the same.
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [PipelineOutcome::failure(
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
        )],
    );
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    let [Event::CreateShaderModule {
        handle: temporary, ..
    }, Event::CreateGraphicsPipelines {
        result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
        ..
    }, Event::DestroyShaderModule {
        handle: destroyed, ..
    }, app_creation] = events.as_slice()
    else {
        panic!("the module, the failed variant, the module destroyed, the app: {events:#?}");
    };
    assert_eq!(temporary, destroyed);
    let (_, app_handle) = only_app_creation(std::slice::from_ref(app_creation));
    assert_eq!(handles, [app_handle]);
    let recorded = fx.recorded(app_handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn with_compare_op_variants_the_variant_flips_the_compare_op_and_rewrites_the_fragment() {
    let fx = Fixture::with_settings(&[(c"mode", c"flip"), (c"compare_op", c"variants")]);
    assert!(fx.state.policy.compare_op_variants);
    let vertex = fx.vertex_module();

    // A plain fragment shader: a variant for the compare op alone, no temporary module.
    let plain = fx.module(&fragment(PLAIN));
    let app = AppPipeline::of_modules(vertex, plain);
    let built = app.build();
    let info = built.info();
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    let events = fx.events();
    let [Event::CreateGraphicsPipelines {
        infos: variant_infos,
        handles: variant,
        ..
    }, Event::CreateGraphicsPipelines {
        infos: app_infos,
        handles: app_handles,
        ..
    }] = events.as_slice()
    else {
        panic!("the variant, then the application's pipeline: {events:#?}");
    };
    assert_eq!(app_handles, &handles);
    assert_eq!(
        variant_infos[0].depth_compare_op,
        Some(vk::CompareOp::GREATER)
    );
    assert_eq!(variant_infos[0].stages, seen(&info).stages);
    assert_eq!(app_infos[0].depth_compare_op, Some(vk::CompareOp::LESS));
    // Only the viewport is made dynamic.
    assert_eq!(
        app_infos[0].dynamic_states,
        [vk::DynamicState::SCISSOR, vk::DynamicState::VIEWPORT]
    );
    assert_eq!(fx.recorded(handles[0]).reversed_variant, Some(variant[0]));

    // A FragDepth shader: one variant with both.
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let created = fx.create_with_variant(&built.info(), None);
    assert_eq!(
        created.variant_info.depth_compare_op,
        Some(vk::CompareOp::GREATER)
    );
    assert_eq!(created.variant_info.stages[1].module, created.temporary);
    assert_eq!(created.app_info.depth_compare_op, Some(vk::CompareOp::LESS));
    fx.finish();
}

#[test]
fn with_compare_op_variants_the_variant_holds_the_flipped_bias_and_binds_send_no_bias() {
    let fx = Fixture::with_settings(&[(c"mode", c"flip"), (c"compare_op", c"variants")]);
    let vertex = fx.vertex_module();
    let plain = fx.module(&fragment(PLAIN));
    let mut app = AppPipeline::of_modules(vertex, plain);
    app.rasterization.depth_bias_enable = vk::TRUE;
    app.rasterization.depth_bias_constant_factor = 4.0;
    app.rasterization.depth_bias_clamp = 0.5;
    app.rasterization.depth_bias_slope_factor = 2.0;
    let built = app.build();
    let info = built.info();
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    let events = fx.events();
    let [Event::CreateGraphicsPipelines {
        infos: variant_infos,
        handles: variant,
        ..
    }, Event::CreateGraphicsPipelines {
        infos: app_infos, ..
    }] = events.as_slice()
    else {
        panic!("the variant, then the application's pipeline: {events:#?}");
    };
    // The variant: compare op and bias flipped, both static; the application's pipeline
    // keeps its own, static too (only the viewport is made dynamic).
    assert_eq!(
        variant_infos[0].depth_compare_op,
        Some(vk::CompareOp::GREATER)
    );
    assert_eq!(variant_infos[0].depth_bias, Some((-4.0, -0.5, -2.0)));
    assert_eq!(app_infos[0].depth_bias, Some((4.0, 0.5, 2.0)));
    let only_viewport = [vk::DynamicState::SCISSOR, vk::DynamicState::VIEWPORT];
    assert_eq!(app_infos[0].dynamic_states, only_viewport);
    assert_eq!(variant_infos[0].dynamic_states, only_viewport);
    let recorded = fx.recorded(handles[0]);
    assert_eq!(recorded.reversed_variant, Some(variant[0]));
    assert!(
        !recorded
            .injected
            .contains(crate::command_state::States::BIAS),
        "{recorded:?}"
    );

    // With dynamic compare op there is no variant: the bias is made dynamic, as before.
    let dynamic = Fixture::with_settings(&[(c"mode", c"flip")]);
    let vertex = dynamic.vertex_module();
    let plain = dynamic.module(&fragment(PLAIN));
    let mut app = AppPipeline::of_modules(vertex, plain);
    app.rasterization.depth_bias_enable = vk::TRUE;
    let built = app.build();
    let (seen, _) = only_app_creation(&{
        let _ = dynamic.create_pipelines(std::slice::from_ref(&built.info()), None);
        dynamic.events()
    });
    assert!(seen.dynamic_states.contains(&vk::DynamicState::DEPTH_BIAS));
    fx.finish();
    dynamic.finish();
}

/// `VK_EXT_depth_clamp_control`: a pipeline whose viewport state chains a user-defined clamp
/// range gets the range as dynamic state (the chain goes down as it is), and its static range
/// is recorded for draw time; one that leaves the range to the viewport, or sets it
/// dynamically, keeps its list.
#[test]
fn a_user_defined_clamp_range_is_made_dynamic_and_recorded() {
    use crate::command_state::States;
    use crate::vk_ext::{
        DepthClampRange, PipelineViewportDepthClampControlCreateInfo,
        DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, DEPTH_CLAMP_MODE_VIEWPORT_RANGE,
        DYNAMIC_STATE_DEPTH_CLAMP_RANGE,
    };
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let plain = fx.module(&fragment(PLAIN));
    let range = DepthClampRange {
        min_depth_clamp: 0.25,
        max_depth_clamp: 0.5,
    };
    let create = |mode: i32, app_dynamic: &[vk::DynamicState]| {
        let control = PipelineViewportDepthClampControlCreateInfo {
            s_type:
                <PipelineViewportDepthClampControlCreateInfo as vk::TaggedStructure>::STRUCTURE_TYPE,
            p_next: std::ptr::null(),
            depth_clamp_mode: mode,
            p_depth_clamp_range: &range,
        };
        let mut app = AppPipeline::of_modules(vertex, plain);
        app.dynamic_states.extend_from_slice(app_dynamic);
        let mut built = app.build();
        built.viewport.p_next =
            (&control as *const PipelineViewportDepthClampControlCreateInfo).cast();
        let (_, handles) = fx.create_pipelines(std::slice::from_ref(&built.info()), None);
        let (seen, _) = only_app_creation(&fx.events());
        (seen, fx.recorded(handles[0]))
    };
    let (seen, recorded) = create(DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, &[]);
    assert_eq!(
        seen.dynamic_states.last(),
        Some(&DYNAMIC_STATE_DEPTH_CLAMP_RANGE)
    );
    assert!(recorded.injected.contains(States::CLAMP_RANGE));
    assert_eq!(recorded.clamp_range, (0.25, 0.5));
    let (seen, recorded) = create(DEPTH_CLAMP_MODE_VIEWPORT_RANGE, &[]);
    assert!(!seen
        .dynamic_states
        .contains(&DYNAMIC_STATE_DEPTH_CLAMP_RANGE));
    assert!(!recorded.injected.contains(States::CLAMP_RANGE));
    let (seen, recorded) = create(
        DEPTH_CLAMP_MODE_USER_DEFINED_RANGE,
        &[DYNAMIC_STATE_DEPTH_CLAMP_RANGE],
    );
    assert_eq!(
        seen.dynamic_states
            .iter()
            .filter(|&&s| s == DYNAMIC_STATE_DEPTH_CLAMP_RANGE)
            .count(),
        1
    );
    assert!(recorded.app_dynamic.contains(States::CLAMP_RANGE));
    assert!(!recorded.injected.contains(States::CLAMP_RANGE));
    fx.finish();
}

#[test]
fn a_variant_the_app_never_destroyed_goes_with_the_device() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let created = fx.create_with_variant(&built.info(), None);
    // The application leaks its pipeline.
    fx.pipelines.borrow_mut().retain(|&p| p != created.app);
    fx.finish_with(&[Event::DestroyPipeline {
        handle: created.variant,
        allocator: false,
    }]);
}

#[test]
fn mode_off_passes_the_next_layers_commands_and_its_hooks_rewrite_nothing() {
    let fx = Fixture::with_settings(&[(c"mode", c"off")]);
    assert!(!fx.state.policy.is_active());
    // The application gets the next layer's own commands.
    for name in PIPELINE_COMMANDS {
        // SAFETY: a live device and NUL-terminated names.
        let (revz, next) = unsafe {
            (
                device::get_device_proc_addr(fx.device, name.as_ptr()),
                fake_chain::fake_get_device_proc_addr_with_pipelines(fx.device, name.as_ptr()),
            )
        };
        assert_eq!(
            revz.map(|f| f as usize),
            next.map(|f| f as usize),
            "{name:?}"
        );
    }

    // revz's hooks themselves (`Hooks::direct`) do nothing more either.
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    assert!(fx
        .state
        .objects
        .fragment_depth_modules
        .get(&module)
        .is_none());
    let mut app = AppPipeline::of_modules(vertex, module);
    // What revz would make dynamic is the application's already.
    app.dynamic_states = vec![
        vk::DynamicState::SCISSOR,
        vk::DynamicState::VIEWPORT,
        vk::DynamicState::DEPTH_COMPARE_OP,
    ];
    let built = app.build();
    let info = built.info();
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(handles, [handle]);
    assert_eq!(
        app_info,
        seen(&info),
        "the application's create info itself"
    );
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    fx.destroy_pipeline(handle, None);
    assert_eq!(
        fx.events(),
        [Event::DestroyPipeline {
            handle,
            allocator: false,
        }]
    );
    fx.finish();
}

/// With `VK_KHR_maintenance5`, a `VkPipelineCreateFlags2CreateInfoKHR` in the create info's
/// chain replaces `flags`: clearing DERIVATIVE, FAIL_ON_PIPELINE_COMPILE_REQUIRED and
/// EARLY_RETURN_ON_FAILURE in `flags` alone would leave them set in the flags that count (a
/// derivative with no base, invalid; refused where only cached pipelines are accepted). The
/// variant's chain starts with a cleared copy instead.
#[test]
fn the_variant_clears_derivative_and_early_return_flags_given_as_flags2() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let app_flags2 = vk::PipelineCreateFlags2KHR::ALLOW_DERIVATIVES
        | vk::PipelineCreateFlags2KHR::DERIVATIVE
        | vk::PipelineCreateFlags2KHR::FAIL_ON_PIPELINE_COMPILE_REQUIRED
        | vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE;
    let flags2 = vk::PipelineCreateFlags2CreateInfoKHR {
        p_next: (&built.rendering as *const vk::PipelineRenderingCreateInfo<'_>).cast(),
        flags: app_flags2,
        ..Default::default()
    };
    let info = vk::GraphicsPipelineCreateInfo {
        p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
        base_pipeline_handle: vk::Pipeline::from_raw(0xBA5E),
        ..built.info()
    };
    let created = fx.create_with_variant(&info, None);
    assert_eq!(created.app_info.flags2, Some(app_flags2));
    // The flags the variant is created with (flags2 where chained): the application's
    // cache-only request is kept.
    let effective = created
        .variant_info
        .flags2
        .unwrap_or(vk::PipelineCreateFlags2KHR::from_raw(u64::from(
            created.variant_info.flags.as_raw(),
        )));
    assert_eq!(
        effective,
        vk::PipelineCreateFlags2KHR::ALLOW_DERIVATIVES
            | vk::PipelineCreateFlags2KHR::FAIL_ON_PIPELINE_COMPILE_REQUIRED
    );
    fx.finish();
}

#[test]
fn a_pipeline_that_discards_every_primitive_is_not_read_beyond_what_the_spec_requires() {
    // Static rasterizer discard makes the viewport state ignored (it may dangle): the
    // precise path must not look for the clip convention there, and no variant is needed.
    let fx = Fixture::with_settings(&[(c"mode", c"complementary")]);
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let mut app = AppPipeline::of_modules(vertex, module);
    app.rasterization.rasterizer_discard_enable = vk::TRUE;
    let built = app.build();
    let dangling = 0x10 as *const vk::PipelineViewportStateCreateInfo<'static>;
    let info = vk::GraphicsPipelineCreateInfo {
        p_viewport_state: dangling,
        ..built.info()
    };
    assert_eq!(
        fx.create_pipelines(std::slice::from_ref(&info), None).0,
        vk::Result::SUCCESS
    );
    let (app_info, handle) = only_app_creation(&fx.events());
    assert_eq!(app_info, seen(&info), "passed down untouched");
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, None);
    assert_eq!(recorded.projection, None);
    assert!(!recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn flags2_after_another_structure_is_replaced_in_a_spliced_chain() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let mut built = app.build();
    let app_flags2 = vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE
        | vk::PipelineCreateFlags2KHR::DISABLE_OPTIMIZATION;
    let flags2 = vk::PipelineCreateFlags2CreateInfoKHR {
        flags: app_flags2,
        ..Default::default()
    };
    built.rendering.p_next = (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast();
    let info = built.info();
    let created = fx.create_with_variant(&info, None);
    assert_eq!(created.app_info.flags2, Some(app_flags2));
    assert_eq!(created.app_info.p_next, info.p_next as usize);
    assert_eq!(
        created.variant_info.flags2,
        Some(vk::PipelineCreateFlags2KHR::DISABLE_OPTIMIZATION)
    );
    assert_eq!(
        created.variant_info.chain,
        [built.rendering.s_type, flags2.s_type]
    );
    assert_eq!(
        flags2.flags, app_flags2,
        "the application's flags2 unchanged"
    );

    // After a structure revz cannot copy, the flags cannot be cleared: no variant.
    let unknown = vk::BaseInStructure {
        s_type: UNKNOWN,
        p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
        ..Default::default()
    };
    built.rendering.p_next = (&unknown as *const vk::BaseInStructure<'_>).cast();
    let info = built.info();
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (_, handle) = only_app_creation(&fx.events());
    assert_eq!(handles, [handle]);
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    fx.finish();
}

/// The graphics pipeline libraries of an [`AppPipeline`] of two stages: a pre-rasterization
/// library of its vertex stage and a fragment shader library of its fragment stage (with the
/// depth state), each a create info sharing the built pipeline's state.
struct Libraries<'a> {
    pre_rasterization: vk::GraphicsPipelineLibraryCreateInfoEXT<'a>,
    fragment: vk::GraphicsPipelineLibraryCreateInfoEXT<'a>,
    built: &'a Built<'a>,
}

impl<'a> Libraries<'a> {
    fn of(built: &'a Built<'a>) -> Libraries<'a> {
        Libraries {
            pre_rasterization: vk::GraphicsPipelineLibraryCreateInfoEXT::default()
                .flags(vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS),
            fragment: vk::GraphicsPipelineLibraryCreateInfoEXT::default()
                .flags(vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER),
            built,
        }
    }

    /// A library of `subset` and stage `index` of the application's pipeline.
    fn library(
        &self,
        subset: &'a vk::GraphicsPipelineLibraryCreateInfoEXT<'a>,
        index: usize,
    ) -> vk::GraphicsPipelineCreateInfo<'a> {
        vk::GraphicsPipelineCreateInfo {
            p_next: (subset as *const vk::GraphicsPipelineLibraryCreateInfoEXT<'_>).cast(),
            flags: self.built.app.flags | vk::PipelineCreateFlags::LIBRARY_KHR,
            stage_count: 1,
            p_stages: &self.built.app.stages[index],
            ..self.built.info()
        }
    }

    fn pre_rasterization_info(&'a self) -> vk::GraphicsPipelineCreateInfo<'a> {
        self.library(&self.pre_rasterization, 0)
    }

    fn fragment_info(&'a self) -> vk::GraphicsPipelineCreateInfo<'a> {
        self.library(&self.fragment, 1)
    }
}

/// A pipeline linking `links` (no state of its own).
fn link_info<'a>(
    links: &'a vk::PipelineLibraryCreateInfoKHR<'a>,
) -> vk::GraphicsPipelineCreateInfo<'a> {
    vk::GraphicsPipelineCreateInfo {
        p_next: (links as *const vk::PipelineLibraryCreateInfoKHR<'_>).cast(),
        layout: layout(),
        ..Default::default()
    }
}

/// The two creations a link with a variant sends down: the variant link, then the
/// application's; their create infos and handles.
fn variant_link_creation(
    events: &[Event],
) -> (SeenPipeline, vk::Pipeline, SeenPipeline, vk::Pipeline) {
    let [variant, app] = events else {
        panic!("the variant link, then the application's: {events:#?}");
    };
    let ([variant_info], [variant]) = created_pipelines(variant) else {
        panic!("one variant: {events:#?}");
    };
    let ([app_info], [app]) = created_pipelines(app) else {
        panic!("one application's pipeline: {events:#?}");
    };
    (variant_info.clone(), *variant, app_info.clone(), *app)
}

#[test]
fn a_fragment_shader_library_gets_a_variant_library_and_its_links_link_the_variant() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let libraries = Libraries::of(&built);

    let (_, pre) = fx.create_pipelines(&[libraries.pre_rasterization_info()], None);
    let (_, pre_handle) = only_app_creation(&fx.events());
    assert_eq!(pre, [pre_handle]);
    assert_eq!(fx.recorded(pre_handle).reversed_variant, None);

    let fragment_info = libraries.fragment_info();
    let created = fx.create_with_variant(&fragment_info, None);
    assert!(created
        .variant_info
        .flags
        .contains(vk::PipelineCreateFlags::LIBRARY_KHR));
    assert_eq!(
        created.variant_info.p_next, fragment_info.p_next as usize,
        "the library's chain, shared"
    );
    assert_eq!(created.variant_info.stages[0].module, created.temporary);
    assert_eq!(created.app_info.stages[0].module, module);

    let linked = [pre_handle, created.app];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    let (result, handles) = fx.create_pipelines(&[link_info(&links)], None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (variant_info, variant, app_info, app_link) = variant_link_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    assert_eq!(variant_info.libraries, [pre_handle, created.variant]);
    assert_eq!(
        app_info.libraries, linked,
        "the application's link is its own"
    );
    assert_eq!(app_info.p_next, &links as *const _ as usize);
    let recorded = fx.recorded(app_link);
    assert_eq!(recorded.reversed_variant, Some(variant));
    assert!(!recorded.unreversed_fragment);
    assert_eq!(
        recorded.subsets,
        vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS
            | vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER
    );
    // A library linking the fragment library (nested) gets a variant library the same way,
    // and what links it links that.
    let nested_links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked[1..]);
    let nested = vk::GraphicsPipelineCreateInfo {
        flags: vk::PipelineCreateFlags::LIBRARY_KHR,
        ..link_info(&nested_links)
    };
    let (_, handles) = fx.create_pipelines(&[nested], None);
    let (variant_info, nested_variant, _, nested_app) = variant_link_creation(&fx.events());
    assert_eq!(handles, [nested_app]);
    assert_eq!(variant_info.libraries, [created.variant]);
    assert!(variant_info
        .flags
        .contains(vk::PipelineCreateFlags::LIBRARY_KHR));
    let outer = [pre_handle, nested_app];
    let outer_links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&outer);
    let _ = fx.create_pipelines(&[link_info(&outer_links)], None);
    let (variant_info, _, _, _) = variant_link_creation(&fx.events());
    assert_eq!(variant_info.libraries, [pre_handle, nested_variant]);
    fx.finish();
}

#[test]
fn a_link_whose_variant_fails_is_marked_unreversed() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let libraries = Libraries::of(&built);
    let created = fx.create_with_variant(&libraries.fragment_info(), None);
    let linked = [created.app];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [PipelineOutcome::failure(
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
        )],
    );
    let (result, handles) = fx.create_pipelines(&[link_info(&links)], None);
    assert_eq!(
        result,
        vk::Result::SUCCESS,
        "the application's link is made"
    );
    let events = fx.events();
    let [Event::CreateGraphicsPipelines {
        result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
        ..
    }, app_creation] = events.as_slice()
    else {
        panic!("the failed variant link, then the application's: {events:#?}");
    };
    let (_, app_link) = only_app_creation(std::slice::from_ref(app_creation));
    assert_eq!(handles, [app_link]);
    let recorded = fx.recorded(app_link);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    fx.finish();
}

#[test]
fn libraries_without_variants_are_linked_as_they_are() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(PLAIN));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let libraries = Libraries::of(&built);
    let (_, fragment_library) = fx.create_pipelines(&[libraries.fragment_info()], None);
    let (app_info, _) = only_app_creation(&fx.events());
    assert_eq!(
        app_info.dynamic_states,
        [
            vk::DynamicState::SCISSOR,
            vk::DynamicState::DEPTH_COMPARE_OP
        ],
        "the compare op made dynamic in the fragment shader library"
    );
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&fragment_library);
    let info = link_info(&links);
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    let (app_info, app_link) = only_app_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    assert_eq!(app_info, seen(&info));
    assert_eq!(fx.recorded(app_link).reversed_variant, None);
    fx.finish();
}

#[test]
fn with_compare_op_variants_a_fragment_shader_library_gets_a_flipped_variant() {
    let fx = Fixture::with_settings(&[(c"mode", c"flip"), (c"compare_op", c"variants")]);
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(PLAIN));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let libraries = Libraries::of(&built);
    let (_, handles) = fx.create_pipelines(&[libraries.fragment_info()], None);
    let (variant_info, variant, app_info, app_library) = variant_link_creation(&fx.events());
    assert_eq!(handles, [app_library]);
    assert_eq!(variant_info.depth_compare_op, Some(vk::CompareOp::GREATER));
    assert_eq!(app_info.depth_compare_op, Some(vk::CompareOp::LESS));
    assert_eq!(variant_info.stages[0].module, module, "no rewrite needed");
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&handles);
    let _ = fx.create_pipelines(&[link_info(&links)], None);
    let (variant_info, _, _, _) = variant_link_creation(&fx.events());
    assert_eq!(variant_info.libraries, [variant]);
    fx.finish();
}

/// The fake's answer for a pipeline not in the cache, created with
/// `FAIL_ON_PIPELINE_COMPILE_REQUIRED`.
fn compile_required() -> PipelineOutcome {
    PipelineOutcome {
        result: vk::Result::PIPELINE_COMPILE_REQUIRED,
        created: vec![false],
    }
}

#[test]
fn a_variant_that_needs_compiling_takes_back_the_app_pipeline_asked_for_from_the_cache() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let mut app = AppPipeline::of_modules(vertex, module);
    app.flags = vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED;
    let built = app.build();
    let info = built.info();
    // The application's pipeline is in the cache, its variant is not.
    fake_chain::script_pipeline_creations(fx.tables.device, [compile_required()]);
    let allocator = vk::AllocationCallbacks::default();
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), Some(&allocator));
    assert_eq!(result, vk::Result::PIPELINE_COMPILE_REQUIRED);
    assert_eq!(handles, [vk::Pipeline::null()], "reported as not created");
    let events = fx.events();
    let [Event::CreateShaderModule {
        handle: temporary, ..
    }, Event::CreateGraphicsPipelines {
        infos: variant_infos,
        result: vk::Result::PIPELINE_COMPILE_REQUIRED,
        ..
    }, Event::DestroyShaderModule {
        handle: destroyed, ..
    }, app_creation, Event::DestroyPipeline {
        handle: taken_back,
        allocator: true,
    }] = events.as_slice()
    else {
        panic!("the variant not compiled, the app's pipeline created then destroyed: {events:#?}");
    };
    assert_eq!(temporary, destroyed);
    assert!(variant_infos[0]
        .flags
        .contains(vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED));
    let (_, app_pipeline) = only_app_creation(std::slice::from_ref(app_creation));
    assert_eq!(
        *taken_back, app_pipeline,
        "with the application's allocator"
    );
    assert!(fx.state.objects.pipelines.get(&app_pipeline).is_none());

    // The application compiles it (without the flag): both are made.
    app.flags = vk::PipelineCreateFlags::empty();
    let built = app.build();
    fx.create_with_variant(&built.info(), None);
    fx.finish();
}

#[test]
fn with_early_return_the_pipelines_after_one_taken_back_are_taken_back_too() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let plain = fx.module(&fragment(PLAIN));
    let cache_only = vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED;
    let mut first = AppPipeline::of_modules(vertex, module);
    let mut second = AppPipeline::of_modules(vertex, module);
    let mut third = AppPipeline::of_modules(vertex, plain);
    second.flags = cache_only;
    third.flags = cache_only;
    /// Where the first create info asks for early return.
    #[derive(PartialEq)]
    enum EarlyReturn {
        No,
        InFlags,
        InFlags2,
    }
    let early_flags2 = vk::PipelineCreateFlags2CreateInfoKHR::default().flags(
        vk::PipelineCreateFlags2KHR::FAIL_ON_PIPELINE_COMPILE_REQUIRED
            | vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE,
    );
    for early_return in [EarlyReturn::No, EarlyReturn::InFlags, EarlyReturn::InFlags2] {
        first.flags = match early_return {
            EarlyReturn::InFlags => cache_only | vk::PipelineCreateFlags::EARLY_RETURN_ON_FAILURE,
            // Replaced by the flags2 in the chain.
            EarlyReturn::InFlags2 => vk::PipelineCreateFlags::empty(),
            EarlyReturn::No => cache_only,
        };
        let mut built = [first.build(), second.build(), third.build()];
        if early_return == EarlyReturn::InFlags2 {
            built[0].rendering.p_next =
                (&early_flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast();
        }
        let infos = built.each_ref().map(|built| built.info());
        // The first's variant is not in the cache, the second's is.
        fake_chain::script_pipeline_creations(
            fx.tables.device,
            [compile_required(), PipelineOutcome::success()],
        );
        let (result, handles) = fx.create_pipelines(&infos, None);
        assert_eq!(result, vk::Result::PIPELINE_COMPILE_REQUIRED);
        let events = fx.events();
        let destroyed = |handle| Event::DestroyPipeline {
            handle,
            allocator: false,
        };
        if early_return == EarlyReturn::No {
            let [_, _, _, _, second_variant, _, app_creation, taken_back @ ..] = events.as_slice()
            else {
                panic!("two variants with their modules, the batch, one taken back: {events:#?}");
            };
            let (_, [second_variant]) = created_pipelines(second_variant) else {
                panic!("one variant: {events:#?}");
            };
            let (_, app_pipelines) = created_pipelines(app_creation);
            assert_eq!(
                handles,
                [vk::Pipeline::null(), app_pipelines[1], app_pipelines[2]]
            );
            assert_eq!(taken_back, [destroyed(app_pipelines[0])]);
            assert_eq!(
                fx.recorded(app_pipelines[1]).reversed_variant,
                Some(*second_variant)
            );
        } else {
            // No variant made after the first: the batch ends there.
            let [_, _, _, app_creation, taken_back @ ..] = events.as_slice() else {
                panic!(
                    "the first's variant and module, the batch, what is taken back: {events:#?}"
                );
            };
            let (_, app_pipelines) = created_pipelines(app_creation);
            assert_eq!(handles, [vk::Pipeline::null(); 3]);
            assert_eq!(
                taken_back,
                app_pipelines
                    .iter()
                    .map(|&p| destroyed(p))
                    .collect::<Vec<_>>(),
                "every pipeline from the first on"
            );
        }
    }
    fx.finish();
}

#[test]
fn an_error_of_the_batch_is_kept_when_a_pipeline_is_taken_back() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let plain = fx.module(&fragment(PLAIN));
    let mut first = AppPipeline::of_modules(vertex, module);
    first.flags = vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED;
    let second = AppPipeline::of_modules(vertex, plain);
    let built = [first.build(), second.build()];
    let infos = built.each_ref().map(|built| built.info());
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [
            compile_required(),
            PipelineOutcome {
                result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
                created: vec![true, false],
            },
        ],
    );
    let (result, handles) = fx.create_pipelines(&infos, None);
    assert_eq!(result, vk::Result::ERROR_OUT_OF_DEVICE_MEMORY);
    assert_eq!(handles, [vk::Pipeline::null(); 2]);
    let events = fx.events();
    let [_, _, _, app_creation, Event::DestroyPipeline {
        handle: taken_back, ..
    }] = events.as_slice()
    else {
        panic!("the variant not compiled, the failed batch, the first taken back: {events:#?}");
    };
    let Event::CreateGraphicsPipelines { handles: app, .. } = app_creation else {
        panic!("the batch: {events:#?}");
    };
    assert_eq!(*taken_back, app[0]);
    fx.finish();
}

#[test]
fn a_variant_link_splices_its_libraries_and_flags2_wherever_they_are_in_the_chain() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let libraries = Libraries::of(&built);
    let created = fx.create_with_variant(&libraries.fragment_info(), None);
    let linked = [created.app];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    let app_flags2 = vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE
        | vk::PipelineCreateFlags2KHR::DISABLE_OPTIMIZATION;
    let flags2 = vk::PipelineCreateFlags2CreateInfoKHR {
        p_next: (&links as *const vk::PipelineLibraryCreateInfoKHR<'_>).cast(),
        flags: app_flags2,
        ..Default::default()
    };
    let rendering = vk::PipelineRenderingCreateInfo {
        p_next: (&flags2 as *const vk::PipelineCreateFlags2CreateInfoKHR<'_>).cast(),
        ..built.rendering
    };
    let info = vk::GraphicsPipelineCreateInfo {
        p_next: (&rendering as *const vk::PipelineRenderingCreateInfo<'_>).cast(),
        ..link_info(&links)
    };
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    let (variant_info, variant, app_info, app_link) = variant_link_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    let chain = [rendering.s_type, flags2.s_type, links.s_type];
    assert_eq!(variant_info.chain, chain);
    assert_eq!(variant_info.libraries, [created.variant]);
    assert_eq!(
        variant_info.flags2,
        Some(vk::PipelineCreateFlags2KHR::DISABLE_OPTIMIZATION)
    );
    assert_eq!(app_info, seen(&info), "the application's link as it was");
    assert_eq!(fx.recorded(app_link).reversed_variant, Some(variant));
    fx.finish();
}

#[test]
fn a_link_of_a_library_given_by_module_identifiers_gets_no_variant() {
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let module = fx.module(&fragment(FRAG_DEPTH));
    let identifier_bytes = [7u8; 16];
    let identifier = vk::PipelineShaderStageModuleIdentifierCreateInfoEXT::default()
        .identifier(&identifier_bytes);
    let mut app = AppPipeline::of_modules(vertex, module);
    app.stages[0] = vk::PipelineShaderStageCreateInfo {
        p_next: (&identifier as *const vk::PipelineShaderStageModuleIdentifierCreateInfoEXT<'_>)
            .cast(),
        ..stage(vk::ShaderStageFlags::VERTEX, vk::ShaderModule::null())
    };
    // Identifiers need the cache-only flag, and so does what links them (VUID 06855).
    app.flags = vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED;
    let built = app.build();
    let libraries = Libraries::of(&built);
    let (_, pre) = fx.create_pipelines(&[libraries.pre_rasterization_info()], None);
    let (_, pre_handle) = only_app_creation(&fx.events());
    assert_eq!(pre, [pre_handle]);
    assert!(fx.recorded(pre_handle).module_identifiers);
    // The fragment shader library is of SPIR-V: it gets its variant library (from the cache
    // too, where the fake finds it).
    let created = fx.create_with_variant(&libraries.fragment_info(), None);

    let linked = [pre_handle, created.app];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    let info = vk::GraphicsPipelineCreateInfo {
        flags: vk::PipelineCreateFlags::FAIL_ON_PIPELINE_COMPILE_REQUIRED,
        ..link_info(&links)
    };
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(result, vk::Result::SUCCESS);
    // A variant link would have to come from the cache too, where it is never found: none,
    // and the link's draws into reversed attachments are known to keep standard depth.
    let (app_info, app_link) = only_app_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    assert_eq!(app_info.libraries, linked);
    let recorded = fx.recorded(app_link);
    assert_eq!(recorded.reversed_variant, None);
    assert!(recorded.unreversed_fragment);
    assert!(recorded.module_identifiers);
    fx.finish();
}

/// A pipeline made from pipeline binaries (`VK_KHR_pipeline_binary`) takes its shaders and
/// compiled state from them: a variant from the same create info would change nothing, so
/// none is made, and a fragment shader computing with depth is known to keep standard depth.
#[test]
fn a_pipeline_made_from_pipeline_binaries_gets_no_variant() {
    let fx = Fixture::with_settings(&[(c"mode", c"flip"), (c"compare_op", c"variants")]);
    let vertex = fx.vertex_module();
    let binaries = [0xB1u64, 0xB2];
    let binary_info = crate::ffi::PipelineBinaryInfo {
        s_type: crate::ffi::STRUCTURE_TYPE_PIPELINE_BINARY_INFO_KHR,
        p_next: std::ptr::null(),
        binary_count: binaries.len() as u32,
        p_pipeline_binaries: binaries.as_ptr(),
    };
    for source in [PLAIN, FRAG_DEPTH] {
        let module = fx.module(&fragment(source));
        let app = AppPipeline::of_modules(vertex, module);
        let built = app.build();
        // In front of the application's chain (its rendering info).
        let info = built.info();
        let binary_info = crate::ffi::PipelineBinaryInfo {
            p_next: info.p_next,
            ..binary_info
        };
        let info = vk::GraphicsPipelineCreateInfo {
            p_next: (&binary_info as *const crate::ffi::PipelineBinaryInfo).cast(),
            ..info
        };
        let (result, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
        assert_eq!(result, vk::Result::SUCCESS);
        let (_, app_handle) = only_app_creation(&fx.events());
        assert_eq!(handles, [app_handle]);
        let recorded = fx.recorded(app_handle);
        assert_eq!(recorded.reversed_variant, None);
        // Nothing is known of the code a binary holds: marked, as for module identifiers.
        assert!(recorded.unreversed_fragment, "{source}");
    }
    // Without binaries (binaryCount 0 is the same as no structure) the variant is made.
    let empty = crate::ffi::PipelineBinaryInfo {
        binary_count: 0,
        ..binary_info
    };
    let module = fx.module(&fragment(PLAIN));
    let app = AppPipeline::of_modules(vertex, module);
    let built = app.build();
    let info = built.info();
    let empty = crate::ffi::PipelineBinaryInfo {
        p_next: info.p_next,
        ..empty
    };
    let info = vk::GraphicsPipelineCreateInfo {
        p_next: (&empty as *const crate::ffi::PipelineBinaryInfo).cast(),
        ..info
    };
    let (_, handles) = fx.create_pipelines(std::slice::from_ref(&info), None);
    assert_eq!(
        fx.events().len(),
        2,
        "the variant, then the application's pipeline"
    );
    assert!(fx.recorded(handles[0]).reversed_variant.is_some());
    fx.finish();
}

/// Creates `app` for subpass `subpass` of `pass`, which must succeed: the events it caused.
fn created_in_subpass(
    fx: &Fixture,
    app: &mut AppPipeline,
    pass: vk::RenderPass,
    subpass: u32,
) -> Vec<Event> {
    app.subpass = Some((pass, subpass));
    let built = app.build();
    let (result, _) = fx.create_pipelines(std::slice::from_ref(&built.info()), None);
    assert_eq!(result, vk::Result::SUCCESS);
    fx.events()
}

/// The variants (code, handle) created before the application's pipeline, which comes last.
fn variants_then_app(events: &[Event]) -> (Vec<(Vec<u32>, vk::Pipeline)>, vk::Pipeline) {
    let (app, variants) = events.split_last().expect("events");
    let Event::CreateGraphicsPipelines { handles, .. } = app else {
        panic!("the application's pipeline last: {events:#?}");
    };
    let made = variants
        .chunks(3)
        .map(|chunk| match chunk {
            [Event::CreateShaderModule { handle, code, .. }, Event::CreateGraphicsPipelines {
                infos,
                handles,
                ..
            }, Event::DestroyShaderModule {
                handle: destroyed, ..
            }] => {
                assert_eq!(handle, destroyed);
                // The fragment stage is the last (of a pipeline, or alone in a library).
                let fragment = infos[0].stages.last().expect("stages").module;
                assert_eq!(fragment, *handle, "the variant's fragment stage");
                (code.clone(), handles[0])
            }
            _ => panic!("a module, a variant, the module destroyed: {events:#?}"),
        })
        .collect();
    (made, handles[0])
}

/// A deferred render pass (`Fixture::deferred_render_pass`) and a fragment module reading its
/// depth as input attachment 0, with that module's code as revz converts it.
struct DeferredInputs {
    vertex: vk::ShaderModule,
    module: vk::ShaderModule,
    pass: vk::RenderPass,
    converted: Vec<u32>,
}

impl DeferredInputs {
    fn of(fx: &Fixture) -> DeferredInputs {
        let words = test_spirv::depth_input_fragment();
        let converted =
            crate::shader::input_depth::reverse_input_depth(&words, &DepthInputs::Indices(vec![0]))
                .unwrap()
                .unwrap();
        DeferredInputs {
            vertex: fx.vertex_module(),
            module: fx.module(&words),
            pass: fx.deferred_render_pass(),
            converted,
        }
    }
}

#[test]
fn depth_read_through_an_input_attachment_gets_variants_that_convert_it() {
    let fx = Fixture::new();
    let DeferredInputs {
        vertex,
        module,
        pass,
        converted,
    } = DeferredInputs::of(&fx);
    validate(&converted);
    let mut app = AppPipeline::of_modules(vertex, module);

    // Subpass 1 reads depth as an input and has no depth attachment: an input variant only.
    let (variants, handle) = variants_then_app(&created_in_subpass(&fx, &mut app, pass, 1));
    let [(code, input)] = variants.as_slice() else {
        panic!("one variant: {variants:?}");
    };
    assert_eq!(*code, converted);
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.input_variant, Some(*input));
    assert_eq!(recorded.reversed_variant, None);
    assert_eq!(recorded.variant_for(false, false, true), Some(*input));
    assert_eq!(recorded.variant_for(false, false, false), None);
    assert!(!recorded.unreversed_fragment);

    // Subpass 2 has the depth attached too: the reversed variant converts the reads as well.
    let (variants, handle) = variants_then_app(&created_in_subpass(&fx, &mut app, pass, 2));
    let [(reversed_code, reversed), (input_code, input)] = variants.as_slice() else {
        panic!("two variants: {variants:?}");
    };
    assert_eq!((reversed_code, input_code), (&converted, &converted));
    let recorded = fx.recorded(handle);
    assert_eq!(recorded.reversed_variant, Some(*reversed));
    assert_eq!(recorded.input_variant, Some(*input));
    assert_eq!(recorded.variant_for(true, false, true), Some(*reversed));
    assert_eq!(recorded.variant_for(false, false, true), Some(*input));

    // Subpass 0 reads no input: nothing to convert (its depth is dynamic state in flip mode).
    let (_, handle) = only_app_creation(&created_in_subpass(&fx, &mut app, pass, 0));
    assert_eq!(fx.recorded(handle).input_variant, None);
    fx.finish();
}

#[test]
fn a_fragment_shader_library_reading_depth_inputs_gets_an_input_variant_its_links_link() {
    let fx = Fixture::new();
    let DeferredInputs {
        vertex,
        module,
        pass,
        converted,
    } = DeferredInputs::of(&fx);
    let mut app = AppPipeline::of_modules(vertex, module);
    // Subpass 1 reads depth as an input and has no depth attachment.
    app.subpass = Some((pass, 1));
    let built = app.build();
    let libraries = Libraries::of(&built);

    let (_, pre) = fx.create_pipelines(&[libraries.pre_rasterization_info()], None);
    let (_, pre_handle) = only_app_creation(&fx.events());
    assert_eq!(pre, [pre_handle]);

    // The fragment shader library: an input variant library with the reads converted.
    let (result, handles) = fx.create_pipelines(&[libraries.fragment_info()], None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (variants, fragment) = variants_then_app(&fx.events());
    assert_eq!(handles, [fragment]);
    let [(code, input_library)] = variants.as_slice() else {
        panic!("one variant: {variants:?}");
    };
    assert_eq!(*code, converted);
    assert_eq!(fx.recorded(fragment).input_variant, Some(*input_library));

    // Its link, with and without the render pass and subpass (which a link of a fragment
    // shader reading input attachments must name: VUID-VkGraphicsPipelineCreateInfo-
    // renderPass-06061): an input variant linking the library's input variant, the rest as
    // they are, and no reversed variant (no library has one).
    let linked = [pre_handle, fragment];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    let named = vk::GraphicsPipelineCreateInfo {
        render_pass: pass,
        subpass: 1,
        ..link_info(&links)
    };
    for link in [named, link_info(&links)] {
        check_input_link(&fx, &link, &linked, *input_library);
    }
    fx.finish();
}

fn check_input_link(
    fx: &Fixture,
    link: &vk::GraphicsPipelineCreateInfo<'_>,
    linked: &[vk::Pipeline],
    input_library: vk::Pipeline,
) {
    let (pre_handle, fragment) = (linked[0], linked[1]);
    assert_ne!(fragment, input_library);
    let (result, handles) = fx.create_pipelines(std::slice::from_ref(link), None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (variant_info, variant, app_info, app_link) = variant_link_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    assert_eq!(variant_info.libraries, [pre_handle, input_library]);
    assert_eq!(
        app_info.libraries, linked,
        "the application's link is its own"
    );
    let recorded = fx.recorded(app_link);
    assert_eq!(recorded.input_variant, Some(variant));
    assert_eq!(recorded.reversed_variant, None);
    assert_eq!(recorded.variant_for(false, false, true), Some(variant));
    assert_eq!(recorded.variant_for(false, false, false), None);
}

/// Creates `app` with dynamic rendering, its rendering info chaining `mapping` where given;
/// it must succeed: the events it caused.
fn created_rendering(
    fx: &Fixture,
    app: &AppPipeline,
    mapping: Option<&vk::RenderingInputAttachmentIndexInfoKHR<'_>>,
) -> Vec<Event> {
    let mut built = app.build();
    if let Some(mapping) = mapping {
        built.rendering.p_next =
            (mapping as *const vk::RenderingInputAttachmentIndexInfoKHR<'_>).cast();
    }
    let (result, _) = fx.create_pipelines(std::slice::from_ref(&built.info()), None);
    assert_eq!(result, vk::Result::SUCCESS);
    fx.events()
}

#[test]
fn dynamic_renderings_local_reads_of_depth_are_converted_in_the_reversed_variant() {
    // VK_KHR_dynamic_rendering_local_read: input attachments read the rendering's own
    // attachments; the depth attachment maps to undecorated inputs by default, or to the
    // index the pipeline's VkRenderingInputAttachmentIndexInfo gives.
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let undecorated_words = test_spirv::undecorated_depth_input_fragment();
    validate(&undecorated_words);
    let undecorated = fx.module(&undecorated_words);
    let decorated_words = test_spirv::depth_input_fragment();
    let decorated = fx.module(&decorated_words);
    let converted = |words: &[u32], inputs: DepthInputs| {
        crate::shader::input_depth::reverse_input_depth(words, &inputs)
            .unwrap()
            .unwrap()
    };
    let only_reversed = |events: &[Event], code: &[u32]| {
        let (variants, handle) = variants_then_app(events);
        let [(variant_code, reversed)] = variants.as_slice() else {
            panic!("one variant: {variants:?}");
        };
        assert_eq!(variant_code, code);
        let recorded = fx.recorded(handle);
        assert_eq!(recorded.reversed_variant, Some(*reversed));
        // The reads are of the depth attachment: reversed exactly where it is.
        assert_eq!(recorded.input_variant, None);
        assert_eq!(recorded.variant_for(true, false, false), Some(*reversed));
        assert_eq!(recorded.variant_for(false, false, false), None);
    };

    // The default mapping: the undecorated input reads depth.
    let app = AppPipeline::of_modules(vertex, undecorated);
    let expected = converted(&undecorated_words, DepthInputs::Undecorated);
    validate(&expected);
    only_reversed(&created_rendering(&fx, &app, None), &expected);
    // The same, the mapping given with a null depth index.
    let colors = [vk::ATTACHMENT_UNUSED];
    let default_depth =
        vk::RenderingInputAttachmentIndexInfoKHR::default().color_attachment_input_indices(&colors);
    only_reversed(
        &created_rendering(&fx, &app, Some(&default_depth)),
        &expected,
    );

    // Depth mapped to index 0: the decorated input reads it.
    let depth_index = 0;
    let indexed = vk::RenderingInputAttachmentIndexInfoKHR {
        p_depth_input_attachment_index: &depth_index,
        ..default_depth
    };
    let app = AppPipeline::of_modules(vertex, decorated);
    let expected = converted(&decorated_words, DepthInputs::Indices(vec![0]));
    only_reversed(&created_rendering(&fx, &app, Some(&indexed)), &expected);
    // Without the mapping, index 0 is the color attachment: nothing to convert (the depth
    // test is dynamic state in flip mode).
    let (_, handle) = only_app_creation(&created_rendering(&fx, &app, None));
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    // Depth mapped to no input.
    let unused = vk::ATTACHMENT_UNUSED;
    let unmapped = vk::RenderingInputAttachmentIndexInfoKHR {
        p_depth_input_attachment_index: &unused,
        ..default_depth
    };
    let app = AppPipeline::of_modules(vertex, undecorated);
    let (_, handle) = only_app_creation(&created_rendering(&fx, &app, Some(&unmapped)));
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    // No depth attachment: nothing reversed to read, no variant.
    let mut app = AppPipeline::of_modules(vertex, undecorated);
    app.depth_format = vk::Format::UNDEFINED;
    let (_, handle) = only_app_creation(&created_rendering(&fx, &app, None));
    assert_eq!(fx.recorded(handle).reversed_variant, None);
    // A fragment shader library, which names no depth format (only a fragment output library
    // does): its reversed variant converts the reads, as a whole pipeline's does.
    let built = app.build();
    let libraries = Libraries::of(&built);
    let (_, _) = fx.create_pipelines(&[libraries.fragment_info()], None);
    let (variants, library) = variants_then_app(&fx.events());
    let [(code, reversed)] = variants.as_slice() else {
        panic!("one variant: {variants:?}");
    };
    assert_eq!(
        *code,
        converted(&undecorated_words, DepthInputs::Undecorated)
    );
    assert_eq!(fx.recorded(library).reversed_variant, Some(*reversed));
    fx.finish();
}

#[test]
fn a_link_of_a_library_reading_depth_locally_links_its_converting_variant() {
    // Dynamic rendering: the fragment shader library reads depth through the default
    // mapping, with the depth test off (a lighting pass over the depth it reads): its
    // reversed variant converts the reads, and the link's reversed variant links it.
    let fx = Fixture::new();
    let vertex = fx.vertex_module();
    let words = test_spirv::undecorated_depth_input_fragment();
    let module = fx.module(&words);
    let mut app = AppPipeline::of_modules(vertex, module);
    app.depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default();
    let built = app.build();
    let libraries = Libraries::of(&built);
    let (_, pre) = fx.create_pipelines(&[libraries.pre_rasterization_info()], None);
    fx.events();
    let (_, fragment) = fx.create_pipelines(&[libraries.fragment_info()], None);
    let (variants, library) = variants_then_app(&fx.events());
    assert_eq!(fragment, [library]);
    let [(code, reversed_library)] = variants.as_slice() else {
        panic!("one variant: {variants:?}");
    };
    let converted =
        crate::shader::input_depth::reverse_input_depth(&words, &DepthInputs::Undecorated)
            .unwrap()
            .unwrap();
    assert_eq!(*code, converted);
    let linked = [pre[0], library];
    let links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&linked);
    let (result, handles) = fx.create_pipelines(&[link_info(&links)], None);
    assert_eq!(result, vk::Result::SUCCESS);
    let (variant_info, variant, _, app_link) = variant_link_creation(&fx.events());
    assert_eq!(handles, [app_link]);
    assert_eq!(variant_info.libraries, [pre[0], *reversed_library]);
    let recorded = fx.recorded(app_link);
    assert_eq!(recorded.reversed_variant, Some(variant));
    assert_eq!(recorded.input_variant, None);
    fx.finish();
}

#[test]
fn input_reads_are_converted_in_infinite_mode_too() {
    // Infinite mode stores complementary depth in images read as input attachments: their
    // reads convert as in the other modes.
    let fx = Fixture::with_settings(&[(c"mode", c"infinite")]);
    let DeferredInputs {
        vertex,
        module,
        pass,
        converted,
    } = DeferredInputs::of(&fx);
    assert!(fx.state.objects.input_modules.get(&module).is_some());
    let mut app = AppPipeline::of_modules(vertex, module);
    let (variants, handle) = variants_then_app(&created_in_subpass(&fx, &mut app, pass, 1));
    let [(code, input)] = variants.as_slice() else {
        panic!("one variant: {variants:?}");
    };
    assert_eq!(*code, converted);
    assert_eq!(fx.recorded(handle).input_variant, Some(*input));
    fx.finish();
}

#[test]
fn modules_of_code_seen_before_are_analyzed_once_and_get_the_same_rewrites() {
    // An application creating a module per pipeline from the same code: the analysis and
    // the rewrites are made at the first module and looked up for the others, even after
    // the first one is destroyed.
    let fx = Fixture::with_settings(&[(c"mode", c"complementary")]);
    let projected = test_spirv::compile_glsl(
        naga::ShaderStage::Vertex,
        "#version 450
        layout(push_constant) uniform PushConstants { mat4 mvp; } pc;
        layout(location = 0) in vec3 position;
        void main() { gl_Position = pc.mvp * vec4(position, 1.0); }",
    );
    let objects = &fx.state.objects;
    let first = fx.module(&projected);
    let rewrite_of = |module| match objects.position_stores.get(&module) {
        Some(Ok(rewrite)) => rewrite.code,
        other => panic!("no Position rewrite: {other:?}"),
    };
    let first_code = rewrite_of(first);
    let first_analysis = objects.vertex_modules.get(&first).expect("analyzed");
    let second = fx.module(&projected);
    assert_ne!(first, second);
    assert!(
        Arc::ptr_eq(&rewrite_of(second), &first_code),
        "the same rewrite"
    );
    assert!(Arc::ptr_eq(
        &objects.vertex_modules.get(&second).expect("analyzed"),
        &first_analysis
    ));
    // SAFETY: a live device and a module it created.
    unsafe { (fx.hooks.destroy_shader_module)(fx.device, first, std::ptr::null()) };
    fx.events();
    fx.modules.borrow_mut().retain(|&m| m != first);
    assert!(objects.position_stores.get(&first).is_none());
    let third = fx.module(&projected);
    assert!(Arc::ptr_eq(&rewrite_of(third), &first_code));
    assert_eq!(objects.vertex_codes.len(), 1, "one code analyzed");
    // Other code is analyzed for itself.
    fx.vertex_module();
    assert_eq!(objects.vertex_codes.len(), 2);
    fx.finish();
}

/// A vertex module projecting with a pushed matrix in a push-constant block of 128 bytes (no
/// room for revz's carrier on a 128-byte device), and a plain fragment module: the vertex
/// code and both modules.
fn full_push_modules(fx: &Fixture) -> (Vec<u32>, vk::ShaderModule, vk::ShaderModule) {
    let words = test_spirv::compile_glsl(
        naga::ShaderStage::Vertex,
        "#version 450
        layout(push_constant) uniform PushConstants { mat4 mvp; vec4 tint[4]; } pc;
        layout(location = 0) in vec3 position;
        void main() { gl_Position = pc.mvp * vec4(position, 1.0); }",
    );
    let vertex = fx.module(&words);
    let fragment_module = fx.module(&fragment(PLAIN));
    (words, vertex, fragment_module)
}

#[test]
fn a_layout_without_room_for_the_carrier_gets_the_stage_with_the_carrier_baked_into_its_variant() {
    // revz never saw the tests' layout created, so it holds no carrier for it: the case of a
    // layout whose push constants leave no room (`NoRoom::Used`), as for a vertex stage
    // whose push-constant block fills 128 bytes.
    let fx = Fixture::with_settings(&[(c"mode", c"infinite")]);
    let (words, vertex, fragment_module) = full_push_modules(&fx);
    let app = AppPipeline::of_modules(vertex, fragment_module);
    let built = app.build();
    let made = fx.create_with_variant(&built.info(), None);
    // The variant's vertex stage is the temporary module: the deriving rewrite with the
    // carrier baked in (complementary depth); the application's pipeline keeps its module.
    assert_eq!(made.code, test_spirv::baked(&words));
    assert_eq!(made.variant_info.stages[0].module, made.temporary);
    assert_eq!(made.app_info.stages[0].module, vertex);
    assert_eq!(made.variant_info.stages[1].module, fragment_module);
    // The compare op stays dynamic in both: the flip-path draws bind the application's
    // pipeline and flip it there.
    assert_eq!(made.variant_info.dynamic_states, EXTENDED);
    assert_eq!(made.app_info.dynamic_states, EXTENDED);
    let recorded = fx.recorded(made.app);
    assert!(recorded.baked);
    assert_eq!(recorded.position_store, None, "nothing pushed");
    assert_eq!(recorded.projection, None);
    assert_eq!(recorded.derived_range, Some(MatrixSource::PushConstants));

    // A dynamic clip convention cannot take a baked selector: the flip path, no variant.
    let mut dynamic_clip = AppPipeline::of_modules(vertex, fragment_module);
    dynamic_clip
        .dynamic_states
        .push(vk::DynamicState::DEPTH_CLIP_NEGATIVE_ONE_TO_ONE_EXT);
    let built = dynamic_clip.build();
    let (result, handles) = fx.create_pipelines(&[built.info()], None);
    assert_eq!(result, vk::Result::SUCCESS);
    only_app_creation(&fx.events());
    let recorded = fx.recorded(handles[0]);
    assert!(!recorded.baked);
    assert_eq!(recorded.reversed_variant, None);
    assert_eq!(recorded.derived_range, None);
    // The code was rewritten once for both pipelines.
    assert_eq!(fx.state.objects.baked_codes.len(), 1);
    fx.finish();
}

#[test]
fn a_baked_pipeline_whose_variant_fails_keeps_no_variant_with_the_baked_stage() {
    // A layout without room, a promotable format: the reversed (baked) and promoted variants
    // are made, the promoted reversed one fails. The pipeline takes the flip path, and the
    // baked variant must not stay to be bound for its flip-path draws (found in review).
    let fx = Fixture::with_settings(&[(c"mode", c"complementary")]);
    let (_, vertex, fragment_module) = full_push_modules(&fx);
    let mut app = AppPipeline::of_modules(vertex, fragment_module);
    app.depth_format = vk::Format::D24_UNORM_S8_UINT;
    let built = app.build();
    fake_chain::script_pipeline_creations(
        fx.tables.device,
        [
            PipelineOutcome::success(),
            PipelineOutcome::success(),
            PipelineOutcome::failure(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY),
        ],
    );
    let (result, handles) = fx.create_pipelines(&[built.info()], None);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    let made: Vec<vk::Pipeline> = events
        .iter()
        .filter_map(|e| match e {
            Event::CreateGraphicsPipelines {
                result: vk::Result::SUCCESS,
                handles: made,
                ..
            } => Some(made[0]),
            _ => None,
        })
        .collect();
    assert_eq!(
        made.len(),
        3,
        "two variants and the application's: {events:#?}"
    );
    let (baked, promoted) = (made[0], made[1]);
    assert!(
        events.contains(&Event::DestroyPipeline {
            handle: baked,
            allocator: false,
        }),
        "the baked variant is destroyed: {events:#?}"
    );
    let recorded = fx.recorded(handles[0]);
    assert!(recorded.promotable);
    assert!(!recorded.baked);
    assert_eq!(recorded.derived_range, None);
    assert_eq!(recorded.reversed_variant, None);
    assert_eq!(recorded.promoted_reversed_variant, None);
    assert_eq!(recorded.promoted_variant, Some(promoted));
    // A draw into a reversed attachment binds the application's pipeline.
    let mut state = crate::command_state::CommandState::new(crate::command_state::Reversing {
        rewrite: Some(revz_math::Target::Complementary),
        reversal: crate::conv::Reversal::Complementary,
    });
    state.begin(
        crate::command_state::Target::Reversed,
        crate::conv::Reversal::Complementary,
        Default::default(),
    );
    state.bind_pipeline(Some(recorded));
    assert_eq!(state.pipeline_to_bind(handles[0]), handles[0]);
    fx.finish();
}
