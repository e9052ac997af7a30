//! Depth resolves driven through revz's hooks over the fake layer (`fake_chain`): the
//! swapped-resolve twin render pass (created, begun in place of the application's pass, and
//! destroyed with it), sources made native where a resolve cannot follow them, MIN/MAX swapped
//! in dynamic rendering, stencil resolves beside a swapped depth resolve (as the device's
//! `independentResolve` allows), and images made native followed across every resolve seen
//! before.
//!
//! Every test makes its own instance and device (flip mode, Vulkan 1.3) with its own dispatch
//! tables, gets revz's hooks from `vkGetDeviceProcAddr`, and checks what reaches the fake layer
//! below and what revz decided for the images.

use std::cell::RefCell;
use std::sync::Arc;

use ash::vk::{self, Handle};

use super::fake_chain::{self, Event, SeenDepthAttachment, SeenResolve, Tables};
use crate::command_state::Target;
use crate::policy::{Convention, ImageDepth, NativeReason};
use crate::state::{DeviceState, DispatchKey, DEVICES};

use vk::ResolveModeFlags as Mode;

const D32: vk::Format = vk::Format::D32_SFLOAT;
const D32_S8: vk::Format = vk::Format::D32_SFLOAT_S8_UINT;
/// Only rendered to: revz reverses it.
const RENDERED: vk::ImageUsageFlags = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
/// Read by shaders: native (`reverse_observable = none`).
const SAMPLED: vk::ImageUsageFlags = vk::ImageUsageFlags::from_raw(
    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT.as_raw() | vk::ImageUsageFlags::SAMPLED.as_raw(),
);
const MULTISAMPLED: vk::SampleCountFlags = vk::SampleCountFlags::TYPE_4;
const SINGLE: vk::SampleCountFlags = vk::SampleCountFlags::TYPE_1;
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};
const LAYOUT: vk::ImageLayout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;

use super::fake_chain::hook_set;

hook_set! {
    struct Hooks {
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
        cmd_begin_render_pass2: c"vkCmdBeginRenderPass2" => vk::PFN_vkCmdBeginRenderPass2,
        cmd_end_render_pass2: c"vkCmdEndRenderPass2" => vk::PFN_vkCmdEndRenderPass2,
        cmd_begin_rendering: c"vkCmdBeginRendering" => vk::PFN_vkCmdBeginRendering,
        cmd_end_rendering: c"vkCmdEndRendering" => vk::PFN_vkCmdEndRendering,
    }
}

/// What reached the fake layer's `vkCmdBeginRenderPass2`.
#[derive(Debug, PartialEq)]
struct PassBegun {
    render_pass: vk::RenderPass,
    framebuffer: vk::Framebuffer,
    clear_depths: Vec<f32>,
    /// Whether the application's own clear value array was passed down (not a copy).
    app_clear_values: bool,
}

/// A render pass created through revz, and what the fake layer's `vkCreateRenderPass2` saw.
struct CreatedPass {
    handle: vk::RenderPass,
    /// Each creation below (the application's pass first): its handle, its subpasses'
    /// resolves, and whether an allocator was passed.
    created: Vec<(vk::RenderPass, Vec<Option<SeenResolve>>, bool)>,
}

/// One instance and device over the fake layer, with one command buffer, and everything a
/// test creates through it (destroyed through revz's hooks by [`Fixture::finish`]).
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    state: Arc<DeviceState>,
    hooks: Hooks,
    pool: vk::CommandPool,
    command_buffer: vk::CommandBuffer,
    images: RefCell<Vec<vk::Image>>,
    views: RefCell<Vec<vk::ImageView>>,
    passes: RefCell<Vec<vk::RenderPass>>,
    framebuffers: RefCell<Vec<vk::Framebuffer>>,
}

impl Fixture {
    /// Flip mode, `reverse_observable = none`, a Vulkan 1.3 application and device, without
    /// `independentResolveNone` or `independentResolve`.
    fn new() -> Fixture {
        Fixture::with_resolve_independence(false, false)
    }

    /// [`Fixture::new`] on a device that reports `independentResolveNone` = `none` and
    /// `independentResolve` = `all`.
    fn with_resolve_independence(none: bool, all: bool) -> Fixture {
        let tables = Tables::fresh();
        fake_chain::set_resolve_independence(tables.instance, none, all);
        let (instance, _) =
            fake_chain::create_instance(&[(c"mode", c"flip"), (c"reverse_observable", c"none")]);

        let (physical, device, _) =
            fake_chain::create_device(tables, fake_chain::fake_get_device_proc_addr_with_passes);
        // SAFETY: the fake's live device.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device) })
            .expect("the device is registered");
        assert_eq!(state.settings.mode, crate::config::Mode::Flip);
        assert!(state.policy.is_active(), "flip mode acts on a 1.3 device");

        let hooks = Hooks::of(device);
        let pool = vk::CommandPool::from_raw(1);
        let allocate = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let mut command_buffer = vk::CommandBuffer::null();
        // SAFETY: a live device, a valid info and room for one handle.
        let result =
            unsafe { (hooks.allocate_command_buffers)(device, &allocate, &mut command_buffer) };
        assert_eq!(result, vk::Result::SUCCESS);
        // Creation left nothing the tests look at (the settings were passed down).
        fake_chain::take_events(tables.instance);
        assert_eq!(fake_chain::take_events(tables.device), []);
        Fixture {
            tables,
            instance,
            physical,
            device,
            state,
            hooks,
            pool,
            command_buffer,
            images: RefCell::default(),
            views: RefCell::default(),
            passes: RefCell::default(),
            framebuffers: RefCell::default(),
        }
    }

