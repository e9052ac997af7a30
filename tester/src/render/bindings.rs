//! The descriptor sets and uniform buffers of the programs that need them: object colors
//! ([`Program::MvpPair`]), per-object matrices in buffers, and the shadow map's sampler and
//! light matrices.

use super::*;

impl<'a> Renderer<'a> {
    /// Creates the uniform buffer of object colors (`mvp_pair.frag`), its descriptor set and
    /// the [`Program::MvpPair`] pipeline layout.
    pub(super) fn create_color_bindings(&mut self, gpu: &'a Gpu, scene: &Scene) -> Result<()> {
        let device = self.device;
        if scene.objects.len() > MAX_OBJECT_COLORS {
            bail!(
                "scene '{}' has more than {MAX_OBJECT_COLORS} objects",
                scene.name
            );
        }
        let mut bytes = vec![0u8; MAX_OBJECT_COLORS * 16];
        let colors = scene.objects.iter().flat_map(|o| o.color);
        for (chunk, value) in bytes.chunks_exact_mut(4).zip(colors) {
            chunk.copy_from_slice(&value.to_le_bytes());
        }
        let mut buffer = HostBuffer::new(gpu, bytes.len(), vk::BufferUsageFlags::UNIFORM_BUFFER)
            .context("object color uniform buffer")?;
        buffer.write(&bytes);
        // Stored at once so that `Drop` destroys whatever was made, even if a later step fails.
        let colors = self.colors.insert(ColorBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            colors: buffer,
        });
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::FRAGMENT)];
        colors.set = single_descriptor_set(
            device,
            &bindings,
            "colors",
            &mut colors.set_layout,
            &mut colors.pool,
        )?;
        let set_layouts = [colors.set_layout];
        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: colors.colors.buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let writes = [vk::WriteDescriptorSet::default()
            .dst_set(colors.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .buffer_info(&buffer_info)];
        // SAFETY: valid set and buffer; the info matches the binding type.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let ranges = super::pair_push_constant_ranges(gpu.limits().max_push_constants_size);
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&ranges);
        // SAFETY: valid device and create info.
        self.pair_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (model-view-projection pair) failed")?;
        Ok(())
    }

    /// Creates the buffers of a buffer delivery (`program`: every object's block at an aligned
    /// stride, the frame block of `ubo-dynamic`), their descriptor set and the pipeline layout
    /// of its pipelines (that set, no push constants).
    pub(super) fn create_matrix_bindings(
        &mut self,
        gpu: &'a Gpu,
        scene: &Scene,
        program: Program,
        aspect: f64,
    ) -> Result<()> {
        let device = self.device;
        let limits = gpu.limits();
        let blocks: Vec<Vec<u8>> = scene
            .objects
            .iter()
            .map(|o| scene.object_block(program, o, aspect))
            .collect();
        let block = blocks.first().map_or(0, Vec::len) as u64;
        if block == 0 {
            bail!("scene '{}' has no object to draw", scene.name);
        }
        let (usage, object_type, stride) = match program.buffers().unwrap_or(program) {
            Program::Ssbo => (
                vk::BufferUsageFlags::STORAGE_BUFFER,
                vk::DescriptorType::STORAGE_BUFFER,
                block,
            ),
            _ => {
                if block > u64::from(limits.max_uniform_buffer_range) {
                    bail!(
                        "a {block}-byte uniform block exceeds maxUniformBufferRange ({})",
                        limits.max_uniform_buffer_range
                    );
                }
                let alignment = limits.min_uniform_buffer_offset_alignment.max(1);
                (
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                    vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC,
                    block.div_ceil(alignment) * alignment,
                )
            }
        };
        let size = usize::try_from(stride * blocks.len() as u64).context("buffer size")?;
        if program.buffers() == Some(Program::Ssbo)
            && size as u64 > u64::from(limits.max_storage_buffer_range)
        {
            bail!(
                "{size} bytes of storage buffer exceed maxStorageBufferRange ({})",
                limits.max_storage_buffer_range
            );
        }
        let mut bytes = vec![0u8; size];
        for (n, data) in blocks.iter().enumerate() {
            let at = n * stride as usize;
            bytes[at..at + data.len()].copy_from_slice(data);
        }
        let mut objects = HostBuffer::new(gpu, size, usage).context("object matrix buffer")?;
        objects.write(&bytes);
        let frame = if program == Program::UboDynamic {
            let data = scene.frame_block(aspect);
            let mut frame = HostBuffer::new(gpu, data.len(), vk::BufferUsageFlags::UNIFORM_BUFFER)
                .context("frame uniform buffer")?;
            frame.write(&data);
            Some(frame)
        } else {
            None
        };
        // Stored at once so that `Drop` destroys whatever was made, even if a later step fails.
        let matrices = self.matrices.insert(MatrixBindings {
            program,
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            stride,
            objects,
            frame,
        });
        // (binding, type, buffer, range)
        let mut layout: Vec<(u32, vk::DescriptorType, vk::Buffer, u64)> = Vec::new();
        if let Some(frame) = &matrices.frame {
            layout.push((0, vk::DescriptorType::UNIFORM_BUFFER, frame.buffer, 64));
        }
        let object_range = if object_type == vk::DescriptorType::STORAGE_BUFFER {
            vk::WHOLE_SIZE
        } else {
            block
        };
        layout.push((
            layout.len() as u32,
            object_type,
            matrices.objects.buffer,
            object_range,
        ));
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = layout
            .iter()
            .map(|&(binding, kind, _, _)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(binding)
                    .descriptor_type(kind)
                    .descriptor_count(1)
                    .stage_flags(program.projecting_stage())
            })
            .collect();
        matrices.set = single_descriptor_set(
            device,
            &bindings,
            "object matrices",
            &mut matrices.set_layout,
            &mut matrices.pool,
        )?;
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = layout
            .iter()
            .map(|&(_, _, buffer, range)| {
                [vk::DescriptorBufferInfo {
                    buffer,
                    offset: 0,
                    range,
                }]
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = layout
            .iter()
            .zip(&infos)
            .map(|(&(binding, kind, _, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(matrices.set)
                    .dst_binding(binding)
                    .descriptor_type(kind)
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: valid set and buffers; the infos match the binding types, and each range
        // lies within its buffer (a dynamic offset of object n, n * stride, keeps it inside).
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let set_layouts = [matrices.set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid device and create info.
        self.matrix_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (buffer delivery) failed")?;
        Ok(())
    }

    /// Creates the shadow receiver's descriptor set (light MVPs, shadow map, comparison
    /// sampler) and pipeline layout.
    pub(super) fn create_shadow_bindings(
        &mut self,
        gpu: &'a Gpu,
        targets: &Targets<'_>,
        scene: &Scene,
    ) -> Result<()> {
        let device = self.device;
        let mvps = scene.light_mvps();
        if mvps.len() > MAX_LIGHT_MVPS {
            bail!(
                "scene '{}' has more than {MAX_LIGHT_MVPS} objects",
                scene.name
            );
        }
        let mut bytes = vec![0u8; MAX_LIGHT_MVPS * 64];
        for (chunk, value) in bytes.chunks_exact_mut(4).zip(mvps.iter().flatten()) {
            chunk.copy_from_slice(&value.to_le_bytes());
        }
        let mut light = HostBuffer::new(gpu, bytes.len(), vk::BufferUsageFlags::UNIFORM_BUFFER)
            .context("light uniform buffer")?;
        light.write(&bytes);

        let sampler_info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_BORDER)
            // Outside the map: depth 1.0, the far plane: lit.
            .border_color(vk::BorderColor::FLOAT_OPAQUE_WHITE)
            .compare_enable(true)
            .compare_op(map_compare(crate::plan::Compare::LessOrEqual))
            .min_lod(0.0)
            .max_lod(0.0);
        // SAFETY: valid device and create info.
        let sampler = unsafe { device.create_sampler(&sampler_info, None) }
            .context("vkCreateSampler failed")?;
        // Stored at once (null handles filled in below) so that `Drop` destroys whatever was
        // made, even if a later step fails.
        let shadow = self.shadow.insert(ShadowBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            sampler,
            plain_sampler: vk::Sampler::null(),
            light,
        });
        let plain_info = vk::SamplerCreateInfo {
            compare_enable: vk::FALSE,
            compare_op: vk::CompareOp::NEVER,
            address_mode_u: vk::SamplerAddressMode::CLAMP_TO_EDGE,
            address_mode_v: vk::SamplerAddressMode::CLAMP_TO_EDGE,
            address_mode_w: vk::SamplerAddressMode::CLAMP_TO_EDGE,
            ..sampler_info
        };
        // SAFETY: valid device and create info.
        shadow.plain_sampler = unsafe { device.create_sampler(&plain_info, None) }
            .context("vkCreateSampler (plain) failed")?;
        let bindings = [
            (
                0,
                vk::DescriptorType::UNIFORM_BUFFER,
                vk::ShaderStageFlags::VERTEX,
            ),
            (
                1,
                vk::DescriptorType::SAMPLED_IMAGE,
                vk::ShaderStageFlags::FRAGMENT,
            ),
            (
                2,
                vk::DescriptorType::SAMPLER,
                vk::ShaderStageFlags::FRAGMENT,
            ),
            (
                3,
                vk::DescriptorType::SAMPLER,
                vk::ShaderStageFlags::FRAGMENT,
            ),
        ]
        .map(|(binding, kind, stages)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(stages)
        });
        shadow.set = single_descriptor_set(
            device,
            &bindings,
            "shadow map",
            &mut shadow.set_layout,
            &mut shadow.pool,
        )?;
        let (set, set_layouts, plain_sampler) =
            (shadow.set, [shadow.set_layout], shadow.plain_sampler);
        let light_buffer = shadow.light.buffer;

        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: light_buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: shadow_view(targets)?,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let sampler_info = [vk::DescriptorImageInfo {
            sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        }];
        let plain_sampler_info = [vk::DescriptorImageInfo {
            sampler: plain_sampler,
            ..sampler_info[0]
        }];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                .buffer_info(&buffer_info),
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&image_info),
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(2)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&sampler_info),
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(3)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&plain_sampler_info),
        ];
        // `shadow-map-raw` writes its set through a descriptor update template (another of
        // the paths by which an application hands a depth view to shaders; core since Vulkan
        // 1.1, so a Vulkan 1.0 render writes it as the others do), every other scene with
        // `vkUpdateDescriptorSets`.
        let through_template = gpu.api_version() >= vk::API_VERSION_1_1
            && scene
                .plan
                .pipelines
                .iter()
                .any(|p| p.program == crate::plan::Program::ShadowReceiverRaw);
        if through_template {
            update_through_template(
                device,
                set,
                set_layouts[0],
                &ShadowData {
                    light: buffer_info[0],
                    map: image_info[0],
                    sampler: sampler_info[0],
                    plain_sampler: plain_sampler_info[0],
                },
            )?;
        } else {
            // SAFETY: valid set, buffer, view and sampler; the infos match the binding types.
            unsafe { device.update_descriptor_sets(&writes, &[]) };
        }

        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.shadow_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (shadow receiver) failed")?;
        Ok(())
    }
}

