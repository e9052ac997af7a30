//! The objects every bench role records with ([`Bench`]): the render pass into a reversed
//! D32_SFLOAT attachment, the pipelines of the storm's mix, command buffers, fence and
//! submits; created in `Bench::new`, destroyed by `Drop`.

use super::*;

impl Drop for Bench<'_> {
    fn drop(&mut self) {
        let device = &self.gpu.device;
        // SAFETY: every handle was created from `device` (or is null) and the device is idle.
        unsafe {
            let _ = device.device_wait_idle();
            device.destroy_fence(self.fence, None);
            device.destroy_command_pool(self.pool, None);
            for &pipeline in &self.pipelines {
                device.destroy_pipeline(pipeline, None);
            }
            device.destroy_shader_module(self.fragment, None);
            device.destroy_pipeline_layout(self.layout, None);
            device.destroy_framebuffer(self.framebuffer, None);
            device.destroy_render_pass(self.render_pass, None);
        }
    }
}

impl<'a> Bench<'a> {
    pub(super) fn new(gpu: &'a Gpu) -> Result<Self> {
        let device = &gpu.device;
        let targets = Targets::new(
            gpu,
            EXTENT.width,
            EXTENT.height,
            DepthFormat::D32,
            TargetOptions {
                depth_readback: false,
                clear_depth_image: false,
                shadow_map: None,
                sampled_depth: false,
                input_depth: false,
                multisample: None,
                depth_subresources: Default::default(),
                depth_blits: false,
                views: 0,
            },
        )?;
        let mut vertices = HostBuffer::new(gpu, 36, vk::BufferUsageFlags::VERTEX_BUFFER)?;
        let triangle: [f32; 9] = [-0.5, -0.5, 0.0, 0.5, -0.5, 0.0, 0.0, 0.5, 0.0];
        let bytes: Vec<u8> = triangle.iter().flat_map(|v| v.to_ne_bytes()).collect();
        vertices.write(&bytes);
        let mut this = Bench {
            gpu,
            render_pass: vk::RenderPass::null(),
            framebuffer: vk::Framebuffer::null(),
            layout: vk::PipelineLayout::null(),
            fragment: vk::ShaderModule::null(),
            pipelines: Vec::new(),
            pool: vk::CommandPool::null(),
            fence: vk::Fence::null(),
            vertices,
            _targets: targets,
        };
        this.render_pass = create_render_pass(device)?;
        let views = [this._targets.color.view, this._targets.depth.view];
        let info = vk::FramebufferCreateInfo::default()
            .render_pass(this.render_pass)
            .attachments(&views)
            .width(EXTENT.width)
            .height(EXTENT.height)
            .layers(1);
        // SAFETY: valid render pass and views compatible with it.
        this.framebuffer = unsafe { device.create_framebuffer(&info, None) }
            .context("vkCreateFramebuffer failed")?;
        let ranges = [vk::PushConstantRange {
            stage_flags: PUSH_STAGES,
            offset: 0,
            size: PUSH_BYTES,
        }];
        let info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges);
        // SAFETY: valid device and create info.
        this.layout = unsafe { device.create_pipeline_layout(&info, None) }
            .context("vkCreatePipelineLayout failed")?;
        this.fragment = create_module(device, &shaders::SCENE_FRAG.words()?)?;
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(gpu.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device and create info.
        this.pool = unsafe { device.create_command_pool(&info, None) }
            .context("vkCreateCommandPool failed")?;
        // SAFETY: valid device.
        this.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .context("vkCreateFence failed")?;
        Ok(this)
    }

    /// Creates a pipeline of `kind` from `vertex` (with `scene.frag`).
    pub(super) fn pipeline(
        &self,
        vertex: vk::ShaderModule,
        kind: PipelineKind,
    ) -> Result<vk::Pipeline> {
        create_pipeline(
            &self.gpu.device,
            vertex,
            self.fragment,
            kind,
            self.layout,
            self.render_pass,
        )
    }