    /// What reached the fake layer for this device and its command buffer since last asked.
    fn events(&self) -> Vec<Event> {
        fake_chain::take_events(self.tables.device)
    }

    /// revz's decision for a depth image.
    fn depth(&self, image: vk::Image) -> ImageDepth {
        self.state
            .objects
            .images
            .get(&image)
            .expect("a tracked depth image")
            .depth
    }

    /// A depth image and a view of it.
    fn depth_image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        samples: vk::SampleCountFlags,
    ) -> (vk::Image, vk::ImageView) {
        let info = fake_chain::depth_image_info(format, EXTENT, usage, samples);
        let mut image = vk::Image::null();
        // SAFETY: a live device and a valid create info.
        let result =
            unsafe { (self.hooks.create_image)(self.device, &info, std::ptr::null(), &mut image) };
        assert_eq!(result, vk::Result::SUCCESS);
        self.images.borrow_mut().push(image);
        let info = fake_chain::depth_view_info(image, format);
        let mut view = vk::ImageView::null();
        // SAFETY: as above.
        let result = unsafe {
            (self.hooks.create_image_view)(self.device, &info, std::ptr::null(), &mut view)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.views.borrow_mut().push(view);
        (image, view)
    }

    /// A render pass of a multisampled D32 attachment (0, cleared) resolved with `mode` into a
    /// single-sampled one (1) in its first subpass, first in that subpass's pNext chain; the
    /// other subpasses use attachment 0 without a resolve.
    fn render_pass(
        &self,
        mode: vk::ResolveModeFlags,
        subpasses: usize,
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) -> CreatedPass {
        self.resolving_pass(D32, mode, Mode::NONE, subpasses, allocator)
    }

    /// [`Fixture::render_pass`] with both attachments of `format`, and the stencil resolved
    /// with `stencil_mode` beside the depth's `depth_mode`.
    fn resolving_pass(
        &self,
        format: vk::Format,
        depth_mode: vk::ResolveModeFlags,
        stencil_mode: vk::ResolveModeFlags,
        subpasses: usize,
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) -> CreatedPass {
        let attachment = |samples, load_op| {
            vk::AttachmentDescription2::default()
                .format(format)
                .samples(samples)
                .load_op(load_op)
                .store_op(vk::AttachmentStoreOp::STORE)
                .final_layout(LAYOUT)
        };
        let attachments = [
            attachment(MULTISAMPLED, vk::AttachmentLoadOp::CLEAR),
            attachment(SINGLE, vk::AttachmentLoadOp::DONT_CARE),
        ];
        let depth = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(LAYOUT)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let destination = vk::AttachmentReference2::default()
            .attachment(1)
            .layout(LAYOUT)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let mut resolve = vk::SubpassDescriptionDepthStencilResolve::default()
            .depth_resolve_mode(depth_mode)
            .stencil_resolve_mode(stencil_mode)
            .depth_stencil_resolve_attachment(&destination);
        let plain = vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth);
        let resolving = plain.push_next(&mut resolve);
        let mut all = vec![resolving];
        all.resize(subpasses, plain);
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(&all);
        let p_allocator = allocator.map_or(std::ptr::null(), |a| a as *const _);
        let mut handle = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_render_pass2)(self.device, &info, p_allocator, &mut handle)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.passes.borrow_mut().push(handle);
        let created = self
            .events()
            .into_iter()
            .map(|event| match event {
                Event::CreateRenderPass2 {
                    handle,
                    resolves,
                    allocator,
                } => (handle, resolves, allocator),
                other => panic!("only render pass creations reach the fake: {other:?}"),
            })
            .collect();
        CreatedPass { handle, created }
    }

    /// Destroys a render pass through revz's hook (not again at the end).
    fn destroy_render_pass(
        &self,
        pass: vk::RenderPass,
        allocator: Option<&vk::AllocationCallbacks<'_>>,
    ) {
        self.passes.borrow_mut().retain(|&p| p != pass);
        let p_allocator = allocator.map_or(std::ptr::null(), |a| a as *const _);
        // SAFETY: a live device and a render pass it created.
        unsafe { (self.hooks.destroy_render_pass)(self.device, pass, p_allocator) };
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
        let result = unsafe {
            (self.hooks.create_framebuffer)(self.device, &info, std::ptr::null(), &mut framebuffer)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.framebuffers.borrow_mut().push(framebuffer);
        framebuffer
    }

    fn begin_command_buffer(&self) {
        let begin = vk::CommandBufferBeginInfo::default();
        // SAFETY: the fixture's command buffer, not recording.
        let result = unsafe { (self.hooks.begin_command_buffer)(self.command_buffer, &begin) };
        assert_eq!(result, vk::Result::SUCCESS);
    }

    /// Records a render pass instance (both attachments' clear values at depth 1.0) and
    /// returns what the fake layer's begin saw.
    fn run_pass(&self, pass: vk::RenderPass, framebuffer: vk::Framebuffer) -> PassBegun {
        self.begin_command_buffer();
        let clear = vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        };
        let clears = [clear; 2];
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(pass)
            .framebuffer(framebuffer)
            .render_area(EXTENT.into())
            .clear_values(&clears);
        let subpass_begin = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
        let subpass_end = vk::SubpassEndInfo::default();
        // SAFETY: a recording primary command buffer and valid begin and end infos.
        unsafe {
            (self.hooks.cmd_begin_render_pass2)(self.command_buffer, &begin, &subpass_begin);
            (self.hooks.cmd_end_render_pass2)(self.command_buffer, &subpass_end);
        }
        match self.events().as_slice() {
            [Event::BeginRenderPass2 {
                render_pass,
                framebuffer,
                clear_values,
                clear_depths,
            }, Event::EndRenderPass2] => PassBegun {
                render_pass: *render_pass,
                framebuffer: *framebuffer,
                clear_depths: clear_depths.clone(),
                app_clear_values: *clear_values == clears.as_ptr() as usize,
            },
            other => panic!("one begin and one end reach the fake: {other:?}"),
        }
    }

    /// Records a dynamic rendering instance and returns the depth attachment the fake layer's
    /// begin saw, and whether it was the application's structure.
    fn run_rendering(
        &self,
        depth: &vk::RenderingAttachmentInfo<'_>,
        stencil: Option<&vk::RenderingAttachmentInfo<'_>>,
    ) -> (SeenDepthAttachment, bool) {
        self.begin_command_buffer();
        let mut info = vk::RenderingInfo::default()
            .render_area(EXTENT.into())
            .layer_count(1)
            .depth_attachment(depth);
        if let Some(stencil) = stencil {
            info = info.stencil_attachment(stencil);
        }
        // SAFETY: a recording primary command buffer and a valid rendering info.
        unsafe {
            (self.hooks.cmd_begin_rendering)(self.command_buffer, &info);
            (self.hooks.cmd_end_rendering)(self.command_buffer);
        }
        match self.events().as_slice() {
            [Event::BeginRendering { depth: Some(seen) }, Event::EndRendering] => {
                let app_structure = seen.address == depth as *const _ as usize;
                (*seen, app_structure)
            }
            other => panic!("one begin and one end reach the fake: {other:?}"),
        }
    }

    /// Destroys everything through revz's hooks, then the device and the instance, and
    /// reclaims the fake objects.
    fn finish(self) {
        // SAFETY: objects of this live device, no longer in use, each destroyed once.
        unsafe {
            let device = self.device;
            let hooks = &self.hooks;
            (hooks.free_command_buffers)(device, self.pool, 1, &self.command_buffer);
            (hooks.destroy_command_pool)(device, self.pool, std::ptr::null());
            for &framebuffer in self.framebuffers.borrow().iter() {
                (hooks.destroy_framebuffer)(device, framebuffer, std::ptr::null());
            }
            for &pass in self.passes.borrow().iter() {
                (hooks.destroy_render_pass)(device, pass, std::ptr::null());
            }
            for &view in self.views.borrow().iter() {
                (hooks.destroy_image_view)(device, view, std::ptr::null());
            }
            for &image in self.images.borrow().iter() {
                (hooks.destroy_image)(device, image, std::ptr::null());
            }
        }
        for image in self.images.borrow().iter() {
            assert!(self.state.objects.images.get(image).is_none());
        }
        for pass in self.passes.borrow().iter() {
            assert!(self.state.objects.render_passes.get(pass).is_none());
        }
        // SAFETY: the fixture's objects, no longer in use.
        let device_events = unsafe {
            fake_chain::tear_down(self.tables, self.instance, self.physical, self.device)
        };
        assert_eq!(device_events.last(), Some(&Event::DestroyDevice));
    }
}

