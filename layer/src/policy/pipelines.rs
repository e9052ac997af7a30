//! What revz makes of a graphics pipeline (and of a fragment shader object): whether it has a
//! depth attachment ([`has_depth_attachment`]), which of its static states become dynamic
//! ([`StaticStateFacts::decide`]), which variants it gets ([`VariantFacts::decide`]), whether
//! it draws into promoted attachments ([`PromotionFacts::decide`]), what a fragment stage that
//! computes with depth gets ([`FragmentStage::variant`], shared with
//! `crate::hooks::shader_object`), and which path its draws take, as logged and shown in the
//! depth profile ([`PipelinePath`]); and which of a batch's pipelines are taken back where a
//! variant needs compiling ([`TakeBack`]).
//!
//! The facts come from `vkCreateGraphicsPipelines` (`crate::hooks::pipeline` reads the create
//! info, only the state the spec says to read and in its order, records the static values
//! itself, and looks up its modules, libraries and render pass) and `vkCreateShadersEXT`
//! (`crate::hooks::shader_object`); the hooks log and make the driver calls, this module only
//! decides.

use ash::vk;

use crate::command_state::States;
use crate::conv::flip_compare_op;
use crate::precise::ProjectionUse;
use crate::shader::derived_range::MatrixSource;
use crate::shader::scan::TessellationModes;

/// Where a graphics pipeline create info's attachments come from, and what it says of depth
/// there (the facts of [`has_depth_attachment`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthAttachmentFacts {
    /// It names a render pass: whether its subpass has a depth attachment (`false` where the
    /// pass is unknown or the subpass has none).
    RenderPass { subpass_depth: bool },
    /// No render pass, and it defines the fragment output interface: the depth format of its
    /// `VkPipelineRenderingCreateInfo` (`None`: it chains none).
    Rendering { depth_format: Option<vk::Format> },
    /// A library without a render pass or the fragment output interface: it does not say
    /// which attachments it draws into.
    NoFragmentOutput,
}

/// Whether a pipeline (or library) has a depth attachment: its render pass's subpass has one,
/// or its rendering formats name a depth format. A library without the fragment output
/// interface counts as having one: it may be linked with output state that renders depth,
/// and a fragment shader library without the attachment formats must give its depth state
/// (the spec's rule), so it is planned as rendering depth.
#[must_use]
pub fn has_depth_attachment(facts: DepthAttachmentFacts) -> bool {
    match facts {
        DepthAttachmentFacts::RenderPass { subpass_depth } => subpass_depth,
        DepthAttachmentFacts::Rendering { depth_format } => {
            depth_format.is_some_and(|format| format != vk::Format::UNDEFINED)
        }
        DepthAttachmentFacts::NoFragmentOutput => true,
    }
}

/// Whether a pipeline's draws can reach a depth attachment: it has one, and does not
/// statically discard every primitive. Otherwise the spec ignores its viewport and depth
/// state (possibly dangling), and nothing about its depth matters.
#[must_use]
pub fn renders_depth(
    has_depth_attachment: bool,
    rasterizer_discard: bool,
    app_dynamic: &[vk::DynamicState],
) -> bool {
    // A discard the application sets dynamically may be off at draw time.
    let discards =
        rasterizer_discard && !app_dynamic.contains(&vk::DynamicState::RASTERIZER_DISCARD_ENABLE);
    has_depth_attachment && !discards
}

/// Whether a pipeline's viewports are static (the application made neither `VIEWPORT` nor
/// `VIEWPORT_WITH_COUNT` dynamic): only then are they read, and made dynamic.
#[must_use]
pub fn viewports_static(app_dynamic: &[vk::DynamicState]) -> bool {
    !app_dynamic.contains(&vk::DynamicState::VIEWPORT)
        && !app_dynamic.contains(&vk::DynamicState::VIEWPORT_WITH_COUNT)
}

/// What [`StaticStateFacts::decide`] reads of a pipeline's depth-stencil state (given where
/// the pipeline renders depth and defines fragment shader state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthStencilFacts {
    pub compare_op: vk::CompareOp,
    pub depth_test_enable: bool,
    pub depth_bounds_test_enable: bool,
}

/// What [`StaticStateFacts::decide`] reads of a pipeline's depth bias (its rasterization
/// state, given where the pipeline renders depth and defines pre-rasterization state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthBiasFacts {
    /// `depthBiasEnable`.
    pub enable: bool,
    /// The bias has an explicit representation (`VkDepthBiasRepresentationInfoEXT`).
    pub represented: bool,
}

/// What revz knows of a pipeline's static depth-related state, gathered by the pipeline hook
/// from the subsets its create info defines.
#[derive(Clone, Copy, Debug)]
pub struct StaticStateFacts<'a> {
    pub has_depth_attachment: bool,
    /// The dynamic states the application listed.
    pub app_dynamic: &'a [vk::DynamicState],
    /// `rasterizerDiscardEnable` (false where the create info defines no rasterization state).
    pub rasterizer_discard: bool,
    /// Its depth-stencil state, where it defines fragment shader state.
    pub depth_stencil: Option<DepthStencilFacts>,
    /// Its depth bias, where it defines pre-rasterization state.
    pub depth_bias: Option<DepthBiasFacts>,
    /// How many static viewports it has (0 where it defines none, or they are dynamic).
    pub static_viewports: usize,
    /// The flipped compare op comes from a pipeline variant, not dynamic state
    /// (`DevicePolicy::compare_op_variants`).
    pub compare_op_variants: bool,
    /// The device has `vkCmdSetDepthBias2EXT`: a bias with an explicit representation can be
    /// sent again with it.
    pub bias_with_representation: bool,
    /// Its viewport state chains a user-defined depth clamp range
    /// (`VkPipelineViewportDepthClampControlCreateInfoEXT`, `VK_EXT_depth_clamp_control`).
    pub user_clamp_range: bool,
}

/// What revz does with a pipeline's static depth state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StaticStatePlan {
    /// Whether its draws can reach a depth attachment ([`renders_depth`]).
    pub renders_depth: bool,
    /// The states revz makes dynamic (the application left them static).
    pub made_dynamic: States,
    /// Whether the reversed variant is to flip the static compare op (the compare op is not
    /// made dynamic, and flipping changes it; whether the variant is made is
    /// [`Variants::compare_op`]).
    pub compare_op_variant: bool,
    /// The static compare op of a pipeline that tests depth (`None` where it does not, or
    /// where the application sets the compare op dynamically): evidence of the application's
    /// depth convention (`crate::policy::ConventionEvidence`).
    pub tested_compare_op: Option<vk::CompareOp>,
}

impl StaticStatePlan {
    /// The dynamic states revz adds to the application's list, in the order they are added.
    pub fn added_dynamic_states(&self) -> impl Iterator<Item = vk::DynamicState> {
        let made = self.made_dynamic;
        [
            (States::COMPARE_OP, vk::DynamicState::DEPTH_COMPARE_OP),
            (States::BOUNDS, vk::DynamicState::DEPTH_BOUNDS),
            (States::VIEWPORT, vk::DynamicState::VIEWPORT),
            (States::BIAS, vk::DynamicState::DEPTH_BIAS),
            (
                States::CLAMP_RANGE,
                crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE,
            ),
        ]
        .into_iter()
        .filter_map(move |(state, dynamic)| made.contains(state).then_some(dynamic))
    }
}

impl StaticStateFacts<'_> {
    /// Which static states become dynamic: in a pipeline that renders depth, the compare op of
    /// a depth test (unless it comes from a variant), the bounds of a bounds test, static
    /// viewports, an enabled bias (unless its explicit representation cannot be sent
    /// again), and a user-defined depth clamp range (depth values, mapped as the bounds: the
    /// range is read whether or not the clamp is enabled, which may be dynamic). State the
    /// application made dynamic is left to it.
    pub fn decide(&self) -> StaticStatePlan {
        let has = |state: vk::DynamicState| self.app_dynamic.contains(&state);
        let mut plan = StaticStatePlan {
            renders_depth: renders_depth(
                self.has_depth_attachment,
                self.rasterizer_discard,
                self.app_dynamic,
            ),
            ..StaticStatePlan::default()
        };
        if !plan.renders_depth {
            return plan;
        }
        if let Some(depth_stencil) = self.depth_stencil {
            let depth_test =
                depth_stencil.depth_test_enable || has(vk::DynamicState::DEPTH_TEST_ENABLE);
            if depth_test && !has(vk::DynamicState::DEPTH_COMPARE_OP) {
                plan.tested_compare_op = Some(depth_stencil.compare_op);
                if self.compare_op_variants {
                    plan.compare_op_variant =
                        flip_compare_op(depth_stencil.compare_op) != depth_stencil.compare_op;
                } else {
                    plan.made_dynamic |= States::COMPARE_OP;
                }
            }
            let bounds = depth_stencil.depth_bounds_test_enable
                || has(vk::DynamicState::DEPTH_BOUNDS_TEST_ENABLE);
            if bounds && !has(vk::DynamicState::DEPTH_BOUNDS) {
                plan.made_dynamic |= States::BOUNDS;
            }
        }
        if self.static_viewports > 0 && viewports_static(self.app_dynamic) {
            plan.made_dynamic |= States::VIEWPORT;
        }
        if let Some(bias) = self.depth_bias {
            let enabled = bias.enable || has(vk::DynamicState::DEPTH_BIAS_ENABLE);
            // A bias with an explicit representation (VK_EXT_depth_bias_control) goes down
            // again with vkCmdSetDepthBias2EXT and its representation; without that command it
            // cannot, and the pipeline keeps its static (unflipped) bias.
            let resendable = !bias.represented || self.bias_with_representation;
            if enabled && resendable && !has(vk::DynamicState::DEPTH_BIAS) {
                plan.made_dynamic |= States::BIAS;
            }
        }
        if self.user_clamp_range && !has(crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE) {
            plan.made_dynamic |= States::CLAMP_RANGE;
        }
        plan
    }
}