impl Renderer<'_> {
    /// Creates the depth-read bindings ([`DepthReadBindings`]) and their pipeline layout (the
    /// set, and the 80-byte push constants).
    pub(super) fn create_depth_read_bindings(
        &mut self,
        gpu: &Gpu,
        targets: &Targets<'_>,
    ) -> Result<()> {
        let device = self.device;
        let view = targets.depth.depth_view;
        if view == vk::ImageView::null() {
            bail!("the scene samples the main depth but it has no depth view");
        }
        let nearest_info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .min_lod(0.0)
            .max_lod(0.0);
        // SAFETY: valid device and create info.
        let nearest = unsafe { device.create_sampler(&nearest_info, None) }
            .context("vkCreateSampler (nearest) failed")?;
        // Stored at once (null handles filled in below) so that `Drop` destroys whatever was
        // made, even if a later step fails.
        let reads = self.depth_read.insert(DepthReadBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            push_set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            read_only_set: vk::DescriptorSet::null(),
            sampled_set: vk::DescriptorSet::null(),
            nearest,
            linear: vk::Sampler::null(),
        });
        // Where the device filters the depth format linearly; nearest otherwise (lavapipe
        // 22.3), which still samples through `texture`, not a fetch.
        let filter = if crate::target::filters_linearly(gpu, targets.depth.format) {
            vk::Filter::LINEAR
        } else {
            vk::Filter::NEAREST
        };
        let linear_info = nearest_info.mag_filter(filter).min_filter(filter);
        // SAFETY: valid device and create info.
        reads.linear = unsafe { device.create_sampler(&linear_info, None) }
            .context("vkCreateSampler (linear) failed")?;
        // Binding 3, the stencil aspect's view, is written where the format has stencil (only
        // `stencil_post.frag` reads it, in scenes that need a stencil format).
        let bindings = [
            (0, vk::DescriptorType::SAMPLED_IMAGE),
            (1, vk::DescriptorType::SAMPLER),
            (2, vk::DescriptorType::SAMPLER),
            (3, vk::DescriptorType::SAMPLED_IMAGE),
        ]
        .map(|(binding, kind)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::FRAGMENT)
        });
        let sets = descriptor_sets(
            device,
            &bindings,
            2,
            "main depth",
            &mut reads.set_layout,
            &mut reads.pool,
        )?;
        (reads.read_only_set, reads.sampled_set) = (sets[0], sets[1]);
        let sampler_infos = [reads.nearest, reads.linear].map(|sampler| vk::DescriptorImageInfo {
            sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        });
        for (set, layout) in [
            (
                reads.read_only_set,
                vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
            ),
            (reads.sampled_set, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
        ] {
            let image_info = [vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: view,
                image_layout: layout,
            }];
            let writes = [
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                    .image_info(&image_info),
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::SAMPLER)
                    .image_info(&sampler_infos[..1]),
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(2)
                    .descriptor_type(vk::DescriptorType::SAMPLER)
                    .image_info(&sampler_infos[1..]),
            ];
            // SAFETY: valid set, view and samplers; the infos match the binding types.
            unsafe { device.update_descriptor_sets(&writes, &[]) };
            let stencil = targets.depth.stencil_view;
            if stencil != vk::ImageView::null() {
                let stencil_info = [vk::DescriptorImageInfo {
                    sampler: vk::Sampler::null(),
                    image_view: stencil,
                    image_layout: layout,
                }];
                let write = vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(3)
                    .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                    .image_info(&stencil_info);
                // SAFETY: valid set and view; the info matches the binding type.
                unsafe { device.update_descriptor_sets(&[write], &[]) };
            }
        }
        if gpu.enabled.push_descriptor {
            let info = vk::DescriptorSetLayoutCreateInfo::default()
                .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
                .bindings(&bindings);
            // SAFETY: valid device (with VK_KHR_push_descriptor) and create info.
            reads.push_set_layout = unsafe { device.create_descriptor_set_layout(&info, None) }
                .context("vkCreateDescriptorSetLayout (pushed main depth) failed")?;
        }
        let (set_layout, push_set_layout) = (reads.set_layout, reads.push_set_layout);
        let pipeline_layout = |set_layout: vk::DescriptorSetLayout| {
            let set_layouts = [set_layout];
            let layout_info = vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(&PUSH_CONSTANT_RANGES);
            // SAFETY: valid device and create info.
            unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (depth reads) failed")
        };
        self.depth_read_layout = pipeline_layout(set_layout)?;
        if push_set_layout != vk::DescriptorSetLayout::null() {
            self.depth_push_layout = pipeline_layout(push_set_layout)?;
        }
        Ok(())
    }
}

