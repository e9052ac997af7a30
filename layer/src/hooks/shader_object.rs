//! Shader objects (`VK_EXT_shader_object`): a fragment shader object that computes with depth
//! (writes `FragDepth` or reads `FragCoord.z`) gets a reversed variant, the shader object of
//! its code rewritten by [`crate::shader::fragment_depth`], which draws into reversed attachments bind
//! in its place ([`crate::command_state`], from `vkCmdBindShadersEXT`). In a precise mode a
//! pre-rasterization shader that stores `Position` gets a variant its precise-path draws bind
//! (`crate::objects::PositionShader`, as [`ShaderObjectPosition`] decides): one with revz's
//! carrier in its ranges, where its stage reads it, one storing `Position` through the pushed
//! carrier, with a pipeline's facts for the state machine ([`pushed_route`]); the others one
//! with the carrier baked in.
//!
//! - The application's `vkCreateShadersEXT` goes down with revz's carrier reserved in every
//!   create info's push-constant ranges, as in pipeline layouts (so that the layouts the
//!   application pushes with stay compatible), and otherwise unchanged. Variants are created before
//!   it, one call per variant, from the application's create info with only the code replaced
//!   (its chain, flags, layouts, push constant ranges and specialization kept, no allocator):
//!   should a structure of that shared chain be written by creation (as creation feedback is
//!   for pipelines), the application's call, made last, leaves its own results there; the
//!   application's handles and result are never touched. A variant whose application shader
//!   was not created is destroyed again; the application's handles are only read on `SUCCESS`
//!   and `INCOMPATIBLE_SHADER_BINARY_EXT`, where every one is written.
//! - Linked shaders (`VK_SHADER_CREATE_LINK_STAGE_BIT_EXT`): the stages of a linked set are
//!   compiled together and must be bound together, so a variant of one could not be bound in
//!   its place alone. Where some shader of the set gets a variant, the call goes down unlinked
//!   (its variants too: `policy::pipelines::LinkedSet`), and every shader of it is then an
//!   unlinked one like the others. Linking is an optimization: the shaders compute the same,
//!   and an application that binds every shader of its set (as it must) binds valid unlinked
//!   shaders, each with the `nextStage` the link required. A set with tessellation stages
//!   goes down unlinked only where its evaluation shader declares every tessellation mode
//!   itself (subdivision, spacing, vertex order: linked, the control stage may hold some
//!   alone; `policy::pipelines::tessellation_stands_alone`); otherwise it keeps its link, and
//!   such a fragment shader that computes with depth keeps standard depth in reversed
//!   attachments (marked, warned once at draw, as a pipeline's unreversed fragment shader
//!   is), and its last pre-rasterization stage takes the flip path. Linked binary code keeps
//!   its link too (nothing of it can be rewritten).
//! - Binary code (`VK_SHADER_CODE_TYPE_BINARY_EXT`) cannot be read or rewritten: binary fragment
//!   shaders get no variant and are marked as keeping standard depth (they may not compute
//!   with depth at all; logged once).
//! - Code the rewrite refuses is marked and logged once per code; a variant that cannot be
//!   created is logged once and marked; the application's call never fails because of revz.
//! - A variant is destroyed (without the application's allocator) with its application shader,
//!   and with the device for shaders the application never destroyed.

use std::sync::Arc;

use ash::vk;

use super::device_state;
use super::pipeline::{first_inline_report, Report};
use super::resources::slice;
use crate::boundary::{guarded, EntryPoint};
use crate::command_state::{PipelineDepth, States};
use crate::objects::{FragmentShader, PositionShader};
use crate::policy::pipelines::{
    tessellation_stands_alone, FragmentStage, FragmentVariant, LinkedSet, PipelinePath,
    ShaderObjectPlan, ShaderObjectPosition,
};
use crate::policy::vertex_stage::{
    entry_point_analysis, LastStage, Missing, MissingFact, VertexStageFacts,
};
use crate::precise;
use crate::shader::fragment_depth;
use crate::shader::scan::TessellationModes;
use crate::state::DeviceState;
use revz_math::DepthConvention;

static CREATE_SHADERS: EntryPoint = EntryPoint::new("vkCreateShadersEXT");
static DESTROY_SHADER: EntryPoint = EntryPoint::new("vkDestroyShaderEXT");

