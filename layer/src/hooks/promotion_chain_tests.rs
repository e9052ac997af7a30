//! Depth format promotion (#15) driven through revz's hooks over the fake layer
//! (`fake_chain`): UNORM depth images created and viewed in float formats (and the images that
//! keep their format, and why), the promoted twins of render passes (and of their
//! swapped-resolve twins), framebuffers of promoted images (imageless ones too) created with
//! the twin, passes over them begun as the twin, pipelines' promoted variants made against the
//! twin or with float rendering formats and bound for draws into promoted attachments,
//! secondaries inheriting the twin or the float formats, constant depth bias converted to
//! float units, and framebuffers that mix both kinds created as the application asked.
//!
//! Every test makes its own instance and device (complementary mode unless it says otherwise,
//! Vulkan 1.3) with its own dispatch tables, asks the fake for its detail events
//! (`fake_chain::record_details`), gets revz's hooks from `vkGetDeviceProcAddr`, and checks
//! what reaches the fake layer below. [`Fixture::finish`] destroys everything through the hooks
//! and checks that every object the fake created (twins and variants included) was destroyed
//! once and that revz forgot it.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::ffi::{c_void, CStr};
use std::sync::Arc;

use ash::vk::{self, Handle};

use super::fake_chain::{
    self, hook_set, seen_image, seen_pipeline, Event, SeenImage, SeenInheritance, SeenPipeline,
    SeenRendering, Tables,
};
use crate::objects::{RenderPassInfo, SecondaryPass};
use crate::policy::ImageDepth;
use crate::shader::test_spirv::{self, PLAIN};
use crate::state::{DeviceState, DispatchKey, DEVICES};

const D16: vk::Format = vk::Format::D16_UNORM;
const D16_S8: vk::Format = vk::Format::D16_UNORM_S8_UINT;
const X8_D24: vk::Format = vk::Format::X8_D24_UNORM_PACK32;
const D24_S8: vk::Format = vk::Format::D24_UNORM_S8_UINT;
const D32: vk::Format = vk::Format::D32_SFLOAT;
const D32_S8: vk::Format = vk::Format::D32_SFLOAT_S8_UINT;
const COLOR: vk::Format = vk::Format::R8G8B8A8_UNORM;
const MAIN: &CStr = c"main";
const EXTENT: vk::Extent2D = vk::Extent2D {
    width: 64,
    height: 64,
};
const LAYOUT: vk::ImageLayout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
const SINGLE: vk::SampleCountFlags = vk::SampleCountFlags::TYPE_1;
const MULTISAMPLED: vk::SampleCountFlags = vk::SampleCountFlags::TYPE_4;
/// Only rendered to: promoted, and reversed.
const ATTACHMENT: vk::ImageUsageFlags = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
/// Aliased memory: an image of these flags keeps its UNORM format (the application places its
/// memory by the format's sizes) and is still reversed.
const KEPT_FLAGS: vk::ImageCreateFlags = vk::ImageCreateFlags::ALIAS;
/// Read by shaders as a storage image (which no read twin serves, and no shader rewrite
/// converts): promoted (a resolve needs one format at both ends), but native.
const READ_IN_PASS: vk::ImageUsageFlags =
    vk::ImageUsageFlags::from_raw(ATTACHMENT.as_raw() | vk::ImageUsageFlags::STORAGE.as_raw());
const COMPLEMENTARY: &[(&CStr, &CStr)] = &[(c"mode", c"complementary")];

hook_set! {
    struct Hooks {
        create_image: c"vkCreateImage" => vk::PFN_vkCreateImage,
        destroy_image: c"vkDestroyImage" => vk::PFN_vkDestroyImage,
        create_image_view: c"vkCreateImageView" => vk::PFN_vkCreateImageView,
        destroy_image_view: c"vkDestroyImageView" => vk::PFN_vkDestroyImageView,
        create_render_pass: c"vkCreateRenderPass" => vk::PFN_vkCreateRenderPass,
        create_render_pass2: c"vkCreateRenderPass2" => vk::PFN_vkCreateRenderPass2,
        destroy_render_pass: c"vkDestroyRenderPass" => vk::PFN_vkDestroyRenderPass,
        create_framebuffer: c"vkCreateFramebuffer" => vk::PFN_vkCreateFramebuffer,
        destroy_framebuffer: c"vkDestroyFramebuffer" => vk::PFN_vkDestroyFramebuffer,
        create_shader_module: c"vkCreateShaderModule" => vk::PFN_vkCreateShaderModule,
        destroy_shader_module: c"vkDestroyShaderModule" => vk::PFN_vkDestroyShaderModule,
        create_graphics_pipelines: c"vkCreateGraphicsPipelines" => vk::PFN_vkCreateGraphicsPipelines,
        destroy_pipeline: c"vkDestroyPipeline" => vk::PFN_vkDestroyPipeline,
        allocate_command_buffers: c"vkAllocateCommandBuffers" => vk::PFN_vkAllocateCommandBuffers,
        free_command_buffers: c"vkFreeCommandBuffers" => vk::PFN_vkFreeCommandBuffers,
        destroy_command_pool: c"vkDestroyCommandPool" => vk::PFN_vkDestroyCommandPool,
        begin_command_buffer: c"vkBeginCommandBuffer" => vk::PFN_vkBeginCommandBuffer,
        cmd_begin_render_pass: c"vkCmdBeginRenderPass" => vk::PFN_vkCmdBeginRenderPass,
        cmd_end_render_pass: c"vkCmdEndRenderPass" => vk::PFN_vkCmdEndRenderPass,
        cmd_begin_render_pass2: c"vkCmdBeginRenderPass2" => vk::PFN_vkCmdBeginRenderPass2,
        cmd_end_render_pass2: c"vkCmdEndRenderPass2" => vk::PFN_vkCmdEndRenderPass2,
        cmd_begin_rendering: c"vkCmdBeginRendering" => vk::PFN_vkCmdBeginRendering,
        cmd_end_rendering: c"vkCmdEndRendering" => vk::PFN_vkCmdEndRendering,
        cmd_bind_pipeline: c"vkCmdBindPipeline" => vk::PFN_vkCmdBindPipeline,
        cmd_set_depth_bias: c"vkCmdSetDepthBias" => vk::PFN_vkCmdSetDepthBias,
        cmd_set_depth_bias2: c"vkCmdSetDepthBias2EXT" => vk::PFN_vkCmdSetDepthBias2EXT,
        cmd_set_depth_clamp_range: c"vkCmdSetDepthClampRangeEXT"
            => crate::vk_ext::PfnCmdSetDepthClampRange,
        cmd_next_subpass2: c"vkCmdNextSubpass2" => vk::PFN_vkCmdNextSubpass2,
        cmd_draw: c"vkCmdDraw" => vk::PFN_vkCmdDraw,
        update_descriptor_sets: c"vkUpdateDescriptorSets" => vk::PFN_vkUpdateDescriptorSets,
        cmd_push_descriptor_set2: c"vkCmdPushDescriptorSet2KHR" => vk::PFN_vkCmdPushDescriptorSet2KHR,
        cmd_copy_image: c"vkCmdCopyImage" => vk::PFN_vkCmdCopyImage,
    }
}

/// One render pass creation the fake saw: the handle, the attachment formats, and each
/// subpass's depth resolve mode (NONE without one; none for the first version).
#[derive(Clone, Debug, PartialEq, Eq)]
struct PassCreated {
    handle: vk::RenderPass,
    formats: Vec<vk::Format>,
    resolves: Vec<vk::ResolveModeFlags>,
}

/// A framebuffer creation as the fake saw it.
#[derive(Clone, Debug, PartialEq, Eq)]
struct FramebufferCreated {
    handle: vk::Framebuffer,
    render_pass: vk::RenderPass,
    /// The application's create info went down itself (not a copy).
    app_info: bool,
    image_view_formats: Option<Vec<Vec<vk::Format>>>,
}

/// A view creation as the fake saw it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ViewCreated {
    handle: vk::ImageView,
    format: vk::Format,
    /// The application's create info went down itself (not a copy).
    app_info: bool,
}

/// What reached the fake while a command buffer recorded: the render passes begun (either
/// version), the pipelines bound and the depth biases set, in order.
#[derive(Debug, Default, PartialEq)]
struct Recorded {
    passes: Vec<vk::RenderPass>,
    binds: Vec<vk::Pipeline>,
    biases: Vec<[f32; 3]>,
    /// `vkCmdSetDepthClampRangeEXT`'s mode and user-defined range.
    clamp_ranges: Vec<(i32, Option<(f32, f32)>)>,
}

/// One pipeline creation the fake saw (one create info per call).
#[derive(Clone, Debug)]
struct PipelineCreated {
    handle: vk::Pipeline,
    info: SeenPipeline,
}

/// What a pipeline renders into.
#[derive(Clone, Copy, Debug)]
enum PipelineTarget {
    Pass(vk::RenderPass),
    Subpass(vk::RenderPass, u32),
    /// Dynamic rendering with these depth and stencil formats (and one color attachment).
    Rendering(vk::Format, vk::Format),
}

/// One instance and device over the fake layer, and everything a test creates through it
/// (destroyed through revz's hooks by [`Fixture::finish`]).
struct Fixture {
    tables: Tables,
    instance: vk::Instance,
    physical: vk::PhysicalDevice,
    device: vk::Device,
    state: Arc<DeviceState>,
    hooks: Hooks,
    pool: vk::CommandPool,
    /// Every event taken from the fake, for the leak check at the end.
    history: RefCell<Vec<Event>>,
    images: RefCell<Vec<vk::Image>>,
    views: RefCell<Vec<vk::ImageView>>,
    passes: RefCell<Vec<vk::RenderPass>>,
    framebuffers: RefCell<Vec<vk::Framebuffer>>,
    modules: RefCell<Vec<vk::ShaderModule>>,
    pipelines: RefCell<Vec<vk::Pipeline>>,
    command_buffers: RefCell<Vec<vk::CommandBuffer>>,
    /// The vertex and fragment modules of the pipelines (made on first use).
    shaders: RefCell<Option<(vk::ShaderModule, vk::ShaderModule)>>,
}

impl Fixture {
    /// Complementary mode (promotion on: `promote_depth_formats = auto`).
    fn new() -> Fixture {
        Fixture::with(COMPLEMENTARY, &[])
    }

    /// A device of `settings` whose physical device refuses images of the formats `refused`.
    fn with(settings: &[(&'static CStr, &'static CStr)], refused: &[vk::Format]) -> Fixture {
        Fixture::with_extensions(settings, refused, &[])
    }

