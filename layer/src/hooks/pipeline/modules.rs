//! Shader modules and pipeline layouts: the analyses and rewrites made once per module at
//! creation (fragment depth, `Position` store, derived range) and the carrier reserved in each
//! pipeline layout.

#![allow(clippy::wildcard_imports)]

use super::*;

/// The fragment stage of a create info (its index) and its rewrite for reversed attachments
/// when it computes with depth: its module's, made at module creation, or one of SPIR-V
/// chained inline into the stage.
pub(super) fn fragment_stage_rewrite(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> Option<(usize, ReversedFragment)> {
    // SAFETY: `stageCount` stages (the application's contract).
    let stages = unsafe { slice(info.p_stages, info.stage_count) };
    let (index, stage) = stages
        .iter()
        .enumerate()
        .find(|(_, stage)| stage.stage == vk::ShaderStageFlags::FRAGMENT)?;
    let rewrite = if stage.module != vk::ShaderModule::null() {
        state.objects.fragment_depth_modules.get(&stage.module)?
    } else {
        let words = inline_code(stage)?;
        state.objects.fragment_codes.get_or_make(words, || {
            rewrite_fragment_module(vk::ShaderModule::null(), words)
        })?
    };
    Some((index, rewrite))
}

/// The fragment stage of a pipeline that may read depth through input attachments, and whose
/// code declares input attachments: its index, its code and which input attachments read
/// depth. Those are, for a render pass, its subpass's input attachments that read depth
/// (`RenderPassInfo::subpass_depth_inputs`); with dynamic rendering
/// (`VK_KHR_dynamic_rendering_local_read`, where input attachments read the rendering's own
/// attachments), the index its `VkRenderingInputAttachmentIndexInfo` maps the depth
/// attachment to, or the undecorated inputs where it maps it to none
/// ([`rendering_depth_inputs`]). `None` where the policy converts no
/// input reads or no input attachment reads depth.
pub(super) fn depth_input_stage(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> Option<DepthInputStage> {
    if !state.policy.converts_input_reads() {
        return None;
    }
    let inputs = if info.render_pass == vk::RenderPass::null() {
        rendering_depth_inputs(info)?
    } else {
        let pass = state.objects.render_passes.get(&info.render_pass)?;
        let indices: Vec<u32> = pass
            .subpass_depth_inputs
            .get(info.subpass as usize)?
            .iter()
            .map(|input| input.index)
            .collect();
        if indices.is_empty() {
            return None;
        }
        DepthInputs::Indices(indices)
    };
    // SAFETY: `stageCount` stages (the application's contract).
    let stages = unsafe { slice(info.p_stages, info.stage_count) };
    let (index, stage) = stages
        .iter()
        .enumerate()
        .find(|(_, stage)| stage.stage == vk::ShaderStageFlags::FRAGMENT)?;
    let code: Arc<[u32]> = if stage.module != vk::ShaderModule::null() {
        state.objects.input_modules.get(&stage.module)?
    } else {
        let words = inline_code(stage)?;
        if !crate::shader::input_depth::reads_input_attachments(words) {
            return None;
        }
        Arc::from(words)
    };
    Some(DepthInputStage {
        index,
        code,
        inputs,
    })
}

/// Dynamic rendering: the input attachments that read the rendering's depth attachment, as
/// the pipeline's `VkRenderingInputAttachmentIndexInfo` maps it: an index, none
/// (`VK_ATTACHMENT_UNUSED`), or, where the structure or its depth index is absent, the inputs
/// without an `InputAttachmentIndex` decoration (the spec's default). The command buffer's
/// mapping (`vkCmdSetRenderingInputAttachmentIndices`) must match the bound pipeline's, so
/// the pipeline's tells what its draws read. Whether the rendering has a depth attachment is
/// not asked here: a fragment shader library need not name the format (only a fragment output
/// library does), and a shader reading an input no attachment maps reads nothing valid; the
/// reversed variants that convert the reads are made only where the pipeline renders depth
/// (`Variants::reversed`).
fn rendering_depth_inputs(info: &vk::GraphicsPipelineCreateInfo<'_>) -> Option<DepthInputs> {
    // SAFETY: a valid chain (the application's contract).
    let mapping =
        unsafe { chain::find::<vk::RenderingInputAttachmentIndexInfoKHR<'_>>(info.p_next) };
    // SAFETY: null or a valid index (the application's contract).
    match mapping.and_then(|m| unsafe { m.p_depth_input_attachment_index.as_ref() }) {
        None => Some(DepthInputs::Undecorated),
        Some(&vk::ATTACHMENT_UNUSED) => None,
        Some(&index) => Some(DepthInputs::Indices(vec![index])),
    }
}

/// A fragment stage that may read depth through input attachments
/// ([`depth_input_stage`]).
pub(super) struct DepthInputStage {
    pub index: usize,
    pub code: Arc<[u32]>,
    /// Its input attachments that read depth.
    pub inputs: DepthInputs,
}

impl DepthInputStage {
    /// `code` with the depth it reads through input attachments converted (`None`: it reads
    /// none). One that cannot be rewritten is logged once.
    pub fn convert(&self, code: &[u32]) -> Option<Arc<[u32]>> {
        match crate::shader::input_depth::reverse_input_depth(code, &self.inputs) {
            Ok(converted) => converted.map(Arc::from),
            Err(reason) => {
                static REFUSED: crate::logging::LogOnce = crate::logging::LogOnce::new();
                REFUSED.log(|| {
                    log::warn!(
                        "a fragment shader reads depth through an input attachment in a way \
                         revz cannot rewrite ({reason}): it reads reversed depth where the \
                         attachment is reversed"
                    )
                });
                None
            }
        }
    }
}

/// A fragment module rewritten for reversed attachments, `None` when it does not compute
/// with depth. One that cannot be rewritten is logged (once per module).
pub(super) fn rewrite_fragment_module(
    module: vk::ShaderModule,
    words: &[u32],
) -> Option<ReversedFragment> {
    let rewrite = fragment_depth::reverse_fragment_depth(words).transpose()?;
    let first = module != vk::ShaderModule::null() || first_inline_report(Report::Rewrite, words);
    if let (Err(reason), true) = (&rewrite, first) {
        log::warn!(
            "shader module {module:?} computes with depth in a way revz cannot rewrite \
             ({reason}): its draws into reversed attachments keep standard depth"
        );
    }
    Some(rewrite.map(Into::into))
}

/// The shader analysis of a module (at its creation, or of SPIR-V chained into a pipeline
/// stage): a module naga cannot read is logged once; its projection is then not read on the
/// CPU, and its stage gets the deriving rewrite (which needs no naga).
pub(super) fn analyze_vertex_module(module: vk::ShaderModule, words: &[u32]) -> ModuleAnalysis {
    // naga reads no tessellation or geometry stage: such a module's projection is not read on
    // the CPU, and its stage gets the deriving rewrite (no entry point analyzed).
    if !crate::shader::scan::declares_vertex_entry_point(words) {
        return Ok(Vec::new());
    }
    let analysis = analysis::analyze_vertex_entry_points(words);
    let first = module != vk::ShaderModule::null() || first_inline_report(Report::Analysis, words);
    if let (Err(reason), true) = (&analysis, first) {
        log::warn!(
            "shader module {module:?} cannot be analyzed ({reason}): no projection is read \
             from its push constants on the CPU; its stage derives its range where it can, \
             and its draws into reversed attachments take the flip path where it cannot"
        );
    }
    analysis
}

/// The analysis and `Position` rewrite of vertex stage code (a module's, `module`, or SPIR-V
/// chained into a stage, `module` null), made once per distinct code
/// (`DeviceObjects::vertex_codes`; what is logged about the code names the first module).
pub(crate) fn vertex_code(
    state: &DeviceState,
    module: vk::ShaderModule,
    words: &[u32],
) -> VertexCode {
    state
        .objects
        .vertex_codes
        .get_or_make(words, || make_vertex_code(state, module, words))
}

/// What is made of vertex stage code: its analysis and its `Position` rewrite.
type VertexCode = (Arc<ModuleAnalysis>, Option<RewrittenVertex>);

/// [`vertex_code`], with the words as the cache keeps them.
fn vertex_code_kept(
    state: &DeviceState,
    module: vk::ShaderModule,
    words: &[u32],
) -> (Arc<[u32]>, VertexCode) {
    state
        .objects
        .vertex_codes
        .get_or_make_kept(words, || make_vertex_code(state, module, words))
}

fn make_vertex_code(state: &DeviceState, module: vk::ShaderModule, words: &[u32]) -> VertexCode {
    let analysis = analyze_vertex_module(module, words);
    let rewrite = position_store_of(state, &analysis, words);
    (Arc::new(analysis), rewrite)
}

/// The deriving `Position` rewrite of last pre-rasterization stage code with the carrier baked
/// in (complementary depth: `crate::shader::position_store::CarrierRead::Baked`), made once
/// per distinct code (`DeviceObjects::baked_codes`): the stage of the reversed variants of a
/// pipeline whose layout has no room for the pushed carrier, and of a shader object's variant.
/// `Ok(None)` where the code stores no `Position`.
pub(crate) fn baked_code(
    state: &DeviceState,
    words: &[u32],
) -> Result<Option<BakedStage>, &'static str> {
    state.objects.baked_codes.get_or_make(words, || {
        let selector = crate::command_state::derived_selector(
            RewriteTarget::Complementary,
            DepthConvention::ZeroToOne,
        );
        let rewrite = position_store::derive_position_store_reading(
            words,
            position_store::CarrierRead::Baked(selector),
        )
        .map_err(|position_store::Unsupported(reason)| reason)?;
        Ok(rewrite.map(|rewrite| BakedStage {
            code: rewrite.code.into(),
            source: rewrite.source,
            assumes_input_unit_w: rewrite.assumes_input_unit_w,
        }))
    })
}

/// The SPIR-V chained into a stage instead of a module (`VkShaderModuleCreateInfo` in its
/// `pNext`), if any.
pub(super) fn inline_code<'a>(
    stage: &'a vk::PipelineShaderStageCreateInfo<'_>,
) -> Option<&'a [u32]> {
    // SAFETY: a valid pNext chain (the application's contract).
    let inline = unsafe { chain::find::<vk::ShaderModuleCreateInfo<'_>>(stage.p_next) }?;
    // SAFETY: `codeSize` bytes of code.
    Some(unsafe { slice(inline.p_code, (inline.code_size / 4) as u32) })
}

/// The `Position` rewrite of a vertex module the policy chose
/// ([`vertex_stage::module_position_store`]): the carrier store where an entry point has its
/// projection in push constants, else the deriving one (`None` without the precise path, or
/// for a module that could not be analyzed: their draws take the flip path anyway).
pub(super) fn position_store_of(
    state: &DeviceState,
    analysis: &ModuleAnalysis,
    words: &[u32],
) -> Option<RewrittenVertex> {
    let (offset, store) = vertex_stage::module_position_store(
        state.policy.carrier_offset,
        analysis
            .as_ref()
            .ok()
            .map(|entries| entries.iter().map(|(_, analysis)| analysis)),
    )?;
    let no_position = position_store::Unsupported("no Position output");
    let rewrite =
        match store {
            PositionStore::Carrier => position_store::rewrite_position_store(words, offset)
                .and_then(|code| {
                    let code = code.ok_or(no_position)?;
                    Ok(VertexRewrite {
                        code: code.into(),
                        derived: None,
                        push_slot: None,
                        needs_input_unit_w: false,
                    })
                }),
            // No projection in push constants: the stage derives its range from the matrix it
            // loads.
            PositionStore::Deriving => position_store::derive_position_store(words, offset)
                .and_then(|rewrite| {
                    let rewrite = rewrite.ok_or(no_position)?;
                    Ok(VertexRewrite {
                        code: rewrite.code.into(),
                        derived: Some(rewrite.source),
                        push_slot: rewrite.push_slot,
                        needs_input_unit_w: rewrite.assumes_input_unit_w,
                    })
                }),
        };
    Some(rewrite)
}

pub unsafe extern "system" fn create_shader_module(
    device: vk::Device,
    p_create_info: *const vk::ShaderModuleCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_module: *mut vk::ShaderModule,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: calling down with the application's arguments.
    let result = unsafe {
        (state.next.fp_v1_0().create_shader_module)(device, p_create_info, p_allocator, p_module)
    };
    if result == vk::Result::SUCCESS {
        super::super::record(&CREATE_SHADER_MODULE, || {
            // SAFETY: valid on success; `codeSize` bytes of code.
            let info = unsafe { &*p_create_info };
            // SAFETY: as above.
            let words = unsafe { slice(info.p_code, (info.code_size / 4) as u32) };
            // SAFETY: valid on success.
            let module = unsafe { *p_module };
            // One pass over the words: not worth keeping the code for.
            if vertex_stage::analyses_fragment_module(state.policy.is_active()) {
                if let Some(rewrite) = rewrite_fragment_module(module, words) {
                    state.objects.fragment_depth_modules.insert(module, rewrite);
                }
            }
            if state.policy.converts_input_reads()
                && crate::shader::input_depth::reads_input_attachments(words)
            {
                state.objects.input_modules.insert(module, Arc::from(words));
            }
            // Only the stages that can store the rasterized Position are analyzed and
            // rewritten (fragment and compute modules with push constants are not parsed).
            // The naga analysis and the rewrite are made once per distinct code
            // (`DeviceObjects::vertex_codes`): a module of code seen before is looked up.
            if vertex_stage::analyses_vertex_module(state.policy.rewrite().is_some(), || {
                crate::shader::scan::declares_position_stage_entry_point(words)
            }) {
                let (kept, (analysis, rewrite)) = vertex_code_kept(&state, module, words);
                state.objects.vertex_words.insert(module, kept);
                if let Some(rewrite) = rewrite {
                    state.objects.position_stores.insert(module, rewrite);
                }
                // Only where a later stage may read this one's Position.
                if !state.policy.carrier_later_stages.is_empty() {
                    state
                        .objects
                        .position_w_one
                        .insert(module, position_store::stores_position_w_one(words));
                }
                if state
                    .policy
                    .carrier_later_stages
                    .contains(vk::ShaderStageFlags::GEOMETRY)
                    && crate::shader::scan::declares_geometry_entry_point(words)
                {
                    state
                        .objects
                        .position_passthrough
                        .insert(module, position_store::passes_position_through(words));
                }
                state.objects.vertex_modules.insert(module, analysis);
            }
            if state.policy.rewrite().is_some()
                && state
                    .policy
                    .carrier_later_stages
                    .contains(vk::ShaderStageFlags::TESSELLATION_EVALUATION)
                && crate::shader::scan::declares_tessellation_entry_point(words)
            {
                use crate::shader::tessellation_positions as tessellation;
                // One answer per module: its entry points are of one stage, or it answers no.
                let carries = tessellation::control_passes_positions_through(words)
                    || tessellation::evaluation_interpolates_positions(words);
                state.objects.position_passthrough.insert(module, carries);
            }
        });
    }
    result
}

destroy_hook!(
    destroy_shader_module,
    DESTROY_SHADER_MODULE,
    vk::ShaderModule,
    fragment_depth_modules
        | vertex_modules
        | position_stores
        | position_w_one
        | position_passthrough
        | vertex_words
        | input_modules,
    destroy_shader_module
);

pub unsafe extern "system" fn create_pipeline_layout(
    device: vk::Device,
    p_create_info: *const vk::PipelineLayoutCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_layout: *mut vk::PipelineLayout,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // The carrier's bytes, reserved in every layout where they fit (`crate::precise`).
    let reserved = guarded(
        &CREATE_PIPELINE_LAYOUT,
        || {
            let offset = state.policy.carrier_offset?;
            // SAFETY: a valid create info (the application's contract).
            let info = unsafe { &*p_create_info };
            // SAFETY: `pushConstantRangeCount` ranges.
            let ranges =
                unsafe { slice(info.p_push_constant_ranges, info.push_constant_range_count) };
            match precise::reserve_carrier(ranges, offset, state.policy.carrier_later_stages) {
                Ok(reserved) => Some(reserved),
                Err(reason) => {
                    static NO_ROOM: AtomicBool = AtomicBool::new(false);
                    if !NO_ROOM.swap(true, Ordering::Relaxed) {
                        log::info!(
                            "a pipeline layout has no room for revz's 16 bytes of push \
                             constants at offset {offset} ({reason}): its pipelines' stages \
                             fit their range from the matrix they load, with the carrier baked \
                             into their reversed variants (where that fails, their draws into \
                             reversed attachments take the flip path)"
                        );
                    }
                    None
                }
            }
        },
        || None,
    );
    let with_carrier = reserved.as_ref().map(|(ranges, _)| {
        // SAFETY: as above.
        let info = unsafe { &*p_create_info };
        vk::PipelineLayoutCreateInfo {
            push_constant_range_count: ranges.len() as u32,
            p_push_constant_ranges: ranges.as_ptr(),
            ..*info
        }
    });
    let p_down = with_carrier
        .as_ref()
        .map_or(p_create_info, |info| info as *const _);
    // SAFETY: calling down with the application's arguments (its push-constant ranges with
    // revz's carrier reserved).
    let result = unsafe {
        (state.next.fp_v1_0().create_pipeline_layout)(device, p_down, p_allocator, p_layout)
    };
    if result == vk::Result::SUCCESS {
        super::super::record(&CREATE_PIPELINE_LAYOUT, || {
            // SAFETY: valid on success.
            let info = unsafe { &*p_create_info };
            // SAFETY: `pushConstantRangeCount` ranges.
            let ranges =
                unsafe { slice(info.p_push_constant_ranges, info.push_constant_range_count) };
            // SAFETY: valid on success.
            let layout = unsafe { *p_layout };
            state.objects.pipeline_layouts.insert(layout, ranges.into());
            if let Some((reserved_ranges, carrier)) = &reserved {
                state.objects.layout_carriers.insert(layout, *carrier);
                if let Some(pusher) = push_layout(&state, device, reserved_ranges) {
                    state.objects.layout_pushers.insert(layout, pusher);
                }
            }
        });
    }
    result
}

destroy_hook!(
    destroy_pipeline_layout,
    DESTROY_PIPELINE_LAYOUT,
    vk::PipelineLayout,
    pipeline_layouts | layout_carriers | layout_pushers,
    destroy_pipeline_layout
);

/// revz's own pipeline layout with `ranges` (and no descriptor sets), made once per set of
/// ranges (`crate::objects::DeviceObjects::layout_pushers`).
pub(crate) fn push_layout(
    state: &DeviceState,
    device: vk::Device,
    ranges: &[vk::PushConstantRange],
) -> Option<vk::PipelineLayout> {
    let key: Vec<(u32, u32, u32)> = ranges
        .iter()
        .map(|r| (r.stage_flags.as_raw(), r.offset, r.size))
        .collect();
    let mut layouts = state
        .objects
        .push_layouts
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&(_, layout)) = layouts.iter().find(|(k, _)| *k == key) {
        return Some(layout);
    }
    let info = vk::PipelineLayoutCreateInfo::default().push_constant_ranges(ranges);
    let mut layout = vk::PipelineLayout::null();
    // SAFETY: a create info of revz's own ranges; revz's object, so no allocator.
    let result = unsafe {
        (state.next.fp_v1_0().create_pipeline_layout)(device, &info, std::ptr::null(), &mut layout)
    };
    (result == vk::Result::SUCCESS).then(|| {
        layouts.push((key, layout));
        layout
    })
}
