//! Graphics pipeline creation: the depth-related state revz must set per draw becomes dynamic.
//!
//! A pipeline can draw into reversed and native attachments alike, so its compare op, viewport,
//! depth bias and depth bounds are made dynamic (when the application left them static) and
//! their static values are recorded; [`crate::command_state`] emits the right values at draw
//! time. Graphics pipeline libraries get the same in the state subsets each defines, and a
//! linked pipeline takes each subset's state from its library. A pipeline whose fragment
//! shader computes with depth, or whose compare op stays static (`compare_op = variants`),
//! gets a reversed variant bound for draws into reversed attachments: a fragment shader library
//! gets a variant library, and what links it a variant linking that one.
//!
//! The module is split by concern: [`plan`](mod@plan) plans what revz does with one create info (the
//! dynamic states it adds, the precise path, the promoted variants), [`variants`] creates the
//! reversed and promoted variants and the rewritten vertex stage, [`modules`] analyzes and
//! rewrites shader modules and reserves the carrier in pipeline layouts; this file holds the
//! pipeline entry points, which gather, ask the plan and apply it. The decisions are the
//! policy's (`crate::policy::pipelines`, `crate::policy::vertex_stage`): these files gather
//! their facts, log, and make the driver calls.

mod modules;
mod plan;
mod variants;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use ash::vk;

use super::device_state;
use super::resources::slice;
use crate::boundary::{guarded, EntryPoint};
use crate::chain;
use crate::command_state::{DepthClip, PipelineDepth, States};
use crate::conv::{flip_compare_op, BiasRepresentation, DepthBias};
use crate::objects::{
    BakedStage, ModuleAnalysis, ReversedFragment, RewrittenVertex, VertexRewrite,
};
use crate::policy::libraries::{self, inherit_libraries, subset_states, Subsets};
use crate::policy::pipelines::{
    baked_stage_conflict, examines_fragment, has_depth_attachment, profiles_pipeline,
    renders_depth, viewports_static, BiasVariantFacts, DepthAttachmentFacts, DepthBiasFacts,
    DepthStencilFacts, FragmentStage, InputReads, PipelinePath, PipelinePromotion,
    PromotionAttachments, PromotionFacts, StaticStateFacts, StaticStatePlan, TakeBack,
    VariantCompile, VariantFacts, VariantKind, Variants,
};
use crate::policy::vertex_stage::{
    self, precise_candidate, Missing, MissingFact, PositionStore, VertexStageFacts,
};
use crate::precise::{self, Carrier, ProjectionUse};
use crate::shader::analysis;
use crate::shader::derived_range::MatrixSource;
use crate::shader::fragment_depth;
use crate::shader::input_depth::DepthInputs;
use crate::shader::position_store;
use crate::state::DeviceState;
use revz_math::{DepthConvention, Target as RewriteTarget};

use modules::*;
use plan::*;
use variants::*;

pub(crate) use modules::{baked_code, push_layout, vertex_code};
pub use modules::{
    create_pipeline_layout, create_shader_module, destroy_pipeline_layout, destroy_shader_module,
};

static CREATE_GRAPHICS_PIPELINES: EntryPoint = EntryPoint::new("vkCreateGraphicsPipelines");
static DESTROY_PIPELINE: EntryPoint = EntryPoint::new("vkDestroyPipeline");
static CREATE_SHADER_MODULE: EntryPoint = EntryPoint::new("vkCreateShaderModule");
static DESTROY_SHADER_MODULE: EntryPoint = EntryPoint::new("vkDestroyShaderModule");
static CREATE_PIPELINE_LAYOUT: EntryPoint = EntryPoint::new("vkCreatePipelineLayout");
static DESTROY_PIPELINE_LAYOUT: EntryPoint = EntryPoint::new("vkDestroyPipelineLayout");

/// What is logged of a shader that revz cannot handle.
#[derive(Hash)]
pub(super) enum Report {
    Rewrite,
    Analysis,
}

/// Whether `report` is made of inline SPIR-V `words` for the first time. Inline code (chained
/// into a pipeline stage) is rewritten and analyzed at every pipeline creation, but reported
/// once, as a module is at its creation. Only hashes are kept: a collision can only drop a
/// log line.
pub(super) fn first_inline_report(report: Report, words: &[u32]) -> bool {
    use std::hash::{Hash, Hasher};
    static REPORTED: std::sync::LazyLock<std::sync::Mutex<rustc_hash::FxHashSet<u64>>> =
        std::sync::LazyLock::new(Default::default);
    let mut hasher = rustc_hash::FxHasher::default();
    (report, words).hash(&mut hasher);
    REPORTED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .insert(hasher.finish())
}

/// What the precise path needs of a pipeline: where its projection is (or where the matrix
/// its vertex stage derives the range from comes from), where revz's carrier is, and its
/// vertex stage (index) rewritten to store the carrier's depth.
struct PreciseStage {
    projection: Option<ProjectionUse>,
    derived: Option<MatrixSource>,
    /// `None`: the layout has no room for it, and `vertex` has it baked in (for the
    /// reversed variants only).
    carrier: Option<Carrier>,
    vertex: (usize, Arc<[u32]>),
    /// The stage rewritten (the last pre-rasterization stage), for the log.
    stage: vertex_stage::LastStage,
}

