//! Drawing a scene: the scene's vertex and index buffers, the Vulkan objects its [`Plan`]
//! names (render passes and framebuffers, pipelines and their layouts, the shadow map's
//! sampler, uniform buffer and descriptor set, the uniform buffer of object colors), recording
//! of one primary command buffer (and any secondaries, on the main thread or one thread each
//! with its own command pool) by interpreting the plan's steps one by one, then the read-back
//! copies, and the single fenced submit.

use std::fmt;

use anyhow::{anyhow, bail, Context, Result};
use ash::prelude::VkResult;
use ash::vk;

use crate::gpu::{Gpu, HostBuffer};
use crate::pipeline::{
    create_pipeline, create_render_pass, create_resolving_render_pass, full_viewport,
    map_color_load, map_compare, MainFormats, PipelineTarget,
};
use crate::plan::{DepthBias, DepthLoad, PassKind, Plan, Program, Recording, Step, Target};
use crate::readback::Readback;
use crate::scene::{DrawRange, Scene, View};
use crate::target::{full_range, MultisampledTargets, Targets, SHADOW_MAP_SIZE};

/// The color the color attachment is cleared to: dark grey (25/255, exact in UNORM8).
pub const CLEAR_COLOR: [f32; 4] = [25.0 / 255.0, 25.0 / 255.0, 25.0 / 255.0, 1.0];
/// The stencil clear value.
pub const CLEAR_STENCIL: u32 = 0;
/// How long to wait for the GPU before giving up (lavapipe renders this in milliseconds).
const FENCE_TIMEOUT_NS: u64 = 60_000_000_000;
/// The light MVPs `shadow_receiver.vert` can index (its uniform array size).
const MAX_LIGHT_MVPS: usize = 16;
/// The object colors `mvp_pair.frag` can index (its uniform array size).
const MAX_OBJECT_COLORS: usize = 16;

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

/// What `shadow_receiver` pipelines bind: the light MVPs, the shadow map and its comparison
/// sampler, in one descriptor set.
struct ShadowBindings<'a> {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    sampler: vk::Sampler,
    light: HostBuffer<'a>,
}

/// What `mvp_pair` pipelines bind: the object colors, in one descriptor set.
struct ColorBindings<'a> {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    colors: HostBuffer<'a>,
}

/// What the buffer-delivery pipelines bind ([`Program::Ubo`], [`Program::UboDynamic`],
/// [`Program::Ssbo`]): every object's block ([`Scene::object_block`]) at `stride` bytes from
/// the last, and for `ubo-dynamic` the frame block ([`Scene::frame_block`]), in one
/// descriptor set. The host writes them once, before recording.
struct MatrixBindings<'a> {
    program: Program,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    /// Bytes from one object's block to the next: the block size rounded up to
    /// `minUniformBufferOffsetAlignment` for the dynamic uniform buffers (object `n`'s dynamic
    /// offset is `n * stride`), the std430 array stride (80) for the storage buffer.
    stride: u64,
    objects: HostBuffer<'a>,
    frame: Option<HostBuffer<'a>>,
}

/// Everything the plan names, for one render of the targets.
pub struct Renderer<'a> {
    /// The device's commands, with the extensions standing in for core ones below their
    /// version.
    gpu: &'a Gpu,
    device: &'a ash::Device,
    /// One per plan pass (null for dynamic rendering).
    render_passes: Vec<vk::RenderPass>,
    /// One per plan pass (null for dynamic rendering).
    framebuffers: Vec<vk::Framebuffer>,
    /// Push constants only.
    plain_layout: vk::PipelineLayout,
    /// Push constants and the shadow descriptor set (null without a shadow map).
    shadow_layout: vk::PipelineLayout,
    shadow: Option<ShadowBindings<'a>>,
    /// 128 bytes of vertex push constants and the color descriptor set (null without an
    /// [`Program::MvpPair`] pipeline).
    pair_layout: vk::PipelineLayout,
    colors: Option<ColorBindings<'a>>,
    /// The buffer-delivery pipelines' layout (no push constants; null without one).
    matrix_layout: vk::PipelineLayout,
    matrices: Option<MatrixBindings<'a>>,
    /// One per plan pipeline.
    pipelines: Vec<vk::Pipeline>,
    /// The libraries the pipelines built from `VK_EXT_graphics_pipeline_library` libraries
    /// were linked from (destroyed after them).
    libraries: Vec<vk::Pipeline>,
    command_pool: vk::CommandPool,
    /// The queue family of the command pools (recording threads create their own).
    queue_family: u32,
    command_buffer: vk::CommandBuffer,
    secondaries: Vec<vk::CommandBuffer>,
    fence: vk::Fence,
    extent: vk::Extent2D,
    bias_clamp: bool,
}

