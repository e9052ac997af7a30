//! The policy: decisions revz takes about depth, as functions of plain facts.
//!
//! | decision | facts it reads | where they come from |
//! |---|---|---|
//! | is a depth image reversed or native ([`DevicePolicy::classify_image`]) | format, usage, tiling, settings | `vkCreateImage` |
//! | is an image considered for promotion at all, before any lock ([`DevicePolicy::may_promote`]) | `promote`, its format | `vkCreateImage` |
//! | is a depth image created in a float format ([`DevicePolicy::promoted_format`]) | format, usage, tiling, flags, external memory, whether a live resolve partner keeps its format, the device's support of the float format, whether its format list can be replaced (`crate::chain::splice_blocked`), settings | `vkCreateImage` (imageless framebuffers: their attachment infos) |
//! | may an image be on one end of a depth resolve, so that its partner's format counts ([`may_be_resolved`]) | its usage | `vkCreateImage` |
//! | does a live image keep a new image's format, as its resolve partner that keeps its own ([`kept_resolve_partner`]) | both images' format, extent and samples, whether the live one is promoted | `vkCreateImage` |
//! | which format a view of a promoted image is made in, and which formats its format list names ([`promoted_view_format`]) | the view's (or listed) format, the image's format and whether it was promoted | `vkCreateImageView` (images from `vkCreateImage`), `vkCreateImage` |
//! | must a resolve's source become native ([`DepthResolve::demotes_source`]) | resolve mode, destination, swappability | framebuffer creation, render pass and rendering begins |
//! | does a resolve's destination become native, or is the pair of reversed ends remembered ([`resolved_destination`]) | whether its source is (still) reversed | framebuffer creation, render pass and rendering begins (`crate::objects::DeviceObjects::settle_depth_resolve`) |
//! | which end of a remembered resolve pair follows an end made native, and why ([`follows_demotion`]) | the pair, the end made native | framebuffer creation, render pass and rendering begins (`crate::objects::DeviceObjects::settle_depth_resolve`) |
//! | does an image made native change: only a reversed one, for the rest of its life ([`ImageDepth::demoted`]) | its decision | wherever a resolve rule makes it native (`crate::objects::DeviceObjects::demote`) |
//! | which MIN/MAX mode a reversed resolve uses ([`ResolveSupport::swapped_depth_mode`]) | the device's resolve properties | `vkCreateDevice` |
//! | does a render pass get a twin with its MIN/MAX depth resolve swapped, and with which mode ([`ResolveSupport::twin_resolve`]) | each subpass's depth resolve mode, the stencil mode where the resolve attachment has stencil, where the resolve structure is in the subpass's chain, the device's resolve properties | `vkCreateRenderPass2` (for the promoted twin too), `vkCreateDevice` |
//! | how a rendering instance's depth resolve goes down for a reversed attachment, and whether revz can resolve it reversed ([`ResolveSupport::reversed_resolve`], then [`ReversedResolve::mode`], [`ReversedResolve::swappable`]) | its depth resolve mode, the stencil attachment's resolve mode where it has a view, the device's resolve properties | `vkCmdBeginRendering`, `vkCreateDevice` |
//! | which attachment formats a render pass's promoted twin has: the float ones ([`promoted_twin_format`]) | each attachment's format | `vkCreateRenderPass*` |
//! | does a render pass get a promoted twin ([`has_promoted_twin`]) | `promote`, whether the twin changes an attachment's format ([`promoted_twin_format`]) | `vkCreateRenderPass*` |
//! | does a dynamic rendering instance draw into promoted attachments, and which format its draws convert from ([`rendering_promoted_from`]) | whether its depth, then its stencil view is of a promoted image, that view's image's format | `vkCmdBeginRendering` (views from `vkCreateImageView`, images from `vkCreateImage`) |
//! | which format a render pass instance's draws convert from in a subpass ([`subpass_promoted_from`]) | whether it was begun as its promoted twin, the format of the subpass's depth attachment | `vkCmdBeginRenderPass*`, `vkCmdNextSubpass*` (formats from `vkCreateRenderPass*`), `vkBeginCommandBuffer` (a secondary's inheritance) |
//! | which of a render pass's attachments its begins clear the depth of ([`clears_depth_at_begin`]) | each attachment's format and load op | `vkCreateRenderPass*` (read at `vkCmdBeginRenderPass*`) |
//! | is a framebuffer considered for promotion at all ([`framebuffer_may_be_promoted`]) | `promote`, whether its pass has a promotable attachment | `vkCreateFramebuffer` (render passes from `vkCreateRenderPass*`) |
//! | what an imageless framebuffer's attachment info says of its image ([`ImageFacts::imageless_attachment`]) | its usage and flags | `vkCreateFramebuffer` |
//! | which view formats an imageless framebuffer of promoted images lists: the float one for its attachment's UNORM format ([`imageless_view_format`]) | each listed format, the pass's format of the attachment, whether it is promotable | `vkCreateFramebuffer` (render passes from `vkCreateRenderPass*`) |
//! | is a framebuffer of promoted depth images, of unpromoted ones, or a mix no pass takes ([`FramebufferStorage::of`]) | whether each of its pass's promotable attachments is a promoted image (imageless: whether its attachment info would be, [`DevicePolicy::promoted_format`]) | `vkCreateFramebuffer` (images from `vkCreateImage`) |
//! | which render pass a pass begin uses in place of the application's ([`PassTwin::choose`]) | whether the framebuffer was created promoted, whether a reversed attachment is resolved, whether the pass has a swapped-resolve twin | `vkCmdBeginRenderPass*` (framebuffers from `vkCreateFramebuffer`, twins from `vkCreateRenderPass*`) |
//! | which target a render pass begin commits ([`pass_committed`]) | whether any of its attachments is reversed | `vkCmdBeginRenderPass*` (framebuffers' and imageless begins' views, images from `vkCreateImage`) |
//! | which of a pass begin's clear values are of reversed attachments: the first commits the convention, and (after it) they flip ([`clears_reversed`]) | whether the pass clears each attachment's depth, whether it is reversed (as created, then after the convention) | `vkCmdBeginRenderPass*` (load ops from `vkCreateRenderPass*`, images from `vkCreateImage`) |
//! | does a pass begin resolve a reversed attachment, so that it takes the swapped-resolve twin ([`resolves_reversed`]) | its subpasses' depth resolve sources, whether each attachment is reversed (after the convention) | `vkCmdBeginRenderPass*` (resolves from `vkCreateRenderPass*`, settled at framebuffer creation or the begin) |
//! | can a render pass's depth resolve be swapped ([`pass_resolve_swappable`]) | its mode, whether the pass has a swapped-resolve twin | framebuffer creation, pass begins |
//! | which clear a reversed image commits the convention with, and the target revz then acts on ([`Observed::committed`]) | whether the image (or any attachment of a pass) is reversed, the depth the first reversed attachment is cleared to there | `vkCmdBeginRenderPass*`, `vkCmdBeginRendering`, `vkCmdClearDepthStencilImage` (images from `vkCreateImage`) |
//! | which target revz acts on for an attachment outside such a commit: native where the application renders reversed itself ([`Observed::effective`]) | whether its image is reversed, the convention (decided then if it is not yet) | framebuffer and begin views, secondaries' inheritance, copy ends (images from `vkCreateImage`) |
//! | which depth a clear of a reversed attachment writes ([`DevicePolicy::reversed_clear`]) | the mode, `far_clip`, the application's depth, n / f of the last rewritten projection (infinite mode) | `vkCmdBeginRenderPass*`, `vkCmdBeginRendering`, `vkCmdClearAttachments`, `vkCmdClearDepthStencilImage` (n / f from push constants) |
//! | which of `vkCmdClearAttachments`' clears flip ([`attachment_clears_flip`], [`flips_attachment_clear`]) | the target draws go to (after the convention), each clear's aspect | `vkCmdClearAttachments` (the target: pass begins, images from `vkCreateImage`) |
//! | is an image clear looked at: only a reversed image's commits the convention or flips ([`image_clear_considered`]) | whether the image is reversed | `vkCmdClearDepthStencilImage` (images from `vkCreateImage`) |
//! | does an image clear write depth, so that its value counts for the convention ([`clears_depth`]) | its ranges' aspects | `vkCmdClearDepthStencilImage` |
//! | does the application render reversed depth itself ([`ConventionEvidence::decide`], once per device) | the clear of the first committed reversed attachment, compare ops of pipelines and `vkCmdSetDepthCompareOp`, pushed projections | pass begins and image clears, pipeline creation, `vkCmdSetDepthCompareOp`, `vkCmdPushConstants*` (each projection as it is classified, [`Observed::note_outcome`]) |
//! | where a secondary without a framebuffer draws ([`secondary_target`]) | the target its pass was last begun with for secondaries, the format's images | primary begins, `vkCreateImage` |
//! | whether such a secondary draws into a promoted attachment ([`secondary_promoted`]) | the same, for promotion | primary begins, `vkCreateImage` |
//! | where a secondary continuing a pass draws ([`inherited_target`]) | the views' targets of the framebuffer its inheritance names (not an imageless one), else its pass (subpass or rendering format) and depth format, the target that pass was last begun with for secondaries, else the format's reversed and native images | `vkBeginCommandBuffer` (`vkCreateFramebuffer`, primary begins, `vkCreateImage`) |
//! | whether it draws into a promoted attachment, and which UNORM format draws convert from ([`inherited_promoted`]) | whether the framebuffer its inheritance names was created promoted (imageless ones too), else as for the target, for promotion (the format's promoted and kept images) | `vkBeginCommandBuffer` (`vkCreateFramebuffer`, primary begins, `vkCreateImage`) |
//! | is a secondary's inheritance looked at for promotion: only where revz promotes, for a render pass with a promotable attachment, for rendering with a depth or stencil format revz promotes (and which) ([`DevicePolicy::promote`], [`pass_promotable`], [`first_promoted_format`]) | `promote`, the pass's promotable attachments, the inherited rendering formats | `vkBeginCommandBuffer` (render passes from `vkCreateRenderPass*`) |
//! | does revz promote attachments of a format ([`promotable_format`]: the UNORM depth formats) | the format | every promotion decision below; render passes (`crate::objects::RenderPassInfo::promotable`) and pass scopes |
//! | which depth and stencil formats promoted dynamic rendering uses: the float ones ([`promoted_attachment_format`]); is a rendering's depth or stencil format promoted, and which first ([`first_promoted_format`]) | the rendering formats | `vkBeginCommandBuffer` (a secondary's inheritance), `vkCreateGraphicsPipelines` (a pipeline's `VkPipelineRenderingCreateInfo`: promotable, and its promoted variant's formats) |
//! | which command hooks a device hands out ([`DevicePolicy::command_hooks`]) | the mode, whether the depth profile is on | `vkGetDeviceProcAddr` (settings read at `vkCreateInstance`, the policy made at `vkCreateDevice`) |
//! | which mode a device's depth follows: the instance's, but `complementary` for `infinite` where the application enabled `VK_EXT_depth_range_unrestricted` ([`DevicePolicy::with_depth_range_unrestricted`]) | the mode, the device's enabled extensions | `vkCreateDevice` |
//! | is the precise path available, and where its carrier goes ([`DevicePolicy::with_push_constant_space`], with `crate::precise::carrier_offset`) | the mode, `maxPushConstantsSize` | `vkCreateDevice` |
//! | which API version an instance has: 1.0 where the application asks for none ([`requested_api_version`]) | its `VkApplicationInfo::apiVersion` | `vkCreateInstance` |
//! | which API version revz uses a device with: the smaller of its instance's and its own ([`device_api_version`]) | the instance's API version, the physical device's | `vkCreateInstance`, `vkCreateDevice` |
//! | is a device asked for its resolve properties, and what it then supports ([`ResolveSupport::queried`], [`ResolveSupport::reported`]; [`ResolveSupport::MINIMAL`] where it is not) | the device's API version, its reported depth resolve modes (SAMPLE_ZERO always added) and independence | `vkCreateDevice` |
//! | does revz add `VK_KHR_get_physical_device_properties2` to an instance ([`instance_needs_properties2`]) | the mode, the API version, whether the application enabled it | `vkCreateInstance` |
//! | may a device of the instance have `VK_EXT_extended_dynamic_state` added ([`extended_dynamic_state_allowed`]) | the API version, whether `VK_KHR_get_physical_device_properties2` is enabled (by the application or revz) | `vkCreateInstance`, `vkCreateDevice` |
//! | which commands `vkGet*ProcAddr` hides from the application ([`hides_instance_command`], [`hides_device_command`]) | the command's name, whether revz added the extension it belongs to | `vkGetInstanceProcAddr`, `vkGetDeviceProcAddr` (what was added: `vkCreateInstance`, `vkCreateDevice`) |
//! | where the device's dynamic compare op comes from ([`CompareOpSource::decide`]) | the API version, the application's `VK_EXT_extended_dynamic_state` and feature structure, the mode, whether revz may add the extension and the device offers it | `vkCreateDevice` |
//! | is where the compare op comes from logged: where revz adds the extension or none is available, in active modes ([`CompareOpSource::logged`]) | the source, whether the mode is off | `vkCreateDevice` |
//! | do draws get the flipped compare op as dynamic state, else from pipeline variants ([`CompareOpSource::is_dynamic`], then [`DevicePolicy::new`] with `compare_op`) | the source, whether the next layer gave revz `vkCmdSetDepthCompareOp`, the `compare_op` setting | `vkCreateDevice` |
//! | which shader modules are analysed: for fragments where revz is active, for the vertex stage where the mode rewrites and the module declares a vertex entry point ([`vertex_stage::analyses_fragment_module`], [`vertex_stage::analyses_vertex_module`]) | the mode, the module's entry points (`crate::shader::scan`) | `vkCreateShaderModule` |
//! | is a pipeline a candidate for the precise path ([`vertex_stage::precise_candidate`]) | the mode, whether it renders depth, whether its create info defines its shaders | `vkCreateGraphicsPipelines` |
//! | does a pipeline's vertex stage store reversed depth itself, and of which range ([`vertex_stage::VertexStageFacts::decide`]) | whether its code is given, its stages, the analysis of its vertex entry point (`crate::shader::analysis`), its layout's push-constant ranges and room for the carrier, its clip convention (static or dynamic), its module's `Position` rewrite and what that derives its range from (`crate::shader::position_store`, `crate::shader::derived_range`) | `vkCreateShaderModule` (or inline code, once per distinct code), `vkCreateGraphicsPipelines` |
//! | why a pipeline whose vertex stage's facts revz lacks takes the flip path ([`vertex_stage::MissingFact::reason`]), and which analysis is its entry point's ([`vertex_stage::entry_point_analysis`]) | whether its vertex module is known and has a `Position` rewrite, whether its inline code has one, whether it has a module or inline code, a vertex stage, a readable module, an entry point name | `vkCreateShaderModule` (or inline code), `vkCreateGraphicsPipelines` |
//! | which `Position` rewrite a vertex module gets: the carrier store or the deriving one ([`vertex_stage::position_store`]), and whether it gets one at all ([`vertex_stage::module_position_store`]) | the carrier's offset (the precise path), whether its analysis could be read, the analysis of its entry points (`crate::shader::analysis`) | `vkCreateShaderModule` (or inline code, once per distinct code) |
//! | which range a derived draw stores and in which clip convention (`crate::command_state::CommandState::derived_use`) | the mode, the target, the pipeline's dynamic clip convention and its current value | draws |
//! | is a copy's depth converted, and which way ([`CopyFacts::decide`]) | which end is a reversed image, whether the texels change format (a promoted end against the application's format), the aspect, `copy_values`, whether the command buffer can dispatch and its compute bindings can be restored, extension structures, multisampled images, active conditional rendering | `vkCmdCopy*`, `vkCmdBlitImage*` (image decisions from `vkCreateImage`, pool families from `vkCreateCommandPool`, compute bindings from `vkCmdBindPipeline` and `vkCmdBindDescriptorSets`, `vkCmdBeginConditionalRenderingEXT`) |
//! | which end of a copy an image is: reversed or native after the convention, unknown images native ([`image_copy_end`], [`ImageDepth::target`]) | whether revz knows the image, its depth decision, the convention | `vkCmdCopy*`, `vkCmdBlitImage*` (images from `vkCreateImage`, the convention from [`ConventionEvidence::decide`]) |
//! | which kind of depth texel an image end holds: that of its promoted format where it has one ([`copied_texels`]) | its format, its promoted format | `vkCmdCopy*`, `vkCmdBlitImage*` (images from `vkCreateImage`) |
//! | does an image count as single-sampled for a copy; unknown images do ([`single_sampled`]) | whether revz knows it, its sample count | `vkCmdCopy*`, `vkCmdBlitImage*` (images from `vkCreateImage`) |
//! | which kinds of texel a copy's conversion reads and writes ([`conversion_kinds`]) | whether each end is a buffer (the application's format) or an image (the format revz stores it in: the float one where promoted) | `vkCmdCopy*`, `vkCmdBlitImage*` (images from `vkCreateImage`) |
//! | which state subsets a pipeline create info defines itself ([`libraries::own_subsets`]) | its `VkGraphicsPipelineLibraryCreateInfoEXT`'s subsets, whether it is a library, whether it links libraries | `vkCreateGraphicsPipelines` |
//! | which of a create info's dynamic states count: those of its own subsets ([`libraries::subset_states`]) | its own subsets | `vkCreateGraphicsPipelines` |
//! | which library's state a link takes for each subset ([`libraries::inherit_libraries`]) | each linked library's subsets and recorded depth state | `vkCreateGraphicsPipelines` (libraries recorded at their creation) |
//! | does a pipeline have a depth attachment; a library without the fragment output interface counts as having one ([`pipelines::has_depth_attachment`]) | its render pass's subpass depth attachment, else (with the fragment output interface) its rendering depth format | `vkCreateGraphicsPipelines` (render passes from `vkCreateRenderPass*`) |
//! | does a pipeline render depth at all ([`pipelines::renders_depth`]) | whether it has a depth attachment, its static `rasterizerDiscardEnable`, its dynamic states | `vkCreateGraphicsPipelines` (render passes from `vkCreateRenderPass*`) |
//! | which of a pipeline's static depth states revz makes dynamic, and whether its compare op comes from a variant ([`pipelines::StaticStateFacts::decide`]) | its dynamic states, whether it has a depth attachment, its static `rasterizerDiscardEnable`, depth-stencil state (test, bounds test, compare op), bias enable and representation, static viewports, `compare_op_variants`, `vkCmdSetDepthBias2EXT` | `vkCreateGraphicsPipelines`, `vkCreateDevice` |
//! | are a pipeline's viewports read, and made dynamic: only static ones ([`pipelines::viewports_static`]) | its dynamic states | `vkCreateGraphicsPipelines` |
//! | which variants a pipeline gets: a flipped compare op, a rewritten fragment stage, its libraries' variants, promoted ones; what it keeps without them ([`pipelines::VariantFacts::decide`]) | whether its code is given (module identifiers, its libraries', pipeline binaries: [`pipelines::code_given`]), its fragment stage's rewrite (`crate::shader::fragment_depth`), the static state's plan, its libraries' variants, its promotion | `vkCreateShaderModule` (or inline code), `vkCreateGraphicsPipelines` |
//! | does a pipeline's reversed variant hold its flipped depth bias, so that the bias stays static ([`pipelines::BiasVariantFacts::variant_holds_bias`]) | whether its compare op comes from the variant, whether its bias was made dynamic, whether it defines every subset and links nothing, whether it is promotable | `vkCreateGraphicsPipelines` (after its variants are decided) |
//! | which of a batch's application pipelines revz takes back where a variant needs compiling, and the batch's result then ([`pipelines::TakeBack`], [`pipelines::VariantCompile`]) | per create info: whether a variant came back `PIPELINE_COMPILE_REQUIRED`, whether it asks for `EARLY_RETURN_ON_FAILURE`; the driver's result | `vkCreateGraphicsPipelines` (the variants' creation, then the application's) |
//! | does a pipeline draw into promoted attachments, and how its promoted variants differ ([`pipelines::PromotionFacts::decide`]) | `promote`, whether its subsets name attachment formats, its render pass (known, promotable attachments, promoted twin) or rendering formats, whether a library it links is promoted | `vkCreateRenderPass*`, `vkCreateGraphicsPipelines` |
//! | is a pipeline's fragment stage looked at ([`pipelines::examines_fragment`]) | whether the mode is active, whether it renders depth, whether its create info defines fragment shader state | `vkCreateGraphicsPipelines` |
//! | is a pipeline warned of whose reversed variant cannot be made from its binaries ([`pipelines::VariantFacts::warns_of_binaries`]) | whether it comes from pipeline binaries, renders depth, the mode is active | `vkCreateGraphicsPipelines` |
//! | does a pipeline's reversed variant hold a fragment stage revz changed ([`pipelines::Variants::reversed_changes_fragment`]) | its variants (a rewritten fragment stage, its libraries' variants) | `vkCreateGraphicsPipelines` |
//! | what a fragment stage that computes with depth gets ([`pipelines::FragmentStage::variant`]) | its rewrite or why there is none, whether a variant of what holds it can be made | `vkCreateGraphicsPipelines`, `vkCreateShadersEXT` |
//! | which path a pipeline's draws take, as logged and in the depth profile ([`pipelines::PipelinePath`]) | its pushed projection, derived range, or flip reason (from [`vertex_stage::VertexStageFacts::decide`] and the rewritten stage's creation) | `vkCreateGraphicsPipelines` |
//! | does a precise pipeline take the flip path after all, its rewritten vertex stage not made, and why ([`vertex_stage::unmade_stage_flip`]) | whether the rewritten stage's module was created | `vkCreateGraphicsPipelines` |
//! | does a pipeline whose reversed variant was not made keep its fragment stage unreversed ([`pipelines::Variants::keeps_unreversed_fragment`]) | whether the variant was to hold a changed fragment stage (rewritten, or the libraries' variants), whether it was created | `vkCreateGraphicsPipelines` |
//! | does the depth profile record a pipeline ([`pipelines::profiles_pipeline`]) | whether it renders depth ([`pipelines::renders_depth`]) | `vkCreateGraphicsPipelines` |
//! | are shader objects' variants planned at all ([`pipelines::shader_object_variants`]) | whether the mode is active | `vkCreateShadersEXT` |
//! | which path a vertex shader object's draws take, in the depth profile ([`pipelines::shader_object_vertex_path`]) | whether the mode is active | `vkCreateShadersEXT` |
//! | is a `vkCmdSetDepthBias2EXT` sent for each draw's target or once where it is recorded ([`BiasRecording::of`]) | whether its chain holds nothing but a `VkDepthBiasRepresentationInfoEXT` | `vkCmdSetDepthBias2EXT` |
//! | which bias a draw sends: in float units where its attachment is promoted, negated where it is reversed (`crate::conv::DepthBias::for_attachment`) | the application's bias and representation, the target, the promoted attachment's UNORM format | `vkCmdSetDepthBias*`, pipelines' static bias, pass and rendering begins |
//! | does an image barrier refresh a read twin: into a layout shaders read from one the image may have been written in ([`twins::barrier_refreshes`]) | its old and new layouts, access masks and queue families | `vkCmdPipelineBarrier*`, `vkCmdWaitEvents*` (twins from `vkCreateImage`) |
//! | where a render pass instance refreshes an attachment's twin: before it, where its first use reads it; after it, where it leaves it readable after writes ([`twins::AttachmentUse::refreshes`]) | the attachment's initial and final layouts, load ops, the layout of each reference to it | `vkCreateRenderPass*` (read at `vkCmdBeginRenderPass*` and `vkCmdEndRenderPass*`) |
//! | which path a draw takes | its target, its pipeline's projection and rewritten store, its matrix's camera | `crate::command_state` (per draw, from these facts) |
//!
//! Each decision lives in the file of its concern: `images.rs` (the two image decisions, and
//! why an image stays native or keeps its format, and how a native one changes no more; which
//! images are considered for promotion, imageless attachments; resolve partners and which keep
//! an image's format, views of promoted images), `resolves.rs` (resolve sources and modes, what
//! a resolve makes of its destination and which end of a pair follows a demotion, the device's
//! resolve support, and swapped-resolve twins), `passes.rs` (render pass instances: which twin
//! begins, framebuffers' storage and promotion, twins' formats and whether a pass has a
//! promoted one, the target, clears and resolves of a begin, a rendering's promotion),
//! `clears.rs` (clears outside pass begins: which attachment clears flip, which image clears
//! are looked at and which write depth), `convention.rs` (the application's convention, and
//! what revz observes of it), `secondaries.rs` (secondaries without a framebuffer, and what
//! their inheritance makes of them, promotion included), `bias.rs` (how a dynamic bias is recorded), `compare_op.rs` (the dynamic compare
//! op, the extensions revz adds for it, and the API versions they depend on), `copies.rs`
//! (copies: whether and how they are converted, and what their image ends are), `pipelines.rs`
//! (pipelines: whether they have a depth attachment, which static states become dynamic, which
//! variants are made, which are taken back uncompiled, promotion, the path a pipeline's draws
//! take, which pipelines the profile records, fragment variants of shader objects and the
//! profile's path of vertex ones), `libraries.rs` (pipeline libraries: the subsets a create
//! info defines, which of its dynamic states count, what a link inherits), `vertex_stage.rs`
//! (the precise path's vertex stage: candidate, store, range, which modules are analysed, why
//! missing facts or an unmade stage take the flip path), `twins.rs` (when read twins are
//! refreshed); [`DevicePolicy`] itself (the mode, the
//! carrier, reversed clears, which command hooks a device hands out) is here. The rows that
//! name code outside this module are decided there.
//!
//! An image is decided once, at creation, for its whole life: every draw into it must then
//! follow the same convention (`shared/DESIGN.md` section 2). A depth image the application can
//! observe keeps standard depth unless the `reverse_observable` setting allows it, because its
//! readers (shadow-map compares, SSAO, picking, screenshots) expect standard values.
//!
//! Where this differs from `shared/DESIGN.md`: the design notes call an application reversed
//! on "a clear to 0 with GREATER, or B > 0 projections"; one reversed-looking matrix (rounding
//! in a P*V*M far from the camera) or a clear to 0 alone is weak evidence, and deciding on it
//! mid-frame left command buffers recorded before drawing reversed and new ones not. The
//! convention is now decided once, from a clear to 0 together with GREATER compare ops or
//! reversed projections, and never changed.