    /// [`Fixture::with`], the application enabling the device extensions `extensions`.
    fn with_extensions(
        settings: &[(&'static CStr, &'static CStr)],
        refused: &[vk::Format],
        extensions: &[&CStr],
    ) -> Fixture {
        let tables = Tables::fresh();
        fake_chain::record_details(tables.device);
        // Memory for read twins (every image here that shaders sample gets one).
        fake_chain::give_memory(tables.instance);
        for &format in refused {
            fake_chain::refuse_image_format(tables.instance, format);
        }
        let (instance, _) = fake_chain::create_instance(settings);
        let (physical, device, _) = fake_chain::create_device_with_extensions(
            tables,
            fake_chain::fake_get_device_proc_addr_with_pipelines,
            extensions,
        );
        // SAFETY: the fake's live device.
        let state = DEVICES
            .get(unsafe { DispatchKey::of(device) })
            .expect("the device is registered");
        assert!(state.policy.is_active());
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
            pool: vk::CommandPool::from_raw(0x9001),
            history: RefCell::default(),
            images: RefCell::default(),
            views: RefCell::default(),
            passes: RefCell::default(),
            framebuffers: RefCell::default(),
            modules: RefCell::default(),
            pipelines: RefCell::default(),
            command_buffers: RefCell::default(),
            shaders: RefCell::default(),
        }
    }

    /// What reached the fake layer for this device and its command buffers since last asked.
    fn events(&self) -> Vec<Event> {
        let events = fake_chain::take_events(self.tables.device);
        self.history.borrow_mut().extend(events.iter().cloned());
        events
    }

    /// Creates an image through revz: its handle and what the fake's `vkCreateImage` saw.
    fn create_image(&self, info: &vk::ImageCreateInfo<'_>) -> (vk::Image, SeenImage) {
        let mut image = vk::Image::null();
        // SAFETY: a live device and a valid create info.
        let result =
            unsafe { (self.hooks.create_image)(self.device, info, std::ptr::null(), &mut image) };
        assert_eq!(result, vk::Result::SUCCESS);
        self.images.borrow_mut().push(image);
        match self.events().as_slice() {
            [Event::CreateImage { handle, info }] if *handle == image => (image, info.clone()),
            other => panic!("one image creation reaches the fake: {other:#?}"),
        }
    }

    /// Creates a view of the depth aspect of `image` in `format` through revz.
    fn create_view(&self, image: vk::Image, format: vk::Format) -> ViewCreated {
        let info = fake_chain::depth_view_info(image, format);
        let mut view = vk::ImageView::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_image_view)(self.device, &info, std::ptr::null(), &mut view)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.views.borrow_mut().push(view);
        match self.events().as_slice() {
            [Event::CreateImageView {
                handle,
                address,
                image: seen_image,
                format,
            }] if *handle == view && *seen_image == image => ViewCreated {
                handle: view,
                format: *format,
                app_info: *address == &info as *const _ as usize,
            },
            other => panic!("one view creation reaches the fake: {other:#?}"),
        }
    }

    /// A 2D depth image of `format`, `usage` and `samples` (64x64, optimal tiling) and a view
    /// of it in `format`.
    fn depth_image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        samples: vk::SampleCountFlags,
    ) -> (vk::Image, vk::ImageView) {
        let info = fake_chain::depth_image_info(format, EXTENT, usage, samples);
        let (image, _) = self.create_image(&info);
        (image, self.create_view(image, format).handle)
    }

    /// A depth attachment as [`Self::depth_image`] makes it, with [`KEPT_FLAGS`]: it keeps its
    /// UNORM format, and is reversed.
    fn kept_depth_image(
        &self,
        format: vk::Format,
        samples: vk::SampleCountFlags,
    ) -> (vk::Image, vk::ImageView) {
        let info = vk::ImageCreateInfo {
            flags: KEPT_FLAGS,
            ..fake_chain::depth_image_info(format, EXTENT, ATTACHMENT, samples)
        };
        let (image, _) = self.create_image(&info);
        (image, self.create_view(image, format).handle)
    }

    /// The float format revz created `image` in, if it promoted it.
    fn promoted(&self, image: vk::Image) -> Option<vk::Format> {
        let info = self
            .state
            .objects
            .images
            .get(&image)
            .expect("a tracked image");
        info.promoted
    }

    /// What revz recorded of a render pass.
    fn pass_info(&self, pass: vk::RenderPass) -> Arc<RenderPassInfo> {
        self.state
            .objects
            .render_passes
            .get(&pass)
            .expect("a tracked render pass")
    }

    /// The render pass creations the fake saw since last asked.
    fn passes_created(&self) -> Vec<PassCreated> {
        let events = self.events();
        let mut created = Vec::new();
        let mut events = events.into_iter();
        while let Some(event) = events.next() {
            match event {
                Event::CreateRenderPass {
                    handle,
                    formats,
                    allocator: false,
                } => created.push(PassCreated {
                    handle,
                    formats,
                    resolves: Vec::new(),
                }),
                Event::CreateRenderPass2 {
                    handle,
                    resolves,
                    allocator: false,
                } => {
                    let Some(Event::RenderPass2Formats {
                        handle: formats_of,
                        formats,
                    }) = events.next()
                    else {
                        panic!("the formats follow each vkCreateRenderPass2");
                    };
                    assert_eq!(formats_of, handle);
                    created.push(PassCreated {
                        handle,
                        formats,
                        resolves: resolves
                            .iter()
                            .map(|r| r.map_or(vk::ResolveModeFlags::NONE, |r| r.depth_mode))
                            .collect(),
                    })
                }
                other => panic!("only render pass creations reach the fake: {other:?}"),
            }
        }
        created
    }

    /// A render pass (`vkCreateRenderPass2`) of one subpass drawing into a cleared depth
    /// attachment of `format` (0), and into a color attachment (1) if `color`. Returns the
    /// application's handle and every creation that reached the fake.
    fn depth_pass(&self, format: vk::Format, color: bool) -> (vk::RenderPass, Vec<PassCreated>) {
        let mut attachments = vec![vk::AttachmentDescription2::default()
            .format(format)
            .samples(SINGLE)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(vk::AttachmentLoadOp::CLEAR)
            .final_layout(LAYOUT)];
        if color {
            attachments.push(
                vk::AttachmentDescription2::default()
                    .format(COLOR)
                    .samples(SINGLE)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .final_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
            );
        }
        let depth = vk::AttachmentReference2::default()
            .attachment(0)
            .layout(LAYOUT)
            .aspect_mask(vk::ImageAspectFlags::DEPTH);
        let colors = [vk::AttachmentReference2::default()
            .attachment(1)
            .layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .aspect_mask(vk::ImageAspectFlags::COLOR)];
        let mut subpass = vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth);
        if color {
            subpass = subpass.color_attachments(&colors);
        }
        let subpasses = [subpass];
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(&subpasses);
        self.create_pass2(&info)
    }

    fn create_pass2(
        &self,
        info: &vk::RenderPassCreateInfo2<'_>,
    ) -> (vk::RenderPass, Vec<PassCreated>) {
        let mut pass = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_render_pass2)(self.device, info, std::ptr::null(), &mut pass)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.passes.borrow_mut().push(pass);
        (pass, self.passes_created())
    }

    /// [`Fixture::depth_pass`] (without color) through the first version,
    /// `vkCreateRenderPass`.
    fn depth_pass_v1(&self, format: vk::Format) -> (vk::RenderPass, Vec<PassCreated>) {
        let attachments = [vk::AttachmentDescription::default()
            .format(format)
            .samples(SINGLE)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .final_layout(LAYOUT)];
        let depth = vk::AttachmentReference::default()
            .attachment(0)
            .layout(LAYOUT);
        let subpasses = [vk::SubpassDescription::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth)];
        let info = vk::RenderPassCreateInfo::default()
            .attachments(&attachments)
            .subpasses(&subpasses);
        let mut pass = vk::RenderPass::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_render_pass)(self.device, &info, std::ptr::null(), &mut pass)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.passes.borrow_mut().push(pass);
        (pass, self.passes_created())
    }

    /// A render pass of one subpass: a multisampled depth attachment of `format` (0, cleared)
    /// resolved with `mode` into a single-sampled one (1).
    fn resolving_pass(
        &self,
        format: vk::Format,
        mode: vk::ResolveModeFlags,
    ) -> (vk::RenderPass, Vec<PassCreated>) {
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
        let reference = |attachment| {
            vk::AttachmentReference2::default()
                .attachment(attachment)
                .layout(LAYOUT)
                .aspect_mask(vk::ImageAspectFlags::DEPTH)
        };
        let (depth, destination) = (reference(0), reference(1));
        let mut resolve = vk::SubpassDescriptionDepthStencilResolve::default()
            .depth_resolve_mode(mode)
            .stencil_resolve_mode(vk::ResolveModeFlags::NONE)
            .depth_stencil_resolve_attachment(&destination);
        let subpasses = [vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .depth_stencil_attachment(&depth)
            .push_next(&mut resolve)];
        let info = vk::RenderPassCreateInfo2::default()
            .attachments(&attachments)
            .subpasses(&subpasses);
        self.create_pass2(&info)
    }

    /// Destroys a render pass through revz's hook now (not again at the end).
    fn destroy_render_pass(&self, pass: vk::RenderPass) {
        self.passes.borrow_mut().retain(|&p| p != pass);
        // SAFETY: a live device and a render pass it created, no longer in use.
        unsafe { (self.hooks.destroy_render_pass)(self.device, pass, std::ptr::null()) };
    }

    /// Creates a framebuffer through revz from `info`: what the fake saw.
    fn create_framebuffer(&self, info: &vk::FramebufferCreateInfo<'_>) -> FramebufferCreated {
        let mut framebuffer = vk::Framebuffer::null();
        // SAFETY: a live device and a valid create info.
        let result = unsafe {
            (self.hooks.create_framebuffer)(self.device, info, std::ptr::null(), &mut framebuffer)
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.framebuffers.borrow_mut().push(framebuffer);
        match self.events().as_slice() {
            [Event::CreateFramebuffer {
                handle,
                address,
                render_pass,
                flags,
                attachments,
                image_view_formats,
            }] if *handle == framebuffer => {
                assert_eq!(*flags, info.flags);
                if !info.flags.contains(vk::FramebufferCreateFlags::IMAGELESS) {
                    // SAFETY: `attachmentCount` views.
                    let views = unsafe {
                        crate::hooks::resources::slice(info.p_attachments, info.attachment_count)
                    };
                    assert_eq!(attachments, views, "the application's views");
                }
                FramebufferCreated {
                    handle: framebuffer,
                    render_pass: *render_pass,
                    app_info: *address == info as *const _ as usize,
                    image_view_formats: image_view_formats.clone(),
                }
            }
            other => panic!("one framebuffer creation reaches the fake: {other:#?}"),
        }
    }

    /// A framebuffer of `pass` with `views`, 64x64.
    fn framebuffer(&self, pass: vk::RenderPass, views: &[vk::ImageView]) -> FramebufferCreated {
        let info = vk::FramebufferCreateInfo::default()
            .render_pass(pass)
            .attachments(views)
            .width(EXTENT.width)
            .height(EXTENT.height)
            .layers(1);
        self.create_framebuffer(&info)
    }

    /// An imageless framebuffer of `pass` whose attachments are described by
    /// (usage, view formats) each.
    fn imageless_framebuffer(
        &self,
        pass: vk::RenderPass,
        attachments: &[(vk::ImageUsageFlags, &[vk::Format])],
    ) -> FramebufferCreated {
        let flagged: Vec<_> = attachments
            .iter()
            .map(|&(usage, formats)| (usage, vk::ImageCreateFlags::empty(), formats))
            .collect();
        self.flagged_imageless_framebuffer(pass, &flagged)
    }

    /// As [`Self::imageless_framebuffer`], with each attachment's image create flags.
    fn flagged_imageless_framebuffer(
        &self,
        pass: vk::RenderPass,
        attachments: &[(vk::ImageUsageFlags, vk::ImageCreateFlags, &[vk::Format])],
    ) -> FramebufferCreated {
        let images: Vec<vk::FramebufferAttachmentImageInfo<'_>> = attachments
            .iter()
            .map(|(usage, flags, formats)| {
                vk::FramebufferAttachmentImageInfo::default()
                    .flags(*flags)
                    .usage(*usage)
                    .width(EXTENT.width)
                    .height(EXTENT.height)
                    .layer_count(1)
                    .view_formats(formats)
            })
            .collect();
        let mut images_info =
            vk::FramebufferAttachmentsCreateInfo::default().attachment_image_infos(&images);
        let mut info = vk::FramebufferCreateInfo::default()
            .flags(vk::FramebufferCreateFlags::IMAGELESS)
            .render_pass(pass)
            .width(EXTENT.width)
            .height(EXTENT.height)
            .layers(1)
            .push_next(&mut images_info);
        info.attachment_count = attachments.len() as u32;
        self.create_framebuffer(&info)
    }

    /// Destroys a framebuffer through revz's hook now (not again at the end).
    fn destroy_framebuffer(&self, framebuffer: vk::Framebuffer) {
        self.framebuffers.borrow_mut().retain(|&f| f != framebuffer);
        // SAFETY: a live device and a framebuffer it created, no longer in use.
        unsafe { (self.hooks.destroy_framebuffer)(self.device, framebuffer, std::ptr::null()) };
    }

    /// Whether revz created a framebuffer with its pass's promoted twin.
    fn framebuffer_promoted(&self, framebuffer: vk::Framebuffer) -> bool {
        self.state
            .objects
            .promoted_framebuffers
            .get(&framebuffer)
            .is_some()
    }

    /// A command buffer of `level` from the fixture's pool.
    fn command_buffer(&self, level: vk::CommandBufferLevel) -> vk::CommandBuffer {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(level)
            .command_buffer_count(1);
        let mut buffer = vk::CommandBuffer::null();
        // SAFETY: a live device, a valid info and room for one handle.
        let result =
            unsafe { (self.hooks.allocate_command_buffers)(self.device, &info, &mut buffer) };
        assert_eq!(result, vk::Result::SUCCESS);
        self.command_buffers.borrow_mut().push(buffer);
        buffer
    }

    /// A primary command buffer, begun.
    fn primary(&self) -> vk::CommandBuffer {
        let buffer = self.command_buffer(vk::CommandBufferLevel::PRIMARY);
        self.begin_primary(buffer);
        buffer
    }

    /// Begins a primary (again).
    fn begin_primary(&self, buffer: vk::CommandBuffer) {
        let begin = vk::CommandBufferBeginInfo::default();
        // SAFETY: a primary of this device, not recording.
        let result = unsafe { (self.hooks.begin_command_buffer)(buffer, &begin) };
        assert_eq!(result, vk::Result::SUCCESS);
        assert_eq!(
            self.events(),
            [Event::BeginCommandBuffer {
                address: &begin as *const _ as usize,
                inheritance: None,
            }],
            "a primary's begin goes down as it is"
        );
    }

    /// Begins and ends `pass` over the imageless `framebuffer` with `view` in a new primary,
    /// its subpass for secondaries (what a secondary without the views then follows).
    fn begin_imageless_for_secondaries(
        &self,
        pass: vk::RenderPass,
        framebuffer: vk::Framebuffer,
        view: vk::ImageView,
    ) {
        let views = [view];
        let mut attachments = vk::RenderPassAttachmentBeginInfo::default().attachments(&views);
        let primary = self.primary();
        let clears = [vk::ClearValue::default()];
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(pass)
            .framebuffer(framebuffer)
            .render_area(EXTENT.into())
            .clear_values(&clears)
            .push_next(&mut attachments);
        let contents = vk::SubpassBeginInfo::default()
            .contents(vk::SubpassContents::SECONDARY_COMMAND_BUFFERS);
        // SAFETY: a recording primary and valid begin and end infos.
        unsafe {
            (self.hooks.cmd_begin_render_pass2)(primary, &begin, &contents);
            (self.hooks.cmd_end_render_pass2)(primary, &vk::SubpassEndInfo::default());
        }
    }

    /// Begins a secondary continuing a render pass as `inheritance` says: what the fake's
    /// begin saw of the inheritance, and whether it was given the application's begin info.
    fn begin_secondary(
        &self,
        buffer: vk::CommandBuffer,
        inheritance: &vk::CommandBufferInheritanceInfo<'_>,
    ) -> (SeenInheritance, bool) {
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE)
            .inheritance_info(inheritance);
        // SAFETY: a secondary of this device, not recording; a valid begin info.
        let result = unsafe { (self.hooks.begin_command_buffer)(buffer, &begin) };
        assert_eq!(result, vk::Result::SUCCESS);
        match self.events().as_slice() {
            [Event::BeginCommandBuffer {
                address,
                inheritance: Some(seen),
            }] => (seen.clone(), *address == &begin as *const _ as usize),
            other => panic!("one begin with an inheritance reaches the fake: {other:#?}"),
        }
    }

    /// Sorts what reached the fake while recording.
    fn recorded(&self) -> Recorded {
        let mut recorded = Recorded::default();
        for event in self.events() {
            match event {
                Event::BeginRenderPass2 { render_pass, .. }
                | Event::BeginRenderPass { render_pass, .. } => recorded.passes.push(render_pass),
                Event::BindPipeline {
                    bind_point: vk::PipelineBindPoint::GRAPHICS,
                    pipeline,
                } => recorded.binds.push(pipeline),
                Event::SetDepthBias {
                    constant,
                    clamp,
                    slope,
                } => recorded.biases.push([constant, clamp, slope]),
                Event::SetDepthClampRange { mode, range } => {
                    recorded.clamp_ranges.push((mode, range))
                }
                Event::EndRenderPass2
                | Event::EndRenderPass
                | Event::NextSubpass2
                | Event::BeginRendering { .. }
                | Event::EndRendering => {}
                other => panic!("a recorded command: {other:?}"),
            }
        }
        recorded
    }

    /// Binds `pipeline` (if any), then sets the depth bias (if `bias`), then draws.
    fn bind_and_draw(
        &self,
        buffer: vk::CommandBuffer,
        pipeline: Option<vk::Pipeline>,
        bias: Option<f32>,
    ) {
        // SAFETY: a recording command buffer inside a pass or rendering instance the pipeline
        // is for.
        unsafe {
            if let Some(pipeline) = pipeline {
                (self.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, pipeline);
            }
            if let Some(constant) = bias {
                (self.hooks.cmd_set_depth_bias)(buffer, constant, 0.0, 0.0);
            }
            (self.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
        }
    }

    /// Records, in a begun primary, `pass` over `framebuffer` (inline, `vkCmdBeginRenderPass2`,
    /// the depth cleared to 1), with `pipeline` bound and a draw (if any), and returns what
    /// reached the fake.
    fn run_pass(
        &self,
        buffer: vk::CommandBuffer,
        pass: vk::RenderPass,
        framebuffer: vk::Framebuffer,
        pipeline: Option<vk::Pipeline>,
    ) -> Recorded {
        self.run_pass_with(buffer, pass, framebuffer, std::ptr::null(), |fx| {
            if pipeline.is_some() {
                fx.bind_and_draw(buffer, pipeline, None)
            }
        })
    }

    /// [`Fixture::run_pass`] with the begin info's chain `p_next`, and `inside` recorded in
    /// the pass.
    fn run_pass_with(
        &self,
        buffer: vk::CommandBuffer,
        pass: vk::RenderPass,
        framebuffer: vk::Framebuffer,
        p_next: *const c_void,
        inside: impl FnOnce(&Fixture),
    ) -> Recorded {
        let clears = [vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        }; 2];
        let begin = vk::RenderPassBeginInfo {
            p_next,
            ..vk::RenderPassBeginInfo::default()
                .render_pass(pass)
                .framebuffer(framebuffer)
                .render_area(EXTENT.into())
                .clear_values(&clears)
        };
        let subpass_begin = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
        // SAFETY: a recording primary and a valid begin info.
        unsafe { (self.hooks.cmd_begin_render_pass2)(buffer, &begin, &subpass_begin) };
        inside(self);
        // SAFETY: as above.
        unsafe { (self.hooks.cmd_end_render_pass2)(buffer, &vk::SubpassEndInfo::default()) };
        self.recorded()
    }

    /// Records, in a begun primary, a rendering instance into `view` as its depth and stencil
    /// attachment (cleared to 1), with `pipeline` bound and a draw, or its contents in
    /// secondaries (`secondary`, no draw); returns what reached the fake.
    fn run_rendering(
        &self,
        buffer: vk::CommandBuffer,
        view: vk::ImageView,
        pipeline: Option<vk::Pipeline>,
        secondary: bool,
    ) -> Recorded {
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(LAYOUT)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let flags = if secondary {
            vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS
        } else {
            vk::RenderingFlags::empty()
        };
        let info = vk::RenderingInfo::default()
            .flags(flags)
            .render_area(EXTENT.into())
            .layer_count(1)
            .depth_attachment(&depth)
            .stencil_attachment(&depth);
        // SAFETY: a recording primary and a valid rendering info.
        unsafe { (self.hooks.cmd_begin_rendering)(buffer, &info) };
        if !secondary {
            self.bind_and_draw(buffer, pipeline, None);
        }
        // SAFETY: as above.
        unsafe { (self.hooks.cmd_end_rendering)(buffer) };
        self.recorded()
    }

    /// The vertex and fragment modules the pipelines use (created on first use).
    fn shaders(&self) -> (vk::ShaderModule, vk::ShaderModule) {
        if let Some(shaders) = *self.shaders.borrow() {
            return shaders;
        }
        let module = |words: &[u32]| {
            let info = vk::ShaderModuleCreateInfo::default().code(words);
            let mut module = vk::ShaderModule::null();
            // SAFETY: a live device and a valid create info.
            let result = unsafe {
                (self.hooks.create_shader_module)(self.device, &info, std::ptr::null(), &mut module)
            };
            assert_eq!(result, vk::Result::SUCCESS);
            self.modules.borrow_mut().push(module);
            module
        };
        let shaders = (
            module(&test_spirv::vertex()),
            module(&test_spirv::fragment(PLAIN)),
        );
        self.events();
        *self.shaders.borrow_mut() = Some(shaders);
        shaders
    }

    /// A graphics pipeline drawing into `target` with a depth test (LESS, static), a static
    /// viewport, and a static constant depth bias of `bias` if any (`dynamic`: the states it
    /// makes dynamic). Returns the application's handle and every pipeline creation that
    /// reached the fake, in order (the application's last), and the application's create info
    /// as the fake would see it.
    fn pipeline(
        &self,
        target: PipelineTarget,
        bias: Option<f32>,
        dynamic: &[vk::DynamicState],
    ) -> (vk::Pipeline, Vec<PipelineCreated>, SeenPipeline) {
        let (vertex, fragment) = self.shaders();
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vertex)
                .name(MAIN),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fragment)
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
            .line_width(1.0)
            .depth_bias_enable(bias.is_some())
            .depth_bias_constant_factor(bias.unwrap_or(0.0));
        let multisample =
            vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(SINGLE);
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let colors = [COLOR];
        let dynamic_state = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(dynamic);
        let (render_pass, subpass, rendering, blend) = match target {
            PipelineTarget::Pass(pass) => (pass, 0, None, &blend[..0]),
            PipelineTarget::Subpass(pass, subpass) => (pass, subpass, None, &blend[..]),
            PipelineTarget::Rendering(depth, stencil) => (
                vk::RenderPass::null(),
                0,
                Some(
                    vk::PipelineRenderingCreateInfo::default()
                        .color_attachment_formats(&colors)
                        .depth_attachment_format(depth)
                        .stencil_attachment_format(stencil),
                ),
                &blend[..],
            ),
        };
        let color_blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(blend);
        let info = vk::GraphicsPipelineCreateInfo {
            p_next: rendering.as_ref().map_or(std::ptr::null(), |r| {
                (r as *const vk::PipelineRenderingCreateInfo<'_>).cast()
            }),
            ..vk::GraphicsPipelineCreateInfo::default()
                .stages(&stages)
                .vertex_input_state(&vertex_input)
                .input_assembly_state(&input_assembly)
                .viewport_state(&viewport)
                .rasterization_state(&rasterization)
                .multisample_state(&multisample)
                .depth_stencil_state(&depth_stencil)
                .color_blend_state(&color_blend)
                .dynamic_state(&dynamic_state)
                .layout(vk::PipelineLayout::from_raw(0x1A10))
                .render_pass(render_pass)
                .subpass(subpass)
        };
        let mut pipeline = vk::Pipeline::null();
        // SAFETY: a live device, a valid create info and room for one handle.
        let result = unsafe {
            (self.hooks.create_graphics_pipelines)(
                self.device,
                vk::PipelineCache::null(),
                1,
                &info,
                std::ptr::null(),
                &mut pipeline,
            )
        };
        assert_eq!(result, vk::Result::SUCCESS);
        self.pipelines.borrow_mut().push(pipeline);
        let created: Vec<PipelineCreated> = self
            .events()
            .into_iter()
            .map(|event| match event {
                Event::CreateGraphicsPipelines {
                    infos,
                    result: vk::Result::SUCCESS,
                    handles,
                    ..
                } if infos.len() == 1 && handles.len() == 1 => PipelineCreated {
                    handle: handles[0],
                    info: infos[0].clone(),
                },
                other => panic!("only pipeline creations of one create info: {other:#?}"),
            })
            .collect();
        assert_eq!(
            created.last().map(|c| c.handle),
            Some(pipeline),
            "the application's pipeline is created last"
        );
        // SAFETY: the valid create info above.
        (pipeline, created, unsafe { seen_pipeline(&info) })
    }

    /// Destroys a pipeline through revz's hook now (not again at the end); returns the
    /// pipelines whose destruction reached the fake.
    fn destroy_pipeline(&self, pipeline: vk::Pipeline) -> Vec<vk::Pipeline> {
        self.pipelines.borrow_mut().retain(|&p| p != pipeline);
        // SAFETY: a live device and a pipeline it created, no longer in use.
        unsafe { (self.hooks.destroy_pipeline)(self.device, pipeline, std::ptr::null()) };
        self.events()
            .into_iter()
            .map(|event| match event {
                Event::DestroyPipeline {
                    handle,
                    allocator: false,
                } => handle,
                other => panic!("only pipeline destructions: {other:?}"),
            })
            .collect()
    }

    /// Destroys everything through revz's hooks; checks that every object the fake created
    /// was destroyed once (revz's twins and variants with the application's objects) and that
    /// revz tracks nothing of them any more; then destroys the device and the instance.
    fn finish(self) {
        let (device, none) = (self.device, std::ptr::null());
        let hooks = &self.hooks;
        let passes = self.passes.borrow().clone();
        // SAFETY: objects of this live device, no longer in use, each destroyed once.
        unsafe {
            let buffers = self.command_buffers.borrow();
            (hooks.free_command_buffers)(device, self.pool, buffers.len() as u32, buffers.as_ptr());
            (hooks.destroy_command_pool)(device, self.pool, none);
            for &pipeline in self.pipelines.borrow().iter() {
                (hooks.destroy_pipeline)(device, pipeline, none);
            }
            for &module in self.modules.borrow().iter() {
                (hooks.destroy_shader_module)(device, module, none);
            }
            for &framebuffer in self.framebuffers.borrow().iter() {
                (hooks.destroy_framebuffer)(device, framebuffer, none);
            }
            for &pass in &passes {
                (hooks.destroy_render_pass)(device, pass, none);
            }
            for &view in self.views.borrow().iter() {
                (hooks.destroy_image_view)(device, view, none);
            }
            for &image in self.images.borrow().iter() {
                (hooks.destroy_image)(device, image, none);
            }
        }
        self.events();
        check_destroyed_once(&self.history.borrow());
        let objects = &self.state.objects;
        let counts = [
            ("images", objects.images.count()),
            ("views", objects.views.count()),
            ("render passes", objects.render_passes.count()),
            ("framebuffers", objects.framebuffers.count()),
            (
                "promoted framebuffers",
                objects.promoted_framebuffers.count(),
            ),
            ("pipelines", objects.pipelines.count()),
        ];
        for (table, count) in counts {
            assert_eq!(count, 0, "revz still tracks {count} {table}");
        }
        for pass in passes {
            let key = SecondaryPass::Subpass(pass, 0);
            assert!(objects.secondary_targets.get(&key).is_none());
            assert!(objects.secondary_promoted.get(&key).is_none());
        }
        drop(self.state);
        // SAFETY: the fixture's objects, no longer in use.
        let device_events =
            unsafe { fake_chain::tear_down(self.tables, self.instance, self.physical, device) };
        assert_eq!(
            device_events,
            [Event::DestroyDevice],
            "revz left nothing of its own to destroy with the device"
        );
    }
}

