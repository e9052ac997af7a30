//! Shader objects (`VK_EXT_shader_object`) driven through revz's hooks over the fake layer
//! (`fake_chain`): a fragment shader object that computes with depth gets a variant of its
//! rewritten code, created before the application's shaders; plain, linked, binary and refused
//! ones get none; failures never reach the application; draws into reversed attachments bind
//! the variant (once), native ones the application's shader back; the variant goes with its
//! shader, or with the device.
//!
//! Lavapipe 22.3 has no `VK_EXT_shader_object`: these tests are the only check of this path.

use std::cell::RefCell;
use std::ffi::CStr;
use std::sync::Arc;

use ash::vk::{self, Handle};

use super::fake_chain::{self, hook_set, Event, SeenShader, Tables};
use crate::objects::{FragmentShader, PositionShader};
use crate::shader::fragment_depth::reverse_fragment_depth;
use crate::shader::test_spirv::{fragment, refused_fragment, validate, vertex, FRAG_DEPTH, PLAIN};
use crate::state::{DeviceState, DispatchKey, DEVICES};

const D32: vk::Format = vk::Format::D32_SFLOAT;
const LAYOUT: vk::ImageLayout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
const MAIN: &CStr = c"main";
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};

fn bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_ne_bytes()).collect()
}

hook_set! {
    struct Hooks {
        create_shaders: c"vkCreateShadersEXT" => vk::PFN_vkCreateShadersEXT,
        destroy_shader: c"vkDestroyShaderEXT" => vk::PFN_vkDestroyShaderEXT,
        cmd_bind_shaders: c"vkCmdBindShadersEXT" => vk::PFN_vkCmdBindShadersEXT,
        create_image: c"vkCreateImage" => vk::PFN_vkCreateImage,
        create_image_view: c"vkCreateImageView" => vk::PFN_vkCreateImageView,
        allocate_command_buffers: c"vkAllocateCommandBuffers" => vk::PFN_vkAllocateCommandBuffers,
        free_command_buffers: c"vkFreeCommandBuffers" => vk::PFN_vkFreeCommandBuffers,
        begin_command_buffer: c"vkBeginCommandBuffer" => vk::PFN_vkBeginCommandBuffer,
        cmd_begin_rendering: c"vkCmdBeginRendering" => vk::PFN_vkCmdBeginRendering,
        cmd_end_rendering: c"vkCmdEndRendering" => vk::PFN_vkCmdEndRendering,
        cmd_draw: c"vkCmdDraw" => vk::PFN_vkCmdDraw,
        create_pipeline_layout: c"vkCreatePipelineLayout" => vk::PFN_vkCreatePipelineLayout,
        cmd_push_constants: c"vkCmdPushConstants" => vk::PFN_vkCmdPushConstants,
        cmd_set_depth_clamp_enable: c"vkCmdSetDepthClampEnableEXT" => vk::PFN_vkCmdSetDepthClampEnableEXT,
        cmd_set_depth_clip_enable: c"vkCmdSetDepthClipEnableEXT" => vk::PFN_vkCmdSetDepthClipEnableEXT,
    }
}

/// One instance and device over the fake layer (flip mode, observable images native), and the
/// shader objects a test creates (destroyed through the hooks by [`Fixture::finish`]).
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    state: Arc<DeviceState>,
    hooks: Hooks,
    shaders: RefCell<Vec<vk::ShaderEXT>>,
}

impl Fixture {
    fn new() -> Fixture {
        Fixture::with_settings(&[(c"mode", c"flip"), (c"reverse_observable", c"none")])
    }

    fn with_settings(settings: &[(&'static CStr, &'static CStr)]) -> Fixture {
        Fixture::with_features(settings, vk::PhysicalDeviceFeatures::default())
    }

    /// A fixture whose device the application created with the core `features`.
    fn with_features(
        settings: &[(&'static CStr, &'static CStr)],
        features: vk::PhysicalDeviceFeatures,
    ) -> Fixture {
        let tables = Tables::fresh();
        let (instance, _) = fake_chain::create_instance(settings);
        let (physical, device, _) = fake_chain::create_device_with(
            tables,
            fake_chain::fake_get_device_proc_addr_with_shader_objects,
            &[],
            features,
        );
        // SAFETY: the fake's live device.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device) })
            .expect("the device is registered");
        let hooks = Hooks::of(device);
        fake_chain::take_events(tables.instance);
        assert_eq!(fake_chain::take_events(tables.device), []);
        Fixture {
            tables,
            instance,
            physical,
            device,
            state,
            hooks,
            shaders: RefCell::default(),
        }
    }

    fn events(&self) -> Vec<Event> {
        fake_chain::take_events(self.tables.device)
    }

    /// The `vkCmdBindShadersEXT` calls that reached the fake since the last look.
    fn shader_binds(&self) -> Vec<Event> {
        self.events()
            .into_iter()
            .filter(|e| matches!(e, Event::BindShaders { .. }))
            .collect()
    }

    /// What revz recorded of a shader object.
    fn recorded(&self, shader: vk::ShaderEXT) -> Option<FragmentShader> {
        self.state.objects.fragment_shaders.get(&shader)
    }

    /// Creates shader objects through revz with an allocator; returns the call's result and
    /// the handles it wrote.
    fn create(&self, infos: &[vk::ShaderCreateInfoEXT<'_>]) -> (vk::Result, Vec<vk::ShaderEXT>) {
        let allocator = vk::AllocationCallbacks::default();
        let mut shaders = vec![vk::ShaderEXT::null(); infos.len()];
        // SAFETY: a live device, valid create infos and room for their handles.
        let result = unsafe {
            (self.hooks.create_shaders)(
                self.device,
                infos.len() as u32,
                infos.as_ptr(),
                &allocator,
                shaders.as_mut_ptr(),
            )
        };
        self.shaders
            .borrow_mut()
            .extend(shaders.iter().filter(|s| !s.is_null()));
        (result, shaders)
    }

    /// A depth image (`usage`) and a view of it.
    fn depth_view(&self, usage: vk::ImageUsageFlags) -> vk::ImageView {
        let info = fake_chain::depth_image_info(D32, EXTENT, usage, vk::SampleCountFlags::TYPE_1);
        let mut image = vk::Image::null();
        // SAFETY: a live device and a valid create info.
        let result =
            unsafe { (self.hooks.create_image)(self.device, &info, std::ptr::null(), &mut image) };
        assert_eq!(result, vk::Result::SUCCESS);
        let info = fake_chain::depth_view_info(image, D32);
        let mut view = vk::ImageView::null();
        // SAFETY: as above.
        let result = unsafe {
            (self.hooks.create_image_view)(self.device, &info, std::ptr::null(), &mut view)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        view
    }

    /// A primary command buffer, recording.
    fn command_buffer(&self) -> vk::CommandBuffer {
        let allocate = vk::CommandBufferAllocateInfo::default()
            .command_pool(vk::CommandPool::from_raw(1))
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let mut buffer = vk::CommandBuffer::null();
        // SAFETY: a live device, a valid info and room for one handle; then a command buffer
        // not recording.
        unsafe {
            let result = (self.hooks.allocate_command_buffers)(self.device, &allocate, &mut buffer);
            assert_eq!(result, vk::Result::SUCCESS);
            let begin = vk::CommandBufferBeginInfo::default();
            let result = (self.hooks.begin_command_buffer)(buffer, &begin);
            assert_eq!(result, vk::Result::SUCCESS);
        }
        buffer
    }

    /// Records a rendering instance into `view` of `draws` draws.
    fn render(&self, buffer: vk::CommandBuffer, view: vk::ImageView, draws: usize) {
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(LAYOUT)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE);
        let info = vk::RenderingInfo::default()
            .render_area(EXTENT.into())
            .layer_count(1)
            .depth_attachment(&depth);
        // SAFETY: a recording primary command buffer and a valid rendering info.
        unsafe {
            (self.hooks.cmd_begin_rendering)(buffer, &info);
            for _ in 0..draws {
                (self.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
            }
            (self.hooks.cmd_end_rendering)(buffer);
        }
    }

    fn bind(
        &self,
        buffer: vk::CommandBuffer,
        stages: &[vk::ShaderStageFlags],
        shaders: &[vk::ShaderEXT],
    ) {
        // SAFETY: a recording command buffer, as many stages as shaders.
        unsafe {
            (self.hooks.cmd_bind_shaders)(
                buffer,
                stages.len() as u32,
                stages.as_ptr(),
                shaders.as_ptr(),
            )
        };
    }

    fn free(&self, buffer: vk::CommandBuffer) {
        // SAFETY: the fixture's command buffer, not in use.
        unsafe {
            (self.hooks.free_command_buffers)(self.device, vk::CommandPool::from_raw(1), 1, &buffer)
        };
    }

    /// Destroys the shader objects left through the hooks, checks what reached the fake (each
    /// variant destroyed without an allocator before its shader with the application's), and
    /// that the device's destruction sends down exactly `at_device_destruction` before the
    /// device itself.
    fn finish_with(self, at_device_destruction: &[Event]) {
        let allocator = vk::AllocationCallbacks::default();
        for &shader in self.shaders.borrow().iter() {
            let variant = self
                .recorded(shader)
                .and_then(FragmentShader::variant)
                .or_else(|| {
                    let position = self.state.objects.position_shaders.get(&shader);
                    position.and_then(|p| p.variant())
                });
            // SAFETY: the fixture's shader object, not in use, destroyed once.
            unsafe { (self.hooks.destroy_shader)(self.device, shader, &allocator) };
            let mut expected: Vec<Event> = variant
                .map(|handle| Event::DestroyShader {
                    handle,
                    allocator: false,
                })
                .into_iter()
                .collect();
            expected.push(Event::DestroyShader {
                handle: shader,
                allocator: true,
            });
            assert_eq!(self.events(), expected);
            assert_eq!(self.recorded(shader), None);
            assert_eq!(self.state.objects.position_shaders.get(&shader), None);
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

/// An unlinked shader create info of SPIR-V `code`.
fn shader_info<'a>(
    stage: vk::ShaderStageFlags,
    next_stage: vk::ShaderStageFlags,
    code: &'a [u32],
) -> vk::ShaderCreateInfoEXT<'a> {
    vk::ShaderCreateInfoEXT::default()
        .stage(stage)
        .next_stage(next_stage)
        .code_type(vk::ShaderCodeTypeEXT::SPIRV)
        .code(bytemuck_bytes(code))
        .name(MAIN)
}

fn bytemuck_bytes(words: &[u32]) -> &[u8] {
    // SAFETY: u32s seen as their bytes.
    unsafe { std::slice::from_raw_parts(words.as_ptr().cast(), std::mem::size_of_val(words)) }
}

/// A vertex, tessellation control and tessellation evaluation shader of `code` (in that
/// order) created linked, the evaluation stage followed by the fragment stage.
fn linked_tessellation<'a>(code: [&'a [u32]; 3]) -> Vec<vk::ShaderCreateInfoEXT<'a>> {
    let stages = [
        (VERTEX_STAGE, vk::ShaderStageFlags::TESSELLATION_CONTROL),
        (
            vk::ShaderStageFlags::TESSELLATION_CONTROL,
            vk::ShaderStageFlags::TESSELLATION_EVALUATION,
        ),
        (
            vk::ShaderStageFlags::TESSELLATION_EVALUATION,
            FRAGMENT_STAGE,
        ),
    ];
    stages
        .into_iter()
        .zip(code)
        .map(|((stage, next), code)| link(shader_info(stage, next, code)))
        .collect()
}