fn resolve(depth_mode: vk::ResolveModeFlags) -> Option<SeenResolve> {
    Some(SeenResolve {
        depth_mode,
        stencil_mode: Mode::NONE,
        attachment: 1,
    })
}

#[test]
fn a_min_or_max_resolve_between_reversed_images_begins_the_swapped_twin() {
    let fx = Fixture::new();
    for (mode, swapped) in [(Mode::MIN, Mode::MAX), (Mode::MAX, Mode::MIN)] {
        let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
        let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
        let pass = fx.render_pass(mode, 1, None);
        // The twin, then the application's pass (so that the driver's last word in any output
        // structure of the chain is about the application's pass): identical but for the
        // swapped mode.
        let [(twin, twin_resolves, false), (app, app_resolves, false)] = pass.created.as_slice()
        else {
            panic!("two creations, without allocators: {:?}", pass.created);
        };
        assert_eq!(*app, pass.handle);
        assert_ne!(twin, app);
        assert_eq!(app_resolves, &[resolve(mode)]);
        assert_eq!(twin_resolves, &[resolve(swapped)]);
        assert_eq!(
            fx.state
                .objects
                .render_passes
                .get(app)
                .and_then(|p| p.swapped_resolve_twin),
            Some(*twin)
        );

        let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
        assert!(fx.state.objects.image_reversed(source));
        assert!(fx.state.objects.image_reversed(destination));

        // The twin goes down with the application's framebuffer, and the cleared reversed
        // attachment's depth flipped (1 -> 0); the resolve target is not cleared.
        assert_eq!(
            fx.run_pass(pass.handle, framebuffer),
            PassBegun {
                render_pass: *twin,
                framebuffer,
                clear_depths: vec![0.0, 1.0],
                app_clear_values: false,
            },
            "{mode:?}"
        );
    }
    fx.finish();
}

