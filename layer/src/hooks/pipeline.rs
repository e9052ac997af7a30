//! Graphics pipeline creation: the depth-related state revz must set per draw becomes dynamic.
//!
//! A pipeline can draw into reversed and native attachments alike, so its compare op, viewport,
//! depth bias and depth bounds are made dynamic (when the application left them static) and
//! their static values are recorded; [`crate::command_state`] emits the right values at draw
//! time. Pipeline libraries are passed through untouched (and their draws into reversed
//! attachments are not corrected: logged once).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use ash::vk;

use super::device_state;
use super::resources::slice;
use crate::boundary::{guarded, EntryPoint};
use crate::command_state::{PipelineDepth, States};
use crate::conv::DepthBias;

static CREATE_GRAPHICS_PIPELINES: EntryPoint = EntryPoint::new("vkCreateGraphicsPipelines");
static DESTROY_PIPELINE: EntryPoint = EntryPoint::new("vkDestroyPipeline");
static CREATE_SHADER_MODULE: EntryPoint = EntryPoint::new("vkCreateShaderModule");
static DESTROY_SHADER_MODULE: EntryPoint = EntryPoint::new("vkDestroyShaderModule");
static LIBRARY_LOGGED: AtomicBool = AtomicBool::new(false);

/// Whether a create info builds or links pipeline libraries.
fn uses_libraries(info: &vk::GraphicsPipelineCreateInfo<'_>) -> bool {
    if info.flags.contains(vk::PipelineCreateFlags::LIBRARY_KHR) {
        return true;
    }
    let mut next = info.p_next.cast::<vk::BaseInStructure>();
    // SAFETY: a valid pNext chain (the application's contract).
    while let Some(base) = unsafe { next.as_ref() } {
        if matches!(
            base.s_type,
            vk::StructureType::PIPELINE_LIBRARY_CREATE_INFO_KHR
                | vk::StructureType::GRAPHICS_PIPELINE_LIBRARY_CREATE_INFO_EXT
        ) {
            return true;
        }
        next = base.p_next;
    }
    false
}

