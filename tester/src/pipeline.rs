//! Vulkan objects made from a scene's [`crate::plan::Plan`] data: render passes (one or two subpasses, main
//! target or shadow map; multisampled ones with `vkCreateRenderPass2` and color and depth
//! resolves) and graphics pipelines (their depth, stencil, bias, bounds and viewport state,
//! static or dynamic, and sample count; made for a render pass or for dynamic rendering, in
//! one call or from `VK_EXT_graphics_pipeline_library` libraries linked together), and the
//! pure maps from the plan's enums to Vulkan's.

use anyhow::{anyhow, ensure, Context, Result};
use ash::vk;

use crate::gpu::Gpu;
use crate::plan::{
    Bias, Bounds, Compare, DepthLoad, DepthTest, PassKind, PassSpec, PipelineSpec, Program,
    StencilTest, StencilWrite, Target, Viewport,
};
use crate::shaders::{self, ShaderSource};
use crate::target::{ResolveModes, COLOR_FORMAT};

/// `VkCompareOp` of a [`Compare`].
pub fn map_compare(op: Compare) -> vk::CompareOp {
    match op {
        Compare::Never => vk::CompareOp::NEVER,
        Compare::Less => vk::CompareOp::LESS,
        Compare::Equal => vk::CompareOp::EQUAL,
        Compare::LessOrEqual => vk::CompareOp::LESS_OR_EQUAL,
        Compare::Greater => vk::CompareOp::GREATER,
        Compare::NotEqual => vk::CompareOp::NOT_EQUAL,
        Compare::GreaterOrEqual => vk::CompareOp::GREATER_OR_EQUAL,
        Compare::Always => vk::CompareOp::ALWAYS,
    }
}

/// `VkAttachmentLoadOp` of a depth load.
fn map_depth_load(load: DepthLoad) -> vk::AttachmentLoadOp {
    match load {
        DepthLoad::Clear(_) => vk::AttachmentLoadOp::CLEAR,
        DepthLoad::Load => vk::AttachmentLoadOp::LOAD,
    }
}

/// `VkAttachmentLoadOp` of the color attachment.
pub fn map_color_load(load_color: bool) -> vk::AttachmentLoadOp {
    if load_color {
        vk::AttachmentLoadOp::LOAD
    } else {
        vk::AttachmentLoadOp::CLEAR
    }
}

/// The layout an attachment must be in before a pass: anything (UNDEFINED) when it is
/// cleared, its attachment layout (where the previous pass or clear left it) when loaded.
fn initial_layout(
    load: vk::AttachmentLoadOp,
    attachment_layout: vk::ImageLayout,
) -> vk::ImageLayout {
    if load == vk::AttachmentLoadOp::LOAD {
        attachment_layout
    } else {
        vk::ImageLayout::UNDEFINED
    }
}

/// The static depth-stencil state of `spec` (the dynamic parts get placeholder values).
fn depth_stencil_state(spec: &PipelineSpec) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
    let (test, op) = match spec.depth_test {
        DepthTest::Off => (false, vk::CompareOp::ALWAYS),
        DepthTest::Static(op) => (true, map_compare(op)),
        DepthTest::Dynamic => (true, vk::CompareOp::ALWAYS),
    };
    let (bounds_test, min, max) = match spec.bounds {
        Bounds::Off | Bounds::Dynamic => (spec.bounds == Bounds::Dynamic, 0.0, 1.0),
        Bounds::Static { min, max } => (true, min, max),
    };
    let stencil_op = |test: StencilTest| {
        vk::StencilOpState::default()
            .fail_op(vk::StencilOp::KEEP)
            .depth_fail_op(vk::StencilOp::KEEP)
            .pass_op(match test.on_pass {
                StencilWrite::Keep => vk::StencilOp::KEEP,
                StencilWrite::Replace => vk::StencilOp::REPLACE,
            })
            .compare_op(map_compare(test.compare))
            .compare_mask(0xff)
            .write_mask(0xff)
            .reference(test.reference)
    };
    let mut state = vk::PipelineDepthStencilStateCreateInfo::default()
        .depth_test_enable(test)
        .depth_write_enable(spec.depth_write)
        .depth_compare_op(op)
        .depth_bounds_test_enable(bounds_test)
        .min_depth_bounds(min)
        .max_depth_bounds(max)
        .stencil_test_enable(spec.stencil.is_some());
    if let Some(test) = spec.stencil {
        state = state.front(stencil_op(test)).back(stencil_op(test));
    }
    state
}

/// The dynamic states of `spec`.
fn dynamic_states(spec: &PipelineSpec) -> Vec<vk::DynamicState> {
    [
        (
            spec.depth_test == DepthTest::Dynamic,
            vk::DynamicState::DEPTH_COMPARE_OP,
        ),
        (spec.bias == Bias::Dynamic, vk::DynamicState::DEPTH_BIAS),
        (
            spec.bounds == Bounds::Dynamic,
            vk::DynamicState::DEPTH_BOUNDS,
        ),
        (
            spec.viewport == Viewport::Dynamic,
            vk::DynamicState::VIEWPORT,
        ),
    ]
    .into_iter()
    .filter_map(|(on, state)| on.then_some(state))
    .collect()
}

/// The attachment formats of the main target, for render passes and dynamic rendering.
#[derive(Clone, Copy, Debug)]
pub struct MainFormats {
    /// The depth (or depth-stencil) format.
    pub depth: vk::Format,
    /// Whether it has a stencil aspect.
    pub stencil: bool,
    /// The shadow map's depth format.
    pub shadow: vk::Format,
    /// Whether render passes can name the aspect an input attachment reads
    /// (`VkRenderPassInputAttachmentAspectCreateInfo`: Vulkan 1.1).
    pub input_aspects: bool,
}