/// Checks that each image, view, render pass, framebuffer and pipeline created in `events`
/// was destroyed exactly once, and nothing else was.
fn check_destroyed_once(events: &[Event]) {
    let mut created: Vec<(&str, u64)> = Vec::new();
    let mut destroyed: Vec<(&str, u64)> = Vec::new();
    for event in events {
        match event {
            Event::CreateImage { handle, .. } => created.push(("image", handle.as_raw())),
            Event::DestroyImage { handle } => destroyed.push(("image", handle.as_raw())),
            Event::CreateImageView { handle, .. } => created.push(("view", handle.as_raw())),
            Event::DestroyImageView { handle } => destroyed.push(("view", handle.as_raw())),
            Event::CreateRenderPass { handle, .. } | Event::CreateRenderPass2 { handle, .. } => {
                created.push(("render pass", handle.as_raw()))
            }
            Event::DestroyRenderPass { handle, .. } => {
                destroyed.push(("render pass", handle.as_raw()))
            }
            Event::CreateFramebuffer { handle, .. } => {
                created.push(("framebuffer", handle.as_raw()))
            }
            Event::DestroyFramebuffer { handle } => {
                destroyed.push(("framebuffer", handle.as_raw()))
            }
            Event::CreateGraphicsPipelines { handles, .. } => created.extend(
                handles
                    .iter()
                    .filter(|h| !h.is_null())
                    .map(|h| ("pipeline", h.as_raw())),
            ),
            Event::DestroyPipeline { handle, .. } => destroyed.push(("pipeline", handle.as_raw())),
            _ => {}
        }
    }
    let unique: BTreeSet<_> = destroyed.iter().copied().collect();
    assert_eq!(
        unique.len(),
        destroyed.len(),
        "destroyed twice: {destroyed:?}"
    );
    let created_set: BTreeSet<_> = created.iter().copied().collect();
    assert_eq!(created_set.len(), created.len());
    let leaked: Vec<_> = created_set.difference(&unique).collect();
    assert!(leaked.is_empty(), "never destroyed: {leaked:?}");
    let unknown: Vec<_> = unique.difference(&created_set).collect();
    assert!(unknown.is_empty(), "destroyed, never created: {unknown:?}");
}

/// The creation that is not the application's `pass` (exactly one).
fn the_twin(created: &[PassCreated], pass: vk::RenderPass) -> &PassCreated {
    match created {
        [twin, app] if app.handle == pass => twin,
        other => panic!("the twin, then the application's pass: {other:#?}"),
    }
}

/// A color view revz does not track (the fake never looks at views).
fn color_view() -> vk::ImageView {
    vk::ImageView::from_raw(0xC010_0001)
}

// --- 1. images and views ---

