//! Drawing a scene: the scene's vertex and index buffers, the Vulkan objects its [`Plan`]
//! names (render passes and framebuffers, pipelines and their layouts, the shadow map's
//! sampler, uniform buffer and descriptor set, the uniform buffer of object colors), recording
//! of one primary command buffer (and any secondaries, on the main thread or one thread each
//! with its own command pool) by interpreting the plan's steps one by one, then the read-back
//! copies, and the single fenced submit.
//!
//! Files: this one creates and owns the objects ([`Renderer`]); `bindings.rs` makes the
//! descriptor sets and uniform buffers of the programs that need them; `record.rs`
//! interprets the steps into commands (`Recorder`).

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

/// What `shadow_receiver` pipelines bind: the light MVPs, the shadow map, its comparison
/// sampler and a plain one (nearest, no compare: `shadow_receiver_raw.frag`), in one
/// descriptor set.
struct ShadowBindings<'a> {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    sampler: vk::Sampler,
    plain_sampler: vk::Sampler,
    light: HostBuffer<'a>,
}

/// What the programs that sample the main depth bind ([`Program::SoftParticle`],
/// [`Program::DepthPost`]): its depth-aspect view, a nearest and a linear sampler (nearest
/// where the device does not filter the depth format linearly), in two sets
/// of one layout, which name the view in the layout each pass samples it in.
struct DepthReadBindings {
    set_layout: vk::DescriptorSetLayout,
    /// The same bindings in a push-descriptor set layout (`VK_KHR_push_descriptor`, where the
    /// device has it): the post pass pushes them instead of binding `sampled_set`; null
    /// otherwise.
    push_set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    /// `DEPTH_STENCIL_READ_ONLY_OPTIMAL` (attached read-only) and `SHADER_READ_ONLY_OPTIMAL`.
    read_only_set: vk::DescriptorSet,
    sampled_set: vk::DescriptorSet,
    nearest: vk::Sampler,
    linear: vk::Sampler,
}

/// What [`Program::DepthPostMs`] binds: the depth-aspect view of the multisampled depth a
/// multisampled pass kept, in `SHADER_READ_ONLY_OPTIMAL` (binding 0, a sampled image) and a
/// nearest sampler (binding 1), in one set written with `vkUpdateDescriptorSets`.
struct MultisampledReadBindings {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    sampler: vk::Sampler,
}

/// What [`Program::DepthInput`] and [`Program::DepthInputUndecorated`] bind: the main depth's
/// depth-aspect view as an input attachment in the layout its passes read it in
/// (`DEPTH_STENCIL_READ_ONLY_OPTIMAL` in a render pass, `RENDERING_LOCAL_READ_KHR` in a
/// local-read rendering), in one set written with `vkUpdateDescriptorSets`.
struct InputBindings {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
}

/// What the depth pyramid's compute pass and [`Program::DepthTiles`] bind: the main depth's
/// depth view (sampled), a nearest sampler and the tiles' storage buffer, in one set of a
/// layout both stages see; the compute pipeline and both pipeline layouts.
struct TileBindings<'a> {
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    tiles: HostBuffer<'a>,
    /// (tiles across, tiles down).
    count: (u32, u32),
    compute_layout: vk::PipelineLayout,
    compute: vk::Pipeline,
    /// Where the compute pass takes its descriptors from (the fragment stage that reads the
    /// tiles keeps `set`).
    compute_descriptors: ComputeTileDescriptors<'a>,
    /// The set or the descriptor buffer's offsets are bound with the `VK_KHR_maintenance6`
    /// commands taking an info ([`crate::plan::TileDescriptors::Sets2`], `Buffer2`).
    binds_with_infos: bool,
}

/// Where the depth pyramid's compute pass takes its descriptors from
/// ([`crate::plan::TileDescriptors`]).
enum ComputeTileDescriptors<'a> {
    /// [`TileBindings::set`].
    Set,
    /// A descriptor buffer: `compute_layout` has its set layout, and the compute pipeline is
    /// a descriptor buffer one.
    Buffer(TileDescriptorBuffer<'a>),
    /// Pushed: `compute_layout` has `set_layout` (a push descriptor layout), and `template`
    /// pushes them where there is one.
    Push {
        set_layout: vk::DescriptorSetLayout,
        template: Option<vk::DescriptorUpdateTemplate>,
    },
    /// [`TileBindings::set`], the compute program a shader object bound in the pipeline's
    /// place.
    ShaderObject(vk::ShaderEXT),
}

