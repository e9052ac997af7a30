//! Drawing a scene: the scene's vertex and index buffers, the render pass and framebuffer over
//! the offscreen targets, the graphics pipeline (static state: depth test LESS with writes,
//! no culling), recording of one primary command buffer (draws, then the read-back copies),
//! and the single fenced submit.

use std::fmt;

use anyhow::{anyhow, bail, Context, Result};
use ash::vk;

use crate::gpu::{Gpu, HostBuffer};
use crate::readback::Readback;
use crate::scene::{DrawRange, Scene, PUSH_CONSTANT_SIZE};
use crate::shaders;
use crate::target::Targets;

/// The color the color attachment is cleared to: dark grey (25/255, exact in UNORM8).
pub const CLEAR_COLOR: [f32; 4] = [25.0 / 255.0, 25.0 / 255.0, 25.0 / 255.0, 1.0];
/// The depth clear value (standard depth: the far plane).
pub const CLEAR_DEPTH: f32 = 1.0;
/// The stencil clear value.
pub const CLEAR_STENCIL: u32 = 0;
/// How long to wait for the GPU before giving up (lavapipe renders this in milliseconds).
const FENCE_TIMEOUT_NS: u64 = 60_000_000_000;

/// The scene's geometry in host-visible vertex and index buffers.
#[derive(Debug)]
pub struct SceneBuffers<'a> {
    vertices: HostBuffer<'a>,
    indices: HostBuffer<'a>,
    draws: Vec<DrawRange>,
}

impl<'a> SceneBuffers<'a> {
    /// Packs every mesh of `scene` into one vertex buffer and one u32 index buffer.
    pub fn upload(gpu: &'a Gpu, scene: &Scene) -> Result<Self> {
        let geometry = scene.geometry();
        let vertex_bytes = geometry.position_bytes();
        let index_bytes = geometry.index_bytes();
        if vertex_bytes.is_empty() || index_bytes.is_empty() {
            bail!("scene '{}' has no geometry", scene.name);
        }
        let mut vertices =
            HostBuffer::new(gpu, vertex_bytes.len(), vk::BufferUsageFlags::VERTEX_BUFFER)
                .context("vertex buffer")?;
        vertices.write(&vertex_bytes);
        let mut indices =
            HostBuffer::new(gpu, index_bytes.len(), vk::BufferUsageFlags::INDEX_BUFFER)
                .context("index buffer")?;
        indices.write(&index_bytes);
        Ok(SceneBuffers {
            vertices,
            indices,
            draws: geometry.draws,
        })
    }
}

/// Render pass, framebuffer, pipeline, command buffer and fence for one render of the targets.
pub struct Renderer<'a> {
    device: &'a ash::Device,
    render_pass: vk::RenderPass,
    framebuffer: vk::Framebuffer,
    pipeline_layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    command_pool: vk::CommandPool,
    command_buffer: vk::CommandBuffer,
    fence: vk::Fence,
    extent: vk::Extent2D,
}

impl fmt::Debug for Renderer<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Renderer")
            .field("render_pass", &self.render_pass)
            .field("pipeline", &self.pipeline)
            .field("extent", &self.extent)
            .finish_non_exhaustive()
    }
}

impl Drop for Renderer<'_> {
    fn drop(&mut self) {
        // SAFETY: every handle is null or was created from `device`, which outlives `self`.
        // Waiting for idle first makes sure no submitted work still uses them (it matters only
        // on error paths: a normal render has already waited on its fence). Destroying null
        // handles is a no-op; destroying the pool frees its command buffer.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.command_pool, None);
            self.device.destroy_pipeline(self.pipeline, None);
            self.device
                .destroy_pipeline_layout(self.pipeline_layout, None);
            self.device.destroy_framebuffer(self.framebuffer, None);
            self.device.destroy_render_pass(self.render_pass, None);
        }
    }
}

