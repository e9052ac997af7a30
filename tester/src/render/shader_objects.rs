//! [`Program::ShaderObjects`]: the flat program's shaders as unlinked vertex and fragment
//! shader objects (`VK_EXT_shader_object`), [`Program::LinkedShaderObjects`]: the same two
//! created linked in one call, [`Program::MeshShaderObjects`]: the mesh
//! program's as mesh and fragment ones, and [`Program::LinkedTessellationShaderObjects`]:
//! `ubo-tessellation`'s four created linked in one call, and
//! [`Program::PassthroughGeometryShaderObjects`]: `ubo-passthrough-geometry`'s three unlinked,
//! and [`Program::ProjectingGeometryShaderObjects`]: `ubo-geometry`'s three unlinked;
//! and their "pipeline" bind: the shaders bound
//! (every other graphics stage the device has bound to null), then every state a
//! [`PipelineSpec`] bakes into a pipeline set with the dynamic state commands, as an engine
//! built on shader objects does at each material change. States a spec leaves dynamic
//! (compare op, bias values, bounds values) are left to the plan's steps, as for pipelines.
//!
//! What the spec would set is set with exactly the values `crate::pipeline::create_pipeline`
//! bakes, so a render with this program draws what the flat program's pipelines draw.

use anyhow::{Context, Result};
use ash::vk;

use crate::gpu::Gpu;
use crate::pipeline::{full_viewport, map_compare, position_input};
use crate::plan::{
    Bias, Bounds, DepthTest, PipelineSpec, Program, StencilTest, StencilWrite, Viewport,
};
use crate::shaders;

/// The create info of a shader object of `words` at `stage`, followed by `next`, with the
/// program's push-constant ranges and descriptor set layouts.
fn create_info<'a>(
    stage: vk::ShaderStageFlags,
    next: vk::ShaderStageFlags,
    words: &'a [u32],
    ranges: &'a [vk::PushConstantRange],
    set_layouts: &'a [vk::DescriptorSetLayout],
) -> vk::ShaderCreateInfoEXT<'a> {
    vk::ShaderCreateInfoEXT::default()
        .stage(stage)
        .next_stage(next)
        .code_type(vk::ShaderCodeTypeEXT::SPIRV)
        .code(bytes_of(words))
        .name(c"main")
        .push_constant_ranges(ranges)
        .set_layouts(set_layouts)
}

/// The program's shader objects, destroyed with the renderer ([`ShaderObjects::destroy`]).
pub(super) struct ShaderObjects {
    /// Each shader with its stage, in pipeline order (vertex or mesh first, fragment last).
    shaders: Vec<(vk::ShaderStageFlags, vk::ShaderEXT)>,
}

/// What a bind needs to know of the pass beside the spec.
pub(super) struct BindTarget {
    pub extent: vk::Extent2D,
    pub samples: vk::SampleCountFlags,
    /// The subpass has a color attachment (one blend state set).
    pub has_color: bool,
    /// The `depthBiasClamp` feature is enabled (a static bias's clamp applies).
    pub bias_clamp: bool,
}

/// The stages and code of `program`'s shaders, in pipeline order.
fn program_shaders(program: Program) -> Vec<(vk::ShaderStageFlags, shaders::ShaderSource)> {
    let fragment = vk::ShaderStageFlags::FRAGMENT;
    match program {
        Program::MeshShaderObjects => vec![
            (vk::ShaderStageFlags::MESH_EXT, shaders::MESH_MESH),
            (fragment, shaders::SCENE_FRAG),
        ],
        Program::LinkedTessellationShaderObjects => vec![
            (vk::ShaderStageFlags::VERTEX, shaders::UBO_LATER_VERT),
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                shaders::PASSTHROUGH_TESC,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                shaders::UBO_TESE,
            ),
            (fragment, shaders::FLAT_COLOR_FRAG),
        ],
        Program::PassthroughGeometryShaderObjects => vec![
            (vk::ShaderStageFlags::VERTEX, shaders::UBO_VERT),
            (vk::ShaderStageFlags::GEOMETRY, shaders::PASSTHROUGH_GEOM),
            (fragment, shaders::FLAT_COLOR_FRAG),
        ],
        Program::ProjectingGeometryShaderObjects => vec![
            (vk::ShaderStageFlags::VERTEX, shaders::UBO_POSITION_VERT),
            (vk::ShaderStageFlags::GEOMETRY, shaders::UBO_GEOM),
            (fragment, shaders::FLAT_COLOR_FRAG),
        ],
        _ => vec![
            (vk::ShaderStageFlags::VERTEX, shaders::SCENE_VERT),
            (fragment, shaders::SCENE_FRAG),
        ],
    }
}