mod bias;
mod clears;
mod compare_op;
mod convention;
mod copies;
mod images;
pub mod libraries;
mod passes;
pub mod pipelines;
mod resolves;
mod secondaries;
pub mod twins;
pub mod vertex_stage;

pub use bias::BiasRecording;
pub use clears::{
    attachment_clears_flip, clears_depth, flips_attachment_clear, image_clear_considered,
};
pub use compare_op::{
    device_api_version, extended_dynamic_state_allowed, hides_device_command,
    hides_instance_command, instance_needs_properties2, requested_api_version, CompareOpFacts,
    CompareOpSource,
};
pub use convention::{Convention, ConventionEvidence, Observed};
pub use copies::{
    conversion_kinds, copied_texels, image_copy_end, single_sampled, CopyDecision, CopyDirection,
    CopyEnd, CopyFacts, Texels, Unconverted,
};
pub use images::{
    first_promoted_format, kept_resolve_partner, may_be_resolved, promotable_format,
    promoted_attachment_format, promoted_view_format, ImageDepth, ImageFacts, KeptFormat,
    NativeReason, ResolvePartner,
};
pub use passes::{
    clears_depth_at_begin, clears_reversed, framebuffer_may_be_promoted, has_promoted_twin,
    imageless_view_format, pass_committed, pass_promotable, pass_resolve_swappable,
    promoted_twin_format, reads_depth_input, rendering_promoted_from, resolves_reversed,
    subpass_promoted_from, FramebufferStorage, PassTwin,
};
pub use resolves::{
    follows_demotion, resolved_destination, DepthResolve, ResolveSupport, ResolvedDestination,
    ReversedResolve, SubpassResolveFacts, TwinResolve,
};
pub use secondaries::{inherited_promoted, inherited_target, secondary_promoted, secondary_target};