impl fmt::Debug for Renderer<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Renderer")
            .field("render_passes", &self.render_passes)
            .field("pipelines", &self.pipelines)
            .field("extent", &self.extent)
            .finish_non_exhaustive()
    }
}

impl Drop for Renderer<'_> {
    fn drop(&mut self) {
        // SAFETY: every handle is null or was created from `device`, which outlives `self`.
        // Waiting for idle first makes sure no submitted work still uses them (it matters only
        // on error paths: a normal render has already waited on its fence). Destroying null
        // handles is a no-op; destroying the pools frees their command buffers and set.
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.command_pool, None);
            for &pipeline in self.pipelines.iter().chain(&self.libraries) {
                self.device.destroy_pipeline(pipeline, None);
            }
            self.device
                .destroy_pipeline_layout(self.shadow_layout, None);
            self.device.destroy_pipeline_layout(self.plain_layout, None);
            self.device.destroy_pipeline_layout(self.pair_layout, None);
            self.device
                .destroy_pipeline_layout(self.matrix_layout, None);
            if let Some(matrices) = &self.matrices {
                self.device.destroy_descriptor_pool(matrices.pool, None);
                self.device
                    .destroy_descriptor_set_layout(matrices.set_layout, None);
            }
            if let Some(colors) = &self.colors {
                self.device.destroy_descriptor_pool(colors.pool, None);
                self.device
                    .destroy_descriptor_set_layout(colors.set_layout, None);
            }
            if let Some(shadow) = &self.shadow {
                self.device.destroy_descriptor_pool(shadow.pool, None);
                self.device
                    .destroy_descriptor_set_layout(shadow.set_layout, None);
                self.device.destroy_sampler(shadow.sampler, None);
            }
            for &framebuffer in &self.framebuffers {
                self.device.destroy_framebuffer(framebuffer, None);
            }
            for &render_pass in &self.render_passes {
                self.device.destroy_render_pass(render_pass, None);
            }
        }
    }
}

/// The stages that read the 80-byte push constants (`mvp`, then `color` for the fragment
/// shader).
const PLAIN_PUSH_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);

/// The push-constant range of the plain and shadow-receiver layouts.
const PUSH_CONSTANT_RANGES: [vk::PushConstantRange; 1] = [vk::PushConstantRange {
    stage_flags: PLAIN_PUSH_STAGES,
    offset: 0,
    size: 80,
}];

/// The push-constant range of the [`Program::MvpPair`] layout: two matrices, vertex stage only.
const PAIR_PUSH_CONSTANT_RANGES: [vk::PushConstantRange; 1] = [vk::PushConstantRange {
    stage_flags: vk::ShaderStageFlags::VERTEX,
    offset: 0,
    size: 128,
}];

impl<'a> Renderer<'a> {
    /// The pipelines, one per plan pipeline.
    pub fn pipelines(&self) -> &[vk::Pipeline] {
        &self.pipelines
    }