/// Whether the fragment stage of a create info writes `FragDepth`, from its module (looked up
/// with `module_writes`) or from SPIR-V chained inline into the stage.
fn writes_frag_depth(
    info: &vk::GraphicsPipelineCreateInfo<'_>,
    module_writes: &dyn Fn(vk::ShaderModule) -> bool,
) -> bool {
    // SAFETY: `stageCount` stages (the application's contract).
    let stages = unsafe { slice(info.p_stages, info.stage_count) };
    stages
        .iter()
        .filter(|stage| stage.stage == vk::ShaderStageFlags::FRAGMENT)
        .any(|stage| {
            if stage.module != vk::ShaderModule::null() {
                return module_writes(stage.module);
            }
            let mut next = stage.p_next.cast::<vk::BaseInStructure>();
            // SAFETY: a valid pNext chain.
            while let Some(base) = unsafe { next.as_ref() } {
                if base.s_type == vk::StructureType::SHADER_MODULE_CREATE_INFO {
                    // SAFETY: the sType identifies the structure; `codeSize` bytes of code.
                    let inline = unsafe { &*next.cast::<vk::ShaderModuleCreateInfo<'_>>() };
                    // SAFETY: as above.
                    let words = unsafe { slice(inline.p_code, (inline.code_size / 4) as u32) };
                    return crate::spirv_scan::writes_frag_depth(words);
                }
                next = base.p_next;
            }
            false
        })
}

/// What revz changes in one create info: the dynamic states to add, and the pipeline's depth
/// state for draw time. `None` when the pipeline has no depth state to follow.
fn plan(
    info: &vk::GraphicsPipelineCreateInfo<'_>,
) -> Option<(Vec<vk::DynamicState>, PipelineDepth)> {
    // SAFETY: the state pointers are null or valid (the application's contract).
    let (depth, raster, viewport, dynamic) = unsafe {
        (
            info.p_depth_stencil_state.as_ref()?,
            info.p_rasterization_state.as_ref(),
            info.p_viewport_state.as_ref(),
            info.p_dynamic_state.as_ref(),
        )
    };
    if raster.is_some_and(|r| r.rasterizer_discard_enable == vk::TRUE) {
        return None;
    }
    // SAFETY: `dynamicStateCount` entries.
    let app_states = dynamic.map_or(&[][..], |d| unsafe {
        slice(d.p_dynamic_states, d.dynamic_state_count)
    });
    let has = |state: vk::DynamicState| app_states.contains(&state);
    let mut app_dynamic = States::NONE;
    for &state in app_states {
        app_dynamic |= States::of_dynamic(state);
    }

    let mut pipeline = PipelineDepth {
        app_dynamic,
        compare_op: depth.depth_compare_op,
        bounds: (depth.min_depth_bounds, depth.max_depth_bounds),
        ..PipelineDepth::default()
    };
    let mut added = Vec::new();
    let depth_test =
        depth.depth_test_enable == vk::TRUE || has(vk::DynamicState::DEPTH_TEST_ENABLE);
    if depth_test && !has(vk::DynamicState::DEPTH_COMPARE_OP) {
        added.push(vk::DynamicState::DEPTH_COMPARE_OP);
        pipeline.injected |= States::COMPARE_OP;
    }
    let viewport_dynamic =
        has(vk::DynamicState::VIEWPORT) || has(vk::DynamicState::VIEWPORT_WITH_COUNT);
    if let Some(viewport) = viewport.filter(|_| !viewport_dynamic) {
        // SAFETY: `viewportCount` viewports when static.
        pipeline.viewports =
            unsafe { slice(viewport.p_viewports, viewport.viewport_count) }.to_vec();
        if !pipeline.viewports.is_empty() {
            added.push(vk::DynamicState::VIEWPORT);
            pipeline.injected |= States::VIEWPORT;
        }
    }
    if let Some(raster) = raster {
        let bias = raster.depth_bias_enable == vk::TRUE || has(vk::DynamicState::DEPTH_BIAS_ENABLE);
        pipeline.bias = DepthBias {
            constant: raster.depth_bias_constant_factor,
            clamp: raster.depth_bias_clamp,
            slope: raster.depth_bias_slope_factor,
        };
        if bias && !has(vk::DynamicState::DEPTH_BIAS) {
            added.push(vk::DynamicState::DEPTH_BIAS);
            pipeline.injected |= States::BIAS;
        }
    }
    let bounds = depth.depth_bounds_test_enable == vk::TRUE
        || has(vk::DynamicState::DEPTH_BOUNDS_TEST_ENABLE);
    if bounds && !has(vk::DynamicState::DEPTH_BOUNDS) {
        added.push(vk::DynamicState::DEPTH_BOUNDS);
        pipeline.injected |= States::BOUNDS;
    }
    let mut states = app_states.to_vec();
    states.extend(added);
    Some((states, pipeline))
}

pub unsafe extern "system" fn create_graphics_pipelines(
    device: vk::Device,
    cache: vk::PipelineCache,
    count: u32,
    p_create_infos: *const vk::GraphicsPipelineCreateInfo<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_pipelines: *mut vk::Pipeline,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    let next = state.next.fp_v1_0().create_graphics_pipelines;
    // SAFETY: `count` create infos.
    let infos = unsafe { slice(p_create_infos, count) };
    let plans = guarded(
        &CREATE_GRAPHICS_PIPELINES,
        || {
            infos
                .iter()
                .map(|info| {
                    if uses_libraries(info) {
                        if !LIBRARY_LOGGED.swap(true, Ordering::Relaxed) {
                            log::warn!(
                                "graphics pipeline libraries are passed through: their draws \
                                 into reversed attachments are not corrected"
                            );
                        }
                        return None;
                    }
                    plan(info).map(|(states, mut depth)| {
                        depth.writes_frag_depth = writes_frag_depth(info, &|module| {
                            state.objects.frag_depth_modules.get(&module).is_some()
                        });
                        (states, depth)
                    })
                })
                .collect::<Vec<_>>()
        },
        Vec::new,
    );
    if plans.iter().all(Option::is_none) {
        // SAFETY: calling down with the application's arguments.
        return unsafe {
            next(
                device,
                cache,
                count,
                p_create_infos,
                p_allocator,
                p_pipelines,
            )
        };
    }

    // The application's create infos with the extra dynamic states; the arrays they point to
    // live until the call returns.
    let dynamic_infos: Vec<Option<vk::PipelineDynamicStateCreateInfo<'_>>> = plans
        .iter()
        .zip(infos)
        .map(|(plan, info)| {
            let (states, _) = plan.as_ref()?;
            // SAFETY: null or valid (the application's contract).
            let base = unsafe { info.p_dynamic_state.as_ref() }
                .copied()
                .unwrap_or_default();
            Some(vk::PipelineDynamicStateCreateInfo {
                dynamic_state_count: states.len() as u32,
                p_dynamic_states: states.as_ptr(),
                ..base
            })
        })
        .collect();
    let modified: Vec<vk::GraphicsPipelineCreateInfo<'_>> = infos
        .iter()
        .zip(&dynamic_infos)
        .map(|(info, dynamic)| match dynamic {
            Some(dynamic) => vk::GraphicsPipelineCreateInfo {
                p_dynamic_state: dynamic,
                ..*info
            },
            None => *info,
        })
        .collect();
    // SAFETY: the application's create infos, with only the dynamic state list extended.
    let result = unsafe {
        next(
            device,
            cache,
            count,
            modified.as_ptr(),
            p_allocator,
            p_pipelines,
        )
    };
    guarded(
        &CREATE_GRAPHICS_PIPELINES,
        || {
            // SAFETY: `count` handles were written (null where creation failed).
            let pipelines = unsafe { slice(p_pipelines, count) };
            for (pipeline, plan) in pipelines.iter().zip(plans) {
                if let (false, Some((_, depth))) = (*pipeline == vk::Pipeline::null(), plan) {
                    state.objects.pipelines.insert(*pipeline, Arc::new(depth));
                }
            }
        },
        || (),
    );
    result
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
        super::record(&CREATE_SHADER_MODULE, || {
            // SAFETY: valid on success; `codeSize` bytes of code.
            let info = unsafe { &*p_create_info };
            // SAFETY: as above.
            let words = unsafe { slice(info.p_code, (info.code_size / 4) as u32) };
            if crate::spirv_scan::writes_frag_depth(words) {
                // SAFETY: valid on success.
                state
                    .objects
                    .frag_depth_modules
                    .insert(unsafe { *p_module }, ());
            }
        });
    }
    result
}