/// `info` linked with the other shaders of its call.
fn link(info: vk::ShaderCreateInfoEXT<'_>) -> vk::ShaderCreateInfoEXT<'_> {
    info.flags(vk::ShaderCreateFlagsEXT::LINK_STAGE)
}

const VERTEX_STAGE: vk::ShaderStageFlags = vk::ShaderStageFlags::VERTEX;
const FRAGMENT_STAGE: vk::ShaderStageFlags = vk::ShaderStageFlags::FRAGMENT;

/// The one `vkCreateShadersEXT` of `events` that created `count` shaders (the application's).
fn app_creation(event: &Event) -> (usize, &[SeenShader], bool, &[vk::ShaderEXT]) {
    match event {
        Event::CreateShaders {
            infos_address,
            infos,
            allocator,
            handles,
            ..
        } => (*infos_address, infos, *allocator, handles),
        other => panic!("a vkCreateShadersEXT: {other:?}"),
    }
}

/// Creates `infos` in one call where one of them gets a variant: checks that the call
/// succeeded and that two calls reached the fake, the variant's then the application's;
/// returns the handles and those two events.
fn create_with_one_variant(
    fx: &Fixture,
    infos: &[vk::ShaderCreateInfoEXT<'_>],
) -> (Vec<vk::ShaderEXT>, Vec<Event>) {
    let (result, handles) = fx.create(infos);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    assert_eq!(
        events.len(),
        2,
        "the variant's call, then the application's: {events:#?}"
    );
    (handles, events)
}

/// A vertex and a fragment shader object of `vertex` and `fragment` code created linked in
/// one call where one of them gets a variant: checks that the call succeeded, and that the
/// variant's call and then the application's reached the fake, both unlinked (the
/// application's create infos otherwise as it made them, its `nextStage` the one the link
/// required). Returns the handles, the variant's create infos and handles, and the
/// application's create infos as the fake saw them.
fn create_linked_pair_with_variant(
    fx: &Fixture,
    vertex: &[u32],
    fragment: &[u32],
) -> (
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
) {
    let infos = [
        link(shader_info(VERTEX_STAGE, FRAGMENT_STAGE, vertex)),
        link(shader_info(
            FRAGMENT_STAGE,
            vk::ShaderStageFlags::empty(),
            fragment,
        )),
    ];
    let (handles, events) = create_with_one_variant(fx, &infos);
    let (_, variant_infos, _, variant_handles) = app_creation(&events[0]);
    let (app_address, app_infos, _, app_handles) = app_creation(&events[1]);
    assert_ne!(app_address, infos.as_ptr() as usize, "a copy goes down");
    assert_eq!(app_handles, handles);
    assert_eq!(app_infos.len(), 2);
    for (seen, given) in app_infos.iter().zip(&infos) {
        // SAFETY: a valid create info.
        let given = unsafe { SeenShader::of(given) };
        assert_eq!(seen.flags, vk::ShaderCreateFlagsEXT::empty(), "unlinked");
        assert_eq!(
            (seen.stage, seen.next_stage, &seen.code),
            (given.stage, given.next_stage, &given.code),
            "the application's shader, with the next stage the link required"
        );
    }
    (
        handles,
        variant_infos.to_vec(),
        variant_handles.to_vec(),
        app_infos.to_vec(),
    )
}

/// A vertex and a fragment shader object of `vertex` and `fragment` code, created unlinked in
/// one call where one of them gets a variant: checks that the call succeeded and that two
/// calls reached the fake, the variant's then the application's (with its allocator; its
/// create infos as they are where `unchanged`: in a precise mode revz reserves its carrier's
/// push-constant range in a copy). Returns the handles, the variant's create infos (as the
/// fake saw them) and handles, and the application's create infos as the fake saw them.
fn create_pair_with_variant(
    fx: &Fixture,
    vertex: &[u32],
    fragment: &[u32],
    unchanged: bool,
) -> (
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
) {
    let infos = [
        shader_info(VERTEX_STAGE, FRAGMENT_STAGE, vertex),
        shader_info(FRAGMENT_STAGE, vk::ShaderStageFlags::empty(), fragment),
    ];
    let (handles, events) = create_with_one_variant(fx, &infos);
    let (variant_address, variant_infos, variant_allocator, variant_handles) =
        app_creation(&events[0]);
    let (app_address, app_infos, app_allocator, app_handles) = app_creation(&events[1]);
    if unchanged {
        // The application's call went down unchanged.
        assert_eq!(app_address, infos.as_ptr() as usize);
        // SAFETY: valid create infos.
        let expected: Vec<SeenShader> =
            infos.iter().map(|i| unsafe { SeenShader::of(i) }).collect();
        assert_eq!(app_infos, expected);
    }
    assert!(app_allocator);
    assert_eq!(app_handles, handles);
    // The variant: its own create info, no allocator.
    assert_ne!(variant_address, infos.as_ptr() as usize);
    assert!(!variant_allocator);
    (
        handles,
        variant_infos.to_vec(),
        variant_handles.to_vec(),
        app_infos.to_vec(),
    )
}

/// The vertex and FragDepth fragment shader objects, created unlinked; returns their handles
/// and the fragment's variant (checked to be of the rewritten code, before the app's call).
fn create_depth_pair(fx: &Fixture) -> (vk::ShaderEXT, vk::ShaderEXT, vk::ShaderEXT) {
    let frag = fragment(FRAG_DEPTH);
    let (handles, variant_infos, variant_handles, expected) =
        create_pair_with_variant(fx, &vertex(), &frag, true);
    // The variant: the fragment create info with only its code replaced.
    let rewritten = reverse_fragment_depth(&frag)
        .expect("rewritable")
        .expect("computes with depth");
    validate(&rewritten);
    assert_eq!(
        variant_infos,
        [SeenShader {
            code: bytes(&rewritten),
            ..expected[1].clone()
        }]
    );
    let variant = variant_handles[0];
    assert_eq!(
        fx.recorded(handles[1]),
        Some(FragmentShader::Reversed(variant))
    );
    assert_eq!(
        fx.recorded(handles[0]),
        None,
        "a vertex shader gets nothing"
    );
    (handles[0], handles[1], variant)
}

#[test]
fn a_frag_depth_fragment_shader_object_gets_a_variant_of_rewritten_code_before_the_app_call() {
    let fx = Fixture::new();
    create_depth_pair(&fx);
    fx.finish();
}

#[test]
fn a_linked_fragment_shader_computing_with_depth_gets_its_variant() {
    let fx = Fixture::new();
    let (vertex, frag, plain) = (vertex(), fragment(FRAG_DEPTH), fragment(PLAIN));
    let (handles, variant_infos, variant_handles, app_infos) =
        create_linked_pair_with_variant(&fx, &vertex, &frag);
    let rewritten = reverse_fragment_depth(&frag)
        .expect("rewritable")
        .expect("computes with depth");
    assert_eq!(
        variant_infos,
        [SeenShader {
            code: bytes(&rewritten),
            ..app_infos[1].clone()
        }]
    );
    assert_eq!(
        fx.recorded(handles[1]),
        Some(FragmentShader::Reversed(variant_handles[0]))
    );
    // A linked pair revz makes no variant of keeps its link.
    let linked_plain = [
        link(shader_info(VERTEX_STAGE, FRAGMENT_STAGE, &vertex)),
        link(shader_info(
            FRAGMENT_STAGE,
            vk::ShaderStageFlags::empty(),
            &plain,
        )),
    ];
    let (result, _) = fx.create(&linked_plain);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    assert_eq!(events.len(), 1, "the application's call alone");
    let (address, ..) = app_creation(&events[0]);
    assert_eq!(
        address,
        linked_plain.as_ptr() as usize,
        "as the application made it"
    );
    fx.finish();
}

#[test]
fn plain_linked_binary_and_refused_fragment_shaders_get_no_variant() {
    let fx = Fixture::new();
    let vertex = vertex();
    let plain = fragment(PLAIN);
    let depth = fragment(FRAG_DEPTH);
    let refused = refused_fragment();
    let binary = [0xB1u8, 0x4A, 0x27, 0x00];
    let binary_info = vk::ShaderCreateInfoEXT::default()
        .stage(FRAGMENT_STAGE)
        .code_type(vk::ShaderCodeTypeEXT::BINARY)
        .code(&binary)
        .name(MAIN);
    let cases: [(Vec<vk::ShaderCreateInfoEXT<'_>>, Option<FragmentShader>); 4] = [
        (
            vec![shader_info(
                FRAGMENT_STAGE,
                vk::ShaderStageFlags::empty(),
                &plain,
            )],
            None,
        ),
        (
            // A set with tessellation stages keeps its link (a set without them goes down
            // unlinked: `a_linked_fragment_shader_computing_with_depth_gets_its_variant`).
            {
                let mut set = linked_tessellation([&vertex, &vertex, &vertex]);
                set.push(link(shader_info(
                    FRAGMENT_STAGE,
                    vk::ShaderStageFlags::empty(),
                    &depth,
                )));
                set
            },
            Some(FragmentShader::Unreversed),
        ),
        (vec![binary_info], Some(FragmentShader::Unreversed)),
        (
            vec![shader_info(
                FRAGMENT_STAGE,
                vk::ShaderStageFlags::empty(),
                &refused,
            )],
            Some(FragmentShader::Unreversed),
        ),
    ];
    for (infos, recorded) in cases {
        let (result, handles) = fx.create(&infos);
        assert_eq!(result, vk::Result::SUCCESS);
        let events = fx.events();
        assert_eq!(events.len(), 1, "only the application's call: {events:#?}");
        let (address, ..) = app_creation(&events[0]);
        assert_eq!(address, infos.as_ptr() as usize);
        let fragment = *handles.last().expect("a fragment shader");
        assert_eq!(fx.recorded(fragment), recorded, "{infos:#?}");
    }
    fx.finish();
}

#[test]
fn a_failed_variant_marks_the_shader_and_a_failed_app_call_destroys_the_variant() {
    let fx = Fixture::new();
    let frag = fragment(FRAG_DEPTH);
    let infos = [shader_info(
        FRAGMENT_STAGE,
        vk::ShaderStageFlags::empty(),
        &frag,
    )];

    // The variant fails: the application's call still goes down and succeeds.
    fake_chain::script_shader_object_creations(
        fx.tables.device,
        [vk::Result::ERROR_OUT_OF_DEVICE_MEMORY],
    );
    let (result, handles) = fx.create(&infos);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    assert_eq!(events.len(), 2);
    assert_eq!(app_creation(&events[1]).3, handles);
    assert_eq!(fx.recorded(handles[0]), Some(FragmentShader::Unreversed));

    // The application's call fails: revz's variant is destroyed, nothing recorded, the
    // application gets its result.
    fake_chain::script_shader_object_creations(
        fx.tables.device,
        [vk::Result::SUCCESS, vk::Result::ERROR_OUT_OF_HOST_MEMORY],
    );
    let (result, handles) = fx.create(&infos);
    assert_eq!(result, vk::Result::ERROR_OUT_OF_HOST_MEMORY);
    assert_eq!(handles, [vk::ShaderEXT::null()]);
    let events = fx.events();
    let variant = app_creation(&events[0]).3[0];
    assert_eq!(
        events[2..],
        [Event::DestroyShader {
            handle: variant,
            allocator: false
        }]
    );
    fx.finish();
}

#[test]
fn draws_into_a_reversed_attachment_bind_the_variant_once_and_native_ones_the_app_shader_back() {
    let fx = Fixture::new();
    let (vertex, frag, variant) = create_depth_pair(&fx);
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let native =
        fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    fx.render(buffer, reversed, 2);
    fx.render(buffer, native, 2);
    // Binding another stage leaves the fragment stage as it is: the variant comes back once.
    fx.render(buffer, reversed, 1);
    fx.bind(buffer, &[VERTEX_STAGE], &[vertex]);
    fx.render(buffer, reversed, 1);
    let events = fx.events();
    let bind = |stages: &[vk::ShaderStageFlags], shaders: &[vk::ShaderEXT]| Event::BindShaders {
        stages: stages.to_vec(),
        shaders: shaders.to_vec(),
    };
    let binds: Vec<&Event> = events
        .iter()
        .filter(|e| matches!(e, Event::BindShaders { .. }))
        .collect();
    assert_eq!(
        binds,
        [
            &bind(&[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]),
            &bind(&[FRAGMENT_STAGE], &[variant]),
            &bind(&[FRAGMENT_STAGE], &[frag]),
            &bind(&[FRAGMENT_STAGE], &[variant]),
            &bind(&[VERTEX_STAGE], &[vertex]),
        ]
    );
    // Unbinding the fragment stage (null) leaves nothing to swap.
    fx.bind(buffer, &[FRAGMENT_STAGE], &[vk::ShaderEXT::null()]);
    fx.render(buffer, native, 1);
    fx.render(buffer, reversed, 1);
    let binds = fx.shader_binds().len();
    assert_eq!(binds, 1, "only the application's unbind");
    fx.free(buffer);
    fx.finish();
}

#[test]
fn a_variant_the_app_never_destroyed_goes_with_the_device() {
    let fx = Fixture::new();
    let (_, frag, variant) = create_depth_pair(&fx);
    // The application leaks its fragment shader.
    fx.shaders.borrow_mut().retain(|&s| s != frag);
    fx.finish_with(&[Event::DestroyShader {
        handle: variant,
        allocator: false,
    }]);
}

#[test]
fn an_active_mode_hands_out_revz_shader_object_hooks() {
    let fx = Fixture::new();
    for name in [
        c"vkCreateShadersEXT",
        c"vkDestroyShaderEXT",
        c"vkCmdBindShadersEXT",
    ] {
        // SAFETY: a live device and NUL-terminated names.
        let (revz, next) = unsafe {
            (
                super::device::get_device_proc_addr(fx.device, name.as_ptr()),
                fake_chain::fake_get_device_proc_addr_with_shader_objects(fx.device, name.as_ptr()),
            )
        };
        assert!(revz.is_some() && next.is_some(), "{name:?}");
        assert_ne!(
            revz.map(|f| f as usize),
            next.map(|f| f as usize),
            "{name:?}"
        );
    }
    fx.finish();
}

#[test]
fn mode_off_hands_out_the_next_layers_shader_object_commands() {
    let fx = Fixture::with_settings(&[(c"mode", c"off")]);
    for name in [
        c"vkCreateShadersEXT",
        c"vkDestroyShaderEXT",
        c"vkCmdBindShadersEXT",
    ] {
        // SAFETY: a live device and NUL-terminated names.
        let (revz, next) = unsafe {
            (
                super::device::get_device_proc_addr(fx.device, name.as_ptr()),
                fake_chain::fake_get_device_proc_addr_with_shader_objects(fx.device, name.as_ptr()),
            )
        };
        assert_eq!(
            revz.map(|f| f as usize),
            next.map(|f| f as usize),
            "{name:?}"
        );
    }
    // SAFETY: the fake's live device, no longer in use.
    let device_events =
        unsafe { fake_chain::tear_down(fx.tables, fx.instance, fx.physical, fx.device) };
    assert_eq!(device_events, [Event::DestroyDevice]);
}

/// A vertex shader projecting with a pushed matrix.
const PROJECTING: &str = "#version 450
    layout(push_constant) uniform PushConstants { mat4 mvp; } pc;
    layout(location = 0) in vec3 position;
    void main() { gl_Position = pc.mvp * vec4(position, 1.0); }";

#[test]
fn a_vertex_shader_object_gets_its_code_with_the_carrier_baked_in_bound_for_precise_draws() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let projecting = crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, PROJECTING);
    let plain = fragment(PLAIN);
    let (handles, variant_infos, variant_handles, app_infos) =
        create_pair_with_variant(&fx, &projecting, &plain, false);
    // The variant: the vertex create info (with revz's carrier range, as the application's)
    // and the code fitting the pushed matrix with the carrier baked in.
    let baked = crate::shader::test_spirv::baked(&projecting);
    assert_eq!(
        variant_infos,
        [SeenShader {
            code: bytes(&baked),
            ..app_infos[0].clone()
        }]
    );
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    assert_eq!(
        fx.state.objects.position_shaders.get(&vertex),
        Some(PositionShader::Baked {
            variant,
            projects_input: false
        })
    );
    assert_eq!(fx.recorded(frag), None);

    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let native =
        fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    fx.render(buffer, reversed, 2);
    fx.render(buffer, native, 1);
    fx.render(buffer, reversed, 1);
    // The application binds its vertex shader again: the variant goes down again once.
    fx.bind(buffer, &[VERTEX_STAGE], &[vertex]);
    fx.render(buffer, reversed, 2);
    // A geometry shader of the application's after it is the last stage: the application's
    // vertex shader back, and the flip path.
    let geometry = vk::ShaderEXT::from_raw(0x6E0);
    fx.bind(buffer, &[vk::ShaderStageFlags::GEOMETRY], &[geometry]);
    fx.render(buffer, reversed, 1);
    let bind = |stages: &[vk::ShaderStageFlags], shaders: &[vk::ShaderEXT]| Event::BindShaders {
        stages: stages.to_vec(),
        shaders: shaders.to_vec(),
    };
    let events = fx.events();
    let binds: Vec<&Event> = events
        .iter()
        .filter(|e| matches!(e, Event::BindShaders { .. }))
        .collect();
    assert_eq!(
        binds,
        [
            &bind(&[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]),
            &bind(&[VERTEX_STAGE], &[variant]),
            &bind(&[VERTEX_STAGE], &[vertex]),
            &bind(&[VERTEX_STAGE], &[variant]),
            &bind(&[VERTEX_STAGE], &[vertex]),
            &bind(&[VERTEX_STAGE], &[variant]),
            &bind(&[vk::ShaderStageFlags::GEOMETRY], &[geometry]),
            &bind(&[VERTEX_STAGE], &[vertex]),
        ]
    );
    // Bound inside a pass into a reversed attachment: the variant goes down in the
    // application's shader's place, and nothing after it.
    fx.bind(
        buffer,
        &[vk::ShaderStageFlags::GEOMETRY],
        &[vk::ShaderEXT::null()],
    );
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(reversed)
        .image_layout(LAYOUT)
        .load_op(vk::AttachmentLoadOp::LOAD)
        .store_op(vk::AttachmentStoreOp::STORE);
    let rendering = vk::RenderingInfo::default()
        .render_area(EXTENT.into())
        .layer_count(1)
        .depth_attachment(&depth);
    fx.events();
    // SAFETY: a recording primary command buffer and a valid rendering info.
    unsafe { (fx.hooks.cmd_begin_rendering)(buffer, &rendering) };
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    // SAFETY: as above.
    unsafe {
        (fx.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
        (fx.hooks.cmd_end_rendering)(buffer);
    }
    let binds = fx.shader_binds();
    assert_eq!(
        binds,
        [
            bind(&[VERTEX_STAGE], &[variant]),
            bind(&[VERTEX_STAGE, FRAGMENT_STAGE], &[variant, frag]),
        ],
        "the begin binds the variant back (the geometry stage is gone), the application's \
         bind goes down with it in place"
    );
    fx.free(buffer);

    // A linked pair goes down unlinked, and so does its variant's call (a call of one linked
    // shader is invalid): its vertex shader gets its variant as an unlinked one does, bound
    // alone in its place for precise-path draws.
    let (handles, variant_infos, variant_handles, app_infos) =
        create_linked_pair_with_variant(&fx, &projecting, &plain);
    assert_eq!(
        variant_infos,
        [SeenShader {
            code: bytes(&baked),
            ..app_infos[0].clone()
        }]
    );
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    assert_eq!(
        fx.state.objects.position_shaders.get(&vertex),
        Some(PositionShader::Baked {
            variant,
            projects_input: false
        })
    );
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]),
            bind(&[VERTEX_STAGE], &[variant]),
        ]
    );
    fx.free(buffer);
    // A set with tessellation stages keeps its link: no variant, the flip path.
    let tessellated = linked_tessellation([&projecting, &plain, &projecting]);
    let (result, handles) = fx.create(&tessellated);
    assert_eq!(result, vk::Result::SUCCESS);
    assert_link_kept_on_the_flip_path(&fx, &fx.events(), handles[2]);
    let binary = vk::ShaderCreateInfoEXT {
        code_type: vk::ShaderCodeTypeEXT::BINARY,
        ..shader_info(VERTEX_STAGE, FRAGMENT_STAGE, &projecting)
    };
    let (_, handles) = fx.create(&[binary]);
    assert_eq!(fx.events().len(), 1);
    assert_eq!(
        fx.state.objects.position_shaders.get(&handles[0]),
        Some(PositionShader::Flip {
            stores_unit_w: false
        })
    );
    fx.finish();
}