impl Renderer<'_> {
    /// Creates the input-attachment bindings ([`InputBindings`]: one `INPUT_ATTACHMENT`
    /// descriptor for the fragment stage, the main depth's depth-aspect view in `layout`, the
    /// one its passes read it in: `DEPTH_STENCIL_READ_ONLY_OPTIMAL` in a render pass,
    /// `RENDERING_LOCAL_READ_KHR` in a local-read rendering) and the layout of
    /// [`Program::DepthInput`] and [`Program::DepthInputUndecorated`] pipelines (the set, and
    /// the 80-byte push constants).
    pub(super) fn create_input_bindings(
        &mut self,
        targets: &Targets<'_>,
        layout: vk::ImageLayout,
    ) -> Result<()> {
        let device = self.device;
        let view = targets.depth.depth_view;
        if view == vk::ImageView::null() {
            bail!("the scene reads the main depth as an input attachment but it has no depth view");
        }
        let input = self.depth_input.insert(InputBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
        });
        let bindings = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::INPUT_ATTACHMENT)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::FRAGMENT)];
        input.set = single_descriptor_set(
            device,
            &bindings,
            "depth input attachment",
            &mut input.set_layout,
            &mut input.pool,
        )?;
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: view,
            image_layout: layout,
        }];
        let writes = [vk::WriteDescriptorSet::default()
            .dst_set(input.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::INPUT_ATTACHMENT)
            .image_info(&image_info)];
        // SAFETY: valid set and view; the info matches the binding type.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let set_layouts = [input.set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.input_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (depth input attachment) failed")?;
        Ok(())
    }
}