/// Creates the render pass of `pass` (not for the dynamic-rendering kinds).
///
/// Main target: attachment 0 color, attachment 1 depth(-stencil); the stencil is cleared or
/// loaded with the depth. Every attachment is stored and ends in its attachment layout (the
/// read-back transitions it). Shadow map: one attachment of `main.shadow` ending in
/// SHADER_READ_ONLY_OPTIMAL, with an outgoing dependency making its writes visible to the
/// fragment shaders of later passes.
///
/// Depth slice ([`Target::DepthSlice`]): one attachment of `main.depth` (the view of one mip
/// level and array layer of the main depth image), no color, ending in its attachment layout.
///
/// [`PassKind::DepthInputSubpasses`]: subpass 1 has the color attachment and the depth as
/// input attachment 0 in `DEPTH_STENCIL_READ_ONLY_OPTIMAL` (its depth aspect named with
/// `VkRenderPassInputAttachmentAspectCreateInfo`), and where the kind says so the same
/// attachment as its read-only depth-stencil attachment; the depth ends in its attachment
/// layout like every main pass's.
pub fn create_render_pass(
    device: &ash::Device,
    pass: &PassSpec,
    main: MainFormats,
) -> Result<vk::RenderPass> {
    let depth_load = map_depth_load(pass.depth);
    let ds_layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    let color_layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
    let mut attachments = Vec::new();
    let depth_index;
    match pass.target {
        Target::Main => {
            let color_load = map_color_load(pass.load_color);
            attachments.push(
                vk::AttachmentDescription::default()
                    .format(COLOR_FORMAT)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .load_op(color_load)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                    .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                    .initial_layout(initial_layout(color_load, color_layout))
                    .final_layout(color_layout),
            );
            depth_index = 1;
            attachments.push(
                vk::AttachmentDescription::default()
                    .format(main.depth)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .load_op(depth_load)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .stencil_load_op(if main.stencil {
                        depth_load
                    } else {
                        vk::AttachmentLoadOp::DONT_CARE
                    })
                    .stencil_store_op(if main.stencil {
                        vk::AttachmentStoreOp::STORE
                    } else {
                        vk::AttachmentStoreOp::DONT_CARE
                    })
                    .initial_layout(initial_layout(depth_load, ds_layout))
                    .final_layout(ds_layout),
            );
        }
        Target::SoftParticles | Target::Post => {
            attachments.push(
                vk::AttachmentDescription::default()
                    .format(COLOR_FORMAT)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .load_op(vk::AttachmentLoadOp::LOAD)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                    .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                    .initial_layout(color_layout)
                    .final_layout(color_layout),
            );
            depth_index = 1;
            if pass.target == Target::SoftParticles {
                // Loaded and kept (STORE_OP_NONE: nothing writes it in the read-only layout,
                // and a STORE would count as a write after the samples), entered from the
                // attachment layout by the pass itself and left read-only. The plan's needs
                // ask for dynamic rendering, which brings STORE_OP_NONE below Vulkan 1.3.
                let kept = if main.stencil {
                    vk::AttachmentLoadOp::LOAD
                } else {
                    vk::AttachmentLoadOp::DONT_CARE
                };
                attachments.push(
                    vk::AttachmentDescription::default()
                        .format(main.depth)
                        .samples(vk::SampleCountFlags::TYPE_1)
                        .load_op(vk::AttachmentLoadOp::LOAD)
                        .store_op(vk::AttachmentStoreOp::NONE)
                        .stencil_load_op(kept)
                        .stencil_store_op(if main.stencil {
                            vk::AttachmentStoreOp::NONE
                        } else {
                            vk::AttachmentStoreOp::DONT_CARE
                        })
                        .initial_layout(ds_layout)
                        .final_layout(vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL),
                );
            }
        }
        Target::DepthSlice { .. } => {
            // One mip level and layer of the main depth image, no color: cleared or loaded,
            // stored, left in its attachment layout (a barrier makes it readable).
            depth_index = 0;
            attachments.push(
                vk::AttachmentDescription::default()
                    .format(main.depth)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .load_op(depth_load)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .stencil_load_op(if main.stencil {
                        depth_load
                    } else {
                        vk::AttachmentLoadOp::DONT_CARE
                    })
                    .stencil_store_op(if main.stencil {
                        vk::AttachmentStoreOp::STORE
                    } else {
                        vk::AttachmentStoreOp::DONT_CARE
                    })
                    .initial_layout(initial_layout(depth_load, ds_layout))
                    .final_layout(ds_layout),
            );
        }
        Target::Shadow => {
            depth_index = 0;
            attachments.push(
                vk::AttachmentDescription::default()
                    .format(main.shadow)
                    .samples(vk::SampleCountFlags::TYPE_1)
                    .load_op(depth_load)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                    .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                    .initial_layout(initial_layout(depth_load, ds_layout))
                    .final_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
            );
        }
    }
    let color_refs = [vk::AttachmentReference {
        attachment: 0,
        layout: color_layout,
    }];
    let depth_ref = vk::AttachmentReference {
        attachment: depth_index,
        layout: if pass.target == Target::SoftParticles {
            vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL
        } else {
            ds_layout
        },
    };
    // The depth read as an input attachment: the same layout for its read-only depth-stencil
    // use in that subpass, where it has one.
    let read_only_depth_ref = vk::AttachmentReference {
        attachment: depth_index,
        layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
    };
    let input_refs = [read_only_depth_ref];
    let subpass = |n: u32| {
        let description =
            vk::SubpassDescription::default().pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS);
        let description = if !pass.has_depth(n) {
            description
        } else if pass.reads_depth_input(n) {
            description.depth_stencil_attachment(&read_only_depth_ref)
        } else {
            description.depth_stencil_attachment(&depth_ref)
        };
        let description = if pass.reads_depth_input(n) {
            description.input_attachments(&input_refs)
        } else {
            description
        };
        if pass.has_color(n) {
            description.color_attachments(&color_refs)
        } else {
            description
        }
    };
    let subpasses: Vec<vk::SubpassDescription<'_>> =
        (0..pass.kind.subpass_count()).map(subpass).collect();

    let attachment_stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    let depth_stages =
        vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    let depth_access = vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
    // Before the pass: the attachment writes of earlier passes (or nothing, for fresh images)
    // come before this pass's load ops (reads for LOAD, writes for CLEAR) and layout changes.
    let mut dependencies = vec![vk::SubpassDependency {
        src_subpass: vk::SUBPASS_EXTERNAL,
        dst_subpass: 0,
        src_stage_mask: attachment_stages,
        dst_stage_mask: attachment_stages,
        src_access_mask: vk::AccessFlags::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
        dst_access_mask: vk::AccessFlags::COLOR_ATTACHMENT_READ
            | vk::AccessFlags::COLOR_ATTACHMENT_WRITE
            | depth_access,
        dependency_flags: vk::DependencyFlags::empty(),
    }];
    if pass.kind == PassKind::DepthPrepassSubpasses {
        // Subpass 0's depth writes before subpass 1's depth tests (same pixel: by region).
        dependencies.push(vk::SubpassDependency {
            src_subpass: 0,
            dst_subpass: 1,
            src_stage_mask: depth_stages,
            dst_stage_mask: depth_stages,
            src_access_mask: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            dst_access_mask: depth_access,
            dependency_flags: vk::DependencyFlags::BY_REGION,
        });
    }
    if pass.kind.reads_depth_input() {
        // Subpass 0's depth writes before subpass 1's input attachment reads (and depth tests,
        // where the depth stays attached) and the layout change into the read-only layout;
        // its color writes before subpass 1's (the same pixels: by region).
        let (tests, test_reads) = if pass.has_depth(1) {
            (depth_stages, vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ)
        } else {
            (vk::PipelineStageFlags::empty(), vk::AccessFlags::empty())
        };
        dependencies.push(vk::SubpassDependency {
            src_subpass: 0,
            dst_subpass: 1,
            src_stage_mask: depth_stages | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
            dst_stage_mask: vk::PipelineStageFlags::FRAGMENT_SHADER
                | tests
                | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
            src_access_mask: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE
                | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            dst_access_mask: vk::AccessFlags::INPUT_ATTACHMENT_READ
                | test_reads
                | vk::AccessFlags::COLOR_ATTACHMENT_READ
                | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            dependency_flags: vk::DependencyFlags::BY_REGION,
        });
    }
    if matches!(pass.target, Target::SoftParticles | Target::Post) {
        // Earlier passes' depth writes (and the barrier into SHADER_READ_ONLY_OPTIMAL of a
        // post pass) before this pass's fragment shaders sample the depth; the samples before
        // later depth writes and copies (the next frame's main pass, the read-back).
        dependencies.push(vk::SubpassDependency {
            src_subpass: vk::SUBPASS_EXTERNAL,
            dst_subpass: 0,
            src_stage_mask: depth_stages,
            dst_stage_mask: vk::PipelineStageFlags::FRAGMENT_SHADER,
            src_access_mask: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            dst_access_mask: vk::AccessFlags::SHADER_READ,
            dependency_flags: vk::DependencyFlags::empty(),
        });
        dependencies.push(vk::SubpassDependency {
            src_subpass: 0,
            dst_subpass: vk::SUBPASS_EXTERNAL,
            src_stage_mask: vk::PipelineStageFlags::FRAGMENT_SHADER | depth_stages,
            dst_stage_mask: depth_stages | vk::PipelineStageFlags::TRANSFER,
            src_access_mask: vk::AccessFlags::empty(),
            dst_access_mask: vk::AccessFlags::empty(),
            dependency_flags: vk::DependencyFlags::empty(),
        });
    }
    if pass.target == Target::Shadow {
        dependencies.push(vk::SubpassDependency {
            src_subpass: 0,
            dst_subpass: vk::SUBPASS_EXTERNAL,
            src_stage_mask: depth_stages,
            dst_stage_mask: vk::PipelineStageFlags::FRAGMENT_SHADER,
            src_access_mask: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            dst_access_mask: vk::AccessFlags::SHADER_READ,
            dependency_flags: vk::DependencyFlags::empty(),
        });
    }
    // Input attachment 0 of subpass 1 reads the depth aspect alone (of a depth-stencil format
    // it would otherwise name both aspects, and the descriptor's view has only one).
    let input_aspects = [vk::InputAttachmentAspectReference {
        subpass: 1,
        input_attachment_index: 0,
        aspect_mask: vk::ImageAspectFlags::DEPTH,
    }];
    let mut input_aspect_info =
        vk::RenderPassInputAttachmentAspectCreateInfo::default().aspect_references(&input_aspects);
    let mut info = vk::RenderPassCreateInfo::default()
        .attachments(&attachments)
        .subpasses(&subpasses)
        .dependencies(&dependencies);
    // A multiview pass renders each view of its mask into that layer of every attachment
    // (the views correlated: rendered alike, as a stereo pair is).
    let view_masks = [pass.view_mask];
    let mut multiview_info = vk::RenderPassMultiviewCreateInfo::default()
        .view_masks(&view_masks)
        .correlation_masks(&view_masks);
    if pass.view_mask != 0 {
        info = info.push_next(&mut multiview_info);
    }
    if pass.kind.reads_depth_input() {
        ensure!(
            main.input_aspects || !main.stencil,
            "reading the depth aspect of a depth-stencil image as an input attachment needs \
             Vulkan 1.1 (VkRenderPassInputAttachmentAspectCreateInfo)"
        );
        if main.input_aspects {
            info = info.push_next(&mut input_aspect_info);
        }
    }
    // SAFETY: valid device; the create info refers to live locals.
    unsafe { device.create_render_pass(&info, None) }.context("vkCreateRenderPass failed")
}

