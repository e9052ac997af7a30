//! What revz does with one graphics pipeline create info (`super`'s entry points apply it):
//! the state subsets it defines, the dynamic states revz adds, whether its draws can take the
//! precise path (a projection in push constants, or a vertex stage that derives its range),
//! and how its promoted variants differ. These functions read the create info and revz's
//! objects and ask the policy (`crate::policy::pipelines`, `crate::policy::vertex_stage`),
//! which decides.

#![allow(clippy::wildcard_imports)]

use super::*;

/// The subsets a create info defines itself, as the policy reads its chain
/// ([`libraries::own_subsets`]): its `VkGraphicsPipelineLibraryCreateInfoEXT`'s, else whether
/// it links libraries and its flags.
pub(super) fn own_subsets(info: &vk::GraphicsPipelineCreateInfo<'_>) -> Subsets {
    // SAFETY: a valid pNext chain (the application's contract).
    let (named, links) = unsafe {
        (
            chain::find::<vk::GraphicsPipelineLibraryCreateInfoEXT<'_>>(info.p_next),
            chain::find::<vk::PipelineLibraryCreateInfoKHR<'_>>(info.p_next),
        )
    };
    libraries::own_subsets(
        named.map(|named| named.flags),
        || links.is_some_and(|links| links.library_count > 0),
        || is_library(info),
    )
}