#[test]
fn a_reversed_source_resolved_into_a_native_image_becomes_native_and_begins_the_app_pass() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, SAMPLED, SINGLE);
    assert!(fx.state.objects.image_reversed(source));
    assert_eq!(
        fx.depth(destination),
        ImageDepth::Native(NativeReason::ReadByShaders(vk::ImageUsageFlags::SAMPLED))
    );
    let pass = fx.render_pass(Mode::MIN, 1, None);
    assert_eq!(pass.created.len(), 2, "the pass has its twin");

    let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
    assert!(!fx.state.objects.image_reversed(source));
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::ResolvedIntoNative(destination))
    );

    // Everything native: the application's pass and clear values go down untouched.
    assert_eq!(
        fx.run_pass(pass.handle, framebuffer),
        PassBegun {
            render_pass: pass.handle,
            framebuffer,
            clear_depths: vec![1.0, 1.0],
            app_clear_values: true,
        }
    );
    // Native for life: a later framebuffer into a reversed image does not bring it back; that
    // image, receiving standard values, becomes native instead.
    let (later, reversed_view) = fx.depth_image(D32, RENDERED, SINGLE);
    fx.framebuffer(pass.handle, &[source_view, reversed_view]);
    assert!(!fx.state.objects.image_reversed(source));
    assert_eq!(
        fx.depth(later),
        ImageDepth::Native(NativeReason::ResolvedFromNative(source))
    );
    fx.finish();
}

#[test]
fn an_observable_source_resolved_into_a_reversed_image_makes_the_destination_native() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, SAMPLED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
    assert!(fx.state.objects.image_reversed(destination));
    let pass = fx.render_pass(Mode::AVERAGE, 1, None);
    let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
    assert_eq!(
        fx.depth(destination),
        ImageDepth::Native(NativeReason::ResolvedFromNative(source))
    );
    assert_eq!(
        fx.run_pass(pass.handle, framebuffer),
        PassBegun {
            render_pass: pass.handle,
            framebuffer,
            clear_depths: vec![1.0, 1.0],
            app_clear_values: true,
        }
    );
    fx.finish();
}

#[test]
fn a_min_resolve_in_a_pass_of_two_subpasses_gets_no_twin_and_demotes_its_source() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let pass = fx.render_pass(Mode::MIN, 2, None);
    assert_eq!(
        pass.created,
        [(pass.handle, vec![resolve(Mode::MIN), None], false)],
        "only the application's pass is created"
    );
    assert_eq!(
        fx.state
            .objects
            .render_passes
            .get(&pass.handle)
            .map(|p| p.swapped_resolve_twin),
        Some(None)
    );

    assert!(fx.state.objects.image_reversed(source));
    let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::UnswappableResolve)
    );
    assert_eq!(
        fx.depth(destination),
        ImageDepth::Native(NativeReason::ResolvedFromNative(source)),
        "the destination receives the native source's values"
    );
    assert_eq!(
        fx.run_pass(pass.handle, framebuffer),
        PassBegun {
            render_pass: pass.handle,
            framebuffer,
            clear_depths: vec![1.0, 1.0],
            app_clear_values: true,
        }
    );
    fx.finish();
}

#[test]
fn sample_zero_and_average_resolves_need_no_twin_and_keep_the_source_reversed() {
    let fx = Fixture::new();
    for mode in [Mode::SAMPLE_ZERO, Mode::AVERAGE] {
        let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
        let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
        let pass = fx.render_pass(mode, 1, None);
        assert_eq!(
            pass.created,
            [(pass.handle, vec![resolve(mode)], false)],
            "{mode:?}: no twin"
        );
        let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
        assert!(fx.state.objects.image_reversed(source), "{mode:?}");
        assert!(fx.state.objects.image_reversed(destination), "{mode:?}");
        // The application's pass, with the reversed attachment's clear flipped.
        assert_eq!(
            fx.run_pass(pass.handle, framebuffer),
            PassBegun {
                render_pass: pass.handle,
                framebuffer,
                clear_depths: vec![0.0, 1.0],
                app_clear_values: false,
            },
            "{mode:?}"
        );
    }
    fx.finish();
}

#[test]
fn destroying_a_render_pass_destroys_its_twin_first_without_the_app_allocator() {
    let fx = Fixture::new();
    let allocator = vk::AllocationCallbacks::default();
    let pass = fx.render_pass(Mode::MIN, 1, Some(&allocator));
    // revz's twin with no allocator; the application's pass with its own.
    let [(twin, _, false), (app, _, true)] = pass.created.as_slice() else {
        panic!("the application's pass and its twin: {:?}", pass.created);
    };
    let (app, twin) = (*app, *twin);
    fx.destroy_render_pass(pass.handle, Some(&allocator));
    assert_eq!(
        fx.events(),
        [
            Event::DestroyRenderPass {
                handle: twin,
                allocator: false
            },
            Event::DestroyRenderPass {
                handle: app,
                allocator: true
            },
        ]
    );
    assert!(fx.state.objects.render_passes.get(&app).is_none());

    // A pass without a twin: only the application's pass is destroyed.
    let plain = fx.render_pass(Mode::AVERAGE, 1, None);
    assert_eq!(plain.created.len(), 1);
    fx.destroy_render_pass(plain.handle, None);
    assert_eq!(
        fx.events(),
        [Event::DestroyRenderPass {
            handle: plain.handle,
            allocator: false
        }]
    );
    fx.finish();
}