/// Creates the render pass of a multisampled main `pass` with `vkCreateRenderPass2`: one
/// subpass drawing into attachment 0 (color) and 1 (depth-stencil), both of `samples` samples,
/// cleared and not stored (transient), resolved at the end of the subpass into attachment 2
/// (the main color image, `pResolveAttachments`) and attachment 3 (the main depth image,
/// `VkSubpassDescriptionDepthStencilResolve` with `resolve`'s modes). The resolve attachments
/// are stored and end in their attachment layouts (the read-back transitions them). Where the
/// pass keeps its depth for shaders ([`crate::plan::Multisample::sampled_depth`]), the depth
/// attachment is stored (stencil too) and not resolved: three attachments.
pub fn create_resolving_render_pass(
    gpu: &Gpu,
    pass: &PassSpec,
    main: MainFormats,
    samples: vk::SampleCountFlags,
    resolve: ResolveModes,
) -> Result<vk::RenderPass> {
    let ds_layout = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    let color_layout = vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL;
    let stencil_load = if main.stencil {
        vk::AttachmentLoadOp::CLEAR
    } else {
        vk::AttachmentLoadOp::DONT_CARE
    };
    let stencil_resolved = main.stencil && resolve.stencil != vk::ResolveModeFlags::NONE;
    // A depth kept for shaders is stored (stencil too), not resolved.
    let kept = pass.multisample.is_some_and(|m| m.sampled_depth);
    let (depth_store, stencil_store) = match (kept, main.stencil) {
        (true, true) => (vk::AttachmentStoreOp::STORE, vk::AttachmentStoreOp::STORE),
        (true, false) => (
            vk::AttachmentStoreOp::STORE,
            vk::AttachmentStoreOp::DONT_CARE,
        ),
        (false, _) => (
            vk::AttachmentStoreOp::DONT_CARE,
            vk::AttachmentStoreOp::DONT_CARE,
        ),
    };
    // Written only by the resolve: their previous contents do not matter.
    let resolved = |format, stencil_store| {
        vk::AttachmentDescription2::default()
            .format(format)
            .samples(vk::SampleCountFlags::TYPE_1)
            .load_op(vk::AttachmentLoadOp::DONT_CARE)
            .store_op(vk::AttachmentStoreOp::STORE)
            .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
            .stencil_store_op(stencil_store)
            .initial_layout(vk::ImageLayout::UNDEFINED)
    };
    let attachments = [
        vk::AttachmentDescription2::default()
            .format(COLOR_FORMAT)
            .samples(samples)
            .load_op(map_color_load(pass.load_color))
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
            .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
            .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(color_layout),
        vk::AttachmentDescription2::default()
            .format(main.depth)
            .samples(samples)
            .load_op(map_depth_load(pass.depth))
            .store_op(depth_store)
            .stencil_load_op(stencil_load)
            .stencil_store_op(stencil_store)
            .initial_layout(vk::ImageLayout::UNDEFINED)
            .final_layout(ds_layout),
        resolved(COLOR_FORMAT, vk::AttachmentStoreOp::DONT_CARE).final_layout(color_layout),
        resolved(
            main.depth,
            if stencil_resolved {
                vk::AttachmentStoreOp::STORE
            } else {
                vk::AttachmentStoreOp::DONT_CARE
            },
        )
        .final_layout(ds_layout),
    ];
    let reference = |attachment, layout, aspects| {
        vk::AttachmentReference2::default()
            .attachment(attachment)
            .layout(layout)
            .aspect_mask(aspects)
    };
    let ds_aspects = if main.stencil {
        vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
    } else {
        vk::ImageAspectFlags::DEPTH
    };
    let color_refs = [reference(0, color_layout, vk::ImageAspectFlags::COLOR)];
    let depth_ref = reference(1, ds_layout, ds_aspects);
    let resolve_refs = [reference(2, color_layout, vk::ImageAspectFlags::COLOR)];
    let depth_resolve_ref = reference(3, ds_layout, ds_aspects);
    let mut depth_resolve = vk::SubpassDescriptionDepthStencilResolve::default()
        .depth_resolve_mode(resolve.depth)
        .stencil_resolve_mode(resolve.stencil)
        .depth_stencil_resolve_attachment(&depth_resolve_ref);
    let subpass = vk::SubpassDescription2::default()
        .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
        .color_attachments(&color_refs)
        .resolve_attachments(&resolve_refs)
        .depth_stencil_attachment(&depth_ref);
    // A kept depth: the color is resolved, the depth is not (no resolve attachment for it).
    let subpasses = if kept {
        [subpass]
    } else {
        [subpass.push_next(&mut depth_resolve)]
    };
    let attachments = if kept {
        &attachments[..3]
    } else {
        &attachments[..]
    };

    let attachment_stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    let attachment_writes =
        vk::AccessFlags::COLOR_ATTACHMENT_WRITE | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE;
    // Before the pass: earlier attachment writes (or nothing, for fresh images) come before
    // this pass's clears, layout changes and resolve writes (color attachment output, for
    // color and depth resolves alike).
    let dependencies = [vk::SubpassDependency2::default()
        .src_subpass(vk::SUBPASS_EXTERNAL)
        .dst_subpass(0)
        .src_stage_mask(attachment_stages)
        .dst_stage_mask(attachment_stages)
        .src_access_mask(attachment_writes)
        .dst_access_mask(
            attachment_writes
                | vk::AccessFlags::COLOR_ATTACHMENT_READ
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ,
        )];
    let info = vk::RenderPassCreateInfo2::default()
        .attachments(attachments)
        .subpasses(&subpasses)
        .dependencies(&dependencies);
    // SAFETY: the device has the command (Vulkan 1.2, or the extension: checked with the
    // targets); the create info refers to live locals.
    unsafe { gpu.create_render_pass2(&info) }.context("vkCreateRenderPass2 failed")
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
    fn new(device: &'a ash::Device, source: &ShaderSource) -> Result<Self> {
        let words = source.words()?;
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        // SAFETY: valid device; `words` is SPIR-V validated at build time (naga) and in tests
        // (spirv-val).
        let module = unsafe { device.create_shader_module(&info, None) }
            .with_context(|| format!("vkCreateShaderModule ({}) failed", source.name))?;
        Ok(ShaderModule { device, module })
    }
}