impl Renderer<'_> {
    /// Creates the bindings of [`Program::DepthPostMs`] ([`MultisampledReadBindings`]: the
    /// multisampled depth's depth-aspect view in `SHADER_READ_ONLY_OPTIMAL` and a nearest
    /// sampler) and its pipeline layout (the set, and the 80-byte push constants).
    pub(super) fn create_multisampled_read_bindings(
        &mut self,
        targets: &Targets<'_>,
    ) -> Result<()> {
        let device = self.device;
        let view = targets
            .multisampled
            .as_ref()
            .map_or(vk::ImageView::null(), |ms| ms.depth.depth_view);
        if view == vk::ImageView::null() {
            bail!("the scene samples a multisampled depth image that no multisampled pass keeps");
        }
        let sampler_info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .min_lod(0.0)
            .max_lod(0.0);
        // SAFETY: valid device and create info.
        let sampler = unsafe { device.create_sampler(&sampler_info, None) }
            .context("vkCreateSampler (multisampled depth) failed")?;
        // Stored at once (null handles filled in below) so that `Drop` destroys whatever was
        // made, even if a later step fails.
        let reads = self.multisampled_read.insert(MultisampledReadBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            sampler,
        });
        let bindings = [
            (0, vk::DescriptorType::SAMPLED_IMAGE),
            (1, vk::DescriptorType::SAMPLER),
        ]
        .map(|(binding, kind)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::FRAGMENT)
        });
        reads.set = single_descriptor_set(
            device,
            &bindings,
            "multisampled depth",
            &mut reads.set_layout,
            &mut reads.pool,
        )?;
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let sampler_info = [vk::DescriptorImageInfo {
            sampler: reads.sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        }];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(reads.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&image_info),
            vk::WriteDescriptorSet::default()
                .dst_set(reads.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&sampler_info),
        ];
        // SAFETY: valid set, view and sampler; the infos match the binding types.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let set_layouts = [reads.set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.multisampled_read_layout =
            unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (multisampled depth reads) failed")?;
        Ok(())
    }
}