/// A depth attachment of dynamic rendering: cleared to 1.0, resolved with `mode`.
fn rendering_depth(
    view: vk::ImageView,
    mode: vk::ResolveModeFlags,
    resolve_view: vk::ImageView,
) -> vk::RenderingAttachmentInfo<'static> {
    vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(LAYOUT)
        .resolve_mode(mode)
        .resolve_image_view(resolve_view)
        .resolve_image_layout(LAYOUT)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::DONT_CARE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        })
}

#[test]
fn dynamic_rendering_swaps_min_and_max_between_reversed_images() {
    let fx = Fixture::new();
    for (mode, swapped) in [(Mode::MIN, Mode::MAX), (Mode::MAX, Mode::MIN)] {
        let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
        let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
        let depth = rendering_depth(source_view, mode, destination_view);
        let (seen, app_structure) = fx.run_rendering(&depth, None);
        assert_eq!(
            (
                seen.view,
                seen.resolve_view,
                seen.resolve_mode,
                seen.clear_depth
            ),
            (source_view, destination_view, swapped, 0.0),
            "{mode:?}"
        );
        assert!(!app_structure, "a copy goes down");
        assert_eq!(
            depth.resolve_mode, mode,
            "the application's structure is kept"
        );
        assert!(fx.state.objects.image_reversed(source));
        assert!(fx.state.objects.image_reversed(destination));
    }
    fx.finish();
}

#[test]
fn dynamic_rendering_into_a_native_image_demotes_the_source_and_passes_the_app_values() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, SAMPLED, SINGLE);
    assert!(fx.state.objects.image_reversed(source));
    let depth = rendering_depth(source_view, Mode::MIN, destination_view);
    let (seen, app_structure) = fx.run_rendering(&depth, None);
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::ResolvedIntoNative(destination))
    );
    assert_eq!(
        (seen.resolve_mode, seen.clear_depth),
        (Mode::MIN, 1.0),
        "mode and clear value unchanged"
    );
    assert!(app_structure, "the application's structure goes down");
    fx.finish();
}

#[test]
fn dynamic_rendering_with_a_stencil_resolve_demotes_a_min_depth_resolve() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32_S8, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32_S8, RENDERED, SINGLE);
    let depth = rendering_depth(source_view, Mode::MIN, destination_view);
    // The same attachment's stencil, resolved with the same mode (no independentResolve).
    let stencil = rendering_depth(source_view, Mode::MIN, destination_view);
    let (seen, app_structure) = fx.run_rendering(&depth, Some(&stencil));
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::UnswappableResolve)
    );
    assert_eq!(
        fx.depth(destination),
        ImageDepth::Native(NativeReason::ResolvedFromNative(source))
    );
    assert_eq!((seen.resolve_mode, seen.clear_depth), (Mode::MIN, 1.0));
    assert!(app_structure);
    fx.finish();
}

/// A twin's resolve structure (or the application's), as the fake saw it.
fn resolve_pair(
    depth_mode: vk::ResolveModeFlags,
    stencil_mode: vk::ResolveModeFlags,
) -> SeenResolve {
    SeenResolve {
        depth_mode,
        stencil_mode,
        attachment: 1,
    }
}

#[test]
fn a_stencil_resolve_beside_a_min_depth_resolve_gets_a_twin_where_the_device_allows_the_pair() {
    // (independentResolveNone, independentResolve, the stencil mode, whether a twin is made)
    for (none, all, stencil, twin_expected) in [
        (true, true, Mode::MIN, true),
        (true, true, Mode::SAMPLE_ZERO, true),
        (true, false, Mode::NONE, true),
        (true, false, Mode::MIN, false),
        (false, false, Mode::MIN, false),
    ] {
        let case = format!("none {none}, all {all}, stencil {stencil:?}");
        let fx = Fixture::with_resolve_independence(none, all);
        let (source, source_view) = fx.depth_image(D32_S8, RENDERED, MULTISAMPLED);
        let (destination, destination_view) = fx.depth_image(D32_S8, RENDERED, SINGLE);
        let pass = fx.resolving_pass(D32_S8, Mode::MIN, stencil, 1, None);
        let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
        let begun = fx.run_pass(pass.handle, framebuffer);
        if twin_expected {
            // Only the depth mode is swapped; the stencil keeps the application's.
            let [(twin, twin_resolves, _), (app, app_resolves, _)] = pass.created.as_slice() else {
                panic!(
                    "{case}: a twin and the application's pass: {:?}",
                    pass.created
                );
            };
            assert_eq!(
                app_resolves,
                &[Some(resolve_pair(Mode::MIN, stencil))],
                "{case}"
            );
            assert_eq!(
                twin_resolves,
                &[Some(resolve_pair(Mode::MAX, stencil))],
                "{case}"
            );
            assert_eq!((begun.render_pass, *app), (*twin, pass.handle), "{case}");
            assert!(fx.state.objects.image_reversed(source), "{case}");
            assert!(fx.state.objects.image_reversed(destination), "{case}");
        } else {
            assert_eq!(pass.created.len(), 1, "{case}: no twin");
            assert_eq!(begun.render_pass, pass.handle, "{case}");
            assert_eq!(
                fx.depth(source),
                ImageDepth::Native(NativeReason::UnswappableResolve),
                "{case}"
            );
            assert_eq!(
                fx.depth(destination),
                ImageDepth::Native(NativeReason::ResolvedFromNative(source)),
                "{case}"
            );
        }
        fx.finish();
    }
}