/// Everything a pipeline is made against besides its spec.
#[derive(Clone, Copy, Debug)]
pub struct PipelineTarget<'p> {
    /// The pass the pipeline is made for.
    pub pass: &'p PassSpec,
    /// Its render pass (null for dynamic rendering).
    pub render_pass: vk::RenderPass,
    /// The pipeline layout.
    pub layout: vk::PipelineLayout,
    /// The size of the pass's target (the viewport and scissor).
    pub extent: vk::Extent2D,
    /// The main target's formats (dynamic rendering).
    pub main: MainFormats,
    /// Whether the `depthBiasClamp` feature is enabled (else the clamp is 0).
    pub bias_clamp: bool,
}

/// A pipeline made by [`create_pipeline`] and what it was linked from: its owner destroys
/// `pipeline`, then `libraries` (kept alive for as long as the pipeline, as an application
/// that may link them again would).
#[derive(Clone, Debug)]
pub struct BuiltPipeline {
    /// The pipeline to bind.
    pub pipeline: vk::Pipeline,
    /// The `VK_EXT_graphics_pipeline_library` libraries it was linked from, in the order
    /// vertex input interface, pre-rasterization shaders, fragment shader, fragment output
    /// interface (empty for an ordinary pipeline).
    pub libraries: Vec<vk::Pipeline>,
}