use revz_math::Target as RewriteTarget;

use crate::command_state::Reversing;
use crate::config::{CompareOp, FarClip, Mode, Observable, Settings};
use crate::conv::{flip_depth, Reversal};

/// Which groups of command hooks a device hands out ([`DevicePolicy::command_hooks`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandHooks {
    /// The depth path's: passes, binds, dynamic depth state, clears, copies, secondaries.
    pub depth_path: bool,
    /// The precise path's: push constants.
    pub precise_path: bool,
    /// The depth profile's: draws, submissions, presents.
    pub profile: bool,
}

/// What the policy needs to know about a device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DevicePolicy {
    pub mode: Mode,
    pub far_clip: FarClip,
    pub observable: Observable,
    /// Whether draws into reversed attachments get the flipped compare op from a pipeline
    /// variant rather than `vkCmdSetDepthCompareOp`: by choice (`compare_op = variants`), or
    /// because the device cannot make it dynamic (no Vulkan 1.3, no
    /// `VK_EXT_extended_dynamic_state`).
    pub compare_op_variants: bool,
    /// Where revz's carrier goes in every pipeline layout (precise modes on a device with the
    /// room: `crate::precise::carrier_offset`); `None`: the precise path is off and every draw
    /// into a reversed attachment takes the flip path.
    pub carrier_offset: Option<u32>,
    /// Whether UNORM depth images are promoted to float formats (`promote_depth_formats` in
    /// this mode).
    pub promote: bool,
    /// The application enabled `VK_EXT_depth_range_unrestricted`: viewports, clears and
    /// fragment shaders may put depth outside [0, 1], which a float image keeps and a UNORM
    /// one clamps. Promotion would change what such an image holds, so UNORM images keep
    /// their format ([`KeptFormat::UnrestrictedDepthRange`]); copies convert float values
    /// without clamping them to [0, 1].
    pub depth_range_unrestricted: bool,
    /// The application enabled `VK_EXT_descriptor_heap`: shaders reach images through
    /// descriptors written into heaps (`vkWriteResourceDescriptorsEXT`, which revz does not
    /// follow: they would name the reversed image, not its read twin), and revz's own
    /// descriptor set binds (a conversion's dispatch) would invalidate the heap state the
    /// application bound. Depth images that shaders read or copies reach keep standard depth
    /// and their format ([`NativeReason::DescriptorHeap`], [`KeptFormat::DescriptorHeap`]), so
    /// that revz never converts: only pure depth attachments are reversed.
    pub descriptor_heap: bool,
    /// The stages other than the vertex stage whose `Position` revz may rewrite on this
    /// device (tessellation evaluation, geometry and mesh, where the application enabled
    /// `tessellationShader`, `geometryShader` and `meshShader`): a carrier range revz adds to a
    /// layout names them too (`crate::precise::reserve_carrier`).
    pub carrier_later_stages: ash::vk::ShaderStageFlags,
    /// The sample counts of multisampled depth images shaders may sample through a read twin
    /// (`crate::depth_copy::twin`: an `R32_SFLOAT` twin written per sample by a compute pass):
    /// those the device offers for storage and sampled `R32_SFLOAT` images, where it has
    /// `shaderStorageImageMultisample` (revz enables it). Empty: such images stay native.
    pub multisampled_twin_samples: ash::vk::SampleCountFlags,
}