#[test]
fn a_stencil_mode_beside_a_resolve_attachment_without_stencil_does_not_block_the_twin() {
    // No independence at all: the spec pairs the modes only where the resolve attachment has a
    // stencil component, and D32 has none, so the stencil mode is ignored.
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let pass = fx.resolving_pass(D32, Mode::MAX, Mode::SAMPLE_ZERO, 1, None);
    let [(twin, twin_resolves, _), (_, app_resolves, _)] = pass.created.as_slice() else {
        panic!("a twin and the application's pass: {:?}", pass.created);
    };
    assert_eq!(
        app_resolves,
        &[Some(resolve_pair(Mode::MAX, Mode::SAMPLE_ZERO))]
    );
    assert_eq!(
        twin_resolves,
        &[Some(resolve_pair(Mode::MIN, Mode::SAMPLE_ZERO))]
    );
    let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
    assert_eq!(fx.run_pass(pass.handle, framebuffer).render_pass, *twin);
    assert!(fx.state.objects.image_reversed(source));
    assert!(fx.state.objects.image_reversed(destination));
    fx.finish();
}

#[test]
fn dynamic_rendering_swaps_a_depth_resolve_beside_a_stencil_resolve_the_device_pairs_with_it() {
    // (independentResolveNone, independentResolve, the stencil mode, whether depth is swapped)
    for (none, all, stencil_mode, swap_expected) in [
        (true, true, Mode::MIN, true),
        (true, true, Mode::SAMPLE_ZERO, true),
        (true, false, Mode::NONE, true),
        (true, false, Mode::MIN, false),
        (false, false, Mode::MIN, false),
    ] {
        let case = format!("none {none}, all {all}, stencil {stencil_mode:?}");
        let fx = Fixture::with_resolve_independence(none, all);
        let (source, source_view) = fx.depth_image(D32_S8, RENDERED, MULTISAMPLED);
        let (destination, destination_view) = fx.depth_image(D32_S8, RENDERED, SINGLE);
        let depth = rendering_depth(source_view, Mode::MIN, destination_view);
        let stencil = rendering_depth(source_view, stencil_mode, destination_view);
        let (seen, app_structure) = fx.run_rendering(&depth, Some(&stencil));
        if swap_expected {
            assert_eq!(
                (seen.resolve_mode, seen.clear_depth),
                (Mode::MAX, 0.0),
                "{case}"
            );
            assert!(!app_structure, "{case}: a copy goes down");
            assert!(fx.state.objects.image_reversed(source), "{case}");
            assert!(fx.state.objects.image_reversed(destination), "{case}");
        } else {
            assert_eq!(
                (seen.resolve_mode, seen.clear_depth),
                (Mode::MIN, 1.0),
                "{case}"
            );
            assert!(app_structure, "{case}");
            assert_eq!(
                fx.depth(source),
                ImageDepth::Native(NativeReason::UnswappableResolve),
                "{case}"
            );
        }
        assert_eq!(
            stencil.resolve_mode, stencil_mode,
            "{case}: the stencil is never changed"
        );
        fx.finish();
    }
}

#[test]
fn dynamic_rendering_ignores_the_resolve_mode_of_a_stencil_attachment_without_a_view() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let depth = rendering_depth(source_view, Mode::MIN, destination_view);
    // No view: the spec does not pair its mode with the depth one (06104, 06105).
    let stencil = rendering_depth(vk::ImageView::null(), Mode::MIN, vk::ImageView::null());
    let (seen, app_structure) = fx.run_rendering(&depth, Some(&stencil));
    assert_eq!((seen.resolve_mode, seen.clear_depth), (Mode::MAX, 0.0));
    assert!(!app_structure);
    assert!(fx.state.objects.image_reversed(source));
    assert!(fx.state.objects.image_reversed(destination));
    fx.finish();
}

#[test]
fn resolves_seen_after_a_demotion_already_followed_it_one_resolve_at_a_time() {
    // What settling each resolve once, as it is seen, always did: a native source makes its
    // destination native, and that destination then makes a later source into it native.
    let fx = Fixture::new();
    let (observed, observed_view) = fx.depth_image(D32, SAMPLED, MULTISAMPLED);
    let (shared, shared_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let (later, later_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let pass = fx.render_pass(Mode::AVERAGE, 1, None);
    fx.framebuffer(pass.handle, &[observed_view, shared_view]);
    assert_eq!(
        fx.depth(shared),
        ImageDepth::Native(NativeReason::ResolvedFromNative(observed))
    );
    fx.framebuffer(pass.handle, &[later_view, shared_view]);
    assert_eq!(
        fx.depth(later),
        ImageDepth::Native(NativeReason::ResolvedIntoNative(shared))
    );
    fx.finish();
}

#[test]
fn a_destination_made_native_later_makes_the_sources_resolved_into_it_before_native() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (shared, shared_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let (observed, observed_view) = fx.depth_image(D32, SAMPLED, MULTISAMPLED);
    // A MIN resolve between reversed images: the twin is begun.
    let min = fx.render_pass(Mode::MIN, 1, None);
    let framebuffer = fx.framebuffer(min.handle, &[source_view, shared_view]);
    assert_eq!(
        fx.run_pass(min.handle, framebuffer).render_pass,
        min.created[0].0
    );
    // Another source, one shaders read, resolves into the same image: that image must hold
    // standard values, so the first source may no longer resolve reversed ones into it.
    let average = fx.render_pass(Mode::AVERAGE, 1, None);
    fx.framebuffer(average.handle, &[observed_view, shared_view]);
    assert_eq!(
        fx.depth(shared),
        ImageDepth::Native(NativeReason::ResolvedFromNative(observed))
    );
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::ResolvedIntoNative(shared))
    );
    // The application's pass and values from then on.
    assert_eq!(
        fx.run_pass(min.handle, framebuffer),
        PassBegun {
            render_pass: min.handle,
            framebuffer,
            clear_depths: vec![1.0, 1.0],
            app_clear_values: true,
        }
    );
    assert_eq!(
        fx.state.objects.resolve_pairs.count(),
        0,
        "nothing left to follow"
    );
    fx.finish();
}