/// Pipelines destroyed when dropped unless taken: the libraries made so far, should a later
/// library or the link fail.
struct PipelineGuard<'a> {
    device: &'a ash::Device,
    pipelines: Vec<vk::Pipeline>,
}

impl Drop for PipelineGuard<'_> {
    fn drop(&mut self) {
        for &pipeline in &self.pipelines {
            // SAFETY: created from `device` and never bound (creation did not complete).
            unsafe { self.device.destroy_pipeline(pipeline, None) };
        }
    }
}

/// One `vkCreateGraphicsPipelines` call for `info`.
fn create_one(
    device: &ash::Device,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    what: &str,
) -> Result<vk::Pipeline> {
    // SAFETY: valid device; every state structure and module `info` refers to is alive for
    // the call (the callers build them as locals around it).
    let pipelines = unsafe {
        device.create_graphics_pipelines(
            vk::PipelineCache::null(),
            std::slice::from_ref(info),
            None,
        )
    }
    .map_err(|(pipelines, e)| {
        for pipeline in pipelines {
            // SAFETY: pipelines returned by the failed call; null ones are ignored.
            unsafe { device.destroy_pipeline(pipeline, None) };
        }
        anyhow!("vkCreateGraphicsPipelines ({what}) failed: {e}")
    })?;
    pipelines
        .into_iter()
        .next()
        .ok_or_else(|| anyhow!("vkCreateGraphicsPipelines ({what}) returned no pipeline"))
}

/// The `VK_EXT_graphics_pipeline_library` state subset a dynamic state belongs to: viewport
/// and depth bias are pre-rasterization state, the depth compare op and bounds fragment
/// shader state.
fn library_of(state: vk::DynamicState) -> vk::GraphicsPipelineLibraryFlagsEXT {
    match state {
        vk::DynamicState::VIEWPORT | vk::DynamicState::DEPTH_BIAS => {
            vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS
        }
        _ => vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER,
    }
}