#[test]
fn attachment_only_unorm_depth_images_are_created_and_viewed_in_float_formats() {
    let fx = Fixture::new();
    for (format, float) in [
        (D16, D32),
        (X8_D24, D32),
        (D16_S8, D32_S8),
        (D24_S8, D32_S8),
    ] {
        let info = fake_chain::depth_image_info(format, EXTENT, ATTACHMENT, SINGLE);
        let (image, seen) = fx.create_image(&info);
        // SAFETY: a valid create info.
        let app = unsafe { seen_image(&info) };
        assert_eq!(
            seen,
            SeenImage {
                address: seen.address,
                format: float,
                ..app.clone()
            },
            "{format:?}: created in {float:?}, nothing else changed"
        );
        assert_ne!(seen.address, app.address, "a copy of the create info");
        let recorded = fx.state.objects.images.get(&image).expect("tracked");
        assert_eq!((recorded.format, recorded.promoted), (format, Some(float)));
        assert_eq!(recorded.depth, ImageDepth::Reversed);
        let view = fx.create_view(image, format);
        assert_eq!(view.format, float, "{format:?}: its view too");
        assert!(!view.app_info);
        assert_eq!(fx.state.objects.view_promoted(view.handle), Some(float));
        assert_eq!(fx.state.objects.view_format(view.handle), Some(format));
    }

    // Sampled images too (a resolve needs one format at both ends); this one is native.
    let info = fake_chain::depth_image_info(D24_S8, EXTENT, READ_IN_PASS, SINGLE);
    let (image, seen) = fx.create_image(&info);
    assert_eq!(seen.format, D32_S8);
    assert!(matches!(
        fx.state.objects.images.get(&image).map(|i| i.depth),
        Some(ImageDepth::Native(_))
    ));

    // A format list naming the UNORM format names the float one (in a copy of the list).
    let listed = [D24_S8];
    let mut list = vk::ImageFormatListCreateInfo::default().view_formats(&listed);
    let info =
        fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE).push_next(&mut list);
    let (_, seen) = fx.create_image(&info);
    // SAFETY: a valid create info and chain.
    let app = unsafe { seen_image(&info) };
    assert_eq!(app.view_formats, Some(vec![D24_S8]));
    assert_eq!(
        seen,
        SeenImage {
            address: seen.address,
            p_next: seen.p_next,
            format: D32_S8,
            view_formats: Some(vec![D32_S8]),
            ..app.clone()
        }
    );
    assert_ne!(seen.p_next, app.p_next, "a copy of the chain");
    assert_eq!(listed, [D24_S8], "the application's list is left alone");

    // Float images are left as they are, and so are their views.
    for format in [D32, D32_S8] {
        let info = fake_chain::depth_image_info(format, EXTENT, ATTACHMENT, SINGLE);
        let (image, seen) = fx.create_image(&info);
        // SAFETY: a valid create info.
        let app = unsafe { seen_image(&info) };
        assert_eq!(
            seen,
            SeenImage {
                address: seen.address,
                ..app
            }
        );
        assert_eq!(fx.promoted(image), None);
        let view = fx.create_view(image, format);
        assert_eq!(view.format, format);
        assert!(
            view.app_info,
            "the application's view create info goes down"
        );
    }
    fx.finish();
}