#[test]
fn a_source_made_native_later_makes_the_images_it_resolved_into_before_native() {
    let fx = Fixture::new();
    let (source, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (reversed, reversed_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let (observed, observed_view) = fx.depth_image(D32, SAMPLED, SINGLE);
    let depth = rendering_depth(source_view, Mode::AVERAGE, reversed_view);
    let (seen, _) = fx.run_rendering(&depth, None);
    assert_eq!(seen.clear_depth, 0.0, "both reversed");
    // The same source resolved into an image shaders read: the source becomes native, and the
    // image it resolved into before receives standard values from then on.
    let pass = fx.render_pass(Mode::AVERAGE, 1, None);
    fx.framebuffer(pass.handle, &[source_view, observed_view]);
    assert_eq!(
        fx.depth(source),
        ImageDepth::Native(NativeReason::ResolvedIntoNative(observed))
    );
    assert_eq!(
        fx.depth(reversed),
        ImageDepth::Native(NativeReason::ResolvedFromNative(source))
    );
    let (seen, app_structure) = fx.run_rendering(&depth, None);
    assert_eq!(seen.clear_depth, 1.0);
    assert!(app_structure);
    fx.finish();
}

#[test]
fn a_demotion_is_followed_across_every_resolve_it_reaches_until_nothing_changes() {
    // first -> first_target <- second -> second_target <- third -> third_target, all reversed;
    // then an image shaders read resolves into third_target. Each demotion reaches the next
    // resolve, back to `first`.
    let fx = Fixture::new();
    let pass = fx.render_pass(Mode::AVERAGE, 1, None);
    let sources: Vec<_> = (0..3)
        .map(|_| fx.depth_image(D32, RENDERED, MULTISAMPLED))
        .collect();
    let targets: Vec<_> = (0..3)
        .map(|_| fx.depth_image(D32, RENDERED, SINGLE))
        .collect();
    for (index, &(_, source_view)) in sources.iter().enumerate() {
        fx.framebuffer(pass.handle, &[source_view, targets[index].1]);
        if let Some(&(_, previous_target)) = index.checked_sub(1).and_then(|i| targets.get(i)) {
            fx.framebuffer(pass.handle, &[source_view, previous_target]);
        }
    }
    for &(image, _) in sources.iter().chain(&targets) {
        assert!(fx.state.objects.image_reversed(image));
    }
    assert_eq!(fx.state.objects.resolve_pairs.count(), 5);

    let (observed, observed_view) = fx.depth_image(D32, SAMPLED, MULTISAMPLED);
    fx.framebuffer(pass.handle, &[observed_view, targets[2].1]);
    assert_eq!(
        fx.depth(targets[2].0),
        ImageDepth::Native(NativeReason::ResolvedFromNative(observed))
    );
    for index in (0..3).rev() {
        assert_eq!(
            fx.depth(sources[index].0),
            ImageDepth::Native(NativeReason::ResolvedIntoNative(targets[index].0)),
            "source {index}"
        );
        if index > 0 {
            assert_eq!(
                fx.depth(targets[index - 1].0),
                ImageDepth::Native(NativeReason::ResolvedFromNative(sources[index].0)),
                "target {}",
                index - 1
            );
        }
    }
    assert_eq!(fx.state.objects.resolve_pairs.count(), 0);
    fx.finish();
}

#[test]
fn a_destroyed_image_takes_its_resolve_pairs_with_it() {
    let fx = Fixture::new();
    let (_, source_view) = fx.depth_image(D32, RENDERED, MULTISAMPLED);
    let (destination, destination_view) = fx.depth_image(D32, RENDERED, SINGLE);
    let pass = fx.render_pass(Mode::AVERAGE, 1, None);
    fx.framebuffer(pass.handle, &[source_view, destination_view]);
    assert_eq!(fx.state.objects.resolve_pairs.count(), 1);
    // Beginning the pass again records nothing new.
    let framebuffer = fx.framebuffer(pass.handle, &[source_view, destination_view]);
    fx.run_pass(pass.handle, framebuffer);
    assert_eq!(fx.state.objects.resolve_pairs.count(), 1);
    fx.images.borrow_mut().retain(|&image| image != destination);
    // SAFETY: a live device and an image it created, destroyed once.
    unsafe { (fx.hooks.destroy_image)(fx.device, destination, std::ptr::null()) };
    assert_eq!(fx.state.objects.resolve_pairs.count(), 0);
    fx.finish();
}

/// The depth convention is decided once, at the first reversed attachment a command buffer
/// commits to: a clear to 0 seen later (in another command buffer of the same frame) must not
/// turn reversal off, or command buffers recorded before would draw reversed and the new ones
/// LESS against reversed contents.
#[test]
fn a_clear_to_0_after_the_first_reversed_pass_leaves_reversal_on() {
    let fx = Fixture::new();
    let (_, view) = fx.depth_image(D32, RENDERED, SINGLE);
    let first = rendering_depth(view, Mode::NONE, vk::ImageView::null());
    let (seen, _) = fx.run_rendering(&first, None);
    assert_eq!(seen.clear_depth, 0.0, "1.0 is reversed to 0.0");
    // A GREATER pipeline and a clear to 0 after the decision: weak, late evidence.
    fx.state
        .observed
        .note_pipeline_compare_op(vk::CompareOp::GREATER);
    let mut late = first;
    late.clear_value.depth_stencil.depth = 0.0;
    let (seen, _) = fx.run_rendering(&late, None);
    assert_eq!(seen.clear_depth, 1.0, "still reversed: 0.0 becomes 1.0");
    assert_eq!(fx.state.observed.convention(), Some(Convention::Standard));
    fx.finish();
}

/// Strong evidence before the first reversed pass (a GREATER pipeline, then the attachment
/// cleared to 0): the application renders reversed itself and is left alone.
#[test]
fn strong_evidence_before_the_first_pass_leaves_a_reversed_application_alone() {
    let fx = Fixture::new();
    let (image, view) = fx.depth_image(D32, RENDERED, SINGLE);
    fx.state
        .observed
        .note_pipeline_compare_op(vk::CompareOp::GREATER);
    let mut depth = rendering_depth(view, Mode::NONE, vk::ImageView::null());
    depth.clear_value.depth_stencil.depth = 0.0;
    let (seen, app_structure) = fx.run_rendering(&depth, None);
    assert_eq!(seen.clear_depth, 0.0);
    assert!(
        app_structure,
        "the application's attachment goes down untouched"
    );
    assert_eq!(
        fx.state.observed.convention(),
        Some(Convention::AppReversed)
    );
    // The image itself stays what the policy made it: only the convention differs.
    assert!(fx.state.objects.image_reversed(image));
    // A clear to 1.0 later is the application's too.
    depth.clear_value.depth_stencil.depth = 1.0;
    let (seen, app_structure) = fx.run_rendering(&depth, None);
    assert_eq!((seen.clear_depth, app_structure), (1.0, true));
    fx.finish();
}

/// A secondary whose inheritance names no framebuffer (dynamic rendering: only formats)
/// follows the target its pass was last begun with for secondaries: a sampled (native) shadow
/// map and a reversed main attachment of the same format no longer make it guess "reversed".
#[test]
fn a_secondary_without_framebuffer_follows_the_rendering_last_begun_for_secondaries() {
    let fx = Fixture::new();
    let (shadow, shadow_view) = fx.depth_image(D32, SAMPLED, SINGLE);
    let (main, main_view) = fx.depth_image(D32, RENDERED, SINGLE);
    assert!(!fx.state.objects.image_reversed(shadow));
    assert!(fx.state.objects.image_reversed(main));
    let allocate = vk::CommandBufferAllocateInfo::default()
        .command_pool(fx.pool)
        .level(vk::CommandBufferLevel::SECONDARY)
        .command_buffer_count(1);
    let mut secondary = vk::CommandBuffer::null();
    // SAFETY: a live device, a valid info and room for one handle.
    let result =
        unsafe { (fx.hooks.allocate_command_buffers)(fx.device, &allocate, &mut secondary) };
    assert_eq!(result, vk::Result::SUCCESS);
    // What a secondary continuing a D32 rendering instance without a framebuffer assumes.
    let secondary_target = || {
        let formats = [];
        let mut rendering = vk::CommandBufferInheritanceRenderingInfo::default()
            .color_attachment_formats(&formats)
            .depth_attachment_format(D32)
            .rasterization_samples(SINGLE);
        let inheritance = vk::CommandBufferInheritanceInfo::default().push_next(&mut rendering);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE)
            .inheritance_info(&inheritance);
        // SAFETY: the secondary, not recording, and a valid begin info.
        let result = unsafe { (fx.hooks.begin_command_buffer)(secondary, &begin) };
        assert_eq!(result, vk::Result::SUCCESS);
        crate::objects::command_buffer(secondary)
            .expect("tracked")
            .state()
            .inherited()
    };
    // Before any rendering for secondaries: both kinds exist, reversed is the guess.
    assert_eq!(secondary_target(), Target::Reversed);
    let begin_for_secondaries = |view| {
        fx.begin_command_buffer();
        let depth = rendering_depth(view, Mode::NONE, vk::ImageView::null());
        let info = vk::RenderingInfo::default()
            .flags(vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS)
            .render_area(EXTENT.into())
            .layer_count(1)
            .depth_attachment(&depth);
        // SAFETY: a recording primary and a valid rendering info.
        unsafe {
            (fx.hooks.cmd_begin_rendering)(fx.command_buffer, &info);
            (fx.hooks.cmd_end_rendering)(fx.command_buffer);
        }
        fx.events();
    };
    // The shadow pass is recorded in secondaries: they draw into the native map.
    begin_for_secondaries(shadow_view);
    assert_eq!(secondary_target(), Target::Native);
    // Then the main pass.
    begin_for_secondaries(main_view);
    assert_eq!(secondary_target(), Target::Reversed);
    // SAFETY: the secondary is not in use.
    unsafe { (fx.hooks.free_command_buffers)(fx.device, fx.pool, 1, &secondary) };
    fx.finish();
}