/// What revz does with one create info: the pipeline's depth state for draw time, and the
/// complete dynamic state list to create it with when revz adds states (`None`: unchanged).
#[derive(Debug)]
struct Plan {
    dynamic_states: Option<Vec<vk::DynamicState>>,
    depth: PipelineDepth,
    /// Why the pipeline's draws take the flip path (precise modes).
    flip_reason: Option<String>,
    /// What the policy made of its static state: whether it renders depth, the states made
    /// dynamic, whether its static compare op flips and is to come from a variant (the
    /// compare op is not made dynamic: `DevicePolicy::compare_op_variants`; [`Variants`] says
    /// whether the variant is made), the compare op it tests with.
    static_state: StaticStatePlan,
    /// The fragment stage (its index) the reversed variant gets rewritten
    /// (`crate::shader::fragment_depth`, and `crate::shader::input_depth` where it reads depth
    /// through input attachments).
    fragment: Option<(usize, Arc<[u32]>)>,
    /// The fragment stage the input variants get: its reads of depth through input attachments
    /// converted, nothing else changed.
    input_fragment: Option<(usize, Arc<[u32]>)>,
    /// The vertex stage (its index) rewritten to store the carrier's depth
    /// (`crate::shader::position_store`): the precise path. The application's pipeline itself (and
    /// its variant) is created with it: with the flip carrier it stores the shader's own z.
    vertex: Option<(usize, Arc<[u32]>)>,
    /// Which stage that is (the last pre-rasterization stage), for the log.
    rewritten_stage: Option<vertex_stage::LastStage>,
    /// Where the layout has no room for the carrier: that stage (its index) with the carrier
    /// baked in, which the reversed variants get instead (`PipelineDepth::baked`); the
    /// application's pipeline keeps its own.
    baked_vertex: Option<(usize, Arc<[u32]>)>,
    /// The libraries the create info links, with those that have a reversed variant replaced
    /// by it; `None` when none has one.
    libraries: Option<Vec<vk::Pipeline>>,
    /// The libraries the create info links, with those that have an input variant (a fragment
    /// shader library converting the depth it reads through input attachments) replaced by
    /// it: what its input variant links. `None` when none has one.
    input_libraries: Option<Vec<vk::Pipeline>>,
    /// How its promoted variants differ from it, where it gets them.
    promotion: Option<Promotion>,
    /// The variants it gets ([`VariantFacts::decide`]; none until it is asked).
    variants: Variants,
    /// Its reversed variant holds its static depth bias flipped, and the bias stays static
    /// ([`crate::policy::pipelines::BiasVariantFacts::variant_holds_bias`]).
    variant_bias: bool,
}

/// How a pipeline's promoted variants differ from it (`crate::policy::DevicePolicy::
/// promoted_format`): a framebuffer of promoted images is begun as its render pass's
/// promoted twin, and a pipeline drawn there must be compatible with the twin (attachment
/// formats count for render pass compatibility and for dynamic rendering).
#[derive(Debug, Default)]
struct Promotion {
    /// The promoted twin of its render pass (`None`: dynamic rendering, or a link).
    render_pass: Option<vk::RenderPass>,
    /// Its rendering formats name a UNORM depth or stencil format: the variants name the
    /// float ones.
    rendering: bool,
    /// The linked libraries with their promoted variants, and with their promoted reversed
    /// ones (`None`: no library has one).
    libraries: Option<Vec<vk::Pipeline>>,
    reversed_libraries: Option<Vec<vk::Pipeline>>,
    /// The same with their promoted input variants.
    input_libraries: Option<Vec<vk::Pipeline>>,
}

/// The subsets whose state includes the render pass or rendering formats.
const USES_ATTACHMENT_FORMATS: Subsets = Subsets::from_raw(
    Subsets::PRE_RASTERIZATION_SHADERS.as_raw()
        | Subsets::FRAGMENT_SHADER.as_raw()
        | Subsets::FRAGMENT_OUTPUT_INTERFACE.as_raw(),
);

/// What became of a pipeline's reversed variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Variant {
    /// None was needed, or it could not be made (logged).
    Missing,
    Made(vk::Pipeline),
    /// It is not in the pipeline cache, and the application asked for no compilation
    /// (`FAIL_ON_PIPELINE_COMPILE_REQUIRED`).
    CompileRequired,
}

impl Variant {
    fn pipeline(self) -> Option<vk::Pipeline> {
        match self {
            Variant::Made(pipeline) => Some(pipeline),
            Variant::Missing | Variant::CompileRequired => None,
        }
    }

    /// Whether it needs compiling, and whether `info`, its create info, then asks for early
    /// return (read only then).
    fn compile(self, info: &vk::GraphicsPipelineCreateInfo<'_>) -> VariantCompile {
        match self {
            Variant::CompileRequired => VariantCompile::Required {
                returns_early: returns_early(info),
            },
            Variant::Missing | Variant::Made(_) => VariantCompile::Done,
        }
    }
}