    /// The standard pipelines of the mix, from one `scene.vert` module.
    pub(super) fn standard_pipelines(&mut self) -> Result<()> {
        let device = &self.gpu.device;
        let vertex = create_module(device, &shaders::SCENE_VERT.words()?)?;
        let created: Result<Vec<_>> = MIX.iter().map(|&k| self.pipeline(vertex, k)).collect();
        // SAFETY: only needed while the pipelines were created.
        unsafe { device.destroy_shader_module(vertex, None) };
        self.pipelines = created?;
        Ok(())
    }

    pub(super) fn allocate(&self, count: usize) -> Result<Vec<vk::CommandBuffer>> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(count as u32);
        // SAFETY: valid pool.
        unsafe { self.gpu.device.allocate_command_buffers(&info) }
            .context("vkAllocateCommandBuffers failed")
    }

    /// Begins `cmd` and the render pass (clear color, depth 1.0), binds the vertex buffer.
    pub(super) fn begin(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let device = &self.gpu.device;
        let clear = [
            vk::ClearValue {
                color: vk::ClearColorValue {
                    float32: [0.0, 0.0, 0.0, 1.0],
                },
            },
            vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            },
        ];
        let pass = vk::RenderPassBeginInfo::default()
            .render_pass(self.render_pass)
            .framebuffer(self.framebuffer)
            .render_area(vk::Rect2D {
                offset: vk::Offset2D { x: 0, y: 0 },
                extent: EXTENT,
            })
            .clear_values(&clear);
        // SAFETY: `cmd` is a fresh or reset primary command buffer of this device; the pass
        // objects are alive.
        unsafe {
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .context("vkBeginCommandBuffer failed")?;
            device.cmd_begin_render_pass(cmd, &pass, vk::SubpassContents::INLINE);
            device.cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.buffer], &[0]);
        }
        Ok(())
    }

    /// Ends the render pass and `cmd`.
    pub(super) fn end(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let device = &self.gpu.device;
        // SAFETY: `cmd` is recording, inside the render pass `begin` started.
        unsafe {
            device.cmd_end_render_pass(cmd);
            device
                .end_command_buffer(cmd)
                .context("vkEndCommandBuffer failed")
        }
    }

    /// Records `draws` draws into `cmd` (a pipeline bind every [`DRAWS_PER_BIND`], an 80-byte
    /// push of each draw's MVP and color before each), between `begin` and `end`.
    pub(super) fn record_storm(
        &self,
        cmd: vk::CommandBuffer,
        pushes: &[[u8; 80]],
        draws: usize,
    ) -> Result<()> {
        let device = &self.gpu.device;
        self.begin(cmd)?;
        for i in 0..draws {
            // SAFETY: `cmd` is recording inside the render pass; pipelines and layout alive.
            unsafe {
                if i % DRAWS_PER_BIND == 0 {
                    let pipeline = self.pipelines[(i / DRAWS_PER_BIND) % self.pipelines.len()];
                    device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
                }
                device.cmd_push_constants(
                    cmd,
                    self.layout,
                    PUSH_STAGES,
                    0,
                    &pushes[i % pushes.len()],
                );
                device.cmd_draw(cmd, 3, 1, 0, 0);
            }
        }
        self.end(cmd)
    }

    pub(super) fn submit_and_wait(&self, cmd: vk::CommandBuffer) -> Result<()> {
        self.submit(cmd)?;
        self.wait()
    }

    pub(super) fn submit(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        // SAFETY: `cmd` is executable; the fence is unsignaled.
        unsafe {
            self.gpu
                .device
                .queue_submit(self.gpu.queue, &[submit], self.fence)
        }
        .context("vkQueueSubmit failed")
    }

    pub(super) fn wait(&self) -> Result<()> {
        let device = &self.gpu.device;
        // SAFETY: the fence was submitted with work.
        unsafe {
            device
                .wait_for_fences(&[self.fence], true, u64::MAX)
                .context("vkWaitForFences failed")?;
            device
                .reset_fences(&[self.fence])
                .context("vkResetFences failed")
        }
    }
}

