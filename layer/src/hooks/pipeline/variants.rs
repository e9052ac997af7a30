//! The pipelines revz makes for an application's pipeline: reversed and promoted variants
//! (one create info each, batch of one), the libraries they link, and the rewritten vertex
//! stage's module.

#![allow(clippy::wildcard_imports)]

use super::*;

/// The libraries a create info links, with each that has a variant of `kind` replaced by it
/// (for draws into reversed or promoted attachments, or beside reversed input attachments):
/// that variant of a link links the libraries' variants. `None` when none has one.
pub(super) fn library_variants(
    state: &DeviceState,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    kind: VariantKind,
) -> Option<Vec<vk::Pipeline>> {
    // SAFETY: a valid pNext chain (the application's contract).
    let links = unsafe { chain::find::<vk::PipelineLibraryCreateInfoKHR<'_>>(info.p_next) }?;
    // SAFETY: `libraryCount` pipelines.
    let libraries = unsafe { slice(links.p_libraries, links.library_count) };
    let variants: Vec<vk::Pipeline> = libraries
        .iter()
        .map(|library| {
            let depth = state.objects.pipelines.get(library);
            depth
                .and_then(|depth| depth.variant_for(kind.reversed, kind.promoted, kind.inputs))
                .unwrap_or(*library)
        })
        .collect();
    (variants.as_slice() != libraries).then_some(variants)
}

/// Creates the reversed variant of a pipeline: its create info (with the dynamic states revz
/// added) with the static depth compare op flipped (and its static depth bias, where the plan
/// keeps it static), the fragment stage rewritten, the stage with the carrier baked in where
/// the layout has no room for it, and the
/// linked libraries replaced by their variants, as the plan says. Not a derivative (the base
/// index of the application's batch means nothing in a batch of one), without early return (a
/// batch of one), and with the application's `FAIL_ON_PIPELINE_COMPILE_REQUIRED`: a variant
/// not in the cache is then [`Variant::CompileRequired`]. [`Variant::Missing`] when it cannot
/// be made: the pipeline's draws into reversed attachments then keep its compare op and
/// fragment shader (logged once).
pub(super) fn create_variant(
    state: &DeviceState,
    device: vk::Device,
    cache: vk::PipelineCache,
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    dynamic: &Option<vk::PipelineDynamicStateCreateInfo<'_>>,
    plan: &Plan,
    kind: VariantKind,
) -> Variant {
    static FAILED: crate::logging::LogOnce = crate::logging::LogOnce::new();
    let failed = |why: &dyn std::fmt::Display| {
        FAILED.log(|| {
            log::warn!(
                "a {kind:?} variant of a pipeline could not be created ({why}): its draws \
                 into reversed attachments keep its compare op, depth bias and fragment \
                 shader, and into promoted ones its attachment formats"
            )
        });
        Variant::Missing
    };
    let promotion = plan.promotion.as_ref().filter(|_| kind.promoted);
    let flipped = if plan.variants.compare_op && kind.reversed {
        // SAFETY: non-null (the plan read it) and valid (the application's contract).
        let Some(depth_stencil) = (unsafe { info.p_depth_stencil_state.as_ref() }) else {
            return failed(&"no depth-stencil state");
        };
        Some(vk::PipelineDepthStencilStateCreateInfo {
            depth_compare_op: flip_compare_op(depth_stencil.depth_compare_op),
            ..*depth_stencil
        })
    } else {
        None
    };
    let biased = if plan.variant_bias && kind.reversed {
        // SAFETY: non-null (the plan read the bias from it) and valid (the application's
        // contract).
        let Some(raster) = (unsafe { info.p_rasterization_state.as_ref() }) else {
            return failed(&"no rasterization state");
        };
        // Negated as a dynamic one is; its pNext chain (a bias representation) is the
        // application's.
        let flipped = crate::conv::DepthBias {
            constant: raster.depth_bias_constant_factor,
            clamp: raster.depth_bias_clamp,
            slope: raster.depth_bias_slope_factor,
            representation: None,
        }
        .flipped();
        Some(vk::PipelineRasterizationStateCreateInfo {
            depth_bias_constant_factor: flipped.constant,
            depth_bias_clamp: flipped.clamp,
            depth_bias_slope_factor: flipped.slope,
            ..*raster
        })
    } else {
        None
    };
    // The chain, spliced where it must change; the splices live until the call returns.
    let mut chain = chain::Spliced::of(info.p_next);
    // Flags given in a `VkPipelineCreateFlags2CreateInfoKHR` replace `flags`: a copy with
    // the same flags cleared takes its place.
    let cleared2 = vk::PipelineCreateFlags2KHR::DERIVATIVE
        | vk::PipelineCreateFlags2KHR::EARLY_RETURN_ON_FAILURE;
    // SAFETY: a valid pNext chain (the application's contract) that outlives the call below.
    let flags2 = unsafe {
        chain.edit(|flags2: &vk::PipelineCreateFlags2CreateInfoKHR<'_>| {
            flags2
                .flags
                .intersects(cleared2)
                .then(|| flags2.flags(flags2.flags & !cleared2))
        })
    };
    if flags2.is_err() {
        return failed(&"an unknown structure precedes its flags2");
    }
    // An input variant links the libraries' input variants (the reversed variants convert
    // input reads too).
    let inputs_only = kind.inputs && !kind.reversed;
    let libraries = match (promotion, kind.reversed) {
        (Some(promotion), _) if inputs_only => &promotion.input_libraries,
        (Some(promotion), false) => &promotion.libraries,
        (Some(promotion), true) => &promotion.reversed_libraries,
        (None, _) if inputs_only => &plan.input_libraries,
        (None, _) => &plan.libraries,
    };
    if let Some(libraries) = libraries {
        // SAFETY: as above; the libraries outlive the call too.
        let links = unsafe {
            chain.edit(|links: &vk::PipelineLibraryCreateInfoKHR<'_>| {
                Some(links.libraries(libraries))
            })
        };
        if links.is_err() {
            return failed(&"an unknown structure precedes its libraries");
        }
    }
    if promotion.is_some_and(|p| p.rendering) {
        let float = crate::policy::promoted_attachment_format;
        // SAFETY: as above.
        let rendering = unsafe {
            chain.edit(|rendering: &vk::PipelineRenderingCreateInfo<'_>| {
                Some(vk::PipelineRenderingCreateInfo {
                    depth_attachment_format: float(rendering.depth_attachment_format),
                    stencil_attachment_format: float(rendering.stencil_attachment_format),
                    ..*rendering
                })
            })
        };
        if rendering.is_err() {
            return failed(&"an unknown structure precedes its rendering formats");
        }
    }
    // SAFETY: `stageCount` stages (the application's contract).
    let mut stages = unsafe { slice(info.p_stages, info.stage_count) }.to_vec();
    let fragment = if kind.reversed {
        plan.fragment.as_ref()
    } else if kind.inputs {
        plan.input_fragment.as_ref()
    } else {
        None
    };
    let rewritten = match fragment {
        Some((index, code)) => {
            let Some(rewritten) = rewritten_stage(state, device, &mut stages[*index], code) else {
                return failed(&"its rewritten fragment stage could not be made");
            };
            Some(rewritten)
        }
        None => None,
    };
    // A layout without room for the carrier: the reversed variants' last pre-rasterization
    // stage has it baked in (`PipelineDepth::baked`).
    let baked = match plan.baked_vertex.as_ref().filter(|_| kind.reversed) {
        Some((index, code)) => {
            let Some(baked) = rewritten_stage(state, device, &mut stages[*index], code) else {
                if let Some(RewrittenStage { module, .. }) = rewritten {
                    // SAFETY: revz's own module, in no pipeline yet.
                    unsafe {
                        (state.next.fp_v1_0().destroy_shader_module)(
                            device,
                            module,
                            std::ptr::null(),
                        )
                    };
                }
                return failed(&"its stage with the carrier baked in could not be made");
            };
            Some(baked)
        }
        None => None,
    };
    let variant_info = vk::GraphicsPipelineCreateInfo {
        p_next: chain.head(),
        flags: info.flags
            & !(vk::PipelineCreateFlags::DERIVATIVE
                | vk::PipelineCreateFlags::EARLY_RETURN_ON_FAILURE),
        base_pipeline_handle: vk::Pipeline::null(),
        base_pipeline_index: -1,
        p_stages: stages.as_ptr(),
        p_depth_stencil_state: flipped
            .as_ref()
            .map_or(info.p_depth_stencil_state, |flipped| flipped),
        p_rasterization_state: biased
            .as_ref()
            .map_or(info.p_rasterization_state, |biased| biased),
        p_dynamic_state: dynamic.as_ref().map_or(info.p_dynamic_state, |d| d),
        render_pass: promotion
            .and_then(|p| p.render_pass)
            .unwrap_or(info.render_pass),
        ..*info
    };
    let mut variant = vk::Pipeline::null();
    // SAFETY: the application's create info with the chain, stages, depth state and dynamic
    // list replaced by copies that live until the call returns; revz's own object, so no
    // allocator.
    let result = unsafe {
        (state.next.fp_v1_0().create_graphics_pipelines)(
            device,
            cache,
            1,
            &variant_info,
            std::ptr::null(),
            &mut variant,
        )
    };
    for RewrittenStage { module, .. } in rewritten.into_iter().chain(baked) {
        // SAFETY: revz's own module; a pipeline no longer needs its modules once created.
        unsafe { (state.next.fp_v1_0().destroy_shader_module)(device, module, std::ptr::null()) };
    }
    match result {
        vk::Result::SUCCESS if variant != vk::Pipeline::null() => Variant::Made(variant),
        vk::Result::PIPELINE_COMPILE_REQUIRED => Variant::CompileRequired,
        _ => failed(&format_args!("{result:?}")),
    }
}