destroy_hook!(
    destroy_shader_module,
    DESTROY_SHADER_MODULE,
    vk::ShaderModule,
    frag_depth_modules,
    destroy_shader_module
);

destroy_hook!(
    destroy_pipeline,
    DESTROY_PIPELINE,
    vk::Pipeline,
    pipelines,
    destroy_pipeline
);

#[cfg(test)]
mod tests {
    use super::*;

    fn depth_state(test: bool, bounds: bool) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
        vk::PipelineDepthStencilStateCreateInfo {
            depth_test_enable: test.into(),
            depth_write_enable: vk::TRUE,
            depth_compare_op: vk::CompareOp::LESS_OR_EQUAL,
            depth_bounds_test_enable: bounds.into(),
            min_depth_bounds: 0.0,
            max_depth_bounds: 0.75,
            ..Default::default()
        }
    }

    fn raster(bias: bool, discard: bool) -> vk::PipelineRasterizationStateCreateInfo<'static> {
        vk::PipelineRasterizationStateCreateInfo {
            depth_bias_enable: bias.into(),
            depth_bias_constant_factor: -4.0,
            depth_bias_slope_factor: -2.0,
            rasterizer_discard_enable: discard.into(),
            ..Default::default()
        }
    }

    const VIEWPORT: [vk::Viewport; 1] = [vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: 64.0,
        height: 64.0,
        min_depth: 0.0,
        max_depth: 1.0,
    }];

    #[test]
    fn static_depth_state_becomes_dynamic_and_is_recorded() {
        let depth = depth_state(true, true);
        let raster = raster(true, false);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewports(&VIEWPORT);
        let app_states = [vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&app_states);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&raster)
            .viewport_state(&viewport)
            .dynamic_state(&dynamic);
        let (states, pipeline) = plan(&info).expect("a pipeline with depth state");
        assert_eq!(
            states,
            [
                vk::DynamicState::SCISSOR,
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::VIEWPORT,
                vk::DynamicState::DEPTH_BIAS,
                vk::DynamicState::DEPTH_BOUNDS,
            ]
        );
        assert_eq!(pipeline.app_dynamic, States::NONE);
        assert_eq!(
            pipeline.injected,
            States::COMPARE_OP | States::VIEWPORT | States::BIAS | States::BOUNDS
        );
        assert_eq!(pipeline.compare_op, vk::CompareOp::LESS_OR_EQUAL);
        assert_eq!(pipeline.bias.constant, -4.0);
        assert_eq!(pipeline.bounds, (0.0, 0.75));
        assert_eq!(pipeline.viewports.len(), 1);
    }

    #[test]
    fn state_the_application_made_dynamic_is_left_to_it() {
        let depth = depth_state(true, false);
        let raster = raster(false, false);
        let app_states = [
            vk::DynamicState::VIEWPORT_WITH_COUNT,
            vk::DynamicState::DEPTH_COMPARE_OP,
        ];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&app_states);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&raster)
            .dynamic_state(&dynamic);
        let (states, pipeline) = plan(&info).expect("a pipeline with depth state");
        assert_eq!(states, app_states);
        assert_eq!(
            pipeline.app_dynamic,
            States::VIEWPORT_WITH_COUNT | States::COMPARE_OP
        );
        assert!(pipeline.injected.is_empty());
    }

    #[test]
    fn pipelines_without_depth_or_rasterization_are_not_touched() {
        let raster_on = raster(false, false);
        let info = vk::GraphicsPipelineCreateInfo::default().rasterization_state(&raster_on);
        assert!(plan(&info).is_none(), "no depth-stencil state");

        let depth = depth_state(true, false);
        let discard = raster(false, true);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&discard);
        assert!(plan(&info).is_none(), "rasterizer discard");
    }

    #[test]
    fn pipeline_libraries_are_recognized() {
        let library =
            vk::GraphicsPipelineCreateInfo::default().flags(vk::PipelineCreateFlags::LIBRARY_KHR);
        assert!(uses_libraries(&library));
        let mut link = vk::PipelineLibraryCreateInfoKHR::default();
        let linked = vk::GraphicsPipelineCreateInfo::default().push_next(&mut link);
        assert!(uses_libraries(&linked));
        assert!(!uses_libraries(&vk::GraphicsPipelineCreateInfo::default()));
    }
}