/// Creates the pipeline of `spec`: vec3 positions, triangle lists, back faces culled where the
/// spec says so, the viewport covering the target, and the spec's depth, stencil, bias, bounds
/// and dynamic state; with [`PipelineSpec::libraries`], from four
/// `VK_EXT_graphics_pipeline_library` libraries (each with its share of the same state) linked
/// into the pipeline returned.
pub fn create_pipeline(
    device: &ash::Device,
    spec: &PipelineSpec,
    target: PipelineTarget<'_>,
) -> Result<BuiltPipeline> {
    let (vertex, fragment) = match spec.program {
        // A pipeline of the shader-object program's shaders (the renderer binds them as
        // shader objects instead).
        Program::Flat | Program::ShaderObjects | Program::LinkedShaderObjects => {
            (shaders::SCENE_VERT, Some(shaders::SCENE_FRAG))
        }
        // The mesh stage in the vertex stage's place (`first_stage` below).
        Program::Mesh | Program::MeshShaderObjects => {
            (shaders::MESH_MESH, Some(shaders::SCENE_FRAG))
        }
        Program::DepthOnly => (shaders::SCENE_VERT, None),
        Program::FragDepth => (shaders::SCENE_VERT, Some(shaders::FRAG_DEPTH_FRAG)),
        Program::ShadowReceiver => (
            shaders::SHADOW_RECEIVER_VERT,
            Some(shaders::SHADOW_RECEIVER_FRAG),
        ),
        Program::ShadowReceiverRaw => (
            shaders::SHADOW_RECEIVER_VERT,
            Some(shaders::SHADOW_RECEIVER_RAW_FRAG),
        ),
        Program::RowMajor => (shaders::ROW_MAJOR_VERT, Some(shaders::SCENE_FRAG)),
        Program::SoftParticle => (
            shaders::SOFT_PARTICLE_VERT,
            Some(shaders::SOFT_PARTICLE_FRAG),
        ),
        Program::DepthPost => (shaders::SCENE_VERT, Some(shaders::DEPTH_POST_FRAG)),
        Program::DepthTiles => (shaders::SCENE_VERT, Some(shaders::DEPTH_TILES_POST_FRAG)),
        Program::StencilPost => (shaders::SCENE_VERT, Some(shaders::STENCIL_POST_FRAG)),
        Program::DepthInput => (shaders::SCENE_VERT, Some(shaders::DEPTH_INPUT_FRAG)),
        Program::DepthInputUndecorated => (
            shaders::SCENE_VERT,
            Some(shaders::DEPTH_INPUT_UNDECORATED_FRAG),
        ),
        Program::DepthMipsPost => (shaders::SCENE_VERT, Some(shaders::DEPTH_MIPS_POST_FRAG)),
        Program::DepthLayersPost => (shaders::SCENE_VERT, Some(shaders::DEPTH_LAYERS_POST_FRAG)),
        Program::Multiview => (shaders::MULTIVIEW_VERT, Some(shaders::SCENE_FRAG)),
        Program::DepthPostMs => (shaders::SCENE_VERT, Some(shaders::DEPTH_POST_MS_FRAG)),
        Program::RowVector => (shaders::ROW_VECTOR_VERT, Some(shaders::SCENE_FRAG)),
        Program::MvpPair => (shaders::MVP_PAIR_VERT, Some(shaders::MVP_PAIR_FRAG)),
        Program::LitMvp => (shaders::LIT_MVP_VERT, Some(shaders::LIT_MVP_FRAG)),
        Program::Ubo => (shaders::UBO_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::UboDynamic => (shaders::UBO_DYNAMIC_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::Ssbo => (shaders::SSBO_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::SsboRows => (shaders::SSBO_ROWS_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::SsboRegisters => (shaders::SSBO_REGISTERS_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::SsboColumns => (shaders::SSBO_COLUMNS_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::SsboVkd3d => (shaders::SSBO_VKD3D_VERT, Some(shaders::FLAT_COLOR_FRAG)),
        Program::SplitPush | Program::FullPush => {
            (shaders::SPLIT_MVP_VERT, Some(shaders::SPLIT_COLOR_FRAG))
        }
        Program::UboGeometry
        | Program::ProjectingGeometryShaderObjects
        | Program::UboTessellatedGeometry
        | Program::UboProjectingTessellation => {
            (shaders::UBO_POSITION_VERT, Some(shaders::FLAT_COLOR_FRAG))
        }
        Program::UboPassthroughGeometry
        | Program::PassthroughGeometryShaderObjects
        | Program::UboInterpolatingTessellation => {
            (shaders::UBO_VERT, Some(shaders::FLAT_COLOR_FRAG))
        }
        Program::PushGeometry => (shaders::UBO_POSITION_VERT, Some(shaders::SCENE_FRAG)),
        Program::UboTessellation | Program::LinkedTessellationShaderObjects => {
            (shaders::UBO_LATER_VERT, Some(shaders::FLAT_COLOR_FRAG))
        }
    };
    // The stages between the vertex and fragment stages, where the program projects there.
    let later: &[(vk::ShaderStageFlags, shaders::ShaderSource)] = match spec.program {
        Program::UboGeometry | Program::ProjectingGeometryShaderObjects => {
            &[(vk::ShaderStageFlags::GEOMETRY, shaders::UBO_GEOM)]
        }
        Program::UboPassthroughGeometry | Program::PassthroughGeometryShaderObjects => {
            &[(vk::ShaderStageFlags::GEOMETRY, shaders::PASSTHROUGH_GEOM)]
        }
        Program::PushGeometry => &[(vk::ShaderStageFlags::GEOMETRY, shaders::PUSH_GEOM)],
        Program::UboTessellation | Program::LinkedTessellationShaderObjects => &[
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                shaders::PASSTHROUGH_TESC,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                shaders::UBO_TESE,
            ),
        ],
        Program::UboTessellatedGeometry => &[
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                shaders::CORNER_POSITIONS_TESC,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                shaders::CORNER_INTERPOLATING_TESE,
            ),
            (vk::ShaderStageFlags::GEOMETRY, shaders::UBO_GEOM),
        ],
        Program::UboProjectingTessellation => &[
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                shaders::CORNER_POSITIONS_TESC,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                shaders::PROJECTING_TESE,
            ),
        ],
        Program::UboInterpolatingTessellation => &[
            (
                vk::ShaderStageFlags::TESSELLATION_CONTROL,
                shaders::POSITION_PASSTHROUGH_TESC,
            ),
            (
                vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                shaders::INTERPOLATING_TESE,
            ),
        ],
        _ => &[],
    };
    ensure!(
        later.is_empty() || !spec.libraries,
        "pipeline libraries are built with a vertex stage alone"
    );
    let later_modules = later
        .iter()
        .map(|(stage, source)| Ok((*stage, ShaderModule::new(device, source)?)))
        .collect::<Result<Vec<_>>>()?;
    let vert = ShaderModule::new(device, &vertex)?;
    let frag = fragment
        .map(|source| ShaderModule::new(device, &source))
        .transpose()?;
    let meshes = matches!(spec.program, Program::Mesh | Program::MeshShaderObjects);
    let first_stage = if meshes {
        vk::ShaderStageFlags::MESH_EXT
    } else {
        vk::ShaderStageFlags::VERTEX
    };
    let vertex_stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(first_stage)
        .module(vert.module)
        .name(c"main");
    let fragment_stage = frag.as_ref().map(|frag| {
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::FRAGMENT)
            .module(frag.module)
            .name(c"main")
    });
    let stages: Vec<_> = std::iter::once(vertex_stage)
        .chain(later_modules.iter().map(|(stage, module)| {
            vk::PipelineShaderStageCreateInfo::default()
                .stage(*stage)
                .module(module.module)
                .name(c"main")
        }))
        .chain(fragment_stage)
        .collect();
    let tessellates = spec.program.tessellates();
    // Each triangle of the index buffer is a patch of three control points.
    let tessellation = vk::PipelineTessellationStateCreateInfo::default().patch_control_points(3);
    let (bindings, attributes) = position_input();
    let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
        .vertex_binding_descriptions(&bindings)
        .vertex_attribute_descriptions(&attributes);
    let input_assembly =
        vk::PipelineInputAssemblyStateCreateInfo::default().topology(if tessellates {
            vk::PrimitiveTopology::PATCH_LIST
        } else {
            vk::PrimitiveTopology::TRIANGLE_LIST
        });
    let (min_depth, max_depth) = match spec.viewport {
        Viewport::Static {
            min_depth,
            max_depth,
        } => (min_depth, max_depth),
        Viewport::Dynamic => (0.0, 1.0),
    };
    let viewports = [full_viewport(target.extent, min_depth, max_depth)];
    let scissors = [vk::Rect2D {
        offset: vk::Offset2D { x: 0, y: 0 },
        extent: target.extent,
    }];
    // OpenGL-convention clip depth ([-w, w]); the device has VK_EXT_depth_clip_control enabled
    // whenever a pipeline asks for it (the plan's needs, checked before rendering).
    let mut depth_clip_control =
        vk::PipelineViewportDepthClipControlCreateInfoEXT::default().negative_one_to_one(true);
    let mut viewport_state = vk::PipelineViewportStateCreateInfo::default()
        .viewports(&viewports)
        .scissors(&scissors);
    if spec.negative_one_to_one {
        viewport_state = viewport_state.push_next(&mut depth_clip_control);
    }
    let mut rasterization = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(if spec.cull_back_faces {
            vk::CullModeFlags::BACK
        } else {
            vk::CullModeFlags::NONE
        })
        .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
        .depth_clamp_enable(spec.depth_clamp || spec.program.clamps_with_clip())
        .line_width(1.0);
    // D3D's rasterizer state: the clamp on, clipping kept on (the device has
    // VK_EXT_depth_clip_enable enabled for such programs: `Needs::depth_clip_enable`).
    let mut depth_clip =
        vk::PipelineRasterizationDepthClipStateCreateInfoEXT::default().depth_clip_enable(true);
    if spec.program.clamps_with_clip() {
        rasterization = rasterization.push_next(&mut depth_clip);
    }
    match spec.bias {
        Bias::Off => {}
        Bias::Dynamic => rasterization = rasterization.depth_bias_enable(true),
        Bias::Static(bias) => {
            rasterization = rasterization
                .depth_bias_enable(true)
                .depth_bias_constant_factor(bias.constant)
                .depth_bias_slope_factor(bias.slope)
                .depth_bias_clamp(if target.bias_clamp { bias.clamp } else { 0.0 });
        }
    }
    let multisample = vk::PipelineMultisampleStateCreateInfo::default()
        .rasterization_samples(vk::SampleCountFlags::from_raw(target.pass.samples()));
    let depth_stencil = depth_stencil_state(spec);
    let blend_attachments: Vec<vk::PipelineColorBlendAttachmentState> =
        if target.pass.has_color(spec.subpass) {
            vec![vk::PipelineColorBlendAttachmentState::default()
                .blend_enable(false)
                .color_write_mask(if spec.color_write {
                    vk::ColorComponentFlags::RGBA
                } else {
                    vk::ColorComponentFlags::empty()
                })]
        } else {
            Vec::new()
        };
    let color_blend =
        vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
    let dynamic = dynamic_states(spec);
    // A dynamic rendering's formats and view mask (no render pass).
    let color_formats = [COLOR_FORMAT];
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .view_mask(target.pass.view_mask)
        .color_attachment_formats(&color_formats)
        .depth_attachment_format(target.main.depth)
        .stencil_attachment_format(if target.main.stencil {
            target.main.depth
        } else {
            vk::Format::UNDEFINED
        });
    let dynamic_rendering = target.pass.kind.is_dynamic_rendering();

    if spec.libraries {
        // In a render pass, every library that needs the render pass and subpass is given
        // them; in a plain dynamic rendering (`Plan::check`), each of those chains a
        // `VkPipelineRenderingCreateInfo` instead (the view mask for the shader libraries, the
        // attachment formats too for the fragment output interface).
        // The shader libraries read the view mask alone: they name no formats (which the
        // fragment output interface holds; the installed validation layer, 1.3.239, would
        // otherwise ask them for color blend and depth-stencil state).
        let shader_rendering =
            vk::PipelineRenderingCreateInfo::default().view_mask(target.pass.view_mask);
        let (mut rendering_pre, mut rendering_fragment, mut rendering_output) =
            (shader_rendering, shader_rendering, rendering);
        let library = |flags: vk::GraphicsPipelineLibraryFlagsEXT| {
            vk::GraphicsPipelineLibraryCreateInfoEXT::default().flags(flags)
        };
        let dynamic_of = |flags| -> Vec<vk::DynamicState> {
            dynamic
                .iter()
                .copied()
                .filter(|&state| library_of(state) == flags)
                .collect()
        };
        let pre_rasterization_dynamic =
            dynamic_of(vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS);
        let fragment_dynamic = dynamic_of(vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER);
        let pre_rasterization_dynamic_state = vk::PipelineDynamicStateCreateInfo::default()
            .dynamic_states(&pre_rasterization_dynamic);
        let fragment_dynamic_state =
            vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&fragment_dynamic);
        let base =
            vk::GraphicsPipelineCreateInfo::default().flags(vk::PipelineCreateFlags::LIBRARY_KHR);
        let mut guard = PipelineGuard {
            device,
            pipelines: Vec::with_capacity(4),
        };

        // Vertex input interface: vertex input and input assembly.
        let mut subset = library(vk::GraphicsPipelineLibraryFlagsEXT::VERTEX_INPUT_INTERFACE);
        let info = base
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .push_next(&mut subset);
        let what = format!("{}: vertex input interface library", spec.name);
        guard.pipelines.push(create_one(device, &info, &what)?);

        // Pre-rasterization shaders: the vertex shader, the viewport (its depth range) and the
        // rasterization state (its depth bias).
        let mut subset = library(vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS);
        let mut info = base
            .stages(std::slice::from_ref(&vertex_stage))
            .viewport_state(&viewport_state)
            .rasterization_state(&rasterization)
            .layout(target.layout)
            .push_next(&mut subset);
        info = if dynamic_rendering {
            info.push_next(&mut rendering_pre)
        } else {
            info.render_pass(target.render_pass).subpass(spec.subpass)
        };
        if !pre_rasterization_dynamic.is_empty() {
            info = info.dynamic_state(&pre_rasterization_dynamic_state);
        }
        let what = format!("{}: pre-rasterization shaders library", spec.name);
        guard.pipelines.push(create_one(device, &info, &what)?);

        // Fragment shader: the fragment shader (none for depth-only programs), the
        // depth-stencil state (compare op, test and write enables, bounds, stencil) and the
        // multisample state.
        let mut subset = library(vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER);
        let mut info = base
            .stages(fragment_stage.as_slice())
            .depth_stencil_state(&depth_stencil)
            .multisample_state(&multisample)
            .layout(target.layout)
            .push_next(&mut subset);
        info = if dynamic_rendering {
            info.push_next(&mut rendering_fragment)
        } else {
            info.render_pass(target.render_pass).subpass(spec.subpass)
        };
        if !fragment_dynamic.is_empty() {
            info = info.dynamic_state(&fragment_dynamic_state);
        }
        let what = format!("{}: fragment shader library", spec.name);
        guard.pipelines.push(create_one(device, &info, &what)?);

        // Fragment output interface: color blending and the multisample state.
        let mut subset = library(vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_OUTPUT_INTERFACE);
        let mut info = base
            .color_blend_state(&color_blend)
            .multisample_state(&multisample)
            .push_next(&mut subset);
        info = if dynamic_rendering {
            info.push_next(&mut rendering_output)
        } else {
            info.render_pass(target.render_pass).subpass(spec.subpass)
        };
        let what = format!("{}: fragment output interface library", spec.name);
        guard.pipelines.push(create_one(device, &info, &what)?);

        // The executable pipeline: the four libraries linked (no link-time optimization),
        // with the same layout.
        let mut linked = vk::PipelineLibraryCreateInfoKHR::default().libraries(&guard.pipelines);
        let mut info = vk::GraphicsPipelineCreateInfo::default()
            .layout(target.layout)
            .push_next(&mut linked);
        if spec.program == Program::DepthInput {
            // A link whose fragment shader reads input attachments names the render pass and
            // subpass too (VUID-VkGraphicsPipelineCreateInfo-renderPass-06061), and the
            // validation layers then ask for the multisample state (06631).
            info = info
                .render_pass(target.render_pass)
                .subpass(spec.subpass)
                .multisample_state(&multisample);
        }
        let what = format!("{}: link of its libraries", spec.name);
        let pipeline = create_one(device, &info, &what)?;
        return Ok(BuiltPipeline {
            pipeline,
            libraries: std::mem::take(&mut guard.pipelines),
        });
    }

    let dynamic_state = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic);
    let mut info = vk::GraphicsPipelineCreateInfo::default()
        .stages(&stages)
        .viewport_state(&viewport_state)
        .rasterization_state(&rasterization)
        .multisample_state(&multisample)
        .depth_stencil_state(&depth_stencil)
        .color_blend_state(&color_blend)
        .dynamic_state(&dynamic_state)
        .layout(target.layout);
    // A mesh pipeline has no vertex input nor input assembly.
    if !meshes {
        info = info
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly);
    }
    if tessellates {
        info = info.tessellation_state(&tessellation);
    }
    // A local-read rendering that maps the depth to an input attachment index gives every
    // pipeline made for it that mapping (the command buffer sets the same one: they must
    // match at each draw); the color attachment maps to no input attachment.
    let color_input_indices = [vk::ATTACHMENT_UNUSED];
    let mut input_indices = vk::RenderingInputAttachmentIndexInfoKHR::default()
        .color_attachment_input_indices(&color_input_indices)
        .depth_input_attachment_index(&DEPTH_INPUT_ATTACHMENT_INDEX);
    if dynamic_rendering {
        // A local-read rendering keeps its depth attachment throughout: the format is named
        // for the pipelines that read it as an input attachment too.
        info = info.push_next(&mut rendering);
        if target.pass.kind == (PassKind::DynamicRenderingLocalRead { indexed: true }) {
            info = info.push_next(&mut input_indices);
        }
    } else {
        info = info.render_pass(target.render_pass).subpass(spec.subpass);
    }
    Ok(BuiltPipeline {
        pipeline: create_one(device, &info, spec.name)?,
        libraries: Vec::new(),
    })
}