/// Points a copy of a fragment stage at a module of `code`, created through the next layer.
/// A stage whose SPIR-V is chained inline drops that structure from its copy's chain. `None`
/// when the module cannot be created or the inline structure cannot be spliced out.
pub(super) fn rewritten_stage(
    state: &DeviceState,
    device: vk::Device,
    stage: &mut vk::PipelineShaderStageCreateInfo<'_>,
    code: &[u32],
) -> Option<RewrittenStage> {
    let chain = if stage.module == vk::ShaderModule::null() {
        // SAFETY: a valid pNext chain (the application's contract) that outlives the
        // variant's creation.
        let spliced =
            unsafe { chain::splice::<vk::ShaderModuleCreateInfo<'_>>(stage.p_next, None) }?;
        stage.p_next = spliced.head();
        Some(spliced)
    } else {
        None
    };
    let create = vk::ShaderModuleCreateInfo::default().code(code);
    let mut module = vk::ShaderModule::null();
    // SAFETY: a create info of revz's words; revz's own object, so no allocator.
    let result = unsafe {
        (state.next.fp_v1_0().create_shader_module)(device, &create, std::ptr::null(), &mut module)
    };
    stage.module = module;
    (result == vk::Result::SUCCESS).then_some(RewrittenStage {
        module,
        _chain: chain,
    })
}