#[test]
fn a_vertex_shader_object_with_push_constant_ranges_takes_the_pipelines_per_camera_route() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    // One call for the vertex shader's variant, then the application's, both with the
    // carrier reserved in their ranges; the variant's code stores Position through the pushed
    // carrier, as a pipeline's vertex stage does.
    let PushedPair {
        offset,
        projecting,
        app_ranges,
        app_layout,
        own,
        handles,
        variant_infos,
        variant_handles,
        app_infos,
    } = pushed_pair(&fx);
    let carrier_code = crate::shader::position_store::rewrite_position_store(&projecting, offset)
        .expect("rewritable")
        .expect("stores Position");
    validate(&carrier_code);
    assert_eq!(
        variant_infos,
        [SeenShader {
            code: bytes(&carrier_code),
            ..app_infos[0].clone()
        }]
    );
    for info in app_infos {
        // revz's copy of the ranges, with the carrier reserved (`reserve_carrier`).
        assert_ne!(info.push_constant_ranges, app_ranges.as_ptr() as usize);
    }
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    match fx.state.objects.position_shaders.get(&vertex) {
        Some(PositionShader::Pushed {
            variant: recorded,
            depth,
            projects_input: false,
        }) => {
            assert_eq!(recorded, variant);
            assert_eq!(depth.projection.map(|p| p.offset), Some(0));
            assert_eq!(depth.position_store.map(|c| c.offset), Some(offset));
            assert_eq!(depth.layout, own);
        }
        other => panic!("the pushed route: {other:?}"),
    }

    // A draw into a reversed attachment after the camera's matrix is pushed: the carrier
    // holds the camera's infinite-mode line (n / w), and the variant is bound for it.
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    let (near, far) = (0.5, 50.0);
    push(
        &fx,
        buffer,
        app_layout,
        VERTEX_STAGE,
        &camera_matrix(near, far),
    );
    fx.render(buffer, reversed, 2);
    let events = fx.events();
    assert_camera_carrier(&events, offset, &[app_layout, own], near, far);
    let binds: Vec<&Event> = events
        .iter()
        .filter(|e| matches!(e, Event::BindShaders { .. }))
        .collect();
    assert_eq!(
        binds,
        [
            &Event::BindShaders {
                stages: vec![VERTEX_STAGE, FRAGMENT_STAGE],
                shaders: vec![vertex, frag],
            },
            &Event::BindShaders {
                stages: vec![VERTEX_STAGE],
                shaders: vec![variant],
            },
        ],
        "the variant once, for both draws"
    );
    fx.free(buffer);
    fx.finish_with(&[Event::DestroyPipelineLayout { handle: own }]);
}