impl ShaderObjects {
    /// The shaders of `program` (`scene.vert` and `scene.frag`; `mesh.mesh` and `scene.frag`
    /// for [`Program::MeshShaderObjects`]; `ubo-tessellation`'s four for
    /// [`Program::LinkedTessellationShaderObjects`]) as shader objects with the
    /// push-constant ranges and descriptor set layouts of the program's layout: unlinked, or
    /// for [`Program::LinkedShaderObjects`] and [`Program::LinkedTessellationShaderObjects`]
    /// linked in one call.
    pub(super) fn new(
        gpu: &Gpu,
        program: Program,
        ranges: &[vk::PushConstantRange],
        set_layouts: &[vk::DescriptorSetLayout],
    ) -> Result<ShaderObjects> {
        let objects = gpu
            .shader_object
            .as_ref()
            .context("the shader-objects program needs VK_EXT_shader_object enabled")?;
        let sources = program_shaders(program);
        let words = sources
            .iter()
            .map(|(_, source)| source.words())
            .collect::<Result<Vec<_>>>()?;
        let names: Vec<&str> = sources.iter().map(|(_, source)| source.name).collect();
        // Each stage followed by the next one of the program (none after the fragment stage).
        let infos: Vec<vk::ShaderCreateInfoEXT<'_>> = sources
            .iter()
            .zip(&words)
            .enumerate()
            .map(|(i, ((stage, _), words))| {
                let next = sources
                    .get(i + 1)
                    .map_or(vk::ShaderStageFlags::empty(), |(next, _)| *next);
                create_info(*stage, next, words, ranges, set_layouts)
            })
            .collect();
        let destroy_all = |shaders: &[vk::ShaderEXT]| {
            for shader in shaders.iter().filter(|s| **s != vk::ShaderEXT::null()) {
                // SAFETY: created above, never used.
                unsafe { objects.destroy_shader(*shader, None) };
            }
        };
        let linked = matches!(
            program,
            Program::LinkedShaderObjects | Program::LinkedTessellationShaderObjects
        );
        let shaders = if linked {
            // One call, all linked.
            let linked: Vec<_> = infos
                .iter()
                .map(|info| info.flags(vk::ShaderCreateFlagsEXT::LINK_STAGE))
                .collect();
            // SAFETY: valid SPIR-V of these stages (checked at build time), a live device.
            let created = unsafe { objects.create_shaders(&linked, None) };
            created
                .map_err(|(shaders, e)| {
                    destroy_all(&shaders);
                    e
                })
                .with_context(|| format!("vkCreateShadersEXT (linked {})", names.join(", ")))?
        } else {
            let mut shaders = Vec::new();
            for (info, name) in infos.iter().zip(&names) {
                // SAFETY: valid SPIR-V of this stage (checked at build time), a live device.
                let created = unsafe { objects.create_shaders(std::slice::from_ref(info), None) };
                match created {
                    Ok(created) => shaders.push(created[0]),
                    Err((_, e)) => {
                        destroy_all(&shaders);
                        return Err(e)
                            .with_context(|| format!("vkCreateShadersEXT ({name}) failed"));
                    }
                }
            }
            shaders
        };
        Ok(ShaderObjects {
            shaders: sources
                .iter()
                .map(|(stage, _)| *stage)
                .zip(shaders)
                .collect(),
        })
    }

    /// Destroys the shaders (the device is idle).
    pub(super) fn destroy(&self, gpu: &Gpu) {
        if let Some(objects) = &gpu.shader_object {
            for &(_, shader) in &self.shaders {
                // SAFETY: created from this device, no longer in use.
                unsafe { objects.destroy_shader(shader, None) };
            }
        }
    }