/// How the depth pyramid's descriptor buffer is made and bound: it holds sampler and resource
/// descriptors (one binding of both kinds).
const TILE_DESCRIPTOR_BUFFER_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::RESOURCE_DESCRIPTOR_BUFFER_EXT.as_raw()
        | vk::BufferUsageFlags::SAMPLER_DESCRIPTOR_BUFFER_EXT.as_raw()
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw(),
);

/// The depth pyramid's compute descriptors in a descriptor buffer: the same three bindings
/// (the main depth's view, the nearest sampler, the tiles), written with `vkGetDescriptorEXT`.
struct TileDescriptorBuffer<'a> {
    /// Made with `DESCRIPTOR_BUFFER_BIT_EXT`.
    set_layout: vk::DescriptorSetLayout,
    /// The descriptors (`RESOURCE_` and `SAMPLER_DESCRIPTOR_BUFFER_BIT_EXT` usage).
    descriptors: HostBuffer<'a>,
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
    /// Push constants and the depth-read set (null without a pass reading the main depth).
    depth_read_layout: vk::PipelineLayout,
    /// Push constants and the pushed depth-read set ([`Program::DepthPost`] where the device
    /// has `VK_KHR_push_descriptor`; null otherwise).
    depth_push_layout: vk::PipelineLayout,
    depth_read: Option<DepthReadBindings>,
    /// Push constants and the input-attachment set ([`Program::DepthInput`],
    /// [`Program::DepthInputUndecorated`]; null without it).
    input_layout: vk::PipelineLayout,
    depth_input: Option<InputBindings>,
    /// Push constants and the multisampled depth's set ([`Program::DepthPostMs`]; null without
    /// it).
    multisampled_read_layout: vk::PipelineLayout,
    multisampled_read: Option<MultisampledReadBindings>,
    /// Push constants and the tiles' set ([`Program::DepthTiles`]; null without it).
    tiles_layout: vk::PipelineLayout,
    depth_tiles: Option<TileBindings<'a>>,
    /// 128 bytes of vertex push constants and the color descriptor set (null without an
    /// [`Program::MvpPair`] pipeline).
    pair_layout: vk::PipelineLayout,
    /// The [`Program::SplitPush`] layout ([`SPLIT_PUSH_CONSTANT_RANGES`]).
    split_layout: vk::PipelineLayout,
    /// The [`Program::FullPush`] layout ([`FULL_PUSH_CONSTANT_RANGES`]).
    full_layout: vk::PipelineLayout,
    /// The [`Program::PushGeometry`] layout (one range, [`GEOMETRY_PUSH_STAGES`]).
    geometry_layout: vk::PipelineLayout,
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
    /// A second primary, where a suspended rendering resumes across command buffers
    /// ([`crate::plan::PassKind::DynamicRenderingSuspended`]).
    continuation: vk::CommandBuffer,
    secondaries: Vec<vk::CommandBuffer>,
    fence: vk::Fence,
    extent: vk::Extent2D,
    bias_clamp: bool,
    /// The shaders of [`Program::ShaderObjects`], [`Program::LinkedShaderObjects`],
    /// [`Program::LinkedTessellationShaderObjects`] or
    /// [`Program::PassthroughGeometryShaderObjects`] (its pipelines have a null handle in
    /// `pipelines`); `None` without that program.
    shader_objects: Option<shader_objects::ShaderObjects>,
    /// The shaders of [`Program::MeshShaderObjects`], likewise.
    mesh_shader_objects: Option<shader_objects::ShaderObjects>,
    /// What [`Program::Mesh`] binds (its layout among them); `None` without that program.
    mesh: Option<mesh::MeshBindings<'a>>,
    /// What [`Program::Multiview`] binds (its layout among them); `None` without that program.
    multiview: Option<multiview::MultiviewBindings<'a>>,
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
            for objects in self.shader_objects.iter().chain(&self.mesh_shader_objects) {
                objects.destroy(self.gpu);
            }
            if let Some(mesh) = &self.mesh {
                mesh.destroy(self.device);
            }
            if let Some(multiview) = &self.multiview {
                multiview.destroy(self.device);
            }
            self.device
                .destroy_pipeline_layout(self.shadow_layout, None);
            self.device.destroy_pipeline_layout(self.plain_layout, None);
            self.device.destroy_pipeline_layout(self.pair_layout, None);
            self.device.destroy_pipeline_layout(self.split_layout, None);
            self.device.destroy_pipeline_layout(self.full_layout, None);
            self.device
                .destroy_pipeline_layout(self.geometry_layout, None);
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
                self.device.destroy_sampler(shadow.plain_sampler, None);
            }
            self.device
                .destroy_pipeline_layout(self.depth_read_layout, None);
            self.device
                .destroy_pipeline_layout(self.depth_push_layout, None);
            self.device.destroy_pipeline_layout(self.tiles_layout, None);
            self.device.destroy_pipeline_layout(self.input_layout, None);
            self.device
                .destroy_pipeline_layout(self.multisampled_read_layout, None);
            if let Some(reads) = &self.multisampled_read {
                self.device.destroy_descriptor_pool(reads.pool, None);
                self.device
                    .destroy_descriptor_set_layout(reads.set_layout, None);
                self.device.destroy_sampler(reads.sampler, None);
            }
            if let Some(input) = &self.depth_input {
                self.device.destroy_descriptor_pool(input.pool, None);
                self.device
                    .destroy_descriptor_set_layout(input.set_layout, None);
            }
            if let Some(tiles) = &self.depth_tiles {
                self.device.destroy_pipeline(tiles.compute, None);
                self.device
                    .destroy_pipeline_layout(tiles.compute_layout, None);
                match &tiles.compute_descriptors {
                    ComputeTileDescriptors::Set => {}
                    ComputeTileDescriptors::ShaderObject(shader) => {
                        if let Some(objects) = &self.gpu.shader_object {
                            objects.destroy_shader(*shader, None);
                        }
                    }
                    ComputeTileDescriptors::Buffer(buffer) => {
                        self.device
                            .destroy_descriptor_set_layout(buffer.set_layout, None);
                    }
                    ComputeTileDescriptors::Push {
                        set_layout,
                        template,
                    } => {
                        if let Some(template) = template {
                            self.device
                                .destroy_descriptor_update_template(*template, None);
                        }
                        self.device.destroy_descriptor_set_layout(*set_layout, None);
                    }
                }
                self.device.destroy_descriptor_pool(tiles.pool, None);
                self.device
                    .destroy_descriptor_set_layout(tiles.set_layout, None);
            }
            if let Some(reads) = &self.depth_read {
                self.device.destroy_descriptor_pool(reads.pool, None);
                self.device
                    .destroy_descriptor_set_layout(reads.set_layout, None);
                self.device
                    .destroy_descriptor_set_layout(reads.push_set_layout, None);
                self.device.destroy_sampler(reads.nearest, None);
                self.device.destroy_sampler(reads.linear, None);
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

/// The stages of the [`Program::PushGeometry`] layout's one range: the geometry stage applies
/// the matrix, the fragment stage reads the color (the vertex stage declares none).
const GEOMETRY_PUSH_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw()
        | vk::ShaderStageFlags::GEOMETRY.as_raw()
        | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);