    /// Creates everything `scene`'s plan needs to render into `targets`.
    pub fn new(gpu: &'a Gpu, targets: &Targets<'_>, scene: &Scene) -> Result<Self> {
        let device = &gpu.device;
        let plan = &scene.plan;
        let needs = plan.needs();
        let mut this = Renderer {
            gpu,
            device,
            render_passes: Vec::new(),
            framebuffers: Vec::new(),
            plain_layout: vk::PipelineLayout::null(),
            shadow_layout: vk::PipelineLayout::null(),
            shadow: None,
            pair_layout: vk::PipelineLayout::null(),
            colors: None,
            matrix_layout: vk::PipelineLayout::null(),
            matrices: None,
            pipelines: Vec::new(),
            libraries: Vec::new(),
            command_pool: vk::CommandPool::null(),
            queue_family: gpu.queue_family,
            command_buffer: vk::CommandBuffer::null(),
            secondaries: Vec::new(),
            fence: vk::Fence::null(),
            extent: targets.extent,
            bias_clamp: gpu.enabled.depth_bias_clamp,
        };
        let main = MainFormats {
            depth: targets.depth.format,
            stencil: targets.depth_format.has_stencil(),
        };
        for pass in &plan.passes {
            if pass.kind == PassKind::DynamicRendering {
                this.render_passes.push(vk::RenderPass::null());
                this.framebuffers.push(vk::Framebuffer::null());
                continue;
            }
            let multisampled = match pass.multisample {
                Some(_) => Some(multisampled_targets(targets)?),
                None => None,
            };
            let render_pass = match multisampled {
                Some(ms) => create_resolving_render_pass(gpu, pass, main, ms.samples, ms.resolve)?,
                None => create_render_pass(device, pass, main)?,
            };
            this.render_passes.push(render_pass);
            let (views, extent) = match (pass.target, multisampled) {
                (Target::Main, Some(ms)) => (
                    vec![
                        ms.color.view,
                        ms.depth.view,
                        targets.color.view,
                        targets.depth.view,
                    ],
                    targets.extent,
                ),
                (Target::Main, None) => {
                    (vec![targets.color.view, targets.depth.view], targets.extent)
                }
                (Target::Shadow, _) => (
                    vec![shadow_view(targets)?],
                    vk::Extent2D {
                        width: SHADOW_MAP_SIZE,
                        height: SHADOW_MAP_SIZE,
                    },
                ),
            };
            let info = vk::FramebufferCreateInfo::default()
                .render_pass(render_pass)
                .attachments(&views)
                .width(extent.width)
                .height(extent.height)
                .layers(1);
            // SAFETY: valid render pass and views compatible with it.
            let framebuffer = unsafe { device.create_framebuffer(&info, None) }
                .context("vkCreateFramebuffer failed")?;
            this.framebuffers.push(framebuffer);
        }

        let layout_info =
            vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        this.plain_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout failed")?;
        if needs.shadow_map {
            this.create_shadow_bindings(gpu, targets, scene)?;
        }
        if plan.pipelines.iter().any(|p| p.program == Program::MvpPair) {
            let limit = gpu.limits().max_push_constants_size;
            if limit < 128 {
                bail!("the device's maxPushConstantsSize is {limit}, 128 are needed");
            }
            this.create_color_bindings(gpu, scene)?;
        }
        if let Some(program) = plan.buffer_program() {
            let aspect = f64::from(targets.extent.width) / f64::from(targets.extent.height);
            this.create_matrix_bindings(gpu, scene, program, aspect)?;
        }

        for spec in &plan.pipelines {
            let pass = &plan.passes[spec.pass];
            let (layout, _) = this.layout(spec.program);
            let built = create_pipeline(
                device,
                spec,
                PipelineTarget {
                    pass,
                    render_pass: this.render_passes[spec.pass],
                    layout,
                    extent: target_extent(pass.target, targets.extent),
                    main,
                    bias_clamp: this.bias_clamp,
                },
            )?;
            this.pipelines.push(built.pipeline);
            this.libraries.extend(built.libraries);
        }

        let pool_info = vk::CommandPoolCreateInfo::default()
            .flags(vk::CommandPoolCreateFlags::TRANSIENT)
            .queue_family_index(gpu.queue_family);
        // SAFETY: valid device, queue family of the device's queue.
        this.command_pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("vkCreateCommandPool failed")?;
        let allocate = |level, count| {
            let info = vk::CommandBufferAllocateInfo::default()
                .command_pool(this.command_pool)
                .level(level)
                .command_buffer_count(count);
            // SAFETY: valid pool.
            unsafe { device.allocate_command_buffers(&info) }
                .context("vkAllocateCommandBuffers failed")
        };
        this.command_buffer = allocate(vk::CommandBufferLevel::PRIMARY, 1)?
            .into_iter()
            .next()
            .ok_or_else(|| anyhow!("vkAllocateCommandBuffers returned no command buffer"))?;
        if needs.secondaries > 0 {
            let count = u32::try_from(needs.secondaries).context("secondary count")?;
            this.secondaries = allocate(vk::CommandBufferLevel::SECONDARY, count)?;
        }

        // SAFETY: valid device, default (unsignalled) fence.
        this.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .context("vkCreateFence failed")?;
        Ok(this)
    }

    /// The pipeline layout of `program` and the stages its push constants are pushed for.
    fn layout(&self, program: Program) -> (vk::PipelineLayout, vk::ShaderStageFlags) {
        match program {
            Program::ShadowReceiver => (self.shadow_layout, PLAIN_PUSH_STAGES),
            Program::MvpPair => (self.pair_layout, vk::ShaderStageFlags::VERTEX),
            Program::Ubo | Program::UboDynamic | Program::Ssbo => {
                (self.matrix_layout, vk::ShaderStageFlags::empty())
            }
            Program::Flat
            | Program::DepthOnly
            | Program::FragDepth
            | Program::RowMajor
            | Program::RowVector
            | Program::LitMvp => (self.plain_layout, PLAIN_PUSH_STAGES),
        }
    }