    /// Whether the shaders include tessellation stages.
    fn tessellates(&self) -> bool {
        self.shaders
            .iter()
            .any(|(stage, _)| *stage == vk::ShaderStageFlags::TESSELLATION_EVALUATION)
    }

    /// Binds the shaders for `spec` and sets every state its pipeline would bake (module
    /// docs).
    ///
    /// # Safety
    /// `cmd` is recording inside a pass compatible with `target`, on `gpu`'s device.
    pub(super) unsafe fn bind(
        &self,
        gpu: &Gpu,
        cmd: vk::CommandBuffer,
        spec: &PipelineSpec,
        target: &BindTarget,
    ) {
        let Some(objects) = &gpu.shader_object else {
            return;
        };
        let device = &gpu.device;
        let enabled = gpu.enabled;
        // Every graphics stage the device has is bound: the program's shaders, null for the
        // others (the vertex stage where the mesh stage has the shader, and the reverse).
        let (mut stages, mut shaders): (Vec<_>, Vec<_>) = self.shaders.iter().copied().unzip();
        let mut others = vec![vk::ShaderStageFlags::VERTEX];
        if enabled.mesh_shader {
            others.push(vk::ShaderStageFlags::MESH_EXT);
        }
        if enabled.geometry_shader {
            others.push(vk::ShaderStageFlags::GEOMETRY);
        }
        if enabled.tessellation_shader {
            others.extend([
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
            ]);
        }
        for other in others {
            if !stages.contains(&other) {
                stages.push(other);
                shaders.push(vk::ShaderEXT::null());
            }
        }
        let tessellates = self.tessellates();
        let (bindings, attributes) = position_input();
        let binding = vk::VertexInputBindingDescription2EXT::default()
            .binding(bindings[0].binding)
            .stride(bindings[0].stride)
            .input_rate(bindings[0].input_rate)
            .divisor(1);
        let attribute = vk::VertexInputAttributeDescription2EXT::default()
            .location(attributes[0].location)
            .binding(attributes[0].binding)
            .format(attributes[0].format)
            .offset(attributes[0].offset);
        // SAFETY: the caller's contract; every command below is VK_EXT_shader_object's or core
        // 1.3 (the tester enables shader objects only on 1.3), with values valid for the
        // device's enabled features.
        unsafe {
            objects.cmd_bind_shaders(cmd, &stages, &shaders);
            objects.cmd_set_vertex_input(cmd, &[binding], &[attribute]);
            if tessellates {
                // Each triangle of the index buffer a patch of three control points, as the
                // `ubo-tessellation` pipelines have it.
                device.cmd_set_primitive_topology(cmd, vk::PrimitiveTopology::PATCH_LIST);
                objects.cmd_set_patch_control_points(cmd, 3);
                objects.cmd_set_tessellation_domain_origin(
                    cmd,
                    vk::TessellationDomainOrigin::UPPER_LEFT,
                );
            } else {
                device.cmd_set_primitive_topology(cmd, vk::PrimitiveTopology::TRIANGLE_LIST);
            }
            device.cmd_set_primitive_restart_enable(cmd, false);
            if let Viewport::Static {
                min_depth,
                max_depth,
            } = spec.viewport
            {
                device.cmd_set_viewport_with_count(
                    cmd,
                    &[full_viewport(target.extent, min_depth, max_depth)],
                );
            }
            device.cmd_set_scissor_with_count(
                cmd,
                &[vk::Rect2D {
                    offset: vk::Offset2D { x: 0, y: 0 },
                    extent: target.extent,
                }],
            );
            device.cmd_set_rasterizer_discard_enable(cmd, false);
            objects.cmd_set_polygon_mode(cmd, vk::PolygonMode::FILL);
            objects.cmd_set_rasterization_samples(cmd, target.samples);
            objects.cmd_set_sample_mask(cmd, target.samples, &[u32::MAX]);
            objects.cmd_set_alpha_to_coverage_enable(cmd, false);
            device.cmd_set_cull_mode(
                cmd,
                if spec.cull_back_faces {
                    vk::CullModeFlags::BACK
                } else {
                    vk::CullModeFlags::NONE
                },
            );
            device.cmd_set_front_face(cmd, vk::FrontFace::COUNTER_CLOCKWISE);
            if enabled.depth_clamp {
                objects.cmd_set_depth_clamp_enable(cmd, spec.depth_clamp);
            }
            if enabled.depth_clip_control {
                objects.cmd_set_depth_clip_negative_one_to_one(cmd, spec.negative_one_to_one);
            }
            // Depth: the test, its compare op where static, writes.
            device.cmd_set_depth_test_enable(cmd, spec.depth_test != DepthTest::Off);
            match spec.depth_test {
                DepthTest::Off => device.cmd_set_depth_compare_op(cmd, vk::CompareOp::ALWAYS),
                DepthTest::Static(op) => device.cmd_set_depth_compare_op(cmd, map_compare(op)),
                DepthTest::Dynamic => {}
            }
            device.cmd_set_depth_write_enable(cmd, spec.depth_write);
            // Bias: enabled, and its factors where static.
            device.cmd_set_depth_bias_enable(cmd, spec.bias != Bias::Off);
            if let Bias::Static(bias) = spec.bias {
                let clamp = if target.bias_clamp { bias.clamp } else { 0.0 };
                device.cmd_set_depth_bias(cmd, bias.constant, clamp, bias.slope);
            }
            // Bounds: enabled (with the feature), and the range where static.
            if enabled.depth_bounds {
                device.cmd_set_depth_bounds_test_enable(cmd, spec.bounds != Bounds::Off);
                if let Bounds::Static { min, max } = spec.bounds {
                    device.cmd_set_depth_bounds(cmd, min, max);
                }
            }
            device.cmd_set_stencil_test_enable(cmd, spec.stencil.is_some());
            if let Some(test) = spec.stencil {
                set_stencil(device, cmd, test);
            }
            if target.has_color {
                objects.cmd_set_color_blend_enable(cmd, 0, &[vk::FALSE]);
                objects.cmd_set_color_blend_equation(
                    cmd,
                    0,
                    &[vk::ColorBlendEquationEXT::default()
                        .src_color_blend_factor(vk::BlendFactor::ONE)
                        .dst_color_blend_factor(vk::BlendFactor::ZERO)
                        .color_blend_op(vk::BlendOp::ADD)
                        .src_alpha_blend_factor(vk::BlendFactor::ONE)
                        .dst_alpha_blend_factor(vk::BlendFactor::ZERO)
                        .alpha_blend_op(vk::BlendOp::ADD)],
                );
                objects.cmd_set_color_write_mask(
                    cmd,
                    0,
                    &[if spec.color_write {
                        vk::ColorComponentFlags::RGBA
                    } else {
                        vk::ColorComponentFlags::empty()
                    }],
                );
            }
        }
    }
}