impl DevicePolicy {
    /// The policy on a device with `maxPushConstantsSize` bytes of push constants.
    pub fn with_push_constant_space(self, max_push_constants_size: u32) -> DevicePolicy {
        DevicePolicy {
            carrier_offset: self
                .rewrite()
                .and(crate::precise::carrier_offset(max_push_constants_size)),
            ..self
        }
    }

    /// The policy of a device; `dynamic_compare_op`: whether `vkCmdSetDepthCompareOp` (core
    /// 1.3 or the EXT) can be used.
    pub fn new(settings: &Settings, dynamic_compare_op: bool) -> DevicePolicy {
        DevicePolicy {
            mode: settings.mode,
            far_clip: settings.far_clip,
            observable: settings.reverse_observable,
            compare_op_variants: settings.compare_op == CompareOp::Variants || !dynamic_compare_op,
            carrier_offset: None,
            promote: settings.promote_depth_formats.applies(settings.mode),
            depth_range_unrestricted: false,
            descriptor_heap: false,
            carrier_later_stages: ash::vk::ShaderStageFlags::empty(),
            multisampled_twin_samples: ash::vk::SampleCountFlags::empty(),
        }
    }

    /// The policy on a device whose multisampled depth images of `samples` can have a read
    /// twin ([`DevicePolicy::multisampled_twin_samples`]).
    pub fn with_multisampled_twins(self, samples: ash::vk::SampleCountFlags) -> DevicePolicy {
        DevicePolicy {
            multisampled_twin_samples: samples & !ash::vk::SampleCountFlags::TYPE_1,
            ..self
        }
    }

