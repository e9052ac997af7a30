//! Recording: the plan's steps turned into commands one by one, on the primary and on
//! secondaries (on the main thread or one thread each with its own command pool).

use super::*;
use crate::plan::DepthLayout;

impl Drop for Recorder<'_> {
    fn drop(&mut self) {
        if self.thread_pools.is_empty() {
            return;
        }
        // SAFETY: the pools were created from this device; once the device is idle none of
        // their command buffers is pending. Destroying a pool frees its command buffers.
        unsafe {
            let _ = self.device().device_wait_idle();
            for &pool in &self.thread_pools {
                self.device().destroy_command_pool(pool, None);
            }
        }
    }
}

impl Recorder<'_> {
    fn device(&self) -> &ash::Device {
        self.renderer.device
    }

    /// Binds the shared vertex and index buffers (once per command buffer).
    pub(super) fn bind_geometry(&self, cmd: vk::CommandBuffer) {
        // SAFETY: `cmd` is recording; the buffers are valid vertex and index buffers.
        unsafe {
            self.device()
                .cmd_bind_vertex_buffers(cmd, 0, &[self.buffers.vertices.buffer], &[0]);
            self.device().cmd_bind_index_buffer(
                cmd,
                self.buffers.indices.buffer,
                0,
                vk::IndexType::UINT32,
            );
        }
    }

    /// Records `steps` into `cmd`; returns the command buffer recording goes on in: `cmd`, or
    /// the renderer's second primary where a suspended rendering resumes there.
    pub(super) fn record(
        &mut self,
        mut cmd: vk::CommandBuffer,
        steps: &[Step],
    ) -> Result<vk::CommandBuffer> {
        for (index, step) in steps.iter().enumerate() {
            // A subpass recorded in secondaries is begun with SECONDARY_COMMAND_BUFFERS
            // contents (the plan check makes that its only kind of step).
            let contents = match steps.get(index + 1) {
                Some(Step::ExecuteSecondaries(..)) => {
                    vk::SubpassContents::SECONDARY_COMMAND_BUFFERS
                }
                _ => vk::SubpassContents::INLINE,
            };
            match step {
                Step::ClearDepthImage { depth } => self.clear_depth_image(cmd, *depth),
                Step::MainDepthLayout { from, to } => {
                    let range = self
                        .targets
                        .depth
                        .range(self.targets.depth_format.aspects());
                    self.main_depth_layout(cmd, range, *from, *to);
                }
                Step::MultisampledDepthLayout { from, to } => {
                    let image = multisampled_targets(self.targets)?.depth.image;
                    let range = full_range(self.targets.depth_format.aspects());
                    self.depth_layout_barrier(cmd, image, range, *from, *to);
                }
                Step::DepthLevelLayout { level, from, to } => {
                    let aspects = self.targets.depth_format.aspects();
                    let range = self.targets.depth.level_range(aspects, *level);
                    self.main_depth_layout(cmd, range, *from, *to);
                }
                Step::BlitDepthLevel { level } => self.blit_depth_level(cmd, *level),
                Step::BuildDepthTiles => self.build_depth_tiles(cmd)?,
                Step::BindDepthTiles(_) => {
                    self.bind_depth_tiles(cmd)?;
                    self.tiles_bound = true;
                }
                Step::BeginPass(n) => self.begin_pass(cmd, *n, contents)?,
                Step::NextSubpass => {
                    self.subpass += 1;
                    let kind = self.pass.map(|n| (n, self.plan.passes[n].kind));
                    if let Some((
                        n,
                        PassKind::DynamicRenderingSuspended {
                            across_command_buffers: across,
                        },
                    )) = kind
                    {
                        // The suspended instance ends; the same rendering resumes at once,
                        // here or first in the next primary.
                        // SAFETY: `cmd` is inside the instance begun suspending.
                        unsafe { self.renderer.gpu.cmd_end_rendering(cmd) };
                        if across {
                            cmd = self.continue_in_next_primary(cmd)?;
                        }
                        self.begin_rendering(cmd, n, true, false)?;
                    } else if kind.is_some_and(|(_, kind)| kind.reads_locally()) {
                        self.local_read_barrier(cmd);
                    } else {
                        // SAFETY: `cmd` is inside a render pass with another subpass (plan
                        // check).
                        unsafe { self.device().cmd_next_subpass(cmd, contents) };
                    }
                }
                Step::EndPass => self.end_pass(cmd),
                Step::Bind(n) => self.bind(cmd, *n),
                Step::Draw(n) => self.draw(cmd, *n, true)?,
                Step::DrawPushed(n) => self.draw(cmd, *n, false)?,
                Step::Push {
                    object,
                    offset,
                    size,
                } => self.push(cmd, *object, *offset, *size)?,
                Step::SetDepthCompareOp(op) => {
                    // SAFETY: `cmd` is recording with a bound pipeline whose compare op is
                    // dynamic; the device has the command (checked before rendering).
                    unsafe {
                        self.renderer
                            .gpu
                            .cmd_set_depth_compare_op(cmd, map_compare(*op))
                    };
                }
                Step::SetDepthBias(bias) => self.set_depth_bias(cmd, *bias),
                Step::SetDepthBounds { min, max } => {
                    // SAFETY: `cmd` is recording; the bound pipeline's bounds are dynamic and
                    // the depthBounds feature is enabled (checked before rendering).
                    unsafe { self.device().cmd_set_depth_bounds(cmd, *min, *max) };
                }
                Step::SetViewport {
                    min_depth,
                    max_depth,
                } => {
                    let extent = self.current_extent();
                    // SAFETY: `cmd` is recording; the bound pipeline's viewport is dynamic.
                    unsafe {
                        self.device().cmd_set_viewport(
                            cmd,
                            0,
                            &[full_viewport(extent, *min_depth, *max_depth)],
                        )
                    };
                }
                Step::ClearDepthRect { rect, depth } => self.clear_depth_rect(cmd, *rect, *depth),
                Step::ExecuteSecondaries(lists, Recording::MainThread) => {
                    self.execute_secondaries(cmd, lists)?;
                }
                Step::ExecuteSecondaries(lists, Recording::ThreadPerSecondary) => {
                    self.execute_secondaries_on_threads(cmd, lists, false)?;
                }
                Step::ExecuteSecondaries(
                    lists,
                    Recording::ThreadPerSecondaryOddWithoutFramebuffer,
                ) => {
                    self.execute_secondaries_on_threads(cmd, lists, true)?;
                }
            }
        }
        Ok(cmd)
    }

    fn current_extent(&self) -> vk::Extent2D {
        let target = self
            .pass
            .map_or(Target::Main, |n| self.plan.passes[n].target);
        target_extent(target, self.targets.extent)
    }

    /// `vkCmdClearDepthStencilImage` of the main depth image, with the transitions to
    /// TRANSFER_DST_OPTIMAL (from nothing: the image is not used before) and back to the
    /// attachment layout the next pass loads from.
    fn clear_depth_image(&self, cmd: vk::CommandBuffer, depth: f32) {
        let image = self.targets.depth.image;
        let range = full_range(self.targets.depth_format.aspects());
        let barrier = |old, new, src_access, dst_access| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(src_access)
                .dst_access_mask(dst_access)
                .old_layout(old)
                .new_layout(new)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range)
        };
        let value = vk::ClearDepthStencilValue {
            depth,
            stencil: CLEAR_STENCIL,
        };
        // SAFETY: `cmd` is recording outside a render pass; the image has TRANSFER_DST usage
        // (the plan's needs asked for it) and the barriers name its whole range.
        unsafe {
            self.device().cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::TRANSFER_WRITE,
                )],
            );
            self.device().cmd_clear_depth_stencil_image(
                cmd,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &value,
                &[range],
            );
            self.device().cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                )],
            );
        }
    }

    /// A barrier of `range` of the main depth image from layout `from` to `to` (plan check:
    /// outside a pass, from the layout it is in): depth tests and writes before fragment
    /// shader reads, or those reads before depth tests, writes and the read-back's copy.
    fn main_depth_layout(
        &self,
        cmd: vk::CommandBuffer,
        range: vk::ImageSubresourceRange,
        from: DepthLayout,
        to: DepthLayout,
    ) {
        self.depth_layout_barrier(cmd, self.targets.depth.image, range, from, to);
    }

    /// A barrier of `range` of depth image `image` from layout `from` to `to`, as
    /// [`Self::main_depth_layout`] describes.
    fn depth_layout_barrier(
        &self,
        cmd: vk::CommandBuffer,
        image: vk::Image,
        range: vk::ImageSubresourceRange,
        from: DepthLayout,
        to: DepthLayout,
    ) {
        let depth_stages = vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
        let depth_access = vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
        let side = |layout| match layout {
            DepthLayout::Attachment => (
                vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                depth_stages,
                depth_access,
            ),
            DepthLayout::ReadOnly => (
                vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
                vk::PipelineStageFlags::FRAGMENT_SHADER | depth_stages,
                vk::AccessFlags::SHADER_READ | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ,
            ),
            DepthLayout::Sampled => (
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                vk::PipelineStageFlags::FRAGMENT_SHADER | vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::AccessFlags::SHADER_READ,
            ),
            DepthLayout::TransferSrc => (
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_READ,
            ),
            DepthLayout::TransferDst => (
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            // Contents discarded: only earlier accesses of any kind to wait for (the
            // previous frame's, which its fence ordered), none to make visible.
            DepthLayout::Undefined => (
                vk::ImageLayout::UNDEFINED,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::AccessFlags::empty(),
            ),
        };
        let (old_layout, src_stage, src_access) = side(from);
        let (new_layout, mut dst_stage, mut dst_access) = side(to);
        if to == DepthLayout::Attachment {
            dst_stage |= vk::PipelineStageFlags::TRANSFER;
            dst_access |= vk::AccessFlags::TRANSFER_READ;
        }
        let barrier = vk::ImageMemoryBarrier::default()
            .src_access_mask(src_access)
            .dst_access_mask(dst_access)
            .old_layout(old_layout)
            .new_layout(new_layout)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        // SAFETY: `cmd` is a recording primary outside any pass; the range is in `from`'s
        // layout (plan check).
        unsafe {
            self.device().cmd_pipeline_barrier(
                cmd,
                src_stage,
                dst_stage,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier],
            )
        };
    }

    /// `vkCmdBlitImage` of mip level `level - 1` of the main depth image into level `level`
    /// (plan check: outside a pass, in TRANSFER_SRC_OPTIMAL and TRANSFER_DST_OPTIMAL), the
    /// whole of each, NEAREST, depth aspect, every layer.
    fn blit_depth_level(&self, cmd: vk::CommandBuffer, level: u32) {
        let depth = &self.targets.depth;
        let layers = |mip_level| vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            mip_level,
            base_array_layer: 0,
            layer_count: depth.subresources.layers,
        };
        let corner = |mip_level| {
            let extent = depth.level_extent(mip_level);
            vk::Offset3D {
                x: extent.width as i32,
                y: extent.height as i32,
                z: 1,
            }
        };
        let region = vk::ImageBlit {
            src_subresource: layers(level - 1),
            src_offsets: [vk::Offset3D::default(), corner(level - 1)],
            dst_subresource: layers(level),
            dst_offsets: [vk::Offset3D::default(), corner(level)],
        };
        // SAFETY: `cmd` is a recording primary outside any pass; the image has TRANSFER_SRC
        // and TRANSFER_DST usage and BLIT features (the plan's needs asked for them); the two
        // levels are distinct and in the layouts named (plan check).
        unsafe {
            self.device().cmd_blit_image(
                cmd,
                depth.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                depth.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
                vk::Filter::NEAREST,
            )
        };
    }

    /// Binds the depth pyramid's compute program (its pipeline, or its shader object) and its
    /// descriptors: its descriptor set, its descriptor buffer and offset, or pushed
    /// ([`crate::plan::TileDescriptors`]).
    fn bind_depth_tiles(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let tiles = self
            .renderer
            .depth_tiles
            .as_ref()
            .ok_or_else(|| anyhow!("no depth tile bindings"))?;
        let device = self.device();
        let compute = vk::PipelineBindPoint::COMPUTE;
        // SAFETY: `cmd` is a recording primary outside any pass; the pipeline and its layout
        // are alive, the set or descriptor buffer matches the layout.
        unsafe {
            match (&tiles.compute_descriptors, &self.renderer.gpu.shader_object) {
                (ComputeTileDescriptors::ShaderObject(shader), Some(objects)) => {
                    objects.cmd_bind_shaders(cmd, &[vk::ShaderStageFlags::COMPUTE], &[*shader]);
                }
                _ => device.cmd_bind_pipeline(cmd, compute, tiles.compute),
            }
            let maintenance6 = || {
                self.renderer
                    .gpu
                    .maintenance6
                    .as_ref()
                    .ok_or_else(|| anyhow!("VK_KHR_maintenance6 is not enabled"))
            };
            match &tiles.compute_descriptors {
                ComputeTileDescriptors::Set if tiles.binds_with_infos => {
                    let sets = [tiles.set];
                    let info = vk::BindDescriptorSetsInfoKHR::default()
                        .stage_flags(vk::ShaderStageFlags::COMPUTE)
                        .layout(tiles.compute_layout)
                        .first_set(0)
                        .descriptor_sets(&sets);
                    maintenance6()?.cmd_bind_descriptor_sets2(cmd, &info);
                }
                ComputeTileDescriptors::Set | ComputeTileDescriptors::ShaderObject(_) => device
                    .cmd_bind_descriptor_sets(
                        cmd,
                        compute,
                        tiles.compute_layout,
                        0,
                        &[tiles.set],
                        &[],
                    ),
                ComputeTileDescriptors::Buffer(buffer) => {
                    let (commands, _) = self
                        .renderer
                        .gpu
                        .descriptor_buffer
                        .as_ref()
                        .ok_or_else(|| anyhow!("descriptor buffers are not enabled"))?;
                    let binding = vk::DescriptorBufferBindingInfoEXT::default()
                        .address(buffer.descriptors.address())
                        .usage(TILE_DESCRIPTOR_BUFFER_USAGE);
                    commands.cmd_bind_descriptor_buffers(cmd, &[binding]);
                    if tiles.binds_with_infos {
                        let info = vk::SetDescriptorBufferOffsetsInfoEXT::default()
                            .stage_flags(vk::ShaderStageFlags::COMPUTE)
                            .layout(tiles.compute_layout)
                            .first_set(0)
                            .buffer_indices(&[0])
                            .offsets(&[0]);
                        maintenance6()?.cmd_set_descriptor_buffer_offsets2(cmd, &info);
                    } else {
                        commands.cmd_set_descriptor_buffer_offsets(
                            cmd,
                            compute,
                            tiles.compute_layout,
                            0,
                            &[0],
                            &[0],
                        );
                    }
                }
                ComputeTileDescriptors::Push { template, .. } => {
                    let data = bindings::TileTemplateData {
                        image: vk::DescriptorImageInfo {
                            sampler: vk::Sampler::null(),
                            image_view: self.targets.depth.depth_view,
                            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                        },
                        sampler: vk::DescriptorImageInfo {
                            sampler: self.tile_sampler()?,
                            image_view: vk::ImageView::null(),
                            image_layout: vk::ImageLayout::UNDEFINED,
                        },
                        tiles: vk::DescriptorBufferInfo {
                            buffer: tiles.tiles.buffer,
                            offset: 0,
                            range: vk::WHOLE_SIZE,
                        },
                    };
                    let gpu = self.renderer.gpu;
                    let pushed = match template {
                        Some(template) => gpu.cmd_push_descriptor_set_with_template(
                            cmd,
                            *template,
                            tiles.compute_layout,
                            (&data as *const bindings::TileTemplateData).cast(),
                        ),
                        None => {
                            let kinds = [
                                vk::DescriptorType::SAMPLED_IMAGE,
                                vk::DescriptorType::SAMPLER,
                            ];
                            let images = [[data.image], [data.sampler]];
                            let buffers = [data.tiles];
                            let mut writes: Vec<vk::WriteDescriptorSet<'_>> = (0..2)
                                .map(|i| {
                                    vk::WriteDescriptorSet::default()
                                        .dst_binding(i as u32)
                                        .descriptor_type(kinds[i])
                                        .image_info(&images[i])
                                })
                                .collect();
                            writes.push(
                                vk::WriteDescriptorSet::default()
                                    .dst_binding(2)
                                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                                    .buffer_info(&buffers),
                            );
                            gpu.cmd_push_descriptor_set(cmd, compute, tiles.compute_layout, &writes)
                        }
                    };
                    anyhow::ensure!(pushed, "VK_KHR_push_descriptor is not enabled");
                }
            }
        }
        Ok(())
    }

    /// The nearest sampler the depth pyramid reads with (the depth-read bindings').
    fn tile_sampler(&self) -> Result<vk::Sampler> {
        self.renderer
            .depth_read
            .as_ref()
            .map(|r| r.nearest)
            .ok_or_else(|| anyhow!("the depth tiles are built without a pass sampling depth"))
    }

    /// The depth pyramid's dispatch ([`Step::BuildDepthTiles`]), its state bound first unless
    /// this recording bound it already ([`Step::BindDepthTiles`]), then a barrier ordering its
    /// writes before fragment shader reads (and the next frame's dispatch after those reads,
    /// which the frames' fences already do).
    fn build_depth_tiles(&self, cmd: vk::CommandBuffer) -> Result<()> {
        let tiles = self
            .renderer
            .depth_tiles
            .as_ref()
            .ok_or_else(|| anyhow!("no depth tile bindings"))?;
        if !self.tiles_bound {
            self.bind_depth_tiles(cmd)?;
        }
        let groups = |n: u32| n.div_ceil(8);
        let barrier = vk::BufferMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::SHADER_WRITE)
            .dst_access_mask(vk::AccessFlags::SHADER_READ)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .buffer(tiles.tiles.buffer)
            .size(vk::WHOLE_SIZE);
        // SAFETY: `cmd` is a recording primary outside any pass; the compute state is bound,
        // the main depth is in SHADER_READ_ONLY_OPTIMAL (plan check).
        unsafe {
            let device = self.device();
            device.cmd_dispatch(cmd, groups(tiles.count.0), groups(tiles.count.1), 1);
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::FRAGMENT_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[barrier],
                &[],
            );
        }
        Ok(())
    }

    /// Pushes the post pass's descriptors (`vkCmdPushDescriptorSetKHR`, another way an
    /// application hands a depth view to shaders): the main depth's depth view in
    /// `SHADER_READ_ONLY_OPTIMAL` and the two samplers.
    fn push_depth_descriptors(&self, cmd: vk::CommandBuffer) {
        let Some(reads) = &self.renderer.depth_read else {
            return;
        };
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: self.targets.depth.depth_view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let samplers = [reads.nearest, reads.linear].map(|sampler| vk::DescriptorImageInfo {
            sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        });
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&image_info),
            vk::WriteDescriptorSet::default()
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&samplers[..1]),
            vk::WriteDescriptorSet::default()
                .dst_binding(2)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&samplers[1..]),
        ];
        // SAFETY: `cmd` is recording with the post pipeline (of the push-descriptor layout)
        // bound; the view and samplers are live, the infos match the binding types.
        unsafe {
            self.renderer.gpu.cmd_push_descriptor_set(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.renderer.depth_push_layout,
                &writes,
            )
        };
    }

    fn begin_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        n: usize,
        contents: vk::SubpassContents,
    ) -> Result<()> {
        self.pass = Some(n);
        self.subpass = 0;
        self.pipeline = None;
        let pass = &self.plan.passes[n];
        if pass.kind.is_dynamic_rendering() {
            let secondaries = contents == vk::SubpassContents::SECONDARY_COMMAND_BUFFERS;
            return self.begin_rendering(cmd, n, false, secondaries);
        }
        let (color_clear, depth_clear) = self.clear_values(n);
        let clear_values = match (pass.target, pass.multisample) {
            // The multisampled attachments are cleared; their resolve attachments are not (a
            // kept depth has none).
            (Target::Main, Some(m)) if m.sampled_depth => {
                vec![color_clear, depth_clear, color_clear]
            }
            (Target::Main, Some(_)) => vec![color_clear, depth_clear, color_clear, depth_clear],
            (Target::Main, None) => vec![color_clear, depth_clear],
            (Target::Shadow | Target::DepthSlice { .. }, _) => vec![depth_clear],
            // Loaded: no clear values are read.
            (Target::SoftParticles | Target::Post, _) => Vec::new(),
        };
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(self.renderer.render_passes[n])
            .framebuffer(self.renderer.framebuffers[n])
            .render_area(vk::Rect2D {
                offset: vk::Offset2D { x: 0, y: 0 },
                extent: target_extent(pass.target, self.targets.extent),
            })
            .clear_values(&clear_values);
        // SAFETY: `cmd` is a recording primary outside any pass; the framebuffer was made for
        // this render pass, with one clear value per attachment.
        unsafe { self.device().cmd_begin_render_pass(cmd, &begin, contents) };
        // Where a render pass has multiview enabled, every state outside the render pass is
        // undefined from its beginning on (the vertex and index buffers too, for the passes
        // after it as well): they are bound again, as multiview applications do (pipelines,
        // descriptor sets and push constants are given by each subpass's own steps).
        let multiview = self
            .plan
            .passes
            .iter()
            .any(|p| p.view_mask != 0 && !p.kind.is_dynamic_rendering());
        if multiview && contents == vk::SubpassContents::INLINE {
            self.bind_geometry(cmd);
        }
        Ok(())
    }

    /// `vkCmdBeginRendering` over the main target, after a barrier that puts both attachments
    /// in their attachment layouts (from nothing when cleared, keeping them when loaded) and
    /// orders earlier attachment writes before this rendering's load ops. A multisampled pass
    /// renders into the multisampled attachments (from nothing: they are transient) and
    /// resolves them into the main images, whose previous contents do not matter either. A
    /// local-read rendering ([`PassKind::DynamicRenderingLocalRead`]) has the depth in
    /// `RENDERING_LOCAL_READ_KHR` instead (the barrier puts it there, [`Self::end_pass`] back)
    /// and, where it maps the depth to an input attachment index, sets that mapping with
    /// `vkCmdSetRenderingInputAttachmentIndicesKHR` right after `vkCmdBeginRendering`, as its
    /// pipelines have it.
    ///
    /// `resuming`: the rendering of a [`PassKind::DynamicRenderingSuspended`] pass begun again
    /// after its first instance (no barrier: nothing may be recorded between the two), with
    /// `VK_RENDERING_RESUMING_BIT` and otherwise the same info; its first instance is begun
    /// with `VK_RENDERING_SUSPENDING_BIT`. `secondaries`: the rendering's draws are recorded
    /// in secondary command buffers (`VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT`).
    fn begin_rendering(
        &self,
        cmd: vk::CommandBuffer,
        n: usize,
        resuming: bool,
        secondaries: bool,
    ) -> Result<()> {
        let pass = &self.plan.passes[n];
        let (color_clear, depth_clear) = self.clear_values(n);
        let targets = self.targets;
        let multisampled = match pass.multisample {
            Some(_) => Some(multisampled_targets(targets)?),
            None => None,
        };
        let depth_load = match pass.depth {
            DepthLoad::Clear(_) => vk::AttachmentLoadOp::CLEAR,
            DepthLoad::Load => vk::AttachmentLoadOp::LOAD,
        };
        let color_load = map_color_load(pass.load_color);
        let color_layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
        // The main depth's layout between passes, and in this rendering.
        let attachment_layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
        let depth_layout = if pass.kind.reads_locally() {
            vk::ImageLayout::RENDERING_LOCAL_READ_KHR
        } else {
            attachment_layout
        };
        let old = |load, layout| {
            if load == vk::AttachmentLoadOp::LOAD {
                layout
            } else {
                vk::ImageLayout::UNDEFINED
            }
        };
        let color_access =
            vk::AccessFlags::COLOR_ATTACHMENT_READ | vk::AccessFlags::COLOR_ATTACHMENT_WRITE;
        let depth_access = vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
        // Every layer a multiview rendering renders (the main images have one otherwise).
        let layers = 32 - pass.view_mask.leading_zeros();
        let barrier = |image, aspects, src_access, dst_access, old_layout, new_layout| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(src_access)
                .dst_access_mask(dst_access)
                .old_layout(old_layout)
                .new_layout(new_layout)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(vk::ImageSubresourceRange {
                    layer_count: layers.max(1),
                    ..full_range(aspects)
                })
        };
        let depth_aspects = targets.depth_format.aspects();
        let mut barriers = vec![
            barrier(
                targets.color.image,
                vk::ImageAspectFlags::COLOR,
                vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                color_access,
                old(color_load, color_layout),
                color_layout,
            ),
            // A resolve destination is written in the color attachment output stage, with
            // color attachment writes, depth included.
            barrier(
                targets.depth.image,
                depth_aspects,
                vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                if multisampled.is_some() {
                    depth_access | vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                } else {
                    depth_access
                },
                old(depth_load, attachment_layout),
                depth_layout,
            ),
        ];
        if let Some(ms) = multisampled {
            barriers.push(barrier(
                ms.color.image,
                vk::ImageAspectFlags::COLOR,
                vk::AccessFlags::empty(),
                color_access,
                vk::ImageLayout::UNDEFINED,
                color_layout,
            ));
            barriers.push(barrier(
                ms.depth.image,
                depth_aspects,
                vk::AccessFlags::empty(),
                depth_access,
                vk::ImageLayout::UNDEFINED,
                attachment_layout,
            ));
        }
        let stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
            | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
        let (color_view, depth_view) = if pass.view_mask != 0 {
            (targets.color.array_view, targets.depth.array_view)
        } else {
            (targets.color.view, targets.depth.view)
        };
        let color_attachment = vk::RenderingAttachmentInfo::default()
            .image_view(color_view)
            .image_layout(color_layout)
            .load_op(color_load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(color_clear);
        let depth_attachment = vk::RenderingAttachmentInfo::default()
            .image_view(depth_view)
            .image_layout(depth_layout)
            .load_op(depth_load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(depth_clear);
        let has_stencil = targets.depth_format.has_stencil();
        // The same view and clear value; the stencil is cleared to 0 or loaded with depth.
        let mut stencil_attachment = depth_attachment;
        let (color_attachments, depth_attachment) = match multisampled {
            Some(ms) => {
                // Draw into the multisampled attachments (not stored: transient) and resolve
                // them into the main images.
                let resolved = |attachment: vk::RenderingAttachmentInfo<'static>,
                                view,
                                mode,
                                resolve_view,
                                layout| {
                    let attachment = attachment
                        .image_view(view)
                        .store_op(vk::AttachmentStoreOp::DONT_CARE)
                        .resolve_mode(mode);
                    if mode == vk::ResolveModeFlags::NONE {
                        attachment
                    } else {
                        attachment
                            .resolve_image_view(resolve_view)
                            .resolve_image_layout(layout)
                    }
                };
                stencil_attachment = resolved(
                    stencil_attachment,
                    ms.depth.view,
                    ms.resolve.stencil,
                    targets.depth.view,
                    depth_layout,
                );
                let depth = resolved(
                    depth_attachment,
                    ms.depth.view,
                    ms.resolve.depth,
                    targets.depth.view,
                    depth_layout,
                );
                let color = resolved(
                    color_attachment,
                    ms.color.view,
                    vk::ResolveModeFlags::AVERAGE,
                    targets.color.view,
                    color_layout,
                );
                ([color], depth)
            }
            None => ([color_attachment], depth_attachment),
        };
        let mut info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D { x: 0, y: 0 },
                extent: targets.extent,
            })
            .layer_count(1)
            .view_mask(pass.view_mask)
            .color_attachments(&color_attachments)
            .depth_attachment(&depth_attachment);
        if has_stencil {
            info = info.stencil_attachment(&stencil_attachment);
        }
        let contents = if secondaries {
            vk::RenderingFlags::CONTENTS_SECONDARY_COMMAND_BUFFERS
        } else {
            vk::RenderingFlags::empty()
        };
        info = info.flags(
            contents
                | match (pass.kind, resuming) {
                    (_, true) => vk::RenderingFlags::RESUMING,
                    (PassKind::DynamicRenderingSuspended { .. }, false) => {
                        vk::RenderingFlags::SUSPENDING
                    }
                    _ => vk::RenderingFlags::empty(),
                },
        );
        // SAFETY: `cmd` is a recording primary outside any pass; the device has
        // dynamicRendering enabled (checked before rendering); the views cover the images
        // transitioned by the barrier; multisampled views resolve into single-sample views of
        // the same formats with modes the device supports (checked with the targets). A
        // resuming instance follows its suspended one with nothing in between.
        unsafe {
            if !resuming {
                self.device().cmd_pipeline_barrier(
                    cmd,
                    stages,
                    stages,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &barriers,
                );
            }
            self.renderer.gpu.cmd_begin_rendering(cmd, &info);
        }
        if pass.kind == (PassKind::DynamicRenderingLocalRead { indexed: true }) {
            let local_read = self
                .renderer
                .gpu
                .dynamic_rendering_local_read
                .as_ref()
                .ok_or_else(|| anyhow!("VK_KHR_dynamic_rendering_local_read is not enabled"))?;
            let color_indices = [vk::ATTACHMENT_UNUSED];
            let indices = vk::RenderingInputAttachmentIndexInfoKHR::default()
                .color_attachment_input_indices(&color_indices)
                .depth_input_attachment_index(&crate::pipeline::DEPTH_INPUT_ATTACHMENT_INDEX);
            // SAFETY: `cmd` is inside the rendering just begun, with one color attachment; the
            // extension is enabled (checked above).
            unsafe { local_read.cmd_set_rendering_input_attachment_indices(cmd, &indices) };
        }
        Ok(())
    }

    /// The by-region barrier a local-read rendering records between the draws that write its
    /// attachments and those that read the depth as an input attachment (its
    /// [`Step::NextSubpass`]), as a render pass's subpass dependency orders them in
    /// [`PassKind::DepthInputSubpasses`]: a memory barrier (no image barrier: nothing changes
    /// layout inside a rendering) from the depth and color attachment writes to the input
    /// attachment reads, the depth tests and the color reads and writes of the same pixels.
    fn local_read_barrier(&self, cmd: vk::CommandBuffer) {
        let depth_stages = vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
        let barrier = vk::MemoryBarrier::default()
            .src_access_mask(
                vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE
                    | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            )
            .dst_access_mask(
                vk::AccessFlags::INPUT_ATTACHMENT_READ
                    | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags::COLOR_ATTACHMENT_READ
                    | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            );
        // SAFETY: `cmd` is inside a local-read rendering (plan check), on a device with
        // dynamicRenderingLocalRead enabled (checked before rendering); BY_REGION, framebuffer
        // stages and a memory barrier alone, as barriers inside a rendering must be.
        unsafe {
            self.device().cmd_pipeline_barrier(
                cmd,
                depth_stages | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::FRAGMENT_SHADER
                    | depth_stages
                    | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::DependencyFlags::BY_REGION,
                &[barrier],
                &[],
                &[],
            )
        };
    }

    /// Ends `cmd` (a suspended rendering's first instance just ended in it) and begins the
    /// renderer's second primary, which the frame goes on in (its geometry bound again: a
    /// command buffer inherits nothing); returns it. Once per frame (the plan check).
    fn continue_in_next_primary(&mut self, cmd: vk::CommandBuffer) -> Result<vk::CommandBuffer> {
        let next = self
            .continuation
            .take()
            .ok_or_else(|| anyhow!("no second primary command buffer to resume in"))?;
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: `cmd` is a recording primary outside any render pass instance; `next` is a
        // primary of the same pool, reset with it and not in use.
        unsafe {
            self.device()
                .end_command_buffer(cmd)
                .context("vkEndCommandBuffer (suspending primary) failed")?;
            self.device()
                .begin_command_buffer(next, &begin)
                .context("vkBeginCommandBuffer (resuming primary) failed")?;
        }
        self.pipeline = None;
        self.bind_geometry(next);
        Ok(next)
    }

    /// The clear values of pass `n`'s attachments: the color's, and the depth's (its
    /// [`DepthLoad::Clear`] value, 1.0 where it loads) with the stencil's.
    fn clear_values(&self, n: usize) -> (vk::ClearValue, vk::ClearValue) {
        let depth = match self.plan.passes[n].depth {
            DepthLoad::Clear(depth) => depth,
            DepthLoad::Load => 1.0,
        };
        let depth_clear = vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth,
                stencil: CLEAR_STENCIL,
            },
        };
        let color_clear = vk::ClearValue {
            color: vk::ClearColorValue {
                float32: CLEAR_COLOR,
            },
        };
        (color_clear, depth_clear)
    }

    fn end_pass(&mut self, cmd: vk::CommandBuffer) {
        let Some(n) = self.pass.take() else { return };
        self.pipeline = None;
        let kind = self.plan.passes[n].kind;
        // SAFETY: `cmd` is inside the pass begun by the matching BeginPass.
        unsafe {
            if kind.is_dynamic_rendering() {
                self.renderer.gpu.cmd_end_rendering(cmd);
            } else {
                self.device().cmd_end_render_pass(cmd);
            }
        }
        if kind.reads_locally() {
            // The depth back from RENDERING_LOCAL_READ_KHR into its attachment layout, after
            // the rendering's tests, reads and store, before the next pass's tests and the
            // read-back's copy.
            let depth_stages = vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
                | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
            let depth_access = vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
            let barrier = vk::ImageMemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE)
                .dst_access_mask(depth_access | vk::AccessFlags::TRANSFER_READ)
                .old_layout(vk::ImageLayout::RENDERING_LOCAL_READ_KHR)
                .new_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(self.targets.depth.image)
                .subresource_range(full_range(self.targets.depth_format.aspects()));
            // SAFETY: `cmd` is a recording primary just outside the rendering, which left the
            // whole main depth image in RENDERING_LOCAL_READ_KHR.
            unsafe {
                self.device().cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::FRAGMENT_SHADER | depth_stages,
                    depth_stages | vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &[barrier],
                )
            };
        }
    }

    fn bind(&mut self, cmd: vk::CommandBuffer, n: usize) {
        self.pipeline = Some(n);
        let renderer = self.renderer;
        let spec = &self.plan.pipelines[n];
        let objects = match spec.program {
            Program::ShaderObjects
            | Program::LinkedShaderObjects
            | Program::LinkedTessellationShaderObjects
            | Program::PassthroughGeometryShaderObjects
            | Program::ProjectingGeometryShaderObjects => renderer.shader_objects.as_ref(),
            Program::MeshShaderObjects => renderer.mesh_shader_objects.as_ref(),
            _ => None,
        };
        if let Some(objects) = objects {
            let pass = &self.plan.passes[spec.pass];
            let target = super::shader_objects::BindTarget {
                extent: self.current_extent(),
                samples: vk::SampleCountFlags::from_raw(pass.samples()),
                has_color: pass.has_color(spec.subpass),
                bias_clamp: renderer.bias_clamp,
            };
            // SAFETY: `cmd` is recording inside a pass compatible with the spec's (plan
            // check), on the renderer's device; the mesh set matches the shaders' layout.
            unsafe {
                objects.bind(renderer.gpu, cmd, spec, &target);
                if let (Program::MeshShaderObjects, Some(mesh)) = (spec.program, &renderer.mesh) {
                    self.device().cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::GRAPHICS,
                        mesh.layout,
                        0,
                        &[mesh.set],
                        &[],
                    );
                }
            }
            return;
        }
        // SAFETY: `cmd` is inside a pass compatible with the pipeline (plan check); the
        // descriptor set matches the shadow layout's only set.
        unsafe {
            self.device().cmd_bind_pipeline(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                renderer.pipelines[n],
            );
            let set = match self.plan.pipelines[n].program {
                Program::ShadowReceiver | Program::ShadowReceiverRaw => {
                    renderer.shadow.as_ref().map(|s| s.set)
                }
                Program::MvpPair => renderer.colors.as_ref().map(|c| c.set),
                Program::SoftParticle => renderer.depth_read.as_ref().map(|r| r.read_only_set),
                Program::DepthPost if renderer.depth_push_layout != vk::PipelineLayout::null() => {
                    self.push_depth_descriptors(cmd);
                    None
                }
                Program::DepthPost
                | Program::StencilPost
                | Program::DepthMipsPost
                | Program::DepthLayersPost => renderer.depth_read.as_ref().map(|r| r.sampled_set),
                Program::DepthTiles => renderer.depth_tiles.as_ref().map(|t| t.set),
                Program::DepthInput | Program::DepthInputUndecorated => {
                    renderer.depth_input.as_ref().map(|i| i.set)
                }
                Program::DepthPostMs => renderer.multisampled_read.as_ref().map(|r| r.set),
                Program::Mesh => renderer.mesh.as_ref().map(|m| m.set),
                Program::Multiview => renderer.multiview.as_ref().map(|m| m.set),
                // The storage buffer holds every object, indexed by the instance index; the
                // dynamic uniform buffers are bound at each draw with its offset.
                Program::Ssbo
                | Program::SsboRows
                | Program::SsboRegisters
                | Program::SsboColumns
                | Program::SsboVkd3d => renderer.matrices.as_ref().map(|m| m.set),
                _ => None,
            };
            if let Some(set) = set {
                let (layout, _) = renderer.layout(self.plan.pipelines[n].program);
                self.device().cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    layout,
                    0,
                    &[set],
                    &[],
                );
            }
        }
    }

    /// `vkCmdPushConstants` of bytes `offset..offset + size` of object `n`'s constants for
    /// the bound program.
    fn push(&self, cmd: vk::CommandBuffer, n: usize, offset: u32, size: u32) -> Result<()> {
        let pipeline = self
            .pipeline
            .ok_or_else(|| anyhow!("push constants without a bound pipeline"))?;
        let program = self.plan.pipelines[pipeline].program;
        let view = match self.pass.map(|p| self.plan.passes[p].target) {
            Some(Target::Shadow) => View::Light,
            _ => View::Camera,
        };
        let object = self
            .scene
            .objects
            .get(n)
            .ok_or_else(|| anyhow!("no object {n}"))?;
        let constants = self
            .scene
            .push_constants_in(program, view, object, self.aspect);
        let bytes = constants
            .get(offset as usize..(offset + size) as usize)
            .ok_or_else(|| anyhow!("push range {offset}+{size} outside the constants"))?;
        let (layout, stages) = self.renderer.layout(program);
        if let Some(ranges) = super::split_ranges(program) {
            // One push per range the bytes reach, each naming its range's stage.
            for &range in ranges {
                let start = offset.max(range.offset);
                let end = (offset + size).min(range.offset + range.size);
                if start < end {
                    let part = &bytes[(start - offset) as usize..(end - offset) as usize];
                    // SAFETY: `cmd` is recording; the layout is the bound pipeline's, whose
                    // range of this stage holds exactly these bytes.
                    unsafe {
                        self.device().cmd_push_constants(
                            cmd,
                            layout,
                            range.stage_flags,
                            start,
                            part,
                        )
                    };
                }
            }
            return Ok(());
        }
        // SAFETY: `cmd` is recording; the layout is the bound pipeline's, whose push-constant
        // range covers these 4-aligned bytes for exactly these stages (plan check).
        unsafe {
            self.device()
                .cmd_push_constants(cmd, layout, stages, offset, bytes)
        };
        Ok(())
    }

    /// Draws object `n`, after pushing all of its constants when `push` is set.
    fn draw(&self, cmd: vk::CommandBuffer, n: usize, push: bool) -> Result<()> {
        let pipeline = self
            .pipeline
            .ok_or_else(|| anyhow!("draw without a bound pipeline"))?;
        let program = self.plan.pipelines[pipeline].program;
        // The buffer deliveries have no push constants: nothing to push.
        if push && program.push_constant_size() > 0 {
            self.push(cmd, n, 0, program.push_constant_size())?;
        }
        let range = self.buffers.draws[n];
        if matches!(program.buffers(), Some(Program::Ubo | Program::UboDynamic)) {
            let matrices = self
                .renderer
                .matrices
                .as_ref()
                .filter(|m| m.program == program)
                .ok_or_else(|| anyhow!("no buffers for the {program:?} program"))?;
            let offset = u32::try_from(n as u64 * matrices.stride).context("dynamic offset")?;
            // SAFETY: `cmd` is recording with a pipeline of this layout bound; the set's one
            // dynamic binding gets object n's block, inside the buffer.
            unsafe {
                self.device().cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.renderer.matrix_layout,
                    0,
                    &[matrices.set],
                    &[offset],
                );
            }
        }
        // The shadow receiver indexes its light MVPs, the pair program its colors, the storage
        // buffer delivery its objects, with the instance index.
        let first_instance = if matches!(
            program,
            Program::ShadowReceiver
                | Program::ShadowReceiverRaw
                | Program::MvpPair
                | Program::Ssbo
                | Program::SsboRows
                | Program::SsboRegisters
                | Program::SsboColumns
                | Program::SsboVkd3d
        ) {
            u32::try_from(n).context("object index")?
        } else {
            0
        };
        if matches!(program, Program::Mesh | Program::MeshShaderObjects) {
            let (layout, stages) = self.renderer.layout(program);
            let meshes = self
                .renderer
                .gpu
                .mesh_shader
                .as_ref()
                .ok_or_else(|| anyhow!("the mesh program needs VK_EXT_mesh_shader enabled"))?;
            // SAFETY: `cmd` is recording inside a pass with the mesh pipeline bound, its set
            // bound and its first 80 bytes pushed; the range's bytes follow them in the
            // layout's one range; the workgroups read indices inside the draw's range.
            unsafe {
                self.device().cmd_push_constants(
                    cmd,
                    layout,
                    stages,
                    super::mesh::DRAW_RANGE_OFFSET,
                    &super::mesh::draw_range_bytes(range),
                );
                meshes.cmd_draw_mesh_tasks(cmd, super::mesh::workgroups(range), 1, 1);
            }
            return Ok(());
        }
        // SAFETY: `cmd` is recording inside a pass with a bound pipeline and its push
        // constants written (plan check); the draw range indexes the bound buffers.
        unsafe {
            self.device().cmd_draw_indexed(
                cmd,
                range.index_count,
                1,
                range.first_index,
                range.vertex_offset,
                first_instance,
            );
        }
        Ok(())
    }

    fn set_depth_bias(&self, cmd: vk::CommandBuffer, bias: DepthBias) {
        let clamp = if self.renderer.bias_clamp {
            bias.clamp
        } else {
            0.0
        };
        // SAFETY: `cmd` is recording; the bound pipeline's bias is dynamic; the clamp is 0
        // unless the depthBiasClamp feature is enabled.
        unsafe {
            self.device()
                .cmd_set_depth_bias(cmd, bias.constant, clamp, bias.slope)
        };
    }

    /// `vkCmdClearAttachments` of the depth aspect over a fraction of the target.
    fn clear_depth_rect(&self, cmd: vk::CommandBuffer, [x0, y0, x1, y1]: [f32; 4], depth: f32) {
        let extent = self.targets.extent;
        let px = |f: f32, size: u32| (f * size as f32).round() as u32;
        let (left, top) = (px(x0, extent.width), px(y0, extent.height));
        let (right, bottom) = (px(x1, extent.width), px(y1, extent.height));
        let rect = vk::ClearRect {
            rect: vk::Rect2D {
                offset: vk::Offset2D {
                    x: left as i32,
                    y: top as i32,
                },
                extent: vk::Extent2D {
                    width: right.saturating_sub(left).max(1),
                    height: bottom.saturating_sub(top).max(1),
                },
            },
            base_array_layer: 0,
            layer_count: 1,
        };
        let attachment = vk::ClearAttachment {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            color_attachment: 0,
            clear_value: vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth,
                    stencil: CLEAR_STENCIL,
                },
            },
        };
        // SAFETY: `cmd` is inside a main-target pass with a depth attachment; the rectangle
        // lies within the render area.
        unsafe {
            self.device()
                .cmd_clear_attachments(cmd, &[attachment], &[rect])
        };
    }

    /// Begins a fresh secondary command buffer that continues pass `n`, inheriting its render
    /// pass, the current subpass and (if `framebuffer`) its framebuffer; in a dynamic
    /// rendering, the rendering's formats, view mask and sample count
    /// (`VkCommandBufferInheritanceRenderingInfo`, no render pass).
    fn begin_secondary(
        &self,
        secondary: vk::CommandBuffer,
        n: usize,
        framebuffer: bool,
    ) -> VkResult<()> {
        let pass = &self.plan.passes[n];
        let color_formats = [crate::target::COLOR_FORMAT];
        let depth = self.targets.depth_format.vk_format();
        let stencil = if self.targets.depth_format.has_stencil() {
            depth
        } else {
            vk::Format::UNDEFINED
        };
        let mut rendering = vk::CommandBufferInheritanceRenderingInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(depth)
            .stencil_attachment_format(stencil)
            .view_mask(pass.view_mask)
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let inheritance = if pass.kind.is_dynamic_rendering() {
            vk::CommandBufferInheritanceInfo::default().push_next(&mut rendering)
        } else {
            let framebuffer = if framebuffer {
                self.renderer.framebuffers[n]
            } else {
                vk::Framebuffer::null()
            };
            vk::CommandBufferInheritanceInfo::default()
                .render_pass(self.renderer.render_passes[n])
                .subpass(self.subpass)
                .framebuffer(framebuffer)
        };
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(
                vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE
                    | vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT,
            )
            .inheritance_info(&inheritance);
        // SAFETY: a fresh secondary of one of this device's pools; the inheritance names the
        // current render pass, subpass and framebuffer, or the formats of the single-sample
        // rendering it continues (plan check).
        unsafe { self.device().begin_command_buffer(secondary, &begin) }
    }

    /// Records each list into the next secondary command buffer and executes them.
    fn execute_secondaries(&mut self, cmd: vk::CommandBuffer, lists: &[Vec<Step>]) -> Result<()> {
        let n = self
            .pass
            .ok_or_else(|| anyhow!("secondaries outside a pass"))?;
        let mut recorded = Vec::with_capacity(lists.len());
        for list in lists {
            let secondary = *self
                .renderer
                .secondaries
                .get(self.next_secondary)
                .ok_or_else(|| anyhow!("not enough secondary command buffers"))?;
            self.next_secondary += 1;
            self.begin_secondary(secondary, n, true)
                .context("vkBeginCommandBuffer (secondary) failed")?;
            // Secondaries inherit no bound state: geometry and pipeline are bound again.
            self.pipeline = None;
            self.bind_geometry(secondary);
            self.record(secondary, list)?;
            // SAFETY: the secondary is recording.
            unsafe { self.device().end_command_buffer(secondary) }
                .context("vkEndCommandBuffer (secondary) failed")?;
            recorded.push(secondary);
        }
        self.pipeline = None;
        // SAFETY: `cmd` is a primary inside a subpass begun with SECONDARY_COMMAND_BUFFERS
        // contents; the secondaries were recorded for it.
        unsafe { self.device().cmd_execute_commands(cmd, &recorded) };
        Ok(())
    }

    /// Records each list on its own thread, at the same time: each thread creates its own
    /// command pool, allocates a secondary from it, records the list with its own recorder
    /// state (binding geometry, pipeline and push constants itself) and hands the pool and
    /// the secondary back; then one `vkCmdExecuteCommands` runs them in list order. With
    /// `odd_without_framebuffer`, the odd-numbered lists inherit no framebuffer.
    fn execute_secondaries_on_threads(
        &mut self,
        cmd: vk::CommandBuffer,
        lists: &[Vec<Step>],
        odd_without_framebuffer: bool,
    ) -> Result<()> {
        let n = self
            .pass
            .ok_or_else(|| anyhow!("secondaries outside a pass"))?;
        let (renderer, scene, plan) = (self.renderer, self.scene, self.plan);
        let (buffers, targets, aspect, subpass) =
            (self.buffers, self.targets, self.aspect, self.subpass);
        let results: Vec<Result<(vk::CommandPool, vk::CommandBuffer)>> =
            std::thread::scope(|scope| {
                let threads: Vec<_> = lists
                    .iter()
                    .enumerate()
                    .map(|(index, list)| {
                        let framebuffer = !(odd_without_framebuffer && index % 2 == 1);
                        let mut recorder = Recorder {
                            renderer,
                            scene,
                            plan,
                            buffers,
                            targets,
                            aspect,
                            pass: Some(n),
                            subpass,
                            pipeline: None,
                            next_secondary: 0,
                            tiles_bound: false,
                            thread_pools: Vec::new(),
                            continuation: None,
                        };
                        scope.spawn(move || recorder.record_on_own_pool(list, framebuffer))
                    })
                    .collect();
                threads
                    .into_iter()
                    .map(|thread| {
                        thread
                            .join()
                            .unwrap_or_else(|_| Err(anyhow!("a recording thread panicked")))
                    })
                    .collect()
            });
        let mut recorded = Vec::with_capacity(results.len());
        let mut first_error = None;
        for result in results {
            match result {
                Ok((pool, secondary)) => {
                    self.thread_pools.push(pool);
                    recorded.push(secondary);
                }
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        if let Some(e) = first_error {
            return Err(e);
        }
        self.pipeline = None;
        // SAFETY: `cmd` is a primary inside a subpass begun with SECONDARY_COMMAND_BUFFERS
        // contents; the secondaries were recorded for it, and their pools are only destroyed
        // after the submission completes.
        unsafe { self.device().cmd_execute_commands(cmd, &recorded) };
        Ok(())
    }

    /// On a recording thread: creates a command pool, allocates one secondary from it and
    /// records `list` into it, inheriting the current render pass, subpass and (if
    /// `framebuffer`) framebuffer. On failure the pool is destroyed again.
    fn record_on_own_pool(
        &mut self,
        list: &[Step],
        framebuffer: bool,
    ) -> Result<(vk::CommandPool, vk::CommandBuffer)> {
        let device = self.renderer.device;
        let n = self
            .pass
            .ok_or_else(|| anyhow!("secondaries outside a pass"))?;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .flags(vk::CommandPoolCreateFlags::TRANSIENT)
            .queue_family_index(self.renderer.queue_family);
        // SAFETY: valid device, queue family of the device's queue.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("vkCreateCommandPool (recording thread) failed")?;
        let recorded = (|| {
            let info = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::SECONDARY)
                .command_buffer_count(1);
            // SAFETY: valid pool, used by this thread only.
            let secondary = unsafe { device.allocate_command_buffers(&info) }
                .context("vkAllocateCommandBuffers (recording thread) failed")?
                .into_iter()
                .next()
                .ok_or_else(|| anyhow!("vkAllocateCommandBuffers returned no command buffer"))?;
            self.begin_secondary(secondary, n, framebuffer)
                .context("vkBeginCommandBuffer (recording thread) failed")?;
            self.bind_geometry(secondary);
            self.record(secondary, list)?;
            // SAFETY: the secondary is recording.
            unsafe { device.end_command_buffer(secondary) }
                .context("vkEndCommandBuffer (recording thread) failed")?;
            Ok(secondary)
        })();
        match recorded {
            Ok(secondary) => Ok((pool, secondary)),
            Err(e) => {
                // SAFETY: nothing recorded in the pool was submitted.
                unsafe { device.destroy_command_pool(pool, None) };
                Err(e)
            }
        }
    }
}