#[test]
fn images_whose_bytes_are_seen_or_that_the_device_refuses_keep_their_unorm_format() {
    let fx = Fixture::new();
    let attachment = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
    let with_usage = |extra: vk::ImageUsageFlags| vk::ImageCreateInfo {
        usage: ATTACHMENT | extra,
        ..attachment
    };
    let mut external = vk::ExternalMemoryImageCreateInfo::default()
        .handle_types(vk::ExternalMemoryHandleTypeFlags::OPAQUE_FD);
    let external_info = vk::ImageCreateInfo {
        p_next: (&mut external as *mut vk::ExternalMemoryImageCreateInfo<'_>).cast(),
        ..attachment
    };
    // Copied from and to: promoted (copies convert between the formats).
    for usage in [
        vk::ImageUsageFlags::TRANSFER_SRC,
        vk::ImageUsageFlags::TRANSFER_DST,
    ] {
        let (image, _) = fx.create_image(&with_usage(usage));
        assert_eq!(fx.promoted(image), Some(vk::Format::D32_SFLOAT_S8_UINT));
    }
    let cases = [
        (
            "host copies",
            with_usage(vk::ImageUsageFlags::from_raw(0x0040_0000)),
        ),
        (
            "linear",
            vk::ImageCreateInfo {
                tiling: vk::ImageTiling::LINEAR,
                ..attachment
            },
        ),
        ("external memory", external_info),
        (
            "aliased",
            vk::ImageCreateInfo {
                flags: vk::ImageCreateFlags::ALIAS,
                ..attachment
            },
        ),
        (
            "sparse",
            vk::ImageCreateInfo {
                flags: vk::ImageCreateFlags::SPARSE_BINDING,
                ..attachment
            },
        ),
        (
            "larger than the device allows in float",
            vk::ImageCreateInfo {
                extent: vk::Extent3D {
                    width: 8192,
                    height: 8192,
                    depth: 1,
                },
                ..attachment
            },
        ),
    ];
    for (why, info) in cases {
        let (image, seen) = fx.create_image(&info);
        // SAFETY: a valid create info.
        let app = unsafe { seen_image(&info) };
        assert_eq!(
            seen,
            SeenImage {
                address: seen.address,
                ..app
            },
            "{why}: created as the application asked"
        );
        assert_eq!(fx.promoted(image), None, "{why}");
        let view = fx.create_view(image, D24_S8);
        assert_eq!(view.format, D24_S8, "{why}");
        assert!(
            view.app_info,
            "{why}: the application's view create info goes down"
        );
        assert_eq!(fx.state.objects.view_promoted(view.handle), None);
    }
    // External memory without handle types is not shared: promoted.
    let mut unshared = vk::ExternalMemoryImageCreateInfo::default();
    let info = vk::ImageCreateInfo {
        p_next: (&mut unshared as *mut vk::ExternalMemoryImageCreateInfo<'_>).cast(),
        ..attachment
    };
    let (image, seen) = fx.create_image(&info);
    assert_eq!((seen.format, fx.promoted(image)), (D32_S8, Some(D32_S8)));
    fx.finish();

    // A device that refuses D32_SFLOAT_S8_UINT images: D24_S8 keeps its format, D16 (to
    // D32_SFLOAT) is still promoted.
    let fx = Fixture::with(COMPLEMENTARY, &[D32_S8]);
    let (image, seen) = fx.create_image(&attachment);
    // SAFETY: a valid create info.
    let app = unsafe { seen_image(&attachment) };
    assert_eq!(
        seen,
        SeenImage {
            address: seen.address,
            ..app
        }
    );
    assert_eq!(fx.promoted(image), None);
    let d16 = fake_chain::depth_image_info(D16, EXTENT, ATTACHMENT, SINGLE);
    let (image, seen) = fx.create_image(&d16);
    assert_eq!((seen.format, fx.promoted(image)), (D32, Some(D32)));
    fx.finish();
}

#[test]
fn memory_requirements_asked_before_creation_are_those_of_the_image_created() {
    // Vulkan 1.3 (VK_KHR_maintenance4) lets an application size memory for an image before
    // creating it; the answer must be for the image vkCreateImage will make.
    let fx = Fixture::new();
    let get = fake_chain::hook!(
        fx.device,
        c"vkGetDeviceImageMemoryRequirements",
        vk::PFN_vkGetDeviceImageMemoryRequirements
    );
    let info = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
    let (_, created) = fx.create_image(&info);
    assert_eq!(created.format, D32_S8);
    let asked = vk::DeviceImageMemoryRequirements::default().create_info(&info);
    let mut requirements = vk::MemoryRequirements2::default();
    // SAFETY: a live device, a valid info and output.
    unsafe { get(fx.device, &asked, &mut requirements) };
    assert_eq!(
        fx.events(),
        [Event::GetDeviceImageMemoryRequirements { format: D32_S8 }],
        "asked about the image created"
    );
    fx.finish();
}

#[test]
fn flip_mode_and_promote_never_leave_the_applications_create_infos_alone() {
    let settings: [&[(&'static CStr, &'static CStr)]; 3] = [
        &[(c"mode", c"flip")],
        &[
            (c"mode", c"complementary"),
            (c"promote_depth_formats", c"never"),
        ],
        &[(c"mode", c"infinite"), (c"promote_depth_formats", c"never")],
    ];
    for settings in settings {
        let fx = Fixture::with(settings, &[]);
        assert!(!fx.state.policy.promote, "{settings:?}");
        let info = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
        let (image, seen) = fx.create_image(&info);
        // SAFETY: a valid create info.
        let app = unsafe { seen_image(&info) };
        // revz always passes its own copy of an image's create info down: every field the
        // application's.
        assert_eq!(
            seen,
            SeenImage {
                address: seen.address,
                ..app
            }
        );
        assert_eq!(fx.promoted(image), None);
        let view = fx.create_view(image, D24_S8);
        assert!(view.app_info && view.format == D24_S8, "{settings:?}");

        let (pass, created) = fx.depth_pass(D24_S8, false);
        assert_eq!(
            created,
            [PassCreated {
                handle: pass,
                formats: vec![D24_S8],
                resolves: vec![vk::ResolveModeFlags::NONE],
            }],
            "{settings:?}: no twin"
        );
        assert_eq!(fx.pass_info(pass).promoted_twin, None);
        let (v1, created) = fx.depth_pass_v1(D24_S8);
        assert_eq!(
            created.len(),
            1,
            "{settings:?}: no twin of a first-version pass"
        );
        assert_eq!(created[0].handle, v1);
        let framebuffer = fx.framebuffer(pass, &[view.handle]);
        assert!(framebuffer.app_info && framebuffer.render_pass == pass);
        assert!(!fx.framebuffer_promoted(framebuffer.handle));
        let (pipeline, created, _) = fx.pipeline(PipelineTarget::Pass(pass), None, &[]);
        assert_eq!(created.len(), 1, "{settings:?}: no promoted variant");
        let recorded = fx.state.objects.pipelines.get(&pipeline).expect("tracked");
        assert!(!recorded.promotable);
        assert_eq!(recorded.promoted_variant, None);
        let (rendering, created, _) =
            fx.pipeline(PipelineTarget::Rendering(D24_S8, D24_S8), None, &[]);
        assert_eq!(created.len(), 1, "{settings:?}: no promoted variant");
        let buffer = fx.primary();
        let run = fx.run_pass(buffer, pass, framebuffer.handle, Some(pipeline));
        assert_eq!(run.passes, [pass]);
        assert_eq!(run.binds, [pipeline]);
        let run = fx.run_rendering(buffer, view.handle, Some(rendering), false);
        assert_eq!(run.binds, [rendering]);
        fx.finish();
    }

    // Infinite mode promotes as complementary does.
    let fx = Fixture::with(&[(c"mode", c"infinite")], &[]);
    let info = fake_chain::depth_image_info(D16, EXTENT, ATTACHMENT, SINGLE);
    let (image, seen) = fx.create_image(&info);
    assert_eq!((seen.format, fx.promoted(image)), (D32, Some(D32)));
    fx.finish();

    // `always` promotes in flip mode too.
    let fx = Fixture::with(
        &[(c"mode", c"flip"), (c"promote_depth_formats", c"always")],
        &[],
    );
    let info = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
    let (image, seen) = fx.create_image(&info);
    assert_eq!((seen.format, fx.promoted(image)), (D32_S8, Some(D32_S8)));
    fx.finish();
}

// --- 2. render passes, framebuffers, pass begins ---

#[test]
fn a_render_pass2_of_a_unorm_depth_attachment_gets_a_float_twin_begun_over_promoted_framebuffers() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, true);
    let twin = the_twin(&created, pass).clone();
    assert_eq!(twin.formats, [D32_S8, COLOR], "the depth format in float");
    assert_eq!(
        created[1].formats,
        [D24_S8, COLOR],
        "the application's pass"
    );
    assert_eq!(twin.resolves, created[1].resolves);
    let info = fx.pass_info(pass);
    assert_eq!(info.promoted_twin, Some(twin.handle));
    assert_eq!(
        (info.swapped_resolve_twin, info.promoted_swapped_twin),
        (None, None),
        "no resolve: no swapped twin"
    );

    let (image, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    assert_eq!(fx.promoted(image), Some(D32_S8));
    let (image, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    assert_eq!(fx.promoted(image), None);
    let promoted = fx.framebuffer(pass, &[promoted_view, color_view()]);
    assert_eq!(promoted.render_pass, twin.handle, "created with the twin");
    assert!(!promoted.app_info);
    assert!(fx.framebuffer_promoted(promoted.handle));
    let kept = fx.framebuffer(pass, &[kept_view, color_view()]);
    assert_eq!(
        kept.render_pass, pass,
        "created with the application's pass"
    );
    assert!(kept.app_info, "the application's create info goes down");
    assert!(!fx.framebuffer_promoted(kept.handle));

    let buffer = fx.primary();
    let run = fx.run_pass(buffer, pass, promoted.handle, None);
    assert_eq!(run.passes, [twin.handle], "begun as the twin");
    let run = fx.run_pass(buffer, pass, kept.handle, None);
    assert_eq!(run.passes, [pass], "begun as it is");

    // Destroying the pass destroys its twin (first), then the pass itself.
    fx.destroy_framebuffer(promoted.handle);
    fx.destroy_framebuffer(kept.handle);
    assert!(!fx.framebuffer_promoted(promoted.handle), "forgotten");
    fx.events();
    fx.destroy_render_pass(pass);
    assert_eq!(
        fx.events(),
        [
            Event::DestroyRenderPass {
                handle: twin.handle,
                allocator: false,
            },
            Event::DestroyRenderPass {
                handle: pass,
                allocator: false,
            },
        ]
    );
    assert!(fx.state.objects.render_passes.get(&pass).is_none());
    fx.finish();
}

#[test]
fn a_first_version_render_pass_of_a_unorm_depth_attachment_gets_a_float_twin_too() {
    let fx = Fixture::new();
    for (format, float) in [(D24_S8, D32_S8), (D16, D32)] {
        let (pass, created) = fx.depth_pass_v1(format);
        let twin = the_twin(&created, pass).clone();
        assert_eq!(twin.formats, [float]);
        assert_eq!(created[1].formats, [format]);
        assert_eq!(fx.pass_info(pass).promoted_twin, Some(twin.handle));

        let (_, promoted_view) = fx.depth_image(format, ATTACHMENT, SINGLE);
        let (_, kept_view) = fx.kept_depth_image(format, SINGLE);
        let promoted = fx.framebuffer(pass, &[promoted_view]);
        assert_eq!(promoted.render_pass, twin.handle);
        let kept = fx.framebuffer(pass, &[kept_view]);
        assert!(kept.app_info && kept.render_pass == pass);

        // Begun through the first version (`vkCmdBeginRenderPass`).
        let buffer = fx.primary();
        let clears = [vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        }];
        for framebuffer in [promoted.handle, kept.handle] {
            let begin = vk::RenderPassBeginInfo::default()
                .render_pass(pass)
                .framebuffer(framebuffer)
                .render_area(EXTENT.into())
                .clear_values(&clears);
            // SAFETY: a recording primary and a valid begin info.
            unsafe {
                (fx.hooks.cmd_begin_render_pass)(buffer, &begin, vk::SubpassContents::INLINE);
                (fx.hooks.cmd_end_render_pass)(buffer);
            }
        }
        assert_eq!(fx.recorded().passes, [twin.handle, pass]);

        fx.destroy_render_pass(pass);
        let destroyed = fx
            .events()
            .into_iter()
            .filter(|e| matches!(e, Event::DestroyRenderPass { .. }))
            .count();
        assert_eq!(destroyed, 2, "the twin with the pass");
    }
    fx.finish();
}

#[test]
fn a_min_resolving_pass_gets_promoted_twins_of_both_modes_and_begins_the_swapped_one() {
    let fx = Fixture::new();
    let (pass, created) = fx.resolving_pass(X8_D24, vk::ResolveModeFlags::MIN);
    use vk::ResolveModeFlags as M;
    let [swapped, promoted, promoted_swapped, app] = created.as_slice() else {
        panic!("three twins, then the application's pass: {created:#?}");
    };
    assert_eq!(app.handle, pass);
    assert_eq!(
        (&app.formats[..], &app.resolves[..]),
        (&[X8_D24; 2][..], &[M::MIN][..])
    );
    assert_eq!(
        (&swapped.formats[..], &swapped.resolves[..]),
        (&[X8_D24; 2][..], &[M::MAX][..])
    );
    assert_eq!(
        (&promoted.formats[..], &promoted.resolves[..]),
        (&[D32; 2][..], &[M::MIN][..])
    );
    assert_eq!(
        (
            &promoted_swapped.formats[..],
            &promoted_swapped.resolves[..]
        ),
        (&[D32; 2][..], &[M::MAX][..])
    );
    let info = fx.pass_info(pass);
    assert_eq!(
        (
            info.swapped_resolve_twin,
            info.promoted_twin,
            info.promoted_swapped_twin
        ),
        (
            Some(swapped.handle),
            Some(promoted.handle),
            Some(promoted_swapped.handle)
        )
    );

    // Both ends promoted and reversed: created with the promoted twin, begun as the promoted
    // swapped twin.
    let (_, source) = fx.depth_image(X8_D24, ATTACHMENT, MULTISAMPLED);
    let (_, destination) = fx.depth_image(X8_D24, ATTACHMENT, SINGLE);
    let framebuffer = fx.framebuffer(pass, &[source, destination]);
    assert_eq!(framebuffer.render_pass, promoted.handle);
    let buffer = fx.primary();
    let run = fx.run_pass(buffer, pass, framebuffer.handle, None);
    assert_eq!(run.passes, [promoted_swapped.handle]);

    // A resolve that needs no swap: only the promoted twin, begun over promoted images
    // (reversed ones included).
    let (pass, created) = fx.resolving_pass(X8_D24, M::SAMPLE_ZERO);
    let twin = the_twin(&created, pass).clone();
    assert_eq!(
        (&twin.formats[..], &twin.resolves[..]),
        (&[D32; 2][..], &[M::SAMPLE_ZERO][..])
    );
    let info = fx.pass_info(pass);
    assert_eq!(
        (
            info.swapped_resolve_twin,
            info.promoted_twin,
            info.promoted_swapped_twin
        ),
        (None, Some(twin.handle), None)
    );
    let framebuffer = fx.framebuffer(pass, &[source, destination]);
    assert_eq!(framebuffer.render_pass, twin.handle);
    let run = fx.run_pass(buffer, pass, framebuffer.handle, None);
    assert_eq!(run.passes, [twin.handle]);
    fx.finish();
}

// --- 3. imageless framebuffers ---

#[test]
fn an_imageless_framebuffer_of_promotable_attachments_names_float_formats_and_the_twin() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, true);
    let twin = the_twin(&created, pass).handle;
    let framebuffer = fx.imageless_framebuffer(
        pass,
        &[
            (ATTACHMENT, &[D24_S8]),
            (vk::ImageUsageFlags::COLOR_ATTACHMENT, &[COLOR]),
        ],
    );
    assert_eq!(framebuffer.render_pass, twin);
    assert_eq!(
        framebuffer.image_view_formats,
        Some(vec![vec![D32_S8], vec![COLOR]]),
        "the depth attachment's view format in float, the color one as it was"
    );
    assert!(!framebuffer.app_info);
    assert!(fx.framebuffer_promoted(framebuffer.handle));

    // Its passes begin as the twin, with the promoted views they are begun with.
    let (_, view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let views = [view, color_view()];
    let attachments = vk::RenderPassAttachmentBeginInfo::default().attachments(&views);
    let buffer = fx.primary();
    let run = fx.run_pass_with(
        buffer,
        pass,
        framebuffer.handle,
        (&attachments as *const vk::RenderPassAttachmentBeginInfo<'_>).cast(),
        |_| {},
    );
    assert_eq!(run.passes, [twin]);

    // Attachment infos of images that keep their format: the application's pass and create
    // info.
    let kept = fx.flagged_imageless_framebuffer(
        pass,
        &[
            (ATTACHMENT, KEPT_FLAGS, &[D24_S8]),
            (
                vk::ImageUsageFlags::COLOR_ATTACHMENT,
                vk::ImageCreateFlags::empty(),
                &[COLOR],
            ),
        ],
    );
    assert_eq!(kept.render_pass, pass);
    assert!(kept.app_info);
    assert_eq!(
        kept.image_view_formats,
        Some(vec![vec![D24_S8], vec![COLOR]])
    );
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let views = [kept_view, color_view()];
    let attachments = vk::RenderPassAttachmentBeginInfo::default().attachments(&views);
    let run = fx.run_pass_with(
        buffer,
        pass,
        kept.handle,
        (&attachments as *const vk::RenderPassAttachmentBeginInfo<'_>).cast(),
        |_| {},
    );
    assert_eq!(run.passes, [pass]);
    fx.finish();
}

// --- 4. pipelines of render passes ---

#[test]
fn a_pipeline_of_a_promoted_pass_gets_a_variant_against_the_twin_bound_for_promoted_targets() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let (_, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let kept = fx.framebuffer(pass, &[kept_view]).handle;

    let (pipeline, created, app_seen) = fx.pipeline(PipelineTarget::Pass(pass), None, &[]);
    let [variant, app] = created.as_slice() else {
        panic!("the promoted variant, then the application's pipeline: {created:#?}");
    };
    assert_eq!(app.info.render_pass, pass);
    assert_eq!(
        variant.info,
        SeenPipeline {
            address: variant.info.address,
            stages_address: variant.info.stages_address,
            render_pass: twin,
            // Standalone, as every variant (no base pipeline).
            base_pipeline_index: -1,
            ..app.info.clone()
        },
        "the variant differs only in its render pass"
    );
    assert_eq!(
        app.info,
        SeenPipeline {
            address: app.info.address,
            dynamic: app.info.dynamic,
            dynamic_states: vec![
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::VIEWPORT
            ],
            ..app_seen
        },
        "the application's pipeline: its own pass, its static compare op and viewport made \
         dynamic (as without promotion)"
    );
    let recorded = fx.state.objects.pipelines.get(&pipeline).expect("tracked");
    assert!(recorded.promotable);
    assert_eq!(
        (
            recorded.reversed_variant,
            recorded.promoted_variant,
            recorded.promoted_reversed_variant
        ),
        (None, Some(variant.handle), None)
    );

    let buffer = fx.primary();
    let run = fx.run_pass(buffer, pass, promoted, Some(pipeline));
    assert_eq!(run.passes, [twin]);
    assert_eq!(
        run.binds,
        [variant.handle],
        "the variant is bound in the application's pipeline's place (no wasted bind)"
    );
    // The pipeline still bound from the last pass is bound as this pass needs it when the pass
    // begins (a draw may use it without a bind), then the application binds it.
    let run = fx.run_pass(buffer, pass, kept, Some(pipeline));
    assert_eq!(
        (run.passes, run.binds),
        (vec![pass], vec![pipeline, pipeline])
    );
    // Back to a promoted pass: the variant at its begin, and in place of the application's
    // bind. The variant still bound from it: an unpromoted pass binds the application's
    // pipeline back as it begins.
    let run = fx.run_pass(buffer, pass, promoted, Some(pipeline));
    assert_eq!(run.binds, [variant.handle, variant.handle]);
    let run = fx.run_pass_with(buffer, pass, kept, std::ptr::null(), |fx| {
        fx.bind_and_draw(buffer, None, None)
    });
    assert_eq!(run.binds, [pipeline]);

    // A pipeline of a pass without UNORM depth gets no promoted variant.
    let (float_pass, created) = fx.depth_pass(D32, false);
    assert_eq!(created.len(), 1);
    let (_, created, _) = fx.pipeline(PipelineTarget::Pass(float_pass), None, &[]);
    assert_eq!(created.len(), 1);

    assert_eq!(fx.destroy_pipeline(pipeline), [variant.handle, pipeline]);
    fx.finish();
}

#[test]
fn with_compare_op_variants_each_target_binds_its_own_variant() {
    let fx = Fixture::with(
        &[(c"mode", c"complementary"), (c"compare_op", c"variants")],
        &[],
    );
    assert!(fx.state.policy.compare_op_variants);
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let (_, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let (_, native_view) = fx.depth_image(D24_S8, READ_IN_PASS, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let kept = fx.framebuffer(pass, &[kept_view]).handle;
    let native = fx.framebuffer(pass, &[native_view]);
    assert_eq!(native.render_pass, twin, "a native image is promoted too");

    let (pipeline, created, _) = fx.pipeline(PipelineTarget::Pass(pass), None, &[]);
    let [reversed, promoted_variant, promoted_reversed, app] = created.as_slice() else {
        panic!("three variants, then the application's pipeline: {created:#?}");
    };
    let made = |c: &PipelineCreated| (c.info.render_pass, c.info.depth_compare_op);
    use vk::CompareOp as Op;
    assert_eq!(made(reversed), (pass, Some(Op::GREATER)));
    assert_eq!(made(promoted_variant), (twin, Some(Op::LESS)));
    assert_eq!(made(promoted_reversed), (twin, Some(Op::GREATER)));
    assert_eq!(made(app), (pass, Some(Op::LESS)));
    let recorded = fx.state.objects.pipelines.get(&pipeline).expect("tracked");
    assert_eq!(
        (
            recorded.reversed_variant,
            recorded.promoted_variant,
            recorded.promoted_reversed_variant
        ),
        (
            Some(reversed.handle),
            Some(promoted_variant.handle),
            Some(promoted_reversed.handle)
        )
    );

    let buffer = fx.primary();
    let run = fx.run_pass(buffer, pass, promoted, Some(pipeline));
    assert_eq!(
        run.binds,
        [promoted_reversed.handle],
        "promoted and reversed"
    );
    // At the begin (the bound variant changes), then at the application's bind.
    let run = fx.run_pass(buffer, pass, kept, Some(pipeline));
    assert_eq!(
        run.binds,
        [reversed.handle, reversed.handle],
        "reversed only"
    );
    let run = fx.run_pass(buffer, pass, native.handle, Some(pipeline));
    assert_eq!(run.passes, [twin]);
    assert_eq!(
        run.binds,
        [promoted_variant.handle, promoted_variant.handle],
        "promoted only"
    );

    let mut destroyed = fx.destroy_pipeline(pipeline);
    destroyed.sort_by_key(|p| p.as_raw());
    let mut all: Vec<vk::Pipeline> = created.iter().map(|c| c.handle).collect();
    all.sort_by_key(|p| p.as_raw());
    assert_eq!(destroyed, all, "every variant with the pipeline");
    fx.finish();
}

#[test]
fn a_pipeline_of_a_subpass_without_depth_gets_a_promoted_variant_too() {
    // Attachment formats count for render pass compatibility in every subpass: a pipeline of
    // a color-only subpass of a promoted pass is drawn in the twin as well.
    let fx = Fixture::new();
    let attachments = [
        vk::AttachmentDescription2::default()
            .format(D24_S8)
            .samples(SINGLE)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .final_layout(LAYOUT),
        vk::AttachmentDescription2::default()
            .format(COLOR)
            .samples(SINGLE)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .final_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
    ];
    let depth = vk::AttachmentReference2::default()
        .attachment(0)
        .layout(LAYOUT)
        .aspect_mask(vk::ImageAspectFlags::DEPTH);
    let colors = [vk::AttachmentReference2::default()
        .attachment(1)
        .layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
        .aspect_mask(vk::ImageAspectFlags::COLOR)];
    let subpasses = [
        vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&colors)
            .depth_stencil_attachment(&depth),
        vk::SubpassDescription2::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&colors),
    ];
    let info = vk::RenderPassCreateInfo2::default()
        .attachments(&attachments)
        .subpasses(&subpasses);
    let (pass, created) = fx.create_pass2(&info);
    let twin = the_twin(&created, pass).clone();
    assert_eq!(twin.formats, [D32_S8, COLOR]);
    let (_, view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let framebuffer = fx.framebuffer(pass, &[view, color_view()]);
    assert_eq!(framebuffer.render_pass, twin.handle);

    let (pipeline, created, _) = fx.pipeline(PipelineTarget::Subpass(pass, 1), None, &[]);
    let [variant, app] = created.as_slice() else {
        panic!("the promoted variant, then the application's pipeline: {created:#?}");
    };
    assert_eq!(
        (variant.info.render_pass, variant.info.subpass),
        (twin.handle, 1)
    );
    assert_eq!((app.info.render_pass, app.info.subpass), (pass, 1));

    let buffer = fx.primary();
    let run = fx.run_pass_with(buffer, pass, framebuffer.handle, std::ptr::null(), |fx| {
        let next = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
        // SAFETY: a recording primary in the first of two subpasses.
        unsafe { (fx.hooks.cmd_next_subpass2)(buffer, &next, &vk::SubpassEndInfo::default()) };
        fx.bind_and_draw(buffer, Some(pipeline), None)
    });
    assert_eq!(run.passes, [twin.handle]);
    assert_eq!(run.binds, [variant.handle]);
    fx.finish();
}

// --- 5. dynamic rendering ---

#[test]
fn dynamic_rendering_pipelines_get_a_variant_with_float_formats_bound_for_promoted_views() {
    let fx = Fixture::new();
    let (pipeline, created, app_seen) =
        fx.pipeline(PipelineTarget::Rendering(D24_S8, D24_S8), None, &[]);
    let [variant, app] = created.as_slice() else {
        panic!("the promoted variant, then the application's pipeline: {created:#?}");
    };
    assert_eq!(
        app.info.rendering,
        Some(SeenRendering {
            colors: vec![COLOR],
            depth: D24_S8,
            stencil: D24_S8,
        })
    );
    assert_eq!(app.info.p_next, app_seen.p_next, "the application's chain");
    assert_eq!(
        variant.info.rendering,
        Some(SeenRendering {
            colors: vec![COLOR],
            depth: D32_S8,
            stencil: D32_S8,
        }),
        "the variant's rendering formats in float"
    );
    assert_ne!(
        variant.info.p_next, app_seen.p_next,
        "in a copy of the chain"
    );
    assert_eq!(variant.info.render_pass, vk::RenderPass::null());
    let recorded = fx.state.objects.pipelines.get(&pipeline).expect("tracked");
    assert!(recorded.promotable);
    assert_eq!(recorded.promoted_variant, Some(variant.handle));

    let (_, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let buffer = fx.primary();
    let run = fx.run_rendering(buffer, promoted_view, Some(pipeline), false);
    assert_eq!(run.binds, [variant.handle]);
    // The variant bound from the last instance is replaced as this one begins.
    let run = fx.run_rendering(buffer, kept_view, Some(pipeline), false);
    assert_eq!(run.binds, [pipeline, pipeline]);

    // Depth only: D16 to D32_SFLOAT, no stencil format.
    let (d16, created, _) = fx.pipeline(
        PipelineTarget::Rendering(D16, vk::Format::UNDEFINED),
        None,
        &[],
    );
    let [variant, _] = created.as_slice() else {
        panic!("the promoted variant, then the application's pipeline: {created:#?}");
    };
    assert_eq!(
        variant
            .info
            .rendering
            .as_ref()
            .map(|r| (r.depth, r.stencil)),
        Some((D32, vk::Format::UNDEFINED))
    );
    let (_, d16_view) = fx.depth_image(D16, ATTACHMENT, SINGLE);
    // The begin binds the last instance's pipeline as this one needs it, then the variant
    // goes down in place of the application's bind.
    let run = fx.run_rendering(buffer, d16_view, Some(d16), false);
    assert_eq!(run.binds.len(), 2);
    assert_eq!(run.binds.last(), Some(&variant.handle));
    fx.finish();
}

// --- 6. secondaries ---

#[test]
fn secondaries_continuing_a_promoted_pass_inherit_its_twin() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let (_, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let kept = fx.framebuffer(pass, &[kept_view]).handle;
    let (pipeline, created, _) = fx.pipeline(PipelineTarget::Pass(pass), None, &[]);
    let variant = created[0].handle;

    // With the promoted framebuffer: the twin, in copies of the begin and inheritance infos.
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let inheritance = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0)
        .framebuffer(promoted);
    let (seen, app_begin) = fx.begin_secondary(secondary, &inheritance);
    assert_eq!(
        seen,
        SeenInheritance {
            address: seen.address,
            render_pass: twin,
            subpass: 0,
            framebuffer: promoted,
            rendering: None,
        }
    );
    assert!(!app_begin);
    assert_ne!(seen.address, &inheritance as *const _ as usize);
    assert_eq!(
        inheritance.render_pass, pass,
        "the application's is left alone"
    );
    fx.bind_and_draw(secondary, Some(pipeline), None);
    assert_eq!(fx.recorded().binds, [variant]);

    // With an unpromoted framebuffer: the application's begin info.
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let inheritance = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0)
        .framebuffer(kept);
    let (seen, app_begin) = fx.begin_secondary(secondary, &inheritance);
    assert!(app_begin);
    assert_eq!(seen.address, &inheritance as *const _ as usize);
    assert_eq!(seen.render_pass, pass);
    fx.bind_and_draw(secondary, Some(pipeline), None);
    assert_eq!(fx.recorded().binds, [pipeline]);

    // Without a framebuffer: as the pass was last begun for secondaries.
    let primary = fx.primary();
    let begin_for_secondaries = |framebuffer| {
        let clears = [vk::ClearValue::default()];
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(pass)
            .framebuffer(framebuffer)
            .render_area(EXTENT.into())
            .clear_values(&clears);
        let contents = vk::SubpassBeginInfo::default()
            .contents(vk::SubpassContents::SECONDARY_COMMAND_BUFFERS);
        // SAFETY: a recording primary and valid begin and end infos.
        unsafe {
            (fx.hooks.cmd_begin_render_pass2)(primary, &begin, &contents);
            (fx.hooks.cmd_end_render_pass2)(primary, &vk::SubpassEndInfo::default());
        }
        fx.recorded().passes
    };
    let unnamed = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0);
    assert_eq!(begin_for_secondaries(promoted), [twin]);
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let (seen, _) = fx.begin_secondary(secondary, &unnamed);
    assert_eq!(
        (seen.render_pass, seen.framebuffer),
        (twin, vk::Framebuffer::null())
    );
    assert_eq!(begin_for_secondaries(kept), [pass]);
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let (seen, app_begin) = fx.begin_secondary(secondary, &unnamed);
    assert!(app_begin && seen.render_pass == pass);
    fx.finish();
}

#[test]
fn secondaries_of_a_pass_not_yet_begun_follow_the_images_of_its_depth_format() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let unnamed = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0);
    let begin = || {
        let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
        fx.begin_secondary(secondary, &unnamed).0.render_pass
    };
    assert_eq!(begin(), pass, "no image of the format");
    fx.kept_depth_image(D24_S8, SINGLE);
    assert_eq!(begin(), pass, "only images that keep the format");
    fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    assert_eq!(
        begin(),
        twin,
        "both kinds: promoted is assumed (and warned about)"
    );
    fx.finish();
}