impl<'a> Renderer<'a> {
    /// Creates the depth pyramid's bindings ([`TileBindings`]), its compute pipeline and the
    /// layout of [`Program::DepthTiles`] pipelines; the compute pipeline takes its
    /// descriptors as `descriptors` says (`None`: the set), from a descriptor buffer
    /// ([`TileDescriptorBuffer`]) or pushed. Needs the depth-read bindings (their nearest
    /// sampler).
    pub(super) fn create_tile_bindings(
        &mut self,
        gpu: &'a Gpu,
        targets: &Targets<'_>,
        descriptors: Option<crate::plan::TileDescriptors>,
    ) -> Result<()> {
        use crate::plan::TileDescriptors;
        let descriptor_buffer = matches!(
            descriptors,
            Some(TileDescriptors::Buffer | TileDescriptors::Buffer2)
        );
        let device = self.device;
        let nearest =
            self.depth_read.as_ref().map(|r| r.nearest).ok_or_else(|| {
                anyhow!("the depth tiles are built without a pass sampling depth")
            })?;
        let count = (targets.extent.width / 4, targets.extent.height / 4);
        let size = (count.0 * count.1) as usize * 8;
        let usage = if descriptor_buffer {
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
        } else {
            vk::BufferUsageFlags::STORAGE_BUFFER
        };
        let tiles = HostBuffer::new(gpu, size.max(8), usage).context("depth tiles buffer")?;
        let tiles = self.depth_tiles.insert(TileBindings {
            set_layout: vk::DescriptorSetLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            tiles,
            count,
            compute_layout: vk::PipelineLayout::null(),
            compute: vk::Pipeline::null(),
            compute_descriptors: ComputeTileDescriptors::Set,
            binds_with_infos: matches!(
                descriptors,
                Some(TileDescriptors::Sets2 | TileDescriptors::Buffer2)
            ),
        });
        let stages = vk::ShaderStageFlags::COMPUTE | vk::ShaderStageFlags::FRAGMENT;
        let kinds = [
            vk::DescriptorType::SAMPLED_IMAGE,
            vk::DescriptorType::SAMPLER,
            vk::DescriptorType::STORAGE_BUFFER,
        ];
        let bindings = [0, 1, 2].map(|binding| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(kinds[binding as usize])
                .descriptor_count(1)
                .stage_flags(stages)
        });
        tiles.set = single_descriptor_set(
            device,
            &bindings,
            "depth tiles",
            &mut tiles.set_layout,
            &mut tiles.pool,
        )?;
        let image_info = [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: targets.depth.depth_view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }];
        let sampler_info = [vk::DescriptorImageInfo {
            sampler: nearest,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        }];
        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: tiles.tiles.buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(tiles.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                .image_info(&image_info),
            vk::WriteDescriptorSet::default()
                .dst_set(tiles.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&sampler_info),
            vk::WriteDescriptorSet::default()
                .dst_set(tiles.set)
                .dst_binding(2)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&buffer_info),
        ];
        // SAFETY: valid set, view, sampler and buffer; the infos match the binding types.
        unsafe { device.update_descriptor_sets(&writes, &[]) };
        let set_layouts = [tiles.set_layout];
        let mut compute_set_layouts = set_layouts;
        match descriptors {
            None
            | Some(
                TileDescriptors::Sets | TileDescriptors::ShaderObject | TileDescriptors::Sets2,
            ) => {}
            Some(TileDescriptors::Buffer | TileDescriptors::Buffer2) => {
                let buffer =
                    tile_descriptor_buffer(gpu, &bindings, (&image_info, nearest, &tiles.tiles))?;
                compute_set_layouts = [buffer.set_layout];
                tiles.compute_descriptors = ComputeTileDescriptors::Buffer(buffer);
            }
            Some(TileDescriptors::Push | TileDescriptors::PushTemplate) => {
                let info = vk::DescriptorSetLayoutCreateInfo::default()
                    .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
                    .bindings(&bindings);
                // SAFETY: valid device and create info (VK_KHR_push_descriptor enabled).
                let set_layout = unsafe { device.create_descriptor_set_layout(&info, None) }
                    .context("vkCreateDescriptorSetLayout (depth tiles, pushed) failed")?;
                compute_set_layouts = [set_layout];
                tiles.compute_descriptors = ComputeTileDescriptors::Push {
                    set_layout,
                    template: None,
                };
            }
        }
        let compute_layout_info =
            vk::PipelineLayoutCreateInfo::default().set_layouts(&compute_set_layouts);
        // SAFETY: valid device and create info.
        tiles.compute_layout = unsafe { device.create_pipeline_layout(&compute_layout_info, None) }
            .context("vkCreatePipelineLayout (depth tiles) failed")?;
        if descriptors == Some(TileDescriptors::ShaderObject) {
            let objects = gpu
                .shader_object
                .as_ref()
                .ok_or_else(|| anyhow!("VK_EXT_shader_object is not enabled"))?;
            let words = crate::shaders::DEPTH_TILES_COMP.words()?;
            let info = vk::ShaderCreateInfoEXT::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .code_type(vk::ShaderCodeTypeEXT::SPIRV)
                .code(super::shader_objects::bytes_of(&words))
                .name(c"main")
                .set_layouts(&compute_set_layouts);
            // SAFETY: valid SPIR-V of the compute stage (checked by the shader tests), a live
            // device with the extension enabled.
            let shader = unsafe { objects.create_shaders(std::slice::from_ref(&info), None) }
                .map_err(|(_, e)| anyhow!("vkCreateShadersEXT (depth tiles) failed: {e}"))?[0];
            tiles.compute_descriptors = ComputeTileDescriptors::ShaderObject(shader);
        }
        if descriptors == Some(TileDescriptors::PushTemplate) {
            let template = push_tiles_template(device, tiles.compute_layout)?;
            if let ComputeTileDescriptors::Push { template: kept, .. } =
                &mut tiles.compute_descriptors
            {
                *kept = Some(template);
            }
        }
        let words = crate::shaders::DEPTH_TILES_COMP.words()?;
        let module_info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid device and SPIR-V (checked by the shader tests).
        let module = unsafe { device.create_shader_module(&module_info, None) }
            .context("vkCreateShaderModule (depth tiles) failed")?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let flags = if descriptor_buffer {
            vk::PipelineCreateFlags::DESCRIPTOR_BUFFER_EXT
        } else {
            vk::PipelineCreateFlags::empty()
        };
        let info = vk::ComputePipelineCreateInfo::default()
            .flags(flags)
            .stage(stage)
            .layout(tiles.compute_layout);
        // SAFETY: valid device, module and layout.
        let created =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) };
        // SAFETY: the module is no longer needed once the pipeline is created (or failed).
        unsafe { device.destroy_shader_module(module, None) };
        tiles.compute = created
            .map_err(|(_, e)| anyhow!("vkCreateComputePipelines (depth tiles) failed: {e}"))?
            .into_iter()
            .next()
            .ok_or_else(|| anyhow!("vkCreateComputePipelines returned no pipeline"))?;
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.tiles_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (depth tiles shading) failed")?;
        Ok(())
    }
}