/// Whether revz can see the code a pipeline runs: neither a stage given by a shader module
/// identifier (`VK_EXT_shader_module_identifier`, its own or a linked library's) nor pipeline
/// binaries (`VK_KHR_pipeline_binary`). Otherwise there is no code to rewrite (a variant of
/// binaries would be the same pipeline), and with identifiers no compiling either: a variant
/// could only come from the cache (it keeps `FAIL_ON_PIPELINE_COMPILE_REQUIRED`:
/// VUID-VkPipelineShaderStageModuleIdentifierCreateInfoEXT-pNext-06851), where the flipped
/// state is not found, so the application's pipeline would be taken back every time. Such
/// pipelines (and those linking them) get no variants.
#[must_use]
pub fn code_given(identified: bool, from_binaries: bool) -> bool {
    !(identified || from_binaries)
}

/// Whether revz looks at a pipeline's fragment stage: the mode is active, the pipeline renders
/// depth and its create info defines fragment shader state (even without depth writes, a
/// fragment shader may read `FragCoord.z`).
#[must_use]
pub fn examines_fragment(active: bool, renders_depth: bool, defines_fragment_shader: bool) -> bool {
    active && renders_depth && defines_fragment_shader
}

/// What revz knows of a fragment stage's code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FragmentStage {
    /// revz cannot see the code that runs (binary code, identifiers, pipeline binaries): it
    /// may compute with depth.
    Unknown,
    /// It does not compute with depth (or there is no fragment stage).
    NoDepth,
    /// It computes with depth, and `crate::shader::fragment_depth` rewrote it.
    Rewritable,
    /// It computes with depth in a way the rewrite refuses.
    CannotRewrite,
}

/// What a fragment stage gets for draws into reversed attachments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FragmentVariant {
    /// Nothing: it does not compute with depth.
    Unchanged,
    /// A variant with its rewritten code, bound for draws into reversed attachments.
    Rewritten,
    /// No variant: it keeps standard depth in reversed attachments (marked, and warned once
    /// at draw).
    Unreversed,
}

impl FragmentStage {
    /// What the stage gets; `variant_allowed`: revz can make a variant of what holds it (a
    /// pipeline whose code is given, a shader object that is not part of a linked set).
    #[must_use]
    pub fn variant(self, variant_allowed: bool) -> FragmentVariant {
        match self {
            FragmentStage::NoDepth => FragmentVariant::Unchanged,
            FragmentStage::Rewritable if variant_allowed => FragmentVariant::Rewritten,
            FragmentStage::Unknown | FragmentStage::CannotRewrite | FragmentStage::Rewritable => {
                FragmentVariant::Unreversed
            }
        }
    }
}

/// What [`VariantFacts::decide`] reads of a pipeline, gathered at `vkCreateGraphicsPipelines`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VariantFacts {
    /// The mode acts on depth.
    pub active: bool,
    /// [`StaticStatePlan::renders_depth`].
    pub renders_depth: bool,
    /// A stage of it, or of a library it links, is given by a shader module identifier.
    pub identified: bool,
    /// It is made from pipeline binaries.
    pub from_binaries: bool,
    /// Its fragment stage, where revz looks at it ([`examines_fragment`]).
    pub fragment: Option<FragmentStage>,
    /// Its static compare op flips and comes from a variant
    /// ([`StaticStatePlan::compare_op_variant`]).
    pub compare_op_flips: bool,
    /// A library it links has a reversed variant (looked up where it renders depth).
    pub library_variants: bool,
    /// It draws into promoted attachments (`PromotionFacts::decide`).
    pub promotion: bool,
    /// Its fragment stage reads depth through input attachments, and
    /// `crate::shader::input_depth` rewrote it to convert what it reads.
    pub converts_inputs: InputReads,
    /// Its subpass (or rendering) has a depth attachment: its draws may go to a reversed one.
    pub depth_attachment: bool,
}

/// Where a pipeline reads the depth it converts through input attachments
/// ([`VariantFacts::converts_inputs`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InputReads {
    /// It reads none (or none revz converts).
    #[default]
    None,
    /// A render pass's subpass (or a link of a fragment shader library of one): the image it
    /// reads may be reversed where its depth attachment is not (a subpass reading depth
    /// without it attached), so it gets input variants beside its reversed ones.
    Subpass,
    /// Dynamic rendering's local reads (`VK_KHR_dynamic_rendering_local_read`): they read the
    /// rendering's own depth attachment, reversed exactly where that attachment is, so its
    /// reversed variants alone convert them (an input variant would never be bound).
    Rendering,
}

/// Which variant of a pipeline to make: for reversed attachments, promoted ones, or both; or,
/// for a pipeline that reads depth through input attachments, for reversed input attachments
/// where the depth attachment is not reversed (`inputs`: only the reads are converted).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VariantKind {
    pub reversed: bool,
    pub promoted: bool,
    pub inputs: bool,
}

impl VariantKind {
    pub const REVERSED: VariantKind = VariantKind {
        reversed: true,
        promoted: false,
        inputs: false,
    };
    pub const PROMOTED: VariantKind = VariantKind {
        reversed: false,
        promoted: true,
        inputs: false,
    };
    pub const PROMOTED_REVERSED: VariantKind = VariantKind {
        reversed: true,
        promoted: true,
        inputs: false,
    };
    pub const INPUTS: VariantKind = VariantKind {
        reversed: false,
        promoted: false,
        inputs: true,
    };
    pub const PROMOTED_INPUTS: VariantKind = VariantKind {
        reversed: false,
        promoted: true,
        inputs: true,
    };
}

/// The variants a pipeline gets, and what it keeps without them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Variants {
    /// The reversed variant flips the static compare op.
    pub compare_op: bool,
    /// The reversed variant has the fragment stage rewritten.
    pub rewritten_fragment: bool,
    /// The reversed variant links the linked libraries' reversed variants.
    pub linked_variants: bool,
    /// It gets promoted variants.
    pub promoted: bool,
    /// It keeps (or links) a fragment shader that may compute with depth, unreversed.
    pub unreversed_fragment: bool,
    /// It draws into promoted attachments but gets no promoted variant: its code is not
    /// given (logged).
    pub promotion_refused: bool,
    /// Its fragment stage converts the depth it reads through input attachments in its
    /// reversed variants (those for a reversed depth attachment, which its subpass's reversed
    /// input attachments are as a rule) and in its input variants (for reversed input
    /// attachments beside a native or no depth attachment).
    pub converted_inputs: bool,
    /// It gets input variants (its subpass's input attachments may be reversed where its
    /// depth attachment is not: [`InputReads::Subpass`]).
    pub input_variants: bool,
    /// Its subpass has a depth attachment (a reversed variant converting its input reads is
    /// needed only then).
    pub depth_attachment: bool,
    /// Its reversed variants have the last pre-rasterization stage with revz's carrier baked
    /// in ([`baked_stage_conflict`] found nothing against it): its layout has no room for the
    /// pushed carrier, and the variants are bound for its precise-path draws only.
    pub baked_vertex: bool,
}

/// Why a pipeline whose layout has no room for the carrier cannot take the precise path with
/// the carrier baked into its reversed variants: they would change something else too (a
/// flipped static compare op or depth bias, a rewritten fragment stage, linked libraries'
/// variants, converted input reads), which its flip-path draws into reversed attachments
/// need as well, and those draws bind it without the baked stage.
#[must_use]
pub fn baked_stage_conflict(variants: &Variants, variant_holds_bias: bool) -> Option<&'static str> {
    (variants.reversed() || variant_holds_bias).then_some(
        "its pipeline layout has no room for revz's push constants, and its reversed variant \
         already changes its compare op, depth bias, fragment stage or libraries",
    )
}

impl VariantFacts {
    /// [`code_given`] of the pipeline.
    #[must_use]
    pub fn code_given(&self) -> bool {
        code_given(self.identified, self.from_binaries)
    }

    /// Whether to warn that a pipeline's reversed variant cannot be made from its binaries: it
    /// renders depth in an active mode (known before its fragment stage is looked at, and
    /// warned then).
    #[must_use]
    pub fn warns_of_binaries(&self) -> bool {
        self.from_binaries && self.renders_depth && self.active
    }