/// The push-constant ranges of a program pushed per range ([`Program::SplitPush`],
/// [`Program::FullPush`]); `None` for the others.
pub(crate) fn split_ranges(program: Program) -> Option<&'static [vk::PushConstantRange]> {
    match program {
        Program::SplitPush => Some(&SPLIT_PUSH_CONSTANT_RANGES),
        Program::FullPush => Some(&FULL_PUSH_CONSTANT_RANGES),
        _ => None,
    }
}

/// The push-constant ranges of the [`Program::FullPush`] pushes: [`SPLIT_PUSH_CONSTANT_RANGES`]
/// with the fragment stage's range to byte 128 (the shader reads 64..80), as applications
/// that give a stage the rest of a 128-byte device's push constants lay them out. Its layout
/// runs the fragment range to the device's `maxPushConstantsSize` ([`full_push_ranges`]), so
/// that no device leaves room for revz's carrier.
pub(crate) const FULL_PUSH_CONSTANT_RANGES: [vk::PushConstantRange; 2] = [
    SPLIT_PUSH_CONSTANT_RANGES[0],
    vk::PushConstantRange {
        stage_flags: vk::ShaderStageFlags::FRAGMENT,
        offset: 64,
        size: 64,
    },
];

/// The [`Program::FullPush`] layout's ranges on a device with `max_push_constants_size`
/// bytes (at least the 128 Vulkan guarantees): [`FULL_PUSH_CONSTANT_RANGES`] with the fragment
/// stage's range to the device's last byte.
fn full_push_ranges(max_push_constants_size: u32) -> [vk::PushConstantRange; 2] {
    let [vertex, fragment] = FULL_PUSH_CONSTANT_RANGES;
    [
        vertex,
        vk::PushConstantRange {
            size: max_push_constants_size.max(128) - fragment.offset,
            ..fragment
        },
    ]
}