impl<'a> Renderer<'a> {
    /// Creates everything needed to render into `targets`.
    pub fn new(gpu: &'a Gpu, targets: &Targets<'_>) -> Result<Self> {
        let device = &gpu.device;
        let mut this = Renderer {
            device,
            render_pass: vk::RenderPass::null(),
            framebuffer: vk::Framebuffer::null(),
            pipeline_layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            command_pool: vk::CommandPool::null(),
            command_buffer: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            extent: targets.extent,
        };
        this.render_pass = create_render_pass(device, targets)?;

        let attachments = [targets.color.view, targets.depth.view];
        let framebuffer_info = vk::FramebufferCreateInfo::default()
            .render_pass(this.render_pass)
            .attachments(&attachments)
            .width(targets.extent.width)
            .height(targets.extent.height)
            .layers(1);
        // SAFETY: valid render pass and views compatible with it.
        this.framebuffer = unsafe { device.create_framebuffer(&framebuffer_info, None) }
            .context("vkCreateFramebuffer failed")?;

        let push_constant_ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            offset: 0,
            size: PUSH_CONSTANT_SIZE,
        }];
        let layout_info =
            vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&push_constant_ranges);
        // SAFETY: valid device and create info.
        this.pipeline_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout failed")?;

        this.pipeline = create_pipeline(
            device,
            this.render_pass,
            this.pipeline_layout,
            targets.extent,
        )?;

        let pool_info = vk::CommandPoolCreateInfo::default()
            .flags(vk::CommandPoolCreateFlags::TRANSIENT)
            .queue_family_index(gpu.queue_family);
        // SAFETY: valid device, queue family of the device's queue.
        this.command_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("vkCreateCommandPool failed")?;
        let allocate_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(this.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool.
        this.command_buffer = unsafe { device.allocate_command_buffers(&allocate_info) }
            .context("vkAllocateCommandBuffers failed")?
            .into_iter()
            .next()
            .ok_or_else(|| anyhow!("vkAllocateCommandBuffers returned no command buffer"))?;

        // SAFETY: valid device, default (unsignalled) fence.
        this.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .context("vkCreateFence failed")?;
        Ok(this)
    }

    /// Records the scene's draws and the read-back copies into one command buffer, submits it
    /// and waits for it to complete. The read-back buffers are ready when this returns.
    pub fn render(
        &self,
        gpu: &Gpu,
        scene: &Scene,
        buffers: &SceneBuffers<'_>,
        targets: &Targets<'_>,
        readback: &Readback<'_>,
    ) -> Result<()> {
        let device = self.device;
        let cmd = self.command_buffer;
        let aspect = f64::from(self.extent.width) / f64::from(self.extent.height);
        if scene.objects.len() != buffers.draws.len() {
            bail!("scene buffers were uploaded for another scene");
        }

        let begin_info = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: fresh command buffer from a pool of this device, not in use.
        unsafe { device.begin_command_buffer(cmd, &begin_info) }
            .context("vkBeginCommandBuffer failed")?;

        let clear_values = [
            vk::ClearValue {
                color: vk::ClearColorValue {
                    float32: CLEAR_COLOR,
                },
            },
            vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: CLEAR_DEPTH,
                    stencil: CLEAR_STENCIL,
                },
            },
        ];
        let pass_begin = vk::RenderPassBeginInfo::default()
            .render_pass(self.render_pass)
            .framebuffer(self.framebuffer)
            .render_area(vk::Rect2D {
                offset: vk::Offset2D { x: 0, y: 0 },
                extent: self.extent,
            })
            .clear_values(&clear_values);
        // SAFETY: the command buffer is recording; every handle is valid and compatible (the
        // framebuffer was made for this render pass, the pipeline for its subpass 0, the
        // buffers hold the geometry the draw ranges index, and the push constants match the
        // layout's single 80-byte VERTEX|FRAGMENT range).
        unsafe {
            device.cmd_begin_render_pass(cmd, &pass_begin, vk::SubpassContents::INLINE);
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
            device.cmd_bind_vertex_buffers(cmd, 0, &[buffers.vertices.buffer], &[0]);
            device.cmd_bind_index_buffer(cmd, buffers.indices.buffer, 0, vk::IndexType::UINT32);
            for (object, draw) in scene.objects.iter().zip(&buffers.draws) {
                let constants = scene.push_constants(object, aspect);
                device.cmd_push_constants(
                    cmd,
                    self.pipeline_layout,
                    vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                    0,
                    &constants,
                );
                device.cmd_draw_indexed(
                    cmd,
                    draw.index_count,
                    1,
                    draw.first_index,
                    draw.vertex_offset,
                    0,
                );
            }
            device.cmd_end_render_pass(cmd);
        }

        readback.record(device, cmd, targets);

        // SAFETY: the command buffer is recording.
        unsafe { device.end_command_buffer(cmd) }.context("vkEndCommandBuffer failed")?;

        let command_buffers = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&command_buffers);
        // SAFETY: executable command buffer, unsignalled fence, queue of this device; the
        // host wrote the vertex/index buffers before the submit (implicitly visible).
        unsafe { device.queue_submit(gpu.queue, &[submit], self.fence) }
            .context("vkQueueSubmit failed")?;
        // SAFETY: the fence was submitted above.
        match unsafe { device.wait_for_fences(&[self.fence], true, FENCE_TIMEOUT_NS) } {
            Ok(()) => Ok(()),
            Err(vk::Result::TIMEOUT) => Err(anyhow!(
                "the render did not complete within {} s",
                FENCE_TIMEOUT_NS / 1_000_000_000
            )),
            Err(e) => Err(anyhow!("vkWaitForFences failed: {e}")),
        }
    }
}