/// The depth pyramid's descriptors as a push template reads them (bindings 0 to 2).
#[repr(C)]
pub(super) struct TileTemplateData {
    pub image: vk::DescriptorImageInfo,
    pub sampler: vk::DescriptorImageInfo,
    pub tiles: vk::DescriptorBufferInfo,
}

/// A push-descriptor update template of the compute bind point for set 0 of `layout`, reading
/// [`TileTemplateData`].
fn push_tiles_template(
    device: &ash::Device,
    layout: vk::PipelineLayout,
) -> Result<vk::DescriptorUpdateTemplate> {
    let image = std::mem::size_of::<vk::DescriptorImageInfo>();
    let entry = |binding: u32, ty, offset| vk::DescriptorUpdateTemplateEntry {
        dst_binding: binding,
        dst_array_element: 0,
        descriptor_count: 1,
        descriptor_type: ty,
        offset,
        stride: 0,
    };
    let entries = [
        entry(0, vk::DescriptorType::SAMPLED_IMAGE, 0),
        entry(1, vk::DescriptorType::SAMPLER, image),
        entry(2, vk::DescriptorType::STORAGE_BUFFER, 2 * image),
    ];
    let info = vk::DescriptorUpdateTemplateCreateInfo::default()
        .descriptor_update_entries(&entries)
        .template_type(vk::DescriptorUpdateTemplateType::PUSH_DESCRIPTORS_KHR)
        .pipeline_bind_point(vk::PipelineBindPoint::COMPUTE)
        .pipeline_layout(layout)
        .set(0);
    // SAFETY: valid device and create info (entries within `TileTemplateData`, of set 0's
    // bindings and types; VK_KHR_push_descriptor enabled).
    unsafe { device.create_descriptor_update_template(&info, None) }
        .context("vkCreateDescriptorUpdateTemplate (depth tiles, pushed) failed")
}