#[test]
fn secondaries_inheriting_an_imageless_framebuffer_follow_how_it_was_created() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let promoted = fx.imageless_framebuffer(pass, &[(ATTACHMENT, &[D24_S8])]);
    assert_eq!(promoted.render_pass, twin);
    let kept = fx.flagged_imageless_framebuffer(pass, &[(ATTACHMENT, KEPT_FLAGS, &[D24_S8])]);
    assert_eq!(kept.render_pass, pass);
    // The pass was last begun for secondaries over the promoted framebuffer.
    let (_, view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    fx.begin_imageless_for_secondaries(pass, promoted.handle, view);
    assert_eq!(fx.recorded().passes, [twin]);

    // A secondary inheriting the framebuffer created with the application's pass must name
    // that pass: a framebuffer given in the inheritance must be compatible with its render
    // pass, and the twin's depth format differs.
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let inheritance = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0)
        .framebuffer(kept.handle);
    let (seen, _) = fx.begin_secondary(secondary, &inheritance);
    assert_eq!(
        (seen.render_pass, seen.framebuffer),
        (pass, kept.handle),
        "the framebuffer's own pass"
    );
    fx.finish();
}

/// An imageless framebuffer fixes its storage at creation but names no views: a secondary
/// inheriting it continues the promoted twin (its creation decides, `policy::inherited_promoted`)
/// and draws into the target its pass was last begun with for secondaries
/// (`policy::inherited_target`), not a guess from the format's images.
#[test]
fn a_secondary_inheriting_an_imageless_framebuffer_takes_its_storage_and_its_passs_target() {
    use crate::command_state::Target;
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D24_S8, false);
    let twin = the_twin(&created, pass).handle;
    let promoted = fx.imageless_framebuffer(pass, &[(ATTACHMENT, &[D24_S8])]);
    assert_eq!(promoted.render_pass, twin);
    // Live images of the format: a reversed attachment, and a sampled (native) one.
    let (reversed, _) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (native, native_view) = fx.depth_image(D24_S8, READ_IN_PASS, SINGLE);
    assert!(fx.state.objects.image_reversed(reversed));
    assert!(!fx.state.objects.image_reversed(native));
    let inheritance = vk::CommandBufferInheritanceInfo::default()
        .render_pass(pass)
        .subpass(0)
        .framebuffer(promoted.handle);
    let inherited = |buffer| {
        crate::objects::command_buffer(buffer)
            .expect("tracked")
            .state()
            .inherited()
    };
    // Before any begin of the pass for secondaries: a guess from the images (reversed), but
    // the framebuffer's creation already says promoted.
    let guessed = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let (seen, _) = fx.begin_secondary(guessed, &inheritance);
    assert_eq!(seen.render_pass, twin, "the framebuffer's creation decides");
    assert_eq!(inherited(guessed), Target::Reversed);

    // The pass begun for secondaries over the native image.
    fx.begin_imageless_for_secondaries(pass, promoted.handle, native_view);
    assert_eq!(fx.recorded().passes, [twin]);
    // After it: the pass's remembered target, native, and still the twin.
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let (seen, _) = fx.begin_secondary(secondary, &inheritance);
    assert_eq!(
        (seen.render_pass, seen.framebuffer),
        (twin, promoted.handle)
    );
    assert_eq!(inherited(secondary), Target::Native);
    fx.finish();
}

#[test]
fn secondaries_continuing_promoted_dynamic_rendering_inherit_float_formats() {
    let fx = Fixture::new();
    let (_, promoted_view) = fx.depth_image(D24_S8, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D24_S8, SINGLE);
    let (pipeline, created, _) = fx.pipeline(PipelineTarget::Rendering(D24_S8, D24_S8), None, &[]);
    let variant = created[0].handle;
    let colors = [COLOR];
    let rendering = || {
        vk::CommandBufferInheritanceRenderingInfo::default()
            .color_attachment_formats(&colors)
            .depth_attachment_format(D24_S8)
            .stencil_attachment_format(D24_S8)
            .rasterization_samples(SINGLE)
    };

    // After a primary began rendering into a promoted view for secondaries.
    let primary = fx.primary();
    let run = fx.run_rendering(primary, promoted_view, None, true);
    assert_eq!(run, Recorded::default());
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let mut formats = rendering();
    let inheritance = vk::CommandBufferInheritanceInfo::default().push_next(&mut formats);
    let (seen, app_begin) = fx.begin_secondary(secondary, &inheritance);
    assert_eq!(
        seen,
        SeenInheritance {
            address: seen.address,
            render_pass: vk::RenderPass::null(),
            subpass: 0,
            framebuffer: vk::Framebuffer::null(),
            rendering: Some(SeenRendering {
                colors: vec![COLOR],
                depth: D32_S8,
                stencil: D32_S8,
            }),
        },
        "the float formats"
    );
    assert!(!app_begin);
    assert_eq!(
        (
            formats.depth_attachment_format,
            formats.stencil_attachment_format
        ),
        (D24_S8, D24_S8),
        "the application's structure is left alone"
    );
    fx.bind_and_draw(secondary, Some(pipeline), None);
    assert_eq!(fx.recorded().binds, [variant]);

    // After one began rendering into a view that kept its format: the application's formats.
    fx.begin_primary(primary);
    fx.run_rendering(primary, kept_view, None, true);
    let secondary = fx.command_buffer(vk::CommandBufferLevel::SECONDARY);
    let mut formats = rendering();
    let inheritance = vk::CommandBufferInheritanceInfo::default().push_next(&mut formats);
    let (seen, app_begin) = fx.begin_secondary(secondary, &inheritance);
    assert!(app_begin);
    assert_eq!(
        seen.rendering.map(|r| (r.depth, r.stencil)),
        Some((D24_S8, D24_S8))
    );
    fx.bind_and_draw(secondary, Some(pipeline), None);
    assert_eq!(fx.recorded().binds, [pipeline]);
    fx.finish();
}

// --- 7. depth bias ---