/// One subpass writing the color and depth attachments. Both are cleared on load and stored;
/// they end in their attachment layouts and `Readback::record` transitions them for copying.
fn create_render_pass(device: &ash::Device, targets: &Targets<'_>) -> Result<vk::RenderPass> {
    let stencil = targets.depth_format.has_stencil();
    let attachments = [
        vk::AttachmentDescription::default()
            .format(targets.color.format)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
            .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL),
        vk::AttachmentDescription::default()
            .format(targets.depth.format)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(if stencil {
                vk::AttachmentLoadOp::CLEAR
            } else {
                vk::AttachmentLoadOp::DONT_CARE
            })
            .stencil_store_op(if stencil {
                vk::AttachmentStoreOp::STORE
            } else {
                vk::AttachmentStoreOp::DONT_CARE
            })
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
    ];
    let color_refs = [vk::AttachmentReference {
        attachment: 0,
        layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
    }];
    let depth_ref = vk::AttachmentReference {
        attachment: 1,
        layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
    };
    let subpasses = [vk::SubpassDescription::default()
        .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
        .color_attachments(&color_refs)
        .depth_stencil_attachment(&depth_ref)];
    // Before the pass: nothing to wait for (fresh images, UNDEFINED layout), but the clears
    // and the attachment writes must not start before the layout transition.
    let dependencies = [vk::SubpassDependency {
        src_subpass: vk::SUBPASS_EXTERNAL,
        dst_subpass: 0,
        src_stage_mask: vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
            | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
        dst_stage_mask: vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
            | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
        src_access_mask: vk::AccessFlags::empty(),
        dst_access_mask: vk::AccessFlags::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
        dependency_flags: vk::DependencyFlags::empty(),
    }];
    let info = vk::RenderPassCreateInfo::default()
        .attachments(&attachments)
        .subpasses(&subpasses)
        .dependencies(&dependencies);
    // SAFETY: valid device; the create info refers to live locals.
    unsafe { device.create_render_pass(&info, None) }.context("vkCreateRenderPass failed")
}

/// A shader module destroyed when dropped (shader modules are only needed while the pipeline
/// is created).
struct ShaderModule<'a> {
    device: &'a ash::Device,
    module: vk::ShaderModule,
}

impl Drop for ShaderModule<'_> {
    fn drop(&mut self) {
        // SAFETY: created from `device`; only referenced during pipeline creation.
        unsafe { self.device.destroy_shader_module(self.module, None) };
    }
}

impl<'a> ShaderModule<'a> {
    fn new(device: &'a ash::Device, source: &shaders::ShaderSource) -> Result<Self> {
        let words = source.words()?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid device; `words` is SPIR-V validated at build time (naga) and in tests
        // (spirv-val).
        let module = unsafe { device.create_shader_module(&info, None) }
            .with_context(|| format!("vkCreateShaderModule ({}) failed", source.name))?;
        Ok(ShaderModule { device, module })
    }
}

/// The scene pipeline: vec3 positions, triangle lists, static viewport (0, 0, w, h) with
/// depth range [0, 1], no culling, depth test LESS with depth writes, no blending, no dynamic
/// state.
fn create_pipeline(
    device: &ash::Device,
    render_pass: vk::RenderPass,
    layout: vk::PipelineLayout,
    extent: vk::Extent2D,
) -> Result<vk::Pipeline> {
    let vert = ShaderModule::new(device, &shaders::SCENE_VERT)?;
    let frag = ShaderModule::new(device, &shaders::SCENE_FRAG)?;
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vert.module)
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(frag.module)
            .name(c"main"),
    ];
    let bindings = [vk::VertexInputBindingDescription {
        binding: 0,
        stride: 12,
        input_rate: vk::VertexInputRate::VERTEX,
    }];
    let attributes = [vk::VertexInputAttributeDescription {
        location: 0,
        binding: 0,
        format: vk::Format::R32G32B32_SFLOAT,
        offset: 0,
    }];
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(&bindings)
        .vertex_attribute_descriptions(&attributes);
    let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
        .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
    let viewports = [vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    }];
    let scissors = [vk::Rect2D {
        offset: vk::Offset2D { x: 0, y: 0 },
        extent,
    }];
    let viewport_state = vk::PipelineViewportStateCreateInfo::default()
        .viewports(&viewports)
        .scissors(&scissors);
    let rasterization = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(vk::CullModeFlags::NONE)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .line_width(1.0);
    let multisample = vk::PipelineMultisampleStateCreateInfo::default()
        .rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(true)
        .depth_write_enable(true)
        .depth_compare_op(vk::CompareOp::LESS)
        .depth_bounds_test_enable(false)
        .stencil_test_enable(false)
        .min_depth_bounds(0.0)
        .max_depth_bounds(1.0);
    let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(false)
        .color_write_mask(vk::ColorComponentFlags::RGBA)];
    let color_blend =
        vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
    let info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&input_assembly)
        .viewport_state(&viewport_state)
        .rasterization_state(&rasterization)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth_stencil)
        .color_blend_state(&color_blend)
        .layout(layout)
        .render_pass(render_pass)
        .subpass(0);
    // SAFETY: valid device; every state structure and module referenced is alive for the call.
    let pipelines =
        unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
            .map_err(|(pipelines, e)| {
                for pipeline in pipelines {
                    // SAFETY: pipelines returned by the failed call; null ones are ignored.
                    unsafe { device.destroy_pipeline(pipeline, None) };
                }
                anyhow!("vkCreateGraphicsPipelines failed: {e}")
            })?;
    pipelines
        .into_iter()
        .next()
        .ok_or_else(|| anyhow!("vkCreateGraphicsPipelines returned no pipeline"))
}