    /// Creates the uniform buffer of object colors (`mvp_pair.frag`), its descriptor set and
    /// the [`Program::MvpPair`] pipeline layout.
    fn create_color_bindings(&mut self, gpu: &'a Gpu, scene: &Scene) -> Result<()> {
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
        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PAIR_PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.pair_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (model-view-projection pair) failed")?;
        Ok(())
    }

    /// Creates the buffers of a buffer delivery (`program`: every object's block at an aligned
    /// stride, the frame block of `ubo-dynamic`), their descriptor set and the pipeline layout
    /// of its pipelines (that set, no push constants).
    fn create_matrix_bindings(
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
        let (usage, object_type, stride) = match program {
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
        if program == Program::Ssbo && size as u64 > u64::from(limits.max_storage_buffer_range) {
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
                    .stage_flags(vk::ShaderStageFlags::VERTEX)
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
    fn create_shadow_bindings(
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
            light,
        });
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
        let (set, set_layouts) = (shadow.set, [shadow.set_layout]);
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
        ];
        // SAFETY: valid set, buffer, view and sampler; the infos match the binding types.
        unsafe { device.update_descriptor_sets(&writes, &[]) };

        let layout_info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&PUSH_CONSTANT_RANGES);
        // SAFETY: valid device and create info.
        self.shadow_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .context("vkCreatePipelineLayout (shadow receiver) failed")?;
        Ok(())
    }

    /// Makes the renderer ready to render again after a completed [`Renderer::render`]: the
    /// fence unsignalled, the primary command buffer back in the initial state (its pool
    /// reset: the pool is TRANSIENT, without per-buffer reset).
    pub fn next_frame(&self) -> Result<()> {
        // SAFETY: the last render waited on the fence: nothing of the pool is pending.
        unsafe {
            self.device
                .reset_fences(&[self.fence])
                .context("vkResetFences failed")?;
            self.device
                .reset_command_pool(self.command_pool, vk::CommandPoolResetFlags::empty())
                .context("vkResetCommandPool failed")?;
        }
        Ok(())
    }

    /// Records the plan's steps and the read-back copies, submits them and waits for them to
    /// complete. The read-back buffers are ready when this returns.
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
        if scene.objects.len() != buffers.draws.len() {
            bail!("scene buffers were uploaded for another scene");
        }
        scene
            .plan
            .check(scene.objects.len(), scene.light.is_some())
            .with_context(|| format!("scene '{}' has a malformed plan", scene.name))?;

        // A render after the first records the command buffers again: the last submission
        // has completed (its fence was waited on).
        // SAFETY: no command buffer of the pool is pending; the fence is not in use.
        unsafe {
            device
                .reset_command_pool(self.command_pool, vk::CommandPoolResetFlags::empty())
                .context("vkResetCommandPool failed")?;
            device
                .reset_fences(&[self.fence])
                .context("vkResetFences failed")?;
        }
        let begin_info = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: a command buffer of this device's pool, reset and not in use.
        unsafe { device.begin_command_buffer(cmd, &begin_info) }
            .context("vkBeginCommandBuffer failed")?;
        let mut recorder = Recorder {
            renderer: self,
            scene,
            plan: &scene.plan,
            buffers,
            targets,
            aspect: f64::from(self.extent.width) / f64::from(self.extent.height),
            pass: None,
            subpass: 0,
            pipeline: None,
            next_secondary: 0,
            thread_pools: Vec::new(),
        };
        recorder.bind_geometry(cmd);
        recorder.record(cmd, &scene.plan.steps)?;

        readback.record(device, cmd, targets);

        // SAFETY: the command buffer is recording.
        unsafe { device.end_command_buffer(cmd) }.context("vkEndCommandBuffer failed")?;

        let command_buffers = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&command_buffers);
        // SAFETY: executable command buffer, unsignalled fence, queue of this device; the
        // host wrote the vertex/index/uniform buffers before the submit (implicitly visible).
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

/// The shadow map's view (the plan checks guarantee one exists when asked for).
fn shadow_view(targets: &Targets<'_>) -> Result<vk::ImageView> {
    targets
        .shadow
        .as_ref()
        .map(|shadow| shadow.view)
        .ok_or_else(|| anyhow!("the scene has a shadow pass but no shadow map was created"))
}