/// The depth pyramid's compute descriptors in a descriptor buffer: a set layout of `bindings`
/// made for descriptor buffers, and a buffer holding, at the offsets the device gives, the
/// descriptors of the main depth's view (`image`: revz hands back its read twin's), the
/// nearest sampler and the tiles buffer (by its address).
fn tile_descriptor_buffer<'a>(
    gpu: &'a Gpu,
    bindings: &[vk::DescriptorSetLayoutBinding<'_>; 3],
    (image, sampler, tiles): (&[vk::DescriptorImageInfo; 1], vk::Sampler, &HostBuffer<'_>),
) -> Result<TileDescriptorBuffer<'a>> {
    let device = &gpu.device;
    let (commands, properties) = gpu
        .descriptor_buffer
        .as_ref()
        .ok_or_else(|| anyhow!("descriptor buffers are not enabled"))?;
    let info = vk::DescriptorSetLayoutCreateInfo::default()
        .flags(vk::DescriptorSetLayoutCreateFlags::DESCRIPTOR_BUFFER_EXT)
        .bindings(bindings);
    // SAFETY: valid device and create info (descriptorBuffer enabled).
    let set_layout = unsafe { device.create_descriptor_set_layout(&info, None) }
        .context("vkCreateDescriptorSetLayout (depth tiles, descriptor buffer) failed")?;
    let made = (|| {
        // SAFETY: a set layout made for descriptor buffers.
        let size = unsafe { commands.get_descriptor_set_layout_size(set_layout) } as usize;
        let mut descriptors = HostBuffer::new(gpu, size.max(16), TILE_DESCRIPTOR_BUFFER_USAGE)
            .context("depth tiles descriptor buffer")?;
        let address = vk::DescriptorAddressInfoEXT::default()
            .address(tiles.address())
            .range(tiles.contents().len() as vk::DeviceSize);
        let mut bytes = vec![0u8; size];
        for binding in bindings {
            let (data, length) = match binding.descriptor_type {
                vk::DescriptorType::SAMPLED_IMAGE => (
                    vk::DescriptorDataEXT {
                        p_sampled_image: image.as_ptr(),
                    },
                    properties.sampled_image_descriptor_size,
                ),
                vk::DescriptorType::SAMPLER => (
                    vk::DescriptorDataEXT {
                        p_sampler: &sampler,
                    },
                    properties.sampler_descriptor_size,
                ),
                _ => (
                    vk::DescriptorDataEXT {
                        p_storage_buffer: &address,
                    },
                    properties.storage_buffer_descriptor_size,
                ),
            };
            // SAFETY: a binding of the layout.
            let offset = unsafe {
                commands.get_descriptor_set_layout_binding_offset(set_layout, binding.binding)
            } as usize;
            let slot = bytes
                .get_mut(offset..offset + length)
                .ok_or_else(|| anyhow!("binding {} lies past the set's size", binding.binding))?;
            let get = vk::DescriptorGetInfoEXT::default()
                .ty(binding.descriptor_type)
                .data(data);
            // SAFETY: the data points at live infos of the binding's type; `slot` is the
            // descriptor's size.
            unsafe { commands.get_descriptor(&get, slot) };
        }
        descriptors.write(&bytes);
        Ok(descriptors)
    })();
    match made {
        Ok(descriptors) => Ok(TileDescriptorBuffer {
            set_layout,
            descriptors,
        }),
        Err(e) => {
            // SAFETY: made above, used by nothing yet.
            unsafe { device.destroy_descriptor_set_layout(set_layout, None) };
            Err(e)
        }
    }
}