/// The application's pipeline layout of `ranges` (one range of `stages` from 0), created
/// through revz, which it pushes with: checks that it and revz's own layout of the same
/// ranges (what revz pushes its carrier with) went down with the carrier reserved at
/// `offset`; returns both.
fn create_layouts(
    fx: &Fixture,
    ranges: &[vk::PushConstantRange],
    stages: vk::ShaderStageFlags,
    offset: u32,
) -> (vk::PipelineLayout, vk::PipelineLayout) {
    let reserved = vec![(stages, 0, offset + 16)];
    let mut app_layout = vk::PipelineLayout::null();
    let layout_info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(ranges);
    // SAFETY: a live device, a valid create info, room for the handle.
    let result = unsafe {
        (fx.hooks.create_pipeline_layout)(
            fx.device,
            &layout_info,
            std::ptr::null(),
            &mut app_layout,
        )
    };
    assert_eq!(result, vk::Result::SUCCESS);
    match &fx.events()[..] {
        [Event::CreatePipelineLayout { handle, ranges }, Event::CreatePipelineLayout {
            handle: own,
            ranges: own_ranges,
        }] if *handle == app_layout && *ranges == reserved && *own_ranges == reserved => {
            (app_layout, *own)
        }
        other => panic!("the application's layout and revz's, both reserved: {other:#?}"),
    }
}