/// What revz makes of one shader create info.
#[derive(Debug)]
enum Plan {
    /// Neither a fragment shader that computes with depth nor, in a precise mode, a
    /// pre-rasterization shader that stores `Position`: nothing.
    Nothing,
    /// A fragment shader's reversed variant of the rewritten code.
    Variant(Arc<[u32]>),
    /// A fragment shader that computes with depth (or may, binary code) but gets no variant.
    Unreversed,
    /// A pre-rasterization shader's variant of its code storing `Position` through the pushed
    /// carrier, what draws need of it, and whether it projects the previous stage's
    /// `Position` (`PositionShader::Pushed`).
    Pushed(Arc<[u32]>, Box<PipelineDepth>, bool),
    /// A vertex, tessellation evaluation, geometry or mesh shader's variant of its code with
    /// the carrier baked in, and whether it projects the previous stage's `Position`
    /// (`PositionShader::Baked`).
    Baked(Arc<[u32]>, bool),
    /// Such a shader whose draws take the flip path, and whether it stores w = 1
    /// (`PositionShader::Flip`).
    PositionFlip { stores_unit_w: bool },
    /// A geometry shader passing the positions through (`PositionShader::PassesThrough`).
    PassesThrough,
}

impl Plan {
    /// Whether the plan makes a variant of the shader.
    fn makes_variant(&self) -> bool {
        matches!(self, Plan::Variant(_) | Plan::Pushed(..) | Plan::Baked(..))
    }
}

/// What revz made of one create info.
#[derive(Clone, Debug)]
enum Made {
    Fragment(FragmentShader),
    Position(PositionShader),
}

impl Made {
    fn variant(&self) -> Option<vk::ShaderEXT> {
        match self {
            Made::Fragment(fragment) => fragment.variant(),
            Made::Position(position) => position.variant(),
        }
    }
}

/// The push-constant ranges a create info gives (the application's, before revz reserved its
/// carrier in them).
fn app_ranges<'a>(info: &vk::ShaderCreateInfoEXT<'a>) -> &'a [vk::PushConstantRange] {
    // SAFETY: `pushConstantRangeCount` ranges (the application's contract).
    unsafe { slice(info.p_push_constant_ranges, info.push_constant_range_count) }
}

/// Whether a create info is part of its call's linked set.
fn is_linked(info: &vk::ShaderCreateInfoEXT<'_>) -> bool {
    info.flags.contains(vk::ShaderCreateFlagsEXT::LINK_STAGE)
}