/// Creates a descriptor set layout of `bindings`, a pool with room for one set of it, and that
/// set. Each handle is stored as soon as it exists (`set_layout`, `pool`), so that the owner's
/// `Drop` destroys whatever was made when a later step fails.
pub(super) fn single_descriptor_set(
    device: &ash::Device,
    bindings: &[vk::DescriptorSetLayoutBinding<'_>],
    what: &str,
    set_layout: &mut vk::DescriptorSetLayout,
    pool: &mut vk::DescriptorPool,
) -> Result<vk::DescriptorSet> {
    descriptor_sets(device, bindings, 1, what, set_layout, pool)?
        .into_iter()
        .next()
        .ok_or_else(|| anyhow!("vkAllocateDescriptorSets ({what}) returned no set"))
}

/// As [`single_descriptor_set`], with room for and `count` sets of the layout.
fn descriptor_sets(
    device: &ash::Device,
    bindings: &[vk::DescriptorSetLayoutBinding<'_>],
    count: u32,
    what: &str,
    set_layout: &mut vk::DescriptorSetLayout,
    pool: &mut vk::DescriptorPool,
) -> Result<Vec<vk::DescriptorSet>> {
    let set_layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings);
    // SAFETY: valid device and create info.
    *set_layout = unsafe { device.create_descriptor_set_layout(&set_layout_info, None) }
        .with_context(|| format!("vkCreateDescriptorSetLayout ({what}) failed"))?;
    let sizes: Vec<vk::DescriptorPoolSize> = bindings
        .iter()
        .map(|b| vk::DescriptorPoolSize {
            ty: b.descriptor_type,
            descriptor_count: b.descriptor_count * count,
        })
        .collect();
    let pool_info = vk::DescriptorPoolCreateInfo::default()
        .max_sets(count)
        .pool_sizes(&sizes);
    // SAFETY: valid device and create info.
    *pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
        .with_context(|| format!("vkCreateDescriptorPool ({what}) failed"))?;
    let set_layouts = vec![*set_layout; count as usize];
    let allocate_info = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(*pool)
        .set_layouts(&set_layouts);
    // SAFETY: valid pool with room for `count` sets of this layout.
    unsafe { device.allocate_descriptor_sets(&allocate_info) }
        .with_context(|| format!("vkAllocateDescriptorSets ({what}) failed"))
}

/// The shadow set's descriptors as an update template reads them (bindings 0 to 3).
#[repr(C)]
struct ShadowData {
    light: vk::DescriptorBufferInfo,
    map: vk::DescriptorImageInfo,
    sampler: vk::DescriptorImageInfo,
    plain_sampler: vk::DescriptorImageInfo,
}

/// Writes the shadow set `set` (of `layout`) with `vkUpdateDescriptorSetWithTemplate`, through a
/// template made for it and destroyed after.
fn update_through_template(
    device: &ash::Device,
    set: vk::DescriptorSet,
    layout: vk::DescriptorSetLayout,
    data: &ShadowData,
) -> Result<()> {
    let image = std::mem::size_of::<vk::DescriptorImageInfo>();
    let entry =
        |binding: u32, kind: vk::DescriptorType, offset: usize| vk::DescriptorUpdateTemplateEntry {
            dst_binding: binding,
            dst_array_element: 0,
            descriptor_count: 1,
            descriptor_type: kind,
            offset,
            stride: image,
        };
    let light = std::mem::size_of::<vk::DescriptorBufferInfo>();
    let entries = [
        vk::DescriptorUpdateTemplateEntry {
            stride: light,
            ..entry(0, vk::DescriptorType::UNIFORM_BUFFER, 0)
        },
        entry(1, vk::DescriptorType::SAMPLED_IMAGE, light),
        entry(2, vk::DescriptorType::SAMPLER, light + image),
        entry(3, vk::DescriptorType::SAMPLER, light + 2 * image),
    ];
    let info = vk::DescriptorUpdateTemplateCreateInfo::default()
        .descriptor_update_entries(&entries)
        .template_type(vk::DescriptorUpdateTemplateType::DESCRIPTOR_SET)
        .descriptor_set_layout(layout);
    // SAFETY: valid device and create info (entries within `ShadowData`, of the set layout's
    // bindings and types).
    let template = unsafe { device.create_descriptor_update_template(&info, None) }
        .context("vkCreateDescriptorUpdateTemplate failed")?;
    // SAFETY: a set of `layout`, and data laid out as the template's entries say.
    unsafe {
        device.update_descriptor_set_with_template(
            set,
            template,
            (data as *const ShadowData).cast(),
        );
        device.destroy_descriptor_update_template(template, None);
    }
    Ok(())
}