/// The push-constant ranges of the [`Program::SplitPush`] layout: the matrix for the vertex
/// stage, the color for the fragment stage.
pub(crate) const SPLIT_PUSH_CONSTANT_RANGES: [vk::PushConstantRange; 2] = [
    vk::PushConstantRange {
        stage_flags: vk::ShaderStageFlags::VERTEX,
        offset: 0,
        size: 64,
    },
    vk::PushConstantRange {
        stage_flags: vk::ShaderStageFlags::FRAGMENT,
        offset: 64,
        size: 16,
    },
];

/// The push-constant range of the [`Program::MvpPair`] layout on a device with
/// `max_push_constants_size` bytes: two matrices (128 bytes), vertex stage only, the range
/// running to the device's last byte, so that, as on a 128-byte device, the layout leaves no
/// room for revz's carrier on any device (lavapipe 25.0 has 256 bytes).
pub(super) fn pair_push_constant_ranges(
    max_push_constants_size: u32,
) -> [vk::PushConstantRange; 1] {
    [vk::PushConstantRange {
        stage_flags: vk::ShaderStageFlags::VERTEX,
        offset: 0,
        size: max_push_constants_size.max(128),
    }]
}

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
            depth_read_layout: vk::PipelineLayout::null(),
            depth_push_layout: vk::PipelineLayout::null(),
            depth_read: None,
            input_layout: vk::PipelineLayout::null(),
            depth_input: None,
            multisampled_read_layout: vk::PipelineLayout::null(),
            multisampled_read: None,
            tiles_layout: vk::PipelineLayout::null(),
            depth_tiles: None,
            pair_layout: vk::PipelineLayout::null(),
            split_layout: vk::PipelineLayout::null(),
            full_layout: vk::PipelineLayout::null(),
            geometry_layout: vk::PipelineLayout::null(),
            colors: None,
            matrix_layout: vk::PipelineLayout::null(),
            matrices: None,
            pipelines: Vec::new(),
            libraries: Vec::new(),
            command_pool: vk::CommandPool::null(),
            queue_family: gpu.queue_family,
            command_buffer: vk::CommandBuffer::null(),
            continuation: vk::CommandBuffer::null(),
            secondaries: Vec::new(),
            fence: vk::Fence::null(),
            extent: targets.extent,
            bias_clamp: gpu.enabled.depth_bias_clamp,
            shader_objects: None,
            mesh_shader_objects: None,
            mesh: None,
            multiview: None,
        };
        let main = MainFormats {
            depth: targets.depth.format,
            stencil: targets.depth_format.has_stencil(),
            shadow: targets
                .shadow
                .as_ref()
                .map_or(crate::target::SHADOW_MAP_FORMAT, |shadow| shadow.format),
            input_aspects: gpu.api_version() >= vk::API_VERSION_1_1,
        };
        for pass in &plan.passes {
            if pass.kind.is_dynamic_rendering() {
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
                // A kept depth is not resolved: no resolve attachment for it.
                (Target::Main, Some(ms)) if pass.multisample.is_some_and(|m| m.sampled_depth) => (
                    vec![ms.color.view, ms.depth.view, targets.color.view],
                    targets.extent,
                ),
                (Target::Main, Some(ms)) => (
                    vec![
                        ms.color.view,
                        ms.depth.view,
                        targets.color.view,
                        targets.depth.view,
                    ],
                    targets.extent,
                ),
                // A multiview pass renders view i into layer i of both.
                (Target::Main, None) if pass.view_mask != 0 => (
                    vec![targets.color.array_view, targets.depth.array_view],
                    targets.extent,
                ),
                (Target::Main, None) => {
                    (vec![targets.color.view, targets.depth.view], targets.extent)
                }
                (Target::SoftParticles, _) => {
                    (vec![targets.color.view, targets.depth.view], targets.extent)
                }
                (Target::Post, _) => (vec![targets.color.view], targets.extent),
                (Target::DepthSlice { level, layer }, _) => (
                    vec![targets.depth.slice_view(level, layer).ok_or_else(|| {
                        anyhow!("the main depth image has no level {level} layer {layer}")
                    })?],
                    targets.depth.level_extent(level),
                ),
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
        if plan
            .pipelines
            .iter()
            .any(|p| p.program == Program::SplitPush)
        {
            let layout_info = vk::PipelineLayoutCreateInfo::default()
                .push_constant_ranges(&SPLIT_PUSH_CONSTANT_RANGES);
            // SAFETY: valid device and create info.
            this.split_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (split push constants) failed")?;
        }
        if plan
            .pipelines
            .iter()
            .any(|p| p.program == Program::FullPush)
        {
            let ranges = full_push_ranges(gpu.limits().max_push_constants_size);
            let layout_info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges);
            // SAFETY: valid device and create info.
            this.full_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (push constants filling the device's) failed")?;
        }
        if plan
            .pipelines
            .iter()
            .any(|p| p.program == Program::PushGeometry)
        {
            let ranges = [vk::PushConstantRange {
                stage_flags: GEOMETRY_PUSH_STAGES,
                offset: 0,
                size: 80,
            }];
            let layout_info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges);
            // SAFETY: valid device and create info.
            this.geometry_layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
                .context("vkCreatePipelineLayout (geometry push constants) failed")?;
        }
        if needs.shadow_map {
            this.create_shadow_bindings(gpu, targets, scene)?;
        }
        if needs.sampled_depth {
            this.create_depth_read_bindings(gpu, targets)?;
        }
        if needs.depth_tiles {
            this.create_tile_bindings(gpu, targets, needs.tile_descriptors)?;
        }
        if needs.input_depth {
            // One layout for every pass reading it (plan check).
            let layout = if needs.dynamic_rendering_local_read {
                vk::ImageLayout::RENDERING_LOCAL_READ_KHR
            } else {
                vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL
            };
            this.create_input_bindings(targets, layout)?;
        }
        if plan
            .pipelines
            .iter()
            .any(|p| p.program == Program::DepthPostMs)
        {
            this.create_multisampled_read_bindings(targets)?;
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

        if plan
            .pipelines
            .iter()
            .any(|p| p.program == Program::Multiview)
        {
            let aspect = f64::from(targets.extent.width) / f64::from(targets.extent.height);
            this.multiview = Some(multiview::MultiviewBindings::new(gpu, scene, aspect)?);
        }
        if plan
            .pipelines
            .iter()
            .any(|p| matches!(p.program, Program::Mesh | Program::MeshShaderObjects))
        {
            this.mesh = Some(mesh::MeshBindings::new(gpu, scene)?);
        }
        if let (Some(mesh), true) = (
            &this.mesh,
            plan.pipelines
                .iter()
                .any(|p| p.program == Program::MeshShaderObjects),
        ) {
            this.mesh_shader_objects = Some(shader_objects::ShaderObjects::new(
                gpu,
                Program::MeshShaderObjects,
                &mesh::MESH_PUSH_CONSTANT_RANGES,
                &[mesh.set_layout],
            )?);
        }
        if let Some(program) = plan.pipelines.iter().map(|p| p.program).find(|&program| {
            matches!(
                program,
                Program::ShaderObjects
                    | Program::LinkedShaderObjects
                    | Program::LinkedTessellationShaderObjects
                    | Program::PassthroughGeometryShaderObjects
                    | Program::ProjectingGeometryShaderObjects
            )
        }) {
            // The buffer delivery's shaders read its blocks, without push constants.
            let (ranges, set_layouts): (&[vk::PushConstantRange], Vec<vk::DescriptorSetLayout>) =
                if program.is_buffer_delivery() {
                    let matrices = this
                        .matrices
                        .as_ref()
                        .context("the tessellated shader objects read the ubo delivery's blocks")?;
                    (&[], vec![matrices.set_layout])
                } else {
                    (&PUSH_CONSTANT_RANGES, Vec::new())
                };
            this.shader_objects = Some(shader_objects::ShaderObjects::new(
                gpu,
                program,
                ranges,
                &set_layouts,
            )?);
        }
        for spec in &plan.pipelines {
            if spec.program.binds_shader_objects() {
                // Bound as shader objects (`record.rs`).
                this.pipelines.push(vk::Pipeline::null());
                continue;
            }
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
        let primaries = allocate(vk::CommandBufferLevel::PRIMARY, 2)?;
        let [first, second] = primaries[..] else {
            bail!(
                "vkAllocateCommandBuffers returned {} command buffers",
                primaries.len()
            );
        };
        (this.command_buffer, this.continuation) = (first, second);
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
            Program::ShadowReceiver | Program::ShadowReceiverRaw => {
                (self.shadow_layout, PLAIN_PUSH_STAGES)
            }
            Program::MvpPair => (self.pair_layout, vk::ShaderStageFlags::VERTEX),
            Program::Ubo
            | Program::UboDynamic
            | Program::Ssbo
            | Program::SsboRows
            | Program::SsboRegisters
            | Program::SsboColumns
            | Program::SsboVkd3d
            | Program::UboGeometry
            | Program::UboPassthroughGeometry
            | Program::UboTessellation
            | Program::UboInterpolatingTessellation
            | Program::UboProjectingTessellation
            | Program::UboTessellatedGeometry
            | Program::LinkedTessellationShaderObjects
            | Program::PassthroughGeometryShaderObjects
            | Program::ProjectingGeometryShaderObjects => {
                (self.matrix_layout, vk::ShaderStageFlags::empty())
            }
            Program::Flat
            | Program::DepthOnly
            | Program::FragDepth
            | Program::RowMajor
            | Program::RowVector
            | Program::LitMvp
            | Program::ShaderObjects
            | Program::LinkedShaderObjects => (self.plain_layout, PLAIN_PUSH_STAGES),
            Program::Mesh | Program::MeshShaderObjects => (
                self.mesh
                    .as_ref()
                    .map_or(vk::PipelineLayout::null(), |m| m.layout),
                mesh::MESH_PUSH_STAGES,
            ),
            // Pushed per range ([`SPLIT_PUSH_CONSTANT_RANGES`]), each with its own stage.
            Program::SplitPush => (self.split_layout, vk::ShaderStageFlags::empty()),
            Program::FullPush => (self.full_layout, vk::ShaderStageFlags::empty()),
            Program::PushGeometry => (self.geometry_layout, GEOMETRY_PUSH_STAGES),
            Program::DepthPost if self.depth_push_layout != vk::PipelineLayout::null() => {
                (self.depth_push_layout, PLAIN_PUSH_STAGES)
            }
            Program::SoftParticle
            | Program::DepthPost
            | Program::StencilPost
            | Program::DepthMipsPost
            | Program::DepthLayersPost => (self.depth_read_layout, PLAIN_PUSH_STAGES),
            Program::DepthTiles => (self.tiles_layout, PLAIN_PUSH_STAGES),
            Program::DepthInput | Program::DepthInputUndecorated => {
                (self.input_layout, PLAIN_PUSH_STAGES)
            }
            Program::DepthPostMs => (self.multisampled_read_layout, PLAIN_PUSH_STAGES),
            Program::Multiview => (
                self.multiview
                    .as_ref()
                    .map_or(vk::PipelineLayout::null(), |m| m.layout),
                PLAIN_PUSH_STAGES,
            ),
        }
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
            tiles_bound: false,
            thread_pools: Vec::new(),
            continuation: Some(self.continuation),
        };
        recorder.bind_geometry(cmd);
        let last = recorder.record(cmd, &scene.plan.steps)?;

        readback.record(device, last, targets);

        // SAFETY: the command buffer is recording.
        unsafe { device.end_command_buffer(last) }.context("vkEndCommandBuffer failed")?;

        // A rendering suspended in the first resumes in the second, next in the same batch.
        let both = [cmd, last];
        let command_buffers = if last == cmd { &both[..1] } else { &both[..] };
        let submit = vk::SubmitInfo::default().command_buffers(command_buffers);
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
        Target::Main | Target::SoftParticles | Target::Post => main,
        Target::DepthSlice { level, .. } => crate::target::level_extent(main, level),
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
    /// The depth pyramid's compute state was bound by this recording
    /// ([`crate::plan::Step::BindDepthTiles`]): its dispatches bind nothing.
    tiles_bound: bool,
    /// The command pools created by recording threads; destroyed when the recorder is dropped,
    /// which [`Renderer::render`] does only after the submission's fence (or on an error path,
    /// after waiting for the device to be idle).
    thread_pools: Vec<vk::CommandPool>,
    /// The primary a suspended rendering resumes in, where it does so across command buffers
    /// (taken once; `None` for secondaries).
    continuation: Option<vk::CommandBuffer>,
}

mod bindings;
mod mesh;
mod multiview;
mod record;
mod shader_objects;