/// A create info's flags: those of a chained `VkPipelineCreateFlags2CreateInfoKHR`, which
/// replace `flags`, or `flags`.
pub(super) fn create_flags(
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> vk::PipelineCreateFlags2KHR {
    // SAFETY: a valid pNext chain (the application's contract).
    match unsafe { chain::find::<vk::PipelineCreateFlags2CreateInfoKHR<'_>>(info.p_next) } {
        Some(flags2) => flags2.flags,
        None => vk::PipelineCreateFlags2KHR::from_raw(u64::from(info.flags.as_raw())),
    }
}

/// Whether a create info asks for its batch to end at its failure (`EARLY_RETURN_ON_FAILURE`).
pub(super) fn returns_early(info: &vk::GraphicsPipelineCreateInfo<'_>) -> bool {
    create_flags(info).contains(vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE)
}

/// Whether a create info builds a library.
pub(super) fn is_library(info: &vk::GraphicsPipelineCreateInfo<'_>) -> bool {
    create_flags(info).contains(vk::PipelineCreateFlags2KHR::LIBRARY)
}

/// The libraries a create info links, as revz recorded them (unknown ones are skipped).
pub(super) fn linked_libraries(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> Vec<Arc<PipelineDepth>> {
    // SAFETY: a valid pNext chain (the application's contract).
    let Some(links) = (unsafe { chain::find::<vk::PipelineLibraryCreateInfoKHR<'_>>(info.p_next) })
    else {
        return Vec::new();
    };
    // SAFETY: `libraryCount` pipelines.
    unsafe { slice(links.p_libraries, links.library_count) }
        .iter()
        .filter_map(|library| state.objects.pipelines.get(library))
        .collect()
}

/// Whether a stage is given by a shader module identifier
/// (`VK_EXT_shader_module_identifier`): no code revz could rewrite.
pub(super) fn uses_module_identifiers(info: &vk::GraphicsPipelineCreateInfo<'_>) -> bool {
    // SAFETY: `stageCount` stages (the application's contract).
    let stages = unsafe { slice(info.p_stages, info.stage_count) };
    stages.iter().any(|stage| {
        // SAFETY: a valid pNext chain (the application's contract).
        unsafe {
            chain::has(
                stage.p_next,
                vk::StructureType::PIPELINE_SHADER_STAGE_MODULE_IDENTIFIER_CREATE_INFO_EXT,
            )
        }
    })
}

/// Whether a create info is made from pipeline binaries (`VkPipelineBinaryInfoKHR` with a
/// `binaryCount` above 0): its shaders and compiled state come from them, so a variant made
/// from the same create info would be the same pipeline, nothing rewritten or flipped.
pub(super) fn uses_pipeline_binaries(info: &vk::GraphicsPipelineCreateInfo<'_>) -> bool {
    // SAFETY: a valid pNext chain (the application's contract).
    let mut structures = unsafe { chain::structures(info.p_next) };
    structures.any(|base| {
        base.s_type == crate::ffi::STRUCTURE_TYPE_PIPELINE_BINARY_INFO_KHR && {
            // SAFETY: the sType identifies the structure.
            let binary = unsafe {
                &*(base as *const vk::BaseInStructure<'_>).cast::<crate::ffi::PipelineBinaryInfo>()
            };
            binary.binary_count > 0
        }
    })
}

/// The clip-space depth convention of a pipeline (`VK_EXT_depth_clip_control`); `None` when
/// it is dynamic, so unknown when the projection is pushed.
pub(super) fn depth_convention(
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    dynamic: &[vk::DynamicState],
) -> Option<DepthConvention> {
    if dynamic.contains(&vk::DynamicState::DEPTH_CLIP_NEGATIVE_ONE_TO_ONE_EXT) {
        return None;
    }
    // SAFETY: null or valid (the application's contract).
    let Some(viewport) = (unsafe { info.p_viewport_state.as_ref() }) else {
        return Some(DepthConvention::ZeroToOne);
    };
    // SAFETY: a valid pNext chain (the application's contract).
    let control = unsafe {
        chain::find::<vk::PipelineViewportDepthClipControlCreateInfoEXT<'_>>(viewport.p_next)
    };
    Some(
        if control.is_some_and(|c| c.negative_one_to_one == vk::TRUE) {
            DepthConvention::NegativeOneToOne
        } else {
            DepthConvention::ZeroToOne
        },
    )
}

/// The facts of a candidate pipeline's vertex stage, and what the policy makes of them
/// ([`VertexStageFacts::decide`]): where its projection is (the precise path), or why its
/// draws take the flip path.
pub(super) fn projection_of(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    code_given: bool,
    bakeable: bool,
) -> Result<PreciseStage, String> {
    // SAFETY: `stageCount` stages (the application's contract).
    let stages = unsafe { slice(info.p_stages, info.stage_count) };
    // The stage whose Position is rasterized: the vertex stage, or a tessellation evaluation
    // or geometry stage after it, or a mesh stage; the stage before stages that only carry
    // its positions on.
    let flags: Vec<vk::ShaderStageFlags> = stages.iter().map(|s| s.stage).collect();
    let last_stage = vertex_stage::LastStage::rewritten(&flags, |flag| {
        stage_carries_positions_on(state, stages, flag)
    });
    let vertex_index =
        last_stage.and_then(|last| stages.iter().position(|s| s.stage == last.flag()));
    let vertex = vertex_index.map(|index| &stages[index]);
    // SAFETY: null or valid (the application's contract).
    let dynamic = unsafe { info.p_dynamic_state.as_ref() }.map_or(&[][..], |d| unsafe {
        // SAFETY: `dynamicStateCount` entries.
        slice(d.p_dynamic_states, d.dynamic_state_count)
    });
    // The module's analysis and rewrite, or inline code's (made once per distinct code).
    let (analysis, rewrite) = match vertex {
        Some(vertex) if vertex.module != vk::ShaderModule::null() => (
            state
                .objects
                .vertex_modules
                .get(&vertex.module)
                .ok_or(MissingFact::UnknownModule.reason()),
            state
                .objects
                .position_stores
                .get(&vertex.module)
                .ok_or(Missing::NotMade(MissingFact::ModuleWithoutRewrite.reason())),
        ),
        Some(vertex) => match inline_code(vertex) {
            Some(words) => {
                // Made once per distinct code (`DeviceObjects::vertex_codes`).
                let (analysis, rewrite) =
                    super::modules::vertex_code(state, vk::ShaderModule::null(), words);
                (
                    Ok(analysis),
                    rewrite.ok_or(Missing::NotMade(MissingFact::InlineWithoutRewrite.reason())),
                )
            }
            None => (
                Err(MissingFact::NoModule.reason()),
                Err(Missing::NotMade(MissingFact::NoModule.reason())),
            ),
        },
        None => (
            Err(MissingFact::NoVertexStage.reason()),
            Err(Missing::NotMade(MissingFact::NoVertexStage.reason())),
        ),
    };
    let rewrite = rewrite.and_then(|r| r.map_err(Missing::Unsupported));
    // SAFETY: a NUL-terminated entry point name, when there is a vertex stage (the
    // application's contract).
    let name = vertex.and_then(|vertex| unsafe { crate::ffi::c_str(vertex.p_name) });
    let entry = vertex_stage::entry_point_analysis(
        analysis
            .as_ref()
            .map(|analysis| &**analysis)
            .map_err(|reason| *reason),
        name.map(std::ffi::CStr::to_bytes),
    );
    // A geometry stage projecting gl_in's Position needs the stage before it (the
    // tessellation evaluation or vertex stage) to store w = 1.
    let input_unit_w = match &rewrite {
        Ok(rewrite) if rewrite.needs_input_unit_w => {
            Some(prior_stage_w_one(state, stages, last_stage))
        }
        _ => None,
    };
    let ranges = state.objects.pipeline_layouts.get(&info.layout);
    let carrier = state.objects.layout_carriers.get(&info.layout);
    // No room for the carrier in the layout: the stage with the carrier baked in, for the
    // reversed variants (complete pipelines only: a library's variants are linked by
    // pipelines revz cannot give another stage).
    let baked = match (&carrier, vertex) {
        (None, Some(vertex)) if bakeable && code_given => {
            let words = if vertex.module != vk::ShaderModule::null() {
                state.objects.vertex_words.get(&vertex.module)
            } else {
                inline_code(vertex).map(Arc::from)
            };
            words.map(|words| baked_code(state, &words)?.ok_or("no Position output"))
        }
        _ => None,
    };
    let input_unit_w = match (&carrier, &baked) {
        (None, Some(Ok(rewrite))) if rewrite.assumes_input_unit_w => {
            Some(prior_stage_w_one(state, stages, last_stage))
        }
        (None, _) => None,
        _ => input_unit_w,
    };
    let facts = VertexStageFacts {
        code_given,
        last_stage,
        carrier_reaches_stage: carrier
            .as_ref()
            .zip(last_stage)
            .is_some_and(|(carrier, last)| carrier.stages.contains(last.flag())),
        analysis: entry,
        ranges: ranges.as_deref(),
        convention: depth_convention(info, dynamic),
        carrier_room: carrier.is_some(),
        baked: baked
            .as_ref()
            .map(|b| b.as_ref().map(|r| r.source).map_err(|reason| *reason)),
        rewrite: rewrite.as_ref().map(|r| r.derived).map_err(|m| *m),
        derived_slot: rewrite.as_ref().ok().and_then(|r| r.push_slot),
        input_unit_w,
    };
    let range = facts.decide()?;
    let stage = last_stage.unwrap_or(vertex_stage::LastStage::Vertex);
    match (carrier, rewrite, baked, vertex_index) {
        (_, _, Some(Ok(baked)), Some(index)) if range.baked => Ok(PreciseStage {
            projection: None,
            derived: range.derived,
            carrier: None,
            vertex: (index, baked.code),
            stage,
        }),
        (Some(carrier), Ok(rewrite), _, Some(index)) => Ok(PreciseStage {
            projection: range.projection,
            derived: range.derived,
            carrier: Some(carrier),
            vertex: (index, rewrite.code),
            stage,
        }),
        // The policy found them all.
        _ => Err(MissingFact::Incomplete.reason().into()),
    }
}

/// How the promoted variants of a pipeline differ from it, if it needs them
/// ([`PromotionFacts::decide`]: its render pass has a promoted twin, its rendering formats are
/// promotable, or a library it links (`linked`) has promoted variants). Logged where a pipeline
/// needs them and cannot have them.
pub(super) fn promotion_of(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    subsets: Subsets,
    linked: &[Arc<PipelineDepth>],
) -> Option<Promotion> {
    let mut twin = None;
    let attachments = if !subsets.intersects(USES_ATTACHMENT_FORMATS) {
        PromotionAttachments::NotNamed
    } else if info.render_pass != vk::RenderPass::null() {
        match state.objects.render_passes.get(&info.render_pass) {
            None => PromotionAttachments::UnknownPass,
            Some(pass) => {
                twin = pass.promoted_twin;
                PromotionAttachments::Pass {
                    promotable: crate::policy::pass_promotable(
                        (0..pass.attachments.len()).map(|i| pass.promotable(i)),
                    ),
                    twin: twin.is_some(),
                }
            }
        }
    } else {
        // SAFETY: a valid pNext chain (the application's contract).
        let rendering = unsafe { chain::find::<vk::PipelineRenderingCreateInfo<'_>>(info.p_next) };
        PromotionAttachments::Rendering {
            promotable: rendering.is_some_and(|r| {
                crate::policy::first_promoted_format(
                    r.depth_attachment_format,
                    r.stencil_attachment_format,
                )
                .is_some()
            }),
        }
    };
    let facts = PromotionFacts {
        promote: state.policy.promote,
        attachments,
        libraries_promotable: linked.iter().any(|library| library.promotable),
    };
    match facts.decide() {
        PipelinePromotion::None => None,
        PipelinePromotion::MissingTwin => {
            static MISSING: crate::logging::LogOnce = crate::logging::LogOnce::new();
            MISSING.log(|| {
                log::error!(
                    "a pipeline of a render pass without its promoted twin: its draws \
                     into promoted depth images use it as it is, and the driver may \
                     reject them"
                )
            });
            None
        }
        PipelinePromotion::Promoted {
            twin: with_twin,
            rendering,
        } => Some(Promotion {
            render_pass: twin.filter(|_| with_twin),
            rendering,
            libraries: library_variants(state, info, VariantKind::PROMOTED),
            reversed_libraries: library_variants(state, info, VariantKind::PROMOTED_REVERSED),
            input_libraries: library_variants(state, info, VariantKind::PROMOTED_INPUTS),
        }),
    }
}

/// Plans one create info. Every graphics pipeline gets a [`PipelineDepth`] (at least the
/// states the application made dynamic, so that draw time never sends state a pipeline keeps
/// static); the static values of the subsets the create info defines (viewport and depth bias
/// are pre-rasterization state, compare op and depth bounds fragment shader state) are read
/// and recorded where the pipeline renders depth, and the policy says which become dynamic
/// ([`StaticStateFacts::decide`]). A linked pipeline adds its libraries' afterwards
/// ([`inherit_libraries`]).
pub(super) fn plan(info: &vk::GraphicsPipelineCreateInfo<'_>, context: &PlanContext) -> Plan {
    // SAFETY: null or valid (the application's contract).
    let dynamic = unsafe { info.p_dynamic_state.as_ref() };
    // SAFETY: `dynamicStateCount` entries.
    let app_states = dynamic.map_or(&[][..], |d| unsafe {
        slice(d.p_dynamic_states, d.dynamic_state_count)
    });
    let mut depth = PipelineDepth {
        subsets: context.subsets,
        ..PipelineDepth::default()
    };
    for &state in app_states {
        depth.app_dynamic |= States::of_dynamic(state);
    }
    depth.app_dynamic = depth.app_dynamic & subset_states(context.subsets);
    let unchanged = |depth| Plan {
        dynamic_states: None,
        depth,
        flip_reason: None,
        static_state: StaticStatePlan::default(),
        fragment: None,
        input_fragment: None,
        vertex: None,
        rewritten_stage: None,
        baked_vertex: None,
        libraries: None,
        input_libraries: None,
        promotion: None,
        variants: Variants::default(),
        variant_bias: false,
    };
    let pre_rasterization = context.subsets.contains(Subsets::PRE_RASTERIZATION_SHADERS);
    let fragment = context.subsets.contains(Subsets::FRAGMENT_SHADER);
    // References are made only from pointers the spec says to read (`then_some` would make
    // them first): the rasterization state first, the depth-stencil and viewport state only
    // once the pipeline renders depth.
    let raster = if context.has_depth_attachment && pre_rasterization {
        // SAFETY: null or valid where the create info defines pre-rasterization state (the
        // application's contract).
        unsafe { info.p_rasterization_state.as_ref() }
    } else {
        None
    };
    let rasterizer_discard = raster.is_some_and(|r| r.rasterizer_discard_enable == vk::TRUE);
    if !renders_depth(context.has_depth_attachment, rasterizer_discard, app_states) {
        return unchanged(depth);
    }
    // SAFETY: null or valid for the subsets the create info defines, as the pipeline renders
    // depth (the application's contract).
    let (depth_stencil, viewport) = unsafe {
        (
            if fragment {
                info.p_depth_stencil_state.as_ref()
            } else {
                None
            },
            if pre_rasterization {
                info.p_viewport_state.as_ref()
            } else {
                None
            },
        )
    };
    // The static values, recorded for draw time.
    if let Some(depth_stencil) = depth_stencil {
        depth.compare_op = depth_stencil.depth_compare_op;
        depth.bounds = (
            depth_stencil.min_depth_bounds,
            depth_stencil.max_depth_bounds,
        );
    }
    // A user-defined clamp range (VK_EXT_depth_clamp_control) where the application left it
    // static: depth values, mapped at draw time.
    let app_clamp_range = app_states.contains(&crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE);
    let clamp_range = viewport.filter(|_| !app_clamp_range).and_then(|viewport| {
        // SAFETY: a valid pNext chain (the application's contract), and the range it points to
        // where the mode is user-defined and the range static.
        unsafe {
            let control = chain::find::<crate::vk_ext::PipelineViewportDepthClampControlCreateInfo>(
                viewport.p_next,
            )?;
            // The range is read only in that mode (the spec ignores the pointer otherwise).
            if control.depth_clamp_mode == crate::vk_ext::DEPTH_CLAMP_MODE_USER_DEFINED_RANGE {
                control.p_depth_clamp_range.as_ref()
            } else {
                None
            }
        }
    });
    if let Some(range) = clamp_range {
        depth.clamp_range = (range.min_depth_clamp, range.max_depth_clamp);
    }
    if let Some(viewport) = viewport.filter(|_| viewports_static(app_states)) {
        // SAFETY: `viewportCount` viewports when static.
        depth.viewports = unsafe { slice(viewport.p_viewports, viewport.viewport_count) }.to_vec();
    }
    if let Some(raster) = raster {
        // Whether draws clamp depth without clipping it (infinite mode's precise path cannot
        // clamp at a far plane: `CommandState::clamps_at_far`).
        depth.static_clamp = raster.depth_clamp_enable == vk::TRUE;
        // SAFETY: the application's valid rasterization state.
        depth.depth_clip = unsafe { depth_clip_of(raster, app_states) };
        // SAFETY: a valid pNext chain (the application's contract).
        let representation =
            unsafe { chain::find::<vk::DepthBiasRepresentationInfoEXT<'_>>(raster.p_next) }
                .map(BiasRepresentation::of);
        depth.bias = DepthBias {
            constant: raster.depth_bias_constant_factor,
            clamp: raster.depth_bias_clamp,
            slope: raster.depth_bias_slope_factor,
            representation,
        };
    }
    let static_state = StaticStateFacts {
        has_depth_attachment: context.has_depth_attachment,
        app_dynamic: app_states,
        rasterizer_discard,
        depth_stencil: depth_stencil.map(|ds| DepthStencilFacts {
            compare_op: ds.depth_compare_op,
            depth_test_enable: ds.depth_test_enable == vk::TRUE,
            depth_bounds_test_enable: ds.depth_bounds_test_enable == vk::TRUE,
        }),
        depth_bias: raster.map(|r| DepthBiasFacts {
            enable: r.depth_bias_enable == vk::TRUE,
            represented: depth.bias.representation.is_some(),
        }),
        static_viewports: depth.viewports.len(),
        compare_op_variants: context.compare_op_variants,
        bias_with_representation: context.bias_with_representation,
        user_clamp_range: clamp_range.is_some(),
    }
    .decide();
    depth.injected |= static_state.made_dynamic;
    Plan {
        dynamic_states: dynamic_states(app_states, &static_state),
        depth,
        flip_reason: None,
        static_state,
        fragment: None,
        input_fragment: None,
        vertex: None,
        rewritten_stage: None,
        baked_vertex: None,
        libraries: None,
        input_libraries: None,
        promotion: None,
        variants: Variants::default(),
        variant_bias: false,
    }
}

/// The dynamic state list a pipeline is created with: the application's, and the states revz
/// makes dynamic (`None`: the application's list as it is).
fn dynamic_states(
    app_states: &[vk::DynamicState],
    static_state: &StaticStatePlan,
) -> Option<Vec<vk::DynamicState>> {
    (!static_state.made_dynamic.is_empty()).then(|| {
        let mut states = app_states.to_vec();
        states.extend(static_state.added_dynamic_states());
        states
    })
}

impl Plan {
    /// The reversed variant holds the flipped bias
    /// ([`crate::policy::pipelines::BiasVariantFacts::variant_holds_bias`]): the bias is
    /// made dynamic no more, in the pipeline and its variants.
    pub(super) fn keep_bias_static(&mut self, info: &vk::GraphicsPipelineCreateInfo<'_>) {
        self.variant_bias = true;
        self.static_state.made_dynamic = self.static_state.made_dynamic.without(States::BIAS);
        self.depth.injected = self.depth.injected.without(States::BIAS);
        // SAFETY: null or valid (the application's contract; `plan` read it already).
        let dynamic = unsafe { info.p_dynamic_state.as_ref() };
        // SAFETY: `dynamicStateCount` entries.
        let app_states = dynamic.map_or(&[][..], |d| unsafe {
            slice(d.p_dynamic_states, d.dynamic_state_count)
        });
        self.dynamic_states = dynamic_states(app_states, &self.static_state);
    }
}

/// What a create info needs from the device's tracked objects to be planned.
pub(super) fn context(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> PlanContext {
    let subsets = own_subsets(info);
    let attachment = if info.render_pass != vk::RenderPass::null() {
        DepthAttachmentFacts::RenderPass {
            subpass_depth: state
                .objects
                .render_passes
                .get(&info.render_pass)
                .and_then(|pass| {
                    pass.subpass_depth
                        .get(info.subpass as usize)
                        .copied()
                        .flatten()
                })
                .is_some(),
        }
    } else if subsets.contains(Subsets::FRAGMENT_OUTPUT_INTERFACE) {
        DepthAttachmentFacts::Rendering {
            // SAFETY: a valid pNext chain (the application's contract).
            depth_format: unsafe {
                chain::find::<vk::PipelineRenderingCreateInfo<'_>>(info.p_next)
            }
            .map(|rendering| rendering.depth_attachment_format),
        }
    } else {
        DepthAttachmentFacts::NoFragmentOutput
    };
    let has_depth_attachment = has_depth_attachment(attachment);
    PlanContext {
        has_depth_attachment,
        subsets,
        compare_op_variants: state.policy.compare_op_variants,
        bias_with_representation: state.commands.set_depth_bias2.is_some(),
    }
}

/// Whether a pipeline's geometry or tessellation stage `flag` only carries the positions it
/// receives on (`DeviceObjects::position_passthrough`, or its inline code scanned now): a
/// geometry stage passing them through, a tessellation control stage copying them, an
/// evaluation stage interpolating them.
fn stage_carries_positions_on(
    state: &DeviceState,
    stages: &[vk::PipelineShaderStageCreateInfo<'_>],
    flag: vk::ShaderStageFlags,
) -> bool {
    use crate::shader::tessellation_positions as tessellation;
    let Some(stage) = stages.iter().find(|s| s.stage == flag) else {
        return false;
    };
    let scan: fn(&[u32]) -> bool = match flag {
        vk::ShaderStageFlags::GEOMETRY => crate::shader::position_store::passes_position_through,
        vk::ShaderStageFlags::TESSELLATION_CONTROL => {
            tessellation::control_passes_positions_through
        }
        vk::ShaderStageFlags::TESSELLATION_EVALUATION => {
            tessellation::evaluation_interpolates_positions
        }
        _ => return false,
    };
    module_fact(stage, &state.objects.position_passthrough, scan)
}

/// What `scan` answers of `stage`'s code: for a module, as it was recorded at the module's
/// creation (`recorded`; `false` where it was not); for inline code, scanned now.
fn module_fact(
    stage: &vk::PipelineShaderStageCreateInfo<'_>,
    recorded: &crate::objects::Table<vk::ShaderModule, bool>,
    scan: fn(&[u32]) -> bool,
) -> bool {
    if stage.module != vk::ShaderModule::null() {
        return recorded.get(&stage.module).unwrap_or(false);
    }
    inline_code(stage).is_some_and(scan)
}

/// Whether the positions the last pre-rasterization stage `last` reads from the stage before
/// it have w = 1 exactly: for a geometry stage, its tessellation evaluation or vertex stage
/// stores `Position` with w = 1 (`DeviceObjects::position_w_one`, or its inline code scanned
/// now), or its evaluation stage interpolates the patch's positions (an affine combination of
/// points with w = 1 has w = 1) as the next case holds; for a tessellation evaluation stage,
/// its control stage copies the vertex stage's positions as they are
/// (`DeviceObjects::position_passthrough`) and the vertex stage stores them with w = 1.
fn prior_stage_w_one(
    state: &DeviceState,
    stages: &[vk::PipelineShaderStageCreateInfo<'_>],
    last: Option<vertex_stage::LastStage>,
) -> bool {
    let find = |flag| stages.iter().find(|s| s.stage == flag);
    let stores_w_one = |stage: Option<&vk::PipelineShaderStageCreateInfo<'_>>| {
        stage.is_some_and(|stage| {
            module_fact(
                stage,
                &state.objects.position_w_one,
                crate::shader::position_store::stores_position_w_one,
            )
        })
    };
    // The patch's positions reach the evaluation stage with w = 1.
    let patch_w_one = || {
        stage_carries_positions_on(state, stages, vk::ShaderStageFlags::TESSELLATION_CONTROL)
            && stores_w_one(find(vk::ShaderStageFlags::VERTEX))
    };
    match last {
        Some(vertex_stage::LastStage::Geometry) => {
            match find(vk::ShaderStageFlags::TESSELLATION_EVALUATION) {
                Some(evaluation) => {
                    stores_w_one(Some(evaluation))
                        || (stage_carries_positions_on(
                            state,
                            stages,
                            vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                        ) && patch_w_one())
                }
                None => stores_w_one(find(vk::ShaderStageFlags::VERTEX)),
            }
        }
        Some(vertex_stage::LastStage::TessellationEvaluation) => patch_w_one(),
        _ => false,
    }
}

/// Whether `info`'s pipeline clamps depth without clipping it: its rasterization state's
/// `depthClampEnable` and its `VkPipelineRasterizationDepthClipStateCreateInfoEXT`, or dynamic
/// state (`VK_DYNAMIC_STATE_DEPTH_CLAMP_ENABLE_EXT`, or `..._DEPTH_CLIP_ENABLE_EXT` with the
/// clamp on).
///
/// # Safety
/// `info` is the application's valid create info.
pub(super) unsafe fn depth_clamp_of(
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> crate::policy::vertex_stage::DepthClamp {
    use crate::policy::vertex_stage::DepthClamp;
    // SAFETY: null or valid (the caller's contract).
    let dynamic = unsafe { info.p_dynamic_state.as_ref() }.map_or(&[][..], |d| unsafe {
        // SAFETY: `dynamicStateCount` entries.
        slice(d.p_dynamic_states, d.dynamic_state_count)
    });
    if dynamic.contains(&vk::DynamicState::DEPTH_CLAMP_ENABLE_EXT) {
        return DepthClamp::Dynamic;
    }
    // SAFETY: null or valid (the caller's contract).
    match unsafe { info.p_rasterization_state.as_ref() } {
        Some(r) if r.depth_clamp_enable == vk::TRUE => {
            // SAFETY: null or valid (the caller's contract).
            match unsafe { depth_clip_of(r, dynamic) } {
                DepthClip::Dynamic => DepthClamp::Dynamic,
                DepthClip::Static(true) => DepthClamp::OnClipped,
                DepthClip::Static(false) | DepthClip::Implied => DepthClamp::On,
            }
        }
        _ => DepthClamp::Off,
    }
}

/// How a rasterization state clips depth (`VK_EXT_depth_clip_enable`), with the pipeline's
/// `dynamic` states.
///
/// # Safety
/// `raster` is the application's valid rasterization state.
pub(super) unsafe fn depth_clip_of(
    raster: &vk::PipelineRasterizationStateCreateInfo<'_>,
    dynamic: &[vk::DynamicState],
) -> DepthClip {
    if dynamic.contains(&vk::DynamicState::DEPTH_CLIP_ENABLE_EXT) {
        return DepthClip::Dynamic;
    }
    // SAFETY: a valid pNext chain (the caller's contract).
    match unsafe {
        chain::find::<vk::PipelineRasterizationDepthClipStateCreateInfoEXT<'_>>(raster.p_next)
    } {
        Some(clip) => DepthClip::Static(clip.depth_clip_enable == vk::TRUE),
        None => DepthClip::Implied,
    }
}