    /// The policy on a device whose application enabled `geometryShader` (`geometry`),
    /// `tessellationShader` (`tessellation`) and `VK_EXT_mesh_shader`'s `meshShader` (`mesh`).
    pub fn with_shader_stages(
        self,
        geometry: bool,
        tessellation: bool,
        mesh: bool,
    ) -> DevicePolicy {
        let mut stages = ash::vk::ShaderStageFlags::empty();
        if geometry {
            stages |= ash::vk::ShaderStageFlags::GEOMETRY;
        }
        if tessellation {
            stages |= ash::vk::ShaderStageFlags::TESSELLATION_EVALUATION;
        }
        if mesh {
            stages |= ash::vk::ShaderStageFlags::MESH_EXT;
        }
        DevicePolicy {
            carrier_later_stages: stages,
            ..self
        }
    }

    /// The policy on a device whose application enabled `VK_EXT_depth_range_unrestricted`
    /// (`enabled`). Infinite mode reverses depth there as complementary mode does (`1 - D`,
    /// the far plane kept): its `n / w` is no map of depth values alone, and cannot follow
    /// what the extension lets an application do with them (clear values, viewport ranges
    /// and clamps beyond 1, a clear of exactly 1 that fragments beyond the far plane fail;
    /// a UNORM format's clamp at 1), where `1 - D` commutes with all of it. Such a device
    /// gets complementary precision: float32 depth reversed, the far plane kept.
    pub fn with_depth_range_unrestricted(self, enabled: bool) -> DevicePolicy {
        let mode = match self.mode {
            Mode::Infinite if enabled => Mode::Complementary,
            mode => mode,
        };
        DevicePolicy {
            depth_range_unrestricted: enabled,
            mode,
            ..self
        }
    }