pub(super) fn create_module(device: &ash::Device, words: &[u32]) -> Result<vk::ShaderModule> {
    let info = vk::ShaderModuleCreateInfo::default().code(words);
    // SAFETY: valid device; `words` is SPIR-V built (and validated) at build time, or such a
    // module with one more unused constant.
    unsafe { device.create_shader_module(&info, None) }.context("vkCreateShaderModule failed")
}

fn create_render_pass(device: &ash::Device) -> Result<vk::RenderPass> {
    let ds_layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    let color_layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
    let attachments = [
        vk::AttachmentDescription::default()
            .format(COLOR_FORMAT)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
            .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(color_layout),
        vk::AttachmentDescription::default()
            .format(vk::Format::D32_SFLOAT)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
            .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(ds_layout),
    ];
    let color_refs = [vk::AttachmentReference {
        attachment: 0,
        layout: color_layout,
    }];
    let depth_ref = vk::AttachmentReference {
        attachment: 1,
        layout: ds_layout,
    };
    let subpasses = [vk::SubpassDescription::default()
        .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
        .color_attachments(&color_refs)
        .depth_stencil_attachment(&depth_ref)];
    let stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    // The previous frame's attachment writes before this frame's clears.
    let dependencies = [vk::SubpassDependency {
        src_subpass: vk::SUBPASS_EXTERNAL,
        dst_subpass: 0,
        src_stage_mask: stages,
        dst_stage_mask: stages,
        src_access_mask: vk::AccessFlags::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
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

/// A pipeline: `scene.vert`'s vertex input (vec3 positions), triangle lists, no culling, the
/// viewport covering the target, depth test with `kind`'s compare op and writes, a static
/// depth bias when `kind` asks for one.
fn create_pipeline(
    device: &ash::Device,
    vertex: vk::ShaderModule,
    fragment: vk::ShaderModule,
    kind: PipelineKind,
    layout: vk::PipelineLayout,
    render_pass: vk::RenderPass,
) -> Result<vk::Pipeline> {
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vertex)
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(fragment)
            .name(c"main"),
    ];
    let (bindings, attributes) = crate::pipeline::position_input();
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(&bindings)
        .vertex_attribute_descriptions(&attributes);
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
    let scissors = [vk::Rect2D {
        offset: vk::Offset2D { x: 0, y: 0 },
        extent: EXTENT,
    }];
    let viewport_state = vk::PipelineViewportStateCreateInfo::default()
        .viewports(&viewports)
        .scissors(&scissors);
    let rasterization = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(vk::CullModeFlags::NONE)
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .line_width(1.0)
        .depth_bias_enable(kind.bias)
        .depth_bias_constant_factor(if kind.bias { 2.0 } else { 0.0 })
        .depth_bias_slope_factor(if kind.bias { 1.0 } else { 0.0 });
    let multisample = vk::PipelineMultisampleStateCreateInfo::default()
        .rasterization_samples(vk::SampleCountFlags::TYPE_1);
    let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(true)
        .depth_write_enable(true)
        .depth_compare_op(kind.compare)
        .min_depth_bounds(0.0)
        .max_depth_bounds(1.0);
    let blend = [vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(false)
        .color_write_mask(vk::ColorComponentFlags::RGBA)];
    let color_blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend);
    let dynamic_state = vk::PipelineDynamicStateCreateInfo::default();
    let info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .vertex_input_state(&vertex_input)
        .input_assembly_state(&input_assembly)
        .viewport_state(&viewport_state)
        .rasterization_state(&rasterization)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth_stencil)
        .color_blend_state(&color_blend)
        .dynamic_state(&dynamic_state)
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