/// What [`plan`](fn@plan::plan) needs to know beyond the create info.
struct PlanContext {
    /// Whether the pipeline renders into a depth attachment; the spec makes
    /// `pDepthStencilState` ignored (possibly dangling) otherwise.
    has_depth_attachment: bool,
    /// The state subsets the create info defines itself (all but for pipeline libraries).
    subsets: Subsets,
    /// The flipped compare op comes from a pipeline variant, not dynamic state.
    compare_op_variants: bool,
    /// The device has `vkCmdSetDepthBias2EXT`: a bias with an explicit representation can be
    /// sent again with it.
    bias_with_representation: bool,
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
    let mut plans = guarded(
        &CREATE_GRAPHICS_PIPELINES,
        || {
            infos
                .iter()
                .map(|info| {
                    let context = context(&state, info);
                    let mut plan = plan(info, &context);
                    if let Some(op) = plan.static_state.tested_compare_op {
                        state.observed.note_pipeline_compare_op(op);
                    }
                    let linked = linked_libraries(&state, info);
                    plan.depth.module_identifiers = uses_module_identifiers(info);
                    let mut facts = VariantFacts {
                        active: state.policy.is_active(),
                        renders_depth: plan.static_state.renders_depth,
                        // A pipeline linking a library of identified stages must keep
                        // FAIL_ON_PIPELINE_COMPILE_REQUIRED too
                        // (VUID-VkPipelineLibraryCreateInfoKHR-pLibraries-06855).
                        identified: plan.depth.module_identifiers
                            || linked.iter().any(|library| library.module_identifiers),
                        from_binaries: uses_pipeline_binaries(info),
                        fragment: None,
                        compare_op_flips: plan.static_state.compare_op_variant,
                        library_variants: false,
                        promotion: false,
                        converts_inputs: InputReads::None,
                        depth_attachment: context.has_depth_attachment,
                    };
                    if facts.warns_of_binaries() {
                        static BINARIES: crate::logging::LogOnce = crate::logging::LogOnce::new();
                        BINARIES.log(|| {
                            log::warn!(
                                "a pipeline is created from pipeline binaries \
                                 (VK_KHR_pipeline_binary): revz cannot make its reversed \
                                 variant, so a fragment shader computing with depth, or a static \
                                 compare op with compare_op = variants, keeps standard depth"
                            )
                        });
                    }
                    let examined = examines_fragment(
                        facts.active,
                        facts.renders_depth,
                        context.subsets.contains(Subsets::FRAGMENT_SHADER),
                    );
                    let fragment = examined.then(|| fragment_stage_rewrite(&state, info));
                    facts.fragment = fragment.as_ref().map(|rewrite| match rewrite {
                        None => FragmentStage::NoDepth,
                        Some((_, Ok(_))) => FragmentStage::Rewritable,
                        Some((_, Err(_))) => FragmentStage::CannotRewrite,
                    });
                    let candidate = precise_candidate(
                        state.policy.rewrite().is_some(),
                        plan.static_state.renders_depth,
                        context.subsets.contains(Subsets::PRE_RASTERIZATION_SHADERS),
                    );
                    let clamp_flip = state.policy.rewrite().and_then(|target| {
                        // SAFETY: the application's valid create info.
                        vertex_stage::depth_clamp_flip(target, unsafe { depth_clamp_of(info) })
                    });
                    if let (true, Some(reason)) = (candidate, clamp_flip) {
                        plan.flip_reason = Some(reason.into());
                    } else if candidate {
                        let bakeable = context.subsets == libraries::ALL_SUBSETS
                            && !is_library(info)
                            && linked.is_empty();
                        match projection_of(&state, info, facts.code_given(), bakeable) {
                            Ok(stage) => {
                                plan.depth.projection = stage.projection;
                                plan.depth.derived_range = stage.derived;
                                plan.depth.layout = state
                                    .objects
                                    .layout_pushers
                                    .get(&info.layout)
                                    .unwrap_or_default();
                                plan.depth.position_store = stage.carrier;
                                plan.rewritten_stage = Some(stage.stage);
                                if stage.carrier.is_some() {
                                    plan.vertex = Some(stage.vertex);
                                } else {
                                    plan.depth.baked = true;
                                    plan.baked_vertex = Some(stage.vertex);
                                }
                            }
                            Err(reason) => plan.flip_reason = Some(reason),
                        }
                    }
                    inherit_libraries(&mut plan.depth, &linked);
                    let libraries = if facts.renders_depth {
                        library_variants(&state, info, VariantKind::REVERSED)
                    } else {
                        None
                    };
                    // A link of a fragment shader library that converts the depth it reads
                    // through input attachments: its input variant links the library's.
                    let input_libraries = library_variants(&state, info, VariantKind::INPUTS);
                    facts.library_variants = libraries.is_some();
                    let promotion = promotion_of(&state, info, context.subsets, &linked);
                    facts.promotion = promotion.is_some();
                    plan.depth.promotable |= facts.promotion;
                    // Depth read through input attachments: converted in the fragment stage
                    // (of the pipeline, or of the fragment shader library it is; a link
                    // links that library's variants).
                    let inputs = context
                        .subsets
                        .contains(Subsets::FRAGMENT_SHADER)
                        .then(|| depth_input_stage(&state, info))
                        .flatten();
                    let inputs = match inputs {
                        Some(_) if !linked.is_empty() => {
                            static LINKED: crate::logging::LogOnce = crate::logging::LogOnce::new();
                            LINKED.log(|| {
                                log::warn!(
                                    "a pipeline that links libraries defines a fragment stage \
                                     reading depth through input attachments: revz does not \
                                     convert those reads there, so they read reversed depth \
                                     where the attachment is reversed"
                                )
                            });
                            None
                        }
                        Some(stage) => stage.convert(&stage.code).map(|code| (stage, code)),
                        None => None,
                    };
                    facts.converts_inputs = match (&inputs, &input_libraries) {
                        // Dynamic rendering's local reads (a link's libraries made for a
                        // render pass's subpass have input variants; one made for dynamic
                        // rendering none).
                        (Some(_), _) if info.render_pass == vk::RenderPass::null() => {
                            InputReads::Rendering
                        }
                        (Some(_), _) | (None, Some(_)) => InputReads::Subpass,
                        (None, None) => InputReads::None,
                    };
                    if inputs.is_none() {
                        // Reads converted in a linked library only: the link's reversed
                        // variant is the one linking the libraries' reversed variants (which
                        // convert them where their subpass has a depth attachment), none of
                        // its own for them.
                        facts.depth_attachment = false;
                    }
                    let variants = facts.decide();
                    let holds_bias = BiasVariantFacts {
                        compare_op_variant: variants.compare_op,
                        bias_made_dynamic: plan.static_state.made_dynamic.contains(States::BIAS),
                        complete: context.subsets == libraries::ALL_SUBSETS
                            && !is_library(info)
                            && linked.is_empty(),
                        promotable: plan.depth.promotable,
                    }
                    .variant_holds_bias();
                    if holds_bias {
                        plan.keep_bias_static(info);
                    }
                    let mut variants = variants;
                    if plan.depth.baked {
                        match baked_stage_conflict(&variants, holds_bias) {
                            Some(reason) => {
                                plan.depth.baked = false;
                                plan.depth.derived_range = None;
                                plan.baked_vertex = None;
                                plan.flip_reason = Some(reason.into());
                            }
                            None => variants.baked_vertex = true,
                        }
                    }
                    if variants.rewritten_fragment {
                        if let Some(Some((index, Ok(code)))) = fragment {
                            plan.fragment = Some((index, code));
                        }
                    }
                    if let (true, Some((stage, code))) = (variants.converted_inputs, inputs) {
                        // The reversed variants convert the reads too, in the stage the
                        // fragment depth rewrite made where there is one.
                        let reversed = match &plan.fragment {
                            Some((_, rewritten)) => stage.convert(rewritten),
                            None => Some(code.clone()),
                        };
                        if let Some(reversed) = reversed {
                            plan.fragment = Some((stage.index, reversed));
                        }
                        if variants.input_variants {
                            plan.input_fragment = Some((stage.index, code));
                        }
                    }
                    if variants.linked_variants {
                        plan.libraries = libraries;
                    }
                    if variants.converted_inputs {
                        plan.input_libraries = input_libraries;
                    }
                    if variants.promoted {
                        plan.promotion = promotion;
                    }
                    plan.depth.unreversed_fragment |= variants.unreversed_fragment;
                    if variants.promotion_refused {
                        static IDENTIFIED: crate::logging::LogOnce = crate::logging::LogOnce::new();
                        IDENTIFIED.log(|| {
                            log::error!(
                                "a pipeline given by identifiers or binaries draws into \
                                 promoted depth images: revz cannot make its promoted variant, \
                                 and the driver may reject its draws there (set \
                                 promote_depth_formats = never for this application)"
                            )
                        });
                    }
                    plan.variants = variants;
                    Some(plan)
                })
                .collect::<Vec<_>>()
        },
        Vec::new,
    );