    /// The policy of a device whose application enabled `VK_EXT_descriptor_heap` (`enabled`):
    /// [`Self::descriptor_heap`].
    pub fn with_descriptor_heap(self, enabled: bool) -> DevicePolicy {
        DevicePolicy {
            descriptor_heap: enabled,
            ..self
        }
    }

    /// Whether the layer acts on this device's depth at all.
    pub fn is_active(&self) -> bool {
        self.mode != Mode::Off
    }

    /// Which of revz's command hooks the device hands out (`vkGetDeviceProcAddr`; the device's
    /// object hooks always are): none where the mode is off, the depth path's in every active
    /// mode, the precise path's where the mode rewrites projections, and the draw and frame
    /// hooks only with the depth profile on (`profile`), which counts them: without it draws
    /// are the next layer's own.
    pub fn command_hooks(&self, profile: bool) -> CommandHooks {
        let active = self.is_active();
        CommandHooks {
            depth_path: active,
            precise_path: active && self.rewrite().is_some(),
            profile: active && profile,
        }
    }

    /// The projection rewrite of the mode, if it has one (flip mode only flips).
    pub fn rewrite(&self) -> Option<RewriteTarget> {
        match self.mode {
            Mode::Complementary => Some(RewriteTarget::Complementary),
            Mode::Infinite => Some(RewriteTarget::Infinite),
            Mode::Off | Mode::Flip => None,
        }
    }