#[test]
fn constant_depth_bias_on_promoted_d16_targets_is_scaled_to_float_units() {
    let fx = Fixture::new();
    let (pass, created) = fx.depth_pass(D16, false);
    let twin = the_twin(&created, pass).handle;
    let (_, promoted_view) = fx.depth_image(D16, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D16, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let kept = fx.framebuffer(pass, &[kept_view]).handle;
    let (pipeline, _, _) = fx.pipeline(PipelineTarget::Pass(pass), Some(-8.0), &[]);
    let buffer = fx.primary();

    // A static bias, sent before the draw (both targets are reversed: negated).
    let run = fx.run_pass(buffer, pass, promoted, Some(pipeline));
    assert_eq!(run.passes, [twin]);
    assert_eq!(
        run.biases,
        [[8.0 * 256.0, 0.0, 0.0]],
        "-8 D16 units in float units, negated"
    );
    let run = fx.run_pass(buffer, pass, kept, Some(pipeline));
    assert_eq!(run.biases, [[8.0, 0.0, 0.0]], "-8 D16 units, negated");

    // A dynamic one: taken at vkCmdSetDepthBias, sent converted before the draw.
    let (dynamic, _, _) = fx.pipeline(
        PipelineTarget::Pass(pass),
        Some(0.0),
        &[vk::DynamicState::DEPTH_BIAS],
    );
    let run = fx.run_pass_with(buffer, pass, promoted, std::ptr::null(), |fx| {
        fx.bind_and_draw(buffer, Some(dynamic), Some(-8.0))
    });
    assert_eq!(run.biases, [[2048.0, 0.0, 0.0]]);
    let run = fx.run_pass_with(buffer, pass, kept, std::ptr::null(), |fx| {
        fx.bind_and_draw(buffer, Some(dynamic), Some(-8.0))
    });
    assert_eq!(run.biases, [[8.0, 0.0, 0.0]]);

    // vkCmdSetDepthBias2EXT without a representation: as vkCmdSetDepthBias.
    let run = fx.run_pass_with(buffer, pass, promoted, std::ptr::null(), |fx| {
        let info = vk::DepthBiasInfoEXT::default().depth_bias_constant_factor(-4.0);
        // SAFETY: a recording primary in a pass.
        unsafe {
            (fx.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, dynamic);
            (fx.hooks.cmd_set_depth_bias2)(buffer, &info);
        }
        fx.bind_and_draw(buffer, None, None);
    });
    // The bind sends the bias the command buffer still holds (the last run's -8, for this
    // target), the setter its own.
    assert_eq!(
        run.biases.last(),
        Some(&[1024.0, 0.0, 0.0]),
        "taken, sent converted before the draw"
    );

    // Dynamic rendering into a promoted D16 view: the same.
    let (rendering, _, _) = fx.pipeline(
        PipelineTarget::Rendering(D16, vk::Format::UNDEFINED),
        Some(-8.0),
        &[],
    );
    let run = fx.run_rendering(buffer, promoted_view, Some(rendering), false);
    assert_eq!(run.biases, [[2048.0, 0.0, 0.0]]);

    // D24's unit is the float unit where depths are near 1: unchanged.
    let (d24_pass, _) = fx.depth_pass(X8_D24, false);
    let (_, d24_view) = fx.depth_image(X8_D24, ATTACHMENT, SINGLE);
    let d24 = fx.framebuffer(d24_pass, &[d24_view]);
    assert!(fx.framebuffer_promoted(d24.handle));
    let (d24_pipeline, _, _) = fx.pipeline(PipelineTarget::Pass(d24_pass), Some(-8.0), &[]);
    let run = fx.run_pass(buffer, d24_pass, d24.handle, Some(d24_pipeline));
    assert_eq!(run.biases, [[8.0, 0.0, 0.0]]);
    fx.finish();
}

/// `vkCmdSetDepthClampRangeEXT` through revz's hook: a user-defined range set in a pass into a
/// reversed attachment goes down mapped like the depth bounds ([min, max] -> [1 - max,
/// 1 - min]) before the draw; the viewport's range goes down as it is.
#[test]
fn a_clamp_range_set_in_a_reversed_pass_goes_down_mapped() {
    use crate::vk_ext::{
        DepthClampRange, DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, DEPTH_CLAMP_MODE_VIEWPORT_RANGE,
        DYNAMIC_STATE_DEPTH_CLAMP_RANGE,
    };
    let fx = Fixture::new();
    let (pass, _) = fx.depth_pass(D32, false);
    let (_, view) = fx.depth_image(D32, ATTACHMENT, SINGLE);
    let framebuffer = fx.framebuffer(pass, &[view]).handle;
    let (pipeline, _, _) = fx.pipeline(
        PipelineTarget::Pass(pass),
        None,
        &[DYNAMIC_STATE_DEPTH_CLAMP_RANGE],
    );
    let buffer = fx.primary();
    let range = DepthClampRange {
        min_depth_clamp: 0.25,
        max_depth_clamp: 0.5,
    };
    let run = fx.run_pass_with(buffer, pass, framebuffer, std::ptr::null(), |fx| {
        // SAFETY: a recording primary in a pass; a valid range.
        unsafe {
            (fx.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, pipeline);
            (fx.hooks.cmd_set_depth_clamp_range)(
                buffer,
                DEPTH_CLAMP_MODE_USER_DEFINED_RANGE,
                &range,
            );
        }
        fx.bind_and_draw(buffer, None, None);
    });
    assert_eq!(
        run.clamp_ranges,
        [(DEPTH_CLAMP_MODE_USER_DEFINED_RANGE, Some((0.5, 0.75)))]
    );
    let run = fx.run_pass_with(buffer, pass, framebuffer, std::ptr::null(), |fx| {
        // SAFETY: as above; the viewport's range reads no pointer.
        unsafe {
            (fx.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, pipeline);
            (fx.hooks.cmd_set_depth_clamp_range)(
                buffer,
                DEPTH_CLAMP_MODE_VIEWPORT_RANGE,
                std::ptr::null(),
            );
        }
        fx.bind_and_draw(buffer, None, None);
    });
    assert_eq!(run.clamp_ranges, [(DEPTH_CLAMP_MODE_VIEWPORT_RANGE, None)]);
    fx.finish();
}

#[test]
fn a_depth_bias_in_the_formats_units_set_with_a_representation_is_scaled_on_promoted_d16() {
    let fx = Fixture::new();
    let (pass, _) = fx.depth_pass(D16, false);
    let (_, promoted_view) = fx.depth_image(D16, ATTACHMENT, SINGLE);
    let (_, kept_view) = fx.kept_depth_image(D16, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let kept = fx.framebuffer(pass, &[kept_view]).handle;
    let (dynamic, _, _) = fx.pipeline(
        PipelineTarget::Pass(pass),
        Some(0.0),
        &[vk::DynamicState::DEPTH_BIAS],
    );
    let buffer = fx.primary();
    // The bias set in (the reversed, promoted) pass; what reached the fake's
    // vkCmdSetDepthBias2EXT.
    let set_in = |framebuffer, representation| {
        let clears = [vk::ClearValue::default()];
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(pass)
            .framebuffer(framebuffer)
            .render_area(EXTENT.into())
            .clear_values(&clears);
        let subpass = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
        let mut represented =
            vk::DepthBiasRepresentationInfoEXT::default().depth_bias_representation(representation);
        let info = vk::DepthBiasInfoEXT::default()
            .depth_bias_constant_factor(-8.0)
            .push_next(&mut represented);
        // SAFETY: a recording primary, valid infos.
        unsafe {
            (fx.hooks.cmd_begin_render_pass2)(buffer, &begin, &subpass);
            (fx.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, dynamic);
            (fx.hooks.cmd_set_depth_bias2)(buffer, &info);
            (fx.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
            (fx.hooks.cmd_end_render_pass2)(buffer, &vk::SubpassEndInfo::default());
        }
        fx.events()
            .into_iter()
            .filter_map(|event| match event {
                Event::SetDepthBias2 {
                    constant,
                    representation: Some(r),
                    ..
                } => Some((constant, r)),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    use vk::DepthBiasRepresentationEXT as R;
    // Absolute biases need no conversion; into an unpromoted D16 image neither.
    assert_eq!(set_in(promoted, R::FLOAT), [(8.0, R::FLOAT)]);
    let format = R::LEAST_REPRESENTABLE_VALUE_FORMAT;
    assert_eq!(set_in(kept, format), [(8.0, format)]);
    // In the format's least representable values: D16's are 256 of the float format's near 1,
    // as for vkCmdSetDepthBias.
    assert_eq!(set_in(promoted, format), [(2048.0, format)]);
    fx.finish();
}

#[test]
fn a_depth_bias_with_a_representation_set_before_the_pass_is_sent_for_its_reversed_attachment() {
    let fx = Fixture::new();
    let (pass, _) = fx.depth_pass(D16, false);
    let (_, promoted_view) = fx.depth_image(D16, ATTACHMENT, SINGLE);
    let promoted = fx.framebuffer(pass, &[promoted_view]).handle;
    let (dynamic, _, _) = fx.pipeline(
        PipelineTarget::Pass(pass),
        Some(0.0),
        &[vk::DynamicState::DEPTH_BIAS],
    );
    let buffer = fx.primary();
    let clears = [vk::ClearValue::default()];
    let begin = vk::RenderPassBeginInfo::default()
        .render_pass(pass)
        .framebuffer(promoted)
        .render_area(EXTENT.into())
        .clear_values(&clears);
    let subpass = vk::SubpassBeginInfo::default().contents(vk::SubpassContents::INLINE);
    let mut represented = vk::DepthBiasRepresentationInfoEXT::default()
        .depth_bias_representation(vk::DepthBiasRepresentationEXT::FLOAT)
        .depth_bias_exact(true);
    let info = vk::DepthBiasInfoEXT::default()
        .depth_bias_constant_factor(-8.0)
        .depth_bias_slope_factor(-1.0)
        .push_next(&mut represented);
    // SAFETY: a recording primary, valid infos.
    unsafe {
        (fx.hooks.cmd_bind_pipeline)(buffer, vk::PipelineBindPoint::GRAPHICS, dynamic);
        // Outside the pass: where its draws go is not known yet.
        (fx.hooks.cmd_set_depth_bias2)(buffer, &info);
        (fx.hooks.cmd_begin_render_pass2)(buffer, &begin, &subpass);
        (fx.hooks.cmd_draw)(buffer, 3, 1, 0, 0);
        (fx.hooks.cmd_end_render_pass2)(buffer, &vk::SubpassEndInfo::default());
    }
    let sent: Vec<_> = fx
        .events()
        .into_iter()
        .filter_map(|event| match event {
            Event::SetDepthBias2 {
                constant,
                slope,
                representation,
                ..
            } => Some((constant, slope, representation)),
            Event::SetDepthBias { .. } => panic!("the representation was dropped"),
            _ => None,
        })
        .collect();
    // Negated for the reversed attachment (not scaled: FLOAT units), with its representation.
    assert_eq!(
        sent,
        [(8.0, 1.0, Some(vk::DepthBiasRepresentationEXT::FLOAT))]
    );
    fx.finish();
}

// --- 8. framebuffers mixing promoted and unpromoted images ---

#[test]
fn a_framebuffer_mixing_promoted_and_unorm_resolve_images_is_created_as_the_application_asked() {
    let fx = Fixture::new();
    let (pass, created) = fx.resolving_pass(X8_D24, vk::ResolveModeFlags::MIN);
    let [swapped, _, _, _] = created.as_slice() else {
        panic!("three twins, then the application's pass: {created:#?}");
    };
    let (image, promoted_source) = fx.depth_image(X8_D24, ATTACHMENT, MULTISAMPLED);
    assert_eq!(fx.promoted(image), Some(D32));
    let (image, kept_destination) = fx.kept_depth_image(X8_D24, SINGLE);
    assert_eq!(fx.promoted(image), None);
    let (image, kept_source) = fx.kept_depth_image(X8_D24, MULTISAMPLED);
    assert_eq!(fx.promoted(image), None);
    let (_, promoted_destination) = fx.depth_image(X8_D24, ATTACHMENT, SINGLE);

    let buffer = fx.primary();
    for views in [
        [promoted_source, kept_destination],
        [kept_source, promoted_destination],
    ] {
        let mixed = fx.framebuffer(pass, &views);
        assert_eq!(mixed.render_pass, pass, "the application's pass");
        assert!(mixed.app_info, "the application's create info");
        assert!(!fx.framebuffer_promoted(mixed.handle));
        // Begun with the application's formats (both ends reversed: the swapped twin).
        let run = fx.run_pass(buffer, pass, mixed.handle, None);
        assert_eq!(run.passes, [swapped.handle]);
    }
    fx.finish();
}

// --- logs ---

/// Set (to the log file's path) in the child process that runs the logging test alone.
const LOG_CHILD: &str = "REVZ_PROMOTION_LOG_CHILD";

/// What the child logs: images that keep their format, for each reason (twice for one), one
/// promoted image, and a framebuffer that mixes both kinds.
#[cfg(unix)]
fn log_child(path: std::ffi::OsString) {
    use std::os::unix::ffi::OsStringExt;
    let path = std::ffi::CString::new(path.into_vec()).expect("a path without NUL");
    let path: &'static CStr = Box::leak(path.into_boxed_c_str());
    let fx = Fixture::with(
        &[
            (c"mode", c"complementary"),
            (c"log", c"info"),
            (c"log_file", path),
        ],
        &[D32],
    );
    // A resolve from a promoted image into one that keeps its format, the source created
    // first (in the other order the source keeps its format too: its likely resolve partner
    // did, `KeptFormat::ResolvePartner`).
    let (pass, _) = fx.resolving_pass(D24_S8, vk::ResolveModeFlags::SAMPLE_ZERO);
    let (_, source) = fx.depth_image(D24_S8, ATTACHMENT, MULTISAMPLED);
    let (_, destination) = fx.kept_depth_image(D24_S8, SINGLE);
    let mixed = fx.framebuffer(pass, &[source, destination]);
    assert_eq!(mixed.render_pass, pass);
    // A second multisampled image now keeps its format: its likely partner does.
    fx.depth_image(D24_S8, ATTACHMENT, MULTISAMPLED);
    let attachment = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
    for info in [
        vk::ImageCreateInfo {
            usage: ATTACHMENT | vk::ImageUsageFlags::from_raw(0x0040_0000),
            ..attachment
        },
        vk::ImageCreateInfo {
            tiling: vk::ImageTiling::LINEAR,
            ..attachment
        },
        vk::ImageCreateInfo {
            flags: vk::ImageCreateFlags::ALIAS,
            ..attachment
        },
        // The device refuses D32_SFLOAT.
        fake_chain::depth_image_info(D16, EXTENT, ATTACHMENT, SINGLE),
        attachment,
    ] {
        fx.create_image(&info);
    }
    fx.finish();
}

#[cfg(unix)]
#[test]
fn images_that_keep_their_format_and_mixed_framebuffers_are_logged() {
    if let Some(path) = std::env::var_os(LOG_CHILD) {
        log_child(path);
        return;
    }
    let path = std::env::temp_dir().join(format!("revz-promotion-log-{}.txt", std::process::id()));
    let _ = std::fs::remove_file(&path);
    let module = module_path!();
    let module = module.split_once("::").map_or(module, |(_, rest)| rest);
    let name = format!("{module}::images_that_keep_their_format_and_mixed_framebuffers_are_logged");
    let output = std::process::Command::new(std::env::current_exe().expect("the test binary"))
        .args([name.as_str(), "--exact", "--test-threads=1"])
        .env(LOG_CHILD, &path)
        // The settings the child passes decide where its log goes.
        .env_remove("REVZ_LOG")
        .env_remove("REVZ_LOG_FILE")
        .output()
        .expect("run the test binary again");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr),
    );
    assert!(
        output.status.success() && stdout.contains("1 passed"),
        "the logging child failed\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
    );
    let log = std::fs::read_to_string(&path).expect("the child's log file");
    let _ = std::fs::remove_file(&path);
    for expected in [
        "keep their format, because host image copies read or write it",
        "keep their format, because its memory layout is seen outside",
        "keep their format, because its memory is sparse or aliased",
        "keep their format, because the device does not support the \
         float format",
        "promoted to D32_SFLOAT_S8_UINT",
        "mixes promoted (float) and UNORM depth images",
        "keep their format, because an image of its format and size it may be resolved with",
    ] {
        assert!(log.contains(expected), "{expected:?} is logged:\n{log}");
    }
    // Once per reason.
    assert_eq!(
        log.matches("because host image copies read or write it")
            .count(),
        1,
        "{log}"
    );
}

/// Issue #39: a single-sampled depth image shaders sample is reversed and gets a read twin (the
/// application's image created with TRANSFER_SRC added, then the twin in the application's
/// format: a promoted image's shaders read UNORM texels); each view of it gets a view of the
/// twin in that format; descriptor writes of its views name the
/// twin's view in `SHADER_READ_ONLY_OPTIMAL` (other views untouched); and the twin's view and
/// image are destroyed with the application's.
/// On a device whose application enabled `VK_EXT_descriptor_heap` (descriptors revz does not
/// follow, heap state its own descriptor set binds would invalidate), a depth image that
/// shaders sample or copies reach is created as the application asked (its format, its usage,
/// no twin) and stays native; a depth attachment nothing else reaches is reversed and
/// promoted as on any device.
#[test]
fn with_descriptor_heaps_a_sampled_or_copied_depth_image_is_left_as_it_is() {
    let fx = Fixture::with_extensions(COMPLEMENTARY, &[], &[c"VK_EXT_descriptor_heap"]);
    assert!(fx.state.policy.descriptor_heap);
    for usage in [
        vk::ImageUsageFlags::SAMPLED,
        vk::ImageUsageFlags::TRANSFER_SRC,
    ] {
        let info = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT | usage, SINGLE);
        let (image, seen) = fx.create_image(&info);
        assert_eq!(seen.format, D24_S8, "{usage:?}: not promoted");
        assert_eq!(seen.usage, ATTACHMENT | usage, "{usage:?}: no usage added");
        let tracked = fx.state.objects.images.get(&image).unwrap();
        assert_eq!(
            tracked.depth,
            crate::policy::ImageDepth::Native(crate::policy::NativeReason::DescriptorHeap)
        );
        assert!(tracked.twin.is_none(), "{usage:?}: no read twin");
    }
    let attachment = fake_chain::depth_image_info(D24_S8, EXTENT, ATTACHMENT, SINGLE);
    let (image, seen) = fx.create_image(&attachment);
    assert_eq!(seen.format, D32_S8, "promoted");
    let tracked = fx.state.objects.images.get(&image).unwrap();
    assert_eq!(tracked.depth, crate::policy::ImageDepth::Reversed);
}

#[test]
fn a_sampled_depth_image_gets_a_read_twin_whose_views_descriptors_name() {
    let fx = Fixture::new();
    let sampled = ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
    let info = fake_chain::depth_image_info(D24_S8, EXTENT, sampled, SINGLE);
    let mut image = vk::Image::null();
    // SAFETY: a live device and a valid create info.
    let result = unsafe { (fx.hooks.create_image)(fx.device, &info, std::ptr::null(), &mut image) };
    assert_eq!(result, vk::Result::SUCCESS);
    let created: Vec<(vk::Image, SeenImage)> = fx
        .events()
        .into_iter()
        .filter_map(|event| match event {
            Event::CreateImage { handle, info } => Some((handle, info)),
            _ => None,
        })
        .collect();
    assert_eq!(created.len(), 2, "{created:#?}");
    let (app, twin) = (&created[0], &created[1]);
    assert_eq!(app.0, image);
    assert_eq!(app.1.format, D32_S8, "promoted");
    assert_eq!(app.1.usage, sampled | vk::ImageUsageFlags::TRANSFER_SRC);
    assert_eq!(twin.1.format, D24_S8, "the application's format");
    assert_eq!(
        twin.1.usage,
        vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST
    );
    let tracked = fx.state.objects.images.get(&image).unwrap();
    assert_eq!(tracked.depth, crate::policy::ImageDepth::Reversed);
    assert_eq!(tracked.twin.map(|t| t.image), Some(twin.0));

    let view_info = fake_chain::depth_view_info(image, D24_S8);
    let mut view = vk::ImageView::null();
    // SAFETY: a live device and a valid create info.
    let result =
        unsafe { (fx.hooks.create_image_view)(fx.device, &view_info, std::ptr::null(), &mut view) };
    assert_eq!(result, vk::Result::SUCCESS);
    let views: Vec<(vk::ImageView, vk::Image, vk::Format)> = fx
        .events()
        .into_iter()
        .filter_map(|event| match event {
            Event::CreateImageView {
                handle,
                image,
                format,
                ..
            } => Some((handle, image, format)),
            _ => None,
        })
        .collect();
    assert_eq!(views.len(), 2, "{views:?}");
    assert_eq!((views[0].0, views[0].1, views[0].2), (view, image, D32_S8));
    let twin_view = views[1].0;
    assert_eq!((views[1].1, views[1].2), (twin.0, D24_S8));

    let other = vk::ImageView::from_raw(0x7777);
    let infos = [
        vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: view,
            image_layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
        },
        vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: other,
            image_layout: vk::ImageLayout::GENERAL,
        },
    ];
    let write = vk::WriteDescriptorSet {
        descriptor_count: 2,
        descriptor_type: vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        p_image_info: infos.as_ptr(),
        ..Default::default()
    };
    // A storage buffer write next to it goes down as it is.
    let buffer_info = vk::DescriptorBufferInfo::default();
    let buffers = vk::WriteDescriptorSet {
        descriptor_count: 1,
        descriptor_type: vk::DescriptorType::STORAGE_BUFFER,
        p_buffer_info: &buffer_info,
        ..Default::default()
    };
    let writes = [buffers, write];
    // SAFETY: a live device and valid writes.
    unsafe {
        (fx.hooks.update_descriptor_sets)(
            fx.device,
            writes.len() as u32,
            writes.as_ptr(),
            0,
            std::ptr::null(),
        )
    };
    // What goes down: the twin's view in SHADER_READ_ONLY_OPTIMAL, the other view as it was.
    let patched = vec![
        vec![],
        vec![
            (twin_view, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
            (other, vk::ImageLayout::GENERAL),
        ],
    ];
    assert_eq!(
        fx.events(),
        [Event::UpdateDescriptorSets {
            image_infos: patched.clone()
        }]
    );
    // The application's array is left as it gave it.
    assert_eq!(infos[0].image_view, view);
    // Pushed through `vkCmdPushDescriptorSet2KHR` (`VK_KHR_maintenance6`): the same.
    let buffer = fx.primary();
    let push = vk::PushDescriptorSetInfoKHR {
        stage_flags: vk::ShaderStageFlags::FRAGMENT,
        set: 1,
        descriptor_write_count: writes.len() as u32,
        p_descriptor_writes: writes.as_ptr(),
        ..Default::default()
    };
    // SAFETY: a recording command buffer and a valid info.
    unsafe { (fx.hooks.cmd_push_descriptor_set2)(buffer, &push) };
    assert_eq!(
        fx.events(),
        [Event::PushDescriptorSet2 {
            set: 1,
            image_infos: patched
        }]
    );
    assert_eq!(infos[0].image_view, view);

    // SAFETY: the view and image, no longer used.
    unsafe {
        (fx.hooks.destroy_image_view)(fx.device, view, std::ptr::null());
        (fx.hooks.destroy_image)(fx.device, image, std::ptr::null());
    }
    let destroyed: Vec<Event> = fx
        .events()
        .into_iter()
        .filter(|e| {
            matches!(
                e,
                Event::DestroyImageView { .. } | Event::DestroyImage { .. }
            )
        })
        .collect();
    assert_eq!(destroyed.len(), 4, "{destroyed:#?}");
    assert!(destroyed.contains(&Event::DestroyImage { handle: twin.0 }));
    assert_eq!(
        fx.state
            .objects
            .twins
            .load(std::sync::atomic::Ordering::Relaxed),
        0
    );
    assert!(fx.state.objects.twin_views.get(&view).is_none());
}

/// A device that refuses the read twin of a promoted image in the application's UNORM format
/// (a D24 format without transfer writes, say: as `vkGetPhysicalDeviceImageFormatProperties`
/// answers, or as `vkCreateImage` fails) gets the twin in the stored float format, its views
/// in that format too: shaders then read float32 texels (up to an ulp from the UNORM ones),
/// which beats keeping the image native.
#[test]
fn a_twin_the_device_refuses_in_the_application_format_is_made_in_the_stored_one() {
    // Refused by the format query, then by the creation itself.
    for query_refuses in [true, false] {
        let refused: &[vk::Format] = if query_refuses { &[D24_S8] } else { &[] };
        let fx = Fixture::with(COMPLEMENTARY, refused);
        if !query_refuses {
            // The application's image, then its twin in D24_S8 refused, then in D32_S8.
            fake_chain::script_image_creations(
                fx.tables.device,
                [vk::Result::SUCCESS, vk::Result::ERROR_FORMAT_NOT_SUPPORTED],
            );
        }
        a_twin_in_the_stored_format(&fx);
    }
}

/// The body of [`a_twin_the_device_refuses_in_the_application_format_is_made_in_the_stored_one`]
/// on `fx`, whose device refuses a D24_S8 twin.
fn a_twin_in_the_stored_format(fx: &Fixture) {
    let sampled = ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
    let info = fake_chain::depth_image_info(D24_S8, EXTENT, sampled, SINGLE);
    let mut image = vk::Image::null();
    // SAFETY: a live device and a valid create info.
    let result = unsafe { (fx.hooks.create_image)(fx.device, &info, std::ptr::null(), &mut image) };
    assert_eq!(result, vk::Result::SUCCESS);
    fx.images.borrow_mut().push(image);
    let formats: Vec<vk::Format> = fx
        .events()
        .into_iter()
        .filter_map(|event| match event {
            Event::CreateImage { info, .. } => Some(info.format),
            _ => None,
        })
        .collect();
    assert_eq!(
        formats,
        [D32_S8, D32_S8],
        "the image promoted, its twin stored alike"
    );
    let tracked = fx.state.objects.images.get(&image).unwrap();
    assert_eq!(tracked.depth, crate::policy::ImageDepth::Reversed);
    let twin = tracked.twin.expect("a twin");
    assert_eq!(twin.format, D32_S8);

    let view_info = fake_chain::depth_view_info(image, D24_S8);
    let mut view = vk::ImageView::null();
    // SAFETY: a live device and a valid create info.
    let result =
        unsafe { (fx.hooks.create_image_view)(fx.device, &view_info, std::ptr::null(), &mut view) };
    assert_eq!(result, vk::Result::SUCCESS);
    fx.views.borrow_mut().push(view);
    let formats: Vec<(vk::Image, vk::Format)> = fx
        .events()
        .into_iter()
        .filter_map(|event| match event {
            Event::CreateImageView { image, format, .. } => Some((image, format)),
            _ => None,
        })
        .collect();
    assert_eq!(formats, [(image, D32_S8), (twin.image, D32_S8)]);
    assert!(fx.state.objects.twin_views.get(&view).is_some());
}

/// In infinite mode a copy of depth between two reversed images goes down as it is, and the
/// destination then holds depth stored with the source's n / f: revz remembers the source's
/// camera for it (its later clears, copies and read twin refreshes map with it). A copy of the
/// stencil alone moves no depth and changes nothing.
#[test]
fn a_copy_between_reversed_images_hands_the_source_camera_to_the_destination() {
    let fx = Fixture::with(&[(c"mode", c"infinite")], &[]);
    let copied = ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
    let info = fake_chain::depth_image_info(D32_S8, EXTENT, copied, SINGLE);
    let (source, _) = fx.create_image(&info);
    let (destination, _) = fx.create_image(&info);
    fx.events();
    let objects = &fx.state.objects;
    assert!(objects.image_reversed(source) && objects.image_reversed(destination));
    objects.near_over_far.insert(source, 0.002);
    objects.near_over_far.insert(destination, 0.25);
    let buffer = fx.primary();
    let region = |aspect| vk::ImageCopy {
        src_subresource: vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        src_offset: vk::Offset3D::default(),
        dst_subresource: vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        dst_offset: vk::Offset3D::default(),
        extent: vk::Extent3D {
            width: EXTENT.width,
            height: EXTENT.height,
            depth: 1,
        },
    };
    let copy = |aspect| {
        let regions = [region(aspect)];
        // SAFETY: a recording command buffer, live images in transfer layouts, one region.
        unsafe {
            (fx.hooks.cmd_copy_image)(
                buffer,
                source,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                destination,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                1,
                regions.as_ptr(),
            )
        };
    };
    copy(vk::ImageAspectFlags::STENCIL);
    assert_eq!(objects.near_over_far.get(&destination), Some(0.25));
    let both = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
    copy(both);
    assert_eq!(objects.near_over_far.get(&destination), Some(0.002));
    // Both went down as the application gave them.
    assert_eq!(
        fx.events(),
        [
            Event::CopyImage {
                src: source,
                dst: destination,
                aspects: vec![(vk::ImageAspectFlags::STENCIL, vk::ImageAspectFlags::STENCIL)]
            },
            Event::CopyImage {
                src: source,
                dst: destination,
                aspects: vec![(both, both)]
            }
        ]
    );
}

/// A device destroyed while the application still holds a sampled depth image and a view of
/// it (Zink leaves some to `vkDestroyDevice`): revz destroys the read twin's view and image
/// (and frees its memory) before the device goes down, so that the application's leak is not
/// revz's too.
#[test]
fn a_read_twin_of_an_image_left_to_the_device_destruction_goes_before_the_device() {
    let fx = Fixture::new();
    let sampled = ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
    let info = fake_chain::depth_image_info(D32, EXTENT, sampled, SINGLE);
    let (mut image, mut view) = (vk::Image::null(), vk::ImageView::null());
    // SAFETY: a live device and valid create infos.
    unsafe {
        let result = (fx.hooks.create_image)(fx.device, &info, std::ptr::null(), &mut image);
        assert_eq!(result, vk::Result::SUCCESS);
        let view_info = fake_chain::depth_view_info(image, D32);
        let result =
            (fx.hooks.create_image_view)(fx.device, &view_info, std::ptr::null(), &mut view);
        assert_eq!(result, vk::Result::SUCCESS);
    }
    let created = fx.events();
    let twin = created
        .iter()
        .filter_map(|event| match event {
            Event::CreateImage { handle, .. } if *handle != image => Some(*handle),
            _ => None,
        })
        .next()
        .expect("the sampled image's read twin");
    let twin_view = created
        .iter()
        .filter_map(|event| match event {
            Event::CreateImageView { handle, .. } if *handle != view => Some(*handle),
            _ => None,
        })
        .next()
        .expect("the view of the twin beside the application's");
    let Fixture {
        tables,
        instance,
        physical,
        device,
        state,
        ..
    } = fx;
    drop(state);
    // SAFETY: the fixture's objects; the application's image and view are left alive.
    let device_events = unsafe { fake_chain::tear_down(tables, instance, physical, device) };
    assert_eq!(
        device_events,
        [
            Event::DestroyImageView { handle: twin_view },
            Event::DestroyImage { handle: twin },
            Event::DestroyDevice
        ]
    );
}