    // The precise path's vertex stage: the application's pipeline itself (and its variant)
    // is created with the rewritten module (`crate::shader::position_store`). With the flip carrier
    // it stores the shader's own z exactly, so one pipeline serves native and reversed
    // attachments, and no second pipeline is compiled for it. The stage arrays and modules
    // live until the calls below return.
    let vertex_stages: Vec<Option<(Vec<vk::PipelineShaderStageCreateInfo<'_>>, RewrittenStage)>> =
        guarded(
            &CREATE_GRAPHICS_PIPELINES,
            || {
                plans
                    .iter_mut()
                    .zip(infos)
                    .map(|(plan, info)| {
                        let plan = plan.as_mut()?;
                        let (index, code) = plan.vertex.take()?;
                        // SAFETY: `stageCount` stages (the application's contract).
                        let mut stages = unsafe { slice(info.p_stages, info.stage_count) }.to_vec();
                        let stage = stages
                            .get_mut(index)
                            .and_then(|stage| rewritten_stage(&state, device, stage, &code));
                        if let Some(reason) = vertex_stage::unmade_stage_flip(stage.is_some()) {
                            plan.depth.projection = None;
                            plan.depth.derived_range = None;
                            plan.depth.position_store = None;
                            plan.flip_reason = Some(reason.into());
                        }
                        Some((stages, stage?))
                    })
                    .collect()
            },
            Vec::new,
        );
    let with_vertex: Vec<vk::GraphicsPipelineCreateInfo<'_>> = infos
        .iter()
        .enumerate()
        .map(
            |(index, info)| match vertex_stages.get(index).and_then(Option::as_ref) {
                Some((stages, _)) => vk::GraphicsPipelineCreateInfo {
                    p_stages: stages.as_ptr(),
                    ..*info
                },
                None => *info,
            },
        )
        .collect();
    let rewrites_vertex = vertex_stages.iter().any(Option::is_some);
    let infos: &[vk::GraphicsPipelineCreateInfo<'_>] = &with_vertex;
    // The application's create infos, with the dynamic state lists revz extends; the arrays
    // they point to live until the call returns.
    let dynamic_infos: Vec<Option<vk::PipelineDynamicStateCreateInfo<'_>>> = plans
        .iter()
        .zip(infos)
        .map(|(plan, info)| {
            let states = plan.as_ref()?.dynamic_states.as_ref()?;
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
    // Variants are created before the application's pipelines: creating a pipeline
    // writes the output structures of its chain (creation feedback), which must end up
    // holding the application's results.
    let variants: Vec<Vec<(VariantKind, Variant)>> = guarded(
        &CREATE_GRAPHICS_PIPELINES,
        || {
            // After a variant that needs compiling in a create info asking for early return,
            // every pipeline is taken back (`take_back_uncompiled`): no more variants.
            let mut returned_early = false;
            plans
                .iter()
                .zip(infos.iter().zip(&dynamic_infos))
                .map(|(plan, (info, dynamic))| {
                    let Some(plan) = plan else {
                        return Vec::new();
                    };
                    let mut made = Vec::new();
                    for kind in plan.variants.kinds() {
                        if returned_early {
                            break;
                        }
                        let variant =
                            create_variant(&state, device, cache, info, dynamic, plan, kind);
                        returned_early = variant.compile(info).ends_batch();
                        made.push((kind, variant));
                    }
                    made
                })
                .collect()
        },
        Vec::new,
    );
    // Per create info: a variant needs compiling (all are taken back then), else made.
    let statuses: Vec<Variant> = variants
        .iter()
        .map(|made| {
            if made.iter().any(|(_, v)| *v == Variant::CompileRequired) {
                Variant::CompileRequired
            } else {
                Variant::Missing
            }
        })
        .collect();
    let result = if dynamic_infos.iter().all(Option::is_none) && !rewrites_vertex {
        // SAFETY: calling down with the application's arguments.
        unsafe {
            next(
                device,
                cache,
                count,
                p_create_infos,
                p_allocator,
                p_pipelines,
            )
        }
    } else {
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
        // SAFETY: the application's create infos, with only dynamic state lists extended and
        // precise-path vertex stages rewritten.
        unsafe {
            next(
                device,
                cache,
                count,
                modified.as_ptr(),
                p_allocator,
                p_pipelines,
            )
        }
    };
    let result = guarded(
        &CREATE_GRAPHICS_PIPELINES,
        // SAFETY: the handles just created from `infos` with `p_allocator`.
        || unsafe {
            take_back_uncompiled(
                &state,
                device,
                infos,
                &statuses,
                p_allocator,
                p_pipelines,
                result,
            )
        },
        || result,
    );
    guarded(
        &CREATE_GRAPHICS_PIPELINES,
        || {
            // SAFETY: `count` handles were written (null where creation failed).
            let pipelines = unsafe { slice(p_pipelines, count) };
            for (index, (&pipeline, plan)) in pipelines.iter().zip(plans).enumerate() {
                let made = variants.get(index).map_or(&[][..], Vec::as_slice);
                let made_kind = |wanted: VariantKind| {
                    made.iter()
                        .find(|(kind, _)| *kind == wanted)
                        .and_then(|(_, variant)| variant.pipeline())
                };
                let Some(mut plan) = plan.filter(|_| pipeline != vk::Pipeline::null()) else {
                    for variant in made.iter().filter_map(|(_, variant)| variant.pipeline()) {
                        // SAFETY: revz's own object, never handed out.
                        unsafe { destroy_pipeline_down(&state, device, variant) };
                    }
                    continue;
                };
                plan.depth.handle = pipeline;
                let variant = made_kind(VariantKind::REVERSED);
                plan.depth.reversed_variant = variant;
                plan.depth.promoted_variant = made_kind(VariantKind::PROMOTED);
                plan.depth.promoted_reversed_variant = made_kind(VariantKind::PROMOTED_REVERSED);
                plan.depth.input_variant = made_kind(VariantKind::INPUTS);
                plan.depth.promoted_input_variant = made_kind(VariantKind::PROMOTED_INPUTS);
                if plan.variants.promoted && plan.depth.promoted_variant.is_none() {
                    static MISSING: crate::logging::LogOnce = crate::logging::LogOnce::new();
                    MISSING.log(|| {
                        log::error!(
                            "pipeline {pipeline:?}: its promoted variant could not be made; its \
                             draws into promoted depth images use it as it is, and the driver \
                             may reject them"
                        )
                    });
                }
                if plan.variants.keeps_unreversed_fragment(variant.is_some()) {
                    plan.depth.unreversed_fragment = true;
                }
                let baked_missing = plan.depth.reversed_variant.is_none()
                    || (plan.variants.promoted && plan.depth.promoted_reversed_variant.is_none());
                if plan.depth.baked && baked_missing {
                    // Its precise-path draws would store the application's stage's depth.
                    // The variants made hold nothing but the baked stage (no other change
                    // was allowed beside it, `baked_stage_conflict`): bound for the flip
                    // path they would store reversed depth reversed again, so they go
                    // (found in review).
                    let made = [
                        plan.depth.reversed_variant.take(),
                        plan.depth.promoted_reversed_variant.take(),
                    ];
                    for variant in made.into_iter().flatten() {
                        // SAFETY: revz's own object, never handed out.
                        unsafe { destroy_pipeline_down(&state, device, variant) };
                    }
                    plan.variants.baked_vertex = false;
                    plan.depth.baked = false;
                    plan.depth.derived_range = None;
                    plan.flip_reason = Some(
                        "its pipeline layout has no room for revz's push constants, and its \
                         reversed variant with the carrier baked in could not be made"
                            .into(),
                    );
                }

                let path = PipelinePath::of(
                    plan.depth.projection,
                    plan.depth.derived_range,
                    plan.depth.baked,
                    plan.flip_reason.as_deref(),
                );
                match path {
                    PipelinePath::Derived(source) | PipelinePath::Baked(source) => log::debug!(
                        "pipeline {pipeline:?}: projection from {}: its {} stage derives \
                         the range from the matrix it loads (precise path{})",
                        source.describe(),
                        plan.rewritten_stage
                            .unwrap_or(vertex_stage::LastStage::Vertex)
                            .name(),
                        if plan.depth.baked {
                            "; its layout has no room for revz's push constants, so its \
                             reversed variants have the carrier baked in"
                        } else {
                            ""
                        }
                    ),
                    PipelinePath::Pushed(p) => log::debug!(
                        "pipeline {pipeline:?}: projection at push-constant bytes {}..{} \
                         ({:?}, {:?}): precise path",
                        p.offset,
                        p.end(),
                        p.storage,
                        p.convention
                    ),
                    PipelinePath::PushedAndFitted(p) => log::debug!(
                        "pipeline {pipeline:?}: projection at push-constant bytes {}..{} \
                         ({:?}, {:?}), read by its {} stage, which derives the range from \
                         the matrix it loads where it is no camera's (precise path)",
                        p.offset,
                        p.end(),
                        p.storage,
                        p.convention,
                        plan.rewritten_stage
                            .unwrap_or(vertex_stage::LastStage::Vertex)
                            .name(),
                    ),
                    PipelinePath::Flip(reason) => {
                        log::debug!("pipeline {pipeline:?}: flip path ({reason})")
                    }
                    PipelinePath::NotRewritten => {}
                }
                if let (Some(profile), true) = (
                    &state.profile,
                    profiles_pipeline(plan.static_state.renders_depth)
                        || plan.variants.converted_inputs,
                ) {
                    // A pipeline listed only for the depth it reads through input
                    // attachments draws no depth: no path, and no flip reason.
                    let (path_label, projection) = if plan.static_state.renders_depth {
                        (path.label(), path.to_string())
                    } else {
                        (
                            "none",
                            "renders no depth (listed for the depth it reads through input \
                             attachments)"
                                .to_owned(),
                        )
                    };
                    profile.pipeline(
                        vk::Handle::as_raw(pipeline),
                        crate::profile::PipelineRecord {
                            kind: "pipeline",
                            path: path_label,
                            projection,
                            reversed_variant: plan.depth.reversed_variant.is_some(),
                            promoted_variant: plan.depth.promoted_variant.is_some(),
                            converts_depth_inputs: plan.variants.converted_inputs,
                        },
                    );
                }
                if plan.variants.converted_inputs {
                    log::debug!(
                        "pipeline {pipeline:?}: its fragment shader reads depth through input \
                         attachments; {:?} (reversed depth attachment) and {:?} (reversed \
                         inputs only) convert what it reads",
                        plan.depth.reversed_variant,
                        plan.depth.input_variant
                    );
                }
                if let (true, Some(variant)) = (plan.variants.rewritten_fragment, variant) {
                    log::debug!(
                        "pipeline {pipeline:?}: its fragment shader computes with depth; \
                         {variant:?}, with the shader rewritten, draws into reversed attachments"
                    );
                }
                state
                    .objects
                    .pipelines
                    .insert(pipeline, Arc::new(plan.depth));
            }
        },
        || (),
    );
    for (_, RewrittenStage { module, .. }) in vertex_stages.into_iter().flatten() {
        // SAFETY: revz's own module; pipelines no longer need their modules once created.
        unsafe { (state.next.fp_v1_0().destroy_shader_module)(device, module, std::ptr::null()) };
    }
    result
}

/// Takes back the application's pipelines whose variant needs compiling where the application
/// asked for none (`FAIL_ON_PIPELINE_COMPILE_REQUIRED`), and those after one asking for
/// `EARLY_RETURN_ON_FAILURE`, as [`TakeBack`] decides: each is destroyed and reported as
/// needing compilation too. Returns the batch's result.
///
/// # Safety
/// `p_pipelines` holds the `infos.len()` handles just created from `infos` with `p_allocator`.
unsafe fn take_back_uncompiled(
    state: &DeviceState,
    device: vk::Device,
    infos: &[vk::GraphicsPipelineCreateInfo<'_>],
    variants: &[Variant],
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_pipelines: *mut vk::Pipeline,
    result: vk::Result,
) -> vk::Result {
    if !variants.contains(&Variant::CompileRequired) {
        return result;
    }
    // SAFETY: the caller's contract (non-null, as `infos` is not empty).
    let pipelines = unsafe { std::slice::from_raw_parts_mut(p_pipelines, infos.len()) };
    let mut take_back = TakeBack::default();
    for ((info, variant), pipeline) in infos.iter().zip(variants).zip(pipelines) {
        if !take_back.takes(variant.compile(info)) {
            continue;
        }
        if *pipeline != vk::Pipeline::null() {
            // SAFETY: the application's pipeline, just created with `p_allocator` and never
            // handed out.
            unsafe { (state.next.fp_v1_0().destroy_pipeline)(device, *pipeline, p_allocator) };
            *pipeline = vk::Pipeline::null();
        }
    }
    take_back.result(result)
}

/// A fragment stage pointed at revz's module of rewritten code: the module (the caller
/// destroys it once the pipeline is created), and the stage's chain without its inline SPIR-V
/// where it had some (the stage points into it).
struct RewrittenStage {
    module: vk::ShaderModule,
    _chain: Option<chain::Spliced>,
}

/// Destroys a pipeline of revz's own through the next layer.
///
/// # Safety
/// `pipeline` was created by revz on `device` and is not in use.
unsafe fn destroy_pipeline_down(state: &DeviceState, device: vk::Device, pipeline: vk::Pipeline) {
    // SAFETY: the caller's contract; revz's own object, so no allocator.
    unsafe { (state.next.fp_v1_0().destroy_pipeline)(device, pipeline, std::ptr::null()) };
}

pub unsafe extern "system" fn destroy_pipeline(
    device: vk::Device,
    pipeline: vk::Pipeline,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    let destroy = state.next.fp_v1_0().destroy_pipeline;
    super::record(&DESTROY_PIPELINE, || {
        let removed = state.objects.forget_pipeline(pipeline);
        for variant in removed.iter().flat_map(|depth| depth.variants()) {
            // SAFETY: revz's own object, in use only where the application's pipeline was.
            unsafe { destroy_pipeline_down(&state, device, variant) };
        }
    });
    // SAFETY: calling down with the application's arguments.
    unsafe { destroy(device, pipeline, p_allocator) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::policy::libraries::ALL_SUBSETS;

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

    const RENDERS_DEPTH: PlanContext = PlanContext {
        has_depth_attachment: true,
        subsets: ALL_SUBSETS,
        compare_op_variants: false,
        bias_with_representation: false,
    };

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
        let Plan {
            dynamic_states,
            depth: pipeline,
            ..
        } = plan(&info, &RENDERS_DEPTH);
        assert_eq!(
            dynamic_states.expect("states were added"),
            [
                vk::DynamicState::SCISSOR,
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::DEPTH_BOUNDS,
                vk::DynamicState::VIEWPORT,
                vk::DynamicState::DEPTH_BIAS,
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
    fn with_variants_the_compare_op_stays_static_and_a_variant_is_planned_where_it_flips() {
        let depth = depth_state(true, false);
        let raster = raster(false, false);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewports(&VIEWPORT);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&raster)
            .viewport_state(&viewport);
        let variants = PlanContext {
            compare_op_variants: true,
            ..RENDERS_DEPTH
        };
        let planned = plan(&info, &variants);
        assert!(planned.static_state.compare_op_variant);
        assert_eq!(
            planned
                .dynamic_states
                .expect("the viewport is made dynamic"),
            [vk::DynamicState::VIEWPORT]
        );
        assert!(!planned.depth.injected.contains(States::COMPARE_OP));
        assert_eq!(planned.depth.compare_op, vk::CompareOp::LESS_OR_EQUAL);

        // EQUAL reads the same reversed: no variant, and nothing else to add.
        let equal = vk::PipelineDepthStencilStateCreateInfo {
            depth_compare_op: vk::CompareOp::EQUAL,
            ..depth
        };
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&equal)
            .rasterization_state(&raster);
        let planned = plan(&info, &variants);
        assert!(!planned.static_state.compare_op_variant);
        assert!(planned.dynamic_states.is_none());
        assert!(!plan(&info, &RENDERS_DEPTH).static_state.compare_op_variant);
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
        let Plan {
            dynamic_states,
            depth: pipeline,
            ..
        } = plan(&info, &RENDERS_DEPTH);
        assert!(dynamic_states.is_none(), "nothing to add");
        assert_eq!(
            pipeline.app_dynamic,
            States::VIEWPORT_WITH_COUNT | States::COMPARE_OP
        );
        assert!(pipeline.injected.is_empty());
    }

    #[test]
    fn pipelines_without_depth_are_recorded_but_not_changed() {
        let app_states = [vk::DynamicState::VIEWPORT];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&app_states);
        let raster_on = raster(false, false);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .rasterization_state(&raster_on)
            .dynamic_state(&dynamic);
        let plan_without = plan(&info, &RENDERS_DEPTH);
        assert!(
            plan_without.dynamic_states.is_none(),
            "no depth-stencil state"
        );
        assert_eq!(plan_without.depth.app_dynamic, States::VIEWPORT);

        // A depth state the spec says to ignore (no depth attachment) is never read.
        let dangling = 0x10 as *const vk::PipelineDepthStencilStateCreateInfo<'static>;
        let info = vk::GraphicsPipelineCreateInfo {
            p_depth_stencil_state: dangling,
            ..info
        };
        let no_attachment = PlanContext {
            has_depth_attachment: false,
            ..RENDERS_DEPTH
        };
        assert!(plan(&info, &no_attachment).dynamic_states.is_none());

        let depth = depth_state(true, false);
        let discard = raster(false, true);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&discard);
        let discarding = plan(&info, &RENDERS_DEPTH);
        assert!(discarding.dynamic_states.is_none(), "rasterizer discard");
        assert!(!discarding.static_state.renders_depth);
        assert!(plan(&info, &no_attachment).dynamic_states.is_none());
    }

    /// A library (or a link) of `subsets`.
    fn library(subsets: Subsets) -> PlanContext {
        PlanContext {
            subsets,
            ..RENDERS_DEPTH
        }
    }

    #[test]
    fn each_library_makes_the_state_of_its_own_subsets_dynamic() {
        let depth = depth_state(true, true);
        let raster = raster(true, false);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewports(&VIEWPORT);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&raster)
            .viewport_state(&viewport);

        let pre_rasterization = plan(&info, &library(Subsets::PRE_RASTERIZATION_SHADERS));
        assert_eq!(
            pre_rasterization.dynamic_states.expect("states were added"),
            [vk::DynamicState::VIEWPORT, vk::DynamicState::DEPTH_BIAS]
        );
        assert_eq!(
            pre_rasterization.depth.injected,
            States::VIEWPORT | States::BIAS
        );
        assert_eq!(pre_rasterization.depth.bias.slope, -2.0);

        // The pre-rasterization state a fragment shader library is given is ignored by the
        // spec, so it may dangle: it is never read.
        let dangling = 0x10 as *const vk::PipelineViewportStateCreateInfo<'static>;
        let info = vk::GraphicsPipelineCreateInfo {
            p_viewport_state: dangling,
            p_rasterization_state: dangling.cast(),
            ..info
        };
        let fragment = plan(&info, &library(Subsets::FRAGMENT_SHADER));
        assert_eq!(
            fragment.dynamic_states.expect("states were added"),
            [
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::DEPTH_BOUNDS
            ]
        );
        assert_eq!(fragment.depth.compare_op, vk::CompareOp::LESS_OR_EQUAL);
        assert_eq!(fragment.depth.bounds, (0.0, 0.75));

        // Vertex input and fragment output define no depth state; a link defines nothing.
        let other = Subsets::VERTEX_INPUT_INTERFACE | Subsets::FRAGMENT_OUTPUT_INTERFACE;
        let info = vk::GraphicsPipelineCreateInfo {
            p_depth_stencil_state: dangling.cast(),
            ..info
        };
        assert!(plan(&info, &library(other)).dynamic_states.is_none());
        assert!(plan(&info, &library(Subsets::empty()))
            .dynamic_states
            .is_none());
    }

    #[test]
    fn a_fragment_shader_library_gets_the_compare_op_variant() {
        let depth = depth_state(true, false);
        let info = vk::GraphicsPipelineCreateInfo::default().depth_stencil_state(&depth);
        let variants = |subsets| PlanContext {
            compare_op_variants: true,
            ..library(subsets)
        };
        let planned = plan(&info, &variants(Subsets::FRAGMENT_SHADER));
        assert!(planned.static_state.compare_op_variant);
        assert!(planned.dynamic_states.is_none());
        // The compare op is fragment shader state: other libraries have none to flip.
        let planned = plan(&info, &variants(Subsets::PRE_RASTERIZATION_SHADERS));
        assert!(!planned.static_state.compare_op_variant);
    }

    #[test]
    fn dynamic_states_outside_a_librarys_subsets_are_ignored() {
        let depth = depth_state(true, false);
        let app_states = [
            vk::DynamicState::VIEWPORT_WITH_COUNT,
            vk::DynamicState::DEPTH_COMPARE_OP,
        ];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&app_states);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .dynamic_state(&dynamic);
        let fragment = plan(&info, &library(Subsets::FRAGMENT_SHADER));
        assert_eq!(fragment.depth.app_dynamic, States::COMPARE_OP);
        let link = plan(&info, &library(Subsets::empty()));
        assert_eq!(link.depth.app_dynamic, States::NONE);
    }

    #[test]
    fn an_explicit_bias_representation_is_made_dynamic_only_where_it_can_be_sent_again() {
        let depth = depth_state(true, false);
        let mut representation = vk::DepthBiasRepresentationInfoEXT::default()
            .depth_bias_representation(vk::DepthBiasRepresentationEXT::FLOAT)
            .depth_bias_exact(true);
        let raster = raster(true, false).push_next(&mut representation);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .depth_stencil_state(&depth)
            .rasterization_state(&raster);
        // Without vkCmdSetDepthBias2EXT: static.
        let kept = plan(&info, &RENDERS_DEPTH);
        assert_eq!(kept.depth.injected, States::COMPARE_OP);
        let with_command = PlanContext {
            bias_with_representation: true,
            ..RENDERS_DEPTH
        };
        let dynamic = plan(&info, &with_command);
        assert_eq!(dynamic.depth.injected, States::COMPARE_OP | States::BIAS);
        assert_eq!(
            dynamic.depth.bias.representation,
            Some(BiasRepresentation {
                representation: vk::DepthBiasRepresentationEXT::FLOAT,
                exact: true
            })
        );
    }

    #[test]
    fn inline_code_is_reported_once_per_kind_of_report() {
        // Words no other test reports.
        let words = [0x0723_0203, 0x5EED_0001, 0x5EED_0002];
        assert!(first_inline_report(Report::Rewrite, &words));
        assert!(!first_inline_report(Report::Rewrite, &words));
        assert!(first_inline_report(Report::Analysis, &words));
        assert!(first_inline_report(Report::Rewrite, &words[..2]));
    }

    #[test]
    fn the_subsets_a_create_info_defines() {
        let ordinary = vk::GraphicsPipelineCreateInfo::default();
        assert_eq!(own_subsets(&ordinary), ALL_SUBSETS);
        let library =
            vk::GraphicsPipelineCreateInfo::default().flags(vk::PipelineCreateFlags::LIBRARY_KHR);
        assert_eq!(own_subsets(&library), Subsets::empty());
        let mut named =
            vk::GraphicsPipelineLibraryCreateInfoEXT::default().flags(Subsets::FRAGMENT_SHADER);
        let fragment = library.push_next(&mut named);
        assert_eq!(own_subsets(&fragment), Subsets::FRAGMENT_SHADER);
        let libraries = [vk::Pipeline::null()];
        let mut links = vk::PipelineLibraryCreateInfoKHR::default().libraries(&libraries);
        let linked = vk::GraphicsPipelineCreateInfo::default().push_next(&mut links);
        assert_eq!(own_subsets(&linked), Subsets::empty());
        // Flags given as flags2 replace `flags`.
        let mut flags2 = vk::PipelineCreateFlags2CreateInfoKHR::default()
            .flags(vk::PipelineCreateFlags2KHR::LIBRARY);
        let library2 = vk::GraphicsPipelineCreateInfo::default().push_next(&mut flags2);
        assert_eq!(own_subsets(&library2), Subsets::empty());
        // A library that defines every subset is still a library.
        let mut every = vk::GraphicsPipelineLibraryCreateInfoEXT::default().flags(ALL_SUBSETS);
        let whole = library.push_next(&mut every);
        assert!(is_library(&whole));
        assert_eq!(own_subsets(&whole), ALL_SUBSETS);
    }
}