/// The multisampled attachments (the plan's needs asked for them when a pass is
/// multisampled).
fn multisampled_targets<'t, 'a>(targets: &'t Targets<'a>) -> Result<&'t MultisampledTargets<'a>> {
    targets
        .multisampled
        .as_ref()
        .ok_or_else(|| anyhow!("the scene has a multisampled pass but no multisampled targets"))
}

/// The size of a pass's target.
fn target_extent(target: Target, main: vk::Extent2D) -> vk::Extent2D {
    match target {
        Target::Main => main,
        Target::Shadow => vk::Extent2D {
            width: SHADOW_MAP_SIZE,
            height: SHADOW_MAP_SIZE,
        },
    }
}

/// Turns plan steps into commands, tracking what the commands depend on.
struct Recorder<'r> {
    renderer: &'r Renderer<'r>,
    scene: &'r Scene,
    plan: &'r Plan,
    buffers: &'r SceneBuffers<'r>,
    targets: &'r Targets<'r>,
    aspect: f64,
    /// The current pass.
    pass: Option<usize>,
    /// The current subpass.
    subpass: u32,
    /// The bound pipeline.
    pipeline: Option<usize>,
    /// The next unused secondary command buffer.
    next_secondary: usize,
    /// The command pools created by recording threads; destroyed when the recorder is dropped,
    /// which [`Renderer::render`] does only after the submission's fence (or on an error path,
    /// after waiting for the device to be idle).
    thread_pools: Vec<vk::CommandPool>,
}

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
    fn bind_geometry(&self, cmd: vk::CommandBuffer) {
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

    /// Records `steps` into `cmd`.
    fn record(&mut self, cmd: vk::CommandBuffer, steps: &[Step]) -> Result<()> {
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
                Step::BeginPass(n) => self.begin_pass(cmd, *n, contents)?,
                Step::NextSubpass => {
                    self.subpass += 1;
                    // SAFETY: `cmd` is inside a render pass with another subpass (plan check).
                    unsafe { self.device().cmd_next_subpass(cmd, contents) };
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
        Ok(())
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
        let depth = match pass.depth {
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
        if pass.kind == PassKind::DynamicRendering {
            return self.begin_rendering(cmd, n, color_clear, depth_clear);
        }
        let clear_values = match (pass.target, pass.multisample) {
            // The multisampled attachments are cleared; their resolve attachments are not.
            (Target::Main, Some(_)) => vec![color_clear, depth_clear, color_clear, depth_clear],
            (Target::Main, None) => vec![color_clear, depth_clear],
            (Target::Shadow, _) => vec![depth_clear],
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
        Ok(())
    }

    /// `vkCmdBeginRendering` over the main target, after a barrier that puts both attachments
    /// in their attachment layouts (from nothing when cleared, keeping them when loaded) and
    /// orders earlier attachment writes before this rendering's load ops. A multisampled pass
    /// renders into the multisampled attachments (from nothing: they are transient) and
    /// resolves them into the main images, whose previous contents do not matter either.
    fn begin_rendering(
        &self,
        cmd: vk::CommandBuffer,
        n: usize,
        color_clear: vk::ClearValue,
        depth_clear: vk::ClearValue,
    ) -> Result<()> {
        let pass = &self.plan.passes[n];
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
        let depth_layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
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
        let barrier = |image, aspects, src_access, dst_access, old_layout, new_layout| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(src_access)
                .dst_access_mask(dst_access)
                .old_layout(old_layout)
                .new_layout(new_layout)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(full_range(aspects))
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
                old(depth_load, depth_layout),
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
                depth_layout,
            ));
        }
        let stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
            | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
        let color_attachment = vk::RenderingAttachmentInfo::default()
            .image_view(targets.color.view)
            .image_layout(color_layout)
            .load_op(color_load)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(color_clear);
        let depth_attachment = vk::RenderingAttachmentInfo::default()
            .image_view(targets.depth.view)
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
            .color_attachments(&color_attachments)
            .depth_attachment(&depth_attachment);
        if has_stencil {
            info = info.stencil_attachment(&stencil_attachment);
        }
        // SAFETY: `cmd` is a recording primary outside any pass; the device has
        // dynamicRendering enabled (checked before rendering); the views cover the images
        // transitioned by the barrier; multisampled views resolve into single-sample views of
        // the same formats with modes the device supports (checked with the targets).
        unsafe {
            self.device().cmd_pipeline_barrier(
                cmd,
                stages,
                stages,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &barriers,
            );
            self.renderer.gpu.cmd_begin_rendering(cmd, &info);
        }
        Ok(())
    }

    fn end_pass(&mut self, cmd: vk::CommandBuffer) {
        let Some(n) = self.pass.take() else { return };
        self.pipeline = None;
        // SAFETY: `cmd` is inside the pass begun by the matching BeginPass.
        unsafe {
            if self.plan.passes[n].kind == PassKind::DynamicRendering {
                self.renderer.gpu.cmd_end_rendering(cmd);
            } else {
                self.device().cmd_end_render_pass(cmd);
            }
        }
    }

    fn bind(&mut self, cmd: vk::CommandBuffer, n: usize) {
        self.pipeline = Some(n);
        let renderer = self.renderer;
        // SAFETY: `cmd` is inside a pass compatible with the pipeline (plan check); the
        // descriptor set matches the shadow layout's only set.
        unsafe {
            self.device().cmd_bind_pipeline(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                renderer.pipelines[n],
            );
            let set = match self.plan.pipelines[n].program {
                Program::ShadowReceiver => renderer.shadow.as_ref().map(|s| s.set),
                Program::MvpPair => renderer.colors.as_ref().map(|c| c.set),
                // The storage buffer holds every object, indexed by the instance index; the
                // dynamic uniform buffers are bound at each draw with its offset.
                Program::Ssbo => renderer.matrices.as_ref().map(|m| m.set),
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
        if matches!(program, Program::Ubo | Program::UboDynamic) {
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
            Program::ShadowReceiver | Program::MvpPair | Program::Ssbo
        ) {
            u32::try_from(n).context("object index")?
        } else {
            0
        };
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
    /// pass, the current subpass and (if `framebuffer`) its framebuffer.
    fn begin_secondary(
        &self,
        secondary: vk::CommandBuffer,
        n: usize,
        framebuffer: bool,
    ) -> VkResult<()> {
        let framebuffer = if framebuffer {
            self.renderer.framebuffers[n]
        } else {
            vk::Framebuffer::null()
        };
        let inheritance = vk::CommandBufferInheritanceInfo::default()
            .render_pass(self.renderer.render_passes[n])
            .subpass(self.subpass)
            .framebuffer(framebuffer);
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(
                vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE
                    | vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT,
            )
            .inheritance_info(&inheritance);
        // SAFETY: a fresh secondary of one of this device's pools; the inheritance names the
        // current render pass, subpass and framebuffer.
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
                            thread_pools: Vec::new(),
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

/// Creates a descriptor set layout of `bindings`, a pool with room for one set of it, and that
/// set. Each handle is stored as soon as it exists (`set_layout`, `pool`), so that the owner's
/// `Drop` destroys whatever was made when a later step fails.
fn single_descriptor_set(
    device: &ash::Device,
    bindings: &[vk::DescriptorSetLayoutBinding<'_>],
    what: &str,
    set_layout: &mut vk::DescriptorSetLayout,
    pool: &mut vk::DescriptorPool,
) -> Result<vk::DescriptorSet> {
    let set_layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings);
    // SAFETY: valid device and create info.
    *set_layout = unsafe { device.create_descriptor_set_layout(&set_layout_info, None) }
        .with_context(|| format!("vkCreateDescriptorSetLayout ({what}) failed"))?;
    let sizes: Vec<vk::DescriptorPoolSize> = bindings
        .iter()
        .map(|b| vk::DescriptorPoolSize {
            ty: b.descriptor_type,
            descriptor_count: b.descriptor_count,
        })
        .collect();
    let pool_info = vk::DescriptorPoolCreateInfo::default()
        .max_sets(1)
        .pool_sizes(&sizes);
    // SAFETY: valid device and create info.
    *pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
        .with_context(|| format!("vkCreateDescriptorPool ({what}) failed"))?;
    let set_layouts = [*set_layout];
    let allocate_info = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(*pool)
        .set_layouts(&set_layouts);
    // SAFETY: valid pool with room for one set of this layout.
    unsafe { device.allocate_descriptor_sets(&allocate_info) }
        .with_context(|| format!("vkAllocateDescriptorSets ({what}) failed"))?
        .into_iter()
        .next()
        .ok_or_else(|| anyhow!("vkAllocateDescriptorSets ({what}) returned no set"))
}