    /// The variants: none where the code is not given (a fragment stage, or libraries with
    /// variants, then stay unreversed, and promotion is refused).
    #[must_use]
    pub fn decide(&self) -> Variants {
        let given = self.code_given();
        let fragment = self.fragment.map(|stage| {
            // What runs is not the code revz sees.
            let stage = if given { stage } else { FragmentStage::Unknown };
            stage.variant(given)
        });
        let libraries = self.renders_depth && self.library_variants;
        Variants {
            compare_op: self.compare_op_flips && given,
            rewritten_fragment: fragment == Some(FragmentVariant::Rewritten),
            linked_variants: libraries && given,
            promoted: self.promotion && given,
            unreversed_fragment: fragment == Some(FragmentVariant::Unreversed)
                || (libraries && !given),
            promotion_refused: self.promotion && !given,
            converted_inputs: self.converts_inputs != InputReads::None && given,
            input_variants: self.converts_inputs == InputReads::Subpass && given,
            depth_attachment: self.depth_attachment,
            baked_vertex: false,
        }
    }
}

impl Variants {
    /// Whether the pipeline gets a variant bound for draws into reversed attachments.
    #[must_use]
    pub fn reversed(&self) -> bool {
        self.baked_vertex
            || self.compare_op
            || self.rewritten_fragment
            || self.linked_variants
            || (self.converted_inputs && self.depth_attachment)
    }

    /// Whether the reversed variant holds a fragment stage revz changed (its own, rewritten, or
    /// the libraries' variants): without that variant the pipeline keeps (or links) the
    /// unreversed one.
    #[must_use]
    pub fn reversed_changes_fragment(&self) -> bool {
        self.rewritten_fragment
            || self.linked_variants
            || (self.converted_inputs && self.depth_attachment)
    }

    /// Whether the pipeline's own draws keep (or link) the unreversed fragment stage, its
    /// reversed variant `made` or not: where that variant was to hold the changed fragment
    /// stage and could not be made, nothing else reverses the fragment's depth.
    #[must_use]
    pub fn keeps_unreversed_fragment(&self, made: bool) -> bool {
        self.reversed_changes_fragment() && !made
    }

    /// The variants the pipeline gets, in the order they are made.
    pub fn kinds(&self) -> impl Iterator<Item = VariantKind> {
        let reversed = self.reversed();
        let promoted = self.promoted;
        let inputs = self.input_variants;
        [
            (reversed, VariantKind::REVERSED),
            (promoted, VariantKind::PROMOTED),
            (reversed && promoted, VariantKind::PROMOTED_REVERSED),
            (inputs, VariantKind::INPUTS),
            (inputs && promoted, VariantKind::PROMOTED_INPUTS),
        ]
        .into_iter()
        .filter_map(|(made, kind)| made.then_some(kind))
    }
}

/// What a pipeline's attachments say of promotion (`DevicePolicy::promoted_format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PromotionAttachments {
    /// The subsets its create info defines name no render pass or rendering formats (a
    /// vertex input library, a link).
    NotNamed,
    /// Its render pass is unknown to revz.
    UnknownPass,
    /// Its render pass: whether an attachment has a format revz promotes, and whether the pass
    /// has its promoted twin.
    Pass { promotable: bool, twin: bool },
    /// Dynamic rendering: whether its depth or stencil format is one revz promotes.
    Rendering { promotable: bool },
}

/// What [`PromotionFacts::decide`] reads, gathered at `vkCreateGraphicsPipelines`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PromotionFacts {
    /// UNORM depth images are promoted on this device (`DevicePolicy::promote`).
    pub promote: bool,
    pub attachments: PromotionAttachments,
    /// A library it links draws into promoted attachments.
    pub libraries_promotable: bool,
}

/// Whether a pipeline draws into promoted attachments, and how its promoted variants differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PipelinePromotion {
    /// It does not (or revz cannot tell: its render pass is unknown).
    None,
    /// Its render pass has promotable attachments but no promoted twin: its draws into
    /// promoted images use it as it is (logged), and it gets no promoted variants.
    MissingTwin,
    /// Its promoted variants are made with its render pass's promoted twin (`twin`), with the
    /// float rendering formats (`rendering`), and with the linked libraries' promoted variants.
    Promoted { twin: bool, rendering: bool },
}

impl PromotionFacts {
    /// The pipeline's promotion: its render pass has promotable attachments (and their twin),
    /// its rendering formats are promotable, or a library it links is promoted.
    #[must_use]
    pub fn decide(&self) -> PipelinePromotion {
        if !self.promote {
            return PipelinePromotion::None;
        }
        let (twin, rendering) = match self.attachments {
            PromotionAttachments::NotNamed
            | PromotionAttachments::Pass {
                promotable: false, ..
            } => (false, false),
            PromotionAttachments::UnknownPass => return PipelinePromotion::None,
            PromotionAttachments::Pass { twin: false, .. } => {
                return PipelinePromotion::MissingTwin
            }
            PromotionAttachments::Pass { twin: true, .. } => (true, false),
            PromotionAttachments::Rendering { promotable } => (false, promotable),
        };
        if twin || rendering || self.libraries_promotable {
            PipelinePromotion::Promoted { twin, rendering }
        } else {
            PipelinePromotion::None
        }
    }
}

/// Which path a pipeline's draws into reversed attachments take (`crate::policy::vertex_stage`
/// decided between the precise and the flip path), as logged and shown in the depth profile:
/// [`PipelinePath::label`] names the path, `Display` says where its projection comes from or
/// why it takes the flip path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PipelinePath<'a> {
    /// The precise path, with the projection in its push constants.
    Pushed(ProjectionUse),
    /// The same, read by a stage that also fits the matrix itself where it is no camera's (a
    /// later stage's push-constant projection, issue #41).
    PushedAndFitted(ProjectionUse),
    /// The precise path, its vertex stage deriving the range from the matrix it loads.
    Derived(MatrixSource),
    /// The same with the carrier baked into its reversed variants (its layout has no room for
    /// the pushed one).
    Baked(MatrixSource),
    /// The flip path, for this reason.
    Flip(&'a str),
    /// The flip path, no reason given: the mode does not rewrite depth (or the pipeline was no
    /// candidate for the precise path).
    NotRewritten,
}

impl<'a> PipelinePath<'a> {
    /// The path of a pipeline with a pushed `projection`, a `derived` range (`baked` into its
    /// variants or not), or a `flip_reason` (a pushed projection first, then a reason, then a
    /// derived range).
    #[must_use]
    pub fn of(
        projection: Option<ProjectionUse>,
        derived: Option<MatrixSource>,
        baked: bool,
        flip_reason: Option<&'a str>,
    ) -> PipelinePath<'a> {
        match (projection, flip_reason, derived) {
            (Some(projection), _, Some(_)) => PipelinePath::PushedAndFitted(projection),
            (Some(projection), _, None) => PipelinePath::Pushed(projection),
            (None, Some(reason), _) => PipelinePath::Flip(reason),
            (None, None, Some(source)) if baked => PipelinePath::Baked(source),
            (None, None, Some(source)) => PipelinePath::Derived(source),
            (None, None, None) => PipelinePath::NotRewritten,
        }
    }

    /// The path's name in the depth profile: `precise` or `flip`.
    #[must_use]
    pub fn label(&self) -> &'static str {
        match self {
            PipelinePath::Pushed(_)
            | PipelinePath::PushedAndFitted(_)
            | PipelinePath::Derived(_)
            | PipelinePath::Baked(_) => "precise",
            PipelinePath::Flip(_) | PipelinePath::NotRewritten => "flip",
        }
    }
}

impl std::fmt::Display for PipelinePath<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PipelinePath::Pushed(projection) => write!(
                f,
                "push-constant bytes {}..{}",
                projection.offset,
                projection.end()
            ),
            PipelinePath::PushedAndFitted(projection) => write!(
                f,
                "push-constant bytes {}..{}, fitted by the shader where they hold no camera's \
                 projection",
                projection.offset,
                projection.end()
            ),
            PipelinePath::Derived(source) => {
                write!(f, "{}, fitted by the shader", source.describe())
            }
            PipelinePath::Baked(source) => write!(
                f,
                "{}, fitted by the shader with the carrier baked into its reversed variants \
                 (no room in its layout)",
                source.describe()
            ),
            PipelinePath::Flip(reason) => f.write_str(reason),
            PipelinePath::NotRewritten => f.write_str("the mode does not rewrite depth"),
        }
    }
}

/// Whether a create info's variants could be made without compiling, where the application
/// asked for none (`FAIL_ON_PIPELINE_COMPILE_REQUIRED`): a fact of [`TakeBack`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VariantCompile {
    /// Its variants were made, not needed, or could not be made (logged).
    Done,
    /// One is not in the pipeline cache and needs compiling; `returns_early`: the create info
    /// asks for its batch to end at its failure (`EARLY_RETURN_ON_FAILURE`).
    Required { returns_early: bool },
}