/// A `stage` shader object of `code` and a fragment one of `fragment`, both with `ranges`,
/// created unlinked in one call where the first gets a variant: checks that two calls reached
/// the fake, the variant's then the application's. Returns the handles, the variant's create
/// infos and handles, and the application's create infos, as the fake saw them.
fn create_with_ranges(
    fx: &Fixture,
    stage: vk::ShaderStageFlags,
    code: &[u32],
    fragment: &[u32],
    ranges: &[vk::PushConstantRange],
) -> (
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
    Vec<vk::ShaderEXT>,
    Vec<SeenShader>,
) {
    let infos = [
        shader_info(stage, FRAGMENT_STAGE, code).push_constant_ranges(ranges),
        shader_info(FRAGMENT_STAGE, vk::ShaderStageFlags::empty(), fragment)
            .push_constant_ranges(ranges),
    ];
    let (handles, events) = create_with_one_variant(fx, &infos);
    let (_, variant_infos, _, variant_handles) = app_creation(&events[0]);
    let (_, app_infos, _, _) = app_creation(&events[1]);
    (
        handles,
        variant_infos.to_vec(),
        variant_handles.to_vec(),
        app_infos.to_vec(),
    )
}

/// [`pushed_pair`]'s shaders and what revz made of them.
struct PushedPair {
    /// revz's carrier offset on the fixture's device.
    offset: u32,
    /// The vertex shader's code (`PROJECTING`, its matrix at push-constant bytes 0..64).
    projecting: Vec<u32>,
    app_ranges: [vk::PushConstantRange; 1],
    /// The application's pipeline layout of `app_ranges`, and revz's own of the same ranges.
    app_layout: vk::PipelineLayout,
    own: vk::PipelineLayout,
    /// As [`create_with_ranges`] returns them.
    handles: Vec<vk::ShaderEXT>,
    variant_infos: Vec<SeenShader>,
    variant_handles: Vec<vk::ShaderEXT>,
    app_infos: Vec<SeenShader>,
}

/// A vertex shader object projecting its pushed matrix and a plain fragment one, with the
/// vertex stage's range 0..64, created through revz after the application's pipeline layout
/// of that range ([`create_layouts`], [`create_with_ranges`]): the pushed route's setup.
fn pushed_pair(fx: &Fixture) -> PushedPair {
    let offset = fx.state.policy.carrier_offset.expect("a carrier offset");
    let projecting = crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, PROJECTING);
    let plain = fragment(PLAIN);
    let app_ranges = [vk::PushConstantRange {
        stage_flags: VERTEX_STAGE,
        offset: 0,
        size: 64,
    }];
    let (app_layout, own) = create_layouts(fx, &app_ranges, VERTEX_STAGE, offset);
    let (handles, variant_infos, variant_handles, app_infos) =
        create_with_ranges(fx, VERTEX_STAGE, &projecting, &plain, &app_ranges);
    PushedPair {
        offset,
        projecting,
        app_ranges,
        app_layout,
        own,
        handles,
        variant_infos,
        variant_handles,
        app_infos,
    }
}

/// The bytes of a perspective camera's projection (`near`, `far`), as pushed.
fn camera_matrix(near: f64, far: f64) -> Vec<u8> {
    glam::dcamera::rh::proj::vulkan::perspective(1.0, 1.5, near, far)
        .as_mat4()
        .to_cols_array()
        .iter()
        .flat_map(|v| v.to_ne_bytes())
        .collect()
}

/// Pushes `bytes` at 0 with `layout` and `stages` through revz.
fn push(
    fx: &Fixture,
    buffer: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    stages: vk::ShaderStageFlags,
    bytes: &[u8],
) {
    // SAFETY: a recording command buffer, the application's layout, its bytes.
    unsafe {
        (fx.hooks.cmd_push_constants)(
            buffer,
            layout,
            stages,
            0,
            bytes.len() as u32,
            bytes.as_ptr().cast(),
        )
    };
}

/// Checks that the carrier's bytes (at `offset`) as last pushed in `events` (the
/// application's push extended to them, or a push of their own, with one of `layouts`) hold
/// the infinite-mode line of the camera `near`, `far`: `(0, k, b, 0)`.
fn assert_camera_carrier(
    events: &[Event],
    offset: u32,
    layouts: &[vk::PipelineLayout],
    near: f64,
    far: f64,
) {
    let mut carrier = None;
    for event in events {
        if let Event::PushConstants {
            layout,
            offset: at,
            bytes,
            ..
        } = event
        {
            assert!(layouts.contains(layout), "{event:?}");
            let end = *at as usize + bytes.len();
            if *at <= offset && end >= offset as usize + 16 {
                let from = (offset - at) as usize;
                carrier = Some(
                    bytes[from..from + 16]
                        .chunks_exact(4)
                        .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                        .collect::<Vec<f32>>(),
                );
            }
        }
    }
    let carrier = carrier.expect("the carrier pushed");
    let range = revz_math::VisibleRange::new(near, far).expect("a range");
    let expected = revz_math::reversed_coefficients(
        range,
        revz_math::Target::Infinite,
        revz_math::DepthConvention::ZeroToOne,
    );
    assert_eq!((carrier[0], carrier[3]), (0.0, 0.0), "{carrier:?}");
    assert!(
        (f64::from(carrier[1]) - expected.k).abs() <= 1e-5 * expected.k.abs().max(1.0),
        "{carrier:?} against {expected:?}"
    );
    assert!(
        (f64::from(carrier[2]) - expected.b).abs() <= 1e-5 * expected.b.abs().max(1e-3),
        "{carrier:?} against {expected:?}"
    );
}

/// The tester's mesh shader (`shaders/glslang/mesh.mesh`), compiled by glslang.
fn mesh_shader_words() -> Vec<u32> {
    crate::shader::test_spirv::words(include_bytes!("../../../shaders/glslang/mesh.mesh.spv"))
}

#[test]
fn a_mesh_shader_object_gets_its_code_with_the_carrier_baked_in_bound_for_precise_draws() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let (mesh_words, plain) = (mesh_shader_words(), fragment(PLAIN));
    let mesh_stage = vk::ShaderStageFlags::MESH_EXT;
    let infos = [
        shader_info(mesh_stage, FRAGMENT_STAGE, &mesh_words),
        shader_info(FRAGMENT_STAGE, vk::ShaderStageFlags::empty(), &plain),
    ];
    let (result, handles) = fx.create(&infos);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    assert_eq!(events.len(), 2, "the variant, then the application's");
    let (_, variant_infos, _, variant_handles) = app_creation(&events[0]);
    // The mesh stage's code fitting the pushed matrix, the carrier baked in: each vertex's
    // Position rewritten where it is stored.
    let selector = crate::command_state::derived_selector(
        revz_math::Target::Complementary,
        revz_math::DepthConvention::ZeroToOne,
    );
    let baked = crate::shader::position_store::derive_position_store_reading(
        &mesh_words,
        crate::shader::position_store::CarrierRead::Baked(selector),
    )
    .unwrap()
    .unwrap()
    .code;
    assert_eq!(variant_infos.len(), 1);
    assert_eq!(variant_infos[0].code, bytes(&baked));
    let (mesh, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    assert_eq!(
        fx.state.objects.position_shaders.get(&mesh),
        Some(PositionShader::Baked {
            variant,
            projects_input: false
        })
    );
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[mesh_stage, FRAGMENT_STAGE], &[mesh, frag]);
    fx.render(buffer, reversed, 1);
    let binds = fx.shader_binds();
    assert_eq!(
        binds.last(),
        Some(&Event::BindShaders {
            stages: vec![mesh_stage],
            shaders: vec![variant],
        }),
        "the mesh stage's variant in its place for the precise draw: {binds:?}"
    );
}