/// The input attachment index a [`PassKind::DynamicRenderingLocalRead`] rendering that maps
/// its depth explicitly maps it to (in its pipelines and in
/// `vkCmdSetRenderingInputAttachmentIndicesKHR`): `depth_input.frag`'s `input_attachment_index`.
pub const DEPTH_INPUT_ATTACHMENT_INDEX: u32 = 0;

/// The viewport covering `extent` with depth range [min_depth, max_depth].
pub fn full_viewport(extent: vk::Extent2D, min_depth: f32, max_depth: f32) -> vk::Viewport {
    vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth,
        max_depth,
    }
}

/// The tester's one vertex layout: a tightly packed float32 position (binding 0, location 0),
/// as [`crate::scene::Mesh`] stores it.
pub fn position_input() -> (
    [vk::VertexInputBindingDescription; 1],
    [vk::VertexInputAttributeDescription; 1],
) {
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
    (bindings, attributes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_ops_map_to_their_vulkan_values() {
        // VkCompareOp values are 0..7 in the order of the enum.
        let ops = [
            Compare::Never,
            Compare::Less,
            Compare::Equal,
            Compare::LessOrEqual,
            Compare::Greater,
            Compare::NotEqual,
            Compare::GreaterOrEqual,
            Compare::Always,
        ];
        for (value, op) in ops.into_iter().enumerate() {
            assert_eq!(map_compare(op).as_raw(), value as i32, "{op:?}");
        }
    }

    #[test]
    fn only_dynamic_parts_become_dynamic_states() {
        let standard = PipelineSpec::standard("s", 0);
        assert!(dynamic_states(&standard).is_empty());
        let all = PipelineSpec {
            depth_test: DepthTest::Dynamic,
            bias: Bias::Dynamic,
            bounds: Bounds::Dynamic,
            viewport: Viewport::Dynamic,
            ..standard
        };
        assert_eq!(dynamic_states(&all).len(), 4);
        // Each goes to the library holding its state: viewport and bias to the
        // pre-rasterization shaders, compare op and bounds to the fragment shader.
        let libraries: Vec<_> = dynamic_states(&all).into_iter().map(library_of).collect();
        let pre = vk::GraphicsPipelineLibraryFlagsEXT::PRE_RASTERIZATION_SHADERS;
        let fragment = vk::GraphicsPipelineLibraryFlagsEXT::FRAGMENT_SHADER;
        assert_eq!(libraries, [fragment, pre, fragment, pre]);
        let state = depth_stencil_state(&all);
        assert_eq!(state.depth_test_enable, vk::TRUE);
        assert_eq!(state.depth_bounds_test_enable, vk::TRUE);
    }
}