/// The linked set of a `vkCreateShadersEXT` call's create infos (empty stages where the call
/// links nothing).
fn linked_set(infos: &[vk::ShaderCreateInfoEXT<'_>]) -> LinkedSet {
    let linked = || infos.iter().filter(|info| is_linked(info));
    let spirv = linked().all(|info| info.code_type == vk::ShaderCodeTypeEXT::SPIRV);
    // The tessellation modes of the linked shader of `stage` (read only for SPIR-V sets with
    // tessellation stages).
    let modes = |stage| {
        let info = linked().find(|info| info.stage == stage)?;
        // SAFETY: `codeSize` bytes of SPIR-V, aligned to 4 bytes (the application's contract).
        let words = unsafe { slice(info.p_code.cast::<u32>(), (info.code_size / 4) as u32) };
        crate::shader::scan::tessellation_modes(words)
    };
    let stages = linked().fold(vk::ShaderStageFlags::empty(), |all, info| all | info.stage);
    let tessellation_stands_alone = spirv
        && stages.contains(vk::ShaderStageFlags::TESSELLATION_EVALUATION)
        && tessellation_stands_alone(
            modes(vk::ShaderStageFlags::TESSELLATION_CONTROL).or_else(|| {
                // No linked control stage: nothing the evaluation stage could lean on.
                (!stages.contains(vk::ShaderStageFlags::TESSELLATION_CONTROL))
                    .then(TessellationModes::default)
            }),
            modes(vk::ShaderStageFlags::TESSELLATION_EVALUATION),
        );
    LinkedSet {
        stages,
        spirv,
        tessellation_stands_alone,
    }
}

/// The plan of one create info: a fragment shader's from what the policy gives its code
/// ([`FragmentStage::variant`]; a shader of a set that keeps its link, `linked`, gets no
/// variant), a
/// pre-rasterization shader's, where the mode rewrites, from
/// [`ShaderObjectPosition::decide`]. `info` has revz's carrier reserved in its ranges where
/// `reserved` says so; `ranges` are the application's.
fn plan(
    state: &DeviceState,
    device: vk::Device,
    info: &vk::ShaderCreateInfoEXT<'_>,
    ranges: &[vk::PushConstantRange],
    reserved: Option<&Reserved>,
    linked: bool,
) -> Plan {
    let rewriting = state.policy.rewrite().is_some();
    if rewriting && crate::command_state::POSITION_STAGES.contains(&info.stage) {
        return position_plan(state, device, info, ranges, reserved, linked);
    }
    if rewriting && info.stage == vk::ShaderStageFlags::TESSELLATION_CONTROL {
        // A control shader that copies the positions on: with an evaluation shader that
        // interpolates them, the stage bound before is the one precise-path draws rewrite.
        let copies = info.code_type == vk::ShaderCodeTypeEXT::SPIRV && {
            // SAFETY: `codeSize` bytes of SPIR-V (the application's contract).
            let words = unsafe { slice(info.p_code.cast::<u32>(), (info.code_size / 4) as u32) };
            crate::shader::tessellation_positions::control_passes_positions_through(words)
        };
        return if copies {
            Plan::PassesThrough
        } else {
            Plan::Nothing
        };
    }
    if info.stage != vk::ShaderStageFlags::FRAGMENT {
        return Plan::Nothing;
    }
    let (stage, rewritten) = match info.code_type {
        vk::ShaderCodeTypeEXT::BINARY => (FragmentStage::Unknown, None),
        vk::ShaderCodeTypeEXT::SPIRV => {
            // SAFETY: `codeSize` bytes of SPIR-V, aligned to 4 bytes (the application's
            // contract).
            let words = unsafe { slice(info.p_code.cast::<u32>(), (info.code_size / 4) as u32) };
            if state.policy.converts_input_reads()
                && crate::shader::input_depth::reads_input_attachments(words)
            {
                // Which input attachment reads depth is command buffer state for shader
                // objects (`vkCmdSetRenderingInputAttachmentIndices`), not known here.
                static INPUTS: crate::logging::LogOnce = crate::logging::LogOnce::new();
                INPUTS.log(|| {
                    log::warn!(
                        "a fragment shader object reads input attachments (dynamic \
                         rendering's local reads): revz does not convert the depth it may \
                         read there, which is reversed where the depth attachment is"
                    )
                });
            }
            match fragment_depth::reverse_fragment_depth(words) {
                Ok(None) => (FragmentStage::NoDepth, None),
                Ok(Some(code)) => (FragmentStage::Rewritable, Some(code)),
                Err(reason) => {
                    if first_inline_report(Report::Rewrite, words) {
                        log::warn!(
                            "a fragment shader object computes with depth in a way revz cannot \
                             rewrite ({reason}): its draws into reversed attachments keep \
                             standard depth"
                        );
                    }
                    (FragmentStage::CannotRewrite, None)
                }
            }
        }
        // Code of a type revz does not know: left alone.
        _ => return Plan::Nothing,
    };
    match (stage.variant(!linked), rewritten) {
        (FragmentVariant::Rewritten, Some(code)) => Plan::Variant(code.into()),
        (FragmentVariant::Unchanged | FragmentVariant::Rewritten, _) => Plan::Nothing,
        (FragmentVariant::Unreversed, _) => {
            match stage {
                FragmentStage::Unknown => {
                    static BINARY: crate::logging::LogOnce = crate::logging::LogOnce::new();
                    BINARY.log(|| {
                        log::warn!(
                            "a fragment shader object is created from binary code: revz cannot \
                             read it, so if it computes with depth (FragDepth or FragCoord.z), \
                             its draws into reversed attachments keep standard depth"
                        )
                    });
                }
                FragmentStage::Rewritable => {
                    static LINKED: crate::logging::LogOnce = crate::logging::LogOnce::new();
                    LINKED.log(|| {
                        log::warn!(
                            "a fragment shader object linked with tessellation stages \
                             (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT) computes with depth: revz \
                             keeps such sets linked, so its \
                             draws into reversed attachments keep standard depth (create it \
                             unlinked to have it reversed)"
                        )
                    });
                }
                // Logged with the rewrite's reason.
                FragmentStage::CannotRewrite | FragmentStage::NoDepth => {}
            }
            Plan::Unreversed
        }
    }
}

/// A create info's push-constant ranges with revz's carrier reserved, and where it lies.
type Reserved = (Vec<vk::PushConstantRange>, precise::Carrier);

/// The plan of a vertex, tessellation evaluation, geometry or mesh shader in a precise mode, as
/// the policy decides ([`ShaderObjectPosition`]): a shader whose ranges hold the carrier takes a
/// pipeline's last stage's route where it gives a precise range ([`pushed_route`]);
/// otherwise the deriving `Position` rewrite of its code with the carrier baked in
/// (complementary depth, as for a pipeline layout without room for the carrier).
fn position_plan(
    state: &DeviceState,
    device: vk::Device,
    info: &vk::ShaderCreateInfoEXT<'_>,
    ranges: &[vk::PushConstantRange],
    reserved: Option<&Reserved>,
    linked: bool,
) -> Plan {
    let spirv = match info.code_type {
        vk::ShaderCodeTypeEXT::SPIRV => true,
        vk::ShaderCodeTypeEXT::BINARY => false,
        _ => return Plan::Nothing,
    };
    let words = spirv.then(|| {
        // SAFETY: `codeSize` bytes of SPIR-V, aligned to 4 bytes (the application's contract).
        unsafe { slice(info.p_code.cast::<u32>(), (info.code_size / 4) as u32) }
    });
    let pushed = match (words, reserved) {
        (Some(words), Some(reserved)) if !linked => {
            Some(pushed_route(state, device, info, words, ranges, reserved))
        }
        _ => None,
    };
    // The baked rewrite, made only where the pushed route does not apply.
    let rewrite = match (words.filter(|_| !linked), &pushed) {
        (_, Some(Ok(_))) | (None, _) => Ok(None),
        (Some(words), _) => super::pipeline::baked_code(state, words),
    };
    let facts = ShaderObjectPosition {
        spirv,
        linked,
        pushed: pushed
            .as_ref()
            .map(|route| route.as_ref().map(|_| ()).map_err(String::as_str)),
        rewrite: rewrite
            .as_ref()
            .map(|r| r.as_ref().map(|r| r.assumes_input_unit_w))
            .map_err(|reason| *reason),
        // Asked only where no route of its own applies (the module is read once more): a
        // geometry shader passing the positions through, an evaluation shader interpolating
        // them (which counts only after a control shader that copies them: `CommandState`).
        passes_through: rewrite.is_err()
            && words.is_some_and(|words| match info.stage {
                vk::ShaderStageFlags::GEOMETRY => {
                    crate::shader::position_store::passes_position_through(words)
                }
                vk::ShaderStageFlags::TESSELLATION_EVALUATION => {
                    crate::shader::tessellation_positions::evaluation_interpolates_positions(words)
                }
                _ => false,
            }),
    };
    match (facts.decide(), pushed, rewrite) {
        (ShaderObjectPlan::PassesThrough, ..) => Plan::PassesThrough,
        (ShaderObjectPlan::Pushed, Some(Ok((code, depth, projects_input))), _) => {
            Plan::Pushed(code, Box::new(depth), projects_input)
        }
        (ShaderObjectPlan::Baked, _, Ok(Some(rewrite))) => {
            Plan::Baked(rewrite.code, rewrite.assumes_input_unit_w)
        }
        (ShaderObjectPlan::Flip(reason), pushed, _) => {
            let first = words.is_none_or(|w| first_inline_report(Report::Analysis, w));
            if first {
                let as_vertex = match pushed {
                    Some(Err(pushed)) => format!("; with revz's pushed carrier: {pushed}"),
                    _ => String::new(),
                };
                log::info!(
                    "a {:?} shader object's draws into reversed attachments take the flip path \
                     ({reason}{as_vertex})",
                    info.stage
                );
            }
            // A later stage projecting its positions relies on their w = 1 (asked only of
            // stages another can follow, on devices that enabled such stages).
            let before_another = matches!(
                info.stage,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::TESSELLATION_EVALUATION
            );
            let stores_unit_w = before_another
                && state.policy.carrier_later_stages.intersects(
                    vk::ShaderStageFlags::GEOMETRY | vk::ShaderStageFlags::TESSELLATION_EVALUATION,
                )
                && words.is_some_and(crate::shader::position_store::stores_position_w_one);
            Plan::PositionFlip { stores_unit_w }
        }
        _ => Plan::Nothing,
    }
}

/// A pre-rasterization shader object's route as a pipeline's last pre-rasterization stage
/// (issue #41): its analysis and `Position` rewrite reading the pushed carrier (made once per
/// distinct code, as for inline code of pipelines: a vertex stage's projection in push
/// constants read by naga, any stage's matrix fitted where it loads it, and located for the
/// CPU where it loads it whole from a push-constant member), what
/// [`VertexStageFacts::decide`] makes of them with the application's ranges (`ranges`) and
/// revz's carrier in them (`reserved`), and revz's layout of those ranges, which the carrier
/// goes down with where the application pushes nothing. The clip depth is taken as [0, 1]:
/// draws the application sets to [-1, 1] take the flip path where the CPU classifies the
/// projection (`crate::command_state`). A stage that projects the previous stage's
/// `Position` is taken as if that stage stored w = 1 (the third value returned): its variant
/// is bound only after a shader storing w = 1, which draws check. `Err`: why the route does
/// not apply.
fn pushed_route(
    state: &DeviceState,
    device: vk::Device,
    info: &vk::ShaderCreateInfoEXT<'_>,
    words: &[u32],
    ranges: &[vk::PushConstantRange],
    (reserved_ranges, carrier): &Reserved,
) -> Result<(Arc<[u32]>, PipelineDepth, bool), String> {
    let (analysis, rewrite) = super::pipeline::vertex_code(state, vk::ShaderModule::null(), words);
    let rewrite = rewrite
        .ok_or(Missing::NotMade(MissingFact::InlineWithoutRewrite.reason()))
        .and_then(|r| r.map_err(Missing::Unsupported));
    let projects_input = rewrite.as_ref().is_ok_and(|r| r.needs_input_unit_w);
    // SAFETY: a NUL-terminated entry point name (the application's contract).
    let name = unsafe { crate::ffi::c_str(info.p_name) };
    let last_stage = LastStage::of([info.stage]);
    let facts = VertexStageFacts {
        code_given: true,
        last_stage,
        carrier_reaches_stage: last_stage.is_some_and(|last| carrier.stages.contains(last.flag())),
        analysis: entry_point_analysis(Ok(&analysis), name.map(std::ffi::CStr::to_bytes)),
        ranges: Some(ranges),
        convention: Some(DepthConvention::ZeroToOne),
        carrier_room: true,
        baked: None,
        rewrite: rewrite.as_ref().map(|r| r.derived).map_err(|m| *m),
        derived_slot: rewrite.as_ref().ok().and_then(|r| r.push_slot),
        // The previous stage's Position, where the stage projects it: not known here, taken
        // as w = 1 and checked by draws against the shaders bound before it.
        input_unit_w: projects_input.then_some(true),
    };
    let range = facts.decide()?;
    let code = rewrite
        .map_err(|_| MissingFact::Incomplete.reason().to_owned())?
        .code;
    let layout = super::pipeline::push_layout(state, device, reserved_ranges)
        .ok_or("revz's pipeline layout of its push-constant ranges could not be made")?;
    Ok((
        code,
        PipelineDepth {
            // Every state of a draw with shader objects is dynamic.
            app_dynamic: States::ALL,
            projection: range.projection,
            position_store: Some(*carrier),
            derived_range: range.derived,
            layout,
            ..PipelineDepth::default()
        },
        projects_input,
    ))
}

/// Whether a plan's variant projects the previous stage's `Position` (assuming its w = 1).
fn projects_input(plan: &Plan) -> bool {
    matches!(plan, Plan::Pushed(_, _, true) | Plan::Baked(_, true))
}

/// `plans` of a call's create infos `infos`, where a linked set holds the stages before a
/// shader whose variant projects the previous stage's `Position`: the set is bound whole, so
/// whether those stages give w = 1 is known now (the rule draws apply to separately bound
/// shaders, `CommandState::input_unit_w`); where they do not, the variant could never be
/// bound, and would only send the set down unlinked, so the shader takes the flip path.
/// Sets without those stages, and unlinked shaders, keep their plans.
fn without_unusable_input_variants(
    mut plans: Vec<Plan>,
    infos: &[vk::ShaderCreateInfoEXT<'_>],
) -> Vec<Plan> {
    let unusable: Vec<bool> = {
        let linked = |stage: vk::ShaderStageFlags| {
            infos
                .iter()
                .zip(&plans)
                .find(|(info, _)| is_linked(info) && info.stage == stage)
                .map(|(_, plan)| plan)
        };
        let stores_unit_w = |plan: &Plan| {
            matches!(
                plan,
                Plan::PositionFlip {
                    stores_unit_w: true
                }
            )
        };
        let vertex = linked(vk::ShaderStageFlags::VERTEX);
        let control = linked(vk::ShaderStageFlags::TESSELLATION_CONTROL);
        let evaluation = linked(vk::ShaderStageFlags::TESSELLATION_EVALUATION);
        // Whether the set's control and vertex stages give the evaluation stage w = 1
        // (`None`: one of them is not in the set).
        let patch_unit_w = control.zip(vertex).map(|(control, vertex)| {
            matches!(control, Plan::PassesThrough) && stores_unit_w(vertex)
        });
        infos
            .iter()
            .zip(&plans)
            .map(|(info, plan)| {
                if !(is_linked(info) && projects_input(plan)) {
                    return false;
                }
                let gives_unit_w = match info.stage {
                    vk::ShaderStageFlags::GEOMETRY => match evaluation {
                        Some(evaluation) if stores_unit_w(evaluation) => Some(true),
                        Some(Plan::PassesThrough) => patch_unit_w,
                        Some(_) => Some(false),
                        None => vertex.map(stores_unit_w),
                    },
                    vk::ShaderStageFlags::TESSELLATION_EVALUATION => patch_unit_w,
                    _ => None,
                };
                gives_unit_w == Some(false)
            })
            .collect()
    };
    for (plan, unusable) in plans.iter_mut().zip(unusable) {
        if unusable {
            log::debug!(
                "a linked shader object projecting the previous stage's Position \
                 (gl_in[i].gl_Position) follows stages of its set that do not give w = 1: it \
                 takes the flip path (its set keeps its link unless another of its shaders \
                 gets a variant)"
            );
            *plan = Plan::PositionFlip {
                stores_unit_w: false,
            };
        }
    }
    plans
}

/// What the log adds of a variant projecting the previous stage's `Position`.
fn after_unit_w(projects_input: bool) -> &'static str {
    if projects_input {
        " where the stage bound before it stores w = 1 (it projects gl_in[i].gl_Position; \
         other draws take the flip path)"
    } else {
        ""
    }
}

/// Creates a variant of a shader object: its create info with the code replaced by `code`,
/// through the next layer, without an allocator (revz's own object). `None` when it cannot
/// be made (logged once, with what that costs: `lost`).
fn create_variant(
    device: vk::Device,
    next: vk::PFN_vkCreateShadersEXT,
    info: &vk::ShaderCreateInfoEXT<'_>,
    code: &[u32],
    failed: &'static crate::logging::LogOnce,
    lost: &str,
) -> Option<vk::ShaderEXT> {
    let variant_info = vk::ShaderCreateInfoEXT {
        code_size: std::mem::size_of_val(code),
        p_code: code.as_ptr().cast(),
        ..*info
    };
    let mut variant = vk::ShaderEXT::null();
    // SAFETY: the application's create info with revz's code, which outlives the call; one
    // handle written.
    let result = unsafe { next(device, 1, &variant_info, std::ptr::null(), &mut variant) };
    if result == vk::Result::SUCCESS && variant != vk::ShaderEXT::null() {
        return Some(variant);
    }
    failed.log(|| {
        log::warn!(
            "the variant of a {:?} shader object could not be created ({result:?}): {lost}",
            info.stage
        )
    });
    None
}

/// Destroys a shader object of revz's own through the next layer.
///
/// # Safety
/// `shader` was created by revz on `device` and is not in use.
unsafe fn destroy_down(state: &DeviceState, device: vk::Device, shader: vk::ShaderEXT) {
    if let Some(destroy) = state.commands.destroy_shader_ext {
        // SAFETY: the caller's contract; revz's own object, so no allocator.
        unsafe { destroy(device, shader, std::ptr::null()) };
    }
}

pub unsafe extern "system" fn create_shaders_ext(
    device: vk::Device,
    count: u32,
    p_create_infos: *const vk::ShaderCreateInfoEXT<'_>,
    p_allocator: *const vk::AllocationCallbacks<'_>,
    p_shaders: *mut vk::ShaderEXT,
) -> vk::Result {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // revz hands this hook out only where the next layer has the command.
    let Some(next) = state.commands.create_shaders_ext else {
        return vk::Result::ERROR_INITIALIZATION_FAILED;
    };
    // SAFETY: `count` create infos.
    let app_infos = unsafe { slice(p_create_infos, count) };
    // Shader objects give their push-constant ranges themselves: they get revz's carrier
    // reserved as pipeline layouts do (`crate::precise::reserve_carrier`), so that they stay
    // compatible with the layouts the application pushes with.
    let reserved: Vec<Option<Reserved>> = guarded(
        &CREATE_SHADERS,
        || {
            let Some(offset) = state.policy.carrier_offset else {
                return Vec::new();
            };
            app_infos
                .iter()
                .map(|info| {
                    // SAFETY: `pushConstantRangeCount` ranges (the application's contract).
                    let ranges = unsafe {
                        slice(info.p_push_constant_ranges, info.push_constant_range_count)
                    };
                    precise::reserve_carrier(ranges, offset, state.policy.carrier_later_stages).ok()
                })
                .collect()
        },
        Vec::new,
    );
    let mut modified: Vec<vk::ShaderCreateInfoEXT<'_>> = app_infos
        .iter()
        .enumerate()
        .map(
            |(index, info)| match reserved.get(index).and_then(Option::as_ref) {
                Some((ranges, _)) => vk::ShaderCreateInfoEXT {
                    push_constant_range_count: ranges.len() as u32,
                    p_push_constant_ranges: ranges.as_ptr(),
                    ..*info
                },
                None => *info,
            },
        )
        .collect();
    // The call's linked set: planned as unlinked shaders where it may go down unlinked, and
    // sent unlinked where one of its shaders then gets a variant (`LinkedSet::unlinks`), so
    // that each variant can be bound in its shader's place alone.
    let linked_set = linked_set(app_infos);
    let keeps_link = !linked_set.stages.is_empty() && !linked_set.may_unlink();
    // Each create info's plan (before any variant is made).
    let plans: Vec<Plan> = guarded(
        &CREATE_SHADERS,
        || {
            if !crate::policy::pipelines::shader_object_variants(state.policy.is_active()) {
                return Vec::new();
            }
            modified
                .iter()
                .enumerate()
                .map(|(index, info)| {
                    let reserved = reserved.get(index).and_then(Option::as_ref);
                    let linked = keeps_link && is_linked(info);
                    plan(
                        &state,
                        device,
                        info,
                        app_ranges(&app_infos[index]),
                        reserved,
                        linked,
                    )
                })
                .collect()
        },
        Vec::new,
    );
    let plans = without_unusable_input_variants(plans, &modified);
    let unlink = linked_set.unlinks(plans.iter().any(Plan::makes_variant));
    if unlink {
        static UNLINKED: crate::logging::LogOnce = crate::logging::LogOnce::new();
        UNLINKED.log(|| {
            log::info!(
                "shader objects created linked (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT) go down \
                 unlinked, so that revz can bind its variants of them one stage at a time for \
                 draws into reversed attachments (linking lets the driver optimize across the \
                 stages; the shaders compute the same without it)"
            )
        });
        for info in &mut modified {
            info.flags &= !vk::ShaderCreateFlagsEXT::LINK_STAGE;
        }
    }
    let infos = &modified[..];
    let p_create_infos = if reserved.is_empty() && !unlink {
        p_create_infos
    } else {
        modified.as_ptr()
    };
    // Before the application's call (see the module comment): each create info's variant, or
    // its mark; `None` for shaders revz leaves alone.
    // Filled one create info at a time, so that a panic caught partway keeps what was made
    // before it (recorded, and destroyed with its shader, like the others).
    let made: std::cell::RefCell<Vec<Option<Made>>> = std::cell::RefCell::default();
    guarded(
        &CREATE_SHADERS,
        || {
            static FRAGMENT_FAILED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            static POSITION_FAILED: crate::logging::LogOnce = crate::logging::LogOnce::new();
            for (info, plan) in infos.iter().zip(plans) {
                let one = match plan {
                    Plan::Nothing => None,
                    Plan::Unreversed => Some(Made::Fragment(FragmentShader::Unreversed)),
                    Plan::Variant(code) => Some(Made::Fragment(
                        create_variant(
                            device,
                            next,
                            info,
                            &code,
                            &FRAGMENT_FAILED,
                            "its draws into reversed attachments keep standard depth",
                        )
                        .map_or(FragmentShader::Unreversed, FragmentShader::Reversed),
                    )),
                    Plan::Pushed(code, depth, projects_input) => Some(Made::Position(
                        create_variant(
                            device,
                            next,
                            info,
                            &code,
                            &POSITION_FAILED,
                            "its draws into reversed attachments take the flip path",
                        )
                        .map_or(
                            PositionShader::Flip {
                                stores_unit_w: false,
                            },
                            |variant| PositionShader::Pushed {
                                variant,
                                depth: Arc::new(*depth),
                                projects_input,
                            },
                        ),
                    )),
                    Plan::Baked(code, projects_input) => Some(Made::Position(
                        create_variant(
                            device,
                            next,
                            info,
                            &code,
                            &POSITION_FAILED,
                            "its draws into reversed attachments take the flip path",
                        )
                        .map_or(
                            PositionShader::Flip {
                                stores_unit_w: false,
                            },
                            |variant| PositionShader::Baked {
                                variant,
                                projects_input,
                            },
                        ),
                    )),
                    Plan::PositionFlip { stores_unit_w } => {
                        Some(Made::Position(PositionShader::Flip { stores_unit_w }))
                    }
                    Plan::PassesThrough => Some(Made::Position(PositionShader::PassesThrough)),
                };
                made.borrow_mut().push(one);
            }
        },
        || (),
    );
    let variants = made.into_inner();
    // SAFETY: calling down with the application's arguments (push-constant ranges with revz's
    // carrier reserved).
    let result = unsafe { next(device, count, p_create_infos, p_allocator, p_shaders) };
    super::record(&CREATE_SHADERS, || {
        // Every handle is written on these results (null where creation failed).
        let written = matches!(
            result,
            vk::Result::SUCCESS | vk::Result::INCOMPATIBLE_SHADER_BINARY_EXT
        );
        if let (Some(profile), true) = (&state.profile, written) {
            for (index, info) in infos.iter().enumerate() {
                // SAFETY: `count` handles written (checked above).
                let shader = unsafe { *p_shaders.add(index) };
                let kind = match info.stage {
                    vk::ShaderStageFlags::VERTEX => "vertex shader object",
                    vk::ShaderStageFlags::TESSELLATION_EVALUATION => {
                        "tessellation evaluation shader object"
                    }
                    vk::ShaderStageFlags::GEOMETRY => "geometry shader object",
                    vk::ShaderStageFlags::MESH_EXT => "mesh shader object",
                    _ => continue,
                };
                if shader != vk::ShaderEXT::null() {
                    let position = match variants.get(index) {
                        Some(Some(Made::Position(position))) => Some(position),
                        _ => None,
                    };
                    let projection = match position {
                        Some(PositionShader::Pushed { depth, .. }) => {
                            PipelinePath::of(depth.projection, depth.derived_range, false, None)
                                .to_string()
                        }
                        Some(PositionShader::Baked { .. }) => {
                            "fitted by the shader, the carrier baked into its variant".to_owned()
                        }
                        Some(PositionShader::PassesThrough) => {
                            "passed through from the stage before it".to_owned()
                        }
                        _ => "not fitted: the flip path (the log says why)".to_owned(),
                    };
                    let variant = position.is_some_and(|p| p.variant().is_some());
                    profile.pipeline(
                        vk::Handle::as_raw(shader),
                        crate::profile::PipelineRecord {
                            kind,
                            path: crate::policy::pipelines::shader_object_vertex_path(
                                state.policy.is_active(),
                                variant,
                            ),
                            projection,
                            reversed_variant: variant,
                            promoted_variant: false,
                            converts_depth_inputs: false,
                        },
                    );
                }
            }
        }
        for (index, depth) in variants.into_iter().enumerate() {
            let Some(depth) = depth else { continue };
            let shader = if written {
                // SAFETY: `count` handles written (checked above).
                unsafe { *p_shaders.add(index) }
            } else {
                vk::ShaderEXT::null()
            };
            if shader != vk::ShaderEXT::null() {
                match depth {
                    Made::Fragment(fragment) => {
                        if let FragmentShader::Reversed(variant) = fragment {
                            log::debug!(
                                "fragment shader object {shader:?} computes with depth; \
                                 {variant:?}, with its code rewritten, draws into reversed \
                                 attachments"
                            );
                        }
                        state.objects.fragment_shaders.insert(shader, fragment);
                    }
                    Made::Position(position) => {
                        match &position {
                            PositionShader::Pushed {
                                variant,
                                depth,
                                projects_input,
                            } => log::debug!(
                                "shader object {shader:?}: {variant:?}, its code storing \
                                 Position through revz's pushed carrier, stores its depth for \
                                 precise-path draws ({}){}",
                                PipelinePath::of(
                                    depth.projection,
                                    depth.derived_range,
                                    false,
                                    None
                                ),
                                after_unit_w(*projects_input)
                            ),
                            PositionShader::Baked {
                                variant,
                                projects_input,
                            } => log::debug!(
                                "shader object {shader:?}: {variant:?}, its code fitting the \
                                 matrix it loads with the carrier baked in, stores its depth \
                                 for precise-path draws{}",
                                after_unit_w(*projects_input)
                            ),
                            PositionShader::PassesThrough => log::debug!(
                                "{:?} shader object {shader:?} passes the positions of the \
                                 stage before it through: that stage's variant stores the depth \
                                 of precise-path draws",
                                infos[index].stage
                            ),
                            PositionShader::Flip { .. } => {}
                        }
                        state.objects.position_shaders.insert(shader, position);
                    }
                }
            } else if let Some(variant) = depth.variant() {
                // SAFETY: revz's own object, never handed out.
                unsafe { destroy_down(&state, device, variant) };
            }
        }
    });
    result
}

pub unsafe extern "system" fn destroy_shader_ext(
    device: vk::Device,
    shader: vk::ShaderEXT,
    p_allocator: *const vk::AllocationCallbacks<'_>,
) {
    // SAFETY: `device` is live.
    let Some(state) = (unsafe { device_state(device) }) else {
        return;
    };
    super::record(&DESTROY_SHADER, || {
        let fragment = state
            .objects
            .fragment_shaders
            .remove(&shader)
            .and_then(FragmentShader::variant);
        let position = state
            .objects
            .position_shaders
            .remove(&shader)
            .and_then(|position| position.variant());
        for variant in fragment.into_iter().chain(position) {
            // SAFETY: revz's own object, in use only where the application's shader was.
            unsafe { destroy_down(&state, device, variant) };
        }
    });
    if let Some(destroy) = state.commands.destroy_shader_ext {
        // SAFETY: calling down with the application's arguments.
        unsafe { destroy(device, shader, p_allocator) };
    }
}