impl VariantCompile {
    /// Whether the batch ends here, as a driver that failed here would end it: no more
    /// variants are made, and every later pipeline is taken back ([`TakeBack::takes`]).
    pub fn ends_batch(self) -> bool {
        matches!(
            self,
            VariantCompile::Required {
                returns_early: true
            }
        )
    }
}

/// Which of a batch's application pipelines revz takes back (destroys, and reports as needing
/// compilation) after the driver created them, create info by create info
/// ([`TakeBack::takes`]), and the batch's result then ([`TakeBack::result`]). A pipeline whose
/// variant needs compiling is taken back, so that the application's compiling call (without
/// `FAIL_ON_PIPELINE_COMPILE_REQUIRED`) makes both and draws never go without their variant;
/// after one in a create info asking for early return, every later one is taken back too, as
/// a driver that failed there would not have created them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TakeBack {
    taken_back: bool,
    returned_early: bool,
}

impl TakeBack {
    /// Whether the pipeline of the next create info (in the batch's order) is taken back.
    pub fn takes(&mut self, compile: VariantCompile) -> bool {
        let required = compile != VariantCompile::Done;
        let takes = required || self.returned_early;
        self.taken_back |= required;
        self.returned_early |= compile.ends_batch();
        takes
    }

    /// The batch's result, given the driver's (`result`): `PIPELINE_COMPILE_REQUIRED` where a
    /// pipeline was taken back for its variant and the driver succeeded; else the driver's.
    pub fn result(&self, result: vk::Result) -> vk::Result {
        if self.taken_back && result == vk::Result::SUCCESS {
            vk::Result::PIPELINE_COMPILE_REQUIRED
        } else {
            result
        }
    }
}

/// Whether the depth profile records a pipeline (its path and variants): only where it renders
/// depth ([`renders_depth`]); others draw nothing revz acts on, so their path says nothing.
#[must_use]
pub fn profiles_pipeline(renders_depth: bool) -> bool {
    renders_depth
}

/// Whether `vkCreateShadersEXT` plans variants of shader objects at all (a fragment one's:
/// [`FragmentStage::variant`]): only where revz acts on the device's depth (`active`);
/// elsewhere no code is read and no variant made.
#[must_use]
pub fn shader_object_variants(active: bool) -> bool {
    active
}

/// A `vkCreateShadersEXT` call's linked set (`VK_SHADER_CREATE_LINK_STAGE_BIT_EXT`: the
/// shaders are compiled together and must be bound together), as revz sees it before the call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkedSet {
    /// The stages of the shaders created linked (empty: the call links nothing).
    pub stages: vk::ShaderStageFlags,
    /// Their code is SPIR-V (a linked set's code types are all the same).
    pub spirv: bool,
    /// Its tessellation evaluation shader declares every tessellation mode the set's
    /// tessellation control shader declares ([`tessellation_stands_alone`]); `false` where
    /// the set has no tessellation stages.
    pub tessellation_stands_alone: bool,
}

/// Whether a linked tessellation evaluation shader of `evaluation`'s modes computes the same
/// unlinked, beside a control shader of `control`'s: it declares its subdivision, spacing and
/// vertex order itself (linked, the two stages' modes combine, and the control stage may hold
/// some alone; an unlinked evaluation shader must declare its subdivision, and the spacing
/// and order it does not declare would no longer come from the control stage), the same as
/// the control stage where that declares them too, and point mode where the control stage
/// asks for it. `None` (modes that could not be read) stands for nothing.
#[must_use]
pub fn tessellation_stands_alone(
    control: Option<TessellationModes>,
    evaluation: Option<TessellationModes>,
) -> bool {
    let (Some(control), Some(evaluation)) = (control, evaluation) else {
        return false;
    };
    let agrees = |own: Option<u32>, other: Option<u32>| {
        own.is_some() && other.is_none_or(|o| Some(o) == own)
    };
    agrees(evaluation.subdivision, control.subdivision)
        && agrees(evaluation.spacing, control.spacing)
        && agrees(evaluation.order, control.order)
        && (evaluation.point_mode || !control.point_mode)
}

impl LinkedSet {
    /// Whether the set may go down unlinked, so that its shaders get variants bound one stage
    /// at a time as unlinked shaders do (linking lets the driver optimize across the stages;
    /// the shaders compute the same without it, and a valid use of the linked set binds
    /// every shader of it, which stays valid unlinked: each keeps the `nextStage` the link
    /// required). Not binary code (revz cannot read or rewrite it, so nothing is gained),
    /// and a set with tessellation stages only where its evaluation shader stands alone
    /// ([`tessellation_stands_alone`]: linked, the two stages may split their modes).
    #[must_use]
    pub fn may_unlink(&self) -> bool {
        let tessellation = vk::ShaderStageFlags::TESSELLATION_CONTROL
            | vk::ShaderStageFlags::TESSELLATION_EVALUATION;
        !self.stages.is_empty()
            && self.spirv
            && (!self.stages.intersects(tessellation) || self.tessellation_stands_alone)
    }

    /// Whether the call goes down unlinked: where it may ([`Self::may_unlink`]) and some
    /// shader of it gets a variant (`variant_wanted`, decided as for unlinked shaders); a set
    /// revz would make no variant of keeps its link.
    #[must_use]
    pub fn unlinks(&self, variant_wanted: bool) -> bool {
        variant_wanted && self.may_unlink()
    }
}

/// The path a pre-rasterization shader object's draws take, as the depth profile shows it:
/// where the mode acts on depth, the precise path where it has a variant (reading the pushed
/// carrier or with the carrier baked in, `variant`, [`ShaderObjectPosition::decide`]), else
/// the flip path; none ("native") elsewhere.
#[must_use]
pub fn shader_object_vertex_path(active: bool, variant: bool) -> &'static str {
    match (active, variant) {
        (false, _) => "native",
        (true, true) => "precise",
        (true, false) => "flip",
    }
}

/// What revz knows of a vertex, tessellation evaluation, geometry or mesh shader object at its
/// creation in a precise mode (issue #41). Its variant, bound in its place for precise-path
/// draws where it is the last pre-rasterization stage bound, takes one of two routes:
/// - a shader whose push-constant ranges got revz's carrier (as a pipeline layout's do,
///   `crate::precise::reserve_carrier`) where its stage reads it takes a pipeline's
///   per-camera route: the variant stores `Position` through the pushed carrier, and its draws
///   classify the pushed projection on the CPU (or push the selector where it fits the matrix
///   it loads);
/// - otherwise the route of a pipeline layout without room for the carrier: a variant of its
///   code that fits the matrix it loads, with the carrier baked in
///   (`crate::shader::position_store::CarrierRead::Baked`): complementary depth, the range
///   fitted per object.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShaderObjectPosition<'a> {
    /// Its code is SPIR-V (not binary).
    pub spirv: bool,
    /// It is part of a linked set (`VK_SHADER_CREATE_LINK_STAGE_BIT_EXT`) that keeps its
    /// link ([`LinkedSet::may_unlink`]: one with tessellation stages whose evaluation shader
    /// does not stand alone).
    pub linked: bool,
    /// A shader with the carrier in its push-constant ranges: what
    /// [`crate::policy::vertex_stage::VertexStageFacts::decide`] made of it as a pipeline's
    /// last pre-rasterization stage (`Ok`: a precise range), or why it refused; `None` where
    /// the route does not apply (binary or linked code, no room for the carrier).
    pub pushed: Option<Result<(), &'a str>>,
    /// The baked rewrite of its code: `Ok(None)` where it stores no `Position`, `Ok(Some(w))`
    /// where it does, `w` whether it projects the previous stage's `Position` (whose w = 1
    /// draws check against the shaders bound before it: `crate::command_state`); or why it
    /// cannot be rewritten.
    pub rewrite: Result<Option<bool>, &'a str>,
    /// A geometry shader that stores `gl_in[i].gl_Position` as it is into every vertex it
    /// emits (`crate::shader::position_store::passes_position_through`).
    pub passes_through: bool,
}

/// [`ShaderObjectPosition::decide`]'s answer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShaderObjectPlan {
    /// Nothing to do: it stores no `Position`.
    Nothing,
    /// A variant reading the pushed carrier, with a pipeline's per-camera route.
    Pushed,
    /// A variant with the carrier baked in.
    Baked,
    /// No variant: a geometry shader passing the positions through, which leaves the
    /// rewrite to the stage bound before it (`crate::objects::PositionShader::PassesThrough`).
    PassesThrough,
    /// Its draws into reversed attachments take the flip path, for this reason.
    Flip(String),
}