#[test]
fn the_depth_profile_lists_a_mesh_shader_object_and_files_its_draws_under_it() {
    // Found in review: only vertex shader objects were listed, and only vertex binds filed
    // the draws that follow.
    let report =
        std::env::temp_dir().join(format!("revz-mesh-objects-{}.json", std::process::id()));
    let report_value =
        std::ffi::CString::new(report.to_str().expect("a UTF-8 temporary path")).expect("no NUL");
    // Leaked: the settings table takes `'static` strings.
    let report_value: &'static CStr = Box::leak(report_value.into_boxed_c_str());
    let fx = Fixture::with_settings(&[
        (c"mode", c"infinite"),
        (c"reverse_observable", c"none"),
        (c"report", report_value),
    ]);
    let (mesh_words, plain) = (mesh_shader_words(), fragment(PLAIN));
    let mesh_stage = vk::ShaderStageFlags::MESH_EXT;
    let (result, handles) = fx.create(&[
        shader_info(mesh_stage, FRAGMENT_STAGE, &mesh_words),
        shader_info(FRAGMENT_STAGE, vk::ShaderStageFlags::empty(), &plain),
    ]);
    assert_eq!(result, vk::Result::SUCCESS);
    let (mesh, frag) = (handles[0], handles[1]);
    let profile = fx.state.profile.as_ref().expect("the profile is on");
    let document = profile.document();
    let listed: Vec<_> = document["pipelines"]
        .as_array()
        .expect("pipelines")
        .iter()
        .filter(|p| p["kind"] == "mesh shader object")
        .map(|p| (p["handle"].clone(), p["path"].clone()))
        .collect();
    assert_eq!(listed.len(), 1, "{document}");
    assert_eq!(listed[0].1, "precise");
    // Bound after the vertex stage is unbound: the draws go under the mesh shader.
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(
        buffer,
        &[vk::ShaderStageFlags::VERTEX, mesh_stage, FRAGMENT_STAGE],
        &[vk::ShaderEXT::null(), mesh, frag],
    );
    let entry = crate::objects::command_buffer(buffer).expect("tracked");
    assert_eq!(entry.state().last_position_shader(), Some(mesh));
    fx.render(buffer, reversed, 1);
    fx.events();
    fx.finish();
    let _ = std::fs::remove_file(report);
}

#[test]
fn a_mesh_shader_object_with_the_carrier_in_its_mesh_range_takes_the_pipelines_route() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let offset = fx.state.policy.carrier_offset.expect("a carrier offset");
    let (mesh_words, plain) = (mesh_shader_words(), fragment(PLAIN));
    let mesh_stage = vk::ShaderStageFlags::MESH_EXT;
    // The application's range of the mesh and fragment stages (no vertex range): revz's
    // carrier goes into it, where the mesh stage reads it.
    let stages = mesh_stage | FRAGMENT_STAGE;
    let app_ranges = [vk::PushConstantRange {
        stage_flags: stages,
        offset: 0,
        size: 96,
    }];
    let (app_layout, own) = create_layouts(&fx, &app_ranges, stages, offset);
    let (handles, variant_infos, variant_handles, _) =
        create_with_ranges(&fx, mesh_stage, &mesh_words, &plain, &app_ranges);
    // The deriving rewrite reading the pushed carrier (each vertex's Position rewritten where
    // it is stored), as a mesh pipeline's stage.
    let rewrite = crate::shader::position_store::derive_position_store(&mesh_words, offset)
        .expect("rewritable")
        .expect("stores Position");
    assert_eq!(variant_infos.len(), 1);
    assert_eq!(variant_infos[0].code, bytes(&rewrite.code));
    let (mesh, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    match fx.state.objects.position_shaders.get(&mesh) {
        Some(PositionShader::Pushed {
            variant: recorded,
            depth,
            projects_input: false,
        }) => {
            assert_eq!(recorded, variant);
            // Its matrix located for the CPU (`pc.mvp`), and fitted in the stage otherwise.
            assert_eq!(depth.projection.map(|p| p.offset), Some(0));
            assert!(depth.derived_range.is_some());
            assert_eq!(depth.layout, own);
        }
        other => panic!("the pushed route: {other:?}"),
    }
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[mesh_stage, FRAGMENT_STAGE], &[mesh, frag]);
    let (near, far) = (0.25, 400.0);
    push(&fx, buffer, app_layout, stages, &camera_matrix(near, far));
    fx.render(buffer, reversed, 1);
    let events = fx.events();
    assert_camera_carrier(&events, offset, &[app_layout, own], near, far);
    let binds: Vec<&Event> = events
        .iter()
        .filter(|e| matches!(e, Event::BindShaders { .. }))
        .collect();
    assert_eq!(
        binds.last(),
        Some(&&Event::BindShaders {
            stages: vec![mesh_stage],
            shaders: vec![variant],
        }),
        "the mesh stage's variant in its place for the precise draw: {binds:?}"
    );
    fx.free(buffer);
    fx.finish_with(&[Event::DestroyPipelineLayout { handle: own }]);
}

#[test]
fn an_infinite_mode_clamp_without_clipping_binds_the_app_shader_and_clipping_brings_the_variant_back(
) {
    // D3D translators' dynamic state through the hooks: each command goes down as it is, and
    // decides whether the vertex shader object's precise variant is bound (infinite mode's
    // precise path has no far plane to clamp at).
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let PushedPair {
        app_layout,
        own,
        handles,
        variant_handles,
        ..
    } = pushed_pair(&fx);
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(buffer, &[VERTEX_STAGE, FRAGMENT_STAGE], &[vertex, frag]);
    push(
        &fx,
        buffer,
        app_layout,
        VERTEX_STAGE,
        &camera_matrix(0.5, 50.0),
    );
    let vertex_bound = |events: &[Event]| {
        events.iter().rev().find_map(|e| match e {
            Event::BindShaders { stages, shaders } => stages
                .iter()
                .position(|&s| s == VERTEX_STAGE)
                .map(|i| shaders[i]),
            _ => None,
        })
    };
    fx.render(buffer, reversed, 1);
    assert_eq!(vertex_bound(&fx.events()), Some(variant), "precise");
    // Turns a switch on through its hook and renders: what went down, the switch's command
    // among it as the application made it.
    let switched_on = |set: unsafe extern "system" fn(vk::CommandBuffer, vk::Bool32),
                       sent: Event| {
        // SAFETY: a recording command buffer.
        unsafe { set(buffer, vk::TRUE) };
        fx.render(buffer, reversed, 1);
        let events = fx.events();
        assert!(events.contains(&sent), "{events:#?}");
        events
    };
    let events = switched_on(
        fx.hooks.cmd_set_depth_clamp_enable,
        Event::SetDepthClampEnable(true),
    );
    assert_eq!(
        vertex_bound(&events),
        Some(vertex),
        "clamped, not clipped: flip"
    );
    let events = switched_on(
        fx.hooks.cmd_set_depth_clip_enable,
        Event::SetDepthClipEnable(true),
    );
    assert_eq!(
        vertex_bound(&events),
        Some(variant),
        "clamped and clipped: precise"
    );
    fx.free(buffer);
    fx.finish_with(&[Event::DestroyPipelineLayout { handle: own }]);
}

/// SPIR-V words of a binary module's bytes.

#[test]
fn a_geometry_shader_object_passing_positions_through_leaves_the_vertex_variant_bound() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let projecting = crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, PROJECTING);
    let plain = fragment(PLAIN);
    let (handles, _, variant_handles, _) =
        create_pair_with_variant(&fx, &projecting, &plain, false);
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    let geometry = vk::ShaderStageFlags::GEOMETRY;
    // glslang's pass-through geometry shader: no variant of its own, marked.
    let passthrough = crate::shader::test_spirv::words(include_bytes!(
        "../shader/test_data/geometry_passthrough.spv"
    ));
    let (result, created) = fx.create(&[shader_info(geometry, FRAGMENT_STAGE, &passthrough)]);
    assert_eq!(result, vk::Result::SUCCESS);
    assert_eq!(fx.events().len(), 1, "the application's call alone");
    assert_eq!(
        fx.state.objects.position_shaders.get(&created[0]),
        Some(PositionShader::PassesThrough)
    );
    // One that reads the positions' z for something else: the flip path.
    let reads_z = crate::shader::test_spirv::words(include_bytes!(
        "../shader/test_data/geometry_reads_z.spv"
    ));
    let (_, refused) = fx.create(&[shader_info(geometry, FRAGMENT_STAGE, &reads_z)]);
    fx.events();
    assert_eq!(
        fx.state.objects.position_shaders.get(&refused[0]),
        Some(PositionShader::Flip {
            stores_unit_w: false
        })
    );
    // Drawn with the pass-through shader after the vertex shader: the vertex shader's
    // variant goes down for precise-path draws, the geometry shader stays the application's.
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    fx.bind(
        buffer,
        &[VERTEX_STAGE, geometry, FRAGMENT_STAGE],
        &[vertex, created[0], frag],
    );
    fx.render(buffer, reversed, 1);
    let bind = |stages: &[vk::ShaderStageFlags], shaders: &[vk::ShaderEXT]| Event::BindShaders {
        stages: stages.to_vec(),
        shaders: shaders.to_vec(),
    };
    assert_eq!(
        fx.shader_binds(),
        [
            bind(
                &[VERTEX_STAGE, geometry, FRAGMENT_STAGE],
                &[vertex, created[0], frag]
            ),
            bind(&[VERTEX_STAGE], &[variant]),
        ]
    );
    // The geometry shader that reads z in its place: the application's vertex shader back.
    fx.bind(buffer, &[geometry], &[refused[0]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&[geometry], &[refused[0]]),
            bind(&[VERTEX_STAGE], &[vertex]),
        ]
    );
    fx.free(buffer);
    fx.finish();
}