    /// How draws into reversed attachments are made, given the n / f seen last (infinite mode).
    pub fn reversing(&self, observed: &Observed) -> Reversing {
        Reversing {
            rewrite: self.rewrite(),
            reversal: self.reversal(observed),
        }
    }

    fn reversal(&self, observed: &Observed) -> Reversal {
        match self.mode {
            Mode::Infinite => Reversal::Infinite {
                near_over_far: observed.near_over_far(),
            },
            _ => Reversal::Complementary,
        }
    }

    /// A depth clear value on a reversed attachment. Infinite reversed-Z puts the far plane at
    /// infinity (0) unless `far_clip = keep`, which clears to n / f instead so that fragments
    /// beyond the far plane lose against the clear (seed 001); a clear is recorded before the
    /// projections of its pass are pushed, so n / f is the last one seen.
    pub fn reversed_clear(&self, depth: f32, observed: &Observed) -> f32 {
        self.reversed_clear_at(depth, observed.near_over_far())
    }

    /// [`Self::reversed_clear`] of an image whose draws' camera has this n / f (the image's
    /// own: [`crate::objects::DeviceObjects::near_over_far`]).
    pub fn reversed_clear_at(&self, depth: f32, near_over_far: f32) -> f32 {
        match self.mode {
            Mode::Infinite if depth == 1.0 && self.far_clip == FarClip::Remove => 0.0,
            Mode::Infinite => Reversal::Infinite { near_over_far }.depth(depth),
            _ => flip_depth(depth),
        }
    }