impl ShaderObjectPosition<'_> {
    #[must_use]
    pub fn decide(&self) -> ShaderObjectPlan {
        if !self.spirv {
            return ShaderObjectPlan::Flip("its code is binary".into());
        }
        if self.linked {
            return ShaderObjectPlan::Flip(
                "it is part of a linked set (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT) with \
                 tessellation stages whose control shader declares tessellation modes its \
                 evaluation shader does not, which revz keeps linked"
                    .into(),
            );
        }
        // The pushed route where it applies; where it refuses, the baked one may still fit the
        // stage's matrix (naga cannot read the code, say).
        if let Some(Ok(())) = self.pushed {
            return ShaderObjectPlan::Pushed;
        }
        match self.rewrite {
            Ok(None) => ShaderObjectPlan::Nothing,
            // Projecting the previous stage's Position too: its variant is bound only after a
            // stage storing w = 1, which only draws can see (shader objects pair there).
            Ok(Some(_)) => ShaderObjectPlan::Baked,
            // It computes no position of its own: the stage before it stores them.
            Err(_) if self.passes_through => ShaderObjectPlan::PassesThrough,
            Err(reason) => ShaderObjectPlan::Flip(format!("it cannot derive its range ({reason})")),
        }
    }
}

/// What decides whether a pipeline's reversed variant holds its depth bias
/// ([`BiasVariantFacts::variant_holds_bias`]), gathered by the pipeline hook once its variants
/// are decided.
#[derive(Clone, Copy, Debug)]
pub struct BiasVariantFacts {
    /// The reversed variant flips the static compare op ([`Variants::compare_op`]): there is
    /// a variant for every draw into a reversed attachment.
    pub compare_op_variant: bool,
    /// [`StaticStateFacts::decide`] made its static bias dynamic (to send it flipped).
    pub bias_made_dynamic: bool,
    /// It defines every state subset itself and links no library (neither a library nor a
    /// link): its own rasterization state is the one its draws use.
    pub complete: bool,
    /// It may draw into promoted attachments (its render pass or formats are promotable, or
    /// a library it links is): those draws bind promoted variants, whose bias in float
    /// units comes from dynamic state.
    pub promotable: bool,
}

impl BiasVariantFacts {
    /// Whether the reversed variant holds the flipped bias statically, and the bias stays
    /// static (revz makes it dynamic no more): with `compare_op = variants` a bind then needs
    /// no `vkCmdSetDepthBias` after it, so that the driver gets the application's calls and no
    /// more (issue #17). Only where every reversed draw binds that variant (a complete
    /// pipeline with a compare-op variant) and no draw binds a promoted one. Where the
    /// variant cannot be made, its reversed draws keep the bias unflipped with the compare
    /// op (logged).
    #[must_use]
    pub fn variant_holds_bias(&self) -> bool {
        self.compare_op_variant && self.bias_made_dynamic && self.complete && !self.promotable
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_required_compile_in_an_early_returning_info_ends_the_batch() {
        assert!(!VariantCompile::Done.ends_batch());
        assert!(!VariantCompile::Required {
            returns_early: false
        }
        .ends_batch());
        assert!(VariantCompile::Required {
            returns_early: true
        }
        .ends_batch());
    }

    #[test]
    fn pipelines_are_taken_back_for_their_variants_and_after_an_early_return() {
        use VariantCompile::{Done, Required};
        let takes = |compiles: &[VariantCompile], result: vk::Result| {
            let mut take_back = TakeBack::default();
            let taken: Vec<bool> = compiles.iter().map(|&c| take_back.takes(c)).collect();
            (taken, take_back.result(result))
        };
        let success = vk::Result::SUCCESS;
        let required = vk::Result::PIPELINE_COMPILE_REQUIRED;
        // Nothing needs compiling: nothing is taken back, the driver's result stands.
        assert_eq!(takes(&[Done, Done], success), (vec![false, false], success));
        assert_eq!(
            takes(&[Done], vk::Result::ERROR_OUT_OF_HOST_MEMORY),
            (vec![false], vk::Result::ERROR_OUT_OF_HOST_MEMORY)
        );
        // Only the one whose variant needs compiling, without early return.
        let late = Required {
            returns_early: false,
        };
        assert_eq!(
            takes(&[Done, late, Done], success),
            (vec![false, true, false], required)
        );
        // Every one from an early return on.
        let early = Required {
            returns_early: true,
        };
        assert_eq!(
            takes(&[Done, early, Done, Done], success),
            (vec![false, true, true, true], required)
        );
        // The driver's failure stands.
        assert_eq!(
            takes(&[late], vk::Result::ERROR_OUT_OF_DEVICE_MEMORY),
            (vec![true], vk::Result::ERROR_OUT_OF_DEVICE_MEMORY)
        );
        assert_eq!(takes(&[late], required), (vec![true], required));
    }

    const TESTED: DepthStencilFacts = DepthStencilFacts {
        compare_op: vk::CompareOp::LESS_OR_EQUAL,
        depth_test_enable: true,
        depth_bounds_test_enable: true,
    };

    const BIASED: DepthBiasFacts = DepthBiasFacts {
        enable: true,
        represented: false,
    };

    /// A pipeline that renders depth with every depth state static and enabled.
    fn all_static() -> StaticStateFacts<'static> {
        StaticStateFacts {
            has_depth_attachment: true,
            app_dynamic: &[],
            rasterizer_discard: false,
            depth_stencil: Some(TESTED),
            depth_bias: Some(BIASED),
            static_viewports: 1,
            compare_op_variants: false,
            bias_with_representation: false,
            user_clamp_range: false,
        }
    }

    #[test]
    fn a_depth_attachment_is_the_subpass_or_the_rendering_format_or_assumed_in_a_library() {
        use DepthAttachmentFacts::{NoFragmentOutput, RenderPass, Rendering};
        assert!(has_depth_attachment(RenderPass {
            subpass_depth: true
        }));
        assert!(!has_depth_attachment(RenderPass {
            subpass_depth: false
        }));
        assert!(has_depth_attachment(Rendering {
            depth_format: Some(vk::Format::D32_SFLOAT)
        }));
        assert!(!has_depth_attachment(Rendering {
            depth_format: Some(vk::Format::UNDEFINED)
        }));
        assert!(!has_depth_attachment(Rendering { depth_format: None }));
        assert!(has_depth_attachment(NoFragmentOutput));
    }

    #[test]
    fn a_pipeline_renders_depth_with_an_attachment_unless_it_statically_discards() {
        assert!(renders_depth(true, false, &[]));
        assert!(!renders_depth(false, false, &[]));
        assert!(!renders_depth(true, true, &[]));
        assert!(renders_depth(
            true,
            true,
            &[vk::DynamicState::RASTERIZER_DISCARD_ENABLE]
        ));
        assert!(!renders_depth(
            false,
            true,
            &[vk::DynamicState::RASTERIZER_DISCARD_ENABLE]
        ));
    }

    #[test]
    fn every_enabled_static_state_becomes_dynamic_in_order() {
        let plan = all_static().decide();
        assert!(plan.renders_depth);
        assert_eq!(
            plan.made_dynamic,
            States::COMPARE_OP | States::BOUNDS | States::VIEWPORT | States::BIAS
        );
        assert!(!plan.compare_op_variant);
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        assert_eq!(
            plan.added_dynamic_states().collect::<Vec<_>>(),
            [
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::DEPTH_BOUNDS,
                vk::DynamicState::VIEWPORT,
                vk::DynamicState::DEPTH_BIAS,
            ]
        );
    }

    /// A user-defined clamp range (`VK_EXT_depth_clamp_control`) holds depth values: made
    /// dynamic (last in the list) unless the application set it dynamically, and kept where
    /// the pipeline renders no depth.
    #[test]
    fn a_user_defined_clamp_range_becomes_dynamic() {
        let facts = StaticStateFacts {
            user_clamp_range: true,
            ..all_static()
        };
        let plan = facts.decide();
        assert!(plan.made_dynamic.contains(States::CLAMP_RANGE));
        assert_eq!(
            plan.added_dynamic_states().last(),
            Some(crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE)
        );
        let app = [crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE];
        let app_set = StaticStateFacts {
            app_dynamic: &app,
            ..facts
        };
        assert!(!app_set.decide().made_dynamic.contains(States::CLAMP_RANGE));
        let no_depth = StaticStateFacts {
            has_depth_attachment: false,
            ..facts
        };
        assert!(no_depth.decide().made_dynamic.is_empty());
        assert_eq!(
            States::of_dynamic(crate::vk_ext::DYNAMIC_STATE_DEPTH_CLAMP_RANGE),
            States::CLAMP_RANGE
        );
    }

    #[test]
    fn a_pipeline_that_renders_no_depth_keeps_its_state() {
        for facts in [
            StaticStateFacts {
                has_depth_attachment: false,
                ..all_static()
            },
            StaticStateFacts {
                rasterizer_discard: true,
                ..all_static()
            },
        ] {
            assert_eq!(facts.decide(), StaticStatePlan::default());
        }
        let dynamic_discard = [vk::DynamicState::RASTERIZER_DISCARD_ENABLE];
        let facts = StaticStateFacts {
            rasterizer_discard: true,
            app_dynamic: &dynamic_discard,
            ..all_static()
        };
        assert!(facts.decide().renders_depth);
    }