/// A vertex shader handing its attribute on with w = 1, for a later stage to project.
const UNIT_W: &str = "#version 450
    layout(location = 0) in vec3 position;
    void main() { gl_Position = vec4(position, 1.0); }";

/// A vertex shader handing its attribute on with w = 0.5: no projection of its own (no
/// variant), and a later stage projecting its positions would not store the camera's line.
const HALF_W: &str = "#version 450
    layout(location = 0) in vec3 position;
    void main() { gl_Position = vec4(position, 0.5); }";

#[test]
fn a_geometry_shader_object_projecting_gl_in_is_bound_only_after_a_vertex_shader_storing_w_one() {
    // Shader objects pair at draw time, so the variant of a geometry shader projecting the
    // previous stage's Position is made at creation, assuming w = 1, and bound only after a
    // vertex shader storing vec4(p, 1.0) (before session 39: the flip path always).
    let features = vk::PhysicalDeviceFeatures {
        geometry_shader: vk::TRUE,
        ..Default::default()
    };
    let fx = Fixture::with_features(
        &[(c"mode", c"infinite"), (c"reverse_observable", c"none")],
        features,
    );
    let geometry = vk::ShaderStageFlags::GEOMETRY;
    let compile =
        |source| crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, source);
    let (unit_w, projecting, half_w) = (compile(UNIT_W), compile(PROJECTING), compile(HALF_W));
    let (_, vertices) = fx.create(&[
        shader_info(VERTEX_STAGE, geometry, &unit_w),
        shader_info(VERTEX_STAGE, geometry, &projecting),
        shader_info(VERTEX_STAGE, geometry, &half_w),
    ]);
    fx.events();
    assert_eq!(
        fx.state.objects.position_shaders.get(&vertices[0]),
        Some(PositionShader::Flip {
            stores_unit_w: true
        }),
        "a vertex shader storing vec4(p, 1.0): no variant, marked"
    );
    assert!(!fx
        .state
        .objects
        .position_shaders
        .get(&vertices[1])
        .is_some_and(|p| p.stores_unit_w()));
    assert_eq!(
        fx.state.objects.position_shaders.get(&vertices[2]),
        Some(PositionShader::Flip {
            stores_unit_w: false
        }),
        "a vertex shader storing vec4(p, 0.5): no variant, not marked"
    );
    // glslang's geometry shader projecting gl_in[i].gl_Position with a matrix per invocation.
    let clip_input = crate::shader::test_spirv::words(include_bytes!(
        "../shader/test_data/geometry_clip_input.spv"
    ));
    let (handles, _) =
        create_with_one_variant(&fx, &[shader_info(geometry, FRAGMENT_STAGE, &clip_input)]);
    let projecting_geometry = handles[0];
    let geometry_variant = match fx.state.objects.position_shaders.get(&projecting_geometry) {
        Some(PositionShader::Baked {
            variant,
            projects_input: true,
        }) => variant,
        other => panic!("a variant projecting gl_in: {other:?}"),
    };
    let (_, frag) = fx.create(&[shader_info(
        FRAGMENT_STAGE,
        vk::ShaderStageFlags::empty(),
        &fragment(PLAIN),
    )]);
    fx.events();
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    let bind = |stages: &[vk::ShaderStageFlags], shaders: &[vk::ShaderEXT]| Event::BindShaders {
        stages: stages.to_vec(),
        shaders: shaders.to_vec(),
    };
    fx.bind(
        buffer,
        &[VERTEX_STAGE, geometry, FRAGMENT_STAGE],
        &[vertices[0], projecting_geometry, frag[0]],
    );
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(
                &[VERTEX_STAGE, geometry, FRAGMENT_STAGE],
                &[vertices[0], projecting_geometry, frag[0]]
            ),
            bind(&[geometry], &[geometry_variant]),
        ]
    );
    // A vertex shader whose w is not shown to be 1: the application's geometry shader back.
    fx.bind(buffer, &[VERTEX_STAGE], &[vertices[1]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&[VERTEX_STAGE], &[vertices[1]]),
            bind(&[geometry], &[projecting_geometry]),
        ]
    );
    // One storing w = 0.5 (no variant of its own): the same.
    fx.bind(buffer, &[VERTEX_STAGE], &[vertices[0]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds().last(),
        Some(&bind(&[geometry], &[geometry_variant]))
    );
    fx.bind(buffer, &[VERTEX_STAGE], &[vertices[2]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&[VERTEX_STAGE], &[vertices[2]]),
            bind(&[geometry], &[projecting_geometry]),
        ]
    );

    // The pushed route (the carrier in its ranges, glslang's `ubo.geom` of the tester: the
    // matrix in a uniform buffer) assumes w = 1 the same way.
    let ubo_geometry =
        crate::shader::test_spirv::words(include_bytes!("../../../shaders/glslang/ubo.geom.spv"));
    // Its calls: revz's layout of the ranges (for pushing the carrier), the variant's, the
    // application's.
    let (result, handles) = fx.create(&[shader_info(geometry, FRAGMENT_STAGE, &ubo_geometry)]);
    assert_eq!(result, vk::Result::SUCCESS);
    let events = fx.events();
    assert_eq!(events.len(), 3, "{events:#?}");
    let own = match events[0] {
        Event::CreatePipelineLayout { handle, .. } => handle,
        ref other => panic!("revz's layout first: {other:?}"),
    };
    let pushed_variant = match fx.state.objects.position_shaders.get(&handles[0]) {
        Some(PositionShader::Pushed {
            variant,
            projects_input: true,
            ..
        }) => variant,
        other => panic!("a pushed variant projecting gl_in: {other:?}"),
    };
    fx.bind(
        buffer,
        &[VERTEX_STAGE, geometry],
        &[vertices[0], handles[0]],
    );
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds().last(),
        Some(&bind(&[geometry], &[pushed_variant]))
    );
    fx.bind(buffer, &[VERTEX_STAGE], &[vertices[2]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds().last(),
        Some(&bind(&[geometry], &[handles[0]]))
    );

    // Linked with the vertex shader before it, the pairing is known at creation: after one
    // storing w = 0.5 the variant could never be bound, so none is made and the set keeps its
    // link; after one storing w = 1 the set goes down unlinked with the variant.
    for (vertex, variant) in [(&half_w, false), (&unit_w, true)] {
        let infos = [
            link(shader_info(VERTEX_STAGE, geometry, vertex)),
            link(shader_info(geometry, FRAGMENT_STAGE, &clip_input)),
        ];
        let (result, handles) = fx.create(&infos);
        assert_eq!(result, vk::Result::SUCCESS);
        let events = fx.events();
        assert_eq!(events.len(), if variant { 2 } else { 1 }, "{events:#?}");
        let (_, app_infos, _, _) = app_creation(events.last().expect("the application's call"));
        let linked = app_infos
            .iter()
            .all(|seen| seen.flags.contains(vk::ShaderCreateFlagsEXT::LINK_STAGE));
        assert_eq!(linked, !variant, "the link kept where no variant is made");
        assert_eq!(
            fx.state
                .objects
                .position_shaders
                .get(&handles[1])
                .is_some_and(|p| p.variant().is_some()),
            variant
        );
    }
    fx.free(buffer);
    fx.finish_with(&[Event::DestroyPipelineLayout { handle: own }]);
}