    /// The map of standard depth onto an image whose draws' camera has `near_over_far`
    /// (`None`: not known for the image; the device's last seen).
    pub fn reversal_of(&self, near_over_far: Option<f32>, observed: &Observed) -> Reversal {
        match (self.mode, near_over_far) {
            (Mode::Infinite, Some(near_over_far)) => Reversal::Infinite { near_over_far },
            _ => self.reversal(observed),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) fn policy(mode: Mode, observable: Observable) -> DevicePolicy {
        DevicePolicy {
            mode,
            far_clip: FarClip::Remove,
            observable,
            compare_op_variants: false,
            carrier_offset: None,
            promote: matches!(mode, Mode::Complementary | Mode::Infinite),
            depth_range_unrestricted: false,
            descriptor_heap: false,
            carrier_later_stages: ash::vk::ShaderStageFlags::empty(),
            multisampled_twin_samples: ash::vk::SampleCountFlags::empty(),
        }
    }

    #[test]
    fn hooks_are_handed_out_by_mode_and_profile() {
        let hooks = |mode, profile| policy(mode, Observable::None).command_hooks(profile);
        let none = CommandHooks {
            depth_path: false,
            precise_path: false,
            profile: false,
        };
        assert_eq!(hooks(Mode::Off, true), none);
        assert_eq!(
            hooks(Mode::Flip, false),
            CommandHooks {
                depth_path: true,
                ..none
            }
        );
        for mode in [Mode::Complementary, Mode::Infinite] {
            assert_eq!(
                hooks(mode, true),
                CommandHooks {
                    depth_path: true,
                    precise_path: true,
                    profile: true,
                }
            );
        }
        assert!(hooks(Mode::Flip, true).profile);
    }

    #[test]
    fn an_images_own_camera_decides_its_clear_and_its_map_in_infinite_mode() {
        let observed = Observed::default();
        // The device last saw a spot light's n / f; the image was drawn by the main camera.
        observed.note_near_over_far(0.08);
        let keep = DevicePolicy {
            far_clip: FarClip::Keep,
            ..policy(Mode::Infinite, Observable::None)
        };
        assert_eq!(keep.reversed_clear_at(1.0, 0.01), 0.01);
        assert_eq!(keep.reversed_clear_at(1.0, 0.0), 0.0);
        assert_eq!(
            keep.reversal_of(Some(0.01), &observed),
            Reversal::Infinite {
                near_over_far: 0.01
            }
        );
        // Not known for the image: the device's last seen.
        assert_eq!(
            keep.reversal_of(None, &observed),
            Reversal::Infinite {
                near_over_far: 0.08
            }
        );
        let complementary = policy(Mode::Complementary, Observable::None);
        assert_eq!(
            complementary.reversal_of(Some(0.01), &observed),
            Reversal::Complementary
        );
        assert_eq!(complementary.reversed_clear_at(0.25, 0.01), 0.75);
    }

    #[test]
    fn infinite_clears_put_the_far_plane_at_infinity_or_at_near_over_far() {
        let observed = Observed::default();
        observed.note_near_over_far(0.001);
        let remove = policy(Mode::Infinite, Observable::None);
        let keep = DevicePolicy {
            far_clip: FarClip::Keep,
            ..remove
        };
        assert_eq!(remove.reversed_clear(1.0, &observed), 0.0);
        assert_eq!(keep.reversed_clear(1.0, &observed), 0.001);
        assert_eq!(keep.reversed_clear(0.0, &observed), 1.0);
        let complementary = policy(Mode::Complementary, Observable::None);
        assert_eq!(complementary.reversed_clear(0.25, &observed), 0.75);
        assert_eq!(
            remove.reversing(&observed).reversal,
            Reversal::Infinite {
                near_over_far: 0.001
            }
        );
        assert_eq!(policy(Mode::Flip, Observable::None).rewrite(), None);
    }
}