    #[test]
    fn state_the_application_made_dynamic_is_left_to_it() {
        let app = [
            vk::DynamicState::DEPTH_COMPARE_OP,
            vk::DynamicState::DEPTH_BOUNDS,
            vk::DynamicState::DEPTH_BIAS,
        ];
        let facts = StaticStateFacts {
            app_dynamic: &app,
            static_viewports: 0,
            ..all_static()
        };
        let plan = facts.decide();
        assert!(plan.renders_depth);
        assert!(plan.made_dynamic.is_empty());
        assert_eq!(plan.added_dynamic_states().count(), 0);
        // A dynamic compare op is no evidence of the convention.
        assert_eq!(plan.tested_compare_op, None);
        for viewport in [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::VIEWPORT_WITH_COUNT,
        ] {
            let app = [viewport];
            assert!(!viewports_static(&app));
            let facts = StaticStateFacts {
                app_dynamic: &app,
                ..all_static()
            };
            assert!(!facts.decide().made_dynamic.contains(States::VIEWPORT));
        }
        assert!(viewports_static(&[vk::DynamicState::SCISSOR]));
    }

    #[test]
    fn disabled_tests_and_bias_stay_static_unless_enabled_dynamically() {
        let off = StaticStateFacts {
            depth_stencil: Some(DepthStencilFacts {
                depth_test_enable: false,
                depth_bounds_test_enable: false,
                ..TESTED
            }),
            depth_bias: Some(DepthBiasFacts {
                enable: false,
                represented: false,
            }),
            static_viewports: 0,
            ..all_static()
        };
        let plan = off.decide();
        assert!(plan.made_dynamic.is_empty());
        assert_eq!(plan.tested_compare_op, None);
        let enables = [
            vk::DynamicState::DEPTH_TEST_ENABLE,
            vk::DynamicState::DEPTH_BOUNDS_TEST_ENABLE,
            vk::DynamicState::DEPTH_BIAS_ENABLE,
        ];
        let enabled = StaticStateFacts {
            app_dynamic: &enables,
            ..off
        };
        let plan = enabled.decide();
        assert_eq!(
            plan.made_dynamic,
            States::COMPARE_OP | States::BOUNDS | States::BIAS
        );
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        // Without the states of other subsets, nothing of theirs is made dynamic.
        let none = StaticStateFacts {
            depth_stencil: None,
            depth_bias: None,
            static_viewports: 0,
            ..all_static()
        };
        assert!(none.decide().made_dynamic.is_empty());
    }