#[test]
fn tessellation_shader_objects_that_only_subdivide_leave_the_vertex_variant_bound() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let projecting = crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, PROJECTING);
    let plain = fragment(PLAIN);
    let (handles, _, variant_handles, _) =
        create_pair_with_variant(&fx, &projecting, &plain, false);
    let (vertex, frag, variant) = (handles[0], handles[1], variant_handles[0]);
    let control = vk::ShaderStageFlags::TESSELLATION_CONTROL;
    let evaluation = vk::ShaderStageFlags::TESSELLATION_EVALUATION;
    let words = |bytes: &[u8]| crate::shader::test_spirv::words(bytes);
    // glslang's control shader copying the clip positions, and evaluation shader
    // interpolating them: no variant of their own, marked.
    let copying = words(include_bytes!(
        "../../../shaders/glslang/position_passthrough.tesc.spv"
    ));
    let interpolating = words(include_bytes!(
        "../../../shaders/glslang/interpolating.tese.spv"
    ));
    let (result, created) = fx.create(&[
        shader_info(control, evaluation, &copying),
        shader_info(evaluation, FRAGMENT_STAGE, &interpolating),
    ]);
    assert_eq!(result, vk::Result::SUCCESS);
    assert_eq!(fx.events().len(), 1, "the application's call alone");
    let (tesc, tese) = (created[0], created[1]);
    for shader in [tesc, tese] {
        assert_eq!(
            fx.state.objects.position_shaders.get(&shader),
            Some(PositionShader::PassesThrough)
        );
    }
    // A control shader computing its levels from the positions' z: nothing of its own.
    let lod_from_z = words(include_bytes!(
        "../shader/test_data/tessellation_lod_from_z.spv"
    ));
    let (_, refused) = fx.create(&[shader_info(control, evaluation, &lod_from_z)]);
    fx.events();
    assert_eq!(fx.state.objects.position_shaders.get(&refused[0]), None);
    // Drawn with both after the vertex shader: the vertex shader's variant goes down for
    // precise-path draws, the tessellation shaders stay the application's.
    let reversed = fx.depth_view(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
    let buffer = fx.command_buffer();
    let all = [VERTEX_STAGE, control, evaluation, FRAGMENT_STAGE];
    fx.bind(buffer, &all, &[vertex, tesc, tese, frag]);
    fx.render(buffer, reversed, 1);
    let bind = |stages: &[vk::ShaderStageFlags], shaders: &[vk::ShaderEXT]| Event::BindShaders {
        stages: stages.to_vec(),
        shaders: shaders.to_vec(),
    };
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&all, &[vertex, tesc, tese, frag]),
            bind(&[VERTEX_STAGE], &[variant]),
        ]
    );
    // The control shader that reads z in its place: the evaluation shader is the last stage
    // again, with no route of its own (the flip path), and the application's vertex shader
    // goes back.
    fx.bind(buffer, &[control], &[refused[0]]);
    fx.render(buffer, reversed, 1);
    assert_eq!(
        fx.shader_binds(),
        [
            bind(&[control], &[refused[0]]),
            bind(&[VERTEX_STAGE], &[vertex]),
        ]
    );
    fx.free(buffer);
    fx.finish();
}

/// Checks that a linked set's creation (`events`) went down as the application's call alone,
/// every create info still linked, and that its last pre-rasterization shader (`last`) takes
/// the flip path.
fn assert_link_kept_on_the_flip_path(fx: &Fixture, events: &[Event], last: vk::ShaderEXT) {
    assert_eq!(events.len(), 1, "the application's call alone: {events:#?}");
    let (_, app_infos, _, _) = app_creation(&events[0]);
    assert!(app_infos
        .iter()
        .all(|info| info.flags == vk::ShaderCreateFlagsEXT::LINK_STAGE));
    assert_eq!(
        fx.state.objects.position_shaders.get(&last),
        Some(PositionShader::Flip {
            stores_unit_w: false
        })
    );
}

/// `words` with every `OpExecutionMode` of `mode` removed.
fn without_mode(words: &[u32], mode: u32) -> Vec<u32> {
    let mut out = words[..crate::shader::scan::HEADER_WORDS].to_vec();
    let mut at = crate::shader::scan::HEADER_WORDS;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let instruction = &words[at..at + count];
        let is_mode = instruction[0] & 0xffff == crate::shader::scan::op::OP_EXECUTION_MODE
            && instruction.get(2) == Some(&mode);
        if !is_mode {
            out.extend_from_slice(instruction);
        }
        at += count;
    }
    out
}

/// `words` with `OpExecutionMode %entry mode` added after its first execution mode (whose
/// entry point it names).
fn with_mode(words: &[u32], mode: u32) -> Vec<u32> {
    let mut out = words[..crate::shader::scan::HEADER_WORDS].to_vec();
    let mut at = crate::shader::scan::HEADER_WORDS;
    let mut added = false;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let instruction = &words[at..at + count];
        out.extend_from_slice(instruction);
        if !added && instruction[0] & 0xffff == crate::shader::scan::op::OP_EXECUTION_MODE {
            crate::shader::scan::push(
                &mut out,
                crate::shader::scan::op::OP_EXECUTION_MODE,
                &[instruction[1], mode],
            );
            added = true;
        }
        at += count;
    }
    assert!(added, "no execution mode to add beside");
    out
}

/// Issue #41: a linked set with tessellation stages goes down unlinked where a shader of it
/// gets a variant and its evaluation shader declares every tessellation mode itself
/// (glslang's: `ubo.tese` declares triangles, equal spacing and counter-clockwise order,
/// `passthrough.tesc` only its output vertices): both calls unlinked, each shader keeping the
/// `nextStage` its link required, and the evaluation shader, whose projection comes from a
/// uniform buffer, gets its variant with the carrier baked in, bound for precise draws. Where
/// the control shader alone declares the spacing (as HLSL hull shaders make it), the set
/// keeps its link and the evaluation shader the flip path.
#[test]
fn a_linked_tessellation_set_whose_evaluation_shader_stands_alone_goes_down_unlinked() {
    let fx = Fixture::with_settings(&[(c"mode", c"infinite"), (c"reverse_observable", c"none")]);
    let projecting = crate::shader::test_spirv::compile_glsl(naga::ShaderStage::Vertex, PROJECTING);
    let plain = fragment(PLAIN);
    let control = crate::shader::test_spirv::words(include_bytes!(
        "../../../shaders/glslang/passthrough.tesc.spv"
    ));
    let evaluation =
        crate::shader::test_spirv::words(include_bytes!("../../../shaders/glslang/ubo.tese.spv"));
    let set = |control: &[u32], evaluation: &[u32]| {
        let mut set = linked_tessellation([&projecting, control, evaluation]);
        set.push(link(shader_info(
            FRAGMENT_STAGE,
            vk::ShaderStageFlags::empty(),
            &plain,
        )));
        // Owned copies: the infos borrow the codes below.
        set.into_iter()
            .map(|info| {
                // SAFETY: the code slices the infos were made from.
                let code = unsafe {
                    std::slice::from_raw_parts(info.p_code.cast::<u32>(), info.code_size / 4)
                };
                (info.stage, info.next_stage, code.to_vec())
            })
            .collect::<Vec<_>>()
    };
    let create = |codes: &[(vk::ShaderStageFlags, vk::ShaderStageFlags, Vec<u32>)]| {
        let infos: Vec<_> = codes
            .iter()
            .map(|(stage, next, code)| link(shader_info(*stage, *next, code)))
            .collect();
        let (result, handles) = fx.create(&infos);
        assert_eq!(result, vk::Result::SUCCESS);
        (handles, fx.events())
    };
    let evaluation_stage = vk::ShaderStageFlags::TESSELLATION_EVALUATION;

    let (handles, events) = create(&set(&control, &evaluation));
    let (_, app_infos, _, _) = app_creation(events.last().expect("the application's call"));
    assert!(
        app_infos
            .iter()
            .all(|info| info.flags == vk::ShaderCreateFlagsEXT::empty()),
        "the application's call unlinked: {app_infos:#?}"
    );
    assert_eq!(
        app_infos
            .iter()
            .map(|info| (info.stage, info.next_stage))
            .collect::<Vec<_>>(),
        [
            (VERTEX_STAGE, vk::ShaderStageFlags::TESSELLATION_CONTROL),
            (vk::ShaderStageFlags::TESSELLATION_CONTROL, evaluation_stage),
            (evaluation_stage, FRAGMENT_STAGE),
            (FRAGMENT_STAGE, vk::ShaderStageFlags::empty()),
        ],
        "each keeps the nextStage its link required"
    );
    let variants: Vec<&SeenShader> = events[..events.len() - 1]
        .iter()
        .flat_map(|event| app_creation(event).1)
        .collect();
    assert!(
        variants
            .iter()
            .all(|info| info.flags == vk::ShaderCreateFlagsEXT::empty()),
        "the variants' calls unlinked too: {variants:#?}"
    );
    assert!(variants.iter().any(|info| info.stage == evaluation_stage));
    assert!(matches!(
        fx.state.objects.position_shaders.get(&handles[2]),
        Some(PositionShader::Baked { .. })
    ));

    // The spacing declared by the control shader alone: the link stays, the flip path.
    const SPACING_EQUAL: u32 = 1;
    let split = set(
        &with_mode(&control, SPACING_EQUAL),
        &without_mode(&evaluation, SPACING_EQUAL),
    );
    let (handles, events) = create(&split);
    assert_link_kept_on_the_flip_path(&fx, &events, handles[2]);
    fx.finish();
}