/// The stencil state of `test` on both faces, as `depth_stencil_state` bakes it.
///
/// # Safety
/// `cmd` is recording on `device`.
unsafe fn set_stencil(device: &ash::Device, cmd: vk::CommandBuffer, test: StencilTest) {
    let both = vk::StencilFaceFlags::FRONT_AND_BACK;
    let pass = match test.on_pass {
        StencilWrite::Keep => vk::StencilOp::KEEP,
        StencilWrite::Replace => vk::StencilOp::REPLACE,
    };
    // SAFETY: the caller's contract.
    unsafe {
        device.cmd_set_stencil_op(
            cmd,
            both,
            vk::StencilOp::KEEP,
            pass,
            vk::StencilOp::KEEP,
            map_compare(test.compare),
        );
        device.cmd_set_stencil_compare_mask(cmd, both, 0xff);
        device.cmd_set_stencil_write_mask(cmd, both, 0xff);
        device.cmd_set_stencil_reference(cmd, both, test.reference);
    }
}

/// The bytes of SPIR-V words.
pub(super) fn bytes_of(words: &[u32]) -> &[u8] {
    // SAFETY: any u32 is 4 initialized bytes; u8 has no alignment requirement.
    unsafe { std::slice::from_raw_parts(words.as_ptr().cast(), std::mem::size_of_val(words)) }
}