    #[test]
    fn with_variants_a_flipping_compare_op_stays_static_and_gets_a_variant() {
        let variants = StaticStateFacts {
            compare_op_variants: true,
            ..all_static()
        };
        let plan = variants.decide();
        assert!(plan.compare_op_variant);
        assert!(!plan.made_dynamic.contains(States::COMPARE_OP));
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::LESS_OR_EQUAL));
        // EQUAL reads the same reversed: no variant.
        let equal = StaticStateFacts {
            depth_stencil: Some(DepthStencilFacts {
                compare_op: vk::CompareOp::EQUAL,
                ..TESTED
            }),
            ..variants
        };
        let plan = equal.decide();
        assert!(!plan.compare_op_variant);
        assert_eq!(plan.tested_compare_op, Some(vk::CompareOp::EQUAL));
    }

    #[test]
    fn an_explicit_bias_representation_is_made_dynamic_only_where_it_can_be_sent_again() {
        let represented = StaticStateFacts {
            depth_bias: Some(DepthBiasFacts {
                enable: true,
                represented: true,
            }),
            ..all_static()
        };
        assert!(!represented.decide().made_dynamic.contains(States::BIAS));
        let resendable = StaticStateFacts {
            bias_with_representation: true,
            ..represented
        };
        assert!(resendable.decide().made_dynamic.contains(States::BIAS));
    }

    #[test]
    fn a_fragment_stage_gets_a_variant_only_where_rewritten_and_allowed() {
        use FragmentStage as S;
        use FragmentVariant as V;
        for allowed in [true, false] {
            assert_eq!(S::NoDepth.variant(allowed), V::Unchanged);
            assert_eq!(S::Unknown.variant(allowed), V::Unreversed);
            assert_eq!(S::CannotRewrite.variant(allowed), V::Unreversed);
        }
        assert_eq!(S::Rewritable.variant(true), V::Rewritten);
        assert_eq!(S::Rewritable.variant(false), V::Unreversed);
    }

    #[test]
    fn code_is_given_without_identifiers_or_binaries_and_fragments_are_examined_in_depth() {
        assert!(code_given(false, false));
        assert!(!code_given(true, false));
        assert!(!code_given(false, true));
        assert!(examines_fragment(true, true, true));
        for facts in [
            (false, true, true),
            (true, false, true),
            (true, true, false),
        ] {
            assert!(!examines_fragment(facts.0, facts.1, facts.2));
        }
    }

    /// A depth-rendering pipeline of given code that wants every variant.
    fn wanting_all() -> VariantFacts {
        VariantFacts {
            active: true,
            renders_depth: true,
            identified: false,
            from_binaries: false,
            fragment: Some(FragmentStage::Rewritable),
            compare_op_flips: true,
            library_variants: true,
            promotion: true,
            converts_inputs: InputReads::None,
            depth_attachment: true,
        }
    }

    #[test]
    fn pipelines_reading_depth_inputs_get_input_variants() {
        let reads = VariantFacts {
            active: true,
            renders_depth: false,
            fragment: Some(FragmentStage::NoDepth),
            converts_inputs: InputReads::Subpass,
            ..VariantFacts::default()
        };
        // No depth attachment: only the input variants (and their promoted form).
        let alone = reads.decide();
        assert!(alone.converted_inputs && !alone.reversed());
        assert!(!alone.keeps_unreversed_fragment(false));
        assert_eq!(alone.kinds().collect::<Vec<_>>(), [VariantKind::INPUTS]);
        let promoted = VariantFacts {
            promotion: true,
            ..reads
        }
        .decide();
        assert_eq!(
            promoted.kinds().collect::<Vec<_>>(),
            [
                VariantKind::PROMOTED,
                VariantKind::INPUTS,
                VariantKind::PROMOTED_INPUTS
            ]
        );
        // Beside a depth attachment: the reversed variant converts the reads too, and must be
        // made for them.
        let beside = VariantFacts {
            depth_attachment: true,
            ..reads
        }
        .decide();
        assert!(beside.reversed() && beside.reversed_changes_fragment());
        assert!(beside.keeps_unreversed_fragment(false));
        assert_eq!(
            beside.kinds().collect::<Vec<_>>(),
            [VariantKind::REVERSED, VariantKind::INPUTS]
        );
        // Code revz cannot see gets none.
        let identified = VariantFacts {
            identified: true,
            ..reads
        }
        .decide();
        assert!(!identified.converted_inputs);
        assert_eq!(identified.kinds().count(), 0);
    }

    #[test]
    fn dynamic_renderings_local_reads_are_converted_by_the_reversed_variants_alone() {
        // They read the rendering's own depth attachment: reversed exactly where the
        // reversed variant is bound, so no input variant (it would never be bound).
        let reads = VariantFacts {
            active: true,
            renders_depth: false,
            fragment: Some(FragmentStage::NoDepth),
            converts_inputs: InputReads::Rendering,
            depth_attachment: true,
            ..VariantFacts::default()
        };
        let variants = reads.decide();
        assert!(variants.converted_inputs && !variants.input_variants);
        assert!(variants.reversed() && variants.reversed_changes_fragment());
        assert_eq!(
            variants.kinds().collect::<Vec<_>>(),
            [VariantKind::REVERSED]
        );
        let promoted = VariantFacts {
            promotion: true,
            ..reads
        }
        .decide();
        assert_eq!(
            promoted.kinds().collect::<Vec<_>>(),
            [
                VariantKind::REVERSED,
                VariantKind::PROMOTED,
                VariantKind::PROMOTED_REVERSED
            ]
        );
        // Code revz cannot see gets none.
        let identified = VariantFacts {
            identified: true,
            ..reads
        }
        .decide();
        assert!(!identified.converted_inputs);
        assert_eq!(identified.kinds().count(), 0);
    }

    #[test]
    fn a_baked_stage_goes_only_where_the_reversed_variant_changes_nothing_else() {
        let none = VariantFacts {
            compare_op_flips: false,
            fragment: Some(FragmentStage::NoDepth),
            library_variants: false,
            converts_inputs: InputReads::None,
            ..wanting_all()
        }
        .decide();
        assert!(!none.reversed());
        assert_eq!(baked_stage_conflict(&none, false), None);
        assert!(
            baked_stage_conflict(&none, true).is_some(),
            "a static bias flipped"
        );
        let mut baked = none;
        baked.baked_vertex = true;
        assert!(baked.reversed());
        let kinds: Vec<_> = baked.kinds().collect();
        assert_eq!(
            kinds,
            [
                VariantKind::REVERSED,
                VariantKind::PROMOTED,
                VariantKind::PROMOTED_REVERSED
            ]
        );
        for facts in [
            VariantFacts {
                compare_op_flips: true,
                ..wanting_all()
            },
            VariantFacts {
                fragment: Some(FragmentStage::Rewritable),
                ..wanting_all()
            },
        ] {
            assert!(baked_stage_conflict(&facts.decide(), false).is_some());
        }
    }

    #[test]
    fn a_pipeline_of_given_code_gets_the_variants_it_needs() {
        let variants = wanting_all().decide();
        assert_eq!(
            variants,
            Variants {
                compare_op: true,
                rewritten_fragment: true,
                linked_variants: true,
                promoted: true,
                unreversed_fragment: false,
                promotion_refused: false,
                converted_inputs: false,
                input_variants: false,
                depth_attachment: true,
                baked_vertex: false,
            }
        );
        assert!(variants.reversed());
        assert!(variants.reversed_changes_fragment());
        assert_eq!(
            variants.kinds().collect::<Vec<_>>(),
            [
                VariantKind::REVERSED,
                VariantKind::PROMOTED,
                VariantKind::PROMOTED_REVERSED
            ]
        );
        assert_eq!(VariantFacts::default().decide(), Variants::default());
        assert_eq!(Variants::default().kinds().count(), 0);
    }

    #[test]
    fn each_reason_alone_makes_the_reversed_variant() {
        let none = VariantFacts {
            fragment: Some(FragmentStage::NoDepth),
            compare_op_flips: false,
            library_variants: false,
            promotion: false,
            ..wanting_all()
        };
        assert!(!none.decide().reversed());
        assert!(!none.decide().unreversed_fragment);
        let compare_op = VariantFacts {
            compare_op_flips: true,
            ..none
        }
        .decide();
        assert!(compare_op.reversed());
        assert!(!compare_op.reversed_changes_fragment());
        assert_eq!(
            compare_op.kinds().collect::<Vec<_>>(),
            [VariantKind::REVERSED]
        );
        let fragment = VariantFacts {
            fragment: Some(FragmentStage::Rewritable),
            ..none
        }
        .decide();
        assert!(fragment.rewritten_fragment && fragment.reversed_changes_fragment());
        // Its variant not made: the pipeline keeps the fragment stage unreversed.
        assert!(fragment.keeps_unreversed_fragment(false));
        assert!(!fragment.keeps_unreversed_fragment(true));
        assert!(
            !compare_op.keeps_unreversed_fragment(false),
            "no fragment change to miss"
        );
        let libraries = VariantFacts {
            library_variants: true,
            ..none
        }
        .decide();
        assert!(libraries.linked_variants && libraries.reversed_changes_fragment());
        // The libraries' variants count only where the pipeline renders depth.
        let no_depth = VariantFacts {
            library_variants: true,
            renders_depth: false,
            ..none
        }
        .decide();
        assert!(!no_depth.linked_variants && !no_depth.unreversed_fragment);
        let promoted = VariantFacts {
            promotion: true,
            ..none
        }
        .decide();
        assert_eq!(
            promoted.kinds().collect::<Vec<_>>(),
            [VariantKind::PROMOTED]
        );
        let refused = VariantFacts {
            fragment: Some(FragmentStage::CannotRewrite),
            ..none
        }
        .decide();
        assert!(refused.unreversed_fragment && !refused.reversed());
        // A fragment stage not looked at is left alone.
        let unexamined = VariantFacts {
            fragment: None,
            ..none
        }
        .decide();
        assert_eq!(
            unexamined,
            Variants {
                depth_attachment: none.depth_attachment,
                ..Variants::default()
            }
        );
    }

    #[test]
    fn without_its_code_a_pipeline_gets_no_variant_and_keeps_its_fragment_unreversed() {
        for facts in [
            VariantFacts {
                identified: true,
                ..wanting_all()
            },
            VariantFacts {
                from_binaries: true,
                ..wanting_all()
            },
        ] {
            assert!(!facts.code_given());
            let variants = facts.decide();
            assert!(!variants.reversed());
            assert!(!variants.promoted);
            assert_eq!(variants.kinds().count(), 0);
            assert!(variants.unreversed_fragment);
            assert!(variants.promotion_refused);
            assert_eq!(facts.warns_of_binaries(), facts.from_binaries);
            // Even a fragment stage that seems not to compute with depth: what runs is not the
            // code revz sees.
            let no_depth = VariantFacts {
                fragment: Some(FragmentStage::NoDepth),
                library_variants: false,
                ..facts
            };
            assert!(no_depth.decide().unreversed_fragment);
            // Libraries with variants leave it unreversed too.
            let libraries = VariantFacts {
                fragment: None,
                ..facts
            };
            assert!(libraries.decide().unreversed_fragment);
            let neither = VariantFacts {
                library_variants: false,
                ..libraries
            };
            assert!(!neither.decide().unreversed_fragment);
        }
    }

    #[test]
    fn binaries_are_warned_of_only_where_they_matter() {
        let binaries = VariantFacts {
            from_binaries: true,
            ..VariantFacts::default()
        };
        assert!(!binaries.warns_of_binaries());
        let active = VariantFacts {
            active: true,
            ..binaries
        };
        assert!(!active.warns_of_binaries());
        let rendering = VariantFacts {
            renders_depth: true,
            ..active
        };
        assert!(rendering.warns_of_binaries());
        let inactive = VariantFacts {
            active: false,
            ..rendering
        };
        assert!(!inactive.warns_of_binaries());
    }

    #[test]
    fn a_pipeline_is_promoted_by_its_attachments_or_its_libraries() {
        use PipelinePromotion as P;
        use PromotionAttachments as A;
        let facts = |attachments, libraries_promotable| PromotionFacts {
            promote: true,
            attachments,
            libraries_promotable,
        };
        let pass = A::Pass {
            promotable: true,
            twin: true,
        };
        assert_eq!(
            facts(pass, false).decide(),
            P::Promoted {
                twin: true,
                rendering: false
            }
        );
        let rendering = A::Rendering { promotable: true };
        assert_eq!(
            facts(rendering, false).decide(),
            P::Promoted {
                twin: false,
                rendering: true
            }
        );
        let unpromoted = [
            A::NotNamed,
            A::Pass {
                promotable: false,
                twin: false,
            },
            A::Rendering { promotable: false },
        ];
        for attachments in unpromoted {
            assert_eq!(facts(attachments, false).decide(), P::None);
            assert_eq!(
                facts(attachments, true).decide(),
                P::Promoted {
                    twin: false,
                    rendering: false
                }
            );
        }
        // Without promotion on the device, nothing is.
        for attachments in [pass, rendering, A::NotNamed] {
            let off = PromotionFacts {
                promote: false,
                ..facts(attachments, true)
            };
            assert_eq!(off.decide(), P::None);
        }
    }

    #[test]
    fn an_unknown_pass_or_a_missing_twin_gives_no_promotion_whatever_the_libraries() {
        use PipelinePromotion as P;
        use PromotionAttachments as A;
        for libraries_promotable in [false, true] {
            let facts = |attachments| PromotionFacts {
                promote: true,
                attachments,
                libraries_promotable,
            };
            assert_eq!(facts(A::UnknownPass).decide(), P::None);
            let missing = A::Pass {
                promotable: true,
                twin: false,
            };
            assert_eq!(facts(missing).decide(), P::MissingTwin);
        }
    }

    #[test]
    fn a_pipelines_path_is_named_once_for_the_log_and_the_profile() {
        let projection = ProjectionUse {
            offset: 64,
            stride: 16,
            storage: revz_math::Storage::ColumnMajor,
            convention: revz_math::DepthConvention::ZeroToOne,
        };
        let derived = Some(MatrixSource::UniformBuffer);
        let pushed = PipelinePath::of(Some(projection), None, false, Some("ignored"));
        assert_eq!(pushed, PipelinePath::Pushed(projection));
        assert_eq!(pushed.label(), "precise");
        assert_eq!(pushed.to_string(), "push-constant bytes 64..128");
        let both = PipelinePath::of(Some(projection), derived, false, None);
        assert_eq!(both, PipelinePath::PushedAndFitted(projection));
        assert_eq!(both.label(), "precise");
        assert_eq!(
            both.to_string(),
            "push-constant bytes 64..128, fitted by the shader where they hold no camera's \
             projection"
        );
        let flip = PipelinePath::of(None, derived, true, Some("its code is not given"));
        assert_eq!(flip, PipelinePath::Flip("its code is not given"));
        assert_eq!(flip.label(), "flip");
        assert_eq!(flip.to_string(), "its code is not given");
        let fitted = PipelinePath::of(None, derived, false, None);
        assert_eq!(fitted.label(), "precise");
        assert_eq!(fitted.to_string(), "a uniform buffer, fitted by the shader");
        let baked = PipelinePath::of(None, derived, true, None);
        assert_eq!(baked.label(), "precise");
        assert_eq!(
            baked.to_string(),
            "a uniform buffer, fitted by the shader with the carrier baked into its reversed \
             variants (no room in its layout)"
        );
        let neither = PipelinePath::of(None, None, false, None);
        assert_eq!(neither, PipelinePath::NotRewritten);
        assert_eq!(neither.label(), "flip");
        assert_eq!(neither.to_string(), "the mode does not rewrite depth");
    }

    #[test]
    fn the_profile_records_only_pipelines_that_render_depth() {
        assert!(profiles_pipeline(true));
        assert!(!profiles_pipeline(false));
    }

    #[test]
    fn shader_objects_get_variants_only_where_the_mode_is_active() {
        assert!(shader_object_variants(true));
        assert!(!shader_object_variants(false));
    }

    #[test]
    fn a_linked_set_goes_down_unlinked_only_where_a_variant_is_wanted_and_it_may() {
        let stages = |flags: &[vk::ShaderStageFlags]| {
            flags
                .iter()
                .fold(vk::ShaderStageFlags::empty(), |all, &s| all | s)
        };
        let (vertex, fragment, geometry) = (
            vk::ShaderStageFlags::VERTEX,
            vk::ShaderStageFlags::FRAGMENT,
            vk::ShaderStageFlags::GEOMETRY,
        );
        let (mesh, task) = (
            vk::ShaderStageFlags::MESH_EXT,
            vk::ShaderStageFlags::TASK_EXT,
        );
        for set in [
            stages(&[vertex, fragment]),
            stages(&[vertex, geometry, fragment]),
            stages(&[task, mesh, fragment]),
            stages(&[vertex]),
        ] {
            let linked = LinkedSet {
                stages: set,
                spirv: true,
                tessellation_stands_alone: false,
            };
            assert!(linked.unlinks(true), "{set:?}");
            // Nothing to gain: the link stays.
            assert!(!linked.unlinks(false), "{set:?}");
            // Binary code cannot be rewritten.
            let binary = LinkedSet {
                spirv: false,
                ..linked
            };
            assert!(!binary.unlinks(true), "{set:?}");
        }
        // Tessellation modes may live in the control stage alone of a linked pair: such a set
        // unlinks only where its evaluation stage stands alone.
        for tessellation in [
            vk::ShaderStageFlags::TESSELLATION_CONTROL,
            vk::ShaderStageFlags::TESSELLATION_EVALUATION,
        ] {
            let linked = LinkedSet {
                stages: stages(&[vertex, tessellation, fragment]),
                spirv: true,
                tessellation_stands_alone: false,
            };
            assert!(!linked.may_unlink());
            assert!(!linked.unlinks(true));
            let alone = LinkedSet {
                tessellation_stands_alone: true,
                ..linked
            };
            assert!(alone.unlinks(true));
            assert!(!alone.unlinks(false));
        }
        // A call that links nothing has nothing to unlink.
        assert!(!LinkedSet {
            stages: vk::ShaderStageFlags::empty(),
            spirv: true,
            tessellation_stands_alone: true,
        }
        .unlinks(true));
    }

    #[test]
    fn an_evaluation_stage_stands_alone_where_it_declares_every_mode_itself() {
        let modes = |subdivision, spacing, order, point_mode| {
            Some(TessellationModes {
                subdivision,
                spacing,
                order,
                point_mode,
            })
        };
        let full = modes(Some(22), Some(1), Some(5), false);
        // glslang's usual split: everything in the evaluation stage, the control stage only
        // its output vertices.
        assert!(tessellation_stands_alone(
            modes(None, None, None, false),
            full
        ));
        // Declared in both, alike.
        assert!(tessellation_stands_alone(full, full));
        // Spacing or order in the control stage alone (HLSL's hull shader attributes, as
        // DXC writes them): linked, they are the evaluation stage's too; unlinked, not.
        for evaluation in [
            modes(Some(22), None, Some(5), false),
            modes(Some(22), Some(1), None, false),
            modes(None, Some(1), Some(5), false),
        ] {
            assert!(
                !tessellation_stands_alone(full, evaluation),
                "{evaluation:?}"
            );
        }
        // Disagreeing stages, point mode asked by the control stage alone, unread modes.
        assert!(!tessellation_stands_alone(
            modes(Some(24), None, None, false),
            full
        ));
        assert!(!tessellation_stands_alone(
            modes(None, None, None, true),
            full
        ));
        assert!(tessellation_stands_alone(
            modes(None, None, None, true),
            modes(Some(22), Some(1), Some(5), true)
        ));
        assert!(!tessellation_stands_alone(None, full));
        assert!(!tessellation_stands_alone(full, None));
    }

    #[test]
    fn vertex_shader_objects_take_the_precise_path_where_they_have_a_baked_variant() {
        assert_eq!(shader_object_vertex_path(true, true), "precise");
        assert_eq!(shader_object_vertex_path(true, false), "flip");
        assert_eq!(shader_object_vertex_path(false, false), "native");
        assert_eq!(shader_object_vertex_path(false, true), "native");
    }

    #[test]
    fn pre_rasterization_shader_objects_get_a_baked_variant_where_their_code_allows() {
        let unlinked = ShaderObjectPosition {
            spirv: true,
            linked: false,
            pushed: None,
            rewrite: Ok(Some(false)),
            passes_through: false,
        };
        assert_eq!(unlinked.decide(), ShaderObjectPlan::Baked);
        let decide = |facts: ShaderObjectPosition<'_>| match facts.decide() {
            ShaderObjectPlan::Flip(reason) => reason,
            other => panic!("{other:?}"),
        };
        assert!(decide(ShaderObjectPosition {
            spirv: false,
            rewrite: Ok(None),
            ..unlinked
        })
        .contains("binary"));
        assert!(decide(ShaderObjectPosition {
            linked: true,
            ..unlinked
        })
        .contains("linked set"));
        // Projecting gl_in's Position: a variant, bound only after a stage storing w = 1
        // (the draw's check, `command_state`).
        assert_eq!(
            ShaderObjectPosition {
                rewrite: Ok(Some(true)),
                ..unlinked
            }
            .decide(),
            ShaderObjectPlan::Baked
        );
        assert_eq!(
            decide(ShaderObjectPosition {
                rewrite: Err("two stores"),
                ..unlinked
            }),
            "it cannot derive its range (two stores)"
        );
        assert_eq!(
            ShaderObjectPosition {
                rewrite: Ok(None),
                ..unlinked
            }
            .decide(),
            ShaderObjectPlan::Nothing
        );
        // A geometry shader passing the positions through, which fits no matrix of its own:
        // the stage before it is rewritten.
        assert_eq!(
            ShaderObjectPosition {
                rewrite: Err("Position is not a matrix times a vector"),
                passes_through: true,
                ..unlinked
            }
            .decide(),
            ShaderObjectPlan::PassesThrough
        );
        // Not where it is binary or linked (its code could not be read, its set not bound
        // apart).
        for facts in [
            ShaderObjectPosition {
                spirv: false,
                rewrite: Err("binary"),
                passes_through: true,
                ..unlinked
            },
            ShaderObjectPosition {
                linked: true,
                rewrite: Err("not a product"),
                passes_through: true,
                ..unlinked
            },
        ] {
            assert!(matches!(facts.decide(), ShaderObjectPlan::Flip(_)));
        }
    }

    #[test]
    fn vertex_shader_objects_with_the_carrier_take_the_pushed_route_where_it_gives_a_range() {
        let pushed = ShaderObjectPosition {
            spirv: true,
            linked: false,
            pushed: Some(Ok(())),
            rewrite: Ok(Some(false)),
            passes_through: false,
        };
        assert_eq!(pushed.decide(), ShaderObjectPlan::Pushed);
        // Refused there: the baked route where the deriving rewrite fits the stage.
        let refused = ShaderObjectPosition {
            pushed: Some(Err("Position does not come from a push-constant matrix")),
            ..pushed
        };
        assert_eq!(refused.decide(), ShaderObjectPlan::Baked);
        assert!(matches!(
            ShaderObjectPosition {
                rewrite: Err("two stores"),
                ..refused
            }
            .decide(),
            ShaderObjectPlan::Flip(_)
        ));
        // Neither binary code nor a linked set can have a variant bound alone.
        for facts in [
            ShaderObjectPosition {
                spirv: false,
                ..pushed
            },
            ShaderObjectPosition {
                linked: true,
                ..pushed
            },
        ] {
            assert!(matches!(facts.decide(), ShaderObjectPlan::Flip(_)));
        }
    }

    #[test]
    fn a_reversed_variant_holds_the_bias_only_where_every_reversed_draw_binds_it() {
        let holds = BiasVariantFacts {
            compare_op_variant: true,
            bias_made_dynamic: true,
            complete: true,
            promotable: false,
        };
        assert!(holds.variant_holds_bias());
        for facts in [
            // Dynamic compare op: no variant, the bias stays dynamic.
            BiasVariantFacts {
                compare_op_variant: false,
                ..holds
            },
            // The application sets the bias, or it is off: nothing to hold.
            BiasVariantFacts {
                bias_made_dynamic: false,
                ..holds
            },
            // A library or a link: the bias is another create info's.
            BiasVariantFacts {
                complete: false,
                ..holds
            },
            // Promoted draws bind promoted variants.
            BiasVariantFacts {
                promotable: true,
                ..holds
            },
        ] {
            assert!(!facts.variant_holds_bias(), "{facts:?}");
        }
    }
}
